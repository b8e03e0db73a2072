"""Aggregation multigrid for the scalar no-slip Laplacians of the MAC voxel Stokes solver.

Each velocity component has its own operator ``A_a`` (7-point negative Laplacian on the active
faces, walls on voxel faces; see :mod:`solvers.voxel.kernels`).  The preconditioner is one
symmetric V-cycle per component:

* coarse levels are Galerkin operators ``P^T A P`` with piecewise-constant prolongation over box
  aggregates of 2 cells per axis (1 on axes of fewer than 4 cells; an odd axis puts 3 cells in
  its last aggregate), so they stay 7-point stencils, stay SPD, and keep exactly the drag of the
  walls of the fine grid however thin the fibres are (no re-discretised coarse masks);
* damped Jacobi smoothing (parallel, symmetric), ``pre = post`` sweeps;
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
    act = fluid & np.roll(fluid, 1, axis=a)
    solid = ~fluid
    both_solid = solid & np.roll(solid, 1, axis=a)
    diag = np.full(fluid.shape, 6, dtype=np.uint8)
    for b in range(3):
        if b == a:
            continue
        for s in (-1, 1):
            diag += np.roll(both_solid, s, axis=b)
    diag[~act] = 0
    c = np.empty((3, *fluid.shape), dtype=np.uint8)
    for b in range(3):
        c[b] = act & np.roll(act, 1, axis=b)
    return diag, c


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
    """Symmetric aggregation V-cycle for one 7-point SPD operator (see module docstring)."""

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
        self.pre = pre
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
            self.levels.append(Level(d=dc, c=cc))
        for li, lev in enumerate(self.levels):
            if li == 0 and work is not None:
                lev.x, lev.t = work[0], work[1]
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

    def _smooth(self, lev: Level, first_from_zero: bool, out: np.ndarray | None = None) -> None:
        """``pre`` damped Jacobi sweeps on ``lev.x``; the last one writes into ``out`` if given
        (saves a copy on the finest level)."""
        sweeps = self.pre
        if first_from_zero:
            kr.jacobi_zero(lev.d, lev.b, lev.x, self.omega)
            sweeps -= 1
        for s in range(sweeps):
            if out is not None and s == sweeps - 1:
                kr.jacobi(lev.d, lev.c[0], lev.c[1], lev.c[2], lev.x, lev.b, out, self.omega)
                return
            kr.jacobi(lev.d, lev.c[0], lev.c[1], lev.c[2], lev.x, lev.b, lev.t, self.omega)
            lev.x, lev.t = lev.t, lev.x
        if out is not None:
            np.copyto(out, lev.x)

    def apply(self, b: np.ndarray, out: np.ndarray) -> None:
        """out = V-cycle(b) starting from zero (approximates A^-1 b).

        Each level runs on :func:`~solvers.voxel.threads.level_threads` numba threads (the
        coarse levels on one: a parallel region there costs more than its work on a busy
        machine); the caller's thread count is restored on return.
        """
        avail = numba.get_num_threads()
        try:
            self._vcycle(b, out, avail)
        finally:
            numba.set_num_threads(avail)

    def _vcycle(self, b: np.ndarray, out: np.ndarray, avail: int) -> None:
        levels = self.levels
        levels[0].b = b
        nlev = len(levels)
        nthr = [level_threads(lev.d.size, avail) for lev in levels]
        for li in range(nlev - 1):
            lev = levels[li]
            numba.set_num_threads(nthr[li])
            self._smooth(lev, True)
            kr.residual_restrict(
                lev.d, lev.c[0], lev.c[1], lev.c[2], lev.x, lev.b, *lev.f, levels[li + 1].b
            )
        self._coarse_solve(levels[-1].b, levels[-1].x)
        for li in range(nlev - 2, -1, -1):
            lev = levels[li]
            numba.set_num_threads(nthr[li])
            kr.prolong_add(lev.d, levels[li + 1].x, *lev.f, self.alpha, lev.x)
            self._smooth(lev, False, out if li == 0 else None)
        if nlev == 1:
            np.copyto(out, levels[0].x)
        levels[0].b = np.zeros(0)

    @property
    def n_levels(self) -> int:
        return len(self.levels)
