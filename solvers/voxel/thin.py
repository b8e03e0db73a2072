"""Local pressure solves of the slow modes of the thin fluid regions (voxel Stokes preconditioner).

Why
---
The smallest eigenvalues of the preconditioned Stokes system, which set how the refinement
cycles' iteration count grows with the box (``benchmarks/RESULTS.md``, "Issue 16 item 4,
iteration growth (defl12)"), belong to *local* pressure modes: on the Toray-like 100 um box the
smallest one (Ritz value -0.048 of the second refinement cycle) holds 90 % of its norm on 4 cells
of a dead-end tube one voxel wide, and the next ones are mixtures of many short dead-end stubs.
The pressure block's pore-scale part ``D^-1`` (the inverse Schur diagonal,
:mod:`solvers.voxel.schur`) treats each cell alone, and the coarse Darcy term's blocks (4^3
cells) average such a tube with the open pore around it, so neither represents the tube's
slowest mode: a one-dimensional Laplacian along the tube, whose smallest Jacobi-scaled
eigenvalue falls as ``(pi / (2 L + 1))^2`` with the tube's length ``L``, and a bigger box holds
longer tubes.

What
----
The pressure cells with at most :data:`MAX_FACES` open faces (the *thin* cells: tubes, slits,
dead ends, throats), and since session 14 the knots where such branches meet (more open faces,
all into thin cells: :data:`JUNCTION`), are grouped into their connected pieces (face neighbours
through open faces; a piece of more than :data:`PIECE` cells is cut into consecutive runs of its
cells), and on each
piece ``P`` the diagonal ``D_P`` is replaced by the piece's own block of the Schur
approximation ``L = G^T diag(A)^-1 G`` (``L_cc = D_c``, the Schur diagonal; ``L_cd = -w_f^2 /
A_ff`` for the face ``f`` between two cells of the piece; faces leaving the piece only on the
diagonal, i.e. a Dirichlet condition at the piece's mouth)::

    B^-1 = blockdiag(L_P^-1 on the pieces, D^-1 on the other cells)

``B`` is block diagonal with symmetric positive definite blocks (a piece with no face leaving
it, an enclosed pocket, keeps ``D``: its ``L_P`` is singular), so the pressure block ``B^-1 +
R^T S_c^+ R`` stays SPD and SYMMLQ / MINRES stay valid.  Stored as ``E_P = L_P^-1 - D_P^-1``
(the pressure block's own, coded ``D^-1``) per piece, symmetric, packed lower triangle,
float32, added to the pressure block's output in one pass (:func:`thin_apply`); single cells
are left out (their block is ``D`` itself).

On a grid with an axis of one cell the periodic face along it joins a cell to itself; the operator
has no pressure difference nor divergence term across it, so it is no face of ``L`` and its two
halves come off the piece's diagonal (session 49: it had overwritten that diagonal with ``-w_f^2 /
A_ff``, every piece of such a grid negative there, the pressure block indefinite); the thin-cell
mask and ``D`` still count it as two open faces.

Only the slow modes (since session 13)
-------------------------------------
The Dirichlet condition at the mouth is right for a dead end behind a narrow mouth, wrong for a
piece whose faces leave it on every cell: the concave corners of a staircase wall are columns of
4-face cells along the wall with two of their four faces into the open pore.  There ``D^-1
L_P`` has its smallest eigenvalue at 0.54-0.56 (sub-voxel walls: 0.72-0.92), the exact local
solve scales those modes by up to 1.8 against a true local Schur complement that couples them to
the pore around, and the far end of the preconditioned spectrum grows: the cylinder arrays of
``docs/validation.md`` took up to 23 % more iterations (``benchmarks/RESULTS.md``, "Thin pieces
on array grids (thin13)").  So each piece's scaled block ``M = D^-1/2 L_P D^-1/2`` (``D`` the
coded diagonal) is decomposed, ``M = V diag(theta) V^T``, and only its modes below :data:`LOW`
are corrected::

    B_P^-1 = D^-1/2 (I + sum_{theta_k < LOW} (1 / theta_k - 1) v_k v_k^T) D^-1/2

(``E_P`` the sum term: SPD, ``B_P^-1`` maps those modes of ``D^-1 L_P`` to 1 and leaves the
others at ``D``); on a dead end (at most :data:`MOUTHS` cells with a face leaving the piece, where
the Dirichlet mouth is right) the modes below :data:`DEAD_END_LOW`.  A piece with no such mode
is dropped: Toray-like 200 um, 765 of 80 574 pieces kept, 0.12 B per voxel instead of 0.84, the
pass 29x shorter.  Every row of ``docs/validation.md`` is back to its count without thin
pieces.

Measured (Toray-like 1 um, SYMMLQ to 1e-6; ``benchmarks/RESULTS.md``): without thin pieces
131 / 150 / 187 / 246 iterations at 100 / 200 / 300 / 400 um; the whole ``L_P^-1`` (session 12,
"Issue 16 item 4, iteration growth (defl12)") 113 / 141 / 166 / 182 (the second refinement
cycle's smallest Ritz value 0.048 / 0.036 / 0.030 / 0.015 -> 0.12 / 0.063 / 0.068 / 0.042, the
far end at 100 um -1.05 -> -1.11); the slow modes (:data:`LOW` 0.3, dead ends 0.45) 104 / 139 /
164 / 182, K within 1e-9 (:data:`LOW` 0.3 alone: 104 / 136 / 164 / 191; 100 um: smallest Ritz
value 0.120, far end -1.03).  With at most 2 open faces (the
one-voxel tubes alone) 124 / 150 at 100 / 200 um, 3 faces 122 / 145 (session 12; 3 faces and
:data:`LOW` 0.3: 124 at 100 um); 5 faces 146 / 162: the pieces then span the open pore space
(5 faces and :data:`LOW` 0.3: 169 at 100 um: those pieces' low modes are not local either).
"""

from __future__ import annotations

import numba as nb
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from solvers.blas_threads import single_thread_blas
from solvers.jit import parallel_kernel
from solvers.reduction import ordered_sum
from solvers.voxel import simd
from solvers.voxel.kernels import _dn, _up  # the periodic neighbours by selects

__all__ = ["JUNCTION", "MAX_FACES", "PIECE", "ThinBlocks", "thin_apply"]

MAX_FACES = 4
"""Most open faces of a thin cell (1-voxel tubes have 2, slits one voxel thick 4)."""

PIECE = 64
"""Most cells of a piece (a larger connected set of thin cells is cut into runs of this many:
any partition keeps the block diagonal ``B`` SPD; it bounds the stored entries per cell)."""

LOW = 0.3
"""Modes of a piece's ``D^-1 L_P`` below this are corrected (mapped to 1), the rest keep ``D``
(inf: the whole ``L_P^-1``, session 12's rule).  Toray-like 100 um: 0.15 / 0.2 / 0.25 / 0.3 /
0.35 / 0.4 / 0.45 / 0.5 / inf give 104 / 106 / 106 / 104 / 104 / 107 / 107 / 108 / 113
iterations, 200 um 0.2 / 0.3 / 0.4 / 0.45 / 0.5 / inf 141 / 136 / 141 / 141 / 139 / 141, 400 um
0.3 / 0.45 / inf 191 / 182 / 182; the wall-corner columns of the cylinder arrays sit at 0.54 and
above, pieces of the permeameter arrays between 0.3 and 0.45 (every permeameter row of
``docs/validation.md`` took 1-9 % more iterations at 0.45), a dead-end tube of L cells at about
``(pi / (2 L + 1))^2``."""

DEAD_END_LOW = 0.45
""":data:`LOW` of the pieces that open to the rest of the fluid through at most
:data:`MOUTHS` cells (dead ends: their Dirichlet mouth is right); Toray-like 100 / 200 / 300 /
400 um 104 / 139 / 164 / 182 iterations, the arrays' counts unchanged."""

JUNCTION = 0
"""A pressure cell with more than :data:`MAX_FACES` open faces whose open faces lead to thin
cells except at most this many is thin too (-1: no such cells, session 13 and before): the knot
where 1-voxel branches of a dead-end tree meet has 5-6 open faces, and cut there each branch was
its own piece with its mouth at the knot, while the tree's slowest mode spans them all (Toray-like
400 um: the second refinement cycle's smallest Ritz value -0.040 on 14 cells for half its norm
around such a knot).  0 (every open neighbour thin): 1 506 cells at 400 um, 13 at 100 um;
``benchmarks/RESULTS.md``, "Issue 16 item 4, the far end of the spectrum (grow14)"."""

MOUTHS = 2
"""Most cells with a face leaving the piece of a dead end (:data:`DEAD_END_LOW`)."""

TASK = 256
"""Pieces per parallel task of :func:`thin_apply` (one pair of work rows per task)."""

AHEAD = 8
"""Pieces ahead whose cells :func:`thin_apply` prefetches: the thin cells are scattered over the
pressure fields, so each piece's loads miss the caches and the hardware prefetchers cannot guess
them (Toray-like 300 um, 0.86 M thin cells, two threads, load 2.6: 48-51 ms -> 17 ms per pass, the
same value; a synthetic 400^3 layout, 2 M cells in 640 k pieces: 64-67 -> 19-20 ms, 4 pieces
ahead 22 ms, 16-32 slower)."""

_OPTS = {"cache": True, "fastmath": True, "nogil": True}


@nb.njit(inline="always")
def _piece_apply(cells, c0, s, packed, f, r, z, x, y):
    """``z[cells] += E r[cells]`` for one piece of ``s`` cells (``E`` packed lower from ``f``,
    walked with one running index); returns the float64 ``r . E r`` on the piece."""
    for i in range(s):
        x[i] = np.float64(r[cells[c0 + i]])
        y[i] = 0.0
    k = f
    for i in range(s):
        xi = x[i]
        acc = 0.0
        for j in range(i):
            e = np.float64(packed[k])
            k += 1
            acc += e * x[j]
            y[j] += e * xi
        y[i] += acc + np.float64(packed[k]) * xi
        k += 1
    out = 0.0
    for i in range(s):
        z[cells[c0 + i]] += np.float32(y[i])
        out += x[i] * y[i]
    return out


@parallel_kernel(**_OPTS)
def thin_apply(cells, start, fstart, packed, width, r, z):
    """``z += E r`` on every piece (:class:`ThinBlocks`: at most ``width`` cells each; ``r, z``
    the flat pressure fields); returns the float64 ``r . E r``.  Pieces are disjoint: no two
    tasks write one cell."""
    npieces = start.shape[0] - 1
    ntask = (npieces + TASK - 1) // TASK
    part = np.zeros(ntask)
    for t in nb.prange(ntask):
        x = np.empty(width)
        y = np.empty(width)
        acc = 0.0
        hi = min(npieces, (t + 1) * TASK)
        for p in range(t * TASK, hi):
            if p + AHEAD < hi:
                for k in range(start[p + AHEAD], start[p + AHEAD + 1]):
                    c = cells[k]
                    simd.prefetch_row(r[c : c + 1])
                    simd.prefetch_row(z[c : c + 1])
            c0 = start[p]
            acc += _piece_apply(cells, c0, start[p + 1] - c0, packed, fstart[p], r, z, x, y)
        part[t] = acc
    return ordered_sum(part)


@nb.njit(inline="always")
def _faces_at(f0, f1, f2, i, j, k):
    """The open-face count and the Schur diagonal (float64 sum over the axes of the float32
    ``q + up``, the two faces of the cell along the axis) of cell ``(i, j, k)``; periodic."""
    nx, ny, nz = f0.shape
    ip = i + 1 if i + 1 < nx else 0
    jp = j + 1 if j + 1 < ny else 0
    kp = k + 1 if k + 1 < nz else 0
    nopen = 0
    diag = 0.0
    for q, up in ((f0[i, j, k], f0[ip, j, k]), (f1[i, j, k], f1[i, jp, k]),
                  (f2[i, j, k], f2[i, j, kp])):  # fmt: skip
        nopen += (q > 0) + (up > 0)
        diag += np.float64(q + up)  # float32 faces: summed in float32, as before
    return nopen, diag


@nb.njit(cache=True, nogil=True)
def _thin_mask(f0, f1, f2, cells, most, mask):
    """``mask`` of the thin cells: pressure cells (``cells != 0``) with 1 to ``most`` open
    faces (the ``w_f^2 / A_ff`` of each component ``f0, f1, f2``, face ``a`` of a cell at the
    cell and at its upper neighbour along ``a``).  One pass over the grid: the former
    ``np.roll`` copies and grid-sized temporaries (count, float64 diagonal) took about 1.5 s of
    the 6 s set-up at 400^3 (``benchmarks/RESULTS.md``, gap13)."""
    nx, ny, nz = f0.shape
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                n = _faces_at(f0, f1, f2, i, j, k)[0]
                mask[i, j, k] = (cells[i, j, k] != 0) and n >= 1 and n <= most


@nb.njit(cache=True, nogil=True)
def _junctions(f0, f1, f2, cells, mask, most, other, out):
    """``out`` of the pressure cells with more than ``most`` open faces of which at most
    ``other`` lead to a cell outside ``mask`` (the thin cells): the knots of thin branches
    (:data:`JUNCTION`).  One pass, row by row, without branches or integer divisions per cell
    (session 49: 2.3x less CPU at 200^3 than the former loop over the six faces with modulo
    neighbours); ``mask`` is read only, so the result does not depend on the order of the
    cells."""
    nx, ny, nz = f0.shape
    for i in range(nx):
        im, ip = _dn(i, nx), _up(i, nx)
        for j in range(ny):
            jm, jp = _dn(j, ny), _up(j, ny)
            u, uu, mu, muu = f0[i, j], f0[ip, j], mask[im, j], mask[ip, j]
            v, vu, mv, mvu = f1[i, j], f1[i, jp], mask[i, jm], mask[i, jp]
            w, mk, cr, row = f2[i, j], mask[i, j], cells[i, j], out[i, j]
            for k in range(nz):
                km, kp = _dn(k, nz), _up(k, nz)
                o = (u[k] > 0, uu[k] > 0, v[k] > 0, vu[k] > 0, w[k] > 0, w[kp] > 0)
                nopen = o[0] + o[1] + o[2] + o[3] + o[4] + o[5]
                wide = ((o[0] & (mu[k] == 0)) + (o[1] & (muu[k] == 0)) + (o[2] & (mv[k] == 0))
                        + (o[3] & (mvu[k] == 0)) + (o[4] & (mk[km] == 0))
                        + (o[5] & (mk[kp] == 0)))  # fmt: skip
                row[k] = (cr[k] != 0) & (mk[k] == 0) & (nopen > most) & (wide <= other)


@nb.njit(cache=True, nogil=True)
def _thin_diagonal(f0, f1, f2, flat):
    """The Schur diagonal (:func:`_faces_at`) of the cells ``flat`` (flat C indices)."""
    nx, ny, nz = f0.shape
    out = np.empty(flat.size)
    for t in range(flat.size):
        c = flat[t]
        i = c // (ny * nz)
        j = (c // nz) % ny
        out[t] = _faces_at(f0, f1, f2, i, j, c % nz)[1]
    return out


def _neighbour(flat: np.ndarray, shape: tuple[int, ...], a: int) -> np.ndarray:
    """Flat index of the lower neighbour along ``a`` (periodic) of each flat index."""
    idx = list(np.unravel_index(flat, shape))
    idx[a] = (idx[a] - 1) % shape[a]
    return np.ravel_multi_index(tuple(idx), shape)


def _pieces(labels: np.ndarray) -> np.ndarray:
    """Piece number of each thin cell (sorted by label): runs of at most :data:`PIECE` cells of
    one component."""
    order = np.argsort(labels, kind="stable")
    lab = labels[order]
    first = np.r_[0, np.flatnonzero(np.diff(lab)) + 1]
    rank = np.arange(lab.size) - np.repeat(first, np.diff(np.r_[first, lab.size]))
    new = (rank % PIECE == 0).astype(np.int64)
    piece = np.empty(lab.size, np.int64)
    piece[order] = np.cumsum(new) - 1
    return piece


GERSHGORIN_SLACK = 1e-9
"""A piece whose Gershgorin floor (:func:`_gershgorin_floor`) is at least ``low`` plus this has no
mode below ``low`` and skips its eigenvalues: the floor is a bound of the exact spectrum, and
``eigvalsh`` finds each eigenvalue of these small, unit-scaled blocks within about 1e-14, so it
too would put none below ``low`` (the same pieces corrected, the same bits)."""


def _gershgorin_floor(mats: np.ndarray) -> np.ndarray:
    """The lowest point of each symmetric matrix's Gershgorin discs, ``min_i (m_ii - sum_{j != i}
    |m_ij|)`` (a positive diagonal: ``2 m_ii - sum_j |m_ij|``), below which it has no
    eigenvalue."""
    return (2.0 * np.diagonal(mats, axis1=1, axis2=2) - np.abs(mats).sum(axis=2)).min(axis=1)


def _cleared(
    thin: np.ndarray,
    d: np.ndarray,
    inner: tuple[np.ndarray, np.ndarray, np.ndarray],
    owner: np.ndarray,
    dinv: np.ndarray,
    npieces: int,
) -> np.ndarray:
    """The pieces whose scaled block ``D^-1/2 L_P D^-1/2`` has its Gershgorin floor at least
    ``max(LOW, DEAD_END_LOW) +`` :data:`GERSHGORIN_SLACK`, from the faces ``inner = (r, c, v)``
    between their cells (thin-cell indices; ``d`` the cells' Schur diagonal, ``dinv`` the coded
    ``D^-1`` by grid cell): no mode below either ``low``, so :func:`_correction` would find none.
    Each face's ``|m_rc|`` is subtracted from both its cells, every face counted (two faces
    between one pair of cells, on an axis of two cells, are summed in the dense block too);
    ``inner`` holds no face from a cell to itself (an axis of one cell: :class:`ThinBlocks`)."""
    r, c, v = inner
    sc = np.sqrt(dinv[thin].astype(np.float64))
    off = v * sc[r] * sc[c]
    floor = d * sc * sc - np.bincount(r, off, thin.size) - np.bincount(c, off, thin.size)
    lowest = np.full(npieces, np.inf)
    mine = owner >= 0
    np.minimum.at(lowest, owner[mine], floor[mine])
    return lowest >= max(LOW, DEAD_END_LOW) + GERSHGORIN_SLACK


def _correction(mats: np.ndarray, dinv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``E_P`` of a batch of pieces (``mats``: their ``L_P``, ``dinv``: the coded ``D^-1`` of their
    cells): the modes of ``D^-1 L_P`` below :data:`LOW` (:data:`DEAD_END_LOW` on a piece with at
    most :data:`MOUTHS` mouth cells) mapped to 1, the others left to ``D``; and which pieces have
    such a mode."""
    if not np.isfinite(LOW):
        inv = np.linalg.inv(mats)
        inv[:, np.arange(mats.shape[1]), np.arange(mats.shape[1])] -= dinv
        return inv, np.ones(mats.shape[0], bool)
    # the cells with a face leaving the piece: row sum of L_P > 0 (faces inside cancel)
    mouths = (mats.sum(axis=2) > 1e-6 * np.diagonal(mats, axis1=1, axis2=2)).sum(axis=1)
    low = np.where(mouths <= MOUTHS, DEAD_END_LOW, LOW)
    s = np.sqrt(dinv.astype(np.float64))
    out = mats  # scaled in place, then overwritten by the correction: no second batch array
    out *= s[:, :, None] * s[:, None, :]
    # the eigenvalues of the pieces whose Gershgorin discs reach below their ``low`` only (the
    # bound of _cleared, with each piece's own low), the eigenvectors of the few with a low mode
    active = np.zeros(out.shape[0], bool)
    maybe = np.flatnonzero(_gershgorin_floor(out) < low + GERSHGORIN_SLACK)
    if maybe.size:
        active[maybe] = np.linalg.eigvalsh(out[maybe])[:, 0] < low[maybe]
    lam, vec = np.linalg.eigh(out[active])
    gain = np.where(lam < low[active, None], 1.0 / lam - 1.0, 0.0)
    out[~active] = 0.0
    out[active] = np.einsum("pik,pk,pjk->pij", vec, gain, vec) * (
        s[active, :, None] * s[active, None, :]
    )
    return out, active


class ThinBlocks:
    """The thin pieces' correction ``E_P`` of the pressure block: ``L_P^-1 - D_P^-1`` on the
    slow modes of ``D^-1 L_P`` only (module docstring).

    Parameters
    ----------
    faces : list of 3 np.ndarray
        ``w_f^2 / A_ff`` of each velocity component's faces (0 off the active faces; the face
        of component ``a`` at cell ``c`` lies between ``c - e_a`` and ``c``).
    cells : np.ndarray
        Pressure-cell mask (non-zero on the pressure unknowns).
    dinv : np.ndarray
        The pressure block's ``D^-1`` (float32 per cell).
    floor : float
        Lower bound of the Schur diagonal (:data:`solvers.voxel_stokes.SCHUR_FLOOR`).
    max_faces : int, optional
        Most open faces of a thin cell (default :data:`MAX_FACES`).
    """

    def __init__(
        self,
        faces: list[np.ndarray],
        cells: np.ndarray,
        dinv: np.ndarray,
        floor: float,
        max_faces: int | None = None,
    ) -> None:
        shape = cells.shape
        most = MAX_FACES if max_faces is None else int(max_faces)
        f0, f1, f2 = (np.ascontiguousarray(q) for q in faces)
        mask = np.empty(shape, np.bool_)
        _thin_mask(f0, f1, f2, np.ascontiguousarray(cells), most, mask)
        if JUNCTION >= 0:  # junctions of thin branches join their pieces (JUNCTION)
            junction = np.empty(shape, np.bool_)  # every cell written
            _junctions(f0, f1, f2, np.ascontiguousarray(cells), mask, most, JUNCTION, junction)
            mask |= junction
            del junction
        thin = np.flatnonzero(mask)
        del mask
        rows, cols, vals = [], [], []
        own = np.zeros(thin.size) if 1 in shape else None
        for a, q in enumerate((f0, f1, f2)):
            if shape[a] == 1:
                # the periodic face from a cell to itself: the operator has no pressure
                # difference across it nor a divergence term (p[c] - p[c], w[c] - w[c] in the
                # kernels), so it is no face of L = G^T diag(A)^-1 G: neither an inner face of a
                # piece (its -w overwrote L_P's diagonal: every piece of a 14 x 13 x 1 grid had a
                # negative one, session 49) nor in the operator's diagonal block (its two halves
                # counted in the Schur diagonal of _faces_at come off below)
                own += 2.0 * q.ravel()[thin].astype(np.float64)
                continue
            low = _neighbour(thin, shape, a)
            pos = np.searchsorted(thin, low)
            pos[pos == thin.size] = 0
            w = q.ravel()[thin]
            both = (thin[pos] == low) & (w > 0)
            rows.append(np.flatnonzero(both))
            cols.append(pos[both])
            vals.append(w[both])
        r, c, v = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
        diag = _thin_diagonal(f0, f1, f2, thin)
        if own is not None:
            diag -= own
        d = np.maximum(diag, floor)
        n = thin.size
        graph = coo_matrix((np.ones(r.size), (r, c)), shape=(n, n))
        ncomp, labels = connected_components(graph, directed=False)
        # an enclosed set of thin cells (no face leaving it) has a singular L_P: keep D there
        leaving = d - np.bincount(r, v, n) - np.bincount(c, v, n)
        opened = np.bincount(labels, leaving > 1e-6 * d, ncomp) > 0
        size = np.bincount(labels, None, ncomp)
        keep = opened[labels] & (size[labels] >= 2)
        self._build(thin, labels, keep, d, (r, c, v), dinv.ravel())

    def _build(
        self,
        thin: np.ndarray,
        labels: np.ndarray,
        keep: np.ndarray,
        d: np.ndarray,
        edges: tuple[np.ndarray, np.ndarray, np.ndarray],
        dinv: np.ndarray,
    ) -> None:
        """Cut the kept components into pieces, invert each piece's ``L_P`` (batched by size)
        and store ``E_P`` packed."""
        piece = np.full(thin.size, -1, np.int64)
        piece[keep] = _pieces(labels[keep])
        order = np.lexsort((thin, piece))[np.count_nonzero(~keep) :]
        npieces = int(piece.max()) + 1 if keep.any() else 0
        sizes = np.bincount(piece[order], None, npieces)
        keepers = np.flatnonzero(sizes >= 2)  # runs of one cell (a cut remainder) keep D
        local = np.full(thin.size, -1, np.int64)
        remap = np.full(npieces, -1, np.int64)
        remap[keepers] = np.arange(keepers.size)
        sel = order[remap[piece[order]] >= 0]
        new_piece = remap[piece[sel]]
        self.start = np.zeros(keepers.size + 1, np.int64)
        np.cumsum(sizes[keepers], out=self.start[1:])
        local[sel] = np.arange(sel.size) - self.start[new_piece]
        owner = np.full(thin.size, -1, np.int64)
        owner[sel] = new_piece
        self.cells = thin[sel]
        s = np.diff(self.start)
        self.width = int(s.max()) if s.size else 0
        self.fstart = np.zeros(keepers.size + 1, np.int64)
        np.cumsum(s * (s + 1) // 2, out=self.fstart[1:])
        self.packed = np.zeros(int(self.fstart[-1]), np.float32)
        r, c, v = edges
        inside = (owner[r] >= 0) & (owner[r] == owner[c])
        r, c, v = r[inside], c[inside], v[inside]
        # the pieces Gershgorin clears from their faces need no dense block (41 825 of 43 240 at
        # the Toray-like 200^3 staircase; 939 of the other 1 415 need eigenvalues); the faces of
        # the others and those pieces grouped by size, each group in its former order (stable
        # sorts: the same matrices), so each size's batch takes its slice (each of the 59
        # batches scanned every face before)
        dense = ~_cleared(thin, d, (r, c, v), owner, dinv, s.size)
        go = dense[owner[r]]
        r, c, v = r[go], c[go], v[go]  # each gathered once (r[go] was gathered twice)
        by = np.argsort(s[owner[r]], kind="stable")
        er, ec, ev = r[by], c[by], v[by]
        esize = s[owner[er]]
        bysize = np.flatnonzero(dense)[np.argsort(s[dense], kind="stable")]
        sizes, first = np.unique(s[bysize], return_index=True)
        bounds = np.r_[first, bysize.size]
        active = np.zeros(s.size, bool)
        with single_thread_blas():  # many small problems: BLAS threads only cost
            for size, lo, hi in zip(sizes, bounds[:-1], bounds[1:], strict=True):
                which = bysize[lo:hi]
                fa, fb = np.searchsorted(esize, [size, size + 1])
                faces = (er[fa:fb], ec[fa:fb], ev[fa:fb])
                active[which] = self._invert(int(size), which, sel, d, faces, local, owner, dinv)
        self._drop(~active)

    def _drop(self, idle: np.ndarray) -> None:
        """Remove the pieces ``idle`` (no slow mode: their correction is 0)."""
        if not idle.any():
            return
        s = np.diff(self.start)
        self.cells = self.cells[np.repeat(~idle, s)]
        self.packed = self.packed[np.repeat(~idle, s * (s + 1) // 2)]
        s = s[~idle]
        self.start = np.zeros(s.size + 1, np.int64)
        np.cumsum(s, out=self.start[1:])
        self.fstart = np.zeros(s.size + 1, np.int64)
        np.cumsum(s * (s + 1) // 2, out=self.fstart[1:])
        self.width = int(s.max()) if s.size else 0

    def _invert(
        self,
        size: int,
        which: np.ndarray,
        sel: np.ndarray,
        d: np.ndarray,
        edges: tuple[np.ndarray, np.ndarray, np.ndarray],
        local: np.ndarray,
        owner: np.ndarray,
        dinv: np.ndarray,
    ) -> np.ndarray:
        """``E_P`` of the pieces ``which`` (ascending), all of ``size`` cells, from the faces
        ``edges`` inside them, in one batched decomposition; returns which of them have a
        correction (a mode below :data:`LOW`)."""
        mats = np.zeros((which.size, size, size))
        members = sel[(self.start[which][:, None] + np.arange(size)).ravel()].reshape(-1, size)
        mats[:, np.arange(size), np.arange(size)] = d[members]
        r, c, v = edges  # the faces inside these pieces (``which`` ascending)
        k, i, j = np.searchsorted(which, owner[r]), local[r], local[c]
        # np.add.at: on an axis of two cells two faces join one pair, and the block holds both
        # (a plain assignment kept the last); with one face per pair 0.0 + (-v) is -v bitwise.
        np.add.at(mats, (k, i, j), -v)
        np.add.at(mats, (k, j, i), -v)
        inv, active = _correction(
            mats, dinv[self.cells[self.start[which][:, None] + np.arange(size)]]
        )
        li, lj = np.tril_indices(size)
        dest = self.fstart[which][:, None] + np.arange(li.size)
        self.packed[dest.ravel()] = inv[:, li, lj].ravel()
        return active

    @property
    def n_cells(self) -> int:
        """Thin cells in the kept pieces."""
        return int(self.cells.size)

    @property
    def nbytes(self) -> int:
        """Bytes of the stored pieces."""
        return int(self.cells.nbytes + self.start.nbytes + self.fstart.nbytes + self.packed.nbytes)

    def apply(self, r: np.ndarray, z: np.ndarray) -> float:
        """``z += E r`` on the pieces (``r, z`` pressure fields, C-contiguous); returns ``r . E
        r`` (float64), the change of the pressure block's ``r . z``."""
        if self.cells.size == 0:
            return 0.0
        return float(
            thin_apply(self.cells, self.start, self.fstart, self.packed, self.width,
                       r.reshape(-1), z.reshape(-1))
        )  # fmt: skip
