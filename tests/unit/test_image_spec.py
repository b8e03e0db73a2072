"""The ``[image]`` spec table: loading the shipped image, derived box and voxel, refusals,
the image RVE (resampling for the error bar), the Python API and the solver wiring."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

import psdesign
from psdesign.errors import SpecError
from psdesign.image.fields import ImageFields, resample
from psdesign.image.writer import write_tiff
from psdesign.packing.build import build_rve
from psdesign.schema.spec import load_spec, validate_spec

#: tests/data/README-puma.md: porosity of fibres_32 (ten rods, 32^3 voxels).
PUMA_POROSITY_32 = 0.96139
VOXEL_32 = 1e-4 / 32  # the unit cube scaled to 100 um


@pytest.fixture()
def img_dir(tmp_path, data_dir):
    shutil.copy(data_dir / "fibres_32.tif", tmp_path / "fibres_32.tif")
    return tmp_path


def write_spec(folder, body: str, name: str = "spec.toml"):
    p = folder / name
    p.write_text(body)
    return p


def test_shipped_tiff_spec_gives_the_peer_box_voxel_and_porosity(img_dir, data_dir) -> None:
    # relative path from the spec's folder, voxel size from the TIFF's ImageJ metadata
    sub = img_dir / "specs"
    sub.mkdir()
    spec = load_spec(write_spec(sub, '[image]\npath = "../fibres_32.tif"\n'))
    assert spec["rve"]["voxel"] == pytest.approx(VOXEL_32, rel=1e-12, abs=0)
    assert spec["rve"]["size"] == pytest.approx([1e-4] * 3, rel=1e-12, abs=0)
    assert spec["image"]["path"] == str((img_dir / "fibres_32.tif").resolve())
    assert spec["flow"]["wall_treatment"] == "staircase"
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    ref = np.load(data_dir / "fibres_32.npz")["solid"].astype(bool)
    assert isinstance(fields, ImageFields) and not fields.analytic_distance
    assert np.array_equal(fields.solid, ref)
    assert fields.porosity == pytest.approx(PUMA_POROSITY_32, abs=1e-5)  # README: 5 digits
    assert built.rve.fibers == [] and built.report["source"] == "image"
    # the validated spec validates again to itself (studies and the API re-validate)
    assert validate_spec(spec) == spec


def test_crop_threshold_and_axis_order(tmp_path) -> None:
    rng = np.random.default_rng(7)
    grey = rng.integers(0, 200, size=(12, 10, 8)).astype(np.uint8)  # [x, y, z]
    np.save(tmp_path / "g.npy", grey.transpose(2, 1, 0))  # stored z, y, x
    body = (
        '[image]\npath = "g.npy"\nvoxel_size = 2e-6\nthreshold = 120\naxis_order = "zyx"\n'
        "crop = [[2, 10], [1, 9], [0, 8]]\n"
    )
    spec = load_spec(write_spec(tmp_path, body))
    f = build_rve(spec).voxelize(2e-6)
    want = grey[2:10, 1:9, 0:8] >= 120
    assert f.grid.shape == (8, 8, 8) and np.array_equal(f.solid, want)
    assert spec["rve"]["size"] == pytest.approx([16e-6] * 3)


def test_signed_distance_is_metres_and_resample_keeps_porosity(img_dir) -> None:
    spec = load_spec(write_spec(img_dir, '[image]\npath = "fibres_32.tif"\n'))
    f = build_rve(spec).voxelize(spec["rve"]["voxel"])
    h = VOXEL_32
    # the surface lies half-way between solid and pore voxel centres
    assert f.distance[f.solid].max() == pytest.approx(-0.5 * h, rel=1e-6)
    assert f.distance[~f.solid].min() == pytest.approx(0.5 * h, rel=1e-6)
    for shape, ratio in (((16, 16, 16), 2.0), ((24, 24, 24), 4 / 3)):
        coarse = resample(f, shape)
        assert coarse.grid.shape == shape and np.allclose(coarse.grid.spacing, ratio * h, atol=0)
        # the solid volume is kept to one coarse voxel (the error bar's second resolution)
        assert abs(coarse.porosity - f.porosity) <= 0.5 / np.prod(shape) + 1e-12
        assert isinstance(coarse, ImageFields)
    # ImageRVE.voxelize: its own voxel gives the image itself, another one a resampling
    rve = build_rve(spec).rve
    assert rve.voxelize(h) is rve.image
    assert rve.voxelize(2 * h).grid.shape == (16, 16, 16)


@pytest.mark.parametrize(
    ("body", "key"),
    [
        ('path = "nope.tif"', "image.path"),
        ('path = "b.raw"\nvoxel_size = 1e-6\nshape = [4, 4, 5]', "image.shape"),
        ('path = "b.raw"\nvoxel_size = 1e-6\nshape = [4, 4, 4]\ndtype = "uint12"', "image.dtype"),
        ('path = "b.raw"\nvoxel_size = 1e-6', "image.shape"),
        ('path = "a.npy"\nvoxel_size = 1e-6\ncrop = [[0, 9], [0, 8], [0, 8]]', "image.crop[0]"),
        ('path = "a.npy"', "image.voxel_size"),
        ('path = "a.npy"\nvoxel_size = 1e-6\nsolid_label = [0, 5]', "image.solid_label"),
        ('path = "a.npy"\nvoxel_size = 1e-6\nsolid_label = 9', "image.solid_label"),
        ('path = "a.npy"\nvoxel_size = 1e-6\nthreshold = 9', "image.threshold"),
        ('path = "a.npy"\nvoxel_size = 1e-6\nthreshold = 1\nsolid_label = 5', "image.threshold"),
        ('path = "a.npy"\nvoxel_size = 1e-6\ndtype = "uint16"', "image.dtype"),
        ('path = "a.txt"\nvoxel_size = 1e-6', "image.format"),
        ('path = "a.npy"\nvoxel_size = 1e-6\naxis_order = "xxz"', "image.axis_order"),
    ],
)
def test_bad_image_tables_name_the_key(tmp_path, body, key) -> None:
    a = np.zeros((8, 8, 8), np.uint8)
    a[2:4] = 5
    np.save(tmp_path / "a.npy", a)
    (tmp_path / "a.txt").write_text("x")
    (tmp_path / "b.raw").write_bytes(bytes(64))
    with pytest.raises(SpecError) as exc:
        load_spec(write_spec(tmp_path, f"[image]\n{body}\n"))
    assert exc.value.key == key, str(exc.value)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize(
    ("extra", "key"),
    [
        ('[[fibers]]\nshape = "rod"\ndiameter = 2e-5\n', "fibers"),
        ("[generator]\nporosity = 0.9\ndiameter = 7e-6\n", "generator"),
        ("[rve]\nsize = [1e-4, 1e-4, 2e-4]\n", "rve.size[2]"),
        ("[rve]\nsize = [1e-4, 1e-4, 1e-4]\nvoxel = 1e-6\n", "rve.voxel"),
        ('[flow]\nwall_treatment = "subvoxel"\n', "flow.wall_treatment"),
    ],
)
def test_fiber_tables_and_inconsistent_tables_are_refused(img_dir, extra, key) -> None:
    p = write_spec(img_dir, f'[image]\npath = "fibres_32.tif"\n{extra}')
    with pytest.raises(SpecError) as exc:
        load_spec(p)
    assert exc.value.key == key, str(exc.value)


def test_consistent_rve_table_is_accepted(img_dir) -> None:
    body = '[image]\npath = "fibres_32.tif"\n[rve]\nsize = [1e-4, 1e-4, 1e-4]\n'
    assert load_spec(write_spec(img_dir, body))["rve"]["voxel"] == pytest.approx(VOXEL_32)


def test_from_image_api_and_voxel_route_on_a_crop(img_dir) -> None:
    m = psdesign.from_image(
        img_dir / "fibres_32.tif", solid_label=255, crop=[[0, 16], [0, 16], [0, 32]]
    )
    assert "image fibres_32.tif" in repr(m)
    assert m.rve.size == pytest.approx([0.5e-4, 0.5e-4, 1e-4])
    k = m.permeability("z", solver="voxel", bc="periodic", error_estimate=False)
    assert k.details["wall_treatment"] == "staircase"
    assert any("staircase" in w for w in k.details["warnings"])
    assert k.converged and k.permeability_m2 > 0
    # the same voxels written as .npy (stored [x, y, z]) give the same K
    np.save(img_dir / "crop.npy", m.fields.solid.astype(np.uint8))
    m2 = psdesign.from_image(img_dir / "crop.npy", voxel_size=VOXEL_32)
    k2 = m2.permeability("z", solver="voxel", bc="periodic", error_estimate=False)
    assert k2.permeability_m2 == pytest.approx(k.permeability_m2, rel=1e-12, abs=0)


def test_tiff_writer_labels_and_voxel_size_round_trip(tmp_path) -> None:
    from psdesign.image.reader import file_voxel_size

    solid = np.zeros((6, 5, 4), bool)
    solid[1:3, 2, :] = True
    write_tiff(solid, tmp_path / "s.tif", 0.7e-6)
    import tifffile

    data = tifffile.imread(tmp_path / "s.tif")
    assert data.dtype == np.uint8 and data.shape == (4, 5, 6)  # pages z, rows y, columns x
    assert set(np.unique(data)) == {0, 1}
    assert file_voxel_size(tmp_path / "s.tif") == pytest.approx(0.7e-6, rel=1e-9, abs=0)


def test_raw_spec_and_vti_voxel_size_from_the_file(tmp_path) -> None:
    import pyvista as pv

    rng = np.random.default_rng(3)
    solid = rng.random((6, 5, 4)) < 0.4
    solid.astype("<i2").transpose(2, 1, 0).tofile(tmp_path / "s.raw")  # x fastest
    body = (
        '[image]\npath = "s.raw"\nvoxel_size = 2e-6\nshape = [6, 5, 4]\ndtype = "int16"\n'
        "solid_label = 1\n"
    )
    spec = load_spec(write_spec(tmp_path, body))
    assert np.array_equal(build_rve(spec).voxelize(2e-6).solid, solid)
    img = pv.ImageData(dimensions=(6, 5, 4), spacing=(2.5e-6,) * 3)
    img.point_data["phase"] = solid.ravel(order="F").astype(np.uint8)
    img.save(str(tmp_path / "s.vti"))
    spec = load_spec(write_spec(tmp_path, '[image]\npath = "s.vti"\n', "v.toml"))
    assert spec["rve"]["voxel"] == pytest.approx(2.5e-6)
    assert spec["rve"]["size"] == pytest.approx([15e-6, 12.5e-6, 10e-6])


def test_a_vti_spacing_in_millimetres_is_warned_about(tmp_path) -> None:
    # session 43 (CT walk-through): a VTI's spacing has no unit and is read as metres; CT
    # software writes mm (3D Slicer) or um. A slit of 1 um voxels exported with spacing 1e-3
    # gave K = 1.4333e-05 m^2 [ok], 1e6 times the 1.4333e-11 of the same voxels, without a
    # word. A file voxel over 100 um is now warned about (naming image.voxel_size); 1 um is not.
    import warnings

    import pyvista as pv

    from psdesign.schema.image import ImageWarning

    solid = np.zeros((8, 8, 6), np.uint8)
    solid[:, :, :2] = 1
    for spacing, warned in ((1e-3, True), (1e-6, False)):
        img = pv.ImageData(dimensions=(9, 9, 7), spacing=(spacing,) * 3)
        img.cell_data["labels"] = solid.ravel(order="F")
        img.save(str(tmp_path / "s.vti"))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            spec = load_spec(write_spec(tmp_path, '[image]\npath = "s.vti"\n'))
        assert spec["rve"]["voxel"] == pytest.approx(spacing, rel=1e-12, abs=0)
        said = [str(w.message) for w in caught if issubclass(w.category, ImageWarning)]
        assert bool(said) == warned, said
        if warned:
            assert said[0].startswith("image.voxel_size: s.vti gives voxels of 0.001 m")
            assert "in mm or um, give image.voxel_size in metres" in said[0]
    with warnings.catch_warnings(record=True) as caught:  # the user's voxel_size: no guess
        warnings.simplefilter("always")
        load_spec(write_spec(tmp_path, '[image]\npath = "s.vti"\nvoxel_size = 1e-6\n'))
    assert not any("gives voxels" in str(w.message) for w in caught)


def test_voxel_size_key_wins_over_the_file_with_a_warning(img_dir) -> None:
    from psdesign.schema.image import ImageWarning

    body = '[image]\npath = "fibres_32.tif"\nvoxel_size = 1e-6\n'
    with pytest.warns(ImageWarning, match="image.voxel_size"):
        spec = load_spec(write_spec(img_dir, body))
    assert spec["rve"]["voxel"] == 1e-6 and spec["rve"]["size"] == pytest.approx([32e-6] * 3)


def test_huge_raw_image_is_refused_by_the_budget_without_reading_it(tmp_path, monkeypatch):
    # docs/images.md: an image over the memory budget is refused before any work, naming
    # image.crop. On main the schema read the whole raw file to learn its shape (25 GiB for
    # 3000^3 uint8) and a MemoryError came out as "spec: cannot validate (MemoryError):
    # nested too deeply or numbers too large". A sparse file: no disk is used.
    n = 3000
    big = tmp_path / "big.raw"
    with open(big, "wb") as f:
        f.truncate(n**3)

    def no_read(*args, **kwargs):
        raise AssertionError("the raw voxels were read")

    monkeypatch.setattr(np, "fromfile", no_read)
    with pytest.raises(SpecError) as info:
        psdesign.from_image(big, voxel_size=1e-6, shape=[n, n, n], dtype="uint8")
    assert info.value.key == "image.crop" and "GiB" in info.value.message
    assert "(allowed: a crop of at most" in info.value.message  # not a voxel size: it is fixed
    with pytest.raises(SpecError, match=r"image\.shape: .* bytes"):  # the size is still checked
        psdesign.from_image(big, voxel_size=1e-6, shape=[n, n, n + 1], dtype="uint8")


def test_a_2d_image_names_the_path_not_a_crop_nobody_gave(tmp_path):
    # a single 2-D slice (a common mistake: one TIFF page instead of the stack) was refused as
    # "image.crop: the image is [16, 16, 1] voxels" with no crop in the spec
    import tifffile

    page = np.zeros((16, 16), np.uint8)
    page[4:12, 4:12] = 1
    tifffile.imwrite(tmp_path / "slice.tif", page)
    with pytest.raises(SpecError) as info:
        psdesign.from_image(tmp_path / "slice.tif", voxel_size=1e-6)
    assert info.value.key == "image.path" and "2-D image" in info.value.message
    assert "at least 4 voxels per axis" in info.value.message
    with pytest.raises(SpecError, match=r"image\.crop: the image is \[16, 16, 1\]"):
        psdesign.from_image(
            tmp_path / "slice.tif", voxel_size=1e-6, crop=[[0, 16], [0, 16], [0, 1]]
        )


@pytest.mark.parametrize(
    "name, shape, kwargs, axes",
    [
        ("rgba.tif", (16, 16, 4), {"photometric": "rgb"}, "YXS"),  # a 2-D colour picture
        ("rgb_stack.tif", (6, 16, 16, 3), {"photometric": "rgb"}, "YXS"),
        ("channels.tif", (5, 2, 16, 16), {"imagej": True, "metadata": {"axes": "ZCYX"}}, "ZCYX"),
    ],
)
def test_a_colour_or_multichannel_tiff_is_refused_naming_the_path(
    tmp_path, name, shape, kwargs, axes
):
    # a 2-D RGBA picture was read as a 3-D image four voxels thick along x (its R, G, B and
    # alpha as slices) and solved, exit 0 (session 43's CT walk-through); a 5-channel ImageJ
    # image likewise with its channels as z slices. Both are one label image nobody gave. (A
    # C axis with no Z has its own refusal since session 52: a 2-channel z stack here.)
    import tifffile

    data = np.zeros(shape, np.uint8)
    data[..., 4:8, :] = 255
    tifffile.imwrite(tmp_path / name, data, **kwargs)
    spec = write_spec(tmp_path, f'[image]\npath = "{name}"\nvoxel_size = 1e-6\n')
    with pytest.raises(SpecError) as info:
        load_spec(spec)
    assert info.value.key == "image.path"
    assert "colour or multi-channel" in info.value.message and axes in info.value.message


@pytest.mark.parametrize("metadata", [{"unit": "um"}, {"axes": "CYX"}])
def test_a_stack_saved_as_imagej_channels_is_refused_with_the_cure(tmp_path, metadata):
    """Session 52 I/O review, finding 3: ``tifffile.imwrite(p, vol_zyx, imagej=True)`` without
    ``metadata={'axes': 'ZYX'}`` stores the 20 z planes as ImageJ channels (axes CYX); the
    refusal said "colour or multi-channel ... (Fiji: Image > Type > 8-bit)", advice that does
    not help. A grey image whose only extra axis is C (no Z, no T) is refused naming what
    happened and the cure; the same array written with the axes loads (porosity 2/3)."""
    import tifffile

    vol = np.zeros((20, 12, 16), np.uint8)  # z, y, x
    vol[:, :4] = 255
    tifffile.imwrite(tmp_path / "c.tif", vol, imagej=True, metadata=metadata)
    tifffile.imwrite(tmp_path / "z.tif", vol, imagej=True, metadata={"axes": "ZYX"})
    with pytest.raises(SpecError) as info:
        load_spec(write_spec(tmp_path, '[image]\npath = "c.tif"\nvoxel_size = 1e-6\n'))
    assert info.value.key == "image.path" and "\n" not in info.value.message
    for words in ("20 planes as ImageJ channels", "axes CYX", "allowed: a single-channel"):
        assert words in info.value.message
    assert "metadata={'axes': 'ZYX'}" in info.value.message
    spec = load_spec(write_spec(tmp_path, '[image]\npath = "z.tif"\nvoxel_size = 1e-6\n'))
    assert spec["rve"]["size"] == pytest.approx([16e-6, 12e-6, 20e-6], rel=1e-12, abs=0)
    assert build_rve(spec).voxelize(1e-6).porosity == pytest.approx(2 / 3, rel=1e-12, abs=0)


def test_a_slice_folder_of_channel_files_gets_the_multichannel_refusal(tmp_path):
    """Review B (session 52): the channels-as-z cure above ("write it with metadata={'axes':
    'ZYX'}") also fired for each file of a slice folder, where following it only meets the
    one-slice-per-file refusal. A folder's 2-channel files keep the general multi-channel
    refusal, naming the file and its channels."""
    import tifffile

    (tmp_path / "s").mkdir()
    for k in range(6):
        plane = np.zeros((2, 12, 16), np.uint8)
        plane[:, :4] = 255
        tifffile.imwrite(tmp_path / "s" / f"s_{k:02d}.tif", plane, imagej=True)
    with pytest.raises(SpecError) as info:
        load_spec(write_spec(tmp_path, '[image]\npath = "s"\nvoxel_size = 1e-6\n'))
    assert info.value.key == "image.path" and "\n" not in info.value.message
    assert "colour or multi-channel" in info.value.message and "2 channels" in info.value.message
    assert "ImageJ channels" not in info.value.message


@pytest.mark.parametrize("given", ["slices", "slices/slice_*.tif"])
def test_a_folder_of_slices_reads_as_the_stack_of_its_slices(tmp_path, given):
    # one TIFF per z slice is a usual CT export; until session 44 a folder or pattern was
    # refused with a recipe to stack the slices (tifffile.imread of the sorted names). Now it
    # is read, and gives the voxels of that stack (tests/cli/test_cli_image_slices.py has
    # the rest: order, refusals, crops).
    import glob

    import tifffile

    (tmp_path / "slices").mkdir()
    for k in range(6):
        page = np.zeros((8, 8), np.uint8)
        page[:, : 2 + k % 3] = 255
        tifffile.imwrite(tmp_path / "slices" / f"slice_{k:03d}.tif", page)
    spec = write_spec(tmp_path, f'[image]\npath = "{given}"\nvoxel_size = 1e-6\n')
    m = psdesign.build(spec)
    files = sorted(glob.glob(str(tmp_path / "slices" / "*.tif")))  # zero-padded: sorted is right
    tifffile.imwrite(tmp_path / "stack.tif", tifffile.imread(files))
    stacked = psdesign.from_image(tmp_path / "stack.tif", voxel_size=1e-6)
    assert m.spec["rve"]["size"] == pytest.approx([8e-6, 8e-6, 6e-6], rel=1e-12, abs=0)
    assert np.array_equal(m.fields.solid, stacked.fields.solid)
    assert m.porosity == pytest.approx(1 - 3 / 8, rel=1e-12, abs=0)


@pytest.mark.parametrize(
    "unit, voxel",
    [
        ("micron", 0.5e-6),
        ("microns", 0.5e-6),
        ("UM", 0.5e-6),
        ("\\u00B5m", 0.5e-6),
        ("mm", 0.5e-3),
        ("micrometers", 0.5e-6),  # review2: the plurals of the words read as "no voxel size"
        ("Millimeters", 0.5e-3),
    ],
)
def test_imagej_unit_spellings_give_the_voxel_size(tmp_path, unit, voxel):
    # session 43: "microns" (a writer's plural) and "UM" read as "carries no voxel size"; the
    # lookup is now in lower case with the usual spellings (ImageJ's own "micron" and its
    # escaped micro sign as before). 0.5 units per pixel in x, y and z.
    import tifffile

    data = np.zeros((8, 8, 8), np.uint8)
    data[:, :, :3] = 255
    meta = {"unit": unit, "spacing": 0.5, "axes": "ZYX"}
    tifffile.imwrite(tmp_path / "s.tif", data, imagej=True, resolution=(2.0, 2.0), metadata=meta)
    m = psdesign.from_image(tmp_path / "s.tif")
    assert m.spec["rve"]["voxel"] == pytest.approx(voxel, rel=1e-12, abs=0)


def _imagej_tiff(path, n: int, resolution: tuple[float, float], spacing: float):
    """An ``n``^3 ImageJ TIFF in um (``resolution`` pixels per um in x, y; ``spacing`` um in z),
    solid in its first three x-planes (the last axis of ZYX)."""
    import tifffile

    data = np.zeros((n, n, n), np.uint8)
    data[:, :, :3] = 255
    meta = {"unit": "um", "spacing": spacing, "axes": "ZYX"}
    tifffile.imwrite(path, data, imagej=True, resolution=resolution, metadata=meta)
    return path


def test_an_imagej_resolution_reads_as_the_decimal_the_file_means(tmp_path):
    """Session 51: 0.8 pixels per um is a 1.25 um voxel, but ``1 / 0.8 * 1e-6`` is the float
    1.2499999999999999e-06, which rve.json and summary.json printed (the box of 8 voxels
    9.999999999999999e-06 m). The conversion now keeps 15 significant digits: 1.25e-06 and
    1e-05 exactly as the decimals read (truth: 8 x 1.25 um = 10 um)."""
    from psdesign.image.reader import file_voxel_size

    _imagej_tiff(tmp_path / "s.tif", 8, (0.8, 0.8), 1.25)
    assert 1 / 0.8 * 1e-6 != 1.25e-6  # the float product the old code kept
    assert file_voxel_size(tmp_path / "s.tif") == 1.25e-6
    m = psdesign.from_image(tmp_path / "s.tif")
    assert repr(m.spec["rve"]["voxel"]) == "1.25e-06"
    assert [repr(x) for x in m.spec["rve"]["size"]] == ["1e-05"] * 3


def test_an_imagej_images_box_reads_as_the_decimal_n_voxels_make(tmp_path):
    """Review s51: the voxel was rounded (above) but not the box: 12 voxels of 1.25 um are
    15 um, and ``12 * 1.25e-6`` is the float 1.5000000000000002e-05, which the spec,
    rve.json's ``size_m`` and summary.json's grid printed (8 voxels are exact by luck). The
    box is rounded as the voxel (``geometry.rve.in_metres``) and still holds exactly 12 cubic voxels
    (the grid rule, ``VoxelGrid.from_voxel`` / ``is_cubic``, within 1e-9). Truth: 12 x 1.25 um
    = 15 um."""
    from psdesign.geometry.rve import VoxelGrid, is_cubic

    _imagej_tiff(tmp_path / "s.tif", 12, (0.8, 0.8), 1.25)
    assert 12 * 1.25e-6 != 1.5e-5  # the float product the old code kept
    m = psdesign.from_image(tmp_path / "s.tif")
    assert repr(m.spec["rve"]["voxel"]) == "1.25e-06"
    for size in (m.spec["rve"]["size"], m.rve.size, m.fields.grid.size):  # spec, rve.json, grid
        assert [repr(float(x)) for x in size] == ["1.5e-05"] * 3
    grid = VoxelGrid.from_voxel(m.rve.size, m.spec["rve"]["voxel"])
    assert grid.shape == (12, 12, 12) and is_cubic([*grid.spacing, 1.25e-6])


def test_an_unknown_imagej_unit_is_named_in_the_refusal(tmp_path):
    # a calibrated file in a unit psdesign does not read was refused as "carries no voxel
    # size", as an uncalibrated one: now the line names the unit and the ones it reads
    import tifffile

    data = np.zeros((8, 8, 8), np.uint8)
    data[:, :, :3] = 255
    for unit in ("furlong", "inch", "ms"):  # inch: ImageJ's unit of a 72-dpi picture, 0.35 mm
        meta = {"unit": unit, "spacing": 1 / 72, "axes": "ZYX"}
        res = (72.0, 72.0)
        tifffile.imwrite(tmp_path / "s.tif", data, imagej=True, resolution=res, metadata=meta)
        with pytest.raises(SpecError) as info:
            psdesign.from_image(tmp_path / "s.tif")
        assert info.value.key == "image.voxel_size" and f"'{unit}'" in info.value.message
    assert psdesign.from_image(tmp_path / "s.tif", voxel_size=1e-6).spec["rve"]["voxel"] == 1e-6


def test_a_tiff_with_other_x_and_y_pixel_sizes_is_refused(tmp_path):
    """ImageJ calibrates x and y by their own resolution tags; only x was read, so 0.5 x 1 um
    pixels were taken as 0.5 um cubes (the box 4 x 8 um read as 4 x 4 um, K of another
    material, exit 0). The docstring said x, y and z must agree; now y is checked too
    (review2). Old code: voxel 5e-07."""
    _imagej_tiff(tmp_path / "s.tif", 8, (2.0, 1.0), 0.5)
    with pytest.raises(SpecError) as info:
        psdesign.from_image(tmp_path / "s.tif")
    assert info.value.key == "image.voxel_size"
    assert "not cubic (x 5e-07 m, y 1e-06 m, z 5e-07 m)" in info.value.message
    # the allowed range, as every refusal's line gives it (session 50's walk: none; a
    # voxel_size given beside such a file is refused the same way)
    assert info.value.message.endswith("(allowed: cubic voxels, x = y = z to 1 part in 1e6)")
    with pytest.raises(SpecError) as info:
        psdesign.from_image(tmp_path / "s.tif", voxel_size=5e-7)
    assert info.value.message.endswith("(allowed: cubic voxels, x = y = z to 1 part in 1e6)")


def test_vti_extent_from_the_header_and_a_vector_array_named(tmp_path, monkeypatch):
    # a VTI image was read whole (twice) to learn its extent and voxel size, so the memory
    # budget came after the read; a field file (first array a velocity) gave
    # "image.cannot reshape array of size 24000 into shape (20,20,20)"
    import pyvista as pv

    grid = pv.ImageData(dimensions=(6, 6, 6), spacing=(1e-6, 1e-6, 1e-6))
    labels = np.zeros(125, np.uint8)
    labels[:40] = 1
    grid.cell_data["solid"] = labels
    small = tmp_path / "small.vti"
    grid.save(small, binary=False)
    text = small.read_text().replace('"0 5 0 5 0 5"', '"0 3000 0 3000 0 3000"')
    (tmp_path / "huge.vti").write_text(text)  # the header says 3000^3 cells; the data do not
    monkeypatch.setattr(pv, "read", lambda *a, **k: pytest.fail("the voxels were read"))
    with pytest.raises(SpecError) as info:
        psdesign.from_image(tmp_path / "huge.vti")
    assert info.value.key == "image.crop" and "3000x3000x3000" in info.value.message
    monkeypatch.undo()
    m = psdesign.from_image(small)  # voxel size from the spacing, one label array
    assert m.spec["rve"]["voxel"] == pytest.approx(1e-6, rel=1e-12) and m.porosity == pytest.approx(
        85 / 125, rel=1e-12
    )
    grid.cell_data.clear()
    grid.cell_data["velocity"] = np.ones((125, 3))
    grid.cell_data["solid"] = labels
    grid.save(tmp_path / "field.vti")
    with pytest.raises(SpecError, match=r"image\.path: the first array .*'velocity', has 3 comp"):
        psdesign.from_image(tmp_path / "field.vti")


def test_out_of_memory_while_reading_an_image_names_image_path(monkeypatch):
    """audit s32: a compressed TIFF is read whole; running out of memory there said "spec:
    cannot validate (MemoryError): nested too deeply or numbers too large"."""
    from psdesign.schema import spec as spec_mod

    def oom(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(spec_mod.SpecDocument, "model_validate", oom)
    with pytest.raises(SpecError) as info:
        spec_mod.validate_document({"image": {"path": "scan.tif"}})
    assert info.value.key == "image.path" and "image.crop" in info.value.message
    assert "nested" not in info.value.message


def test_a_flat_array_and_a_raw_file_of_another_size_give_the_allowed_range(tmp_path):
    """Session 50 (walk): a 2-D .npy ("image.path: expected a 3-D image, got shape [16, 16]")
    and a raw file whose bytes are not shape x dtype ended without "(allowed: ...)", the tail
    of every other refusal's line."""
    np.save(tmp_path / "flat.npy", np.zeros((16, 16), np.uint8))
    with pytest.raises(SpecError) as info:
        psdesign.from_image(tmp_path / "flat.npy", voxel_size=1e-6)
    assert info.value.key == "image.path"
    assert info.value.message.endswith("(allowed: a 3-D image, at least 4 voxels per axis)")
    np.zeros(1000, np.uint8).tofile(tmp_path / "x.raw")
    with pytest.raises(SpecError) as info:
        psdesign.from_image(tmp_path / "x.raw", voxel_size=1e-6, shape=[10, 10, 11])
    assert info.value.key == "image.shape"
    assert info.value.message.endswith(
        "(allowed: [nx, ny, nz] with nx ny nz x 1 bytes = the file's 1000 bytes)"
    ), info.value.message


def test_a_vti_a_percent_off_cubic_is_refused(tmp_path) -> None:
    """Session 50's review: the .vti check ``np.allclose(h, h[0], rtol=1e-6)`` kept numpy's
    ``atol=1e-8`` m, 1 % of a 1 um voxel: spacing (1, 1, 1.009) um was read as cubic 1 um and
    solved, against the refusal's own "x = y = z to 1 part in 1e6"."""
    import pyvista as pv

    solid = np.random.default_rng(3).random((6, 5, 4)) < 0.4
    img = pv.ImageData(dimensions=(6, 5, 4), spacing=(1e-6, 1e-6, 1.009e-6))
    img.point_data["phase"] = solid.ravel(order="F").astype(np.uint8)
    img.save(str(tmp_path / "s.vti"))
    with pytest.raises(SpecError) as info:
        load_spec(write_spec(tmp_path, '[image]\npath = "s.vti"\n'))
    assert info.value.key == "image.voxel_size" and "not cubic" in info.value.message


def test_every_route_refuses_a_grid_a_percent_off_cubic() -> None:
    """Session 50's second review: after the .vti mend, five more places checked cubic voxels
    with numpy's ``atol=1e-8`` m (1 % of a 1 um voxel); ``psdesign.flow.voxel._cubic_voxel``
    read a (1, 1, 1.009) um grid of hand-built fields as cubic 1 um. Now one rule,
    ``psdesign.geometry.rve.is_cubic``, in every route: the voxel route refuses it."""
    from types import SimpleNamespace

    from psdesign.flow.voxel import _cubic_voxel

    grid = SimpleNamespace(grid=SimpleNamespace(spacing=np.array([1e-6, 1e-6, 1.009e-6])))
    with pytest.raises(ValueError, match="cubic voxels"):
        _cubic_voxel(grid)
    grid.grid.spacing = np.array([1e-6, 1e-6, 1e-6 * (1 + 1e-12)])  # a rounding: cubic
    assert _cubic_voxel(grid) == 1e-6


@pytest.mark.parametrize(
    "direction",
    [[[0, 1, 0], [1, 0, 0], [0, 0, 1]], [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]],
    ids=["x-y swapped", "x flipped"],
)
def test_a_vti_with_a_direction_other_than_the_identity_is_refused(tmp_path, direction) -> None:
    """Session 52 I/O review, finding 2: the .vti reader took spacing and extent only, so an
    image whose Direction matrix swaps x and y (plates normal to world x stored normal to j)
    was solved in the stored frame: K_x of plates normal to x reported ``ok``, exit 0. A
    rotated or flipped image is refused (``image.path``, naming what is allowed), before any
    voxel is read; the same file with the identity direction still loads (8 of 16 x-layers
    solid: porosity 0.5 exactly)."""
    import pyvista as pv

    from psdesign.image.reader import ImageSource, read_labels

    solid = np.zeros((16, 12, 20), dtype=np.uint8)
    solid[::2] = 1
    for name, d in (("ok.vti", np.eye(3)), ("turned.vti", np.asarray(direction, float))):
        img = pv.ImageData(dimensions=solid.shape, spacing=(1e-6,) * 3)
        img.direction_matrix = d
        img.point_data["phase"] = solid.ravel(order="F")
        img.save(str(tmp_path / name))
    spec = load_spec(write_spec(tmp_path, '[image]\npath = "ok.vti"\n'))
    assert spec["rve"]["size"] == pytest.approx([16e-6, 12e-6, 20e-6], rel=1e-12, abs=0)
    assert build_rve(spec).voxelize(spec["rve"]["voxel"]).porosity == 0.5
    with pytest.raises(SpecError) as info:
        load_spec(write_spec(tmp_path, '[image]\npath = "turned.vti"\n'))
    assert info.value.key == "image.path"
    assert "not the identity" in info.value.message and "allowed: the identity" in str(info.value)
    with pytest.raises(ValueError, match="image.path: turned.vti has the Direction matrix"):
        read_labels(ImageSource(path=tmp_path / "turned.vti", voxel=1e-6))
