"""The voxel permeameter K without entrance bias (issue 12 item 2) and its error bar.

Independent truth: the periodic (homogenised) K of the same array on the same grid, which the
permeameter of a periodic array between slip walls must reproduce once entrance and exit losses
are excluded; published values (Sangani & Acrivos 1982 across, the Sparrow & Loeffler series
along) for the error bar. The old definition (the drop between the RVE's face planes) is
computed beside the new one and must fail the same bar.
"""

from __future__ import annotations

import numpy as np
import pytest
from arrays import L, along_array_k, array_distance, array_spec, exact_k, radius_of

from psdesign.flow.darcy import darcy_permeability, windowed_drop
from psdesign.flow.permeability import permeability
from psdesign.flow.voxel import column_of, permeameter_k
from psdesign.packing.build import build_rve
from psdesign.schema.spec import validate_spec
from solvers.voxel_stokes import solve_voxel_stokes


def test_windowed_drop_removes_periodic_part_for_two_or_more_periods():
    rng = np.random.default_rng(3)
    for periods in (2, 3, 5):
        per = 7  # layers per period
        s = np.arange(periods * per + 1) / per  # plane positions in periods
        wiggle = rng.normal(size=per)
        fl = np.concatenate([[0.0], np.cumsum(np.tile(wiggle - wiggle.mean(), periods))])
        profile = 5.0 - 2.0 * s + fl  # drop 2 per period
        assert windowed_drop(profile) == pytest.approx(2.0 * periods, rel=1e-12)
    # an entrance loss at the first plane is all in the face drop, next to nothing in the window
    profile = 6.0 - 2.0 * np.arange(31) / 10.0
    profile[0] += 0.3
    assert profile[0] - profile[-1] == pytest.approx(6.3)
    assert windowed_drop(profile) == pytest.approx(6.0, rel=2e-3)


@pytest.mark.parametrize("flow", ["across", "along"])
def test_permeameter_matches_periodic_within_one_percent(flow):
    # square array, solid fraction 0.3, 20 voxels per cell, RVE two cells long, slip sides:
    # the sides are symmetry planes of the array, so the periodic K is the exact target
    n, d = 20, ("x" if flow == "across" else "z")
    if flow == "across":
        cell = array_distance((n, n, 2), "square", 0.3)
        rve = np.tile(cell, (2, 1, 1))
    else:
        cell = array_distance((n, n, 1), "square", 0.3)
        rve = np.repeat(cell, 2 * n, axis=2)
    per = solve_voxel_stokes(cell <= 0, 1.0, d, distance=cell, tol=1e-8)
    k_per = column_of(per)["xyz".index(d)]
    res = solve_voxel_stokes(rve <= 0, 1.0, d, distance=rve, tol=1e-8, bc="permeameter")
    assert res.converged and res.flux_imbalance < 1e-6
    assert permeameter_k(res) == pytest.approx(k_per, rel=0.01)
    # the old definition (plane-averaged pressure drop between the RVE faces) misses the bar
    k_faces = darcy_permeability(
        res.flow_rate, 1.0, res.rve_length, res.rve_area, res.rve_pressure_drop
    )
    assert abs(k_faces / k_per - 1.0) > 0.015


def _reference(kind: str, flow: str, phi: float) -> float:
    if flow == "along":
        return along_array_k(phi, kind) * radius_of(phi, kind, spacing=L) ** 2
    return exact_k(kind, flow, phi)


#: (flow, solid fraction, voxels per spacing): small permeameter cases, two cells long.
COVERAGE_CASES = [("across", 0.2, 24), ("across", 0.4, 24), ("along", 0.2, 24)]


def test_permeameter_error_bar_covers_true_error():
    faces_covered = []
    for flow, phi, n in COVERAGE_CASES:
        along = flow == "along"
        spec = array_spec(
            "square", phi, n, n_cells=1 if along else 2, depth_voxels=2 * n if along else None
        )
        spec = validate_spec(spec)
        built = build_rve(spec)
        fields = built.voxelize(spec["rve"]["voxel"])
        res = permeability(
            built.rve,
            fields,
            "z" if along else "x",
            {**spec["flow"], "bc": "permeameter"},
            "voxel",
        )
        assert res["pressure_drop_definition"] == "windowed-dissipation"
        assert res["status"] == "ok", res["warnings"]
        exact = _reference("square", flow, phi)
        bar = res["permeability_rel_error"]
        assert abs(res["permeability_m2"] / exact - 1.0) <= bar
        k_faces = (
            res["permeability_m2"] * res["pressure_drop_rve_pa"] / res["pressure_drop_faces_pa"]
        )
        faces_covered.append(abs(k_faces / exact - 1.0) <= bar)
    # the bar has teeth: with K from the face-plane drop (the old definition) this test fails
    assert not all(faces_covered)


def test_floor_law_and_window_term_closed_forms():
    from psdesign.flow import error as err

    k, eps, h = 1e-12, 0.5, 1e-7
    r = np.sqrt(8 * k / eps)
    # sub-voxel walls: first-order floor 0.1 h / R (calibrated), not the order-2 0.5 (h / R)^2
    q, c = err.FLOOR["subvoxel"]
    assert err.resolution_floor(h, k, eps, 2, err.FLOOR["subvoxel"]) == pytest.approx(c * h / r)
    assert (q, c) == (1, 0.1)
    # window term: the larger of C_W x (gap of the two windowed estimators) and C_R (R / L)^2
    assert err.window_rel_error(2.0, 2.01, k, eps, 100 * r) == pytest.approx(
        err.WINDOW_SAFETY * 0.005
    )
    assert err.window_rel_error(2.0, 2.0, k, eps, 4 * r) == pytest.approx(err.WINDOW_REACH / 16)
    assert err.window_rel_error(2.0, None, k, eps, 4 * r) == 0.0  # no second estimator
    est = err.combine(k, eps, h, 2, 1e-6, k_coarse=k, ratio=2.0, floor_law=(1, 0.1), window=0.02)
    assert est.rel_error == pytest.approx(0.1 * h / r + 0.02 + 1e-6)
