"""Numba kernels of the voxel Laplace solver (float64 conjugate-gradient passes).

Stencil layout as in :mod:`solvers.voxel.kernels`: a 7-point operator stored as ``d[i, j, k]``
(diagonal) and ``cx, cy, cz`` (coupling of unknown ``(i, j, k)`` to its *lower* neighbour along
x, y, z, periodic wrap; a zero coupling on the first layer makes an axis non-periodic):
``(A x)_I = d_I x_I - sum_b (c_b[I] x[I - e_b] + c_b[I + e_b] x[I + e_b])``; ``d == 0`` marks an
inactive unknown (kept at zero).  Rows along the last axis go through 1-D views so LLVM
vectorises the interior; only the two wrapping ends are scalar.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from solvers.jit import parallel_kernel
from solvers.reduction import ordered_column_sums, ordered_sum

_OPTS = {"cache": True, "fastmath": False, "nogil": True}


@nb.njit(inline="always")
def _wrap(i, n):
    if i < 0:
        return n - 1
    if i >= n:
        return 0
    return i


@parallel_kernel(**_OPTS)
def apply_dot(d, cx, cy, cz, x, out):
    """``out = A x`` (0 on inactive unknowns); returns ``x . A x``."""
    nx, ny, nz = d.shape
    part = np.zeros(nx)
    for i in nb.prange(nx):
        ip = _wrap(i + 1, nx)
        im = _wrap(i - 1, nx)
        acc = 0.0
        for j in range(ny):
            jp = _wrap(j + 1, ny)
            jm = _wrap(j - 1, ny)
            dr = d[i, j]
            xr = x[i, j]
            xim = x[im, j]
            xip = x[ip, j]
            xjm = x[i, jm]
            xjp = x[i, jp]
            cxr = cx[i, j]
            cxp = cx[ip, j]
            cyr = cy[i, j]
            cyp = cy[i, jp]
            czr = cz[i, j]
            o = out[i, j]
            for k in range(nz):
                km = k - 1 if k > 0 else nz - 1
                kp = k + 1 if k < nz - 1 else 0
                s = (
                    cxr[k] * xim[k]
                    + cxp[k] * xip[k]
                    + cyr[k] * xjm[k]
                    + cyp[k] * xjp[k]
                    + czr[k] * xr[km]
                    + czr[kp] * xr[kp]
                )
                v = dr[k] * xr[k] - s if dr[k] != 0 else 0.0
                o[k] = v
                acc += v * xr[k]
        part[i] = acc
    return ordered_sum(part)


@parallel_kernel(**_OPTS)
def update_xr(x, r, p, q, alpha, r32, d):
    """``x += alpha p``, ``r -= alpha q``, ``r32 = float32(r)``; returns ``|D^-1 r|^2``."""
    fd = d.reshape(-1)
    fx = x.reshape(-1)
    fr = r.reshape(-1)
    fp = p.reshape(-1)
    fq = q.reshape(-1)
    f32 = r32.reshape(-1)
    n = fx.size
    nchunk = 64
    part = np.zeros(nchunk)
    step = (n + nchunk - 1) // nchunk
    for c in nb.prange(nchunk):
        acc = 0.0
        for t in range(c * step, min(n, (c + 1) * step)):
            fx[t] += alpha * fp[t]
            v = fr[t] - alpha * fq[t]
            fr[t] = v
            f32[t] = v
            if fd[t] != 0:
                w = v / fd[t]
                acc += w * w
        part[c] = acc
    return ordered_sum(part)


@parallel_kernel(**_OPTS)
def dot_z(r, z32, z):
    """``z = float64(z32)``; returns ``r . z``."""
    fr = r.reshape(-1)
    fz = z.reshape(-1)
    f32 = z32.reshape(-1)
    n = fr.size
    nchunk = 64
    part = np.zeros(nchunk)
    step = (n + nchunk - 1) // nchunk
    for c in nb.prange(nchunk):
        acc = 0.0
        for t in range(c * step, min(n, (c + 1) * step)):
            v = np.float64(f32[t])
            fz[t] = v
            acc += fr[t] * v
        part[c] = acc
    return ordered_sum(part)


@parallel_kernel(**_OPTS)
def update_p(p, z, beta):
    """``p = z + beta p``."""
    fp = p.reshape(-1)
    fz = z.reshape(-1)
    n = fp.size
    for t in nb.prange(n):
        fp[t] = fz[t] + beta * fp[t]


@parallel_kernel(**_OPTS)
def dot_z32(r, z32):
    """Returns ``r . float64(z32)``."""
    fr = r.reshape(-1)
    f32 = z32.reshape(-1)
    n = fr.size
    nchunk = 64
    part = np.zeros(nchunk)
    step = (n + nchunk - 1) // nchunk
    for c in nb.prange(nchunk):
        acc = 0.0
        for t in range(c * step, min(n, (c + 1) * step)):
            acc += fr[t] * np.float64(f32[t])
        part[c] = acc
    return ordered_sum(part)


@parallel_kernel(**_OPTS)
def update_p32(p, z32, beta):
    """``p = float64(z32) + beta p``."""
    fp = p.reshape(-1)
    fz = z32.reshape(-1)
    n = fp.size
    for t in nb.prange(n):
        fp[t] = np.float64(fz[t]) + beta * fp[t]


@nb.njit(inline="always")
def _harmonic(a, b):
    s = a + b
    return 2.0 * a * b / s if s > 0 else 0.0


@parallel_kernel(**_OPTS)
def coefficients(sigma, axis, fixed, cx, cy, cz, d, rhs):
    """Face conductances (harmonic means), diagonal and right-hand side of the system.

    ``fixed``: no wrap couplings (insulated sides), Dirichlet ``T = 1`` / ``0`` on the faces
    normal to ``axis`` through a half-cell conductance ``2 sigma``.  Periodic: unit mean
    gradient, ``rhs = c_a[I] - c_a[I + e_a]``.
    """
    for i in nb.prange(sigma.shape[0]):
        _conductance_slab(sigma, fixed, cx, cy, cz, np.int64(i))
    for i in nb.prange(sigma.shape[0]):
        _diagonal_slab(sigma, axis, fixed, cx, cy, cz, d, rhs, np.int64(i))


@nb.njit(**_OPTS)
def _conductance_slab(sigma, fixed, cx, cy, cz, i):
    """Plane ``i`` of the face conductances of :func:`coefficients` (a serial function the
    parallel loop calls: numba's parfor passes see a short loop; see
    :mod:`solvers.voxel.kernels`)."""
    nx, ny, nz = sigma.shape
    im = _wrap(i - 1, nx)
    for j in range(ny):
        jm = _wrap(j - 1, ny)
        for k in range(nz):
            km = _wrap(k - 1, nz)
            s = sigma[i, j, k]
            gx = _harmonic(s, sigma[im, j, k])
            gy = _harmonic(s, sigma[i, jm, k])
            gz = _harmonic(s, sigma[i, j, km])
            if fixed:
                if i == 0:
                    gx = 0.0
                if j == 0:
                    gy = 0.0
                if k == 0:
                    gz = 0.0
            cx[i, j, k] = gx
            cy[i, j, k] = gy
            cz[i, j, k] = gz


@nb.njit(**_OPTS)
def _diagonal_slab(sigma, axis, fixed, cx, cy, cz, d, rhs, i):
    """Plane ``i`` of the diagonal and right-hand side of :func:`coefficients` (9 parameters:
    the kernel's and ``i``)."""
    nx, ny, nz = sigma.shape
    n_a = sigma.shape[axis]
    ip = _wrap(i + 1, nx)
    for j in range(ny):
        jp = _wrap(j + 1, ny)
        for k in range(nz):
            kp = _wrap(k + 1, nz)
            dd = (
                np.float64(cx[i, j, k])
                + cx[ip, j, k]
                + cy[i, j, k]
                + cy[i, jp, k]
                + cz[i, j, k]
                + cz[i, j, kp]
            )
            pos = i if axis == 0 else (j if axis == 1 else k)
            b = 0.0
            if fixed:
                s = sigma[i, j, k]
                if pos == 0:
                    dd += 2.0 * s
                    b = 2.0 * s
                if pos == n_a - 1:
                    dd += 2.0 * s
            else:
                if axis == 0:
                    b = np.float64(cx[i, j, k]) - cx[ip, j, k]
                elif axis == 1:
                    b = np.float64(cy[i, j, k]) - cy[i, jp, k]
                else:
                    b = np.float64(cz[i, j, k]) - cz[i, j, kp]
            d[i, j, k] = dd
            rhs[i, j, k] = b if dd != 0 else 0.0


@parallel_kernel(**_OPTS)
def face_fluxes(t, cx, cy, cz, axis, offset):
    """Face fluxes ``c_b (t[I - e_b] - t[I] + offset [b == axis])`` summed per plane normal to
    ``axis`` (``planes[p]`` = faces between layers ``p - 1`` and ``p``) and summed over the box
    per axis (``totals``)."""
    nx, ny, nz = t.shape
    n_a = t.shape[axis]
    part = np.zeros((nx, n_a))
    tot = np.zeros((nx, 3))
    for i in nb.prange(nx):
        im = _wrap(i - 1, nx)
        for j in range(ny):
            jm = _wrap(j - 1, ny)
            for k in range(nz):
                km = _wrap(k - 1, nz)
                tc = t[i, j, k]
                fx = cx[i, j, k] * (t[im, j, k] - tc + (offset if axis == 0 else 0.0))
                fy = cy[i, j, k] * (t[i, jm, k] - tc + (offset if axis == 1 else 0.0))
                fz = cz[i, j, k] * (t[i, j, km] - tc + (offset if axis == 2 else 0.0))
                tot[i, 0] += fx
                tot[i, 1] += fy
                tot[i, 2] += fz
                if axis == 0:
                    part[i, i] += fx
                elif axis == 1:
                    part[i, j] += fy
                else:
                    part[i, k] += fz
    return ordered_column_sums(part), ordered_column_sums(tot)
