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
here with the pressure term and the Lanczos combination; ``_momentum_row_w`` for sub-voxel
walls; both also take :func:`solvers.voxel.kernels.unit_couplings`); the continuity rows are
the same expressions as in :func:`solvers.voxel.kernels._stokes_residual`.
A change to those inlined helpers recompiles this module's kernels: the numba cache stamps
cover the imported project modules (:class:`solvers.jit.DependencyLocator`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from solvers.jit import parallel_kernel
from solvers.voxel.kernels import _dn, _momentum_row_w, _stencil_rows, _unit, _up
from solvers.voxel.memory import DIRECTION_BITS
from solvers.voxel.memory import TIGHT_TOL_BELOW as LO32_BELOW

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


@nb.njit(inline="always")
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
    for k in range(nz):
        kl = k - shift if k >= shift else k - shift + nz
        v = np.float32(row[k] + (pr[k] - plow[kl])) if dr[k] != 0 else row[k]
        val = s * v - c1 * yr[k] if c1 != 0.0 else s * v
        yr[k] = val
        acc += np.float64(xr[k]) * np.float64(val)
    return acc


@parallel_kernel(**_OPTS)
def stokes_lanczos(du, dv, dw, cu, cv, cw, fluid, x, s, c1, y):
    """``y <- s K x - c1 y`` in place for the MAC Stokes matrix of
    :mod:`solvers.voxel.kernels` (staircase); returns ``x . y_new`` (float64).

    ``y`` is read only when ``c1 != 0`` (the first Lanczos step passes ``c1 = 0`` and any
    ``y``).  Rows along k, one temporary row per outer index.
    """
    nx = fluid.shape[0]
    acc = np.zeros(nx)
    for i in nb.prange(nx):
        acc[i] = _lanczos_slab(du, dv, dw, cu, cv, cw, fluid, x, s, c1, y, np.int64(i))
    return acc.sum()


@nb.njit(**_OPTS)
def _lanczos_slab(du, dv, dw, cu, cv, cw, fluid, x, s, c1, y, i):
    """Plane ``i`` of :func:`stokes_lanczos`; returns its ``x . y_new`` (12 parameters: the
    kernel's and ``i``)."""
    nx, ny, nz = fluid.shape
    u = x[0]
    v = x[1]
    w = x[2]
    p = x[3]
    row = np.empty(nz, dtype=y.dtype)
    s_y = 0.0
    im = _dn(i, nx)
    ip = _up(i, nx)
    for j in range(ny):
        jm = _dn(j, ny)
        jp = _up(j, ny)
        pr = p[i, j]
        s_y += _momentum_lanczos(du, cu, u, pr, p[im, j], 0, i, j, s, c1, y[0, i, j], row)
        s_y += _momentum_lanczos(dv, cv, v, pr, p[i, jm], 0, i, j, s, c1, y[1, i, j], row)
        s_y += _momentum_lanczos(dw, cw, w, pr, pr, 1, i, j, s, c1, y[2, i, j], row)
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
    return s_y


@parallel_kernel(**_OPTS)
def stokes_lanczos_w(du, dv, dw, cu, cv, cw, fluid, wu, wv, ww, x, s, c1, y):
    """:func:`stokes_lanczos` for the face-weighted (sub-voxel) matrix of
    :func:`solvers.voxel.kernels._stokes_residual`."""
    nx = fluid.shape[0]
    acc = np.zeros(nx)
    for i in nb.prange(nx):
        acc[i] = _lanczos_w_slab(
            du, dv, dw, cu, cv, cw, fluid, wu, wv, ww, x, s, c1, y, np.int64(i)
        )
    return acc.sum()


@nb.njit(**_OPTS)
def _lanczos_w_slab(du, dv, dw, cu, cv, cw, fluid, wu, wv, ww, x, s, c1, y, i):
    """Plane ``i`` of :func:`stokes_lanczos_w`; returns its ``x . y_new`` (15 parameters: the
    kernel's and ``i``)."""
    nx, ny, nz = fluid.shape
    u = x[0]
    v = x[1]
    w = x[2]
    p = x[3]
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
    """The MINRES solution in 48 bits per entry: float32 ``hi`` plus, once :meth:`extend` has
    run, an int16 ``lo`` in units of a per-field power of two ``scale`` below the float32
    round-off of the field's largest entry (value ``hi + lo * scale``, absolute error at most
    ``2^-37`` of that entry); an int32 ``lo`` (float64 precision) for ``tol`` below
    :data:`solvers.voxel.memory.TIGHT_TOL_BELOW` (1e-7; +8 B per cell).

    A float32 solution alone cannot go below a true relative residual of about 1e-6 (the
    round-off of the velocity times the viscous stencil: 2.6e-6 measured on PuMA fibres_32,
    ``benchmarks/RESULTS.md``); with the int16 ``lo`` the floor is about ``2.5e-11`` times the
    largest velocity in voxel units (~1e-9 on fibres_32; the 40^3 cylinder arrays along the
    fibres, velocities of a few hundred, missed tol 1e-9 with it: hence int32 below 1e-7).
    ``lo`` is allocated after the first refinement cycle
    (:func:`solvers.voxel_stokes._solve_core`), when the field's size is known, so the first
    cycle runs on ``hi`` alone.
    """

    LO_BITS_BELOW = {2: 38, 4: 52}
    """``scale = 2^(E - bits)`` for a field whose largest magnitude times 2 is below ``2^E``, by
    the byte size of ``lo``: 14 (int16) or 28 (int32) bits below float32's 24-bit mantissa,
    so ``|lo|`` stays a quarter of its range while the entries stay below twice the largest
    one at :meth:`extend` (clipped beyond)."""

    def __init__(self, shape: tuple[int, ...], packing: Packing | None = None) -> None:
        self.shape = shape
        self.packing = packing
        self.hi = np.zeros(shape if packing is None else packing.size, np.float32)
        self.lo = np.zeros((0,) * self.hi.ndim, np.int16)
        self.scale = np.ones(shape[0])

    def _field(self, arr: np.ndarray, a: int) -> np.ndarray:
        return arr[a] if self.packing is None else self.packing.field(arr, a)

    @property
    def extended(self) -> bool:
        """True once :meth:`extend` has allocated ``lo``."""
        return self.lo.size > 0

    def extend(self, tol: float = 1e-6) -> None:
        """Allocate ``lo`` (zero; int32 if ``tol < LO32_BELOW``) and set the per-field scales
        from the current ``hi``."""
        if self.extended:
            return
        dtype = np.int32 if tol < LO32_BELOW else np.int16
        bits = self.LO_BITS_BELOW[np.dtype(dtype).itemsize]
        fields = [self._field(self.hi, a) for a in range(self.shape[0])]
        mags = [max(float(f.max()), -float(f.min())) if f.size else 0.0 for f in fields]
        top = max(mags)
        for a, m in enumerate(mags):
            m = m if m > 0.0 else top
            self.scale[a] = 2.0 ** (np.frexp(2.0 * m)[1] - bits) if m > 0 else 1.0
        self.lo = np.zeros(self.hi.shape, dtype)

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
        for a, i, sl, act in self.packing.planes():
            vals = self.hi[sl].astype(np.float64)
            if self.extended:
                vals += self.lo[sl] * self.scale[a]
            x[a, i][act] = vals
        return x


@nb.njit(inline="always")
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


ROWS_PER_TASK = 64
"""Rows (or blocks) of a 4-field vector per parallel task of :func:`minres_direction` (one work
row allocated per task, not per row)."""


@nb.njit(inline="always")
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


@parallel_kernel(**_OPTS)
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
    lmax = 32767.0 if xl.itemsize == 2 else 2147483647.0  # int16 or int32 extension
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


@parallel_kernel(**_OPTS)
def add_direction(xh, xl, xs, c, q, e):
    """``x += c u`` for a row-scaled int16 direction ``u = q * e`` and the solution of
    :func:`minres_direction` (``xh``, or ``xh + xl * xs[field]`` when ``xl`` is not empty)."""
    nz = xh.size // e.size
    fh = xh.reshape(-1, nz)
    fq = q.reshape(-1, nz)
    extended = xl.size > 0
    fl = xl.reshape(-1, nz) if extended else xl.reshape(0, nz)
    lmax = 32767.0 if xl.itemsize == 2 else 2147483647.0
    nrow = fh.shape[0]
    per = nrow // xs.shape[0]
    for t in nb.prange(nrow):
        lr = fl[t] if extended else fl.reshape(-1)
        _solution_row(fh[t], lr, xs[t // per], c * e[t], fq[t], lmax)


@parallel_kernel(**_OPTS)
def subtract_sq(r, y):
    """``r -= y`` (flat, parallel); returns the float64 ``||r||^2`` of the result."""
    fr = r.reshape(-1, r.shape[-1])
    fy = y.reshape(-1, y.shape[-1])
    m, n = fr.shape
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
    return part.sum()


@parallel_kernel(**_OPTS)
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

    Parameters
    ----------
    masks : list of 4 np.ndarray
        ``(nx, ny, nz)`` arrays, non-zero on the active unknowns: the three velocity diagonals
        and the pressure-cell mask (references, not copied).
    """

    def __init__(self, masks: list[np.ndarray]) -> None:
        self.masks = masks
        self.shape = (4, *masks[0].shape)
        nz = self.shape[-1]
        counts = np.concatenate([np.count_nonzero(m.reshape(-1, nz), axis=1) for m in masks])
        self.start = np.zeros(counts.size + 1, np.int64)
        np.cumsum(counts, out=self.start[1:])
        self.size = int(self.start[-1])

    def offset(self, a: int, i: int = 0) -> int:
        """First packed entry of plane ``i`` of field ``a``."""
        return int(self.start[(a * self.shape[1] + i) * self.shape[2]])

    def field(self, packed: np.ndarray, a: int) -> np.ndarray:
        """The packed entries of field ``a`` (a view)."""
        return packed[self.offset(a) : self.offset(a + 1)]

    def planes(self):
        """``(field, plane, slice of the packed entries, active entries of the plane)`` for
        every plane of every field (plane by plane: no temporaries of the grid's size)."""
        for a, m in enumerate(self.masks):
            for i in range(self.shape[1]):
                yield a, i, slice(self.offset(a, i), self.offset(a, i + 1)), m[i] != 0

    def unpack(self, packed: np.ndarray, out: np.ndarray, scale: np.ndarray | None = None) -> None:
        """``out[a][active] = packed_a (* scale[a])``, zero elsewhere."""
        out.fill(0.0)
        for a, i, sl, act in self.planes():
            out[a, i][act] = packed[sl] if scale is None else packed[sl] * scale[a]


@nb.njit(inline="always")
def _packed_row(mr, zr, s, w, h, lo, p, q, cs, sn, zeta, sc, lmax, zc, row):
    """:func:`symmlq_step` on one row: ``mr`` the row's activity, ``w[p:q], h[p:q], lo[p:q]``
    its packed entries (``lo`` empty: the solution is ``h`` alone).  The active entries of
    ``zr`` are gathered into ``zc`` first; the rest runs on contiguous slices in the plain loops
    of :func:`minres_direction` (vectorised; one loop over the mask was 2.9x slower)."""
    if q == p:
        return
    if q - p < zr.shape[0]:  # gather without branches (the row is partly active)
        c = 0
        for k in range(zr.shape[0]):
            zc[c] = zr[k]
            c += mr[k] != 0
    else:
        zc = zr
    wr = w[p:q]
    for k in range(q - p):
        v = s * np.float64(zc[k])
        wo = np.float64(wr[k])
        row[k] = np.float32(cs * wo + sn * v)
        wr[k] = np.float32(sn * wo - cs * v)
    if zeta != 0.0:
        lr = lo[p:q] if lo.shape[0] > 0 else lo
        _solution_row(h[p:q], lr, sc, zeta, row[: q - p], lmax)


@parallel_kernel(**_OPTS)
def symmlq_step(z, s, w, cs, sn, xh, xl, xs, zeta, du, dv, dw, fluid, start):
    """One SYMMLQ rotation of the direction ``w`` (:func:`solvers.voxel_stokes._symmlq`'s
    ``w-bar``) with the Lanczos vector ``v = s z``: ``x += zeta (cs w + sn v)`` (the finished
    direction, rounded to float32) and ``w <- sn w - cs v`` in one pass.  ``w`` and the
    solution (``xh``, or ``xh + xl * xs[field]`` when ``xl`` is not empty: :class:`Solution`)
    are packed (:class:`Packing`: the active unknowns of ``du, dv, dw, fluid``, row ``t``
    starting at ``start[t]``).  ``cs = 1, sn = 0`` moves ``x`` to the CG point
    (``x += zeta w``); ``zeta = 0, cs = -1, sn = 0`` sets ``w = v``."""
    nx, ny, nz = fluid.shape
    per = nx * ny
    fz = z.reshape(-1, nz)
    lmax = 32767.0 if xl.itemsize == 2 else 2147483647.0  # int16 or int32 extension
    nrow = 4 * per
    ntask = (nrow + ROWS_PER_TASK - 1) // ROWS_PER_TASK
    for task in nb.prange(ntask):
        zc = np.empty(nz, np.float32)
        row = np.empty(nz, np.float32)
        for t in range(task * ROWS_PER_TASK, min(nrow, (task + 1) * ROWS_PER_TASK)):
            a = t // per
            i = (t - a * per) // ny
            j = t - a * per - i * ny
            p = start[t]
            q = start[t + 1]
            sc = xs[a]
            if a == 0:
                _packed_row(du[i, j], fz[t], s, w, xh, xl, p, q, cs, sn, zeta, sc, lmax, zc, row)
            elif a == 1:
                _packed_row(dv[i, j], fz[t], s, w, xh, xl, p, q, cs, sn, zeta, sc, lmax, zc, row)
            elif a == 2:
                _packed_row(dw[i, j], fz[t], s, w, xh, xl, p, q, cs, sn, zeta, sc, lmax, zc, row)
            else:
                _packed_row(fluid[i, j], fz[t], s, w, xh, xl, p, q, cs, sn, zeta, sc, lmax, zc, row)
