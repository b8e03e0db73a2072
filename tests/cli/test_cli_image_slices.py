"""A CT scan exported as one 2-D TIFF per slice (``[image] path = "slices/"`` or
``"slices/*.tif"``, :mod:`psdesign.image.slices`): the same voxels, numbers and files as the
same volume in one multi-page TIFF, natural order, refusals (exit 2, one line, nothing
written), the voxel-size rule, crops reading only their slices, the memory budget, studies.

Until session 44 a folder or pattern was refused (``image.path``) with a recipe to stack the
slices; every test here fails on that code (each run of a folder exits 2)."""

from __future__ import annotations

import json
import random
import re
import shutil
import warnings

import numpy as np
import pytest
import tifffile

import psdesign
from psdesign.cli.main import main
from psdesign.errors import SpecError

#: Plane Poiseuille flow between periodic plates (the slit of tests/cli/test_cli_image.py):
#: gap h = 16 um, period H = 24 um along z, 1 um voxels; along the plates the superficial
#: K = h^3 / (12 H) = 1.4222e-11 m^2 (mean gap velocity h^2 G / (12 mu) times h / H); the
#: MAC grid's second-order error at 16 cells across the gap gives 1.43333e-11 (+0.78 %).
SLIT_K = (16e-6) ** 3 / (12 * 24e-6)
SLIT_K_MAC = 1.43333e-11
IMAGEJ_UM = {"imagej": True, "resolution": (1.0, 1.0), "metadata": {"unit": "um"}}
NO_BAR = "[flow]\nerror_estimate = false\n"


def slit() -> np.ndarray:
    """The slit stored ``zyx`` (24 slices of 16 x 16): plates normal to z, 255 = solid."""
    plates = np.zeros((24, 16, 16), np.uint8)
    plates[:4] = plates[20:] = 255
    return plates


def write_slices(folder, stack, name="s{k}.tif", order=None, **kw) -> None:
    """``stack[k]`` as ``folder / name.format(k=k)``, written in ``order`` (default k)."""
    folder.mkdir(parents=True, exist_ok=True)
    for k in order if order is not None else range(len(stack)):
        tifffile.imwrite(folder / name.format(k=k), stack[k], **{**IMAGEJ_UM, **kw})


def write_stack(path, stack) -> None:
    """``stack`` as one multi-page ImageJ TIFF, pages z (the truth the slices must match)."""
    meta = {"unit": "um", "axes": "ZYX"}
    tifffile.imwrite(path, stack, imagej=True, resolution=(1.0, 1.0), metadata=meta)


def spec(folder, path: str, extra: str = "", name: str = "spec.toml"):
    p = folder / name
    p.write_text(f'[image]\npath = "{path}"\nsolid_label = 255\n{extra}')
    return p


def run_json(capsys, *args) -> dict:
    assert main([*args, "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    out.pop("wall_time_s", None)  # the only number that may differ between two runs
    out.get("error_estimate", {}).pop("wall_time_s", None)
    return out


def test_slices_give_the_stack_byte_for_byte_and_the_slit_k(tmp_path, capsys) -> None:
    """The slit as one multi-page TIFF and as 24 slices named s0 ... s23 (no zero padding:
    ``sorted()`` reads s0, s1, s10, ..., s19, s2, s20, ..., which splits the gap into two
    slits of 10 and 6 um), written in a shuffled order: the same mask, the same K JSON and
    byte-identical field files; K is the closed form within its bar. A folder and a pattern
    alike."""
    stack = slit()
    write_stack(tmp_path / "stack.tif", stack)
    order = list(range(24))
    random.Random(4).shuffle(order)
    write_slices(tmp_path / "slices", stack, order=order)
    outs = {}
    for label, path in [("stack", "stack.tif"), ("folder", "slices"), ("glob", "slices/s*.tif")]:
        p = spec(tmp_path, path, NO_BAR, f"{label}.toml")
        args = ["permeability", str(p), "--solver", "voxel", "--direction", "x"]
        outs[label] = run_json(capsys, *args, "--fields", str(tmp_path / f"f_{label}"))
    assert outs["folder"] == outs["stack"] == outs["glob"]
    k = outs["folder"]
    assert k["status"] == "ok" and k["porosity"] == pytest.approx(16 / 24, rel=1e-12, abs=0)
    assert abs(k["permeability_m2"] / SLIT_K - 1) <= k["permeability_rel_error"]
    assert k["permeability_m2"] == pytest.approx(SLIT_K_MAC, rel=1e-4, abs=0)
    files = sorted(f.name for f in (tmp_path / "f_stack").iterdir())
    assert files and files == sorted(f.name for f in (tmp_path / "f_folder").iterdir())
    for f in files:
        want = (tmp_path / "f_stack" / f).read_bytes()
        assert (tmp_path / "f_folder" / f).read_bytes() == want, f
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = psdesign.from_image(tmp_path / "slices", solid_label=255)
        truth = psdesign.from_image(tmp_path / "stack.tif", solid_label=255)
    assert np.array_equal(m.fields.solid, truth.fields.solid)
    assert "slices" in m._repr_html_() and "image slices" in repr(m)  # the notebook's view


def test_other_commands_and_generate_outputs_are_the_stacks(tmp_path, capsys) -> None:
    """pores, diffusivity and conductivity print the stack's numbers for the folder;
    ``generate`` writes the same files twice (reproducible) and the stack's voxels, its
    summary naming the folder as ``image.path``; ``mesh`` writes the stack's mesh files."""
    stack = slit()
    write_stack(tmp_path / "stack.tif", stack)
    write_slices(tmp_path / "slices", stack, name="recon_{k:04d}.tif")
    one = spec(tmp_path, "stack.tif", '[transport]\nerror_estimate = "residual"\n', "a.toml")
    many = spec(tmp_path, "slices", '[transport]\nerror_estimate = "residual"\n', "b.toml")
    # pores along the plates (x): across them (z) no intrusion path crosses, exit 3 since s53
    pores = ["pores", "--axis", "x"]
    for cmd in (pores, ["diffusivity", "--direction", "x"], ["conductivity", "--solid", "10"]):
        assert run_json(capsys, cmd[0], str(many), *cmd[1:]) == run_json(
            capsys, cmd[0], str(one), *cmd[1:]
        ), cmd[0]
    for out in ("g1", "g2"):
        assert main(["generate", str(many), "-o", str(tmp_path / out), "--no-preview"]) == 0
    assert main(["generate", str(one), "-o", str(tmp_path / "g0"), "--no-preview"]) == 0
    for f in ("rve.json", "field.vti", "summary.json"):
        assert (tmp_path / "g1" / f).read_bytes() == (tmp_path / "g2" / f).read_bytes(), f
    assert (tmp_path / "g1/field.vti").read_bytes() == (tmp_path / "g0/field.vti").read_bytes()
    summary = json.loads((tmp_path / "g1" / "summary.json").read_text())
    assert summary["generation"]["path"] == str(tmp_path / "slices")
    flow_x = '[flow]\ndirection = "x"\n'  # along the plates: z has no pore path
    for name, path in (("m0", "stack.tif"), ("m1", "slices")):
        mesh_spec = spec(tmp_path, path, flow_x, f"{name}.toml")
        assert main(["mesh", str(mesh_spec), "-o", str(tmp_path / name), "--quiet"]) == 0
    for f in ("mesh.json", "pore.vtu", "pore_boundary.vtu"):
        assert (tmp_path / "m1" / f).read_bytes() == (tmp_path / "m0" / f).read_bytes(), f


def _bad(folder, case: str) -> str:
    """Write the slices of a refusal ``case`` into ``folder``; return the path to give."""
    page = np.zeros((16, 16), np.uint8)
    page[:4] = 255
    n = 3 if case == "three slices" else 8
    write_slices(folder, [page] * n, name="s{k:03d}.tif")
    if case == "no tiff":
        for f in folder.iterdir():
            f.rename(f.with_suffix(".png"))
    elif case == "other shape":
        tifffile.imwrite(folder / "s005.tif", np.zeros((16, 12), np.uint8), **IMAGEJ_UM)
    elif case == "other dtype":
        tifffile.imwrite(folder / "s005.tif", page.astype(np.uint16), **IMAGEJ_UM)
    elif case == "colour":
        tifffile.imwrite(folder / "s005.tif", np.zeros((16, 16, 3), np.uint8), photometric="rgb")
    elif case == "multi-page":
        tifffile.imwrite(folder / "s005.tif", np.stack([page, page]))  # 2 pages, no ImageJ
    elif case == "gap":
        (folder / "s005.tif").unlink()
    elif case == "duplicate":
        shutil.copy(folder / "s005.tif", folder / "s5.tiff")
    elif case == "no number":
        shutil.copy(folder / "s005.tif", folder / "preview.tif")
    elif case == "two scans":
        shutil.copy(folder / "s005.tif", folder / "t008.tif")
    elif case == "complex":  # every slice complex: one type, so only check_numeric refuses
        for k in range(n):
            tifffile.imwrite(folder / f"s{k:03d}.tif", page.astype(np.complex64))
    elif case == "calibration":
        tifffile.imwrite(folder / "s005.tif", page, **{**IMAGEJ_UM, "resolution": (2.0, 2.0)})
    return {"no match": "slices/x_*.tif"}.get(case, "slices")


@pytest.mark.parametrize(
    ("case", "words"),
    [
        ("no tiff", "no .tif / .tiff file in the folder"),
        ("no match", "no .tif / .tiff file matches"),
        ("three slices", "3 slices (allowed: at least 4"),
        ("other shape", "s005.tif is [16, 12] (rows, columns) uint8, s000.tif is [16, 16] uint8"),
        ("other dtype", "s005.tif is [16, 16] (rows, columns) uint16, s000.tif is [16, 16] uint8"),
        ("colour", "s005.tif is a colour or multi-channel image"),
        ("multi-page", "s005.tif holds 2 pages"),
        ("gap", "slice number 5 is missing (between s004.tif and s006.tif)"),
        ("duplicate", "s005.tif and s5.tiff both have slice number 5"),
        ("no number", "preview.tif has no slice number"),
        ("two scans", "are named by two patterns"),
        ("calibration", "s005.tif has pixels of 0.5 x 0.5 um, s000.tif of 1 x 1 um"),
        ("complex", "s000.tif holds elements of type complex64, not numbers (allowed: bool, "),
    ],
)
@pytest.mark.parametrize("command", ["permeability", "generate"])
def test_bad_slices_exit_2_one_line_naming_image_path(tmp_path, capsys, case, words, command):
    """Each problem of a slice folder, before any work: exit 2, one line naming
    ``image.path`` and the file at fault, no output folder."""
    path = _bad(tmp_path / "slices", case)
    out = tmp_path / "out"
    args = [command, str(spec(tmp_path, path))] + (
        ["-o", str(out)] if command == "generate" else []
    )
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("psdesign: error: image.path:") and "\n" not in err, err
    assert words in err, err
    assert not out.exists()


def test_a_folder_with_another_format_names_image_format(tmp_path, capsys) -> None:
    """A folder or pattern is read as TIFF slices: ``format = "raw"`` beside it is the key at
    fault (exit 2, one line)."""
    write_slices(tmp_path / "slices", slit())
    args = ["permeability", str(spec(tmp_path, "slices", 'format = "raw"\n'))]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("psdesign: error: image.format: raw: a folder or pattern is read as")
    assert "\n" not in err


def test_checks_read_headers_only(tmp_path, monkeypatch) -> None:
    """A gap in the numbering is refused before any pixel is read (the checks read the
    headers), and a good folder's extent comes from its headers alone."""
    from psdesign.image import load, slices

    _bad(tmp_path / "slices", "gap")

    def no_pixels(*args, **kwargs):
        raise AssertionError("a slice's pixels were read")

    monkeypatch.setattr(slices, "_slice_array", no_pixels)
    with pytest.raises(SpecError, match="slice number 5 is missing"):
        psdesign.from_image(tmp_path / "slices", voxel_size=1e-6)
    write_slices(tmp_path / "good", [np.zeros((16, 16), np.uint8)] * 5)
    src = load.source_of({"path": str(tmp_path / "good"), "format": "tif"}, voxel=1e-6)
    assert load.header_shape(src) == (16, 16, 5)


def test_voxel_size_from_the_first_slice_z_taken_equal_with_a_note(tmp_path) -> None:
    """Slices calibrated 0.5 um per pixel (ImageJ unit and X/Y resolution) give 0.5 um voxels;
    a slice stores no z spacing, so z is taken equal to x and y, and a warning says so. With
    ``voxel_size`` given nothing is assumed (no warning); uncalibrated slices without it, and
    slices of 0.5 x 1 um pixels, are refused naming ``image.voxel_size``."""
    page = np.zeros((16, 16), np.uint8)
    page[:, :6] = 255
    write_slices(tmp_path / "cal", [page] * 6, resolution=(2.0, 2.0))
    with pytest.warns(UserWarning, match=r"no z spacing, so z is taken equal to x and y") as rec:
        m = psdesign.from_image(tmp_path / "cal", solid_label=255)
    assert len(rec) == 1
    assert m.spec["rve"]["voxel"] == pytest.approx(0.5e-6, rel=1e-12, abs=0)
    assert m.spec["rve"]["size"] == pytest.approx([8e-6, 8e-6, 3e-6], rel=1e-12, abs=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        psdesign.from_image(tmp_path / "cal", solid_label=255, voxel_size=0.5e-6)
    (tmp_path / "raw").mkdir()
    for k in range(6):
        tifffile.imwrite(tmp_path / "raw" / f"s{k}.tif", page)
    with pytest.raises(SpecError) as info:
        psdesign.from_image(tmp_path / "raw", solid_label=255)
    assert (
        info.value.key == "image.voxel_size"
        and "raw (first slice s0.tif) carries no voxel size" in str(info.value)
    )
    assert psdesign.from_image(tmp_path / "raw", voxel_size=1e-6).porosity == 10 / 16
    write_slices(tmp_path / "oblong", [page] * 6, resolution=(2.0, 1.0))  # 0.5 x 1 um pixels
    with pytest.raises(SpecError) as info:
        psdesign.from_image(tmp_path / "oblong", solid_label=255)
    assert info.value.key == "image.voxel_size" and "not cubic (x 5e-07 m, y 1e-06 m" in str(
        info.value
    )


@pytest.mark.parametrize("compression", [None, "zlib"])
def test_a_crop_reads_only_its_slices_rows_and_columns(tmp_path, monkeypatch, compression):
    """A crop of 4 of 12 slices decodes (or memory-maps) only those 4 files, and the labels
    are the crop of the whole stack (the truth, read by NumPy), for each axis order; the
    array read is the crop's size."""
    from psdesign.image import slices
    from psdesign.image.reader import ImageSource, read_labels

    rng = np.random.default_rng(0)
    stored = rng.integers(0, 3, size=(12, 9, 7), dtype=np.uint8)
    write_slices(tmp_path / "sl", stored, name="r_{k:02d}.tif", compression=compression)
    read = []
    real = slices._slice_array
    monkeypatch.setattr(slices, "_slice_array", lambda p: read.append(p.name) or real(p))
    crop = ((2, 6), (1, 5), (3, 7))
    for order in ("zyx", "xyz", "yxz"):
        read.clear()
        truth = stored.transpose([order.index(a) for a in "xyz"])[2:6, 1:5, 3:7]
        src = ImageSource(tmp_path / "sl", 1e-6, solid=1, crop=crop, axis_order=order)
        np.testing.assert_array_equal(read_labels(src), truth)
        page_axis = "xyz".index(order[0])
        lo, hi = crop[page_axis]
        assert read == [f"r_{k:02d}.tif" for k in range(lo, hi)], order


def test_the_memory_budget_refuses_a_folder_naming_the_crop(tmp_path, monkeypatch) -> None:
    """As for a stack: an image over the budget is refused (``image.crop``) from the headers,
    without a pixel read; a crop inside it is accepted."""
    from psdesign.image import slices
    from psdesign.schema import budget

    page = np.zeros((64, 64), np.uint8)
    page[:, :20] = 1
    write_slices(tmp_path / "sl", [page] * 64, name="s{k:02d}.tif")
    # a budget of 1 MB: the voxel solver's 64^3 grid needs 34.6 MB, an 8^3 crop 68 kB
    monkeypatch.setattr(budget, "machine_memory", lambda: 2e6)
    real = slices._slice_array
    monkeypatch.setattr(slices, "_slice_array", lambda p: pytest.fail("pixels read"))
    with pytest.raises(SpecError) as info:
        psdesign.from_image(tmp_path / "sl", voxel_size=1e-6, flow={"solver": "voxel"})
    assert info.value.key == "image.crop" and "64x64x64" in str(info.value)
    monkeypatch.setattr(slices, "_slice_array", real)
    m = psdesign.from_image(
        tmp_path / "sl", voxel_size=1e-6, crop=[[16, 24], [0, 8], [0, 8]], flow={"solver": "voxel"}
    )
    assert m.fields.grid.shape == (8, 8, 8) and m.porosity == 0.5


def test_generate_never_writes_a_slice_into_the_spec_folder(tmp_path, capsys) -> None:
    """``generate --format tiff --force`` into the slice folder would add rve.tif, read as one
    more slice next time: refused, naming ``-o``; the folder is unchanged."""
    write_slices(tmp_path / "slices", slit(), name="s{k:02d}.tif")
    before = sorted(p.name for p in (tmp_path / "slices").iterdir())
    img = spec(tmp_path, "slices", "voxel_size = 1e-6\n")
    args = ["generate", str(img), "-o", str(tmp_path / "slices")]
    assert main([*args, "--format", "tiff", "--force", "--no-preview"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("psdesign: error: -o:") and "\n" not in err
    assert "rve.tif would be one more slice of this spec's image" in err
    assert sorted(p.name for p in (tmp_path / "slices").iterdir()) == before


def test_a_study_on_a_folder_of_slices(tmp_path) -> None:
    """A study whose base spec reads a folder runs, with the slit's K, and its case id is the
    slices' content: the same folder moved gives the same id, a changed slice another."""
    from psdesign.study.design import case_hash

    write_slices(tmp_path / "a" / "slices", slit())
    spec(tmp_path / "a", "slices", NO_BAR, "img.toml")
    study = tmp_path / "a" / "study.toml"
    study.write_text(
        'base = "img.toml"\n[study]\nname = "sl"\ndesign = "full-factorial"\n'
        'outputs = ["porosity", "k_x"]\nsolver = "voxel"\n'
        '[parameters]\n"flow.viscosity" = [1.0e-5]\n'
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = psdesign.run_study(study, tmp_path / "out", workers=0, progress=False, report=False)
    assert df["k_x_m2"].iloc[0] == pytest.approx(SLIT_K_MAC, rel=1e-4, abs=0)
    shutil.copytree(tmp_path / "a", tmp_path / "b")

    def case(folder):
        return case_hash({"image": {"path": str(folder / "slices")}}, ["k_x"], "voxel")

    assert case(tmp_path / "a") == case(tmp_path / "b")
    page = slit()[7]
    page[0, 0] = 255
    tifffile.imwrite(tmp_path / "b" / "slices" / "s7.tif", page, **IMAGEJ_UM)
    assert case(tmp_path / "a") != case(tmp_path / "b")


def porosity_study(folder, path: str, extra: str = ""):
    """Run a one-case porosity study (voxel solver, no report) of the image ``path`` in
    ``folder`` (its spec ``img.toml`` with ``extra`` keys) into ``folder / "out"``."""
    spec(folder, path, extra + NO_BAR, "img.toml")
    study = folder / "study.toml"
    study.write_text(
        'base = "img.toml"\n[study]\nname = "sl"\ndesign = "full-factorial"\n'
        'outputs = ["porosity"]\nsolver = "voxel"\n[parameters]\n"flow.viscosity" = [1.0e-5]\n'
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return psdesign.run_study(study, folder / "out", workers=0, progress=False, report=False)


def test_a_study_report_names_the_image_it_solved(tmp_path) -> None:
    """The report of a study over a cropped folder of slices names the folder, its format,
    the voxel size read from the slices' calibration (1 um, IMAGEJ_UM), the crop and the
    cropped shape (12 x 16 x 24 voxels); until session 44 only study.json did. With the
    folder moved away, the report still names the path and crop and says the rest is not
    read (a report is never lost)."""
    from psdesign.report.html import build_html

    write_slices(tmp_path / "slices", slit())
    df = porosity_study(tmp_path, "slices", "crop = [[2, 14], [0, 16], [0, 24]]\n")
    assert df["porosity"].iloc[0] == pytest.approx(16 / 24, rel=1e-12, abs=0)
    rows = dict(re.findall(ROW, build_html(tmp_path / "out")))
    assert rows["image"] == str(tmp_path / "slices")
    assert rows["image format"] == "tif"
    assert rows["image voxel size (m)"] == f"1e-06 ({Z_TAKEN_EQUAL})"
    assert rows["image crop (x, y, z voxel ranges)"] == "[[2, 14], [0, 16], [0, 24]]"
    assert rows["image shape (voxels x, y, z)"].startswith("12 x 16 x 24 (box 1.2e-05 x")
    shutil.move(tmp_path / "slices", tmp_path / "moved")
    # the header as the run read it (study.json, session 45): the same rows, image moved
    assert dict(re.findall(ROW, build_html(tmp_path / "out"))) == rows
    doc = json.loads((tmp_path / "out" / "study.json").read_text())
    doc.pop("image_header")  # a folder written before session 45: the header is read now
    (tmp_path / "out" / "study.json").write_text(json.dumps(doc))
    rows = dict(re.findall(ROW, build_html(tmp_path / "out")))
    assert (
        rows["image"] == str(tmp_path / "slices")
        and "[[2, 14]" in rows["image crop (x, y, z voxel ranges)"]
    )
    assert rows["image voxel size, shape"].startswith("not read now: ")


def test_a_study_report_shows_the_image_as_the_study_ran_it(tmp_path, capsys) -> None:
    """The report read the image's header when it was written, not when the study ran
    (session 44 note): a stack replaced after the run by one of another voxel size (2 um, was
    1 um) and shape (8 x 8 x 12, was 16 x 16 x 24) showed the new file's 2e-06 and 8 x 8 x 12
    beside results computed on the old one. The run stores the header in study.json
    (``image_header``); ``psdesign study report`` shows that. Fails on main's runner and
    image_source (the report showed 2e-06)."""
    write_stack(tmp_path / "scan.tif", slit())
    porosity_study(tmp_path, "scan.tif")
    small = slit()[::2, ::2, ::2]
    meta = {"unit": "um", "axes": "ZYX"}
    tifffile.imwrite(
        tmp_path / "scan.tif", small, imagej=True, resolution=(0.5, 0.5), metadata=meta
    )
    assert main(["study", "report", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    rows = dict(re.findall(ROW, (tmp_path / "out" / "report.html").read_text()))
    assert rows["image voxel size (m)"] == "1e-06 (from the file)", rows
    assert rows["image shape (voxels x, y, z)"].startswith("16 x 16 x 24 (box 1.6e-05 x")
    assert rows["image format"] == "tif"


def test_a_study_over_a_slice_folder_says_z_taken_equal_once(tmp_path) -> None:
    """Slices calibrated in x/y only, no ``image.voxel_size``: the "z is taken equal to x and
    y" warning is the spec's, the same for every case. A 3-case study printed it 8 times
    (load_study's checks, validate_case_specs, each case; session 44): now once, from the
    runner's check of the case specs (psdesign.study.worker.show_case_warnings, each text
    once), with the 'always' filter so that no registry hides a repeat."""
    write_slices(tmp_path / "slices", slit())
    spec(tmp_path, "slices", NO_BAR, "img.toml")
    study = tmp_path / "study.toml"
    study.write_text(
        'base = "img.toml"\n[study]\nname = "z1"\ndesign = "full-factorial"\n'
        'outputs = ["porosity"]\nsolver = "voxel"\n'
        '[parameters]\n"flow.viscosity" = [1.0e-5, 2.0e-5, 3.0e-5]\n'
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = psdesign.run_study(study, tmp_path / "out", workers=0, progress=False, report=False)
    assert len(df) == 3 and (df["status"] == "ok").all()
    z_lines = [str(w.message) for w in caught if "z is taken equal to x and y" in str(w.message)]
    assert len(z_lines) == 1, z_lines
    assert z_lines[0].startswith("image.voxel_size: 1e-06 m from s0.tif's x/y calibration")


@pytest.mark.parametrize("path", ["run[1]", "run[1]/s*.tif"])
def test_a_folder_named_with_brackets_is_read(tmp_path, path) -> None:
    """A real folder named ``run[1]`` (a scanner's run number) holds the slices: it and a
    pattern in it read the stack's voxels. Until the s44 review both were refused, exit 2
    ("image.path: .../run[1]: a pattern may only be in the file name"): the glob check looked
    at the folder's name without asking whether that folder exists."""
    from psdesign.image.reader import ImageSource, read_labels

    write_slices(tmp_path / "run[1]", slit())
    write_stack(tmp_path / "stack.tif", slit())
    got = read_labels(ImageSource(path=str(tmp_path / path), voxel=1e-6))
    want = read_labels(ImageSource(path=str(tmp_path / "stack.tif"), voxel=1e-6))
    assert got.shape == want.shape == (16, 16, 24) and np.array_equal(got, want)


def test_the_slice_number_is_the_run_of_digits_that_changes(tmp_path) -> None:
    """``recon_0000_8bit.tif ... recon_0023_8bit.tif`` (a converted export): the number is the
    run that differs between the names, not the last (``8`` in every name). Until the s44
    review the folder was refused as "named by two patterns ('recon_0000_#bit',
    'recon_0001_#bit'): two scans in one folder?". Names written in shuffled order; the
    labels equal the multi-page stack's. Two scans beside each other are still refused."""
    from psdesign.image.reader import ImageSource, read_labels

    order = random.Random(3).sample(range(24), 24)
    write_slices(tmp_path / "bit", slit(), name="recon_{k:04d}_8bit.tif", order=order)
    write_stack(tmp_path / "stack.tif", slit())
    got = read_labels(ImageSource(path=str(tmp_path / "bit"), voxel=1e-6))
    want = read_labels(ImageSource(path=str(tmp_path / "stack.tif"), voxel=1e-6))
    assert np.array_equal(got, want)
    write_slices(tmp_path / "bit", slit(), name="other_{k:04d}_8bit.tif")
    with pytest.raises(ValueError, match="named by two patterns"):
        read_labels(ImageSource(path=str(tmp_path / "bit"), voxel=1e-6))


#: A row of the report's Study table: label, value.
ROW = r"<tr><th>([^<]*)</th><td>([^<]*)</td></tr>"

#: The report's voxel-size source for slices calibrated in x/y only (the study's warning).
Z_TAKEN_EQUAL = "x and y from the calibration of s0.tif; z taken equal: a slice stores no z spacing"


def test_the_report_says_where_the_image_voxel_size_came_from(tmp_path) -> None:
    """A slice folder calibrated in x/y only: the study warns "z is taken equal to x and y",
    and the report's voxel-size row said "from the file" (session 44 review: the file stores
    no z spacing). Now it says z was taken equal; a multi-page ImageJ stack (its spacing in
    the file) says "from the file", a given ``image.voxel_size`` "given"."""
    from psdesign.report.image_source import image_rows

    write_slices(tmp_path / "slices", slit())
    stack = tmp_path / "stack.tif"
    meta = {"unit": "um", "spacing": 1.0, "axes": "ZYX"}
    tifffile.imwrite(stack, slit(), imagej=True, resolution=(1.0, 1.0), metadata=meta)

    def voxel_row(image: dict) -> str:
        rows = dict(image_rows({"base": {"image": image | {"solid_label": 255}}}, tmp_path))
        return rows["image voxel size (m)"]

    assert voxel_row({"path": "slices"}) == f"1e-06 ({Z_TAKEN_EQUAL})"
    assert voxel_row({"path": "stack.tif"}) == "1e-06 (from the file)"
    given = voxel_row({"path": "slices", "voxel_size": 2e-6})
    assert given == "2e-06 (given (image.voxel_size))"
