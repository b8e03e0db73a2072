"""The error bar on K (psdesign.flow.error) covers the true error: cylinder arrays with
published permeabilities (Sangani & Acrivos 1982 Table 1 across, Drummond & Tahir 1984 along,
``reference_values``), solved with the voxel route through the dispatcher."""

from __future__ import annotations

import numpy as np
import pytest
from arrays import L, along_array_k, array_spec, exact_k, radius_of

from psdesign.flow import error as err
from psdesign.flow.permeability import permeability
from psdesign.packing.build import build_rve
from psdesign.schema.spec import validate_spec

#: (array, flow, solid fraction, voxels per spacing): 13 cases, 8.6-32 voxels per fiber
#: diameter; the staircase error (-7 % ... +10 %) oscillates in sign over these.
CASES = [("square", "across", phi, n) for phi in (0.1, 0.2, 0.3, 0.4, 0.5) for n in (24, 40)] + [
    ("square", "along", phi, 32) for phi in (0.1, 0.2, 0.3)
]


#: results of the plain solves (no keyword), by case: the tests below that read a case of CASES
#: take the first test's solve (same spec, same code path, deterministic) instead of repeating it
_SOLVED: dict[tuple[str, str, float, int], tuple[dict, float]] = {}


def _solve(kind: str, flow: str, phi: float, n: int, **kw) -> tuple[dict, float]:
    if not kw and (kind, flow, phi, n) in _SOLVED:
        return _SOLVED[kind, flow, phi, n]
    spec = validate_spec(array_spec(kind, phi, n))
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    res = permeability(
        built.rve, fields, "x" if flow == "across" else "z", spec["flow"], "voxel", **kw
    )
    if not kw:
        _SOLVED[kind, flow, phi, n] = (res, exact_k(kind, flow, phi))
    return res, exact_k(kind, flow, phi)


def test_error_bar_covers_true_error_on_at_least_9_in_10_array_cases():
    covered = []
    for case in CASES:
        res, exact = _solve(*case)
        assert res["converged"]
        true = abs(res["permeability_m2"] / exact - 1.0)
        covered.append(true <= res["permeability_rel_error"])
    assert len(covered) >= 10
    assert np.mean(covered) >= 0.9, list(zip(CASES, covered, strict=True))


def test_solver_term_alone_would_not_cover():
    # a bar from the residual alone (the naive choice) misses nearly every case: the test above
    # has teeth
    misses = 0
    for case in CASES[:4]:
        res, exact = _solve(*case)
        misses += abs(res["permeability_m2"] / exact - 1.0) > res["error_estimate"]["solver"]
    assert misses >= 3


def test_result_carries_bar_status_and_resolution():
    res, _ = _solve("square", "across", 0.2, 24)
    est = res["error_estimate"]
    # analytic cylinders: sub-voxel walls, second order (staircase would be first order)
    assert res["wall_treatment"] == "subvoxel"
    assert est["method"] == "two_grid" and est["ratio"] == 2.0 and est["order"] == 2
    assert res["bc"] == "periodic"
    # D = 2 sqrt(0.2 / pi) L = 0.505 L at 24 voxels per L: 12.1 voxels across
    assert res["cells_per_diameter"] == pytest.approx(2 * np.sqrt(0.2 / np.pi) * 24, rel=1e-3)
    assert res["status"] in ("ok", "untrustworthy")
    assert res["permeability_rel_error"] == pytest.approx(
        est["discretization"] + est["solver"], rel=1e-12, abs=0
    )


def test_under_resolved_fiber_warns_and_is_untrustworthy():
    res, _ = _solve("square", "across", 0.1, 16, error_estimate=False)  # 5.7 voxels across
    assert res["cells_per_diameter"] < err.MIN_CELLS_PER_DIAMETER
    assert res["status"] == "untrustworthy"
    assert any("across the thinnest fiber" in w for w in res["warnings"])
    assert res["error_estimate"]["method"] == "resolution_only"


def test_resolution_warning_says_whether_it_rates():
    """Below 8 cells per diameter the voxel route is untrustworthy, the tet route only warned
    (its status follows its bar); the quickstart's rows read "ok" beside "only 2.4 mesh cells
    ... refine", so the FEM line says it does not rate (session 31)."""
    voxel = err.resolution_warnings(5.0, "voxel", "z")
    fem = err.resolution_warnings(2.4, "fem", "z")
    assert voxel == [
        "K_z: only 5.0 voxels across the thinnest fiber diameter (< 8); refine rve.voxel"
    ]
    assert fem == [
        "K_z: only 2.4 mesh cells across the thinnest fiber diameter (< 8); refine rve.voxel / "
        "flow.lattice_step (a warning only: the body-fitted mesh's status follows its error bar)"
    ]
    # session 40: a bar with the fibre term (tet route, fibres) covers the fibre's resolution
    # down to 1.5 cells per diameter (session 39's calibration), so no "refine" line above it
    assert err.resolution_warnings(2.4, "fem", "z", fiber_floor=True) == []
    assert err.resolution_warnings(1.4, "fem", "z", fiber_floor=True) == [
        "K_z: only 1.4 mesh cells across the thinnest fiber diameter (< 1.5); refine rve.voxel / "
        "flow.lattice_step (a warning only: the body-fitted mesh's status follows its error bar)"
    ]
    assert err.status_of(True, 0.05, None) == "ok"  # what the tet route passes: no cpd
    assert err.status_of(True, 0.05, 5.0) == "untrustworthy"


def test_richardson_and_floor_closed_forms():
    # GCI: F_s |K_h - K_H| / ((r^p - 1) K_h)
    assert err.richardson_rel_error(1.0, 1.04, 2.0, 2) == pytest.approx(3 * 0.04 / 3)
    # the floor is C_p (h / R)^p with R = sqrt(8 K / eps): Poiseuille tube of radius R
    k, eps, h = 1e-12, 0.5, 1e-7
    r = np.sqrt(8 * k / eps)
    assert err.resolution_floor(h, k, eps, 1) == pytest.approx(err.FLOOR_CONSTANT[1] * h / r)
    est = err.combine(k, eps, h, 1, 1e-6, k_coarse=1.01 * k, ratio=2.0)
    assert est.rel_error == pytest.approx(max(0.03, err.FLOOR_CONSTANT[1] * h / r) + 1e-6)
    assert err.status_of(False, 0.01, 20) == "not_converged"
    assert err.status_of(True, 0.5, 20) == "untrustworthy"
    assert err.status_of(True, 0.01, 20) == "ok"


def test_coarse_grid_keeps_cubic_voxels():
    assert err.coarse_voxel_shape((40, 40, 12)) == ((20, 20, 6), 2.0)
    assert err.coarse_voxel_shape((30, 45, 15)) == ((20, 30, 10), 1.5)
    assert err.coarse_voxel_shape((7, 5, 3)) is None


def test_failed_coarse_solve_falls_back_to_doubled_floor():
    def boom():
        raise RuntimeError("coarse lattice does not mesh")

    res = {"permeability_m2": 1e-12, "porosity": 0.5, "residual": 1e-7, "flux_imbalance": 0.0}
    est = err.estimate_with(res, 1e-7, 1, boom)
    assert est.method == "resolution_only" and "does not mesh" in est.coarse_failure
    assert est.floor == pytest.approx(2 * err.resolution_floor(1e-7, 1e-12, 0.5, 1))
    assert est.rel_error == pytest.approx(est.floor + 1e-7)


def _one_solid_voxel_k(tmp_path, upsample: int):
    """K_x of an 8^3 image (1 um voxels) whose only solid is the voxel at the origin, solved
    at ``upsample`` times finer voxels (each voxel repeated ``upsample``^3 times: the same
    geometry, a periodic array of 1 um cubes 8 um apart)."""
    import psdesign

    a = np.zeros((8, 8, 8), np.uint8)
    a[0, 0, 0] = 1
    a = np.repeat(np.repeat(np.repeat(a, upsample, 0), upsample, 1), upsample, 2)
    folder = tmp_path / f"x{upsample}"
    folder.mkdir()
    np.save(folder / "img.npy", a)
    (folder / "img.toml").write_text(
        f'[image]\npath = "img.npy"\nvoxel_size = {1e-6 / upsample!r}\n'
    )
    return psdesign.build(folder / "img.toml").permeability("x", solver="voxel")


def test_a_grid_that_loses_the_solid_when_coarsened_is_untrustworthy(tmp_path):
    """Session 37 edge audit: an image whose solid vanishes on the coarse grid of the error bar
    got the floor alone (4.8 %) and status "ok", 38 % above the same geometry solved 2x finer
    (61 % above 4x finer; the truth: the upsampled image is the same cubes, and K falls
    monotonically with refinement, 5.52 -> 4.00 -> 3.44e-11 m^2). Such a K is untrustworthy,
    as a fiber under 8 voxels across is (MIN_CELLS_PER_DIAMETER)."""
    coarse = _one_solid_voxel_k(tmp_path, 1)
    fine = _one_solid_voxel_k(tmp_path, 2)
    assert coarse.details["error_estimate"]["method"] == "resolution_only"
    miss = coarse.permeability_m2 / fine.permeability_m2 - 1.0
    assert miss == pytest.approx(0.38, abs=0.03)
    assert miss > coarse.rel_error  # the floor does not bound this error ...
    assert coarse.status == "untrustworthy"  # ... and the status says so
    assert "no solid voxel" in coarse.details["error_estimate"]["coarse_failure"]
    assert any("a phase vanishes" in w for w in coarse.details["warnings"])


def test_a_coarse_grid_that_only_closes_a_throat_keeps_the_floor():
    """The lost-phase rule is not "any coarse failure": a coarse grid that closes a gap keeps
    the doubled floor, which covers there (square array across at solid fraction 0.75, gap
    0.46 um = 1.8 voxels of 0.25 um: -14.4 % against Sangani & Acrivos, bar 17 %)."""
    est = err.estimate_with(
        {"permeability_m2": 1e-12, "porosity": 0.5, "residual": 0.0, "flux_imbalance": 0.0},
        1e-7,
        2,
        lambda: (_ for _ in ()).throw(ValueError("no percolating fluid path")),
    )
    assert not est.coarse_lost_phase
    assert err.status_of(True, 0.05, None, coarse_lost_phase=est.coarse_lost_phase) == "ok"
    assert err.status_of(True, 0.05, None, coarse_lost_phase=True) == "untrustworthy"


def _duct_k(tmp_path, a: int, b: int, lo: int):
    """K_x (m^2) of a 16^3 solid image (1 um voxels) with a straight ``a x b``-voxel duct along
    x from voxel ``lo``, and the closed form: Shah & London (1978) / White, Viscous Fluid Flow
    Eq. 3-48, ``Q mu / G = a^3 b / 12 (1 - 192 a / (pi^5 b) sum_odd tanh(n pi b / 2a) / n^5)``
    per 16 x 16 um of cross-section."""
    import math

    import psdesign

    img = np.ones((16, 16, 16), np.uint8)
    img[:, lo : lo + a, lo : lo + b] = 0
    folder = tmp_path / f"duct{a}x{b}_{lo}"
    folder.mkdir()
    np.save(folder / "img.npy", img)
    (folder / "img.toml").write_text('[image]\npath = "img.npy"\nvoxel_size = 1e-06\n')
    res = psdesign.build(folder / "img.toml").permeability("x", solver="voxel")
    h = 1e-6
    s = sum(math.tanh(n * math.pi * b / (2 * a)) / n**5 for n in range(1, 400, 2))
    q = (a * h) ** 3 * (b * h) / 12 * (1 - 192 * a / (math.pi**5 * b) * s)
    return res, q / (16 * h) ** 2


@pytest.mark.parametrize(("a", "b", "lo"), [(3, 5, 6), (3, 5, 7), (1, 1, 7)])
def test_the_bar_covers_a_duct_a_few_voxels_across(tmp_path, a, b, lo):
    """Staircase walls on the voxel faces make K of a channel a few voxels across
    second-order high with a large constant (the thin-channel term, ``THIN_CHANNEL``,
    calibrated on slits and square ducts; these rectangular ducts are not in that set):
    3x5 voxels +27.8 %, 1x1 +256 % against the closed form. Before session 38 the bars were
    22.8 / 24.2 % and 100 % (the first-order floor, R = sqrt(8 K / eps) is 2.2 and 1 voxels)."""
    res, exact = _duct_k(tmp_path, a, b, lo)
    true = res.permeability_m2 / exact - 1.0
    assert true == pytest.approx({3: 0.278, 1: 2.557}[a], abs=0.005)
    assert true <= res.rel_error
    assert res.status == "untrustworthy"


@pytest.mark.parametrize(
    ("phi", "n", "wall", "true_error"),
    [
        (0.6, 24, "subvoxel", -0.059),
        (0.5, 12, "subvoxel", -0.057),
        (0.4, 12, "staircase", 0.475),
        (0.6, 24, "staircase", 0.687),
    ],
)
def test_a_narrow_gap_result_is_covered_or_not_ok(phi, n, wall, true_error):
    """Near touching (square array across, Sangani & Acrivos 1982 Table 1; gap
    ``L (1 - 2 sqrt(phi / pi))`` = 3.0 voxels at 0.6 and 24, 2.4 at 0.5 and 12, 3.4 at 0.4 and 12) K
    goes as gap^2.5 and the gap's wall error dominates; the two grids round the gap each its own
    way and agreed by chance. Before session 38 (s38-gaps) each of these was ``ok`` outside its
    bar: -5.9 % in 5.0 %, -5.7 % in 4.8 %, +47.5 % in 19.9 %, +68.7 % in 16.8 %. The gap term
    ``C_G h / g`` (``GAP``, calibrated on other resolutions and shifts) covers them or makes
    them untrustworthy."""
    spec = array_spec("square", phi, n)
    spec["flow"] = {**spec["flow"], "wall_treatment": wall}
    spec = validate_spec(spec)
    built = build_rve(spec)
    res = permeability(built.rve, built.voxelize(spec["rve"]["voxel"]), "x", spec["flow"], "voxel")
    true = res["permeability_m2"] / exact_k("square", "across", phi) - 1.0
    assert true == pytest.approx(true_error, abs=0.002)
    assert abs(true) <= res["permeability_rel_error"] or res["status"] != "ok"
    assert res["error_estimate"]["gap"] > 0.0


def test_a_bar_past_the_limit_says_it_may_understate_the_error():
    """The bar's constants are fitted to cover the ``ok`` results only (``GAP``: the smallest
    ``C_G`` that leaves no ``ok`` result outside its bar), so a bar past 20 % is no bound: the
    square array across at solid fraction 0.7, 19 voxels per spacing (sub-voxel walls), reads
    56 % under Sangani & Acrivos 1982 Table 1 in a 36.5 % bar (session 52 walk-numbers). Its
    warning said only "estimated error 36.5 % exceeds 20 %"; it now says the bar may
    understate the error, as the lost-phase warning says its floor does not bound it."""
    res, exact = _solve("square", "across", 0.7, 19)
    true = res["permeability_m2"] / exact - 1.0
    assert true == pytest.approx(-0.56, abs=0.01)
    assert res["permeability_rel_error"] == pytest.approx(0.365, abs=0.001)
    assert abs(true) > res["permeability_rel_error"] and res["status"] == "untrustworthy"
    (line,) = [w for w in res["warnings"] if "exceeds 20 %" in w]
    assert line.startswith("K_x: estimated error 36.5 % exceeds 20 %, where the bar may ")
    assert "understate the error" in line and "rve.voxel" in line
    # an ok result's warnings are as before: no such line
    res, _ = _solve("square", "across", 0.3, 24)
    assert res["status"] == "ok" and not any("understate" in w for w in res["warnings"])


def test_a_bar_made_by_the_window_term_advises_a_longer_rve_not_a_finer_grid():
    """Review B (session 52): the past-the-limit line always said "refine the grid", also where
    the permeameter's window term ``C_R (R/L)^2`` makes the bar, which no grid refinement
    shrinks (the next line said to lengthen the RVE). One cylinder at solid fraction 0.02 in a
    40 um square cell 8.125 um deep, 64 voxels per period, a one-copy voxel permeameter across
    it: bar 65.1 %, window 64.7 % (the reviewer's case). The line gives the window's advice."""
    import psdesign

    phi, side = 0.02, 40e-6
    spec = {
        "rve": {"size": [side, side, 8.125e-6], "voxel": side / 64},
        "fibers": [
            {
                "shape": "cylinder",
                "diameter": float(2 * side * np.sqrt(phi / np.pi)),
                "center": [side / 2, side / 2, 4e-6],
                "direction": [0, 0, 1],
            }
        ],
        "flow": {"permeameter_copies": 1},
    }
    r = psdesign.build(spec).permeability("x", solver="voxel", bc="permeameter")
    window = r.details["error_estimate"]["window"]
    assert r.status == "untrustworthy" and window >= r.rel_error / 2 and r.rel_error > 0.2
    (line,) = [w for w in r.details["warnings"] if "exceeds 20 %" in w]
    assert line.endswith("lengthen the RVE along the flow or use bc = 'periodic'")
    assert "refine the grid" not in line


def test_a_permeameter_along_cylinders_gets_no_entrance_reach_term():
    """Square array along the cylinders, solid fraction 0.1, 24 voxels per spacing, one
    diameter long (the reviewer's case, session 52 walk-numbers finding 4): the geometry does
    not vary along the flow, so the window's a-priori reach term ``C_R (R / L)^2`` (calibrated
    across arrays; along them measured at most 0.003 of ``(R / L)^2``, ``WINDOW_REACH``) is
    dropped and the window term is the measured gap of the two windowed drops alone. Truth:
    Sparrow & Loeffler 1959's collocation series (``arrays.along_array_k``). Before: +0.6 % in
    a 63.4 % bar (window 62.1 %), untrustworthy, exit 3; now covered by a 4.4 % bar, ok."""
    spec = validate_spec(array_spec("square", 0.1, 24))
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    assert [fields.varies_along(a) for a in range(3)] == [True, True, False]
    flow = {**spec["flow"], "bc": "permeameter"}
    res = permeability(built.rve, fields, "z", flow, "voxel")
    a = radius_of(0.1, "square") * L
    true = res["permeability_m2"] / (along_array_k(0.1, "square") * a * a) - 1.0
    assert true == pytest.approx(0.006, abs=0.002)
    gap = abs(res["pressure_drop_plane_window_pa"] / res["pressure_drop_rve_pa"] - 1.0)
    assert res["error_estimate"]["window"] == pytest.approx(err.WINDOW_SAFETY * gap, rel=1e-12)
    assert res["error_estimate"]["window"] < 0.05
    assert abs(true) <= res["permeability_rel_error"] < err.UNTRUSTWORTHY_REL_ERROR
    assert res["status"] == "ok"
    # the reach term stays where the geometry varies along the flow (the calibration's regime)
    r = {**res, "rve_length_m": res["rve_length_m"] / 100}
    assert (
        err.window_of(r)
        > err.window_of(r, varies_along_flow=False)
        == res["error_estimate"]["window"]
    )


def test_an_image_gets_no_gap_term_an_analytic_rve_does(tmp_path):
    """The gap term bounds a wall the grid misplaces; a segmented image's walls are its voxel
    faces (its thin channels have the thin-channel term): a 3-voxel slit through a 16^3 image
    has no gap term, while the same slit between analytic walls would (throat 3 voxels)."""
    img = np.ones((16, 16, 16), np.uint8)
    img[:, 6:9, :] = 0
    np.save(tmp_path / "slit.npy", img)
    spec = validate_spec({"image": {"path": str(tmp_path / "slit.npy"), "voxel_size": 1e-6}})
    built = build_rve(spec)
    res = permeability(built.rve, built.voxelize(1e-6), "x", spec["flow"], "voxel")
    assert res["error_estimate"]["gap"] == 0.0 and res["error_estimate"]["throat_m"] is None
    spec = validate_spec(array_spec("square", 0.6, 24))
    built = build_rve(spec)
    res = permeability(built.rve, built.voxelize(spec["rve"]["voxel"]), "x", spec["flow"], "voxel")
    assert res["error_estimate"]["throat_m"] / spec["rve"]["voxel"] == pytest.approx(2.5, abs=0.1)


@pytest.mark.parametrize(("phi", "n"), [(0.6, 24), (0.7, 12)])
def test_flow_along_near_touching_fibres_gets_no_gap_term(phi, n):
    """Along straight fibres the flow runs through the widest pore: no throat limits it and a
    wall error in the gap between fibres moves K little (Sparrow & Loeffler 1959's series,
    ``tests/arrays.py``). Before s38-femgap the gap term set the along bar anyway, from the
    widest pore's width (square 0.6 at 24 voxels: throat 12.2 voxels, bar 1.64 %; 0.7 at 12:
    5.1 voxels, 3.93 %); now no throat is found along (``throat_m`` None), the bar is the
    two-grid / floor bar (1.54 %, 3.74 %) and still covers the true error (-0.07 %, -1.26 %).
    The same array across keeps its term (throat 2.5 voxels at 0.6 and 24)."""
    spec = validate_spec(array_spec("square", phi, n))
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    res = permeability(built.rve, fields, "z", spec["flow"], "voxel")
    est = res["error_estimate"]
    assert est["gap"] == 0.0 and est["throat_m"] is None
    a = radius_of(phi, "square") * L
    true = res["permeability_m2"] / (along_array_k(phi, "square") * a * a) - 1.0
    assert abs(true) <= res["permeability_rel_error"]
    assert res["status"] == "ok"


@pytest.mark.parametrize(
    ("solver", "phi", "cells", "true_error"),
    [
        ("fem", 0.6, 24, -0.0056),
        pytest.param("fem", 0.7, 48, -0.0022, marks=pytest.mark.slow),  # 24 s, 1.2 GB
        ("diffuse", 0.5, 24, -0.0174),
    ],
)
def test_tet_and_diffuse_near_touching_are_covered_without_a_gap_term(
    solver, phi, cells, true_error
):
    """Square arrays across near touching (Sangani & Acrivos 1982 Table 1; gap 0.126 L at 0.6,
    0.056 L at 0.7, 0.202 L at 0.5) on the routes without a gap term (session 38, s38-femgap,
    ``benchmarks/narrow_gap_bar.py --set fem2 / diffuse``): the tet route (stuffing mesher,
    ``lattice_step`` L / cells, the field at 2 voxels per step; the gap 3.0 and 2.7 lattice
    steps) and the diffuse wall (``cells`` voxels per spacing, gap 4.9 voxels). Their floors
    ``C (h / R)^2`` grow as the gap closes: the true error is inside the bar (7.6 %, 11.0 %,
    19.1 %) with no ``gap`` term."""
    spec = array_spec("square", phi, 2 * cells if solver == "fem" else cells)
    flow = {**spec["flow"], "bc": "periodic"}
    if solver == "fem":
        flow["lattice_step"] = L / cells
    else:
        flow["wall_treatment"] = "diffuse"
    spec["flow"] = flow
    spec = validate_spec(spec)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    res = permeability(built.rve, fields, "x", spec["flow"], "fem" if solver == "fem" else "voxel")
    true = res["permeability_m2"] / exact_k("square", "across", phi) - 1.0
    assert true == pytest.approx(true_error, abs=0.001)
    assert abs(true) <= res["permeability_rel_error"] <= err.UNTRUSTWORTHY_REL_ERROR
    assert res["status"] == "ok" and res["error_estimate"]["gap"] == 0.0


def _tet_array(kind: str, phi: float, voxels: int, cells: float, shift: float = 0.0, **kw):
    """The tet route (stuffing mesher, ``lattice_step`` L / cells, periodic) on one cell of
    the array across (flow along x), its cylinders shifted by ``shift`` lattice steps along x
    and y: (result, true relative error)."""
    spec = array_spec(kind, phi, voxels)
    for fb in spec["fibers"]:
        c = fb["center"]
        fb["center"] = [c[0] + shift * L / cells, c[1] + shift * L / cells, c[2]]
    spec["flow"] = {**spec["flow"], "bc": "periodic", "lattice_step": L / cells}
    spec = validate_spec(spec)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    res = permeability(built.rve, fields, "x", spec["flow"], "fem", **kw)
    return res, res["permeability_m2"] / exact_k(kind, "across", phi) - 1.0


def _r_term(res: dict) -> float:
    """The flow term ``C_R (h / R)^2`` of a tet result's floor (``FLOOR["tet"]``)."""
    q, c = err.FLOOR["tet"]
    step = res["mesh_quality"]["lattice_step_m"]
    return c * (step / err.flow_length_scale(res["permeability_m2"], res["porosity"])) ** q


def test_tet_fibre_floor_covers_a_chance_agreement_the_flow_term_would_miss():
    """The tet floor is ``max(0.2 (h / R)^2, 0.27 (h / D)^2)`` (session 39, s39-tetfloor,
    ``benchmarks/tet_floor.py``): in a dilute array the error follows the fibre's resolution
    ``h / D``, not the flow's. The hexagonal array across at solid fraction 0.1 (Drummond &
    Tahir 1984, the triangular array's series, ``reference_values.drummond_tahir_hex_transverse``),
    41 voxels per spacing (cell width within 0.02 % of sqrt(3) L), lattice L / 20.5 (6.8 cells
    per diameter, h / R = 0.088) has its two lattices agree by chance: true error -0.28 %,
    Richardson term 0.20 %; the flow term 0.2 (h / R)^2 = 0.16 % would miss it, the fibre term
    0.27 / 6.8^2 = 0.58 % covers it."""
    res, true = _tet_array("hex", 0.1, 41, 20.5)
    est = res["error_estimate"]
    assert true == pytest.approx(-0.0028, abs=0.0005)
    assert est["method"] == "two_grid" and est["richardson"] < abs(true)  # chance agreement
    assert abs(true) <= res["permeability_rel_error"] and res["status"] == "ok"
    assert _r_term(res) + est["solver"] < abs(true)  # the flow term alone would not cover it
    assert est["floor"] == pytest.approx(0.27 / 6.8**2, rel=0.01)  # D / h = 6.8 lattice steps
    assert est["fiber_floor"] == est["floor"]  # the JSON says which term set it


def test_tet_fibre_floor_alone_covers_a_dilute_array_without_a_second_lattice():
    """``flow.error_estimate = false`` (or a coarse lattice that fails to mesh) leaves the tet
    route the doubled floor alone (session 39, s39-tetfloor): the square array across at solid
    fraction 0.05 (Sangani & Acrivos 1982 Table 1, L^2 / K = 15.56), lattice L / 12 (3.0 cells
    per diameter, the default rule's D / 3) shifted by a quarter step: true error -0.93 %; the
    doubled flow term 2 x 0.2 (h / R)^2 = 0.52 % would miss it, the doubled fibre term 2 x 0.27 /
    3^2 = 6.0 % covers it."""
    res, true = _tet_array("square", 0.05, 24, 12, shift=0.25, error_estimate=False)
    est = res["error_estimate"]
    assert true == pytest.approx(-0.0093, abs=0.001)
    assert est["method"] == "resolution_only"
    assert abs(true) <= res["permeability_rel_error"] and res["status"] == "ok"
    assert 2 * _r_term(res) + est["solver"] < abs(true)  # the flow term alone would not


def test_tet_floor_is_not_wider_than_the_dense_arrays_need():
    """Where the flow length ``R`` is under a fibre diameter the one-term floor 0.5 (h / R)^2
    was 3.3-310 times the tet error (session 39, s39-tetfloor: those arrays need at most
    0.154). The square array across at solid fraction 0.4 (Sangani & Acrivos 1982 Table 1),
    lattice L / 12 (h / R = 0.34): true error -0.19 %, old floor 5.66 %; now the flow term
    0.2 (h / R)^2 = 2.3 % (the fibre term 0.27 (h / D)^2 = 0.37 %), still covering the error."""
    res, true = _tet_array("square", 0.4, 24, 12)
    est = res["error_estimate"]
    assert true == pytest.approx(-0.0019, abs=0.0005)
    assert abs(true) <= res["permeability_rel_error"] and res["status"] == "ok"
    assert est["floor"] == pytest.approx(_r_term(res), rel=1e-9)
    assert 0.02 < est["floor"] < 0.025  # 0.5 (h / R)^2 = 5.66 % before


def _loose_tol_cylinder(tol: float):
    """The walk-mesh case (session 52): one cylinder along z, solid fraction 0.2, in a 40 um
    square cell, 1 um voxels, an FEM permeameter along it (no entrance length: the geometry does
    not vary along the flow) solved to ``flow.tol = tol``."""
    import psdesign

    spec = {
        "rve": {"size": [40e-6, 40e-6, 40e-6], "voxel": 1e-6},
        "fibers": [
            {
                "shape": "cylinder",
                "diameter": 20.1850e-6,
                "center": [20e-6, 20e-6, 20e-6],
                "direction": [0, 0, 1],
            }
        ],
        "flow": {"viscosity": 1.8e-5, "tol": tol},
    }
    return psdesign.build(spec).permeability("z", solver="fem", bc="permeameter")


def test_bar_advice_follows_its_largest_term():
    """One rule (session 52 walk-mesh finding 4): the advice of a bar past the limit is that of
    its largest term, and a window term within ``C_W`` times the solver term is the solve's
    (the two windowed drops of one unconverged solve differ by about its residual). The terms
    are the walk's measured FEM bars: ``tol = 0.3`` (solver 58.9 %, window 85.3 %, Richardson
    54.4 %) was told to refine the grid and that the RVE is short."""
    e = err.ErrorEstimate
    loose = e(1.986, 0.544, 0.544, 0.003, 0.589, 2, 2.0, 1.25e-11, "two_grid", window=0.853)
    (over, why) = err.bar_warnings("K_z", loose, "flow.lattice_step")
    assert over.endswith("tighten flow.tol (the solve's residual makes most of the bar)")
    assert "window term 85.3 %" in why and "residual of 58.9 %" in why and "short" not in why
    # tol = 0.05: ok, no over-limit line; the 6.0 % window is the solve's (solver 7.8 %)
    ok = e(0.146, 0.0086, 0.0086, 0.0027, 0.0777, 2, 2.0, 5.7e-11, "two_grid", window=0.0601)
    (line,) = err.bar_warnings("K_z", ok, "flow.lattice_step")
    assert "RVE is short" not in line and line.endswith("tighten flow.tol")
    # a short RVE (review B's voxel case: window 64.7 % of 65.1 %, converged) and a coarse grid
    short = e(0.651, 0.004, None, 0.002, 1e-6, 2, None, None, "resolution_only", window=0.647)
    assert (
        err.bar_cause(short) == "window" and "RVE is short" in err.bar_warnings("K_x", short, "")[1]
    )
    coarse = e(0.40, 0.39, 0.39, 0.01, 1e-6, 2, 2.0, 1e-11, "two_grid", window=0.005)
    (line,) = err.bar_warnings("K_x", coarse, "rve.voxel")
    assert line.endswith("refine the grid (rve.voxel)")


@pytest.mark.slow
def test_a_loose_tolerance_is_blamed_on_the_tolerance():
    """Session 52 walk-mesh finding 4, end to end (~8 s): at ``tol = 0.3`` the FEM K is
    untrustworthy (right) and its line said "refine the grid (flow.lattice_step)" and "the RVE
    is short ... lengthen it" for a cylinder whose section does not change along the flow.
    Truth: at the default tolerance the same solve's window term is 0.03 %, so the 85 % here
    is the solve's; the advice is to tighten flow.tol and no line blames the length."""
    r = _loose_tol_cylinder(0.3)
    est = r.details["error_estimate"]
    assert r.status == "untrustworthy" and est["solver"] > 0.2
    text = "\n".join(r.details["warnings"])
    assert "tighten flow.tol (the solve's residual" in text
    assert "refine the grid" not in text and "RVE is short" not in text
