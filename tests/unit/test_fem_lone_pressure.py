"""A pressure vertex that meets no free velocity dof (a cap tet on a no-slip wall) is solved.

pytetwild leaves such caps on square arrays across at solid fraction 0.5 (one tet with three
no-slip wall faces whose fourth vertex is in no other tet: all ten P2 velocity nodes fixed, so
that vertex's pressure row is zero); the saddle matrix was exactly singular and SuperLU's
"Factor is exactly singular" escaped the tet route (session 39, helper s39-tetwild).

Truth: plane Poiseuille flow, ``Q / W = G H^3 / (12 mu)`` (F. M. White, *Viscous Fluid Flow*,
3rd ed., McGraw-Hill 2006, Sec. 3-3.2), which P2 / P1 contains exactly; the cap carries no
flow (its velocity is zero), so the flow rate and the linear pressure are unchanged.
"""

from __future__ import annotations

import numpy as np
import pytest
from meshes import box_mesh, tag_box_boundary

from solvers.fem_stokes import StokesOptions, solve_stokes

W, H, LZ = 10e-6, 20e-6, 30e-6
MU, DP = 1.8e-5, 50.0


def _capped_channel():
    """The plane channel of ``test_fem_stokes`` with one tet capped onto its y = H wall."""
    pts, tets = box_mesh((0, 0, 0), (W, H, LZ), (2, 6, 6))
    tags = tag_box_boundary(pts, tets, (0, 0, 0), (W, H, LZ), 2)
    tri = tags["side_y1"][7]
    apex = pts[tri].mean(axis=0) + np.array([0.0, 0.3 * H / 6, 0.0])
    pts = np.vstack([pts, apex])
    a = len(pts) - 1
    cap = np.array([[tri[0], tri[1], tri[2], a]])
    p = pts[cap[0]]
    if np.dot(np.cross(p[1] - p[0], p[2] - p[0]), p[3] - p[0]) < 0:
        cap = cap[:, [1, 0, 2, 3]]
    tets = np.vstack([tets, cap])
    tags["side_y1"] = np.delete(tags["side_y1"], 7, axis=0)
    tags["wall"] = np.array([[tri[0], tri[1], a], [tri[1], tri[2], a], [tri[2], tri[0], a]])
    return pts, tets, tags, a


def test_cap_tet_on_a_wall_solves_and_changes_nothing():
    pts, tets, tags, apex = _capped_channel()
    res = solve_stokes(
        pts,
        tets,
        tags,
        p_inlet=DP,
        p_outlet=0.0,
        viscosity=MU,
        noslip=("side_y0", "side_y1", "wall"),
        slip=("side_x0", "side_x1"),
        options=StokesOptions(tol=1e-11, direct_max_dofs=10**6),
    )
    assert res.converged
    q_exact = W * (DP / LZ) * H**3 / (12 * MU)  # White (2006) Sec. 3-3.2
    assert res.flux["outlet"] == pytest.approx(q_exact, rel=1e-8, abs=0)
    # the apex's pressure is its tet's mean (the field is linear in z: exact there too)
    assert res.pressure[apex] == pytest.approx(DP * (1 - pts[apex, 2] / LZ), rel=1e-6)
    np.testing.assert_allclose(res.velocity[apex], 0.0, atol=1e-12)
