"""``flow.max_memory_gb`` before any work on every route, and advice naming the route's key
(session 41, helper s41-routes; benchmarks/RESULTS.md "Session 41: route-aware refusals").

Before: the cap was checked up front for the stuffing mesh only. A pytetwild spec with
``max_memory_gb = 1e-6`` placed its fibre and meshed (4-11 s) before the solve refused it,
advising "a coarser flow.lattice_step", a key pytetwild ignores; the voxel route ignored the cap
and solved. Truth for the voxel figures: the per-cell bytes counted and traced in
``solvers/voxel/memory.py`` (20^3 cells x (16 B of fields + 107 B of the sub-voxel solver + 9 B
of box-wall couplings) = 1.056e-3 GB); for pytetwild: meshes measured in session 41
(:data:`MEASURED`).
"""

from __future__ import annotations

import numpy as np
import pytest

from psdesign.cli.main import main
from psdesign.errors import SpecError
from psdesign.flow import fem
from psdesign.flow import permeability as P
from psdesign.meshing.options import tetwild_mesh_size
from psdesign.schema import budget
from psdesign.schema.spec import validate_spec
from solvers.fem.memory import MemoryLimitError

ONE_FIBER = (
    "[rve]\nsize = [20e-6, 20e-6, 20e-6]\nvoxel = 1e-6\n[[fibers]]\ndiameter = 6e-6\n"
    "[flow]\n{flow}max_memory_gb = {cap}\n"
)
ROUTES = {
    "pytetwild": ('solver = "fem"\nmesher = "pytetwild"\n', "a longer flow.edge_length"),
    "voxel": ('solver = "voxel"\n', "a coarser rve.voxel"),
    "stuffing": ('solver = "fem"\n', "a coarser flow.lattice_step"),
}


def _spec(route: str, cap: float) -> dict:
    import tomllib

    return tomllib.loads(ONE_FIBER.format(flow=ROUTES[route][0], cap=cap))


@pytest.mark.parametrize("route", sorted(ROUTES))
def test_a_tiny_cap_is_refused_before_the_rve_is_built_on_every_route(
    route, tmp_path, capsys, monkeypatch
):
    """exit 2, one line naming flow.max_memory_gb, the estimate and the route's own key; no
    fibre placed, no mesh, no solve, no --fields folder. Old code: pytetwild meshed, then named
    flow.lattice_step; voxel solved (exit 0)."""
    import psdesign.packing.build as build

    def boom(*a, **k):
        raise AssertionError("the RVE was built although the cap refuses the spec")

    monkeypatch.setattr(build, "build_rve", boom)
    path = tmp_path / "s.toml"
    path.write_text(ONE_FIBER.format(flow=ROUTES[route][0], cap=1e-6))
    out = tmp_path / "fields"
    assert main(["permeability", str(path), "--fields", str(out)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("psdesign: error: flow.max_memory_gb: the "), line
    assert "over the cap of 1e-06 GB" in line and line.endswith(f", or {ROUTES[route][1]})")
    assert not out.exists()


def test_the_voxel_cap_is_the_voxel_solve_estimate():
    """20^3 grid, periodic: grid_bytes = 8000 x (16 + 107 + 9) B = 1.056e-3 GB (fields,
    sub-voxel solver, box-wall couplings). Refused only over 1.25 x the cap (the estimate is an
    upper bound: traced 80-88 B per cell of solver against 107)."""
    need = budget.grid_bytes([20, 20, 20], "voxel")
    assert need / 1e9 == pytest.approx(8000 * (16 + 107 + 9) / 1e9, rel=1e-12)
    validate_spec(_spec("voxel", need / 1e9 / 1.25))  # at the margin: accepted
    with pytest.raises(SpecError) as ei:
        validate_spec(_spec("voxel", need / 1e9 / 1.26))
    assert ei.value.key == "flow.max_memory_gb" and "20x20x20 grid" in ei.value.message
    validate_spec(_spec("stuffing", 1.0))  # the FEM's own grid check takes no voxel cap


def test_the_voxel_cap_counts_the_reservoir_cells_the_solver_rounds_up():
    """A 7 um cube at 1 um, permeameter (one copy, aux_length 0.2): each reservoir is
    ceil(0.2 x 7) = 2 whole cells (the solver's rule, solvers.voxel.memory.reservoir_cells: at
    least one, rounded up), so the solve holds 7 x 7 x (7 + 2 x 2) = 539 cells, not the
    7^3 x (1 + 2 x 0.2) = 480.2 the estimate counted until session 44 (12 % short). A cap
    between the two estimates is refused now (old code accepted it); along x or y the same
    cube holds the same count."""
    b = budget.VOXEL_SOLVER_BYTES_PER_VOXEL
    fields = 343 * budget.GEOMETRY_BYTES_PER_VOXEL  # 16 B, above 5 B x 2 tiled
    need, old = fields + 539 * b, fields + 480.2 * b
    doc = {
        "rve": {"size": [7e-6] * 3, "voxel": 1e-6},
        "fibers": [{"diameter": 3e-6}],
        "flow": {"solver": "voxel", "bc": "permeameter", "permeameter_copies": 1},
    }
    cap = (need + old) / 2 / budget.CAP_MARGIN / 1e9
    with pytest.raises(SpecError) as ei:
        validate_spec(doc | {"flow": doc["flow"] | {"max_memory_gb": cap}})
    assert ei.value.key == "flow.max_memory_gb" and "7x7x7 grid" in ei.value.message
    validate_spec(doc | {"flow": doc["flow"] | {"max_memory_gb": 1.001 * need / 1.25e9}})
    assert budget.CAP_MARGIN == 1.25
    for axis in (None, 0, 2):
        got = budget.grid_bytes([7, 7, 7], "voxel", 1, {"aux": 0.2, "axis": axis})
        assert got == pytest.approx(need, rel=1e-12)


#: pytetwild meshes made in session 41 (``calib_tw.py``, benchmarks/RESULTS.md): box volume
#: meshed (copies plus reservoirs), target edge, fibre diameter, the fibre-diameter envelope,
#: tets made. 20 and 30 um boxes of one 6 um fibre (2 copies, aux 0.2), the first also at
#: edge_length 0.1; a 60 x 60 x 40 um straight generator paper, porosity 0.85, D 7 um (1 copy)
#: at the default edge and at edge_length 0.06.
MEASURED = [
    (20e-6**3 * 2.4, 5.1e-6, 6e-6, True, 3067),
    (30e-6 * 30e-6 * 20e-6 * 2.4, 5.1e-6, 6e-6, True, 6779),
    (20e-6**3 * 2.4, 3.98e-6, 6e-6, False, 2046),
    (60e-6 * 60e-6 * 40e-6 * 1.4, 5.95e-6, 7e-6, True, 36945),
    (60e-6 * 60e-6 * 40e-6 * 1.4, 6.1e-6, 7e-6, False, 23735),
]


@pytest.mark.parametrize("box, edge, d, fine, made", MEASURED)
def test_the_pytetwild_cap_counts_no_more_than_the_mesh_made(box, edge, d, fine, made):
    """The estimate over its safety factor is under every measured mesh (estimate / made
    1.16-4.47), so no spec a run would fit is refused before meshing."""
    tets = tetwild_mesh_size(box, edge, d, fine)[1]
    assert tets / budget.TETWILD_CAP_SAFETY < made < tets * 1.0


def test_a_cap_between_the_least_mesh_and_the_made_one_waits_for_the_mesh():
    """0.3 GB: over the least pytetwild mesh's 0.359 GB (x 1.25), so not refused up front (0.2
    GB against 0.164 GB before the estimate's session 54 calibration)."""
    validate_spec(_spec("pytetwild", 0.3))


class _Mesh:
    tets = np.zeros((2672, 4), dtype=np.int64)


@pytest.mark.parametrize(
    "mesher, key",
    [("pytetwild", "a longer flow.edge_length"), ("stuffing", "a coarser flow.lattice_step")],
)
def test_the_solve_refusal_names_the_route_key(mesher, key):
    """The solve's own check on the built mesh (a pytetwild spec at a 0.18 GB cap: 2672 tets,
    0.199 GB) named flow.lattice_step on every route."""
    exc = MemoryLimitError("estimated memory 0.199 GB exceeds max_memory_gb=0.18 GB")
    exc.estimate_gb, exc.limit_gb = 0.199, 0.18
    err = fem.memory_error(exc, _Mesh(), 0.18, mesher)
    assert err.key == "flow.max_memory_gb"
    assert str(err).endswith(f"(allowed: >= 0.199 GB, or {key})"), str(err)


class _Grid:
    spacing = np.array([0.5e-6] * 3)
    size = np.array([20e-6] * 3)


class _Fields:
    grid = _Grid()
    solid = np.zeros((2, 2, 2), dtype=bool)


class _RVE:
    size = np.array([20e-6] * 3)
    fibers: list = []


@pytest.mark.parametrize(
    "mesher, key", [("pytetwild", "flow.edge_length"), ("stuffing", "flow.lattice_step")]
)
def test_the_under_resolution_warning_names_the_route_key(mesher, key):
    """A pytetwild result whose mesh reports no edge (cached before session 39) was read as a
    lattice mesh: the warning said 'refine rve.voxel / flow.lattice_step'. The key is the one
    flow.mesher reads."""
    res = {
        "permeability_m2": 1.5e-11,
        "porosity": 0.7,
        "direction": "z",
        "converged": True,
        "residual": 1e-9,
        "flux_imbalance": 1e-9,
        "cells_per_diameter": 1.2,
        "mesh_quality": {},
    }
    out = P.with_error_estimate(_RVE(), _Fields(), "z", {"mesher": mesher}, "fem", res, False)
    (line,) = [w for w in out["warnings"] if "across the thinnest fiber" in w]
    assert f"refine rve.voxel / {key} (" in line, line


@pytest.mark.parametrize(
    "route, refused", [("pytetwild", False), ("stuffing", True), ("voxel", True)]
)
def test_a_lattice_step_is_checked_where_a_stuffing_mesh_reads_it(route, refused):
    """A 1 nm lattice step (8e12 cells in the 20 um cube): pytetwild does not read it, and was
    refused naming it; the stuffing route and a voxel spec (``psdesign mesh`` meshes it with
    the stuffing mesher) still refuse it, and a pytetwild spec meshed with ``--mesher
    stuffing`` is validated again with that mesher (psdesign/cli/mesh.py)."""
    spec = _spec(route, 10.0)
    spec["flow"]["lattice_step"] = 1e-9
    if not refused:
        validate_spec(spec)
        spec["flow"]["mesher"] = "stuffing"  # what psdesign mesh --mesher stuffing validates
    with pytest.raises(SpecError) as ei:
        validate_spec(spec)
    assert ei.value.key == "flow.lattice_step" and "8e+12 cells" in ei.value.message


@pytest.mark.parametrize(
    "mesher, key, value", [("stuffing", "edge_length", 0.005), ("pytetwild", "lattice_step", 1e-6)]
)
def test_the_other_meshers_key_is_named_as_unused(
    mesher, key, value, tmp_path, capsys, monkeypatch
):
    """flow.edge_length on the stuffing route (or flow.lattice_step on pytetwild) was ignored
    without a word (a 20 um cube with edge_length = 0.005 solved with the default lattice,
    exit 0, no line): now a warning names it and the key the route reads."""

    def route(rve, fields, direction, flow, solver, progress=None):
        return {
            "permeability_m2": 2e-11,
            "direction": "z",
            "porosity": 0.92,
            "solver": solver,
            "bc": "permeameter",
            "converged": True,
            "residual": 1e-9,
            "iterations": 1,
            "flux_imbalance": 1e-9,
            "wall_time_s": 0.0,
            "cells_per_diameter": 20.0,
        }

    monkeypatch.setattr(P, "route_result", route)
    path = tmp_path / "s.toml"
    flow = f'solver = "fem"\nmesher = "{mesher}"\n{key} = {value}\n'
    path.write_text(ONE_FIBER.format(flow=flow, cap=10.0))
    assert main(["permeability", str(path), "--quiet", "--no-error-estimate"]) == 0
    err = capsys.readouterr().err
    own = "flow.lattice_step" if mesher == "stuffing" else "flow.edge_length"
    line = f"psdesign: warning: flow.{key} = {value!r} is not used: mesher {mesher} reads {own}"
    assert line in err, err


def test_the_wall_distance_is_transformed_once_per_grid(tmp_path, capsys, monkeypatch):
    """``--direction all`` on the voxel route transformed the same grid's wall distance three
    times (0.66-0.77 s each at 200^3, identical values): now once, the same values, and not
    held once the grid is freed."""
    import gc
    import weakref

    from psdesign.geometry import throat
    from psdesign.geometry.rve import VoxelFields, VoxelGrid

    calls = []
    edt = throat.periodic_edt
    real = throat.wall_distance_voxels

    def counted(*a, **k):
        calls.append(1)
        return edt(*a, **k)

    monkeypatch.setattr(throat, "periodic_edt", counted)  # the transform, on either code
    path = tmp_path / "s.toml"
    path.write_text(ONE_FIBER.format(flow=ROUTES["voxel"][0], cap=10.0))
    assert main(["permeability", str(path), "--direction", "all", "--quiet"]) in (0, 3)
    assert "K_x" in capsys.readouterr().out
    assert len(calls) == 1

    d = np.linspace(-2e-6, 3e-6, 6 * 7 * 8, dtype=np.float32).reshape(6, 7, 8)
    grid = VoxelGrid.from_voxel(np.array([6e-6, 7e-6, 8e-6]), 1e-6)
    fields = VoxelFields(distance=d, count=np.zeros(d.shape, np.uint8), grid=grid)
    first = fields.wall_distance
    assert fields.wall_distance is first and len(calls) == 2
    assert np.array_equal(first, real(d, 1e-6)) and not first.flags.writeable
    held = weakref.ref(first)
    del fields, first
    gc.collect()
    assert held() is None  # not held once the grid is freed


def test_the_command_lines_solver_decides_the_checks(tmp_path, capsys):
    """A spec written for the FEM with a 0.01 GB cap (its stuffing solve needs 0.391 GB) run
    with ``--solver voxel`` (1.06e-3 GB) was refused by the FEM's check, naming
    flow.lattice_step, a key of a route not taken; the spec is now validated with the chosen
    solver, and the FEM run of the same spec is still refused."""
    path = tmp_path / "s.toml"
    path.write_text(ONE_FIBER.format(flow=ROUTES["stuffing"][0], cap=0.01))
    args = ["permeability", str(path), "--quiet", "--no-error-estimate"]
    assert main([*args, "--solver", "voxel"]) in (0, 3)  # finished
    assert "solver voxel" in capsys.readouterr().out
    assert main(args) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "flow.max_memory_gb" in line and line.endswith("a coarser flow.lattice_step)")


#: Parameters swept in :func:`test_a_studys_cap_refusal_names_the_key_its_file_holds`: one that
#: leaves the route's resolution key in the base, and the route's resolution key itself.
SWEEPS = {
    "voxel": ('"rve.voxel" = [1e-6, 0.8e-6]', "a coarser {}rve.voxel"),
    "stuffing": ('"flow.lattice_step" = [2e-6, 1.5e-6]', "a coarser {}flow.lattice_step"),
    "pytetwild": ('"flow.edge_length" = [0.2, 0.1]', "a longer {}flow.edge_length"),
}


@pytest.mark.parametrize("swept", [False, True])
@pytest.mark.parametrize("route", sorted(ROUTES))
def test_a_studys_cap_refusal_names_the_key_its_file_holds(route, swept, tmp_path, capsys):
    """Session 42 (s42-fixes): a study whose base.flow.max_memory_gb is too small was refused
    naming base.flow.max_memory_gb, but its advice named the spec's key ('a coarser
    rve.voxel'), which a study file does not have. The advice now follows the refusal's own
    rule: base.rve.voxel, or parameters.rve.voxel where a parameter sweeps it. Exit 2, one
    line, no output folder."""
    (tmp_path / "base.toml").write_text(ONE_FIBER.format(flow=ROUTES[route][0], cap=1e-6))
    param, advice = SWEEPS[route] if swept else ('"flow.pressure_drop" = [1.0, 2.0]', "")
    advice = advice or ROUTES[route][1].replace(" flow.", " {}flow.").replace(" rve.", " {}rve.")
    solver = "voxel" if route == "voxel" else "fem"
    (tmp_path / "study.toml").write_text(
        f'base = "base.toml"\n[study]\nname = "cap"\noutputs = ["k_z"]\nsolver = "{solver}"\n'
        f"seeds = [1]\n[parameters]\n{param}\n"
    )
    out = tmp_path / "out"
    assert main(["study", "run", str(tmp_path / "study.toml"), "-o", str(out)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("psdesign: error: base.flow.max_memory_gb: the "), line
    want = advice.format("parameters." if swept else "base.")
    assert line.endswith(f", or {want})"), line
    assert not out.exists()


#: Study refusals whose advice names a second key (session 43): the base (a spec with one
#: 6 um fibre, or a generated one), the parameter swept, and the line's ending with the second
#: key spelled as the study file holds it.
ADVICE = {
    "mesher": (
        '[flow]\nsolver = "fem"\nmesher = "pytetwild"\nbc = "periodic"\n',
        '"flow.pressure_drop" = [1.0, 2.0]',
        "base.flow.mesher: pytetwild cannot mesh with base.flow.bc = 'periodic' (no matching "
        "opposite faces) (allowed: stuffing with base.flow.bc = 'periodic', or "
        "base.flow.bc = 'permeameter')",
    ),
    "mesher swept": (
        '[flow]\nsolver = "fem"\nmesher = "pytetwild"\n',
        '"flow.bc" = ["periodic", "permeameter"]',
        "parameters.flow.bc: level 'periodic' gives flow.mesher: pytetwild cannot mesh with "
        "parameters.flow.bc = 'periodic' (no matching opposite faces) (allowed: stuffing with "
        "parameters.flow.bc = 'periodic', or parameters.flow.bc = 'permeameter')",
    ),
    "method": (
        "[[fibers]]\ndiameter = 6e-6\n[generator]\nn_fibers = 2\ndiameter = 6e-6\n"
        '[intersections]\nmethod = "ga"\nmin_gap = 1e-6\n',
        '"generator.n_fibers" = [2, 3]',
        "base.intersections.min_gap: only used with base.intersections.method = 'fast' "
        "(allowed: base.intersections.method = 'fast')",
    ),
}


@pytest.mark.parametrize("case", sorted(ADVICE))
def test_a_studys_refusal_spells_its_advice_keys_as_its_file_does(case, tmp_path, capsys):
    """Session 42 re-spelled a memory refusal's advice key (base.rve.voxel); the other
    refusals' advice still named keys as a spec file holds them ('bc = 'periodic'', 'method =
    'fast''), which a study file has as base.flow.bc or parameters.flow.bc. Exit 2, one line,
    no output folder. Old code: 'cannot mesh with bc = 'periodic'', 'only used with method =
    'fast''."""
    base, param, want = ADVICE[case]
    if "[[fibers]]" not in base:
        base = "[[fibers]]\ndiameter = 6e-6\n" + base
    (tmp_path / "base.toml").write_text(
        "[rve]\nsize = [20e-6, 20e-6, 20e-6]\nvoxel = 1e-6\n" + base
    )
    (tmp_path / "study.toml").write_text(
        'base = "base.toml"\n[study]\nname = "advice"\noutputs = ["k_z"]\nsolver = "fem"\n'
        f"seeds = [1]\n[parameters]\n{param}\n"
    )
    out = tmp_path / "out"
    assert main(["study", "run", str(tmp_path / "study.toml"), "-o", str(out)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == f"psdesign: error: {want}"
    assert not out.exists()


def test_a_study_spells_a_key_inside_a_table_parameter_and_a_list_element():
    """The rule behind the advice: a key a table parameter holds is that parameter's, one
    element of a list key swept is the element's parameter, any other key the base's."""
    from psdesign.study.studyfile import study_key

    assert study_key("rve.voxel", ["rve"]) == "rve.voxel in parameters.rve"
    assert study_key("image.crop", ["image.crop.2"]) == "parameters.image.crop.2"
    assert study_key("flow.lattice_step", ["rve.voxel"]) == "base.flow.lattice_step"


#: One 6 um fibre along x at z = 7 um in a 20 um cube. With the default period (the box) its
#: end planes along z match: periodic, one period per copy, so "auto" stacks 2 copies along z.
#: With a 30 um period they differ (7 um and 13 um from the axis): not periodic, 1 copy.
OFF_CENTRE = (
    "[rve]\nsize = [20e-6, 20e-6, 20e-6]\nvoxel = 1e-6\n{period}[[fibers]]\ndiameter = 6e-6\n"
    "direction = [1, 0, 0]\ncenter = [10e-6, 10e-6, 7e-6]\n[flow]\n{flow}max_memory_gb = {cap}\n"
)
#: Caps between the one-copy and the two-copy need (session 42, benchmarks/RESULTS.md).
#: Stuffing at a 1.5 um lattice (session 54: at the default 2 um the estimate's 0.35 GB base
#: leaves no cap between one and two copies, 0.435 / 0.499 GB): up front 0.552 GB (1 copy,
#: porosity counted 1); at the plan, 2 copies at porosity 0.929: 0.705 GB. 0.55 GB: 1.25 x
#: 0.55 = 0.6875 is over 0.552 and under 0.705, and the one-copy solve's own estimate (its
#: built mesh has fewer tets than counted up front) is under 0.55. (Session 42, 2 um: 0.278 /
#: 0.391 GB, 0.270 / 0.375 GB at the plan, cap 0.29 GB; the one-copy run's peak RSS 0.33 GB,
#: over its estimate then.) Voxel (16 B of fields, 116 B of solver per solved cell, reservoirs
#: 2 x 0.2 of one copy): 8000 x (16 + 116 x 1.4) B = 1.43e-3 GB for one copy, 8000 x (16 + 116
#: x 2.4) = 2.36e-3 GB for two; 1.8e-3 GB (x 1.25 = 2.25e-3).
BETWEEN = {
    "stuffing": ('solver = "fem"\nlattice_step = 1.5e-6\n', 0.55),
    "voxel": ('solver = "voxel"\nbc = "permeameter"\n', 1.8e-3),
}


@pytest.mark.parametrize("route", sorted(BETWEEN))
def test_a_cap_between_one_and_two_copies_runs_where_auto_stacks_one(
    route, tmp_path, capsys, monkeypatch
):
    """Session 42 (s42-fixes): the stuffing route's up-front cap counted "auto" as 2 copies on
    every spec, so a cap between the one- and two-copy needs refused a non-periodic RVE (which
    stacks one) before any work (exit 2, 'needs about 0.391 GB'); the run fits (solve estimate
    0.278 GB, peak RSS 0.33 GB). Now it runs; the periodic one-period RVE, where "auto" stacks
    two, is refused once the stack is planned, before it is meshed or solved. The voxel route
    counted "auto" as one copy and, the solver taking no cap, solved the periodic RVE's two
    copies over the cap (exit 0): now refused the same way."""
    flow, cap = BETWEEN[route]
    args = ["--direction", "z", "--quiet", "--no-error-estimate", "--json"]
    path = tmp_path / "np.toml"
    path.write_text(OFF_CENTRE.format(period="period = 30e-6\n", flow=flow, cap=cap))
    assert main(["permeability", str(path), *args]) in (0, 3)  # finished
    out = capsys.readouterr().out
    assert '"permeameter_copies": 1' in out and '"geometry_periodic_along_flow": false' in out

    from psdesign.flow import fem as fem_route
    from solvers import voxel_stokes

    def boom(*a, **k):
        raise AssertionError("meshed or solved although the planned stack is over the cap")

    monkeypatch.setattr(fem_route, "fem_mesh", boom)
    monkeypatch.setattr(voxel_stokes, "solve_voxel_stokes", boom)
    path = tmp_path / "p.toml"
    path.write_text(OFF_CENTRE.format(period="", flow=flow, cap=cap))
    fields = tmp_path / "fields"
    assert main(["permeability", str(path), *args, "--fields", str(fields)]) == 2
    (line,) = [x for x in capsys.readouterr().err.splitlines() if "error" in x]
    assert line.startswith("psdesign: error: flow.max_memory_gb: the "), line
    assert f"over the cap of {cap:.3g} GB" in line, line
    assert not fields.exists()


def test_the_caps_documented_text_says_when_the_auto_stack_is_checked():
    """Session 42 (s42-fixes) checks the stack "auto" plans (two copies of a periodic
    one-period RVE) once the RVE is built (test above), but the key's description, which
    docs/spec-keys.md's table and every out-of-range line print, still said 'checked before
    any work' alone (review s42-review). Session 43 counts explicit fibers' planned stack
    before any work; the text says which stacks wait for the built RVE."""
    from pathlib import Path

    from psdesign.schema.flow import FlowTable

    text = FlowTable.model_fields["max_memory_gb"].description
    assert "of a generated RVE once built" in text, text
    table = (Path(__file__).resolve().parents[2] / "docs" / "spec-keys.md").read_text()
    (row,) = [ln for ln in table.splitlines() if ln.startswith("| `flow.max_memory_gb` |")]
    assert text in row


def test_the_voxel_cap_refusal_names_the_direction_it_counted(tmp_path, capsys, monkeypatch):
    """Since s44-polish the voxel estimate counts the grid of the direction solved (a
    permeameter's whole-cell reservoirs): a 24 x 12 x 8 um box at 1 um holds 24x12x12 = 3456
    cells along z and 34x12x8 = 3264 along x (spied on solvers.voxel_stokes._setup_grid,
    benchmarks/RESULTS.md "Session 44 ... s44-review2"), so a cap between the two refuses z
    and accepts x. The refusal said "the voxel solve of the 24x12x8 grid" for both (session
    44 review2); it names the direction now, or the least of the three for a spec checked
    alone (no direction pinned), and so does the budget's refusal of the grid."""
    b = budget.VOXEL_SOLVER_BYTES_PER_VOXEL
    fields = 2304 * budget.GEOMETRY_BYTES_PER_VOXEL
    along_z, along_x = fields + 3456 * b, fields + 3264 * b
    cap = (along_z + along_x) / 2 / budget.CAP_MARGIN / 1e9
    text = (
        "[rve]\nsize = [24e-6, 12e-6, 8e-6]\nvoxel = 1e-6\n[[fibers]]\ndiameter = 3e-6\n[flow]\n"
        'solver = "voxel"\nbc = "permeameter"\npermeameter_copies = 1\n'
    )
    path = tmp_path / "s.toml"
    path.write_text(text + f"max_memory_gb = {cap!r}\n")
    for direction in ("z", "y"):
        assert main(["permeability", str(path), "--quiet", "--direction", direction]) == 2
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert f"the voxel solve of the 24x12x8 grid (counted along {direction}) needs" in line
    import tomllib

    doc = tomllib.loads(text + f"max_memory_gb = {0.9 * along_x / 1.25e9!r}\n")
    with pytest.raises(SpecError) as ei:
        validate_spec(doc)
    assert "24x12x8 grid (counted along the least of x, y, z) needs" in ei.value.message
    monkeypatch.setattr(budget, "machine_memory", lambda: 2 * fields)  # the budget's refusal
    with pytest.raises(SpecError) as ei:
        validate_spec(tomllib.loads(text))
    assert "B each with solver 'voxel', counted along the least of x, y, z)" in ei.value.message


def test_a_voxel_route_keeps_a_pytetwild_mesher_with_the_periodic_bc():
    """The voxel solver meshes nothing: a table written for the FEM with mesher = "pytetwild"
    and bc = "periodic" is the voxel route's to solve. Session 49's review: once checked_flow
    ran the whole table through the schema, ``permeability_both_bc(..., "voxel")`` lost its
    periodic K to "flow.mesher: pytetwild cannot mesh with flow.bc = 'periodic'" (b74d15a solved
    it, K 2.1678e-11 m^2). The FEM still refuses it."""
    flow = {"mesher": "pytetwild", "bc": "periodic"}
    assert P.checked_flow(flow, "voxel")["mesher"] == "pytetwild"
    with pytest.raises(SpecError, match=r"^flow\.mesher: pytetwild cannot mesh"):
        P.checked_flow(flow, "fem")
