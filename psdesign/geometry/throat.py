"""The narrowest throat the flow must pass: the percolation radius of the pore's wall distance.

The percolation radius ``r*`` of a pore space along an axis is the largest ``r`` such that the
voxels farther than ``r`` from every wall still connect the inlet plane to the outlet plane: the
radius of the largest ball that can travel through the sample (a maximin path). ``2 r*`` is the
width of the throat every path must squeeze through, the gap that sets the permeability of
near-touching fibres (lubrication: ``K ~ g^2.5`` between two cylinders, so a wall error ``delta``
there moves ``K`` by about ``2.5 delta / g``; :mod:`psdesign.flow.error`, ``gap`` term).

The wall distance is the analytic signed distance inside its narrow band (sub-voxel), and beyond
the band, or for a segmented image, the periodic Euclidean transform of the voxel mask minus half
a voxel (:func:`psdesign.geometry.edt.periodic_edt`). Connectivity: 6-neighbour, a path
winding around the periodic box (:func:`percolates`). ``r*`` is found by bisection on ``r``
(one labelling per step).
"""

from __future__ import annotations

import numpy as np

from psdesign.geometry.edt import periodic_edt
from solvers.voxel_stokes import percolates as fluid_percolates


def wall_distance_voxels(distance: np.ndarray, step: float, analytic: bool = True) -> np.ndarray:
    """Distance (in voxels, float32) of each voxel centre to the nearest wall; <= 0 in solid.

    Parameters
    ----------
    distance : ndarray (nx, ny, nz)
        Signed distance in metres, <= 0 in solid, clipped above at its band margin
        (:class:`psdesign.geometry.rve.VoxelFields`).
    step : float
        Voxel edge (m).
    analytic : bool
        Whether ``distance`` samples an analytic surface inside its band (False: an image's).

    Returns
    -------
    ndarray of float32
    """
    pore = distance > 0.0
    if pore.all():
        return np.full(distance.shape, np.float32(np.inf))
    if not pore.any():
        return np.zeros(distance.shape, np.float32)
    out = periodic_edt(pore)
    out -= np.float32(0.5)
    np.maximum(out, 0.0, out=out)
    if analytic:
        d = distance / np.float32(step)
        band = distance < distance.max()  # the clip value marks voxels beyond the band
        out[band] = d[band]
        out[~pore] = np.minimum(d[~pore], 0.0)
    return out


def percolates(mask: np.ndarray, axis: int) -> bool:
    """Whether the True voxels of ``mask`` (face-connected) wind around the periodic box along
    ``axis``: :func:`solvers.voxel_stokes.percolates` of the complement, the test the voxel
    solver's own no-path refusal uses (one definition of a path).

    >>> m = np.zeros((4, 3, 3), bool); m[:, 0, 1] = True
    >>> percolates(m, 0), percolates(m, 1)
    (True, False)
    """
    return fluid_percolates(~mask, axis)


def percolation_radius(wall_distance: np.ndarray, axis: int, tol: float = 0.05) -> float:
    """The percolation radius ``r*`` (voxels) of ``wall_distance`` along ``axis``: the largest
    ``r`` (to ``tol`` voxels) with ``{wall_distance > r}`` percolating; 0 when the pore does not
    percolate.

    >>> d = np.zeros((8, 9, 1), np.float32); d[:, 3:6, :] = [[[0.5], [1.5], [0.5]]]
    >>> round(percolation_radius(d, 0), 1), percolation_radius(d, 1)
    (1.5, 0.0)
    """
    if not percolates(wall_distance > 0.0, axis):
        return 0.0
    lo, hi = 0.0, float(np.max(wall_distance[np.isfinite(wall_distance)], initial=0.0))
    if hi <= 0.0:
        return 0.0
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if percolates(wall_distance > mid, axis):
            lo = mid
        else:
            hi = mid
    return float(lo)
