"""The permeameter's flat-top window: whole-RVE K of hexagonal arrays within 1 % of the periodic K
for 2, 3, 4 and 5 cells, along and across (issue 12 item 2).

Independent truth: the periodic (homogenised) K of the same array on the same grid, which the
permeameter of a periodic array between slip walls (mirror planes of the hexagonal lattice) must
reproduce once the entrance and exit losses are excluded. The sin^2 window over the whole sample
missed it by -1.00 % with two cells across at solid fraction 0.1 (26 voxels per spacing): the
entrance disturbance of the hexagonal cell (lateral period sqrt(3) L, cylinders cut by the faces)
reaches into the sin^2 window's quadratic ends. The flat-top window (whole periods in the middle
of the sample, zero near the faces, ``psdesign.flow.darcy.window``) is exact in the periodic
interior and leaves -0.32 %.
"""

from __future__ import annotations

import numpy as np
import pytest
from arrays import array_spec

from psdesign.flow.darcy import window, window_mean, window_shape, windowed_drop
from psdesign.flow.voxel import permeability_voxel
from psdesign.packing.build import build_rve
from psdesign.schema.spec import validate_spec

N = 26  # voxels per spacing (hexagonal cell 26 x 45: sqrt(3) 26 = 45.03)


@pytest.mark.parametrize("periods", [2, 3, 4, 5, 7, 8])
def test_flat_top_window_is_exact_for_whole_periods_and_zero_near_the_faces(periods):
    rng = np.random.default_rng(periods)
    for per in (1, 4, 7):  # layers per period
        wiggle = rng.normal(size=per)
        drops = 2.0 / per + np.tile(wiggle - wiggle.mean(), periods)  # drop 2 per period
        profile = 5.0 - np.concatenate([[0.0], np.cumsum(drops)])
        assert windowed_drop(profile, periods) == pytest.approx(2.0 * periods, rel=1e-12)
    span, ramp = window_shape(periods)
    t = np.linspace(0.0, 1.0, 20001)
    w = window(t, periods)
    edge = 0.5 * (1.0 - span - ramp)
    assert edge >= 3 / 16 - 1e-12  # at least 3/16 of the sample from each face
    assert np.all(w[t < edge] == 0.0) and np.all(w[t > 1.0 - edge] == 0.0)
    assert np.trapezoid(w, t) == pytest.approx(window_mean(periods), rel=1e-6)
    # an entrance loss in the first layers is not in the drop at all
    profile = 6.0 - 2.0 * np.arange(8 * periods + 1) / (8 * periods)
    profile[:2] += 0.3
    assert windowed_drop(profile, periods) == pytest.approx(2.0, rel=1e-12)
    assert window_shape(1) is None and window_mean(1) == 0.5  # one period: sin^2, unchanged


def _hex_k(flow: str, phi: float, cells: int, bc: str) -> dict:
    """Voxel route on the hexagonal array; a permeameter result also carries the solve's
    energy-flux profile (``profile``)."""
    along = flow == "along"
    spec = array_spec(
        "hex",
        phi,
        N,
        n_cells=1 if along or bc == "periodic" else cells,
        depth_voxels=cells * N if along else None,
    )
    spec = validate_spec(spec)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    got = {}

    def capture(_name, solution, **_):
        got["profile"] = getattr(solution, "rve_energy_flux_profile", None)

    res = permeability_voxel(
        fields, "z" if along else "x", {**spec["flow"], "bc": bc}, rve=built.rve, capture=capture
    )
    assert res["converged"], res
    return res | got


def _gap(flow: str, phi: float, cells: int) -> tuple[float, dict]:
    per = _hex_k(flow, phi, 1 if flow == "across" else cells, "periodic")
    perm = _hex_k(flow, phi, cells, "permeameter")
    return perm["permeability_m2"] / per["permeability_m2"] - 1.0, perm


def test_hexagonal_two_cells_across_within_one_percent_of_periodic():
    gap, perm = _gap("across", 0.1, 2)
    # measured -0.32 % (the sin^2 window over the sample: -1.00 %)
    assert abs(gap) <= 0.01
    assert perm["periods_per_copy"] == 2 and perm["permeameter_copies"] == 1
    # the sin^2 window over the whole sample, same solve, keeps about three times the residual
    k_per = perm["permeability_m2"] / (1.0 + gap)
    k_sin2 = perm["permeability_m2"] * perm["pressure_drop_rve_pa"] / windowed_drop(perm["profile"])
    assert abs(gap) < 0.5 * abs(k_sin2 / k_per - 1.0)


#: (flow, phi, cells) of the slow sweep; across 0.1 with 2 cells is the default test above
#: (same ``_gap``, same bar, fewer asserts), so it is not solved twice
HEX_SWEEP = [
    (flow, phi, cells)
    for flow, phi in (("across", 0.1), ("across", 0.3), ("along", 0.1), ("along", 0.3))
    for cells in (2, 3, 4, 5)
    if (flow, phi, cells) != ("across", 0.1, 2)
]


@pytest.mark.slow
@pytest.mark.parametrize(("flow", "phi", "cells"), HEX_SWEEP)
def test_hexagonal_arrays_within_one_percent_of_periodic(flow, phi, cells):
    gap, _ = _gap(flow, phi, cells)
    print(f"\nhex {flow} phi {phi} {cells} cells: permeameter / periodic - 1 = {gap:+.3%}")
    assert abs(gap) <= 0.01
