"""Aggregation multigrid for the scalar no-slip Laplacians of the MAC voxel Stokes solver.

Each velocity component has its own operator ``A_a`` (7-point negative Laplacian on the active
faces, walls on voxel faces; see :mod:`solvers.voxel.kernels`).  The preconditioner is one
symmetric V-cycle per component:

* coarse levels are Galerkin operators ``P^T A P`` with piecewise-constant prolongation over box
  aggregates of 2 cells per axis (1 on axes of fewer than 4 cells; an odd axis puts 3 cells in
  its last aggregate), so they stay 7-point stencils, stay SPD, and keep exactly the drag of the
  walls of the fine grid however thin the fibres are (no re-discretised coarse masks);
* damped Jacobi smoothing (parallel, symmetric), ``pre = post`` sweeps; the first two
  pre-smoothing sweeps from zero are one pass (:func:`~solvers.voxel.kernels.jacobi2_zero`),
  the coarse correction is fused into the first post-smoothing sweep
  (:func:`~solvers.voxel.kernels.prolong_jacobi`) and the last sweep returns ``b . out``, the
  preconditioned dot product of MINRES, so no pass of the grid is spent on them (with
  ``pre = 1`` the dot takes a pass of its own);
* the coarse correction is over-weighted by ``alpha`` (piecewise-constant aggregation makes the
  coarse operator about twice too stiff for smooth modes; cf. Braess 1995, Notay's AGMG);
* the coarsest level (<= ``max_coarse`` unknowns) is solved by a sparse LU.

The V-cycle is a fixed symmetric positive definite operator, as MINRES requires.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from solvers.voxel import kernels as kr
from solvers.voxel.threads import level_threads


def component_operator(fluid: np.ndarray, a: int) -> tuple[np.ndarray, np.ndarray]:
    """Finest-level operator of velocity component ``a``: diagonal and couplings (uint8).

    A face is active when both its cells are fluid.  Normal neighbours contribute 2 to the
    diagonal (value 0 on an inactive neighbour face, whose node lies on a solid surface);
    each of the four tangential neighbours contributes 1, or 2 when both of its cells are solid
    (the wall lies half a cell away: ghost value ``-q``).
    """
    act = np.empty(fluid.shape, bool)
    _with_lower(np.logical_and, fluid, a, act)
    both_solid = np.empty(fluid.shape, bool)  # solid & lower solid = ~(fluid | lower fluid)
    _with_lower(np.logical_or, fluid, a, both_solid)
    np.logical_not(both_solid, out=both_solid)
    diag = np.full(fluid.shape, 6, dtype=np.uint8)
    for b in range(3):
        if b == a:
            continue
        _add_shifted(diag, both_solid, b)
    diag *= act
    c = np.empty((3, *fluid.shape), dtype=np.uint8)
    for b in range(3):
        _with_lower(np.logical_and, act, b, c[b].view(bool))
    return diag, c


def roll_halves(a: int, shift: int) -> list[tuple[tuple[slice, ...], tuple[slice, ...]]]:
    """``(destination, source)`` index pairs of ``out[i] = x[i - shift]`` along ``a``
    (periodic; ``shift`` +-1): the two slices ``np.roll(x, shift, axis=a)`` is made of."""
    pairs = []  # the two destinations are disjoint: their order does not matter
    for dst, src in (
        (slice(shift, None), slice(None, -shift)),
        (slice(None, shift), slice(-shift, None)),
    ):
        di, si = [slice(None)] * 3, [slice(None)] * 3
        di[a], si[a] = dst, src
        pairs.append((tuple(di), tuple(si)))
    return pairs


def _with_lower(op: np.ufunc, x: np.ndarray, a: int, out: np.ndarray) -> None:
    """``out = op(x, np.roll(x, 1, axis=a))`` (each cell with its lower neighbour along
    ``a``, periodic) without the rolled copy."""
    for dst, src in roll_halves(a, 1):
        op(x[dst], x[src], out=out[dst])


def _add_shifted(diag: np.ndarray, x: np.ndarray, b: int) -> None:
    """``diag += np.roll(x, -1, axis=b) + np.roll(x, 1, axis=b)`` (one after the other, as
    integers: exact) without the rolled copies."""
    for shift in (-1, 1):
        for dst, src in roll_halves(b, shift):
            diag[dst] += x[src]


def _small_integers(fine: Level, coarse: np.ndarray) -> np.ndarray:
    """A Galerkin coarse array as uint8 when the fine operator is integer and every entry fits
    (piecewise-constant aggregation sums integers exactly: on the staircase the first coarse
    level has diagonals <= 80 and couplings <= 4, 12 of its 16 bytes per cell saved, about 4.5 B
    per fine cell for the three components), else the float32 array itself.  The kernels run
    on it as on the finest level (uint8 operator, float32 vectors): same arithmetic, same
    result."""
    ints = np.issubdtype(fine.d.dtype, np.integer) and np.issubdtype(fine.c.dtype, np.integer)
    if ints and coarse.size and float(coarse.min()) >= 0.0 and float(coarse.max()) <= 255.0:
        return coarse.astype(np.uint8)
    return coarse


def _kernel(kernel, nthr: int):
    """The dispatcher of a :func:`~solvers.jit.parallel_kernel` that a level on ``nthr``
    threads runs: its serial twin on one thread (what the twin's own dispatch picks there,
    without its per-call thread-count query; the coarse levels make 24 of the 36 kernel calls
    of a Krylov iteration's three V-cycles), else the twin itself.  A kernel without a twin (a
    benchmark's timing wrapper) is called as it is."""
    return getattr(kernel, "serial", kernel) if nthr == 1 else kernel


def _check_c_ordered(name: str, a: np.ndarray, shape: tuple[int, ...]) -> None:
    """Refuse an output buffer the kernels cannot write (one line, ``ValueError``): not a
    C-ordered array of ``shape`` (a strided or Fortran-ordered view reached numba's
    TypingError; it is the caller's array, so it is not replaced by a copy)."""
    if not isinstance(a, np.ndarray) or a.shape != tuple(shape) or not a.flags.c_contiguous:
        what = (
            f"shape {a.shape}, C-contiguous {a.flags.c_contiguous}"
            if isinstance(a, np.ndarray)
            else type(a).__name__
        )
        raise ValueError(
            f"{name} must be a C-contiguous array of shape {tuple(shape)} (the operator's), "
            f"got {what}; pass np.ascontiguousarray(...) or a new np.empty"
        )


@dataclass
class Level:
    """One level: operator (diag, couplings), aggregation factors to the next level, work."""

    d: np.ndarray
    c: np.ndarray
    f: tuple[int, int, int] = (1, 1, 1)
    x: np.ndarray = field(default_factory=lambda: np.zeros(0))
    b: np.ndarray = field(default_factory=lambda: np.zeros(0))
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))


class ScalarMG:
    """Symmetric aggregation V-cycle for one 7-point SPD operator (see module docstring).

    ``work`` gives the finest level's smoothing arrays instead of allocating them: two arrays,
    or one, the other being the output of :meth:`apply` (4 B per fine cell saved).
    """

    def __init__(
        self,
        d: np.ndarray,
        c: np.ndarray,
        pre: int = 2,
        omega: float = 0.9,
        alpha: float = 1.6,
        max_coarse: int = 512,
        work: list[np.ndarray] | None = None,
    ) -> None:
        if int(pre) < 1:
            raise ValueError(f"pre (Jacobi sweeps per half cycle) must be >= 1, got {pre!r}")
        if c.shape[1:] != d.shape:  # the Galerkin product would read past the stand-in's row
            raise ValueError(
                f"c (couplings) must have shape (3, *d.shape) = (3, {', '.join(map(str, d.shape))})"
                f", got {c.shape}: kernels.unit_couplings replaces them only after the set-up"
            )
        # the kernels are compiled for C-ordered arrays: a strided or Fortran-ordered view
        # failed with numba's multi-page TypingError (session 52 I/O review, finding 6); the
        # operator is the class's own, so copied (no copy when already C-ordered)
        d, c = np.ascontiguousarray(d), np.ascontiguousarray(c)
        for w in work or ():
            _check_c_ordered("work", w, d.shape)
        self.pre = int(pre)
        self.omega = omega
        self.alpha = alpha
        self.levels = [Level(d=d, c=c)]
        while True:
            top = self.levels[-1]
            shp = top.d.shape
            if int(np.prod(shp)) <= max_coarse:
                break
            f = tuple(2 if n >= 4 else 1 for n in shp)
            if f == (1, 1, 1):
                break
            nc = tuple(n // m for n, m in zip(shp, f, strict=True))
            dc = np.empty(nc, np.float32)
            cc = np.empty((3, *nc), np.float32)
            kr.galerkin(top.d, top.c[0], top.c[1], top.c[2], *f, dc, cc[0], cc[1], cc[2])
            top.f = f
            self.levels.append(Level(d=_small_integers(top, dc), c=_small_integers(top, cc)))
        # the finest level's two smoothing arrays: ``work`` if given (one array: the other is
        # the V-cycle's output, see :meth:`_vcycle`)
        self._fine_work = work[0] if work is not None and len(work) == 1 else None
        for li, lev in enumerate(self.levels):
            if li == 0 and work is not None:
                lev.x = work[0]
                lev.t = work[1] if len(work) > 1 else np.zeros(0, np.float32)
            else:
                lev.x = np.zeros(lev.d.shape, np.float32)
                lev.t = np.zeros(lev.d.shape, np.float32)
            lev.b = np.zeros(lev.d.shape, np.float32) if li > 0 else np.zeros(0)
        self._coarse_solve = self._factor(self.levels[-1])

    @staticmethod
    def _factor(lev: Level):
        d = lev.d.astype(np.float64)
        shp = d.shape
        n = d.size
        idx = np.arange(n).reshape(shp)
        rows = [np.arange(n)]
        cols = [np.arange(n)]
        vals = [np.where(d.ravel() > 0, d.ravel(), 1.0)]
        for b in range(3):
            cb = lev.c[b].astype(np.float64).ravel()
            nb_idx = np.roll(idx, 1, axis=b).ravel()
            keep = cb != 0
            rows += [idx.ravel()[keep], nb_idx[keep]]
            cols += [nb_idx[keep], idx.ravel()[keep]]
            vals += [-cb[keep], -cb[keep]]
        mat = sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
        )
        active = d.ravel() > 0
        lu = spla.splu(mat.tocsc())  # SuperLU: no BLAS threads (they spin on a busy machine)
        lin = lu.solve

        def solve(b: np.ndarray, x: np.ndarray) -> None:
            sol = lin(b.ravel().astype(np.float64))
            sol[~active] = 0.0
            x[...] = sol.reshape(shp)

        return solve

    def _pre_smooth(self, lev: Level, nthr: int) -> None:
        """``pre`` damped Jacobi sweeps from zero on ``lev.x`` (the first two in one pass), on
        ``nthr`` threads (:func:`_kernel`)."""
        if self.pre >= 2:
            _kernel(kr.jacobi2_zero, nthr)(lev.d, *lev.c, lev.b, lev.x, self.omega, nthr)
            rest = self.pre - 2
        else:
            _kernel(kr.jacobi_zero, nthr)(lev.d, lev.b, lev.x, self.omega)
            rest = self.pre - 1
        for _ in range(rest):
            _kernel(kr.jacobi, nthr)(lev.d, *lev.c, lev.x, lev.b, lev.t, self.omega)
            lev.x, lev.t = lev.t, lev.x

    def _post_smooth(self, lev: Level, xc: np.ndarray, out: np.ndarray | None, nthr: int) -> float:
        """Coarse correction ``x += alpha P xc`` and ``pre`` Jacobi sweeps (the correction fused
        into the first), on ``nthr`` threads; the last sweep writes into ``out`` if given (the
        finest level: saves a copy) and its ``b . out`` is returned (0.0 without ``out``): by
        :func:`~solvers.voxel.kernels.jacobi` from the same pass, or with one sweep only
        (``pre == 1``, :func:`~solvers.voxel.kernels.prolong_jacobi` sums no dot) by a pass of
        its own."""
        dst = out if (out is not None and self.pre == 1) else lev.t
        _kernel(kr.prolong_jacobi, nthr)(
            lev.d, *lev.c, lev.x, xc, *lev.f, self.alpha, lev.b, dst, self.omega, nthr
        )
        dot = _kernel(kr.dot, nthr)(lev.b, dst) if dst is out else 0.0
        if dst is lev.t:
            lev.x, lev.t = lev.t, lev.x
        for s in range(1, self.pre):
            dst = out if (out is not None and s == self.pre - 1) else lev.t
            dot = _kernel(kr.jacobi, nthr)(lev.d, *lev.c, lev.x, lev.b, dst, self.omega)
            if dst is lev.t:
                lev.x, lev.t = lev.t, lev.x
        return dot if out is not None else 0.0

    def apply(self, b: np.ndarray, out: np.ndarray) -> float:
        """out = V-cycle(b) starting from zero (approximates A^-1 b); returns ``b . out``
        (float64, from the last smoothing sweep: no extra pass).

        Each level runs on :func:`~solvers.voxel.threads.level_threads` numba threads (the
        coarse levels on one: a parallel region there costs more than its work on a busy
        machine); the caller's thread count is restored on return.
        """
        _check_c_ordered("out", out, self.levels[0].d.shape)  # the caller's: not copied
        b = np.ascontiguousarray(b)  # read only: a strided b is copied
        avail = numba.get_num_threads()
        try:
            return self._vcycle(b, out, avail)
        finally:
            numba.set_num_threads(avail)

    def _vcycle(self, b: np.ndarray, out: np.ndarray, avail: int) -> float:
        levels = self.levels
        levels[0].b = b
        if self._fine_work is not None:
            self._fine_arrays(out)
        nlev = len(levels)
        nthr = [level_threads(lev.d.size, avail) for lev in levels]
        cur = avail  # numba.set_num_threads only where the count changes (it takes a lock)
        for li in range(nlev - 1):
            lev = levels[li]
            if nthr[li] != cur:
                cur = nthr[li]
                numba.set_num_threads(cur)
            self._pre_smooth(lev, nthr[li])
            _kernel(kr.residual_restrict, nthr[li])(
                lev.d, *lev.c, lev.x, lev.b, *lev.f, levels[li + 1].b
            )
        self._coarse_solve(levels[-1].b, levels[-1].x)
        dot = 0.0
        for li in range(nlev - 2, -1, -1):
            lev = levels[li]
            if nthr[li] != cur:
                cur = nthr[li]
                numba.set_num_threads(cur)
            dot = self._post_smooth(lev, levels[li + 1].x, out if li == 0 else None, nthr[li])
        if nlev == 1:
            np.copyto(out, levels[0].x)
            dot = kr.dot(b, out)
        levels[0].b = np.zeros(0)
        if self._fine_work is not None:  # hold no reference to the caller's output
            levels[0].x, levels[0].t = self._fine_work, np.zeros(0, np.float32)
        return float(dot)

    def _fine_arrays(self, out: np.ndarray) -> None:
        """Finest level with one work array: smooth between it and ``out``, starting on the
        array that makes the last post-smoothing sweep land in ``out`` (``pre >= 2``: ``out``,
        then ``pre`` sweeps alternate back to it; ``pre == 1``: the work array)."""
        lev = self.levels[0]
        work = self._fine_work
        lev.x, lev.t = (out, work) if self.pre >= 2 else (work, out)

    @property
    def n_levels(self) -> int:
        return len(self.levels)
