"""Sub-voxel operator stored as a uint8 staircase-like operator plus cut-face corrections.

The sub-voxel wall treatment (:mod:`solvers.voxel.boundary`) gives every active face a float
diagonal (the ghost-fluid stiffness ``1 / theta`` of its wall sides) and a weight ``w_f`` (its
cut control volume).  On the Toray-like grids only 14 % of the active faces of a component are
cut: the others have an integer diagonal and weight 1, exactly as the staircase.  So each
component keeps

* a dense uint8 diagonal ``d8`` = the diagonal rounded to the nearest integer (>= 1 on the
  active faces, 0 elsewhere), read by the V-cycles (their operator is this integer one: any
  fixed SPD operator is a valid preconditioner; its Galerkin first coarse level is then uint8
  too, :func:`solvers.voxel.multigrid._small_integers`), and
* on the cut faces only (diagonal not an integer, or weight not 1): the position ``k`` along
  the row (uint16), the diagonal's remainder ``diag - d8`` in units of :data:`DIAG_QUANTUM`
  (int16) and the weight in units of :data:`WEIGHT_QUANTUM` (uint16), in rows ``(i, j)`` of
  the grid (CSR: ``start[a, i * ny + j]``).

6 B per cut face instead of the dense float32 diagonal and weight (8 B on every face): 2.6 B
per cell on the Toray-like 64^3 grid instead of 24 B (``benchmarks/RESULTS.md``, sub10).  The
Stokes operator the solve uses is the one these stored values define (diagonal
``d8 + dd * DIAG_QUANTUM``, weight ``ww * WEIGHT_QUANTUM``): the quantisation moves a cut face's
diagonal by at most 1.5e-5 and its weight by 7.6e-6 (K by about 1e-7 relative).  The Krylov
product (:func:`stokes_lanczos_cut`) and the float64 residual (:func:`stokes_residual_cut`)
run the staircase rows on ``d8`` and weight 1, then correct the cut faces of each row.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from solvers.jit import parallel_kernel
from solvers.reduction import ordered_sum
from solvers.voxel.kernels import _dn, _on, _stencil, _up
from solvers.voxel.lanczos import _combine, _momentum_lanczos

_OPTS = {"cache": True, "fastmath": True, "nogil": True}

_EXACT = {"cache": True, "nogil": True}
"""Options of the float64 residual: no ``fastmath``, under which LLVM narrowed the continuity
rows' float64 arithmetic on float32 inputs to float32 (their cut-face terms then cancelled only
to 4e-8, and the refinement cycles stalled near a relative residual of 1e-6)."""

DIAG_QUANTUM = 2.0**-15
"""Unit of the stored remainder ``diag - d8`` (int16; ``|diag - d8| <= 1/2``)."""

WEIGHT_QUANTUM = 1.0 / 65535.0
"""Unit of the stored cut-face weight (uint16; weight 1 is 65535, the smallest non-zero
weight, 0.05, about 3277).  The weight is ``float32(ww * WEIGHT_QUANTUM)`` (:func:`_weight`),
so the dense float32 weights of :meth:`CutFaces.weight` are the kernels' to the last bit."""


@nb.njit(inline="always")
def _weight(code):
    """The weight of a stored code (float64 of its float32 value)."""
    return np.float64(np.float32(code * WEIGHT_QUANTUM))


@dataclass
class CutFaces:
    """Cut-face corrections of the three velocity components (module docstring).

    Attributes
    ----------
    start : np.ndarray, int32 or int64, shape (3, nx * ny + 1)
        Offsets of each row's cut faces in ``k, dd, ww`` (component ``a``, row ``i * ny + j``).
    k : np.ndarray, uint16
        Position of each cut face along its row.
    dd : np.ndarray, int16
        ``(diag - d8) / DIAG_QUANTUM``.
    ww : np.ndarray, uint16
        ``weight / WEIGHT_QUANTUM`` (0 for a face released by
        :func:`solvers.voxel.boundary.pressure_cells`).
    shape : tuple of int
        Grid shape.
    """

    start: np.ndarray
    k: np.ndarray
    dd: np.ndarray
    ww: np.ndarray
    shape: tuple[int, int, int]

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(start, k, dd, ww)``: the kernels' arguments."""
        return self.start, self.k, self.dd, self.ww

    @property
    def nbytes(self) -> int:
        """Bytes held (the offsets and the three per-face arrays)."""
        return int(sum(a.nbytes for a in self.arrays))

    def flat_index(self, a: int) -> np.ndarray:
        """Flat grid index of each cut face of component ``a`` (int64)."""
        nz = self.shape[2]
        st = self.start[a]
        rows = np.repeat(np.arange(st.size - 1, dtype=np.int64), np.diff(st))
        return rows * nz + self.k[st[0] : st[-1]]

    def weight(self, a: int, d8: np.ndarray) -> np.ndarray:
        """Dense float32 weight of component ``a`` (1 on the uncut active faces of ``d8``)."""
        w = (d8 > 0).astype(np.float32)
        st = self.start[a]
        cut = self.ww[st[0] : st[-1]] * WEIGHT_QUANTUM
        w.ravel()[self.flat_index(a)] = cut.astype(np.float32)
        return w

    def diagonal(self, a: int, d8: np.ndarray) -> np.ndarray:
        """Dense float64 diagonal of component ``a``."""
        diag = d8.astype(np.float64)
        st = self.start[a]
        diag.ravel()[self.flat_index(a)] += self.dd[st[0] : st[-1]] * DIAG_QUANTUM
        return diag

    def scale_inverse(self, a: int, d8: np.ndarray) -> np.ndarray:
        """``w_f^2 / A_ff`` of component ``a`` (float32, 0 off the active faces): its faces'
        part of the Schur diagonal (:func:`solvers.voxel.schur.schur_code`)."""
        q = np.divide(1.0, d8, out=np.zeros(d8.shape, np.float32), where=d8 > 0)
        st = self.start[a]
        idx = self.flat_index(a)
        w = (self.ww[st[0] : st[-1]] * WEIGHT_QUANTUM).astype(np.float32).astype(np.float64)
        diag = d8.ravel()[idx] + self.dd[st[0] : st[-1]] * DIAG_QUANTUM
        q.ravel()[idx] = w * w / diag
        return q


class WeightView:
    """``weights[a]``: the dense weight of component ``a``, formed on access (4 B per cell while
    the caller holds it), for the set-up code that reads dense weights."""

    def __init__(self, cut: CutFaces, d8: list[np.ndarray]) -> None:
        self._cut = cut
        self._d8 = d8

    def __getitem__(self, a: int) -> np.ndarray:
        return self._cut.weight(a, self._d8[a])

    def __len__(self) -> int:
        return 3


@dataclass
class _Coo:
    """One component's cut faces during the set-up: sorted flat indices and their values."""

    idx: np.ndarray
    dd: np.ndarray
    ww: np.ndarray


def compress(diag: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, _Coo]:
    """Dense sub-voxel ``(diag, weight)`` of one component (float32, 0 off the active faces)
    -> its uint8 diagonal ``d8`` and its cut faces (module docstring)."""
    act = diag > 0
    d8 = np.rint(diag)
    np.maximum(d8, 1.0, out=d8, where=act)
    if float(d8.max(initial=0.0)) > 255.0:
        raise ValueError("sub-voxel diagonal above 255: THETA_MIN too small for uint8")
    cut = act & ((diag != d8) | (weight != 1.0))
    idx = np.flatnonzero(cut)
    del cut, act
    dflat = diag.ravel()[idx].astype(np.float64) - d8.ravel()[idx]
    dd = np.rint(dflat / DIAG_QUANTUM).astype(np.int16)
    wflat = weight.ravel()[idx].astype(np.float64)
    ww = np.rint(wflat / WEIGHT_QUANTUM)
    ww[(wflat > 0.0) & (ww < 1.0)] = 1.0  # a face with a weight keeps one (pressure_cells)
    return d8.astype(np.uint8), _Coo(idx, dd, ww.astype(np.uint16))


def pressure_cells(d8: list[np.ndarray], coos: list[_Coo]) -> np.ndarray:
    """:func:`solvers.voxel.boundary.pressure_cells` on the compressed components: the cells
    with at least one active face, less the cells left with a single weighted face, whose face
    weight becomes 0 (a face not cut so far joins the cut faces with its integer diagonal);
    ``coos`` is updated in place."""
    acts = [da > 0 for da in d8]
    cells = np.zeros(d8[0].shape, dtype=bool)
    for a, act in enumerate(acts):
        cells |= act | np.roll(act, -1, axis=a)
    on = acts
    for a, coo in enumerate(coos):
        on[a].ravel()[coo.idx[coo.ww == 0]] = False
    while True:
        count = np.zeros(cells.shape, np.int8)
        for a in range(3):
            count += on[a].astype(np.int8) + np.roll(on[a], -1, axis=a).astype(np.int8)
        lone = cells & (count == 1)
        if not lone.any():
            return cells
        for a, coo in enumerate(coos):
            off = np.flatnonzero(on[a] & (lone | np.roll(lone, 1, axis=a)))
            if off.size:
                on[a].ravel()[off] = False
                _zero_weights(coo, off)
        cells &= ~lone


def _zero_weights(coo: _Coo, off: np.ndarray) -> None:
    """Set the weight of the faces ``off`` (sorted flat indices) to 0, adding the uncut ones."""
    known = np.zeros(off.size, bool)
    pos = np.minimum(np.searchsorted(coo.idx, off), max(coo.idx.size - 1, 0))
    if coo.idx.size:
        known = coo.idx[pos] == off
    coo.ww[pos[known]] = 0
    new = off[~known]
    if new.size:
        idx = np.concatenate([coo.idx, new])
        order = np.argsort(idx, kind="stable")
        coo.idx = idx[order]
        coo.dd = np.concatenate([coo.dd, np.zeros(new.size, np.int16)])[order]
        coo.ww = np.concatenate([coo.ww, np.zeros(new.size, np.uint16)])[order]


def finish(coos: list[_Coo], shape: tuple[int, int, int]) -> CutFaces:
    """Rows (CSR) of the three components' cut faces."""
    nx, ny, nz = shape
    if nz > 65535:
        raise ValueError("grid rows longer than 65535 cells: uint16 cut-face positions")
    nrows = nx * ny
    total = sum(c.idx.size for c in coos)
    itype = np.int32 if total < 2**31 else np.int64
    start = np.zeros((3, nrows + 1), itype)
    base = 0
    for a, coo in enumerate(coos):
        counts = np.bincount(coo.idx // nz, minlength=nrows)
        start[a, 0] = base
        np.cumsum(counts, out=start[a, 1:])
        start[a, 1:] += base
        base += coo.idx.size
    k = np.concatenate([(c.idx % nz).astype(np.uint16) for c in coos])
    dd = np.concatenate([c.dd for c in coos])
    ww = np.concatenate([c.ww for c in coos])
    return CutFaces(start, k, dd, ww, shape)


@nb.njit(inline="always")
def _fix_momentum(qr, pr, plow, shift, st, kk, dd, ww, row, s, yr):
    """Cut-face corrections of one momentum row after :func:`_momentum_lanczos`: ``yr[k] += s
    ((diag - d8) q_k + (w - 1) (p_k - p_low))`` on the row's cut faces; returns the float64
    change of ``q . yr``."""
    nz = qr.shape[0]
    acc = 0.0
    for e in range(st[row], st[row + 1]):
        k = np.int64(kk[e])
        kl = k - shift if k >= shift else k - shift + nz
        dp = np.float64(pr[k]) - np.float64(plow[kl])
        corr = dd[e] * DIAG_QUANTUM * np.float64(qr[k]) + (_weight(ww[e]) - 1.0) * dp
        old = yr[k]
        new = np.float32(old + s * corr)
        yr[k] = new
        acc += np.float64(qr[k]) * (np.float64(new) - np.float64(old))
    return acc


@nb.njit(inline="always")
def _fix_div(qr, st, kk, ww, row, sign, shift, fr, out):
    """Cut-face corrections of one continuity row: the faces of row ``row`` of a component
    (``qr`` its values) add ``sign (w - 1) q_f`` to the balance of the cell ``k + shift``
    (``sign`` +1: the face is the cell's lower face, -1 its upper face; periodic in k)."""
    nz = qr.shape[0]
    for e in range(st[row], st[row + 1]):
        k = np.int64(kk[e])
        kc = k + shift
        kc = kc + nz if kc < 0 else (kc - nz if kc >= nz else kc)
        if fr[kc] != 0:
            out[kc] += sign * (_weight(ww[e]) - 1.0) * np.float64(qr[k])


@parallel_kernel(**_OPTS)
def stokes_lanczos_cut(du, dv, dw, cu, cv, cw, fluid, start, kk, dd, ww, x, s, c1, y):
    """:func:`solvers.voxel.lanczos.stokes_lanczos` (``y <- s K x - c1 y`` in place, returns
    ``x . y_new``) for the sub-voxel matrix stored as ``d8`` plus the cut faces
    ``(start, kk, dd, ww)`` of :class:`CutFaces`."""
    nx = fluid.shape[0]
    acc = np.zeros(nx)
    for i in nb.prange(nx):
        acc[i] = _lanczos_cut_slab(
            du, dv, dw, cu, cv, cw, fluid, start, kk, dd, ww, x, s, c1, y, np.int64(i)
        )
    return ordered_sum(acc)


@nb.njit(inline="always")
def _plane(fluid, x, i):
    """``(ny, nz, u, v, w, p, i - 1, i + 1)`` of plane ``i`` (periodic): the preamble of the
    slab functions of :func:`stokes_lanczos_cut` and :func:`stokes_residual_cut`."""
    nx, ny, nz = fluid.shape
    return ny, nz, x[0], x[1], x[2], x[3], _dn(i, nx), _up(i, nx)


@nb.njit(**_OPTS)
def _lanczos_cut_slab(du, dv, dw, cu, cv, cw, fluid, start, kk, dd, ww, x, s, c1, y, i):
    """Plane ``i`` of :func:`stokes_lanczos_cut` (16 parameters: the kernel's and ``i``)."""
    ny, nz, u, v, w, p, im, ip = _plane(fluid, x, i)
    row = np.empty(nz, dtype=y.dtype)
    div = np.empty(nz)
    s_y = 0.0
    for j in range(ny):
        jm = _dn(j, ny)
        jp = _up(j, ny)
        pr = p[i, j]
        r0 = i * ny + j
        s_y += _momentum_lanczos(du, cu, u, pr, p[im, j], 0, i, j, s, c1, y[0, i, j], row)
        s_y += _fix_momentum(u[i, j], pr, p[im, j], 0, start[0], kk, dd, ww, r0, s, y[0, i, j])
        s_y += _momentum_lanczos(dv, cv, v, pr, p[i, jm], 0, i, j, s, c1, y[1, i, j], row)
        s_y += _fix_momentum(v[i, j], pr, p[i, jm], 0, start[1], kk, dd, ww, r0, s, y[1, i, j])
        s_y += _momentum_lanczos(dw, cw, w, pr, pr, 1, i, j, s, c1, y[2, i, j], row)
        s_y += _fix_momentum(w[i, j], pr, pr, 1, start[2], kk, dd, ww, r0, s, y[2, i, j])
        fr = fluid[i, j]
        _divergence_row(u[i, j], u[ip, j], v[i, j], v[i, jp], w[i, j], fr, div)
        _fix_rows(u, v, w, start, kk, ww, i, j, ip, jp, ny, fr, div)
        for k in range(nz):
            row[k] = div[k]
        s_y += _combine(row, s, c1, y[3, i, j], pr)
    return s_y


@nb.njit(inline="always")
def _divergence_row(ur, uip, vr, vjp, wr, fr, out):
    """``out[k]`` = the unweighted ``sum_a q_a[I] - q_a[I + e_a]`` of the cells of one row
    (float64; 0 off the pressure cells ``fr``)."""
    nz = ur.shape[0]
    for k in range(nz):
        kp = k + 1 if k + 1 < nz else 0
        val = (
            np.float64(ur[k])
            - np.float64(uip[k])
            + np.float64(vr[k])
            - np.float64(vjp[k])
            + np.float64(wr[k])
            - np.float64(wr[kp])
        )
        out[k] = val * _on(fr[k])  # a multiply, not a select: kernels._on


@nb.njit(inline="always")
def _fix_rows(u, v, w, start, kk, ww, i, j, ip, jp, ny, fr, div):
    """The cut-face weights in the continuity row ``(i, j)``: lower faces ``u[i, j], v[i, j],
    w[i, j]``, upper faces ``u[ip, j], v[i, jp]`` and ``w[i, j, k + 1]``."""
    _fix_div(u[i, j], start[0], kk, ww, i * ny + j, 1.0, 0, fr, div)
    _fix_div(u[ip, j], start[0], kk, ww, ip * ny + j, -1.0, 0, fr, div)
    _fix_div(v[i, j], start[1], kk, ww, i * ny + j, 1.0, 0, fr, div)
    _fix_div(v[i, jp], start[1], kk, ww, i * ny + jp, -1.0, 0, fr, div)
    _fix_div(w[i, j], start[2], kk, ww, i * ny + j, 1.0, 0, fr, div)
    _fix_div(w[i, j], start[2], kk, ww, i * ny + j, -1.0, -1, fr, div)


@parallel_kernel(**_EXACT)
def stokes_residual_cut(du, dv, dw, cu, cv, cw, fluid, start, kk, dd, ww, x, gdir, r):
    """``r = f - K x`` in float64 arithmetic for the matrix of :func:`stokes_lanczos_cut` (``f``
    the face weight on the active faces of ``gdir``); returns ``(||r||^2, ||f||^2)`` (as
    :func:`solvers.voxel.kernels.stokes_residual`)."""
    nx = fluid.shape[0]
    acc = np.zeros(nx)
    accf = np.zeros(nx)
    for i in nb.prange(nx):
        acc[i], accf[i] = _residual_cut_slab(
            du, dv, dw, cu, cv, cw, fluid, start, kk, dd, ww, x, gdir, r, np.int64(i)
        )
    return ordered_sum(acc), ordered_sum(accf)


@nb.njit(inline="always")
def _momentum_residual(d, c, q, pr, plow, shift, st, kk, dd, ww, i, j, force, val, f):
    """``val = (K x)`` of one momentum row (float64, 0 on inactive faces) and ``f`` its body
    force (the weight if ``force``, else 0), both corrected on the row's cut faces."""
    nx, ny, nz = d.shape
    dr = d[i, j]
    for k in range(nz):
        if dr[k] != 0:
            kl = k - shift if k >= shift else k - shift + nz
            val[k] = _stencil(d, c[0], c[1], c[2], q, i, j, k, nx, ny, nz) + (
                np.float64(pr[k]) - np.float64(plow[kl])
            )
            f[k] = 1.0 if force else 0.0
        else:
            val[k] = 0.0
            f[k] = 0.0
    qr = q[i, j]
    row = i * ny + j
    for e in range(st[row], st[row + 1]):
        k = np.int64(kk[e])
        kl = k - shift if k >= shift else k - shift + nz
        wt = _weight(ww[e])
        dp = np.float64(pr[k]) - np.float64(plow[kl])
        val[k] += dd[e] * DIAG_QUANTUM * np.float64(qr[k]) + (wt - 1.0) * dp
        if force:
            f[k] = wt


@nb.njit(**_EXACT)
def _residual_cut_slab(du, dv, dw, cu, cv, cw, fluid, start, kk, dd, ww, x, gdir, r, i):
    """Plane ``i`` of :func:`stokes_residual_cut`; returns its ``(||r||^2, ||f||^2)``
    (15 parameters: the kernel's and ``i``)."""
    ny, nz, u, v, w, p, im, ip = _plane(fluid, x, i)
    val = np.empty(nz)
    f = np.empty(nz)
    s2 = 0.0
    f2 = 0.0
    for j in range(ny):
        jm = _dn(j, ny)
        jp = _up(j, ny)
        pr = p[i, j]
        for a in range(3):
            if a == 0:
                _momentum_residual(du, cu, u, pr, p[im, j], 0, start[0], kk, dd, ww, i, j,
                                   gdir == 0, val, f)  # fmt: skip
            elif a == 1:
                _momentum_residual(dv, cv, v, pr, p[i, jm], 0, start[1], kk, dd, ww, i, j,
                                   gdir == 1, val, f)  # fmt: skip
            else:
                _momentum_residual(dw, cw, w, pr, pr, 1, start[2], kk, dd, ww, i, j,
                                   gdir == 2, val, f)  # fmt: skip
            out = r[a, i, j]
            for k in range(nz):
                res = f[k] - val[k]
                out[k] = res
                s2 += res * res
                f2 += f[k] * f[k]
        fr = fluid[i, j]
        _divergence_row(u[i, j], u[ip, j], v[i, j], v[i, jp], w[i, j], fr, val)
        _fix_rows(u, v, w, start, kk, ww, i, j, ip, jp, ny, fr, val)
        out = r[3, i, j]
        for k in range(nz):
            out[k] = -val[k]
            s2 += val[k] * val[k]
    return s2, f2
