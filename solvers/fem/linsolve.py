"""Linear solvers for the Taylor-Hood saddle-point system.

The reduced system (homogeneous Dirichlet velocity dofs removed) is

    [ A_x              -D_x^T ] [u_x]   [f_x]
    [      A_y         -D_y^T ] [u_y] = [f_y]
    [           A_z    -D_z^T ] [u_z]   [f_z]
    [ -D_x  -D_y  -D_z    0   ] [ p ]   [ 0 ]

with ``A_c = mu L[free_c, free_c]`` (one scalar P2 Laplacian restricted to the free dofs of
component c) and ``D_c`` the P1 x P2 derivative blocks. It is symmetric indefinite; write it
``K = [[A, B^T], [B, 0]]`` with ``B = -[D_x D_y D_z]``.

* Small systems: sparse LU (SuperLU) of the assembled block matrix.
* Large systems, default (:func:`solve_gmres`): right-preconditioned GMRES with the block
  upper-triangular preconditioner ``P = [[A_hat, B^T], [0, -S_hat]]`` (``A_hat``: one
  smoothed-aggregation V-cycle per velocity component, ``S_hat = mu^-1 M_p`` the lumped pressure
  mass for the Schur complement ``B A^-1 B^T``). With exact blocks ``K P^-1`` has the single
  eigenvalue 1 and GMRES converges in two steps; with spectrally equivalent blocks the count
  is bounded independently of the mesh size (Elman, Silvester & Wathen, *Finite Elements and
  Fast Iterative Solvers*, 2nd ed., OUP 2014, sec. 4.2 and 9.2). Right preconditioning makes
  GMRES minimise the true residual ``||b - K x||``, which is the stopping test, so no
  over-solving is needed. Measured on the Toray-like permeameter case (658 k unknowns) it
  needs about 3x fewer iterations than the block-diagonal MINRES below (benchmarks/RESULTS.md,
  "FEM solver").
* ``krylov="minres"`` (:func:`solve_minres`): MINRES with the block-diagonal preconditioner
  ``diag(A_hat, S_hat)`` (Silvester & Wathen, SIAM J. Numer. Anal. 31 (1994) 1352-1367): short
  recurrences, so no stored Krylov basis, but its own stopping test is a preconditioned-norm
  estimate and it is run to a 100x tighter target and restarted until the true residual
  meets the tolerance.

The operator is applied blockwise, never assembled as one matrix.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyamg
import scipy.sparse as sp
from scipy.linalg import solve_triangular
from scipy.sparse.linalg import LinearOperator, minres, splu

from solvers.amg_seed import pyamg_seed

# MINRES' own stopping test uses a preconditioned-norm estimate; aiming below the requested
# true-residual tolerance avoids restarts (each restart discards the Krylov space).
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


#: Krylov methods of :func:`solve_iterative`.
KRYLOV = ("gmres", "minres")

#: Krylov vectors GMRES keeps before it restarts (memory: ``8 (restart + 1)`` bytes per unknown;
#: pages are touched only as the basis grows; ``memory.KRYLOV_BYTES_PER_DOF`` counts them). The
#: Toray-like permeameter case (658 k unknowns) converges in 128.
DEFAULT_RESTART = 200

#: Re-orthogonalise an Arnoldi vector when one Gram-Schmidt pass leaves less than this fraction
#: of its norm (the DGKS criterion, 1 / sqrt(2)).
REORTH = 0.7071


class VCycle:
    """One V-cycle of a pyamg hierarchy from a zero initial guess, ``M @ r``.

    The same cycle as ``pyamg.MultilevelSolver.aspreconditioner(cycle="V")`` (pre-smoother,
    restricted residual, coarse correction, post-smoother on every level; the hierarchy's own
    coarse solver), without the two residual norms ``||b - A x||`` that pyamg's ``solve``
    computes before and after each cycle for its stopping test: two fine-level mat-vecs of
    about seven per cycle, which a preconditioner never needs.
    """

    def __init__(self, ml):
        self.ml = ml
        self.shape = ml.levels[0].A.shape

    def __matmul__(self, b: np.ndarray) -> np.ndarray:
        x = np.zeros_like(b)
        self._cycle(0, x, b)
        return x

    def _cycle(self, lvl: int, x: np.ndarray, b: np.ndarray) -> None:
        levels = self.ml.levels
        level = levels[lvl]
        A = level.A
        level.presmoother(A, x, b)
        coarse_b = level.R @ (b - A @ x)
        if lvl == len(levels) - 2:
            coarse_x = self.ml.coarse_solver(levels[-1].A, coarse_b)
        else:
            coarse_x = np.zeros_like(coarse_b)
            self._cycle(lvl + 1, coarse_x, coarse_b)
        x += level.P @ coarse_x
        level.postsmoother(A, x, b)


def _amg(A: sp.csr_matrix, kind: str):
    if kind not in ("sa", "rs"):
        raise ValueError(f"amg must be 'sa' or 'rs', got {kind!r}")
    with pyamg_seed():
        if kind == "sa":
            ml = pyamg.smoothed_aggregation_solver(A, symmetry="hermitian", max_coarse=500)
        else:
            ml = pyamg.ruge_stuben_solver(A, max_coarse=500)
    if len(ml.levels) == 1:  # no coarsening: pyamg's own path (coarse solve only)
        return ml.aspreconditioner(cycle="V")
    return VCycle(ml)


def velocity_preconditioners(system: SaddleSystem, amg: str = "sa") -> list:
    """One AMG V-cycle operator per velocity component (one hierarchy per distinct block)."""
    by_matrix: dict[int, object] = {}
    for A in system.A:
        if id(A) not in by_matrix:
            by_matrix[id(A)] = _amg(A, amg)
    return [by_matrix[id(A)] for A in system.A]


def block_diagonal(system: SaddleSystem, precs: list):
    """``r -> diag(A_hat, S_hat)^-1 r`` (symmetric positive definite; for MINRES)."""
    inv_m = system.viscosity / system.m_lumped

    def apply(r: np.ndarray) -> np.ndarray:
        rx, ry, rz, rp = system.split(r)
        return np.concatenate([precs[0] @ rx, precs[1] @ ry, precs[2] @ rz, inv_m * rp])

    return apply


def block_triangular(system: SaddleSystem, precs: list):
    """``r -> P^-1 r`` for ``P = [[A_hat, B^T], [0, -S_hat]]`` (for GMRES, right-applied).

    ``y_p = -S_hat^-1 r_p``, then ``y_u = A_hat^-1 (r_u - B^T y_p) = A_hat^-1 (r_u + D^T y_p)``.
    """
    inv_m = system.viscosity / system.m_lumped

    def apply(r: np.ndarray) -> np.ndarray:
        parts = system.split(r)
        yp = -inv_m * parts[3]
        out = [precs[c] @ (parts[c] + system.D[c].T @ yp) for c in range(3)]
        out.append(yp)
        return np.concatenate(out)

    return apply


def gmres(
    matvec,
    prec,
    b: np.ndarray,
    *,
    tol: float,
    max_iter: int,
    restart: int = DEFAULT_RESTART,
    x0: np.ndarray | None = None,
    callback=None,
) -> tuple[np.ndarray, int]:
    """Right-preconditioned restarted GMRES for ``K x = b`` (``K = matvec``, ``P^-1 = prec``).

    Arnoldi with classical Gram-Schmidt (two matrix-vector products with the stored basis per
    step) and a second pass only when the first one cancelled more than ``1 - REORTH`` of the
    vector's norm (Daniel, Gragg, Kaufman & Stewart, Math. Comp. 30 (1976) 772-795), which
    keeps the basis orthogonal to working precision; Givens rotations for the least-squares
    problem. Stops when the GMRES residual norm, which with right
    preconditioning is ``||b - K x||``, is <= ``tol ||b||``, or after ``max_iter`` steps in all.

    Parameters
    ----------
    matvec, prec : callable
        ``v -> K v`` and ``v -> P^-1 v``.
    b : ndarray
        Right-hand side.
    tol : float
        Relative residual target.
    max_iter : int
        Arnoldi steps in all (over restarts).
    restart : int
        Basis size before a restart.
    x0 : ndarray, optional
        Initial guess (default 0).
    callback : callable, optional
        ``callback(iteration, relative_residual)`` after each step.

    Returns
    -------
    (x, iterations)
    """
    n = len(b)
    nb = float(np.linalg.norm(b)) or 1.0
    x = np.zeros_like(b) if x0 is None else x0.copy()
    r = b - matvec(x) if x0 is not None else b.copy()
    total = 0
    m = max(1, min(int(restart), int(max_iter)))
    while total < max_iter:
        beta = float(np.linalg.norm(r))
        if beta <= tol * nb or not np.isfinite(beta):
            break
        V = np.empty((m + 1, n))  # pages are touched only as the basis grows
        H = np.zeros((m + 1, m))
        cs, sn = np.zeros(m), np.zeros(m)
        g = np.zeros(m + 1)
        g[0] = beta
        V[0] = r / beta
        k = 0
        while k < m and total < max_iter:
            w = matvec(prec(V[k]))
            w_norm = float(np.linalg.norm(w))
            h = V[: k + 1] @ w
            w -= V[: k + 1].T @ h
            hn = float(np.linalg.norm(w))
            if hn < REORTH * w_norm:  # cancellation: orthogonalise once more (DGKS)
                h2 = V[: k + 1] @ w
                w -= V[: k + 1].T @ h2
                h += h2
                hn = float(np.linalg.norm(w))
            H[: k + 1, k] = h
            H[k + 1, k] = hn
            if hn > 0:
                V[k + 1] = w / hn
            for i in range(k):  # apply the earlier rotations to the new column
                hi, hi1 = H[i, k], H[i + 1, k]
                H[i, k] = cs[i] * hi + sn[i] * hi1
                H[i + 1, k] = -sn[i] * hi + cs[i] * hi1
            d = float(np.hypot(H[k, k], H[k + 1, k]))
            cs[k], sn[k] = (H[k, k] / d, H[k + 1, k] / d) if d > 0 else (1.0, 0.0)
            H[k, k], H[k + 1, k] = d, 0.0
            g[k + 1] = -sn[k] * g[k]
            g[k] *= cs[k]
            k += 1
            total += 1
            if callback is not None:
                callback(total, abs(g[k]) / nb)
            if abs(g[k]) <= tol * nb or hn == 0:
                break
        y = _upper_solve(H[:k, :k], g[:k])
        x += prec(V[:k].T @ y)
        del V
        r = b - matvec(x)
    return x, total


def _upper_solve(R: np.ndarray, g: np.ndarray) -> np.ndarray:
    return solve_triangular(R, g, lower=False, check_finite=False)


def solve_gmres(
    system: SaddleSystem,
    b: np.ndarray,
    *,
    tol: float,
    max_iter: int,
    amg: str = "sa",
    restart: int = DEFAULT_RESTART,
    callback=None,
) -> SolveInfo:
    """GMRES with the block upper-triangular preconditioner (see the module docstring).

    Converged when the true relative residual ``||b - K x|| / ||b|| <= tol`` (recomputed at
    the end; if rounding left it above ``tol``, GMRES continues from that iterate while
    iterations remain).
    """
    precs = velocity_preconditioners(system, amg)
    prec = block_triangular(system, precs)
    x = np.zeros_like(b)
    spent = 0
    res = 1.0
    while spent < max_iter:
        x, its = gmres(
            system.matvec,
            prec,
            b,
            tol=tol,
            max_iter=max_iter - spent,
            restart=restart,
            x0=x if spent else None,
            callback=None if callback is None else (lambda i, r, s=spent: callback(s + i, r)),
        )
        spent += its
        res = relative_residual(system, x, b)
        if res <= tol or not np.isfinite(res) or its == 0:
            break
    return SolveInfo(
        x=x,
        converged=bool(res <= tol),
        iterations=spent,
        residual=res,
        method=f"gmres+amg-{amg}",
    )


def solve_minres(
    system: SaddleSystem,
    b: np.ndarray,
    *,
    tol: float,
    max_iter: int,
    amg: str = "sa",
    callback=None,
) -> SolveInfo:
    """Block-diagonally preconditioned MINRES.

    The stopping test is the true relative residual ``||b - K x|| / ||b|| <= tol``: MINRES
    (whose internal test uses a preconditioned-norm estimate) is restarted from its last
    iterate until the true residual meets ``tol`` or ``max_iter`` iterations are spent.
    ``callback(iteration, nan)`` after each step (MINRES gives no cheap true residual).
    """
    precs = velocity_preconditioners(system, amg)
    M = LinearOperator((system.n, system.n), matvec=block_diagonal(system, precs), dtype=float)
    K = system.operator()
    count = [0]

    def cb(_xk):
        count[0] += 1
        if callback is not None:
            callback(count[0], float("nan"))

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


def solve_iterative(
    system: SaddleSystem,
    b: np.ndarray,
    *,
    tol: float,
    max_iter: int,
    amg: str = "sa",
    krylov: str = "gmres",
    callback=None,
) -> SolveInfo:
    """Dispatch to :func:`solve_gmres` (default) or :func:`solve_minres`."""
    if krylov == "gmres":
        return solve_gmres(system, b, tol=tol, max_iter=max_iter, amg=amg, callback=callback)
    if krylov == "minres":
        return solve_minres(system, b, tol=tol, max_iter=max_iter, amg=amg, callback=callback)
    raise ValueError(f"krylov must be one of {KRYLOV}, got {krylov!r}")
