"""The assembled saddle-point system of the diffuse-wall voxel Stokes model, its preconditioner
and its MINRES solve (scipy sparse + pyamg; :mod:`solvers.voxel.diffuse` is the public entry).

Voxel units throughout (h = 1, mu = 1, unit body force).  On a periodic ``nx x ny x nz`` grid
``u``, ``v``, ``w`` sit on the x, y, z faces, ``p`` on the cells; every face is an unknown (the
solid ones too: the drag keeps them at rest).  Per velocity component ``c``::

    A_c = sum_d D_d^T diag(eps_cd) D_d + diag(drag_c),    (D_d x)_i = x_i - x_{i - e_d}

with ``eps_cd`` where the flux between the two velocity nodes sits: a cell centre for ``d = c``,
the midpoint of the cell edge along ``e = 3 - c - d`` for ``d != c`` (the 2-D model's corner
points seen end-on, so an extruded grid reproduces the 2-D model exactly).  The pressure force,
the flux (``div(eps u) = 0``) and the body force are weighted by ``eps`` at the face
(``G_c = diag(eps_face_c) D_c``).  The saddle matrix ``[[A, -G], [-G^T, P]]`` pins the pressure
cells with no weighted face (``P`` = 1) and carries ``-1e-11`` on the others (the pressure's
constant mode).  No cross-component viscous terms (as in the 2-D model of wall22).

Solve: MINRES (scipy) with the block-diagonal SPD preconditioner of port22: a smoothed-
aggregation AMG V-cycle (pyamg) per velocity block and the inverse diagonal of ``S = G^T
diag(A)^-1 G`` on the pressure (41 MINRES iterations where an AMG V-cycle on ``S`` took 173;
spheres c 0.216 at 32^3, ``benchmarks/RESULTS.md``, port22), inside an iterative refinement on
the true residual ``||b - K x|| / ||b||`` (scipy's MINRES stops on ``||r|| / (||A|| ||x||)``,
which can be far above the relative residual).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["DiffuseSystem", "assemble", "minres_solve", "preconditioner"]

PRESSURE_REGULARISATION = -1e-11
"""Diagonal of the live pressure cells (the pressure's constant mode; port22)."""

LIVE_FLOOR = 1e-9
"""A pressure cell is live (a mass balance) when the weights of its faces sum above this."""

REFINEMENT_CYCLES = 6
"""MINRES runs on the true residual at most (the first included)."""


@dataclass
class DiffuseSystem:
    """The saddle-point system ``[[A, -G], [-G^T, P]] (u, p) = (eps f, 0)`` (module docstring).

    Attributes
    ----------
    shape : tuple of int
        The grid ``(nx, ny, nz)``.
    blocks : list of (eps, A_c, G_c)
        Per velocity component the face fluid fraction (raveled), the viscous block (CSR) and
        the weighted pressure difference restricted to the live cells (CSR).
    live : np.ndarray of bool
        Pressure cells with a weighted face (raveled).
    rhs : np.ndarray
        The right-hand side (``4 n``).
    """

    shape: tuple[int, int, int]
    blocks: list
    live: np.ndarray
    rhs: np.ndarray

    @property
    def n(self) -> int:
        """Cells of the grid."""
        return int(np.prod(self.shape))

    def pin(self) -> np.ndarray:
        """The pressure block's diagonal ``P``."""
        return np.where(self.live, PRESSURE_REGULARISATION, 1.0)

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """``K x`` without the assembled matrix."""
        n = self.n
        p = x[3 * n :]
        out = np.empty_like(x)
        out[3 * n :] = self.pin() * p
        for c, (_, a_c, g_c) in enumerate(self.blocks):
            u = x[c * n : (c + 1) * n]
            out[c * n : (c + 1) * n] = a_c @ u - g_c @ p
            out[3 * n :] -= g_c.T @ u
        return out

    def operator(self) -> spla.LinearOperator:
        """``K`` as a scipy linear operator."""
        return spla.LinearOperator((4 * self.n, 4 * self.n), self.matvec, dtype=float)

    def matrix(self) -> sp.csr_matrix:
        """``K`` assembled (for a direct factorisation of small grids)."""
        (_, a0, g0), (_, a1, g1), (_, a2, g2) = self.blocks
        return sp.bmat(
            [
                [a0, None, None, -g0],
                [None, a1, None, -g1],
                [None, None, a2, -g2],
                [-g0.T, -g1.T, -g2.T, sp.diags(self.pin())],
            ],
            format="csr",
        )


def _neighbours(shape: tuple[int, int, int]) -> list[np.ndarray]:
    """Per axis ``d`` the raveled index of cell ``(i, j, k) - e_d`` (periodic)."""
    idx = np.arange(int(np.prod(shape)), dtype=np.int64).reshape(shape)
    return [np.roll(idx, 1, axis=d).ravel() for d in range(3)]


def _viscous_block(weights, drag: np.ndarray, prev: list[np.ndarray], shape) -> sp.csr_matrix:
    """``sum_d D_d^T diag(w_d) D_d + diag(drag)``; ``weights[d]`` raveled (None: skip the axis,
    a one-cell axis where ``D_d`` = 0)."""
    n = drag.size
    i = np.arange(n, dtype=np.int64)
    rows, cols, vals = [i], [i], [drag]
    for d, w in enumerate(weights):
        if w is None or shape[d] == 1:
            continue
        j = prev[d]
        rows += [i, j, i, j]
        cols += [i, j, j, i]
        vals += [w, w, -w, -w]
    mat = sp.coo_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), (n, n)
    )
    return mat.tocsr()


def _gradient(
    eps: np.ndarray, prev: np.ndarray, live: np.ndarray, axis_cells: int
) -> sp.csr_matrix:
    """``diag(eps) D_c`` restricted to the live pressure cells (columns)."""
    n = eps.size
    i = np.arange(n, dtype=np.int64)
    if axis_cells == 1:
        return sp.csr_matrix((n, n))
    rows = np.concatenate([i, i])
    cols = np.concatenate([i, prev])
    vals = np.concatenate([eps * live, -eps * live[prev]])
    mat = sp.coo_matrix((vals, (rows, cols)), (n, n)).tocsr()
    mat.eliminate_zeros()
    return mat


def _live_cells(faces: list[np.ndarray], prev: list[np.ndarray], shape) -> np.ndarray:
    """Pressure cells whose weighted faces sum above :data:`LIVE_FLOOR` (``|G|^T 1``)."""
    total = np.zeros(faces[0].size)
    for c in range(3):
        if shape[c] == 1:
            continue
        total += faces[c]  # the cell's own (lower) face c: +eps in row i, column i
        total[prev[c]] += faces[c]  # face c of the next cell: -eps in column i (a permutation)
    return total > LIVE_FLOOR


def assemble(grid, force) -> DiffuseSystem:
    """The saddle-point system of a :class:`solvers.voxel.diffuse.DiffuseGrid` (or anything with
    its ``cell``, ``face``, ``edge``, ``drag`` arrays) under the body force ``force`` (a
    3-vector, voxel units)."""
    shape = tuple(int(m) for m in grid.cell.shape)
    prev = _neighbours(shape)
    faces = [np.ascontiguousarray(grid.face[c], dtype=float).ravel() for c in range(3)]
    live = _live_cells(faces, prev, shape)
    blocks = []
    for c in range(3):
        weights = []
        for d in range(3):
            if d == c:  # the cell centre between face i - e_c and face i: cell i - e_c
                weights.append(np.roll(grid.cell, 1, axis=c).ravel().astype(float))
            else:  # the edge along e = 3 - c - d at the cell's lower corner
                weights.append(np.asarray(grid.edge[3 - c - d], dtype=float).ravel())
        a_c = _viscous_block(weights, np.asarray(grid.drag[c], dtype=float).ravel(), prev, shape)
        del weights
        blocks.append((faces[c], a_c, _gradient(faces[c], prev[c], live, shape[c])))
    f = np.asarray(force, dtype=float)
    rhs = np.concatenate([faces[c] * f[c] for c in range(3)] + [np.zeros(faces[0].size)])
    return DiffuseSystem(shape, blocks, live, rhs)


def _schur_diagonal(system: DiffuseSystem) -> np.ndarray:
    """Diagonal of ``S - P`` with ``S = G^T diag(A)^-1 G``: ``|P|`` (1e-11) on the live cells,
    1 on the pinned ones.

    port22 added ``1e-8`` of the live mean of ``S`` instead: deep in a fibre, where ``S`` is
    ``eps^2 / D`` ~ 1e-15, that over-scaled the weakly coupled pressures by ~300x, and their
    slow convergence held the true residual (tilted array phi 0.3, 24 voxels per spacing,
    MINRES to ``rtol`` 1e-12: 161 iterations, true residual 2.6e-8; with ``|P|``: 50 and 2.1e-8,
    the same K to 1e-11; dport23)."""
    diag = np.zeros(system.n)
    for _, a_c, g_c in system.blocks:
        diag += (g_c.multiply(g_c)).T @ (1.0 / a_c.diagonal())
    return diag + np.abs(system.pin())


def preconditioner(system: DiffuseSystem, pressure: str = "diag") -> spla.LinearOperator:
    """Block-diagonal SPD preconditioner: an AMG V-cycle (pyamg smoothed aggregation) per
    velocity block; on the pressure ``S = G^T diag(A)^-1 G`` (pinned cells: identity) either its
    inverse diagonal (``diag``, the product's sub-voxel pressure scaling without its coarse
    Darcy term) or an AMG V-cycle (``amg``, 4x the iterations: port22).  The hierarchies are
    built with NumPy's global generator seeded (:func:`solvers.amg_seed.pyamg_seed`: pyamg's
    random start vectors gave another K each run)."""
    import pyamg

    from solvers.amg_seed import pyamg_seed

    def amg(a):
        return pyamg.smoothed_aggregation_solver(a, symmetry="hermitian").aspreconditioner()

    n = system.n
    sdiag = _schur_diagonal(system)
    with pyamg_seed():
        cycles = [amg(a) for _, a, _ in system.blocks]
        if pressure == "amg":
            schur = sum(g.T @ sp.diags(1.0 / a.diagonal()) @ g for _, a, g in system.blocks)
            pcyc = amg((schur + sp.diags(sdiag - schur.diagonal())).tocsr())
    if pressure == "amg":

        def press(r):
            return pcyc @ r
    elif pressure == "diag":
        inv = 1.0 / sdiag

        def press(r):
            return inv * r
    else:
        raise ValueError(f"pressure must be 'diag' or 'amg', got {pressure!r}")

    def apply(r):
        out = np.empty_like(r)
        for c in range(3):
            out[c * n : (c + 1) * n] = cycles[c] @ r[c * n : (c + 1) * n]
        out[3 * n :] = press(r[3 * n :])
        return out

    return spla.LinearOperator((4 * n, 4 * n), apply, dtype=float)


def minres_solve(
    system: DiffuseSystem,
    tol: float,
    max_iter: int,
    progress: Callable[[int, float], None] | None = None,
    pressure: str = "diag",
) -> tuple[np.ndarray, dict]:
    """MINRES to the true relative residual ``tol`` within ``max_iter`` iterations in all.

    Returns ``(x, info)``; ``info`` has ``converged``, ``iterations``, ``residual`` (true,
    relative), ``history`` (after each run) and ``message``.
    """
    op, m = system.operator(), preconditioner(system, pressure)
    b = system.rhs
    bnorm = float(np.linalg.norm(b))
    x = np.zeros_like(b)
    history, its, res, message = [1.0], 0, 1.0, ""
    count = [0]

    def tick(_):
        count[0] += 1
        if progress is not None and count[0] % 25 == 0:
            progress(its + count[0], res)

    for _ in range(REFINEMENT_CYCLES):
        count[0] = 0
        r = b - op @ x
        dx, _info = spla.minres(op, r, M=m, rtol=tol, maxiter=max_iter - its, callback=tick)
        x += dx
        its += count[0]
        res = float(np.linalg.norm(b - op @ x)) / bnorm
        history.append(res)
        if progress is not None:
            progress(its, res)
        if res <= tol:
            message = "converged"
            break
        if its >= max_iter:
            message = (
                f"MINRES stopped at max_iter {max_iter}: true residual {res:.3g} > tol {tol:g}"
            )
            break
        if res > 0.5 * history[-2]:
            message = f"MINRES stalled at true residual {res:.3g} > tol {tol:g} (no halving)"
            break
    else:
        message = f"true residual {res:.3g} > tol {tol:g} after {REFINEMENT_CYCLES} MINRES runs"
    info = {
        "converged": res <= tol,
        "iterations": its,
        "residual": res,
        "history": history,
        "message": message,
    }
    return x, info
