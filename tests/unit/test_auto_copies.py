"""``permeameter_copies = "auto"`` lengthens the stack while the window term is above 1 %.

The rule (:func:`psdesign.flow.stack.next_auto_copies`) and its loop
(:func:`psdesign.flow.permeability.auto_lengthen`) on stand-in route results whose window terms
are those measured on ``studies/examples/three_rods.toml`` (``docs/permeability.md``, "Two copies
are not always enough": FEM 10.0 / 1.9 / 0.4 %, voxel 5.5 / 1.2 / 0.3 % with 2 / 3 / 4 copies).
The window term is ``2.5 |dp_alt / dp - 1|`` (:func:`psdesign.flow.error.window_rel_error`), so a
stand-in with ``dp = 1`` and ``dp_alt = 1 + w / 2.5`` has term ``w`` (its reach term is ~0 here).
"""

from __future__ import annotations

import pytest

from psdesign.flow import permeability as perm
from psdesign.flow.error import window_of
from psdesign.flow.stack import AUTO_MAX_COPIES, next_auto_copies
from psdesign.geometry.fibers import make_fiber
from psdesign.geometry.rve import RVE
from psdesign.schema import budget

FEM_WINDOW = {2: 0.100, 3: 0.019, 4: 0.004}
VOXEL_WINDOW = {2: 0.055, 3: 0.012, 4: 0.003}


def _rve() -> RVE:
    import numpy as np

    fib = make_fiber(
        "cylinder", diameter=0.2, center=np.array([0.5, 0.5, 0.5]), theta=None, omega=None,
        direction=[1, 0, 0], u=0.0, f=1.0, isovalue=None,
    )  # fmt: skip
    return RVE(size=np.full(3, 20e-6), fibers=[fib])


def _stub(windows: dict, solver: str, calls: list):
    """A route_result stand-in: the result of ``flow["permeameter_copies"]`` copies (auto: 2)."""

    def route(rve, fields, direction, flow, solver_, progress=None, capture=None):
        copies = flow.get("permeameter_copies", "auto")
        copies = 2 if copies in (None, "auto") else int(copies)
        calls.append(dict(flow))
        res = {
            "bc": "permeameter",
            "solver": solver,
            "direction": "z",
            "geometry_periodic_along_flow": True,
            "permeameter_copies": copies,
            "permeability_m2": 1e-12 * (1 + 0.01 * copies),
            "porosity": 0.9,
            "pressure_drop_rve_pa": 1.0,
            "pressure_drop_plane_window_pa": 1.0 + windows[copies] / 2.5,
            "rve_length_m": 1.0,  # R / L ~ 1e-6: no reach term
            "n_points": 1000,
            "n_tets": 5000,
            "mesh_quality": {"lattice_step_m": 4e-6},
            "warnings": [],
        }
        if capture is not None:  # as the routes do: the solve's fields, then the result
            capture("voxel_flow", solution=f"solution of {copies} copies", result=res)
        return res

    return route


def _run(monkeypatch, windows, solver="voxel", flow=None):
    calls: list = []
    monkeypatch.setattr(perm, "route_result", _stub(windows, solver, calls))
    rve = _rve()
    flow = {"bc": "permeameter", "aux_length": 0.2} | (flow or {})
    first = perm.route_result(rve, None, "z", flow, solver)
    fields = rve.voxelize(2e-6)
    res, used = perm.auto_lengthen(rve, fields, "z", flow, solver, first)
    return res, used, calls


def test_the_rule():
    r = {"bc": "permeameter", "geometry_periodic_along_flow": True, "permeameter_copies": 2}
    assert next_auto_copies("auto", r, 0.0101) == (3, "window")
    assert next_auto_copies(None, r, 0.01) == (None, "converged")  # at the threshold: stays
    assert next_auto_copies(3, r, 0.5) == (None, "fixed")
    assert next_auto_copies("auto", {**r, "bc": "periodic"}, 0.5) == (None, "fixed")
    assert next_auto_copies("auto", {**r, "geometry_periodic_along_flow": False}, 0.5) == (
        None,
        "not periodic",
    )
    last = {**r, "permeameter_copies": AUTO_MAX_COPIES}
    assert next_auto_copies("auto", last, 0.5) == (None, "max")
    # an array of two cells (auto: 1 copy) is not stacked: its window is exact (the term is the
    # a-priori reach part there; validation_cylinders: 2.8 %, a second copy moved K by 0.03 %)
    array = {**r, "permeameter_copies": 1, "periods_per_copy": 2}
    assert next_auto_copies("auto", array, 0.028) == (None, "periods")


@pytest.mark.parametrize(("solver", "windows"), [("fem", FEM_WINDOW), ("voxel", VOXEL_WINDOW)])
def test_three_rods_windows_take_four_copies(monkeypatch, solver, windows):
    res, used, calls = _run(monkeypatch, windows, solver)
    assert res["permeameter_copies"] == 4
    tries = res["permeameter_auto"]["tries"]
    assert [t["copies"] for t in tries] == [2, 3, 4]
    assert [t["window"] for t in tries] == pytest.approx([windows[c] for c in (2, 3, 4)])
    assert res["permeameter_auto"]["stopped"] == "converged"
    assert used["permeameter_copies"] == 4  # the error bar's coarse solve uses the final stack
    assert not any("stopped at" in w for w in res["warnings"])
    if solver == "fem":  # the FEM keeps the first solve's default lattice step
        assert [c.get("lattice_step") for c in calls] == [None, 4e-6, 4e-6]


def test_below_the_threshold_one_solve(monkeypatch):
    res, used, calls = _run(monkeypatch, {2: 0.0042})  # quickstart's FEM term at 2 copies
    assert len(calls) == 1 and res["permeameter_copies"] == 2
    assert res["permeameter_auto"] == {
        "tries": [{"copies": 2, "permeability_m2": 1.02e-12, "window": pytest.approx(0.0042)}],
        "stopped": "converged",
    }


@pytest.mark.parametrize(("periodic", "copies"), [(True, 2), (False, 1)])
def test_coarse_solve_gets_the_final_copies_without_lengthening(monkeypatch, periodic, copies):
    """``"auto"`` stopped at its first solve (window term converged, or one copy of a geometry
    that is not periodic along the flow): the error bar's coarse solve is pinned to that solve's
    copies, not re-planned on the coarser grid. Re-planned, rev_toray's RVE (end planes 0.46 um
    apart: 0.55 voxel at 0.833 um, one copy; 0.28 voxel on the 1.67 um coarse grid, two copies)
    had its bar from two different samples (docs/solver-agreement.md)."""
    calls: list = []
    stub = _stub({2: 0.0042}, "voxel", calls)

    def route(*args, **kwargs):
        res = stub(*args, **kwargs)
        if not periodic:
            res |= {"geometry_periodic_along_flow": False, "permeameter_copies": 1}
        return res

    monkeypatch.setattr(perm, "route_result", route)
    rve = _rve()
    flow = {"bc": "permeameter", "aux_length": 0.2}
    first = perm.route_result(rve, None, "z", flow, "voxel")
    res, used = perm.auto_lengthen(rve, rve.voxelize(2e-6), "z", flow, "voxel", first)
    assert len(calls) == 1
    assert res["permeameter_auto"]["stopped"] == ("converged" if periodic else "not periodic")
    assert used["permeameter_copies"] == copies
    assert flow.get("permeameter_copies") is None  # the caller's table is not changed


def test_explicit_copies_are_kept(monkeypatch):
    res, used, calls = _run(monkeypatch, FEM_WINDOW, flow={"permeameter_copies": 2})
    assert len(calls) == 1 and "permeameter_auto" not in res and used["permeameter_copies"] == 2


def test_max_copies_warns(monkeypatch):
    res, _, calls = _run(monkeypatch, {2: 0.2, 3: 0.1, 4: 0.05})
    assert res["permeameter_copies"] == 4 and len(calls) == 3
    assert res["permeameter_auto"]["stopped"] == "max"
    (w,) = [w for w in res["warnings"] if "stopped at" in w]
    assert "4 copies" in w and "5.0 %" in w and "flow.permeameter_copies" in w


def test_budget_stops_and_names_the_key(monkeypatch):
    # the first solve fits; 3 copies of the 10^3 grid would not in a 1.5 x 2-copy budget
    two = budget.grid_bytes([10, 10, 10], "voxel", 2, {"aux": 0.2})
    monkeypatch.setattr(budget, "machine_memory", lambda: 2 * 1.2 * two)
    res, _, calls = _run(monkeypatch, VOXEL_WINDOW)
    assert len(calls) == 1 and res["permeameter_auto"]["stopped"] == "budget"
    (w,) = [w for w in res["warnings"] if "stopped at" in w]
    assert "2 copies" in w and "3 would need" in w and "flow.permeameter_copies" in w


def test_restack_bytes_scales_the_fem_mesh():
    from solvers.fem.memory import estimate_memory_gb

    r = {"solver": "fem", "permeameter_copies": 2, "n_points": 1000, "n_tets": 5000}
    assert budget.restack_bytes(r, 3, [0, 0, 0], 0.2) == pytest.approx(
        estimate_memory_gb(1500, 7500) * 1e9
    )
    assert budget.restack_bytes({"solver": "voxel"}, 4, [20] * 3, 0.2) == pytest.approx(
        budget.grid_bytes([20] * 3, "voxel", 4, {"aux": 0.2})
    )


def test_window_of_is_the_error_bars_term():
    r = {"permeability_m2": 1e-12, "porosity": 0.9, "pressure_drop_rve_pa": 1.0}
    r |= {"pressure_drop_plane_window_pa": 1.004, "rve_length_m": 1.0}
    assert window_of(r) == pytest.approx(0.01)


def test_only_the_final_solves_fields_are_captured(monkeypatch):
    # a lengthened stack writes the fields of the solve it reports (4 copies), not of the two
    # superseded ones (they used to be written as flow_z, flow_z_2, flow_z_3)
    calls: list = []
    monkeypatch.setattr(perm, "route_result", _stub(VOXEL_WINDOW, "voxel", calls))
    seen: list = []
    flow = {"bc": "permeameter", "aux_length": 0.2}
    res = perm.permeability(
        _rve(), _rve().voxelize(2e-6), "z", flow, "voxel", error_estimate=False,
        capture=lambda kind, **kw: seen.append((kind, kw["solution"], kw["result"])),
    )  # fmt: skip
    assert len(calls) == 3 and res["permeameter_copies"] == 4
    assert [(k, s) for k, s, _ in seen] == [("voxel_flow", "solution of 4 copies")]
    assert seen[0][2] is res


@pytest.mark.parametrize("solver", ["voxel", "fem"])
def test_the_memory_cap_stops_the_stack_too(monkeypatch, solver):
    """session 41 (s41-routes): "auto" checked a longer stack against half the machine only.
    Under flow.max_memory_gb the FEM's 3-copy solve refused the cap after the 2-copy solve's
    work (exit 2, no K); the voxel route's went over it without a word. Now the stack stops
    at the cap, names it and keeps the 2-copy result. The 3-copy estimate (restack_bytes, the
    estimate each solve's own check uses) is over CAP_MARGIN times the cap (session 43: the
    rule of every cap check, budget.fits_cap)."""
    first = {"solver": solver, "permeameter_copies": 2, "n_points": 1000, "n_tets": 5000}
    three = budget.restack_bytes(first, 3, [10] * 3, 0.2)
    cap = 0.99 * three / budget.CAP_MARGIN  # bytes (the 2-copy solve is the stub's)
    res, _, calls = _run(monkeypatch, VOXEL_WINDOW, solver, {"max_memory_gb": cap / 1e9})
    assert len(calls) == 1 and res["permeameter_auto"]["stopped"] == "max_memory_gb"
    (w,) = [w for w in res["warnings"] if "stopped at" in w]
    assert "2 copies" in w and "over flow.max_memory_gb" in w and "flow.permeameter_copies" in w


def test_a_stack_within_the_cap_margin_is_solved(monkeypatch):
    """session 43: auto_lengthen stopped at 1.0 x flow.max_memory_gb while the up-front checks
    (check_cap, check_planned_stack) allow CAP_MARGIN = 1.25 x; one rule now
    (budget.fits_cap). The 3-copy voxel stack needs 1.1 x the cap: solved (old code: stopped at
    2 copies with 'over flow.max_memory_gb'); at 1.3 x it stops, as check_cap refuses it."""
    first = {"solver": "voxel", "permeameter_copies": 2}
    three = budget.restack_bytes(first, 3, [10] * 3, 0.2)
    four = budget.restack_bytes(first, 4, [10] * 3, 0.2)
    res, _, calls = _run(monkeypatch, VOXEL_WINDOW, "voxel", {"max_memory_gb": three / 1.1 / 1e9})
    assert four > budget.CAP_MARGIN * three / 1.1  # the fourth copy is over the margin
    assert len(calls) == 2 and res["permeameter_copies"] == 3
    assert res["permeameter_auto"]["stopped"] == "max_memory_gb"
    res, _, calls = _run(monkeypatch, VOXEL_WINDOW, "voxel", {"max_memory_gb": three / 1.3 / 1e9})
    assert len(calls) == 1 and res["permeameter_copies"] == 2


def test_the_fem_solves_own_cap_refusal_keeps_the_shorter_stack(monkeypatch):
    """An FEM stack whose estimate is within the margin is meshed; the solve's own check on the
    built mesh (no margin, solvers.fem_stokes) may still refuse it: "auto" keeps the 2-copy
    result and says why, instead of exit 2 with no K."""
    from psdesign.errors import SpecError

    calls: list = []
    stub = _stub(FEM_WINDOW, "fem", calls)

    def route(rve, fields, direction, flow, solver_, progress=None, capture=None):
        if flow.get("permeameter_copies") == 3:
            raise SpecError("flow.max_memory_gb", "estimated memory 0.2 GB exceeds 0.19 GB")
        return stub(rve, fields, direction, flow, solver_, progress, capture)

    monkeypatch.setattr(perm, "route_result", route)
    rve = _rve()
    flow = {"bc": "permeameter", "aux_length": 0.2}
    first = perm.route_result(rve, None, "z", flow, "fem")
    res, used = perm.auto_lengthen(rve, rve.voxelize(2e-6), "z", flow, "fem", first)
    assert res["permeameter_copies"] == 2 and used["permeameter_copies"] == 2
    assert res["permeameter_auto"]["stopped"] == "max_memory_gb"
    (w,) = [w for w in res["warnings"] if "stopped at" in w]
    assert "3 were refused by the solve" in w and "flow.permeameter_copies" in w


def test_the_field_is_read_once_per_axis_for_the_window_and_the_bar(monkeypatch):
    """Session 53: ``auto_lengthen`` (the window term of each solve) and
    ``with_error_estimate`` (the bar) each asked whether the geometry varies along the flow,
    one ``np.ptp`` pass over the distance field each time. The fields keep the answer per axis
    now: one pass. Truth: a cylinder along x varies along z and y, not along x."""
    import numpy as np

    rve = _rve()
    fields = rve.voxelize(2e-6)
    passes: list = []
    ptp = np.ptp

    def counted(a, axis=None, **kw):
        if a is fields.distance:
            passes.append(axis)
        return ptp(a, axis=axis, **kw)

    monkeypatch.setattr(np, "ptp", counted)
    calls: list = []
    monkeypatch.setattr(perm, "route_result", _stub(VOXEL_WINDOW, "voxel", calls))
    flow = {"bc": "permeameter", "aux_length": 0.2}
    first = perm.route_result(rve, fields, "z", flow, "voxel")
    res, _ = perm.auto_lengthen(rve, fields, "z", flow, "voxel", first)
    assert res["permeameter_copies"] == 4 and len(calls) == 3
    assert fields.varies_along(2)  # as with_error_estimate asks it for the bar
    assert passes == [2]
    assert fields.varies_along(1) and not fields.varies_along(0)
    assert passes == [2, 1, 0]
