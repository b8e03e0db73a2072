"""The copies an ``"auto"`` permeameter stacks, counted before any work where the spec tells
(session 43, helper s43-ends; benchmarks/RESULTS.md "Session 43: loose ends").

Before: up front ``"auto"`` counted one copy against ``flow.max_memory_gb`` and two against
the machine budget, whatever the geometry; the two copies of a periodic RVE were refused by the
cap only once the RVE was built (``check_planned_stack``), and a non-periodic one was refused by
the budget for two copies it would never stack. Now an RVE of explicit fibers is planned from
its analytic field before it is built (``psdesign.flow.stack.spec_auto_copies``: the end-plane
test ``plan_copies`` applies to the built RVE) along each direction a route solves.

Truth: the voxel route's bytes (``budget.grid_bytes``: 16 B of fields per voxel, or 5 B per
tiled copy plus one, and ``VOXEL_SOLVER_BYTES_PER_VOXEL`` per solved cell, the reservoirs 0.2
of a copy each); one 6 um rod along x in a 20 um cube of period 20 um is periodic along y and
z (a PS rod repeats one period across its axis) and two periods along x (a cylinder along the
flow: its window is exact, one copy); in a 20 x 20 x 30 um box its copies are 20 um apart
along z, so the end planes z = 0 and z = 30 um differ (one copy, not periodic).
"""

from __future__ import annotations

import tomllib

import pytest
from toml_writer import dumps

from psdesign.cli.main import main
from psdesign.errors import SpecError
from psdesign.schema import budget
from psdesign.schema.spec import check_directions, validate_spec

CUBE = [20, 20, 20]  # the grid of the 20 um cube at 1 um
ONE = budget.grid_bytes(CUBE, "voxel", 1, {"aux": 0.2})
TWO = budget.grid_bytes(CUBE, "voxel", 2, {"aux": 0.2})
#: flow.max_memory_gb between one copy and two, the margin counted
CAP = 0.5 * (ONE + TWO) / budget.CAP_MARGIN / 1e9


def _spec(cap: float | None = CAP, size=(20e-6, 20e-6, 20e-6), center=None) -> dict:
    fiber = {"diameter": 6e-6} | ({"center": list(center)} if center else {})
    flow = {"solver": "voxel", "bc": "permeameter"}
    if cap is not None:
        flow["max_memory_gb"] = cap
    return {
        "rve": {"size": list(size), "voxel": 1e-6, "period": 20e-6},
        "fibers": [fiber],
        "flow": flow,
    }


@pytest.fixture
def no_build(monkeypatch):
    """The RVE builders raise: a refusal must come before any of them runs."""
    import psdesign.packing.build as build
    import psdesign.study.case as case

    def boom(*a, **k):
        raise AssertionError("the RVE was built although the planned stack is refused")

    for module in (build, case):
        monkeypatch.setattr(module, "build_rve", boom)


@pytest.fixture
def no_voxels(monkeypatch):
    """The API's Material builds its RVE in psdesign.build; its voxel fields must not be."""
    import psdesign.api as api

    def boom(*a, **k):
        raise AssertionError("the voxel fields were built although the planned stack is refused")

    monkeypatch.setattr(api.Material, "fields", property(boom))


def _along(spec: dict) -> dict:
    """``spec`` validated as a route checks it before any work: alone, then along its
    ``flow.direction`` (the direction the route solves, ``check_directions``)."""
    valid = validate_spec(spec)
    check_directions(valid, valid["flow"], [valid["flow"]["direction"]])
    return valid


def test_the_premise():
    assert ONE <= budget.CAP_MARGIN * CAP * 1e9 < TWO


def test_a_periodic_two_copy_stack_over_the_cap_is_refused_before_the_rve_is_built(
    tmp_path, capsys, no_build
):
    """exit 2, one line naming flow.max_memory_gb and the two copies; old code: the check ran
    after the RVE and its voxel fields were built (build_rve called)."""
    path = tmp_path / "s.toml"
    path.write_text(dumps(_spec()))
    assert main(["permeability", str(path), "--direction", "z"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("psdesign: error: flow.max_memory_gb: the voxel solve of the ")
    assert (
        "20x20x20 grid (2 copies stacked, counted along z)" in line
        and f"{TWO / 1e9:.3g} GB" in line
    )
    assert main(["permeability", str(path), "--direction", "all"]) == 2  # z is among them
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_one_copy_along_the_rod_fits_the_cap():
    """Along x the rod is a cylinder along the flow: one copy, under the cap; periodic bc: one."""
    _along(_spec() | {"flow": _spec()["flow"] | {"direction": "x"}})
    with pytest.raises(SpecError, match="2 copies stacked"):
        _along(_spec() | {"flow": _spec()["flow"] | {"direction": "z"}})
    _along(_spec() | {"flow": {**_spec()["flow"], "direction": "z", "bc": "periodic"}})


def test_a_spec_whose_direction_is_over_the_cap_runs_along_another(tmp_path, capsys):
    """flow.direction is the default of a command line (and of a study's outputs), which may
    solve another: s43-ends planned along it when the spec was loaded, so this spec (z: two
    copies over the cap) run with --direction x (one copy, under it) was refused before any
    work (exit 2, '2 copies stacked'); main before s43-ends solved it (exit 0). Loaded alone a
    spec counts the fewest copies over the axes; the command pins the one it solves. Old
    code: validate_spec raised, the command exited 2."""
    spec = _spec() | {"flow": _spec()["flow"] | {"direction": "z"}}
    validate_spec(spec)
    path = tmp_path / "s.toml"
    path.write_text(dumps(spec))
    args = ["permeability", str(path), "--no-error-estimate", "--quiet", "--json"]
    assert main([*args, "--direction", "x"]) in (0, 3)  # finished (3: a status not ok, exit_status)
    assert '"permeameter_copies": 1' in capsys.readouterr().out
    assert main(args) == 2  # its own direction, z: refused before any work
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "flow.max_memory_gb" in line and "2 copies stacked" in line


def test_the_api_refuses_before_voxelizing(no_voxels):
    import psdesign

    m = psdesign.build(_spec())  # no direction yet: "auto" may stack one copy
    with pytest.raises(SpecError) as ei:
        m.permeability("z")
    assert ei.value.key == "flow.max_memory_gb" and "2 copies stacked" in ei.value.message


def test_a_study_refuses_before_any_case(tmp_path, capsys, no_build):
    """`psdesign study run`: exit 2, one line naming base.flow.max_memory_gb, no case run."""
    (tmp_path / "base.toml").write_text(dumps(_spec()))
    study = tmp_path / "study.toml"
    study.write_text(
        'base = "base.toml"\n[study]\nname = "planned"\noutputs = ["porosity", "k_z"]\n'
        'solver = "voxel"\nseeds = [0]\n[parameters]\n"fibers.0.diameter" = [6e-6]\n'
    )
    rc = main(["study", "run", str(study), "-o", str(tmp_path / "out"), "--quiet"])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and "base.flow.max_memory_gb" in line and "2 copies stacked" in line, line


@pytest.mark.parametrize(
    "planned, size, center", [(2, None, None), (1, (20e-6, 20e-6, 30e-6), (10e-6,) * 3)]
)
def test_the_machine_budget_counts_the_planned_copies(
    monkeypatch, tmp_path, capsys, no_build, planned, size, center
):
    """Half the machine between one copy and two, no cap: the periodic cube is refused before
    the RVE is built naming flow.permeameter_copies; the 30 um box, not periodic along z,
    stacks one copy and is accepted (old code: refused it for two copies)."""
    spec = _spec(None, size or (20e-6,) * 3, center)
    shape = [20, 20, 30] if size else CUBE
    one, two = (budget.grid_bytes(shape, "voxel", c, {"aux": 0.2}) for c in (1, 2))
    monkeypatch.setattr(budget, "machine_memory", lambda: (one + two) / budget.MEMORY_FRACTION / 2)
    along_z = spec | {"flow": spec["flow"] | {"direction": "z"}}
    if planned == 1:
        _along(along_z)
        return
    with pytest.raises(SpecError) as ei:
        _along(along_z)
    assert ei.value.key == "flow.permeameter_copies"
    path = tmp_path / "s.toml"
    path.write_text(dumps(spec))
    assert main(["permeability", str(path), "--direction", "z"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "flow.permeameter_copies: 2 copies of the 20x20x20 grid" in line


def test_a_generated_rve_keeps_the_after_build_check():
    """A [generator]'s fibers are known once generated: up front "auto" counts one copy against
    the cap (check_planned_stack refuses two once the RVE is built, as before)."""
    spec = _spec()
    del spec["fibers"]
    spec["generator"] = {"n_fibers": 1, "diameter": 6e-6}
    spec["flow"]["direction"] = "z"
    validate_spec(spec)
    assert tomllib.loads(dumps(spec))  # plain TOML data


def test_the_plan_is_made_only_where_it_can_change_the_outcome(monkeypatch):
    """Where two copies (the most "auto" plans first) fit the budget and the cap, the analytic
    field is not evaluated (10-30 ms a direction, on every level a study checks)."""
    import psdesign.flow.stack as stack

    def boom(*a, **k):
        raise RuntimeError("planned although two copies fit")  # pydantic passes it on

    monkeypatch.setattr(stack, "spec_auto_copies", boom)
    validate_spec(_spec(cap=1.0) | {"flow": _spec(cap=1.0)["flow"] | {"direction": "z"}})
    with pytest.raises(RuntimeError, match="planned although"):
        validate_spec(_spec() | {"flow": _spec()["flow"] | {"direction": "z"}})


def _image_spec(tmp_path, solid, name: str) -> dict:
    """A 20^3 voxel image at 1 um (``name``.npy, x y z; one file per mask: the mask cache
    knows a file by its path, size and time), voxel route, "auto" permeameter along z."""
    import numpy as np

    path = tmp_path / f"{name}.npy"
    np.save(path, np.asarray(solid, dtype=np.uint8))
    flow = {"solver": "voxel", "bc": "permeameter", "max_memory_gb": CAP, "direction": "z"}
    return {"image": {"path": str(path), "voxel_size": 1e-6}, "flow": flow}


def test_an_image_plans_its_copies_from_its_mask(tmp_path):
    """An image's copies are the voxel seam test's on its mask (flow.stack.end_planes: the
    seam between the last and first layer against the worst step between neighbours inside),
    which the schema reads anyway: a rod along x through the middle is periodic along z (two
    copies, over the cap: refused naming image.crop's advice); a ramp whose solid grows by one
    row a layer (steps of 1/20 of a layer, a seam of 19/20) is not (one copy, under the cap).
    Old code: both passed up front (one copy counted; the rod refused once built)."""
    import numpy as np

    y, z = np.meshgrid(np.arange(20), np.arange(20), indexing="ij")
    rod = np.broadcast_to(((y - 9.5) ** 2 + (z - 9.5) ** 2 <= 9)[None], (20, 20, 20))
    with pytest.raises(SpecError) as ei:
        _along(_image_spec(tmp_path, rod, "rod"))
    assert ei.value.key == "flow.max_memory_gb" and "2 copies stacked" in ei.value.message
    assert ei.value.message.endswith("or a smaller image.crop)")
    ramp = np.broadcast_to((y < z)[None], (20, 20, 20))
    validate_spec(_image_spec(tmp_path, ramp, "ramp"))
    # the built images plan the same copies (the one rule, flow.stack.plan_copies)
    from psdesign.flow.stack import plan_copies
    from psdesign.image.load import image_rve

    for mask, copies, name in ((rod, 2, "rod"), (ramp, 1, "ramp")):
        spec = _image_spec(tmp_path, mask, name)
        del spec["flow"]["max_memory_gb"]
        rve = image_rve(validate_spec(spec)["image"])
        assert plan_copies({"permeameter_copies": "auto"}, rve, rve.image, 2).copies == copies


#: A 40 um cube with one 32 um PS rod (porosity 0.59 once voxelized), FEM stuffing at a 2 um
#: lattice, "auto" along z (periodic, one period: 2 copies), flow.max_memory_gb = 1.45 (1.2 since
#: the estimate's session 54 calibration). Run by main's code before s43-ends (review2,
#: benchmarks/RESULTS.md): exit 0, K_z = 4.303e-12 m^2 converged, the solve's own estimate 1.3 GB
#: (1.1 GB since session 54) on the built 68240-tet mesh under the cap.
DENSE_FEM = {
    "rve": {"size": [40e-6] * 3, "voxel": 1e-6},
    "fibers": [{"diameter": 32e-6}],
    "flow": {"solver": "fem", "lattice_step": 2e-6, "max_memory_gb": 1.2, "direction": "z"},
}


def test_a_dense_fem_stack_is_counted_at_its_porosity_not_at_one():
    """s43-ends counted the planned two copies of explicit fibers at porosity 1 (every lattice
    cell pore: 2.04 GB, over 1.25 x 1.45 GB; 1.63 GB over 1.25 x 1.2 GB since session 54) and
    refused up front a spec that ran (above);
    the check of the built RVE counts them at its porosity (check_planned_stack). Now the
    plan's porosity is an upper bound sampled from the analytic field, at or above the voxel
    count's. Old code: SpecError 'needs about 2.04 GB'."""
    import numpy as np

    from psdesign.geometry.porosity import sampled_porosity_bound
    from psdesign.packing.build import build_rve

    size, step = (40e-6,) * 3, 2e-6
    assert budget.fem_need_bytes(size, step, 2, 0.2, 1.0) > budget.CAP_MARGIN * 1.2e9  # premise
    valid = _along(DENSE_FEM)
    built = build_rve(valid)
    fields = built.voxelize(1e-6)
    bound = sampled_porosity_bound(built.rve)
    assert fields.porosity <= bound <= fields.porosity + 0.04, (fields.porosity, bound)
    flow = valid["flow"] | {"bc": "permeameter"}
    budget.check_planned_stack(flow, "fem", 2, size, 1e-6, fields.porosity, 32e-6)  # passes
    # one copy fits 1.25 x 0.9 GB (1.03 GB at porosity 1), two at the bound do not (1.18 GB)
    tight = DENSE_FEM | {"flow": DENSE_FEM["flow"] | {"max_memory_gb": 0.9}}
    with pytest.raises(
        SpecError,
        match=r"is estimated \(conservatively\) to need about 1\.18 GB, over the cap of 0\.9 GB",
    ):
        _along(tight)
    assert np.isclose(fields.porosity, 0.5925, atol=1e-3)


def test_an_image_fem_stack_is_counted_at_the_masks_porosity(tmp_path):
    """An image's planned stack on the FEM route: counted at the mask's porosity, the figure
    check_planned_stack counts once built (0.432 GB at porosity 0.48 against 1.25 x 0.38 GB),
    not at porosity 1 (0.511 GB; 0.273 and 0.391 GB against 1.25 x 0.3 GB before the session 54
    calibration). Old code: refused up front."""
    import numpy as np

    y, z = np.meshgrid(np.arange(20), np.arange(20), indexing="ij")
    rod = np.broadcast_to(((y - 9.5) ** 2 + (z - 9.5) ** 2 <= 64)[None], (20, 20, 20))
    spec = _image_spec(tmp_path, rod, "dense")
    spec["flow"] = {"solver": "fem", "max_memory_gb": 0.38, "direction": "z"}
    size = (20e-6,) * 3
    assert budget.fem_need_bytes(size, 2e-6, 2, 0.2, 1.0) > budget.CAP_MARGIN * 0.38e9  # premise
    valid = _along(spec)
    from psdesign.image.load import image_rve

    rve = image_rve(valid["image"])
    assert rve.image.porosity == pytest.approx(0.48)
    budget.check_planned_stack(valid["flow"], "fem", 2, size, 1e-6, rve.image.porosity, None)
