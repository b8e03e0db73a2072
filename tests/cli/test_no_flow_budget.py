"""Commands that solve no flow are held to their voxel grid's memory, not to a flow solve.

Session 52 walk (geometry): ``generate``, ``pores``, ``diffusivity`` (and ``conductivity``,
``forcefield``) refused, exit 2, a spec with no ``[flow]`` table for "the FEM solve of about
1.22e+06 tets (2 copies) needs about 16.7 GiB", a solve none of them runs; the advice the
transport warnings gave (a finer voxel) led there. They now load the spec inside
:func:`psdesign.schema.budget.unplanned_route`; ``permeability --solver fem`` and ``study run``
still refuse up front.

Truth: the budget's own figures on a machine of 1 GiB (budget 0.5 GiB): the FEM's refined
field of two D = 6 um rods at 1 um voxels needs about 0.938 GiB (refused), the 20^3 grid's own
fields 16 B per voxel (:data:`~psdesign.schema.budget.GEOMETRY_BYTES_PER_VOXEL`), 128 kB, and
its transport solve, 0.35 GB for the process and 130 B per voxel (session 54), fit;
on a machine of 200 kB (budget 100 kB) the grid itself does not fit and every command refuses.
"""

from __future__ import annotations

import pytest

from psdesign.cli.main import main
from psdesign.schema import budget

SPEC = """[rve]
size = [20e-6, 20e-6, 20e-6]
voxel = 1e-6
[[fibers]]
shape = "rod"
diameter = 6e-6
center = [10e-6, 10e-6, 10e-6]
[[fibers]]
shape = "rod"
diameter = 6e-6
center = [10e-6, 10e-6, 14e-6]
omega = 90.0
"""

STUDY = """[base.rve]
size = [20e-6, 20e-6, 20e-6]
voxel = 1e-6
[[base.fibers]]
shape = "rod"
diameter = 6e-6
center = [10e-6, 10e-6, 10e-6]
[study]
name = "s"
design = "full-factorial"
seeds = [1]
outputs = ["porosity", "k_z"]
solver = "fem"
[parameters]
"rve.voxel" = [1e-6]
"""


def _argv(name: str, spec, tmp_path) -> list[str]:
    s = str(spec)
    relax = tmp_path / "relax.toml"  # the force field's own spec: [forcefield.relax] added
    relax.write_text(SPEC + "[forcefield.relax]\nmax_shift = 6e-6\n")
    return {
        "generate": ["generate", s, "-o", str(tmp_path / "g"), "--no-preview"],
        "pores": ["pores", s, "--json"],
        "diffusivity": ["diffusivity", s, "--direction", "z", "--json"],
        "conductivity": ["conductivity", s, "--direction", "z", "--json"],
        "forcefield": [
            "forcefield",
            str(relax),
            "-o",
            str(tmp_path / "f"),
            "--no-pictures",
            "--quiet",
        ],
    }[name]


@pytest.fixture
def spec(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(SPEC)
    return p


def test_the_premise():
    assert budget.GEOMETRY_BYTES_PER_VOXEL * 20**3 == pytest.approx(128e3)
    assert budget.grid_bytes([20] * 3, "geometry") < 2**29 < 0.938 * 2**30
    # the 1 GiB machine the commands run on: the transport solve fits its 0.5 GiB budget
    assert budget.grid_bytes([20] * 3, "transport") < 2**29 < 0.938 * 2**30


@pytest.mark.parametrize("name", ["generate", "pores", "diffusivity", "conductivity", "forcefield"])
def test_a_command_that_solves_no_flow_is_not_refused_for_the_fem_solve(
    name, spec, tmp_path, capsys, monkeypatch
):
    # 1 GiB: the FEM's refined field (0.938 GiB) is over its 0.5 GiB budget, the transport
    # solve (0.35 GB process + 130 B per voxel, session 54) and the grid are not
    monkeypatch.setattr(budget, "machine_memory", lambda: 2**30)
    rc = main(_argv(name, spec, tmp_path))
    err = capsys.readouterr().err
    assert "psdesign: error" not in err and "FEM" not in err, err
    assert rc in (0, 3)  # a result, rated (3: a value not trusted at 6 voxels per fibre)


def test_the_flow_solves_still_refuse_up_front(spec, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(budget, "machine_memory", lambda: 64 * 2**20)
    assert main(["permeability", str(spec), "--solver", "fem", "--direction", "z"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("psdesign: error: rve.voxel: the FEM's refined field needs about")
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    assert main(["study", "run", str(study), "-o", str(tmp_path / "out")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "base.rve.voxel: the FEM's refined field needs about" in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["pores", "diffusivity", "conductivity"])
def test_a_transport_command_is_held_to_its_own_solve(name, spec, tmp_path, capsys, monkeypatch):
    """Review E (session 52): loaded inside ``unplanned_route`` alone, the transport commands
    were held to the grid's 16 B per voxel, while they peak at 270-324 B per voxel (pores,
    diffusivity on an 864 k-voxel RVE): an out-of-memory crash instead of exit 2. On a machine
    of 4 MiB (budget 2 MiB) the 20^3 grid's fields (128 kB) fit and its transport solve
    (:data:`~psdesign.schema.budget.TRANSPORT_BYTES_PER_VOXEL`, 3.3 MB) does not."""
    monkeypatch.setattr(budget, "machine_memory", lambda: 4 * 2**20)
    need = budget.grid_bytes([20] * 3, "transport")
    assert budget.grid_bytes([20] * 3, "geometry") < 2 * 2**20 < need
    assert main(_argv(name, spec, tmp_path)) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("psdesign: error: rve.voxel: a 20x20x20 grid") and "transport" in line
    assert f"needs about {need / 2**30:.3g} GiB" in line
    assert main(_argv("generate", spec, tmp_path)) == 0  # no transport solve: the grid fits


@pytest.mark.parametrize("name", ["generate", "pores", "forcefield"])
def test_their_voxel_grid_is_still_held_to_the_memory(name, spec, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(budget, "machine_memory", lambda: 200e3)
    assert main(_argv(name, spec, tmp_path)) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "rve.voxel: a 20x20x20 grid (8e+03 voxels, 16 B each for the voxel grid's own" in line
    assert f"needs about {128e3 / 2**30:.3g} GiB" in line
    assert not (tmp_path / "g").exists() and not (tmp_path / "f").exists()


@pytest.mark.parametrize("method", ["pores", "diffusivity", "conductivity"])
def test_the_api_is_held_to_the_transport_solve_too(method, spec, monkeypatch):
    """Review G (session 52): only the commands' loader checked the transport solve's memory;
    ``psdesign.build(spec).diffusivity()`` (and ``pores``, ``conductivity``) ran on a grid
    the command refuses. One check (``budget.check_transport``): the same refusal, before the
    voxels are computed."""
    import psdesign
    from psdesign.errors import SpecError

    m = psdesign.build(spec)
    monkeypatch.setattr(budget, "machine_memory", lambda: 4 * 2**20)
    with pytest.raises(SpecError) as info:
        getattr(m, method)(**({"direction": "z"} if method != "pores" else {}))
    assert info.value.key == "rve.voxel" and "transport" in info.value.message
    assert m._fields is None  # refused before the voxels


def test_build_is_held_to_the_geometry_and_permeability_to_its_solve(spec, monkeypatch):
    """Session 52 review E (left): ``psdesign.build`` (geometry only) was refused for the FEM
    solve of the spec (the refined field's 0.938 GiB on a 64 MiB machine, as the commands
    above), so neither ``.porosity`` nor ``.pores()`` could be had. It is held to the grid's own
    fields now (128 kB, fits); ``.permeability`` still refuses its FEM solve before any work,
    with the command's line, and its voxel solve on the same grid runs."""
    import psdesign
    from psdesign.errors import SpecError

    monkeypatch.setattr(budget, "machine_memory", lambda: 64 * 2**20)
    m = psdesign.build(spec)
    assert m._fields is None
    with pytest.raises(SpecError) as info:
        m.permeability("z", solver="fem")
    assert info.value.key == "rve.voxel"
    assert info.value.message.startswith("the FEM's refined field needs about")
    assert m._fields is None  # refused before the voxels
    with pytest.raises(SpecError):  # the spec's own [flow]: the FEM's default route
        m.permeability("z")
    assert 0.0 < m.porosity < 1.0


def test_a_study_without_k_is_held_to_the_work_of_its_outputs(tmp_path, capsys, monkeypatch):
    """Session 52 review E (left): ``study run`` of outputs without a K (porosity alone) was
    refused for the FEM solve no case runs (on a machine of 64 MiB, the refined field's
    0.938 GiB: the line of ``test_the_flow_solves_still_refuse_up_front``). It runs now, held
    to the grid's own fields (128 kB), and writes the porosity; a transport output is held to
    its solve (``TRANSPORT_BYTES_PER_VOXEL``: 3.3 MB of the 20^3 grid, over a 4 MiB machine's
    2 MiB budget) before any work, as ``pores`` is; the study file's check, the runner's and
    each case's apply the one rule (``schema.study.validate_case_spec``)."""
    import csv

    monkeypatch.setattr(budget, "machine_memory", lambda: 64 * 2**20)
    study = tmp_path / "study.toml"
    study.write_text(STUDY.replace('["porosity", "k_z"]', '["porosity"]'))
    out = tmp_path / "out"
    # --workers 0: the case runs in this process, so its own check sees the 64 MiB machine too
    # (a pool worker would see this machine's memory), and no pool starts (~5 s of CPU)
    assert main(["study", "run", str(study), "-o", str(out), "--quiet", "--workers", "0"]) == 0
    (row,) = csv.DictReader((out / "results.csv").open())
    assert 0.0 < float(row["porosity"]) < 1.0 and row["porosity_status"] == "ok"
    capsys.readouterr()
    monkeypatch.setattr(budget, "machine_memory", lambda: 4 * 2**20)
    study.write_text(STUDY.replace('["porosity", "k_z"]', '["porosity", "pore_d50_m"]'))
    assert main(["study", "run", str(study), "-o", str(tmp_path / "t")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "base.rve.voxel: a 20x20x20 grid" in line and "transport" in line
    assert not (tmp_path / "t").exists()


@pytest.mark.parametrize("name", ["pores", "diffusivity", "conductivity"])
def test_a_transport_command_refuses_an_image_before_reading_its_voxels(
    name, tmp_path, capsys, monkeypatch
):
    """Session 54 walk: a 700^3 ``.npy`` image was read whole (12.8 s, 0.8 GB) by the spec
    check before the transport refusal. Now the refusal comes from the header: the voxel
    reader fails the test if called. Truth: the budget's figures on a machine of 4 MiB
    (budget 2 MiB): the 20^3 grid's fields (128 kB) fit, its transport solve (3.3 MB) does
    not, and the one line is the same ``check_transport`` line as for the RVE route."""
    import numpy as np

    import psdesign.image.load as image_load

    image = np.zeros((20, 20, 20), np.uint8)
    image[:, :, :5] = 1
    np.save(tmp_path / "img.npy", image)
    spec = tmp_path / "img.toml"
    spec.write_text('[image]\npath = "img.npy"\nvoxel_size = 1e-6\n')

    def no_read(*args, **kwargs):
        raise AssertionError("the image's voxels were read")

    monkeypatch.setattr(image_load, "read_image", no_read)
    monkeypatch.setattr(budget, "machine_memory", lambda: 4 * 2**20)
    argv = _argv(name, spec, tmp_path)
    assert main(argv) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("psdesign: error: image.crop: a 20x20x20 grid"), line
    assert "transport command's scan or Laplace solve" in line


def test_a_study_case_of_transport_outputs_refuses_an_image_before_its_voxels(
    tmp_path, monkeypatch
):
    """The study's case check (:func:`psdesign.schema.study.validate_case_spec`) holds an image
    case of transport outputs to the same figure, from the header (session 54); truth as
    above (4 MiB machine: the 20^3 grid's 3.3 MB transport solve over the 2 MiB budget)."""
    import numpy as np

    import psdesign.image.load as image_load
    from psdesign.errors import SpecError
    from psdesign.schema.study import validate_case_spec

    np.save(tmp_path / "img.npy", np.eye(20, dtype=np.uint8)[:, :, None].repeat(20, axis=2))

    def no_read(*args, **kwargs):
        raise AssertionError("the image's voxels were read")

    monkeypatch.setattr(image_load, "read_image", no_read)
    monkeypatch.setattr(budget, "machine_memory", lambda: 4 * 2**20)
    case = {"image": {"path": str(tmp_path / "img.npy"), "voxel_size": 1e-6}}
    with pytest.raises(SpecError) as info:
        validate_case_spec(case, ["porosity", "diffusivity_z"])
    assert info.value.key == "image.crop" and "transport command" in info.value.message
