"""Numba kernels of the voxel Stokes solver's MINRES loop with the fewest stored vectors.

:func:`solvers.voxel_stokes._minres` keeps six 4-field vectors (the float64 solution ``x``, the
two Lanczos vectors ``r1, r2``, the preconditioned vector ``z`` and two unscaled directions
``u, u1``) instead of seven: the operator product is written *in place* over the older Lanczos
vector (:func:`stokes_lanczos`: ``r1 <- s K z - c1 r1``, each entry of ``r1`` is read once
before it is overwritten, so no product vector is stored), and the direction update runs
before the next preconditioned vector is formed (:func:`minres_direction`), so that ``z`` is
free to receive it.  The bytes streamed per iteration do not grow: the in-place product reads
``r1`` where the former product read it for its second dot product, and the Lanczos axpy
(:func:`add_scaled`) reads one vector fewer than the former three-vector update.

The momentum rows come from :mod:`solvers.voxel.kernels` (``_momentum_row``,
``_momentum_row_w``); the continuity rows are the same expressions as in
:func:`solvers.voxel.kernels.stokes_apply` / ``stokes_apply_w``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from solvers.jit import parallel_kernel
from solvers.voxel.kernels import _dn, _momentum_row, _momentum_row_w, _up

_OPTS = {"cache": True, "fastmath": True, "nogil": True}


@nb.njit(inline="always")
def _combine(row, s, c1, yr, xr):
    """``yr <- s row - c1 yr`` (``yr`` not read when ``c1 == 0``: it may hold garbage);
    returns the float64 sum of ``xr * yr_new``."""
    acc = 0.0
    if c1 == 0.0:
        for k in range(row.shape[0]):
            val = s * row[k]
            yr[k] = val
            acc += np.float64(xr[k]) * np.float64(val)
    else:
        for k in range(row.shape[0]):
            val = s * row[k] - c1 * yr[k]
            yr[k] = val
            acc += np.float64(xr[k]) * np.float64(val)
    return acc


@parallel_kernel(**_OPTS)
def stokes_lanczos(du, dv, dw, cu, cv, cw, fluid, x, s, c1, y):
    """``y <- s K x - c1 y`` in place for the MAC Stokes matrix of
    :func:`solvers.voxel.kernels.stokes_apply`; returns ``x . y_new`` (float64).

    ``y`` is read only when ``c1 != 0`` (the first Lanczos step passes ``c1 = 0`` and any
    ``y``).  Rows along k, one temporary row per outer index.
    """
    nx, ny, nz = fluid.shape
    u = x[0]
    v = x[1]
    w = x[2]
    p = x[3]
    acc = np.zeros(nx)
    for i in nb.prange(nx):
        row = np.empty(nz, dtype=y.dtype)
        s_y = 0.0
        im = _dn(i, nx)
        ip = _up(i, nx)
        for j in range(ny):
            jm = _dn(j, ny)
            jp = _up(j, ny)
            pr = p[i, j]
            _momentum_row(du, cu, u, pr, p[im, j], 0, i, j, row)
            s_y += _combine(row, s, c1, y[0, i, j], u[i, j])
            _momentum_row(dv, cv, v, pr, p[i, jm], 0, i, j, row)
            s_y += _combine(row, s, c1, y[1, i, j], v[i, j])
            _momentum_row(dw, cw, w, pr, pr, 1, i, j, row)
            s_y += _combine(row, s, c1, y[2, i, j], w[i, j])
            ur = u[i, j]
            uip = u[ip, j]
            vr = v[i, j]
            vjp = v[i, jp]
            wr = w[i, j]
            fr = fluid[i, j]
            for k in range(nz - 1):
                val = ur[k] - uip[k] + vr[k] - vjp[k] + wr[k] - wr[k + 1]
                row[k] = val if fr[k] != 0 else 0.0
            k = nz - 1
            val = ur[k] - uip[k] + vr[k] - vjp[k] + wr[k] - wr[0]
            row[k] = val if fr[k] != 0 else 0.0
            s_y += _combine(row, s, c1, y[3, i, j], pr)
        acc[i] = s_y
    return acc.sum()


@parallel_kernel(**_OPTS)
def stokes_lanczos_w(du, dv, dw, cu, cv, cw, fluid, wu, wv, ww, x, s, c1, y):
    """:func:`stokes_lanczos` for the face-weighted (sub-voxel) matrix of
    :func:`solvers.voxel.kernels.stokes_apply_w`."""
    nx, ny, nz = fluid.shape
    u = x[0]
    v = x[1]
    w = x[2]
    p = x[3]
    acc = np.zeros(nx)
    for i in nb.prange(nx):
        row = np.empty(nz, dtype=y.dtype)
        s_y = 0.0
        im = _dn(i, nx)
        ip = _up(i, nx)
        for j in range(ny):
            jm = _dn(j, ny)
            jp = _up(j, ny)
            pr = p[i, j]
            _momentum_row_w(du, cu, u, pr, p[im, j], 0, wu[i, j], i, j, row)
            s_y += _combine(row, s, c1, y[0, i, j], u[i, j])
            _momentum_row_w(dv, cv, v, pr, p[i, jm], 0, wv[i, j], i, j, row)
            s_y += _combine(row, s, c1, y[1, i, j], v[i, j])
            _momentum_row_w(dw, cw, w, pr, pr, 1, ww[i, j], i, j, row)
            s_y += _combine(row, s, c1, y[2, i, j], w[i, j])
            ur = u[i, j]
            uip = u[ip, j]
            vr = v[i, j]
            vjp = v[i, jp]
            wr = w[i, j]
            a0 = wu[i, j]
            a1 = wu[ip, j]
            b0 = wv[i, j]
            b1 = wv[i, jp]
            c0 = ww[i, j]
            fr = fluid[i, j]
            for k in range(nz):
                kp = k + 1 if k + 1 < nz else 0
                val = (
                    a0[k] * ur[k]
                    - a1[k] * uip[k]
                    + b0[k] * vr[k]
                    - b1[k] * vjp[k]
                    + c0[k] * wr[k]
                    - c0[kp] * wr[kp]
                )
                row[k] = val if fr[k] != 0 else 0.0
            s_y += _combine(row, s, c1, y[3, i, j], pr)
        acc[i] = s_y
    return acc.sum()


@parallel_kernel(**_OPTS)
def minres_direction(z, s, u1, a1, u, a0, x, cx):
    """``u1 <- s z - a1 u1 - a0 u`` (the next unscaled MINRES direction) and ``x += cx u``
    (the previous direction's solution update, float64 ``x``) in one pass."""
    fz = z.ravel()
    f1 = u1.ravel()
    f0 = u.ravel()
    fx = x.ravel()
    for q in nb.prange(fz.size):
        old = f0[q]
        f1[q] = s * fz[q] - a1 * f1[q] - a0 * old
        fx[q] += cx * old


@parallel_kernel(**_OPTS)
def add_scaled(x, c, u):
    """``x += c u`` (flat, parallel; any float dtypes, e.g. float64 ``x`` and float32 ``u``)."""
    fx = x.ravel()
    fu = u.ravel()
    for q in nb.prange(fx.size):
        fx[q] += c * fu[q]
