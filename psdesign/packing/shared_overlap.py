"""The rounding of the overlap shared by three or more fibers, estimated where it lies.

Omega's count (:attr:`psdesign.geometry.rve.VoxelFields.intersection_volume_fraction`) is the
fraction of voxel centres in ``c >= 2`` fibers; the lenses' exact volumes sum ``C(c, 2)`` over
the box. The two differ by the shared part ``g(c) = C(c, 2) - 1`` (``c >= 3``), so the count's
error is the pairs' summed errors (:func:`psdesign.packing.overlap_status._in_place_errors`)
minus ``sum_v g(c_v) / N - int g(c)``: the grid's rounding of the shared part, of no closed
form. Session 49 review: left out, a 4 x 4 array of cylinders 18 voxels thick at 48^3 (axes
on voxel faces, voxels in 3 fibers) counted 0.72222 against the 2-D count's 0.70963, 1.77x
its bar, rated ``ok``. :func:`shared_part_error` integrates ``g`` over the voxels in 3+
fibers and their neighbours at 16^2 or 8^3 points each, from the cylinders' own fields.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from psdesign.geometry.rve import RVE

#: Points per axis at which :func:`shared_part_error` samples a voxel where fibers vary along
#: at most two axes (one point along the third), and where they vary along all three: about
#: 256-512 points a voxel. Its error is the difference from half as many per axis. On 4 x 4 /
#: 3 x 3 arrays of z-cylinders (session 49 review) 4 per axis read 0.44x / 0.33x the bar for
#: errors of 1.76x / 1.33x (2-D count at 4000^2), 8 read 1.60x / 1.20x, 16 read 1.81x / 1.36x.
SHARED_SAMPLES_2D = 16
SHARED_SAMPLES_3D = 8

#: Points beyond which :func:`shared_part_error` halves the points per axis (down to 2; about
#: 1 s of cylinder fields): 8^3 points in each of mix3.py's 32-48^3 random layouts cost up to
#: 0.8 s (RESULTS.md session 49); a 250^3 grid holds ~200x their voxels.
SHARED_POINTS = 2**21


def fibers_vary(fibers: list) -> list[bool]:
    """Per axis, whether any of ``fibers``' lattices has a component along it: along an axis
    where none has, every slice of the box rounds alike (adding 0.0 leaves each sum as it is).
    """
    return [any(fb.lattice[:, a].any() for fb in fibers) for a in range(3)]


def shared_part_error(rve: RVE, count: np.ndarray, spacing: np.ndarray) -> tuple[float, float]:
    """The count's rounding of the part of the box in three or more fibers, and its error.

    Parameters
    ----------
    rve
        The RVE whose fibers were counted (all cylinders; otherwise ``(0.0, 0.0)``: a rod's
        field only approximates a distance, and its lenses are bounds anyway).
    count
        The fields' fibers per voxel (:attr:`psdesign.geometry.rve.VoxelFields.count`).
    spacing
        The grid's spacing, metres, per axis.

    Returns
    -------
    tuple of float
        ``sum_v g(c_v) / N - int g(c)`` (a fraction of the box; ``g(c) = C(c, 2) - 1`` for
        ``c >= 3``, else 0): what the pairs' summed count errors hold beyond the count's own,
        ``int`` estimated at :data:`SHARED_SAMPLES_2D` or :data:`SHARED_SAMPLES_3D` points per
        axis in each voxel in 3+ fibers and its 26 neighbours; and the estimate's error, its
        difference from the estimate at half as many points per axis.
    """
    fibers = getattr(rve, "fibers", None) or []
    if count.max(initial=0) < 3 or any(fb.shape != "cylinder" for fb in fibers):
        return 0.0, 0.0
    varies = fibers_vary(fibers)
    # along an axis no fiber varies every slice rounds alike (as in _count_both): one stands
    # for all, a fraction of its own voxels as of the box's
    count = count[tuple(slice(None) if v else slice(0, 1) for v in varies)]
    voxels = _around(count >= 3)
    h = np.asarray(spacing, float) / rve.period  # normalized, as RVE.voxelize rasterizes
    centre = (voxels + 0.5) * h
    counted = float(_g(count[tuple(voxels.T)].astype(np.int64)).sum())
    s = SHARED_SAMPLES_3D if all(varies) else SHARED_SAMPLES_2D
    # fewer points on big grids (their error, stated, grows): a cost bound, not a precision
    while s > 2 and len(voxels) * s ** sum(varies) > SHARED_POINTS:
        s //= 2
    fine, coarse = (_sampled(fibers, centre, h, k, varies) for k in (s, s // 2))
    n = float(count.size)
    return (counted - fine) / n, abs(fine - coarse) / n


def _around(mask: np.ndarray) -> np.ndarray:
    """The indices (k, 3, C order) of the voxels in ``mask`` and their 26 neighbours
    (periodic), each once: a periodic dilation by one voxel per axis. Listing the 27 offsets of
    each voxel and ``np.unique(axis=0)`` cost 7.7 s and a 273 MB peak of a 250^3 random
    packing's 8.7 s (session 49 review, /tmp/rre/e.py); the dilation gives the same array."""
    near = mask.copy()
    for a in range(mask.ndim):
        near = near | np.roll(near, 1, a) | np.roll(near, -1, a)
    return np.argwhere(near)


def _sampled(fibers: list, centre: np.ndarray, h: np.ndarray, s: int, varies: list) -> float:
    """``sum_v mean g(c)`` over ``s`` points (cell midpoints) per axis of each voxel at
    ``centre``; one along an axis where no fiber ``varies`` (every fiber runs along it)."""
    u = [(np.arange(s) + 0.5) / s - 0.5 if v else np.zeros(1) for v in varies]
    offset = np.stack(np.meshgrid(*u, indexing="ij"), axis=-1).reshape(-1, 3) * h
    c = np.zeros((len(centre), len(offset)), np.int64)
    reach = float(np.linalg.norm(h))  # a cylinder's field is its distance: a voxel's points lie
    for fb in fibers:  # within half a diagonal of its centre
        near = np.flatnonzero(fb.field(centre) <= reach)
        if len(near):
            pts = (centre[near, None, :] + offset[None]).reshape(-1, 3)
            c[near] += (fb.field(pts) <= 0.0).reshape(len(near), -1)
    return float(_g(c).mean(axis=1).sum())


def _g(c: np.ndarray) -> np.ndarray:
    """``C(c, 2) - 1`` where ``c >= 3`` fibers meet, else 0: the pairs' excess over one."""
    return np.where(c >= 3, c * (c - 1) // 2 - 1, 0)
