"""Sub-voxel ("analytic") pore volume of a signed-distance field.

The voxel count ``(distance > 0).sum() * voxel^3`` is a staircase: on cylinders of 3-10 voxels
radius it is off by up to 1-2 % of the solid volume, and the mesher used to copy that error.
Here the pore volume is the midpoint sum of a smoothed Heaviside of the distance,

    V = voxel^3 * sum_i H(d_i / w),   w = width * voxel,

with the 4th-order kernel ``H' = k(t) = 105/64 (1 - t^2)^2 (1 - 3 t^2)`` on ``|t| <= 1``
(``int k = 1``, ``int k t^2 = 0``). For a smooth surface at distance ``s`` the area element is
``A(s) = A_0 (1 + 2 kappa_m s + K s^2)``; the error of ``int H(d/w) dV`` against the exact volume
is ``A_0 int (H - step)(s) (2 kappa_m s + K s^2) ds``, whose ``s`` term vanishes because the
second moment of ``k`` does and whose ``s^2`` term vanishes because ``H - step`` is odd. The same
moment kills the first-order error where a surface crosses a box face obliquely. What remains
is the midpoint-quadrature error of a smooth transition two voxels wide.

Accuracy (``tests/unit/test_pore_volume.py``): solid volume of single straight and tilted rods
(R = 3.5-10 voxels) and square arrays (solid fraction 0.1-0.5, 20-40 voxels per cell) within
5e-4 of pi R^2 L (typically 1e-5 to 1e-4), against 0.5-2 % for the voxel count.

Requirements: ``distance`` must be a true signed distance (|grad d| = 1) within ``w`` of the
surface, and pore gaps narrower than ``2 w`` are under-counted (the field there never reaches
``w``); the mesher closes gaps below ``min_gap_voxels`` anyway.
"""

from __future__ import annotations

import numpy as np

DEFAULT_WIDTH_VOXELS = 2.0
_CHUNK = 1 << 22


def smoothed_heaviside(t: np.ndarray) -> np.ndarray:
    """4th-order smoothed step: 0 for t <= -1, 1 for t >= 1, exact moments 0 and 2."""
    t = np.clip(t, -1.0, 1.0)
    t2 = t * t
    return 0.5 + (105.0 / 64.0) * t * (1.0 + t2 * (-5.0 / 3.0 + t2 * (7.0 / 5.0 - t2 * 3.0 / 7.0)))


def analytic_pore_volume(
    distance: np.ndarray, voxel: float, width: float = DEFAULT_WIDTH_VOXELS
) -> float:
    """Pore volume ``{distance > 0}`` of the box ``distance.shape * voxel`` at sub-voxel accuracy.

    Parameters
    ----------
    distance
        Signed distance at voxel centres (> 0 in the pore), any units consistent with ``voxel``.
    voxel
        Voxel size.
    width
        Half-width of the smoothed transition in voxels (> 0; 2 is accurate to ~1e-4 of the
        solid volume on 3.5-10 voxel radii, see module notes).

    Returns
    -------
    float
        Pore volume in ``voxel`` units cubed.
    """
    if not width > 0:
        raise ValueError(f"width must be > 0 voxels, got {width}")
    flat = np.asarray(distance).reshape(-1)
    w = float(width) * float(voxel)
    total = 0.0
    for s in range(0, len(flat), _CHUNK):  # chunks keep the float64 temporaries small
        total += float(smoothed_heaviside(flat[s : s + _CHUNK].astype(np.float64) / w).sum())
    return total * float(voxel) ** 3


def analytic_porosity(
    distance: np.ndarray, voxel: float, width: float = DEFAULT_WIDTH_VOXELS
) -> float:
    """:func:`analytic_pore_volume` divided by the box volume."""
    return analytic_pore_volume(distance, voxel, width) / (np.asarray(distance).size * voxel**3)
