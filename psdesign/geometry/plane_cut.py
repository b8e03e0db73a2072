"""The tangent-plane partial volume: each voxel cut by the plane through its centre's signed
distance along the distance's gradient, a second quadrature of the pore volume.

The partial volume ``clip(1/2 + d / h, 0, 1)`` of :mod:`psdesign.geometry.porosity` is exact
only for a plane along a voxel face. A plane at an angle cuts a voxel in a fraction that is
not linear in ``d``; on an axis-aligned cylinder the boundary crosses long runs of voxels at
nearly the same angle and offset (the diagonal stretches of a voxel-aligned circle), so those
errors add up instead of averaging out, and a circle centred on a voxel corner or centre
repeats each of them eight times. The cut here is exact for a plane at any angle: its error
on a smooth surface is the curvature's, about ``h^2 / 24`` times the surface integral of the
mean-curvature sum (``2 pi h^2 / 24`` of pore area per unit length of a straight cylinder),
smooth in ``h`` with no lattice part.

The fraction of a voxel (edge 1, centred at 0) on the pore side of the plane ``n . x = -t``
(``t = d / (h |grad d|)``) is the distribution function at ``t`` of
``n_x U_1 + n_y U_2 + n_z U_3`` with ``U_i`` uniform on ``[-1/2, 1/2]``:
:func:`cube_fraction_below`.
"""

from __future__ import annotations

import numpy as np

#: Voxels per slab of whole x-planes (with one plane either side for the gradient): bounds the
#: float64 temporaries, about 200 bytes per voxel near the surface (a 200^3 generator grid,
#: 7 % of voxels near it: 29 MB peak with 32-plane slabs).
SLAB_VOXELS = 1 << 20

#: Smallest width of a uniform in :func:`cube_fraction_below`: a normal component below it is
#: raised to it (keeps the divided difference finite; changes a fraction by about
#: ``WIDTH_MIN / 6``, 1.7e-5, where the plane touches an edge, elsewhere ~1e-8).
WIDTH_MIN = 1e-4

#: |d| / h beyond which a voxel is whole (pore or solid) under any plane: half the cube's
#: diagonal, sqrt(3) / 2, rounded up.
REACH = 0.87


def cube_fraction_below(t: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """``P(w_1 U_1 + w_2 U_2 + w_3 U_3 <= t)`` for ``U_i`` uniform on ``[-1/2, 1/2]``: the
    fraction of a unit cube below a plane with normal components ``w`` (>= 0) at ``t`` from its
    centre.

    The closed form of a sum of three uniforms (a divided difference of ``max(s, 0)^3 / 6``);
    widths below :data:`WIDTH_MIN` are raised to it.

    Parameters
    ----------
    t : ndarray (k,)
        Offsets, in units of the cube's edge.
    widths : ndarray (k, 3)
        Absolute normal components.

    Returns
    -------
    ndarray (k,)
        Fractions in [0, 1].

    >>> round(float(cube_fraction_below(np.array([0.25]), np.array([[1.0, 0.0, 0.0]]))[0]), 9)
    0.75
    >>> w = np.array([[0.6, 0.8, 0.0]])  # a 2-D cut: a triangle of legs 0.5 and 0.375
    >>> round(float(cube_fraction_below(np.array([-0.4]), w)[0]), 6)
    0.09375
    """
    w = np.maximum(np.asarray(widths, dtype=np.float64), WIDTH_MIN)
    s = np.asarray(t, dtype=np.float64) + 0.5 * w.sum(axis=1)
    total = np.zeros_like(s)
    for k in range(8):
        picked = [(k >> i) & 1 for i in range(3)]
        shift = s - (picked[0] * w[:, 0] + picked[1] * w[:, 1] + picked[2] * w[:, 2])
        sign = -1.0 if sum(picked) % 2 else 1.0
        total += sign * np.maximum(shift, 0.0) ** 3
    return np.clip(total / (6.0 * w[:, 0] * w[:, 1] * w[:, 2]), 0.0, 1.0)


def _gradient(block: np.ndarray, idx: tuple[np.ndarray, ...]) -> np.ndarray:
    """Gradient (per voxel) of ``block`` at the voxels ``idx``: central differences; one-sided
    at the block's faces; across a ridge or valley of the field (the two one-sided differences
    of opposite sign: midway between two surfaces, a crease of a union) the steeper one, the
    side of the nearer surface."""
    here = block[idx]
    out = np.empty((here.size, 3))
    for ax in range(3):
        a, m = idx[ax], block.shape[ax]
        up, down = list(idx), list(idx)
        up[ax], down[ax] = np.minimum(a + 1, m - 1), np.maximum(a - 1, 0)
        fwd = np.where(up[ax] > a, block[tuple(up)] - here, np.nan)
        bwd = np.where(down[ax] < a, here - block[tuple(down)], np.nan)
        central = np.where(np.isnan(fwd), bwd, np.where(np.isnan(bwd), fwd, 0.5 * (fwd + bwd)))
        steeper = np.where(np.abs(fwd) > np.abs(bwd), fwd, bwd)
        out[:, ax] = np.where(fwd * bwd < 0, steeper, central)
    return np.nan_to_num(out)


def plane_partial_porosity(distance: np.ndarray, h: float) -> float:
    """Mean tangent-plane partial pore volume of the voxels (see the module's docstring).

    ``distance`` is the signed distance at the voxel centres (metres, <= 0 in the solid; an
    approximate distance is fine: the offset is ``d / |grad d|``), ``h`` the voxel edge. A
    voxel whose gradient vanishes (a flat field) is cut along a face. Exact for a plane at any
    angle:

    >>> x, y, z = np.meshgrid(*[np.arange(8) + 0.5] * 3, indexing="ij")
    >>> d = (0.6 * x + 0.8 * y - 3.3).astype(np.float32)  # pore above the plane
    >>> round(plane_partial_porosity(d, 1.0), 6) == round(1 - 3.3 ** 2 / (2 * 0.6 * 0.8) / 64, 6)
    True
    """
    n = distance.shape[0]
    slab = max(1, SLAB_VOXELS // (distance.shape[1] * distance.shape[2]))
    total = 0.0
    for i in range(0, n, slab):
        lo, hi = max(i - 1, 0), min(i + slab + 1, n)
        block = distance[lo:hi].astype(np.float64) / h
        core = block[i - lo : i - lo + min(slab, n - i)]
        total += float(np.count_nonzero(core >= REACH))
        near = np.nonzero(np.abs(core) < REACH)
        if near[0].size == 0:
            continue
        idx = (near[0] + (i - lo), near[1], near[2])
        grad = _gradient(block, idx)
        norm = np.linalg.norm(grad, axis=1)
        flat = norm < 1e-3
        grad[flat], norm[flat] = (1.0, 0.0, 0.0), 1.0
        t = block[idx] / norm
        total += float(cube_fraction_below(t, np.abs(grad) / norm[:, None]).sum())
    return total / distance.size
