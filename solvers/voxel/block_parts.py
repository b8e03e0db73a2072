"""Split blocks of the coarse pressure term: a local Darcy correction per fluid part.

Why
---
The coarse Darcy term of the pressure preconditioner (:mod:`solvers.voxel.schur`) gives every
box block of ``BLOCK^3`` cells one pressure value.  A block that a fibre cuts into fluid parts
joined only outside the block (fluid on both sides of a fibre, or a one-cell pocket in a
corner) then forces one value on regions whose real pressures differ: such parts are the
pressure modes that neither the per-cell Schur diagonal nor the box blocks represent, and
they set the smallest eigenvalues of the preconditioned system, the ones that grow the
iteration count with the box (``benchmarks/RESULTS.md``, "Issue 16 item 4, iteration growth
(iter11)").  Measured on the Toray-like 100 um box at 1 um: a coarse space of the connected
fluid parts of each block (a general sparse Darcy operator, pyamg) lifted the smallest
negative Ritz value from 0.048 to 0.058-0.064 and cut the count 131 -> 122; a general sparse
coarse solve costs a V-cycle of 0.4 s per iteration at 400^3 (1 M parts), so this module keeps
the box term and adds, additively, the cheap diagonal part of that coarse space.

What
----
A third additive term of the pressure block (two-level additive Schwarz with a one-level
correction on a few local subspaces)::

    M_p^-1 = D^-1 + WEIGHT R^T S_c^+ R + P^T T^-1 P

* ``P`` sums the pressure residual over each fluid part of every *split* block (a block whose
  fluid cells, joined through the velocity unknowns inside the block, form more than one
  connected part); ``P^T`` injects a part value into its cells.  Toray-like at 1 um, 4^3
  blocks: 1.2 % of the blocks, 0.2 % of the fluid cells (100 um: 188 split blocks of 15 625,
  401 parts, 1 808 of 797 610 fluid cells; 200 um: 1 406 blocks, 2 982 parts, 12 136 cells).
* ``T`` is diagonal: the Darcy transmissibility of the part to the neighbouring blocks, the
  sum over its open faces on the block boundary of the box term's interface transmissibility
  shared equally among the interface's open faces (``K_f A / l / n_open``).  A part with no
  open face out of its block gets no correction.

The term is symmetric positive semi-definite, so ``M_p`` stays SPD (SYMMLQ / MINRES).  It is
off by default (:data:`solvers.voxel.schur.SPLIT_PARTS`): with the coarse weight 0.6 and the
first-cycle floor 1e-5 it took the 100 / 200 / 300 um boxes from 131 / 150 / 187 to 129 / 150
/ 194 iterations; added to the box term on the largest part of a block too, it over-corrects
there (the far end of the negative spectrum at 300 um: -1.37 -> -1.66).  Restricting it to the
smaller parts (126 instead of 124 at 100 um with the floor 1e-4) was not measured at 300 um.  Cost:
a gather and a scatter over the split blocks' cells per iteration; memory: 12 bytes per such
cell (index and part) and 16 per part.
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["SplitParts", "split_block_cells"]

_OPTS = {"cache": True, "nogil": True}


@nb.njit(**_OPTS)
def _label_block(fluid, dx, dy, dz, lo, hi, lab, stack):
    """Connected parts of the pressure cells (``fluid != 0``), joined through the active
    velocity unknowns (``dx > 0`` etc.) between them, of the block ``lo <= (i, j, k) < hi``:
    ``lab`` (local, -1 off the fluid) gets the part numbers, the return value is the number
    of parts."""
    sx, sy, sz = hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]
    for a in range(sx):
        for b in range(sy):
            for c in range(sz):
                lab[a, b, c] = -2 if fluid[lo[0] + a, lo[1] + b, lo[2] + c] != 0 else -1
    parts = 0
    for a in range(sx):
        for b in range(sy):
            for c in range(sz):
                if lab[a, b, c] != -2:
                    continue
                lab[a, b, c] = parts
                top = 0
                stack[0, 0], stack[0, 1], stack[0, 2] = a, b, c
                top = 1
                while top > 0:
                    top -= 1
                    p, q, s = stack[top, 0], stack[top, 1], stack[top, 2]
                    i, j, k = lo[0] + p, lo[1] + q, lo[2] + s
                    # the six neighbours inside the block joined by an active velocity unknown
                    for e in range(6):
                        pp, qq, ss, ok = p, q, s, False
                        if e == 0 and p + 1 < sx:
                            pp, ok = p + 1, dx[i + 1, j, k] > 0
                        elif e == 1 and p > 0:
                            pp, ok = p - 1, dx[i, j, k] > 0
                        elif e == 2 and q + 1 < sy:
                            qq, ok = q + 1, dy[i, j + 1, k] > 0
                        elif e == 3 and q > 0:
                            qq, ok = q - 1, dy[i, j, k] > 0
                        elif e == 4 and s + 1 < sz:
                            ss, ok = s + 1, dz[i, j, k + 1] > 0
                        elif e == 5 and s > 0:
                            ss, ok = s - 1, dz[i, j, k] > 0
                        if ok and lab[pp, qq, ss] == -2:
                            lab[pp, qq, ss] = parts
                            stack[top, 0], stack[top, 1], stack[top, 2] = pp, qq, ss
                            top += 1
                parts += 1
    return parts


@nb.njit(**_OPTS)
def _block_lo_hi(ic, f, nc, n):
    lo = ic * f
    return lo, (n if ic == nc - 1 else lo + f)


@nb.njit(**_OPTS)
def _split_cells(fluid, dx, dy, dz, fx, fy, fz, cells, part):
    """Walk all blocks; for every block with more than one fluid part write its fluid cells'
    flat indices and global part numbers into ``cells, part`` (if they are long enough) and
    return ``(number of cells, number of parts)``."""
    nx, ny, nz = dx.shape
    f = (fx, fy, fz)
    nc = (max(nx // fx, 1), max(ny // fy, 1), max(nz // fz, 1))
    big = (2 * fx, 2 * fy, 2 * fz)
    lab = np.empty(big, np.int32)
    stack = np.empty((big[0] * big[1] * big[2], 3), np.int64)
    lo = np.empty(3, np.int64)
    hi = np.empty(3, np.int64)
    ncell = 0
    npart = 0
    for ic in range(nc[0]):
        lo[0], hi[0] = _block_lo_hi(ic, f[0], nc[0], nx)
        for jc in range(nc[1]):
            lo[1], hi[1] = _block_lo_hi(jc, f[1], nc[1], ny)
            for kc in range(nc[2]):
                lo[2], hi[2] = _block_lo_hi(kc, f[2], nc[2], nz)
                parts = _label_block(fluid, dx, dy, dz, lo, hi, lab, stack)
                if parts < 2:
                    continue
                for a in range(hi[0] - lo[0]):
                    for b in range(hi[1] - lo[1]):
                        for c in range(hi[2] - lo[2]):
                            lv = lab[a, b, c]
                            if lv < 0:
                                continue
                            if ncell < cells.size:
                                cells[ncell] = ((lo[0] + a) * ny + lo[1] + b) * nz + lo[2] + c
                                part[ncell] = npart + lv
                            ncell += 1
                npart += parts
    return ncell, npart


def split_block_cells(
    fluid: np.ndarray, diags: list[np.ndarray], f: tuple[int, int, int]
) -> tuple[np.ndarray, np.ndarray, int]:
    """Fluid cells of the split blocks and their parts.

    Parameters
    ----------
    fluid : np.ndarray, shape (nx, ny, nz)
        Pressure cells (``!= 0``).
    diags : list of 3 np.ndarray
        Diagonals of the velocity operators (``> 0`` on the active velocity unknowns; the
        unknown ``[i, j, k]`` of component ``a`` sits on the face between cell ``i - e_a`` and
        cell ``i``).
    f : tuple of 3 int
        Cells per axis of a block (the last block of an axis takes the remainder).

    Returns
    -------
    cells : np.ndarray of int64
        Flat (C order) indices of the fluid cells of every block with two or more parts.
    part : np.ndarray of int64
        Part number of each of those cells, ``0 .. n_parts - 1``.
    n_parts : int
        Number of parts.
    """
    empty = np.zeros(0, np.int64)
    n, _ = _split_cells(fluid, *diags, *f, empty, empty)
    cells, part = np.empty(n, np.int64), np.empty(n, np.int64)
    _, n_parts = _split_cells(fluid, *diags, *f, cells, part)
    return cells, part, int(n_parts)


@nb.njit(**_OPTS)
def _part_transmissibility(cells, part, dx, dy, dz, fx, fy, fz, tx, ty, tz, out):
    """``out[p] +=`` the per-face transmissibility ``t[a][upper block]`` of every open face of
    a part's cells on its block's boundary (``t`` already divided by the interface's open
    faces)."""
    nx, ny, nz = dx.shape
    shp = (nx, ny, nz)
    f = (fx, fy, fz)
    nc = (tx.shape[0], tx.shape[1], tx.shape[2])
    for m in range(cells.size):
        c = cells[m]
        idx = (c // (ny * nz), (c // nz) % ny, c % nz)
        blk = (
            min(idx[0] // fx, nc[0] - 1),
            min(idx[1] // fy, nc[1] - 1),
            min(idx[2] // fz, nc[2] - 1),
        )
        acc = 0.0
        for a in range(3):
            if nc[a] == 1:
                continue
            d = dx if a == 0 else (dy if a == 1 else dz)
            t = tx if a == 0 else (ty if a == 1 else tz)
            i = idx[a]
            # lower face: the unknown at the cell itself, a boundary when i starts a block
            if i % f[a] == 0 and i // f[a] < nc[a]:
                if d[idx[0], idx[1], idx[2]] > 0:
                    acc += t[blk[0], blk[1], blk[2]]
            # upper face: the unknown at i + 1 (periodic), a boundary when i + 1 starts a block
            up = (i + 1) % shp[a]
            if up % f[a] == 0 and up // f[a] < nc[a]:
                q = [idx[0], idx[1], idx[2]]
                q[a] = up
                if d[q[0], q[1], q[2]] > 0:
                    ub = [blk[0], blk[1], blk[2]]
                    ub[a] = up // f[a]
                    acc += t[ub[0], ub[1], ub[2]]
        out[part[m]] += acc


class SplitParts:
    """The split blocks' term ``P^T T^-1 P`` of the pressure block (module docstring).

    Parameters
    ----------
    fluid : np.ndarray, shape (nx, ny, nz)
        Pressure cells (``!= 0``).
    diags : list of 3 np.ndarray
        Diagonals of the velocity operators (``> 0`` on the active velocity unknowns).
    f : tuple of 3 int
        Cells per axis of a block.
    face_trans : list of 3 np.ndarray
        Per axis, on the blocks: the box term's transmissibility between block ``I - e_a`` and
        ``I`` divided by the number of open faces of that interface.
    """

    def __init__(
        self,
        fluid: np.ndarray,
        diags: list[np.ndarray],
        f: tuple[int, int, int],
        face_trans: list[np.ndarray],
    ) -> None:
        self.cells, self.part, self.n_parts = split_block_cells(fluid, diags, f)
        trans = np.zeros(self.n_parts)
        _part_transmissibility(self.cells, self.part, *diags, *f, *face_trans, trans)
        self.inverse = np.divide(1.0, trans, out=np.zeros_like(trans), where=trans > 0)

    def apply(self, r: np.ndarray, z: np.ndarray) -> float:
        """``z += P^T T^-1 P r`` on the pressure field (flat views of C-contiguous ``r, z``);
        returns the added ``r . z`` part, ``(P r) . T^-1 (P r)`` (float64)."""
        if self.n_parts == 0:
            return 0.0
        rf, zf = r.reshape(-1), z.reshape(-1)
        pr = np.bincount(self.part, rf[self.cells].astype(np.float64), self.n_parts)
        x = pr * self.inverse
        zf[self.cells] += x[self.part].astype(np.float32)
        return float(np.dot(pr, x))

    @property
    def nbytes(self) -> int:
        """Bytes held: the cell indices, their parts and the inverse transmissibilities."""
        return self.cells.nbytes + self.part.nbytes + self.inverse.nbytes
