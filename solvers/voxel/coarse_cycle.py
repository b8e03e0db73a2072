"""The one-thread coarse part of a multigrid V-cycle as one compiled call.

The coarse levels of :class:`solvers.voxel.multigrid.ScalarMG` (fewer than
:data:`solvers.voxel.threads.PARALLEL_MIN_CELLS` cells: one thread) cost little work but,
called level by level from Python, ~25 numba dispatches per V-cycle (13-14 argument arrays
typed on each), a SuperLU solve with its float64 copies, and the Python around them: at 200^3
their kernels took 2-11x the time their bytes need (``benchmarks/RESULTS.md``, session 50).
:func:`coarse_vcycle` runs those levels, down, the coarsest solve and back up, in one call:
the same serial kernels (:mod:`solvers.voxel.kernels`, their ``serial`` twins) on the levels
packed into flat float32 buffers (:class:`CoarsePack`), and the coarsest solve as a
precomputed dense inverse.  Serial only, by design: the levels it runs are the ones
:func:`~solvers.voxel.threads.level_threads` keeps on one thread whatever the thread count,
so no parallel twin is needed (:mod:`solvers.jit`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

import solvers.jit  # noqa: F401  (cache stamps over the imported sources, before cache=True)
from solvers.voxel import kernels as kr

_OPTS = kr._OPTS

_JACOBI2_ZERO = kr.jacobi2_zero.serial
_JACOBI_ZERO = kr.jacobi_zero.serial
_JACOBI = kr.jacobi.serial
_RESIDUAL_RESTRICT = kr.residual_restrict.serial
_PROLONG_JACOBI = kr.prolong_jacobi.serial


class CoarsePack:
    """Levels ``l0 .. L-1`` of a V-cycle in flat buffers: operator ``d`` (float32), couplings
    ``c`` (3 rows, float32), vectors ``x, b, t``; ``off[l]`` the first entry of level ``l``,
    ``shape[l]`` its shape, ``fac[l]`` its aggregation factors to level ``l + 1``; ``inv`` the
    dense inverse of the coarsest operator (float64, rows of inactive unknowns zero).

    :meth:`views` gives level ``l``'s ``x, b, t`` as 3-D views of the buffers, which the
    caller's :class:`~solvers.voxel.multigrid.Level` objects hold: the level above writes its
    restricted residual into the first ``b`` and reads the result from the first ``x``.
    """

    def __init__(self, levels: list, inv: np.ndarray) -> None:
        sizes = [int(lev.d.size) for lev in levels]
        self.off = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        n = int(self.off[-1])
        self.shape = np.array([lev.d.shape for lev in levels], np.int64)
        self.fac = np.array([lev.f for lev in levels], np.int64)
        self.d = np.empty(n, np.float32)
        self.c = np.empty((3, n), np.float32)
        for lev, lo, hi in zip(levels, self.off[:-1], self.off[1:], strict=True):
            self.d[lo:hi] = lev.d.ravel()  # uint8 -> float32: exact
            self.c[:, lo:hi] = lev.c.reshape(3, -1)
        self.x = np.zeros(n, np.float32)
        self.b = np.zeros(n, np.float32)
        self.t = np.zeros(n, np.float32)
        self.inv = np.ascontiguousarray(inv, dtype=np.float64)

    def views(self, li: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(x, b, t)`` of level ``li`` (0 = the first packed level) as 3-D views."""
        lo, hi = int(self.off[li]), int(self.off[li + 1])
        shp = tuple(int(s) for s in self.shape[li])
        return tuple(a[lo:hi].reshape(shp) for a in (self.x, self.b, self.t))

    def same_layout(self, other: CoarsePack) -> bool:
        """Whether ``other`` packs levels of the same shapes (its vectors then fit)."""
        return bool(np.array_equal(self.off, other.off) and np.array_equal(self.shape, other.shape))

    @property
    def nbytes(self) -> int:
        """Bytes of the packed operators and the inverse (the vectors are the levels')."""
        return int(self.d.nbytes + self.c.nbytes + self.inv.nbytes)

    def run(self, pre: int, omega: float, alpha: float) -> None:
        """The V-cycle from the first packed level down (its ``b`` given) and back up, its
        result in the first level's ``x`` (:func:`coarse_vcycle`)."""
        coarse_vcycle(
            self.d, self.c, self.x, self.b, self.t, self.off, self.shape, self.fac, self.inv,
            (pre, omega, alpha),
        )  # fmt: skip


@nb.njit(inline="always")
def _level(a, off, shape, li):
    """3-D view of level ``li`` of the flat buffer ``a``."""
    return a[off[li] : off[li + 1]].reshape((shape[li, 0], shape[li, 1], shape[li, 2]))


@nb.njit(**_OPTS)
def dense_solve(inv, b, x):
    """``x = inv b`` (float64 sums; float32 result)."""
    n = b.shape[0]
    for i in range(n):
        s = 0.0
        row = inv[i]
        for j in range(n):
            s += row[j] * np.float64(b[j])
        x[i] = s


@nb.njit(**_OPTS)
def _smooth_down(d, c, x, b, t, off, shape, fac, li, pre, omega):
    """Pre-smoothing of level ``li`` from zero and its restricted residual into level
    ``li + 1``'s ``b``; returns which buffer holds the level's ``x`` (0: ``x``, 1: ``t``)."""
    dl, bl = _level(d, off, shape, li), _level(b, off, shape, li)
    cx, cy = _level(c[0], off, shape, li), _level(c[1], off, shape, li)
    cz = _level(c[2], off, shape, li)
    xa, xb = _level(x, off, shape, li), _level(t, off, shape, li)
    if pre >= 2:
        _JACOBI2_ZERO(dl, cx, cy, cz, bl, xa, omega, 1)
        rest = pre - 2
    else:
        _JACOBI_ZERO(dl, bl, xa, omega)
        rest = pre - 1
    side = 0
    for _ in range(rest):
        if side == 0:
            _JACOBI(dl, cx, cy, cz, xa, bl, xb, omega)
        else:
            _JACOBI(dl, cx, cy, cz, xb, bl, xa, omega)
        side = 1 - side
    cur = xa if side == 0 else xb
    f0, f1, f2 = fac[li, 0], fac[li, 1], fac[li, 2]
    _RESIDUAL_RESTRICT(dl, cx, cy, cz, cur, bl, f0, f1, f2, _level(b, off, shape, li + 1))
    return side


@nb.njit(**_OPTS)
def _smooth_up(d, c, x, b, t, off, shape, fac, li, side, xc, pre, omega, alpha):
    """Coarse correction ``alpha P xc`` fused into the first of ``pre`` post-smoothing sweeps
    of level ``li`` (its ``x`` in buffer ``side``); the result left in ``x``."""
    dl, bl = _level(d, off, shape, li), _level(b, off, shape, li)
    cx, cy = _level(c[0], off, shape, li), _level(c[1], off, shape, li)
    cz = _level(c[2], off, shape, li)
    xa, xb = _level(x, off, shape, li), _level(t, off, shape, li)
    f0, f1, f2 = fac[li, 0], fac[li, 1], fac[li, 2]
    src, dst = (xa, xb) if side == 0 else (xb, xa)
    _PROLONG_JACOBI(dl, cx, cy, cz, src, xc, f0, f1, f2, alpha, bl, dst, omega, 1)
    side = 1 - side
    for _ in range(1, pre):
        src, dst = (xa, xb) if side == 0 else (xb, xa)
        _JACOBI(dl, cx, cy, cz, src, bl, dst, omega)
        side = 1 - side
    if side == 1:
        xa[...] = xb


@nb.njit(**_OPTS)
def coarse_vcycle(d, c, x, b, t, off, shape, fac, inv, params):
    """The V-cycle of the packed levels (:class:`CoarsePack`) from zero: ``params = (pre,
    omega, alpha)`` as :class:`~solvers.voxel.multigrid.ScalarMG`'s; the first level's ``b``
    in, its ``x`` out; the sweeps are the serial kernels the Python V-cycle calls, in its
    order, so the cycle stays the same symmetric operator."""
    pre, omega, alpha = params
    nlev = off.shape[0] - 1
    sides = np.zeros(nlev, np.int64)
    for li in range(nlev - 1):
        sides[li] = _smooth_down(d, c, x, b, t, off, shape, fac, li, pre, omega)
    last = nlev - 1
    dense_solve(inv, b[off[last] : off[last + 1]], x[off[last] : off[last + 1]])
    for li in range(nlev - 2, -1, -1):
        xc = _level(x, off, shape, li + 1)
        _smooth_up(d, c, x, b, t, off, shape, fac, li, sides[li], xc, pre, omega, alpha)
