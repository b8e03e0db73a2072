"""The narrowest throat (psdesign.geometry.throat) and the gap term of the K bar
(psdesign.flow.error.gap_rel_error): closed forms on slits and cylinder gaps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from psdesign.flow import error as err
from psdesign.geometry.throat import percolates, percolation_radius, wall_distance_voxels


def _slit_image(width: int, lo: int, n: int = 12) -> np.ndarray:
    """Signed distance of a voxel image (+-h/2 at the walls, h = 1) holding a slit of ``width``
    voxels across y, open along x and z."""
    d = -np.ones((n, n, 4), np.float32)
    d[:, lo : lo + width, :] = 1.0
    return d


@pytest.mark.parametrize(("width", "lo"), [(1, 5), (2, 5), (3, 4), (4, 3), (5, 3)])
def test_a_slit_of_w_voxels_has_a_throat_of_w_voxels_within_the_sampling(width, lo):
    """A slit of ``w`` voxels: its wall distance at the voxel centres peaks at ``w / 2``
    (odd ``w``, a centre on the mid-plane) or ``(w - 1) / 2`` (even), so ``2 r*`` is ``w`` or
    ``w - 1`` and the throat width ``2 r* + 1/2`` is within half a voxel of ``w``."""
    wd = wall_distance_voxels(_slit_image(width, lo), 1.0, analytic=False)
    r = percolation_radius(wd, 0, tol=0.01)
    assert 2 * r == pytest.approx(width if width % 2 else width - 1, abs=0.03)
    assert abs(err.throat_width_voxels(r) - width) <= 0.5 + 0.03
    assert percolation_radius(wd, 1) == 0.0  # closed across the slit


def test_percolation_wraps_across_the_periodic_faces():
    """A channel that leaves through y = n - 1 and comes back at y = 0, and leaves through
    x = n - 1 to come back at x = 0, winds around the periodic box along x only through the
    periodic faces (the voxel solver's test, ``solvers.voxel_stokes.percolates``)."""
    m = np.zeros((6, 6, 1), bool)
    m[:3, 0, 0] = True
    m[2:, 5, 0] = True  # joined to the first half through the y faces at x = 2
    # plane x = 0 reaches plane x = 5, but (5, 5) has no fluid neighbour across the x face:
    # in the periodic medium that path is a dead end
    assert not percolates(m, 0)
    m[5, 0, 0] = True  # (5, 5) -y-> (5, 0) -x-> (0, 0): a loop once around x
    assert percolates(m, 0)
    assert not percolates(m, 1)
    m[2, 0, 0] = False
    m[2, 5, 0] = False  # now the halves meet only across the x face: no loop
    assert not percolates(m, 0)


def test_the_throat_between_cylinders_is_their_gap():
    """Square array of cylinders (spacing 24 voxels, solid fraction 0.6: gap
    ``L - 2a = 24 (1 - 2 sqrt(0.6 / pi)) = 3.02`` voxels), the analytic distance field: the
    throat width is within half a voxel of the gap, whatever the sub-voxel shift."""
    n, phi = 24, 0.6
    a = n * math.sqrt(phi / math.pi)
    gap = n - 2 * a
    for shift in (0.0, 0.25, 0.5):
        x = np.arange(n) + 0.5 - shift
        dx = np.minimum(np.abs(x - n / 2), n - np.abs(x - n / 2))
        dist = np.hypot(dx[:, None], dx[None, :]) - a  # one cylinder per cell, periodic
        dist = np.minimum(dist, 3.0)[:, :, None].repeat(2, axis=2).astype(np.float32)
        r = percolation_radius(wall_distance_voxels(dist, 1.0), 0, tol=0.01)
        assert abs(err.throat_width_voxels(r) - gap) <= 0.5 + 0.02, shift


def test_a_closed_pore_has_no_throat():
    d = -np.ones((4, 4, 4), np.float32)
    d[1:3, 1:3, 1:3] = 1.0
    assert percolation_radius(wall_distance_voxels(d, 1.0, analytic=False), 0) == 0.0


def test_the_gap_term_widens_the_bar_only_where_it_exceeds_the_rest():
    """``estimate_with``: the floor is at least ``C_G h / g``; a throat wide enough that the term
    is under the two-grid term leaves the bar as it was; the tet route has no gap term."""
    res = {"permeability_m2": 1e-12, "porosity": 0.5, "residual": 0.0, "flux_imbalance": 0.0}
    h = 1e-6
    no_gap = err.estimate_with(res, h, 2, lambda: (1.02e-12, 2.0), "subvoxel")
    wide = err.GAP["subvoxel"] * h / no_gap.discretization * 1.01
    same = err.estimate_with(res, h, 2, lambda: (1.02e-12, 2.0), "subvoxel", lambda: wide)
    assert same.rel_error == no_gap.rel_error and same.throat == wide
    assert same.gap == pytest.approx(no_gap.discretization / 1.01)
    narrow = err.estimate_with(res, h, 2, lambda: (1.02e-12, 2.0), "subvoxel", lambda: 2 * h)
    assert narrow.gap == pytest.approx(err.GAP["subvoxel"] / 2)
    assert narrow.rel_error == pytest.approx(narrow.gap + no_gap.rel_error - no_gap.discretization)
    assert err.estimate_with(res, h, 2, None, "tet", lambda: 2 * h).gap == 0.0


def test_a_straight_channel_has_no_throat_a_constricted_one_does():
    """:func:`psdesign.flow.error.throat_limits`: along a straight slit (5 voxels, image walls)
    the percolation radius is the largest wall distance, 2.5 voxels (the centre plane, half the
    width), so no throat limits the flow; pinch the slit to 1 voxel over one x-plane and the
    throat (2 r* + 1/2 = 1.5 voxels, r* 0.5) is under the widest pore's 5 voxels."""
    d = _slit_image(5, 3)
    wd = wall_distance_voxels(d, 1.0, analytic=False)
    r, widest = percolation_radius(wd, 0), float(wd.max())
    assert widest == pytest.approx(2.5) and r == pytest.approx(2.5, abs=0.05)
    assert not err.throat_limits(r, widest)
    d[5, 3:5, :] = -1.0
    d[5, 6:8, :] = -1.0
    wd = wall_distance_voxels(d, 1.0, analytic=False)
    r = percolation_radius(wd, 0)
    assert r == pytest.approx(0.5, abs=0.05)
    assert err.throat_limits(r, float(wd.max()))
