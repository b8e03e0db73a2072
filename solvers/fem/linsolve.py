"""Linear solvers for the Taylor-Hood saddle-point system.

The reduced system (homogeneous Dirichlet velocity dofs removed) is

    [ A_x              -D_x^T ] [u_x]   [f_x]
    [      A_y         -D_y^T ] [u_y] = [f_y]
    [           A_z    -D_z^T ] [u_z]   [f_z]
    [ -D_x  -D_y  -D_z    0   ] [ p ]   [ 0 ]

with ``A_c = mu L[free_c, free_c]`` (one scalar P2 Laplacian restricted to the free dofs of
component c) and ``D_c`` the P1 x P2 derivative blocks. It is symmetric indefinite.

* Small systems: sparse LU (SuperLU) of the assembled block matrix.
* Large systems: MINRES with the block-diagonal preconditioner
  ``diag(AMG(A_x), AMG(A_y), AMG(A_z), mu^-1 M_p)`` (one smoothed-aggregation V-cycle per velocity
  component, lumped pressure mass for the Schur complement), which is spectrally equivalent
  to the system for inf-sup stable pairs (Silvester & Wathen, SIAM J. Numer. Anal. 31 (1994)
  1352-1367; Elman, Silvester & Wathen, *Finite Elements and Fast Iterative Solvers*, 2nd ed.,
  OUP 2014, ch. 4). The operator is applied blockwise, never assembled as one matrix.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pyamg
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, minres, splu

# MINRES' own stopping test uses a preconditioned-norm estimate; aiming below the requested
# true-residual tolerance avoids restarts (each restart discards the Krylov space).
#: Seconds between two ``progress`` reports of :func:`solve_minres` (each costs one product).
PROGRESS_EVERY_S = 2.0
INNER_FACTOR = 0.01


@dataclass
class SaddleSystem:
    """Blocks of the reduced Stokes system (see module docstring)."""

    A: list  # three csr matrices (may be the same object when free sets coincide)
    D: list  # three csr matrices (n_p, n_free_c)
    m_lumped: np.ndarray  # (n_p,)
    viscosity: float

    @property
    def sizes(self) -> list[int]:
        return [a.shape[0] for a in self.A] + [len(self.m_lumped)]

    @property
    def n(self) -> int:
        return int(sum(self.sizes))

    def split(self, x: np.ndarray) -> list[np.ndarray]:
        cuts = np.cumsum(self.sizes)[:-1]
        return np.split(x, cuts)

    def matvec(self, x: np.ndarray) -> np.ndarray:
        ux, uy, uz, p = self.split(x)
        out = []
        yp = np.zeros_like(p)
        for A, D, u in zip(self.A, self.D, (ux, uy, uz), strict=True):
            out.append(A @ u - D.T @ p)
            yp -= D @ u
        out.append(yp)
        return np.concatenate(out)

    def operator(self) -> LinearOperator:
        return LinearOperator((self.n, self.n), matvec=self.matvec, dtype=np.float64)

    def assembled(self) -> sp.csc_matrix:
        z = [[None] * 4 for _ in range(4)]
        for c in range(3):
            z[c][c] = self.A[c]
            z[c][3] = -self.D[c].T
            z[3][c] = -self.D[c]
        z[3][3] = sp.csr_matrix((len(self.m_lumped), len(self.m_lumped)))
        return sp.bmat(z, format="csc")


@dataclass
class SolveInfo:
    x: np.ndarray
    converged: bool
    iterations: int
    residual: float
    method: str


def relative_residual(system: SaddleSystem, x: np.ndarray, b: np.ndarray) -> float:
    """Euclidean ``||b - K x|| / ||b||``."""
    nb = float(np.linalg.norm(b))
    return float(np.linalg.norm(b - system.matvec(x))) / (nb if nb > 0 else 1.0)


def solve_direct(system: SaddleSystem, b: np.ndarray, tol: float) -> SolveInfo:
    """Sparse LU of the assembled block matrix (small systems only); converged if the true
    relative residual is <= ``tol``."""
    K = system.assembled()
    lu = splu(K, permc_spec="COLAMD")
    x = lu.solve(b)
    del lu, K
    res = relative_residual(system, x, b)
    return SolveInfo(x=x, converged=bool(res <= tol), iterations=1, residual=res, method="direct")


def _amg(A: sp.csr_matrix, kind: str):
    if kind == "sa":
        ml = pyamg.smoothed_aggregation_solver(A, symmetry="hermitian", max_coarse=500)
    elif kind == "rs":
        ml = pyamg.ruge_stuben_solver(A, max_coarse=500)
    else:
        raise ValueError(f"amg must be 'sa' or 'rs', got {kind!r}")
    return ml.aspreconditioner(cycle="V")


def solve_minres(
    system: SaddleSystem,
    b: np.ndarray,
    *,
    tol: float,
    max_iter: int,
    amg: str = "sa",
    progress: Callable[[int, float], None] | None = None,
) -> SolveInfo:
    """Block-diagonally preconditioned MINRES.

    ``progress(iterations, residual)``, if given, is called about every
    :data:`PROGRESS_EVERY_S` seconds with the true relative residual of the current iterate.

    The stopping test is the true relative residual ``||b - K x|| / ||b|| <= tol``: MINRES
    (whose internal test uses a preconditioned-norm estimate) is restarted from its last
    iterate until the true residual meets ``tol`` or ``max_iter`` iterations are spent.
    """
    by_matrix: dict[int, object] = {}  # one hierarchy per distinct velocity block
    for A in system.A:
        if id(A) not in by_matrix:
            by_matrix[id(A)] = _amg(A, amg)
    precs = [by_matrix[id(A)] for A in system.A]
    inv_m = system.viscosity / system.m_lumped

    def apply_prec(r: np.ndarray) -> np.ndarray:
        rx, ry, rz, rp = system.split(r)
        return np.concatenate([precs[0] @ rx, precs[1] @ ry, precs[2] @ rz, inv_m * rp])

    M = LinearOperator((system.n, system.n), matvec=apply_prec, dtype=np.float64)
    K = system.operator()
    count = [0]
    last = [time.perf_counter()]

    def cb(xk):
        count[0] += 1
        if progress is not None and time.perf_counter() - last[0] >= PROGRESS_EVERY_S:
            last[0] = time.perf_counter()
            progress(count[0], relative_residual(system, xk, b))

    x = np.zeros_like(b)
    res = 1.0
    inner_tol = tol * INNER_FACTOR
    while count[0] < max_iter:
        before = count[0]
        x, _info = minres(K, b, x0=x, rtol=inner_tol, maxiter=max_iter - count[0], M=M, callback=cb)
        res = relative_residual(system, x, b)
        if res <= tol or not np.isfinite(res) or count[0] == before:
            break
        inner_tol = max(inner_tol * 0.1, 1e-15)
    return SolveInfo(
        x=x,
        converged=bool(res <= tol),
        iterations=count[0],
        residual=res,
        method=f"minres+amg-{amg}",
    )
