"""Numba kernels of the voxel Stokes solver's Krylov loop with the fewest stored vectors.

:func:`solvers.voxel_stokes._symmlq` (the default) keeps five 4-field vectors: the solution
``x``, the two Lanczos vectors ``r1, r2``, the preconditioned vector ``z`` and one direction
``w`` (SYMMLQ's ``w-bar``, :func:`symmlq_step`); :func:`solvers.voxel_stokes._minres` keeps
two unscaled directions ``u, u1`` instead (:func:`minres_direction`).  The operator product is
written *in place* over the older Lanczos vector (:func:`stokes_lanczos`: ``r1 <- s K z - c1
r1``, each entry of ``r1`` is read once before it is overwritten, so no product vector is
stored), and the direction update runs before the next preconditioned vector is formed, so
that ``z`` is free to receive it.

Storage (issue 16 item 3): the direction and the solution never enter a stencil, so SYMMLQ
stores them on the active unknowns only (:class:`Packing`; 77 % of the entries on the
Toray-like grids); the solution is float32 plus, from the second refinement cycle, an int16
extension (:class:`Solution`: 6 B per entry instead of the float64 8 B).  MINRES'
directions can be stored in 16 bits per entry (:class:`Directions`, row-scaled int16), at
about +10 % iterations.  Three float32 4-field vectors remain (``r1, r2, z``): they carry the
recurrence.

The momentum rows come from :mod:`solvers.voxel.kernels` (the stencil ``_stencil_rows``, fused
here with the pressure term and the Lanczos combination; it also takes
:func:`solvers.voxel.kernels.unit_couplings`); the continuity rows are the same expressions as
in :func:`solvers.voxel.kernels.stokes_residual` (sub-voxel walls:
:func:`solvers.voxel.cutfaces.stokes_lanczos_cut`).
A change to those inlined helpers recompiles this module's kernels: the numba cache stamps
cover the imported project modules (:class:`solvers.jit.DependencyLocator`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from solvers.jit import SerialHelpers, parallel_kernel
from solvers.reduction import ordered_sum
from solvers.voxel import memory as vmem
from solvers.voxel import simd
from solvers.voxel.kernels import BLOCK as FLAT_BLOCK
from solvers.voxel.kernels import (
    PREFETCH,
    _dn,
    _ends,
    _fetch,
    _fetch_lines,
    _on,
    _plane_dot,
    _stencil_rows,
    _u,
    _unit,
    _up,
    _wrap_row,
    _wrap_rows,
    _wrap_sum,
)
from solvers.voxel.memory import DIRECTION_BITS
from solvers.voxel.memory import TIGHT_TOL_BELOW as LO32_BELOW

_OPTS = {"cache": True, "fastmath": True, "nogil": True}
_SERIAL = SerialHelpers(**_OPTS)
"""The helpers' variants in the serial twins: :data:`_OPTS` without the disk cache for the
plain leaves (see :data:`solvers.voxel.kernels._SERIAL`); the helpers imported from
:mod:`solvers.voxel.kernels` take their serial variants from there."""


@_SERIAL.inline
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


@_SERIAL.inline
def _momentum_lanczos(d, c, q, pr, plow, shift, i, j, s, c1, yr, row):
    """One momentum row of :func:`stokes_lanczos`: ``row = (A q)[i, j, :]`` (the stencil of
    :func:`solvers.voxel.kernels._stencil_rows`, 0 on inactive faces), then in one loop the
    pressure difference ``pr[k] - plow[k - shift]`` (active faces, periodic in k) and
    ``yr <- s row - c1 yr``; returns the float64 ``q . yr``.  Two loops instead of the three of
    a plain momentum row + :func:`_combine` (2.4x faster on the Toray-like 100^3 operator; the
    same float32 roundings, the fused expressions may differ by one float32 ulp)."""
    nx, ny, nz = d.shape
    ip = _up(i, nx)
    jp = _up(j, ny)
    if _unit(d, c[0]):  # kernels.unit_couplings: one row of ones for all six neighbours
        one = c[0][0, 0]
        _stencil_rows(
            d[i, j], one, one, one, one, one,
            q[i, j], q[_dn(i, nx), j], q[ip, j], q[i, _dn(j, ny)], q[i, jp], row,
        )  # fmt: skip
    else:
        _stencil_rows(
            d[i, j], c[0][i, j], c[0][ip, j], c[1][i, j], c[1][i, jp], c[2][i, j],
            q[i, j], q[_dn(i, nx), j], q[ip, j], q[i, _dn(j, ny)], q[i, jp], row,
        )  # fmt: skip
    dr = d[i, j]
    xr = q[i, j]
    acc = 0.0
    # the first ``shift`` entries wrap along k; the rest is one branch-free loop (the mask
    # multiplies: kernels._on)
    for k in range(shift):
        v = row[k] + (pr[k] - plow[k - shift + nz]) * _on(dr[k])
        val = s * v - c1 * yr[k] if c1 != 0.0 else s * v
        yr[k] = val
        acc += np.float64(xr[k]) * np.float64(val)
    for k in range(shift, nz):
        v = row[k] + (pr[k] - plow[k - shift]) * _on(dr[k])
        val = s * v - c1 * yr[k] if c1 != 0.0 else s * v
        yr[k] = val
        acc += np.float64(xr[k]) * np.float64(val)
    return acc


@_SERIAL.inline
def _fetch_momentum(d, q, ya, i, ip, j):
    """Prefetch the rows of a momentum equation's streams a few j ahead: the diagonal, the
    component's next plane and the output (kernels._fetch)."""
    _fetch(d, i, j)
    _fetch(q, ip, j)
    _fetch(ya, i, j)


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def stokes_lanczos(du, dv, dw, cu, cv, cw, fluid, x, s, c1, y):
    """``y <- s K x - c1 y`` in place for the MAC Stokes matrix of
    :mod:`solvers.voxel.kernels` (staircase); returns ``x . y_new`` (float64).

    ``y`` is read only when ``c1 != 0`` (the first Lanczos step passes ``c1 = 0`` and any
    ``y``).  With :func:`solvers.voxel.kernels.unit_couplings` (periodic staircase grids) one
    flat prefetching loop per equation and x-plane (:func:`_lanczos_flat_slab`); otherwise rows
    along k, one temporary row per outer index.
    """
    nx = fluid.shape[0]
    acc = np.zeros(nx)
    for i in nb.prange(nx):
        acc[i] = _lanczos_slab(du, dv, dw, cu, cv, cw, fluid, x, s, c1, y, np.int64(i))
    return ordered_sum(acc)


@_SERIAL.slab(**_OPTS)
def _lanczos_slab(du, dv, dw, cu, cv, cw, fluid, x, s, c1, y, i):
    """Plane ``i`` of :func:`stokes_lanczos`; returns its ``x . y_new`` (12 parameters: the
    kernel's and ``i``)."""
    nx, ny, nz = fluid.shape
    if _unit(du, cu[0]) and _unit(dv, cv[0]) and _unit(dw, cw[0]):
        return _lanczos_flat_slab(du, dv, dw, fluid, x, s, c1, y, i)
    u = x[0]
    v = x[1]
    w = x[2]
    p = x[3]
    row = np.empty(nz, dtype=y.dtype)
    s_y = 0.0
    im = _dn(i, nx)
    ip = _up(i, nx)
    # one equation over the whole plane at a time (the rows of one momentum component, then the
    # continuity rows): about 9 arrays streamed at once instead of about 25 when the four rows
    # of each (i, j) were formed together, which the hardware prefetchers did not follow
    # (-15 % CPU at 200^3, the same values; benchmarks/RESULTS.md, vec10)
    # each loop prefetches the rows a few j ahead of the arrays it streams from memory
    # (kernels._fetch; the same values)
    for j in range(ny):
        _fetch_momentum(du, u, y[0], i, ip, j)
        _fetch(p, i, j)
        s_y += _momentum_lanczos(du, cu, u, p[i, j], p[im, j], 0, i, j, s, c1, y[0, i, j], row)
    for j in range(ny):
        _fetch_momentum(dv, v, y[1], i, ip, j)
        pr = p[i, j]
        s_y += _momentum_lanczos(dv, cv, v, pr, p[i, _dn(j, ny)], 0, i, j, s, c1, y[1, i, j], row)
    for j in range(ny):
        _fetch_momentum(dw, w, y[2], i, ip, j)
        pr = p[i, j]
        s_y += _momentum_lanczos(dw, cw, w, pr, pr, 1, i, j, s, c1, y[2, i, j], row)
    for j in range(ny):
        _fetch(fluid, i, j)
        _fetch(y[3], i, j)
        jp = _up(j, ny)
        pr = p[i, j]
        ur = u[i, j]
        uip = u[ip, j]
        vr = v[i, j]
        vjp = v[i, jp]
        wr = w[i, j]
        fr = fluid[i, j]
        for k in range(nz - 1):
            row[k] = (ur[k] - uip[k] + vr[k] - vjp[k] + wr[k] - wr[k + 1]) * _on(fr[k])
        k = nz - 1
        row[k] = (ur[k] - uip[k] + vr[k] - vjp[k] + wr[k] - wr[0]) * _on(fr[k])
        s_y += _combine(row, s, c1, y[3, i, j], pr)
    return s_y


@_SERIAL.leaf
def _lanczos_value(v, s, c1, yo, upd):
    """``s v - c1 yo`` (``yo`` unused unless ``upd``: it may hold garbage when ``c1 == 0``)."""
    return s * v - c1 * yo if upd else s * v


@_SERIAL.leaf
def _momentum_value(dk, xc, sm, pc, plo):
    """One momentum row entry of the staircase operator with unit couplings: the stencil of
    :func:`solvers.voxel.kernels._stencil_rows_unit` from the neighbours' sum ``sm`` plus the
    pressure difference ``pc - plo`` (0 on an inactive face), as :func:`_momentum_lanczos`."""
    return (dk * xc - sm) * _on(dk) + (pc - plo) * _on(dk)


@_SERIAL.inline
def _momentum_flat(fd, fx, fy, q0, c0, xm, xp, p0, pb, ny, nz, s, c1, pf):
    """The interior rows (``1 <= j <= ny - 2``) of one momentum component of
    :func:`_lanczos_flat_slab` as one flat loop over the plane (flat offsets: ``q0`` the plane
    in ``fd``; ``c0, xm, xp`` the component's planes ``i, i - 1, i + 1`` and ``p0`` the
    pressure plane ``i`` in ``fx``, ``fy``; the lower pressure of cell ``t`` at ``pb + t``), in
    blocks of :data:`~solvers.voxel.kernels.BLOCK` cells, each prefetching the lines
    :data:`~solvers.voxel.kernels.PREFETCH` cells ahead in the streams from memory (``y``,
    ``d``, the plane ``i + 1`` of ``x``, and ``pf``: the pressure plane ``i`` or None).  The two
    k-ends of each row come out wrong (their k-neighbours are the next rows' entries) and are
    redone by :func:`_momentum_ends`."""
    pl = _u(ny * nz)
    unz = _u(nz)
    one = _u(1)
    upd = c1 != 0.0
    t0 = unz
    while t0 < pl - unz:
        qa = t0 + _u(PREFETCH)
        _fetch_lines(fy, c0 + qa, 16)
        _fetch_lines(fx, xp + qa, 16)
        _fetch_lines(fd, q0 + qa, 64)
        _fetch_lines(pf, p0 + qa, 16)
        t1 = min(t0 + _u(FLAT_BLOCK), pl - unz)
        for t in range(t0, t1):
            c = c0 + t
            sm = fx[xm + t] + fx[xp + t] + fx[c - unz] + fx[c + unz] + fx[c - one] + fx[c + one]
            v = _momentum_value(fd[q0 + t], fx[c], sm, fx[p0 + t], fx[pb + t])
            fy[c] = _lanczos_value(v, s, c1, fy[c], upd)
        t0 = t1


@_SERIAL.inline
def _momentum_wraps(fd, fx, fy, q0, c0, xm, xp, p0, pb, a, ny, nz, s, c1):
    """The rows 0 and ``ny - 1`` of :func:`_momentum_flat`'s plane (their y-neighbours wrap;
    the lower pressure of component ``a == 1`` too), vectorised along ``1 <= k <= nz - 2``."""
    unz = _u(nz)
    one = _u(1)
    upd = c1 != 0.0
    for r in range(_wrap_rows(ny)):
        j = _wrap_row(r, ny)
        rj = _u(j * nz)
        rm = _u(_dn(j, ny) * nz)
        rp = _u(_up(j, ny) * nz)
        plo = p0 + rm if a == 1 else pb + rj
        for k in range(one, unz - one):
            t = rj + k
            c = c0 + t
            sm = (
                fx[xm + t]
                + fx[xp + t]
                + fx[c0 + rm + k]
                + fx[c0 + rp + k]
                + fx[c - one]
                + fx[c + one]
            )
            v = _momentum_value(fd[q0 + t], fx[c], sm, fx[p0 + t], fx[plo + k])
            fy[c] = _lanczos_value(v, s, c1, fy[c], upd)


@_SERIAL.inline
def _momentum_ends(fd, fx, fy, q0, c0, xm, xp, p0, pb, a, ny, nz, s, c1, saved):
    """The k-ends of every row of :func:`_momentum_flat`'s plane with their periodic
    neighbours; ``saved[2 j + e]``: the entry of ``y`` there before the flat loop overwrote it
    (:func:`_save_ends`)."""
    upd = c1 != 0.0
    for j in range(ny):
        for e in range(_ends(nz)):
            k = 0 if e == 0 else nz - 1
            t = _u(j * nz + k)
            jm = _u(_dn(j, ny) * nz + k)
            km = _u(j * nz + _dn(k, nz))
            c = c0 + t
            sm = _wrap_sum(fx, c0, fx, xm, fx, xp, j, k, ny, nz)
            plo = pb + t if a == 0 else p0 + jm if a == 1 else p0 + km
            v = _momentum_value(fd[q0 + t], fx[c], sm, fx[p0 + t], fx[plo])
            fy[c] = _lanczos_value(v, s, c1, saved[2 * j + e], upd)


@_SERIAL.leaf
def _save_ends(fy, c0, ny, nz, saved):
    """``saved[2 j + e]`` = the entry of the plane at ``fy[c0:]`` at the ``e``-th k-end of row
    ``j`` (k = 0, nz - 1)."""
    for j in range(ny):
        for e in range(_ends(nz)):
            saved[2 * j + e] = fy[c0 + _u(j * nz + (0 if e == 0 else nz - 1))]


@_SERIAL.inline
def _momentum_plane(fd, fx, fy, q0, c0, xm, xp, p0, pb, a, ny, nz, s, c1, saved, pf):
    """Plane ``c0`` of momentum component ``a`` of :func:`_lanczos_flat_slab`; returns its
    ``x . y_new``."""
    _save_ends(fy, c0, ny, nz, saved)
    _momentum_flat(fd, fx, fy, q0, c0, xm, xp, p0, pb, ny, nz, s, c1, pf)
    _momentum_wraps(fd, fx, fy, q0, c0, xm, xp, p0, pb, a, ny, nz, s, c1)
    _momentum_ends(fd, fx, fy, q0, c0, xm, xp, p0, pb, a, ny, nz, s, c1, saved)
    return _plane_dot(fx, fy, c0, _u(ny * nz))


@_SERIAL.inline
def _continuity_plane(ff, fx, fy, q0, uu, uip, vv, ww, p0, ny, nz, s, c1, saved):
    """Plane ``p0`` of the continuity rows of :func:`_lanczos_flat_slab` (the divergence of the
    velocity planes at ``uu, uip`` (``u`` planes ``i, i + 1``), ``vv, ww``); returns its ``x .
    y_new``.  One flat prefetching loop over every row but the last (whose ``v``-neighbour
    wraps), that row vectorised apart, then the k-ends (the ``w``-neighbour wraps) with the
    entries of ``y`` saved before the flat loop overwrote them."""
    pl = _u(ny * nz)
    unz = _u(nz)
    one = _u(1)
    upd = c1 != 0.0
    for j in range(ny):
        saved[j] = fy[p0 + _u(j * nz + nz - 1)]
    hi = pl - unz
    t0 = _u(0)
    while t0 < hi:
        qa = t0 + _u(PREFETCH)
        _fetch_lines(fy, p0 + qa, 16)
        _fetch_lines(ff, q0 + qa, 64)
        _fetch_lines(fx, uip + qa, 16)
        t1 = min(t0 + _u(FLAT_BLOCK), hi)
        for t in range(t0, t1):
            div = (
                fx[uu + t]
                - fx[uip + t]
                + fx[vv + t]
                - fx[vv + t + unz]
                + fx[ww + t]
                - fx[ww + t + one]
            )
            fy[p0 + t] = _lanczos_value(div * _on(ff[q0 + t]), s, c1, fy[p0 + t], upd)
        t0 = t1
    for k in range(_u(0), unz - one):  # the last row: its v-neighbour is row 0
        t = hi + k
        div = fx[uu + t] - fx[uip + t] + fx[vv + t] - fx[vv + k] + fx[ww + t] - fx[ww + t + one]
        fy[p0 + t] = _lanczos_value(div * _on(ff[q0 + t]), s, c1, fy[p0 + t], upd)
    for j in range(ny):  # the last entry of every row: its w-neighbour is the row's first
        rj = _u(j * nz)
        t = rj + unz - one
        div = (
            fx[uu + t] - fx[uip + t] + fx[vv + t] - fx[vv + _u(_up(j, ny) * nz) + unz - one]
            + fx[ww + t] - fx[ww + rj]
        )  # fmt: skip
        fy[p0 + t] = _lanczos_value(div * _on(ff[q0 + t]), s, c1, saved[j], upd)
    return _plane_dot(fx, fy, p0, pl)


@_SERIAL.inline
def _lanczos_flat_slab(du, dv, dw, fluid, x, s, c1, y, i):
    """Plane ``i`` of :func:`stokes_lanczos` when every component has
    :func:`solvers.voxel.kernels.unit_couplings` (the staircase's periodic grids): each
    equation's plane is one flat loop with software prefetch, as the multigrid's finest sweeps
    (:func:`solvers.voxel.kernels._jacobi_flat`), the row ends and wrap rows redone apart, and
    ``x . y_new`` summed per plane from cache: 0.84-0.89x the one-thread CPU of the row loops
    of :func:`_lanczos_slab` at 200^3; 1.55x without the prefetch (``benchmarks/RESULTS.md``,
    band15).  The same expressions, so the same values up to float32 round-off (fastmath may
    contract them differently).

    Inlined into :func:`_lanczos_slab` by numba, not a cached function of its own: as one, the
    call from ``_lanczos_slab`` reached either its own compile or the copy linked into its
    caller, whichever the process had loaded first, and the two differ in the last bits under
    fastmath reassociation; a staircase solve's K and residual then depended on whether the
    process had compiled the kernels (session 37: K 2.6e-11 apart, residual 5.3477e-07 vs
    5.3271e-07).  Inlined, one code in every process; +12 s CPU on a cold compile of
    :func:`stokes_lanczos`'s twins (61-62 -> 72-74 s), the product's speed unchanged."""
    nx, ny, nz = fluid.shape
    fx = simd.flat(x)
    fy = simd.flat(y)
    pl = _u(ny * nz)
    n3 = _u(nx) * pl
    q0 = _u(i) * pl
    qm = _u(_dn(i, nx)) * pl
    qp = _u(_up(i, nx)) * pl
    p0 = _u(3) * n3 + q0
    saved = np.empty(2 * ny, dtype=y.dtype)
    s_y = _momentum_plane(
        simd.flat(du), fx, fy, q0, q0, qm, qp, p0, _u(3) * n3 + qm, 0, ny, nz, s, c1, saved, fx
    )
    s_y += _momentum_plane(
        simd.flat(dv), fx, fy, q0, n3 + q0, n3 + qm, n3 + qp, p0, p0 - _u(nz), 1, ny, nz, s, c1,
        saved, None,
    )  # fmt: skip
    w0 = _u(2) * n3
    s_y += _momentum_plane(
        simd.flat(dw), fx, fy, q0, w0 + q0, w0 + qm, w0 + qp, p0, p0 - _u(1), 2, ny, nz, s, c1,
        saved, None,
    )  # fmt: skip
    s_y += _continuity_plane(
        simd.flat(fluid), fx, fy, q0, q0, qp, n3 + q0, w0 + q0, p0, ny, nz, s, c1, saved
    )
    return s_y


Q_MAX = 32767.0
"""Largest magnitude of a stored direction entry (int16): each row of a direction is stored as
``q * e`` with ``|q| <= Q_MAX`` and one float32 scale ``e`` per row (block floating point)."""


BLOCK = 16
"""Entries of a direction that share one scale (:class:`Directions`; 2 B per cell for the two
directions).  Measured, Toray-like 64^3 sub-voxel, tol 1e-6: 230 MINRES iterations with blocks
of 16, 237 with one scale per row of 64, 217 with float32 directions
(``benchmarks/RESULTS.md``)."""


class Directions:
    """A MINRES direction stored in 16 bits per entry: ``int16`` mantissas ``q`` (4 fields x
    grid) and one float32 scale ``e`` per block of :data:`BLOCK` consecutive entries along the
    last axis (per row when the row length is not a multiple of it); the value is ``q * e``
    (absolute error at most ``max|block| / 65534``).

    Parameters
    ----------
    shape : tuple of int
        ``(4, nx, ny, nz)``.
    """

    def __init__(self, shape: tuple[int, ...], bits: int | None = None) -> None:
        bits = DIRECTION_BITS if bits is None else bits
        if bits not in (16, 32):
            raise ValueError(f"direction bits must be 16 or 32, got {bits!r}")
        self.q = np.zeros(shape, np.int16 if bits == 16 else np.float32)
        nz = shape[-1]
        block = BLOCK if nz % BLOCK == 0 and bits == 16 else nz
        self.e = np.zeros(int(np.prod(shape)) // block, np.float32)

    @property
    def block(self) -> int:
        """Entries per scale."""
        return self.q.size // self.e.size

    def clear(self) -> None:
        """Set the direction to zero."""
        self.q.fill(0)
        self.e.fill(0.0)

    def value(self) -> np.ndarray:
        """The stored direction as a float32 array (a copy; for tests)."""
        b = self.block
        return (self.q.reshape(-1, b).astype(np.float32) * self.e[:, None]).reshape(self.q.shape)


class Solution:
    """The Krylov solution in 40 or 48 bits per entry: float32 ``hi`` plus, once :meth:`extend`
    has run, an int8 (``tol >=`` :data:`solvers.voxel.memory.SHORT_SOLUTION_FROM`, 1e-6) or
    int16 ``lo`` in units of a per-field power of two ``scale`` below the float32 round-off of
    the field's largest entry (value ``hi + lo * scale``, absolute error at most ``2^-31``
    (int8) or ``2^-37`` (int16) of that entry); an int32 ``lo`` (float64 precision) for ``tol``
    below :data:`solvers.voxel.memory.TIGHT_TOL_BELOW` (1e-7).

    A float32 solution alone cannot go below a true relative residual of about 1e-6 (the
    round-off of the velocity times the viscous stencil: 2.6e-6 measured on PuMA fibres_32,
    ``benchmarks/RESULTS.md``); with the int16 ``lo`` the floor is about ``2.5e-11`` times the
    largest velocity in voxel units (~1e-9 on fibres_32; the 40^3 cylinder arrays along the
    fibres, velocities of a few hundred, missed tol 1e-9 with it: hence int32 below 1e-7).
    ``lo`` is allocated after the first refinement cycle
    (:func:`solvers.voxel_stokes._solve_core`), when the field's size is known, so the first
    cycle runs on ``hi`` alone.
    """

    LO_BITS_BELOW = {1: 32, 2: 38, 4: 52}
    """``scale = 2^(E - bits)`` for a field whose largest magnitude times 2 is below ``2^E``, by
    the byte size of ``lo``: 8 (int8), 14 (int16) or 28 (int32) bits below float32's 24-bit
    mantissa, so ``|lo|`` stays within its range (int8: up to 128, clipped at 127 on an exact
    tie) or a quarter of it (int16, int32) while the entries stay below twice the largest one
    at :meth:`extend` (clipped beyond).  int8 (40 bits in all, ``2^-31`` of the row's largest
    entry, one scale per row: :meth:`_row_scales`) only for ``tol >= SHORT_SOLUTION_FROM``: at
    tol 1e-6 on the Toray-like grids, with one scale per field, ``2^(E - 31)`` added a third
    refinement cycle at 100^3 (160 instead of 153 iterations), ``2^(E - 32)`` and ``2^(E - 33)``
    did not there but did at 200^3 (190 instead of 180), and so did one scale per row
    (``benchmarks/RESULTS.md``, issue 16 session 9)."""

    def __init__(self, shape: tuple[int, ...], packing: Packing | None = None) -> None:
        self.shape = shape
        self.packing = packing
        self.hi = np.zeros(shape if packing is None else packing.size, np.float32)
        self.lo = np.zeros((0,) * self.hi.ndim, np.int16)
        self.scale = np.ones(shape[0])
        self.widened = False

    def _field(self, arr: np.ndarray, a: int) -> np.ndarray:
        return arr[a] if self.packing is None else self.packing.field(arr, a)

    @property
    def extended(self) -> bool:
        """True once :meth:`extend` has allocated ``lo``."""
        return self.lo.size > 0

    def extend(self, tol: float = 1e-6) -> None:
        """Allocate ``lo`` (zero; int32 if ``tol < LO32_BELOW``; int8 for a packed solution,
        SYMMLQ's, if ``tol >=`` :data:`solvers.voxel.memory.SHORT_SOLUTION_FROM`; else int16)
        and set the scales from the current ``hi``: one per field, or, with int8, one per row
        (:meth:`_row_scales`)."""
        if self.extended:
            return
        short = self.short(tol)
        dtype = np.int32 if tol < LO32_BELOW else np.int8 if short else np.int16
        bits = self.LO_BITS_BELOW[np.dtype(dtype).itemsize]
        fields = [self._field(self.hi, a) for a in range(self.shape[0])]
        mags = [max(float(f.max()), -float(f.min())) if f.size else 0.0 for f in fields]
        top = max(mags)
        for a, m in enumerate(mags):
            m = m if m > 0.0 else top
            self.scale[a] = 2.0 ** (np.frexp(2.0 * m)[1] - bits) if m > 0 else 1.0
        if short:
            self.scale = self._row_scales(bits)
        self.lo = np.zeros(self.hi.shape, dtype)

    def short(self, tol: float) -> bool:
        """True when :meth:`extend` gives the int8 extension at ``tol``: a packed solution,
        ``tol >=`` :data:`solvers.voxel.memory.SHORT_SOLUTION_FROM`, not :meth:`widen`-ed."""
        return self.packing is not None and tol >= vmem.SHORT_SOLUTION_FROM and not self.widened

    def widen(self) -> None:
        """Fold the int8 extension into ``hi`` (float32 rounding) and make the next
        :meth:`extend` an int16 one: the way past the int8 extension's residual floor, which
        lies just above ``tol`` 1e-6 on some grids (hexagonal array along the rods, phi 0.1, 82
        voxels per spacing, two cells, permeameter: the residual stalled at 1.05e-6;
        ``benchmarks/RESULTS.md``, session 10).  One field at a time, so the fold's temporaries
        are two float32 arrays of one field."""
        if self.lo.dtype == np.int8:
            pk = self.packing
            per = pk.shape[1] * pk.shape[2]
            for a, mask in enumerate(pk.masks):
                rows = np.count_nonzero(mask, axis=2).ravel()
                scales = np.repeat(self.scale[a * per : (a + 1) * per], rows)
                hi = pk.field(self.hi, a)
                hi += pk.field(self.lo, a) * scales
            self.lo = np.zeros((0,) * self.hi.ndim, np.int16)
            self.scale = np.ones(self.shape[0])
        self.widened = True

    ROW_RANGE = 8
    """Row scales (int8 extension) are at most ``2^ROW_RANGE`` below their field's: an entry
    that outgrows its row's scale later is clipped to its float32 round-off, which stays below
    the field's scale for entries below ``2^-ROW_RANGE`` of the field's largest."""

    def _row_scales(self, bits: int) -> np.ndarray:
        """float32 scale of every row (``4 nx ny``; 4 B per row, 0.5 B per cell at nz = 32):
        ``2^(E_row - bits)`` from the row's largest magnitude as for the field (rows without
        entries take the field's), at least ``2^-ROW_RANGE`` times the field's.  The
        quantisation error of the solution then follows the local magnitude (Toray-like 100^3,
        tol 1e-6: final true residual 7.6e-7 against 9.2e-7 with one scale per field and
        4.3e-7 with the int16 extension; ``benchmarks/RESULTS.md``, issue 16 session 9)."""
        pk = self.packing
        per = pk.shape[1] * pk.shape[2]
        rows = np.empty(4 * per)
        packed_row_absmax(self.hi, *pk.masks, pk.start, rows)
        out = np.empty(rows.size, np.float32)
        for a in range(4):
            sl = slice(a * per, (a + 1) * per)
            ef = int(np.frexp(self.scale[a])[1]) - 1  # the field's exponent minus bits
            e = np.frexp(2.0 * rows[sl])[1] - bits
            e = np.where(rows[sl] > 0.0, np.maximum(e, ef - self.ROW_RANGE), ef)
            out[sl] = np.ldexp(1.0, np.maximum(e, -120))
        return out

    def lo_value(self, out: np.ndarray) -> np.ndarray:
        """``out <- lo * scale`` (float32), zero before :meth:`extend`."""
        if not self.extended:
            out.fill(0.0)
        elif self.packing is not None:
            self.packing.unpack(self.lo, out, self.scale)
        else:
            for a in range(out.shape[0]):
                np.multiply(self.lo[a], np.float32(self.scale[a]), out=out[a])
        return out

    def hi_value(self, out: np.ndarray) -> np.ndarray:
        """``hi`` on the grid: ``hi`` itself, or unpacked into ``out`` (float32)."""
        if self.packing is None:
            return self.hi
        self.packing.unpack(self.hi, out)
        return out

    def value(self) -> np.ndarray:
        """The solution as a new float64 array."""
        if self.packing is None:
            x = self.hi.astype(np.float64)
            if self.extended:
                for a in range(x.shape[0]):
                    x[a] += self.lo[a] * self.scale[a]
            return x
        x = np.zeros(self.shape)
        pk = self.packing
        unpack_planes(self.hi, np.ones(4), *pk.masks, pk.start, x, False)
        if self.extended:
            unpack_planes(self.lo, self.scale, *pk.masks, pk.start, x, True)
        return x


@_SERIAL.leaf
def _quantise_row(row, m, q, t, e):
    """Store ``row`` (largest magnitude ``m``) as ``q[t] * e[t]`` (float32 ``q``: as is)."""
    if q.itemsize == 4:
        e[t] = 1.0
        for k in range(row.shape[0]):
            q[t, k] = row[k]
    elif m > 0.0:
        inv = Q_MAX / m
        e[t] = m / Q_MAX
        for k in range(row.shape[0]):
            q[t, k] = np.int16(np.rint(row[k] * inv))
    else:
        e[t] = 0.0
        for k in range(row.shape[0]):
            q[t, k] = 0


@_SERIAL.leaf
def _lo_max(lo):
    """Largest magnitude of the solution's integer extension ``lo`` (int8, int16 or int32)."""
    if lo.itemsize == 1:
        return 127.0
    return 32767.0 if lo.itemsize == 2 else 2147483647.0


ROWS_PER_TASK = 64
"""Rows (or blocks) of a 4-field vector per parallel task of :func:`minres_direction` (one work
row allocated per task, not per row)."""


@_SERIAL.inline
def _solution_row(hr, lr, sc, cu, r0, lmax):
    """``x += cu r0`` on one row of the solution: ``hr`` alone (``lr`` empty), or ``hr + lr sc``
    updated in float64 and split again into float32 ``hr`` and the integer ``lr`` (``sc`` a
    power of two, so the multiplication by its inverse is the exact division)."""
    nz = r0.shape[0]
    if lr.shape[0] > 0:
        inv = 1.0 / sc
        for k in range(nz):
            xe = np.float64(hr[k]) + lr[k] * sc + cu * np.float64(r0[k])
            h = np.float32(xe)
            hr[k] = h
            lq = np.rint((xe - np.float64(h)) * inv)
            lr[k] = min(max(lq, -lmax), lmax)
    else:
        for k in range(nz):
            hr[k] += cu * np.float64(r0[k])


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def minres_direction(z, s, q1, e1, a1, q0, e0, a0, xh, xl, xs, cx):
    """``u1 <- s z - a1 u1 - a0 u`` (the next unscaled MINRES direction) and ``x += cx u``
    (the previous direction's solution update) in one pass.

    The directions ``u = q0 * e0`` and ``u1 = q1 * e1`` are float32 (``e = 1``) or row-scaled
    int16 (:class:`Directions`; the new ``u1`` is quantised row by row); the solution is ``xh``
    (any float dtype) or, when ``xl`` is not empty, ``xh + xl * xs[field]`` (:class:`Solution`),
    updated in float64 and split again into float32 ``xh`` and int16 ``xl``.  Each row is
    walked in two plain loops (the solution, then the direction: written in place for float32
    directions), which LLVM vectorises; one loop over all seven arrays was left scalar
    (3.5x slower, issue 16)."""
    nz = z.size // e1.size  # entries per scale (a row along the last axis or a block of it)
    fz = z.reshape(-1, nz)
    f1 = q1.reshape(-1, nz)
    f0 = q0.reshape(-1, nz)
    fh = xh.reshape(-1, nz)
    extended = xl.size > 0
    fl = xl.reshape(-1, nz) if extended else xl.reshape(0, nz)
    lmax = _lo_max(xl)
    nrow = fz.shape[0]
    per = nrow // xs.shape[0]
    direct = q1.itemsize == 4
    ntask = (nrow + ROWS_PER_TASK - 1) // ROWS_PER_TASK
    for task in nb.prange(ntask):
        row = np.empty(nz, np.float32)
        for t in range(task * ROWS_PER_TASK, min(nrow, (task + 1) * ROWS_PER_TASK)):
            zr = fz[t]
            r1 = f1[t]
            r0 = f0[t]
            c1 = a1 * e1[t]
            c0 = a0 * e0[t]
            lr = fl[t] if extended else fl.reshape(-1)
            _solution_row(fh[t], lr, xs[t // per], cx * e0[t], r0, lmax)
            if direct:
                for k in range(nz):
                    r1[k] = np.float32(s * zr[k] - c1 * r1[k] - c0 * np.float64(r0[k]))
                e1[t] = 1.0
            else:
                m = 0.0
                for k in range(nz):
                    val = np.float32(s * zr[k] - c1 * r1[k] - c0 * np.float64(r0[k]))
                    row[k] = val
                    m = max(m, abs(val))
                _quantise_row(row, m, f1, t, e1)


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def add_direction(xh, xl, xs, c, q, e):
    """``x += c u`` for a row-scaled int16 direction ``u = q * e`` and the solution of
    :func:`minres_direction` (``xh``, or ``xh + xl * xs[field]`` when ``xl`` is not empty)."""
    nz = xh.size // e.size
    fh = xh.reshape(-1, nz)
    fq = q.reshape(-1, nz)
    extended = xl.size > 0
    fl = xl.reshape(-1, nz) if extended else xl.reshape(0, nz)
    lmax = _lo_max(xl)
    nrow = fh.shape[0]
    per = nrow // xs.shape[0]
    for t in nb.prange(nrow):
        lr = fl[t] if extended else fl.reshape(-1)
        _solution_row(fh[t], lr, xs[t // per], c * e[t], fq[t], lmax)


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def subtract_sq(r, y):
    """``r -= y`` (flat, parallel); returns the float64 ``||r||^2`` of the result."""
    m = r.shape[0] * r.shape[1]  # one partial sum per plane (per row: 1 B per cell at 32^3)
    fr = r.reshape(m, -1)
    fy = y.reshape(m, -1)
    n = fr.shape[1]
    part = np.zeros(m)
    for t in nb.prange(m):
        rr = fr[t]
        yr = fy[t]
        acc = 0.0
        for k in range(n):
            val = rr[k] - yr[k]
            rr[k] = val
            acc += np.float64(val) * np.float64(val)
        part[t] = acc
    return ordered_sum(part)


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def add_scaled(x, c, u):
    """``x += c u`` (flat, parallel; any float dtypes, e.g. float64 ``x`` and float32 ``u``)."""
    fx = x.ravel()
    fu = u.ravel()
    for q in nb.prange(fx.size):
        fx[q] += c * fu[q]


class Packing:
    """The active unknowns of the four fields of a vector, in C order (the layout of the packed
    vectors of :func:`symmlq_step`: SYMMLQ's direction and the solution, which never enter a
    stencil): every vector of the solve vanishes on the inactive unknowns (the kernels write 0
    there), so they are not stored (on the Toray-like grids 23 % of the entries).

    Only the offset of each plane is stored (``start``, int64 per plane of a field: 4 nx + 1
    entries); the kernels count a row's active entries as they gather them (per row, 8 B per
    row of nz entries, was 1 B per cell at nz = 32).

    Parameters
    ----------
    masks : list of 4 np.ndarray
        ``(nx, ny, nz)`` arrays, non-zero on the active unknowns: the three velocity diagonals
        and the pressure-cell mask (references, not copied).
    """

    def __init__(self, masks: list[np.ndarray]) -> None:
        self.masks = masks
        self.shape = (4, *masks[0].shape)
        nx = self.shape[1]
        counts = np.concatenate([np.count_nonzero(m.reshape(nx, -1), axis=1) for m in masks])
        self.start = np.zeros(counts.size + 1, np.int64)
        np.cumsum(counts, out=self.start[1:])
        self.size = int(self.start[-1])

    def offset(self, a: int, i: int = 0) -> int:
        """First packed entry of plane ``i`` of field ``a``."""
        return int(self.start[a * self.shape[1] + i])

    def field(self, packed: np.ndarray, a: int) -> np.ndarray:
        """The packed entries of field ``a`` (a view)."""
        return packed[self.offset(a) : self.offset(a + 1)]

    def unpack(self, packed: np.ndarray, out: np.ndarray, scale: np.ndarray | None = None) -> None:
        """``out[a][active] = packed_a (* scale)``, zero elsewhere (one pass, no temporaries:
        :func:`unpack_planes`; ``scale`` per field or per row)."""
        sc = np.ones(4) if scale is None else scale
        unpack_planes(packed, sc, *self.masks, self.start, out, False)


@_SERIAL.leaf
def _count(mr):
    """Non-zero entries of the row ``mr``."""
    c = 0
    for k in range(mr.shape[0]):
        c += mr[k] != 0
    return c


@_SERIAL.inline
def _unpack_row(mr, packed, p, sc, out, add):
    """Row ``out`` from the packed entries from ``p`` on (active where ``mr != 0``, scaled by
    ``sc``; added to ``out`` if ``add``, else written with zeros elsewhere); returns the next
    row's first packed entry."""
    for k in range(mr.shape[0]):
        if mr[k] != 0:
            val = np.float64(packed[p]) * sc
            if add:
                out[k] += val
            else:
                out[k] = val
            p += 1
        elif not add:
            out[k] = 0.0
    return p


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def unpack_planes(packed, scale, du, dv, dw, fluid, start, out, add):
    """``out[a]`` (``+=`` if ``add``) from the packed entries of field ``a`` (:class:`Packing`:
    plane offsets ``start``) times ``scale`` (one per field, or one per row of the four
    fields), zero off the active unknowns."""
    nx, ny, nz = fluid.shape
    per = (4 * nx * ny) // scale.shape[0]
    for t in nb.prange(4 * nx):
        a = t // nx
        i = t - a * nx
        p = start[t]
        for j in range(ny):
            sc = np.float64(scale[(t * ny + j) // per])
            if a == 0:
                p = _unpack_row(du[i, j], packed, p, sc, out[a, i, j], add)
            elif a == 1:
                p = _unpack_row(dv[i, j], packed, p, sc, out[a, i, j], add)
            elif a == 2:
                p = _unpack_row(dw[i, j], packed, p, sc, out[a, i, j], add)
            else:
                p = _unpack_row(fluid[i, j], packed, p, sc, out[a, i, j], add)


@_SERIAL.inline
def _row_absmax(packed, p, n):
    m = 0.0
    for k in range(p, p + n):
        m = max(m, abs(np.float64(packed[k])))
    return m


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def packed_row_absmax(packed, du, dv, dw, fluid, start, out):
    """``out[row]``: the largest magnitude of the packed entries of each row (``4 nx ny``
    rows, 0 for a row without entries)."""
    nx, ny, nz = fluid.shape
    for t in nb.prange(4 * nx):
        a = t // nx
        i = t - a * nx
        p = start[t]
        for j in range(ny):
            if a == 0:
                n = _count(du[i, j])
            elif a == 1:
                n = _count(dv[i, j])
            elif a == 2:
                n = _count(dw[i, j])
            else:
                n = _count(fluid[i, j])
            out[t * ny + j] = _row_absmax(packed, p, n)
            p += n


def direction24_value(wt: np.ndarray, wm: np.ndarray) -> np.ndarray:
    """The float32 value of a 24-bit direction of :func:`symmlq_step` (upper 16 bits ``wt``,
    next 8 bits ``wm``; a copy, for tests)."""
    bits = (wt.astype(np.uint32) << np.uint32(16)) | (wm.astype(np.uint32) << np.uint32(8))
    return bits.view(np.float32)


@_SERIAL.inline
def _gather(mr, zr, zc):
    """The entries of ``zr`` where ``mr != 0`` into ``zc``; returns how many.  Sixteen at a time
    by :func:`solvers.voxel.simd.compress16` (the scalar loop below, which LLVM does not
    vectorise, cost about 6 ms of CPU per iteration at 200^3), the rest of the row branch-free."""
    n = zr.shape[0]
    c = 0
    k = 0
    while k + simd.WIDTH <= n:
        c += simd.compress16(zr, mr, zc, k, c)
        k += simd.WIDTH
    for t in range(k, n):
        zc[c] = zr[t]
        c += mr[t] != 0
    return c


@_SERIAL.inline
def _rotate32(wsrc, zc, row, wdst, n, s, cs, sn):
    """The rotation of :func:`symmlq_step` on ``n`` entries in float32 arithmetic (``v = s
    zc``): ``row <- cs w + sn v`` (the finished direction) and ``wdst <- sn w - cs v`` (``w``
    read from ``wsrc``; the two may be one array).  float32, not float64, in every cycle: where
    the direction is stored in 24 bits (16 of mantissa) float32's 2^-24 round-off is below what
    is kept; where it is stored as a full float32 (first cycles, tol below 1e-6, after
    ``widen``) the arithmetic's round-off is the storage's size, and the justification is
    measured (same iterations, K within 1.1e-10 on nine validation cases); the loop runs 8
    lanes wide without the four float32/float64 conversions per 4 entries of the float64 form
    (``benchmarks/RESULTS.md``, session 47)."""
    s32 = np.float32(s)
    c32 = np.float32(cs)
    n32 = np.float32(sn)
    for k in range(n):
        v = s32 * zc[k]
        wo = wsrc[k]
        row[k] = c32 * wo + n32 * v
        wdst[k] = n32 * wo - c32 * v


@_SERIAL.inline
def _two_sum(a, b):
    """``(s, e)`` with ``s = fl(a + b)`` and ``a + b = s + e`` exactly (Knuth's TwoSum; exact
    only without reassociation: :data:`_EXACT_OPTS`)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@_SERIAL.inline
def _solution_row8(hr, lr, sc, cu, r0, lmax):
    """``x += cu r0`` on one row of the solution ``hr + lr sc`` with the int8 extension, in
    float32: ``d = cu r0`` rounded to float32, ``hr + d = s + e`` and ``s + (lr sc + e) = h +
    rem`` exactly (:func:`_two_sum`), ``hr <- h``, ``lr <- rint(rem / sc)`` (``sc`` a power of
    two, so the multiplication by its inverse is the exact division).  Same invariant as the
    float64 form of :func:`_solution_row` (``|rem| <=`` half an ulp of ``h``, ``lr`` clamped to
    +-127); ``d`` is rounded twice (``cu`` to float32, then the product): up to ~``2^-23`` of
    the step, below the extension's ``2^-31`` of the row's largest entry once the steps are
    below ~``2^-8`` of it (the later refinement
    cycles, which alone carry the extension, correct a solution already within ~1e-4)."""
    c = np.float32(cu)
    s32 = np.float32(sc)
    inv = np.float32(1.0 / sc)
    lm = np.float32(lmax)
    for k in range(r0.shape[0]):
        s, e = _two_sum(hr[k], c * r0[k])
        h, rem = _two_sum(s, np.float32(lr[k]) * s32 + e)
        hr[k] = h
        lr[k] = min(max(np.rint(rem * inv), -lm), lm)


@_SERIAL.inline
def _packed_row(mr, zr, s, wt, wm, h, lo, p, cs, sn, zeta, sc, lmax, zc, row, wrow, bits):
    """:func:`symmlq_step` on one row from packed entry ``p`` on: ``mr`` the row's activity,
    ``wt, wm, h, lo`` the packed direction and solution (``lo`` empty: the solution is ``h``
    alone; ``wm`` empty: ``wt`` is the float32 direction, else the 24-bit one, see
    :func:`symmlq_step`).  The active entries of ``zr`` are gathered into ``zc`` first; the rest
    runs on contiguous slices in plain loops (vectorised; one loop over the mask was 2.9x
    slower, one loop for the rotation and the solution no faster).  Returns the next row's
    first packed entry."""
    n = _gather(mr, zr, zc)
    if n == 0:
        return p
    q = p + n
    if wm.shape[0] > 0:  # 24-bit direction: float32 bits 31..8 in uint16 + uint8
        wt_r = wt[p:q]
        wm_r = wm[p:q]
        for k in range(n):
            bits[k] = (np.uint32(wt_r[k]) << np.uint32(16)) | (np.uint32(wm_r[k]) << np.uint32(8))
        _rotate32(wrow, zc, row, wrow, n, s, cs, sn)
        for k in range(n):
            b = bits[k] + np.uint32(0x80)  # round the magnitude to nearest (ties away)
            wt_r[k] = np.uint16(b >> np.uint32(16))
            wm_r[k] = np.uint8((b >> np.uint32(8)) & np.uint32(0xFF))
    else:
        _rotate32(wt[p:q], zc, row, wt[p:q], n, s, cs, sn)
    if zeta != 0.0:
        if lo.itemsize == 1 and lo.shape[0] > 0:
            _solution_row8(h[p:q], lo[p:q], sc, zeta, row[:n], lmax)
        else:
            lr = lo[p:q] if lo.shape[0] > 0 else lo
            _solution_row(h[p:q], lr, sc, zeta, row[:n], lmax)
    return q


_EXACT_OPTS = {**_OPTS, "fastmath": {"nnan", "ninf", "nsz", "arcp", "afn"}}
""":data:`_OPTS` without fastmath's ``reassoc`` (it would fold :func:`_two_sum`'s error to
zero) and ``contract`` (a fused multiply-add would round the sum without the product
:func:`_two_sum` corrects for): :func:`symmlq_step`'s float32 arithmetic is then each
operation rounded once, as numpy's float32 (``tests/unit/test_voxel_lanczos.py``)."""


@parallel_kernel(helpers=_SERIAL, **_EXACT_OPTS)
def symmlq_step(z, s, wt, wm, cs, sn, xh, xl, xs, zeta, du, dv, dw, fluid, start):
    """One SYMMLQ rotation of the direction ``w`` (:func:`solvers.voxel_stokes._symmlq`'s
    ``w-bar``) with the Lanczos vector ``v = s z``: ``x += zeta (cs w + sn v)`` (the finished
    direction, rounded to float32) and ``w <- sn w - cs v`` in one pass.  ``w`` and the
    solution (``xh``, or ``xh + xl * xs[field]`` when ``xl`` is not empty: :class:`Solution`)
    are packed (:class:`Packing`: the active unknowns of ``du, dv, dw, fluid``, plane ``t`` of
    the four fields starting at ``start[t]``).  ``w`` is float32 ``wt`` (``wm`` empty) or
    24 bits per entry (:data:`solvers.voxel.memory.LATER_SYMMLQ_BITS`): the float32's upper
    16 bits in uint16 ``wt`` and the next 8 in uint8 ``wm``, rounded to nearest (relative
    error <= 2^-16).  ``cs = 1, sn = 0`` moves ``x`` to the CG point (``x += zeta w``);
    ``zeta = 0, cs = -1, sn = 0`` sets ``w = v``.

    The rotation is float32 arithmetic (:func:`_rotate32`), and so is the update of a solution
    with the int8 extension (:func:`_solution_row8`); the int16 / int32 extensions, which keep
    more than float32 pairs can, are updated in float64 (:func:`_solution_row`).  Each float32
    operation is rounded once (:data:`_EXACT_OPTS`): the values are those of the same
    expressions in numpy float32, on any thread count."""
    nx, ny, nz = fluid.shape
    lmax = _lo_max(xl)
    per = (4 * nx * ny) // xs.shape[0]  # the solution's scales: per field or per row
    for t in nb.prange(4 * nx):
        zc = np.empty(nz, np.float32)
        row = np.empty(nz, np.float32)
        wrow = np.empty(nz, np.float32)
        bits = wrow.view(np.uint32)
        a = t // nx
        i = t - a * nx
        p = start[t]
        for j in range(ny):
            sc = np.float64(xs[(t * ny + j) // per])
            zr = z[a, i, j]
            if a == 0:  # one call per field: the masks' dtypes differ (float32 / uint8)
                p = _packed_row(du[i, j], zr, s, wt, wm, xh, xl, p, cs, sn, zeta, sc, lmax, zc,
                                row, wrow, bits)  # fmt: skip
            elif a == 1:
                p = _packed_row(dv[i, j], zr, s, wt, wm, xh, xl, p, cs, sn, zeta, sc, lmax, zc,
                                row, wrow, bits)  # fmt: skip
            elif a == 2:
                p = _packed_row(dw[i, j], zr, s, wt, wm, xh, xl, p, cs, sn, zeta, sc, lmax, zc,
                                row, wrow, bits)  # fmt: skip
            else:
                p = _packed_row(fluid[i, j], zr, s, wt, wm, xh, xl, p, cs, sn, zeta, sc, lmax,
                                zc, row, wrow, bits)  # fmt: skip


_SERIAL.seal(globals())

# both twins of :func:`stokes_lanczos` call the one slab compiled over the serial helpers (plain
# leaves): the parallel twin's own slab, its leaves inlined by numba, cost 3x the serial one's
# compile (44 s against 14 s CPU) and gave other last bits on the row loops (non-unit couplings;
# benchmarks/RESULTS.md, session 48).  The slab's leaves that take arrays run per row, plane or
# block, not per entry, so the reference counts they may touch cost nothing measurable
_lanczos_slab = _SERIAL.ns["_lanczos_slab"]
