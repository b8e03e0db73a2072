"""Exact local pressure solves on the thin fluid cells (solvers.voxel.thin).

Independent truth: the Schur approximation ``L = G^T diag(A)^-1 G`` of each piece assembled here
cell by cell from the velocity diagonals of ``multigrid.component_operator`` (``L_cc`` the sum of
``1 / A_ff`` over the cell's open faces, ``L_cd = -1 / A_ff`` across a face inside the piece),
and dense linear algebra (numpy) on it.
"""

from __future__ import annotations

import numpy as np
import pytest

from solvers.voxel import multigrid as mg
from solvers.voxel import thin

FLOOR = 1e-4


def _tube_grid(length: int = 5) -> tuple[np.ndarray, list[tuple[int, int, int]]]:
    """Fluid: a slab three cells thick (y = 0..2, periodic in x and z; its cells have 5 or 6
    open faces) and a dead-end tube one voxel wide along +y from the slab at (4, 3.., 4)."""
    fluid = np.zeros((8, 12, 8), bool)
    fluid[:, 0:3, :] = True
    tube = [(4, 3 + t, 4) for t in range(length)]
    for c in tube:
        fluid[c] = True
    return fluid, tube


def _faces(fluid: np.ndarray) -> list[np.ndarray]:
    """``1 / A_ff`` of each component's faces (0 off the active faces)."""
    out = []
    for a in range(3):
        d = mg.component_operator(fluid, a)[0]
        out.append(np.divide(1.0, d, out=np.zeros(d.shape, np.float32), where=d > 0))
    return out


def _schur_piece(faces: list[np.ndarray], piece: list[tuple[int, int, int]]) -> np.ndarray:
    """Dense ``L_P`` of the cells ``piece``, cell by cell (face of component a at cell c lies
    between c - e_a and c)."""
    shape = faces[0].shape
    where = {c: i for i, c in enumerate(piece)}
    mat = np.zeros((len(piece), len(piece)))
    for i, c in enumerate(piece):
        for a in range(3):
            up = list(c)
            up[a] = (up[a] + 1) % shape[a]
            low = list(c)
            low[a] = (low[a] - 1) % shape[a]
            for face, other in ((c, tuple(low)), (tuple(up), tuple(up))):
                q = float(faces[a][face])
                if q == 0.0:
                    continue
                mat[i, i] += q
                if other in where:
                    mat[i, where[other]] -= q
    return mat


def _dinv(faces: list[np.ndarray]) -> np.ndarray:
    """``1 / (sum of the cell's face terms)``, floored: the pore-scale pressure block."""
    s2 = sum(q.astype(np.float64) + np.roll(q, -1, axis=a) for a, q in enumerate(faces))
    return (1.0 / np.maximum(s2, FLOOR)).astype(np.float32)


def _block(tb: thin.ThinBlocks, dinv: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, float]:
    """``B^-1 r`` and ``r . B^-1 r`` (the diagonal block plus the thin pieces' correction)."""
    z = (dinv * r).astype(np.float32)
    rz = float(np.dot(r.ravel().astype(np.float64), z.ravel()))
    rz += tb.apply(r, z)
    return z, rz


def test_the_dead_end_tube_is_one_piece_solved_exactly() -> None:
    fluid, tube = _tube_grid(5)
    faces = _faces(fluid)
    dinv = _dinv(faces)
    tb = thin.ThinBlocks(faces, fluid, dinv, FLOOR)
    flat = sorted(np.ravel_multi_index(tuple(np.array(tube).T), fluid.shape))
    assert tb.n_cells == 5 and np.array_equal(np.sort(tb.cells), flat)
    lp = _schur_piece(faces, tube)
    rng = np.random.default_rng(1)
    r = np.zeros(fluid.shape, np.float32)
    r[fluid] = rng.standard_normal(int(fluid.sum()))
    z, rz = _block(tb, dinv, r)
    rp = np.array([r[c] for c in tube], np.float64)
    np.testing.assert_allclose([z[c] for c in tube], np.linalg.solve(lp, rp), rtol=2e-5)
    off = fluid.copy()
    for c in tube:
        off[c] = False
    np.testing.assert_array_equal(z[off], (dinv * r)[off])  # D^-1 elsewhere
    assert rz == pytest.approx(float(np.dot(r.ravel(), z.ravel())), rel=1e-5)


def test_the_tubes_slow_mode_is_mapped_to_one() -> None:
    # D^-1 L_P on the tube has a small eigenvalue (the 1-D Laplacian's slowest mode behind the
    # dead end); with the piece's block the preconditioned local operator is the identity
    fluid, tube = _tube_grid(6)
    faces = _faces(fluid)
    dinv = _dinv(faces)
    tb = thin.ThinBlocks(faces, fluid, dinv, FLOOR)
    lp = _schur_piece(faces, tube)
    dp = np.diag(lp)
    theta, vecs = np.linalg.eigh(lp / np.sqrt(np.outer(dp, dp)))
    assert theta[0] < 0.1  # the slow mode the diagonal leaves
    for k in range(len(tube)):
        v = vecs[:, k] / np.sqrt(dp)  # eigenvector of D^-1 L_P with value theta_k
        r = np.zeros(fluid.shape, np.float32)
        for c, val in zip(tube, lp @ v, strict=True):
            r[c] = val
        z, _ = _block(tb, dinv, r)
        np.testing.assert_allclose([z[c] for c in tube], v, rtol=1e-4, atol=1e-5 * abs(v).max())


def test_an_enclosed_pocket_keeps_the_diagonal() -> None:
    fluid, _ = _tube_grid(3)
    fluid[1, 8:10, 1] = True  # two cells with no face to the rest: L_P singular
    faces = _faces(fluid)
    tb = thin.ThinBlocks(faces, fluid, _dinv(faces), FLOOR)
    pocket = np.ravel_multi_index(([1, 1], [8, 9], [1, 1]), fluid.shape)
    assert not np.isin(pocket, tb.cells).any() and tb.n_cells == 3


def test_a_long_thin_region_is_cut_into_pieces_and_stays_spd() -> None:
    # a slit one cell thick (4 open faces per cell) spanning a periodic plane: 64 x 4 cells of
    # one component, cut into runs of PIECE cells
    fluid = np.zeros((4, 6, 64), bool)
    fluid[:, 0:3, :] = True  # the thick channel
    fluid[:, 4, :] = True  # the slit (y = 3 and 5 solid)
    fluid[0, 3, ::8] = True  # eight one-cell throats from the slit to the channel
    faces = _faces(fluid)
    dinv = _dinv(faces)
    tb = thin.ThinBlocks(faces, fluid, dinv, FLOOR)
    sizes = np.diff(tb.start)
    assert sizes.max() <= thin.PIECE and tb.n_cells == 4 * 64 - 8  # the throats: single cells
    rng = np.random.default_rng(2)
    vecs = []
    for _ in range(2):
        r = np.zeros(fluid.shape, np.float32)
        r[fluid] = rng.standard_normal(int(fluid.sum()))
        vecs.append(r)
    za, ra = _block(tb, dinv, vecs[0])
    zb, _ = _block(tb, dinv, vecs[1])
    assert float(np.dot(vecs[1].ravel(), za.ravel())) == pytest.approx(
        float(np.dot(vecs[0].ravel(), zb.ravel())), rel=1e-4
    )
    assert ra > 0.0
    # each piece's block is its own L_P: B^-1 L_P = I on the first piece
    first = [np.unravel_index(c, fluid.shape) for c in tb.cells[tb.start[0] : tb.start[1]]]
    first = [tuple(int(i) for i in c) for c in first]
    lp = _schur_piece(faces, first)
    v = rng.standard_normal(len(first))
    r = np.zeros(fluid.shape, np.float32)
    for c, val in zip(first, lp @ v, strict=True):
        r[c] = val
    z, _ = _block(tb, dinv, r)
    np.testing.assert_allclose([z[c] for c in first], v, rtol=1e-3, atol=1e-4 * abs(v).max())


def test_the_thin_mask_and_diagonal_count_every_open_face() -> None:
    """The one-pass mask and Schur diagonal (``thin._thin_mask``, ``thin._thin_diagonal``)
    against their definition evaluated cell by cell on a random periodic grid (odd sides, so
    every wrap-around is exercised): a pressure cell is thin when 1 to 4 of its six faces (the
    faces of component ``a`` at the cell and at its upper neighbour along ``a``) are open, and
    its diagonal is the sum of those faces' ``1 / A_ff``."""
    rng = np.random.default_rng(3)
    fluid = rng.random((7, 9, 5)) < 0.6
    faces = _faces(fluid)
    cells = fluid.view(np.uint8)
    mask = np.empty(fluid.shape, bool)
    thin._thin_mask(*faces, cells, thin.MAX_FACES, mask)
    shape = fluid.shape
    want_mask = np.zeros(shape, bool)
    want_diag = np.zeros(shape)
    for c in np.ndindex(shape):
        qs = []
        for a in range(3):
            up = list(c)
            up[a] = (up[a] + 1) % shape[a]
            qs += [float(faces[a][c]), float(faces[a][tuple(up)])]
        nopen = sum(q > 0 for q in qs)
        want_mask[c] = bool(fluid[c]) and 1 <= nopen <= thin.MAX_FACES
        want_diag[c] = sum(qs)
    np.testing.assert_array_equal(mask, want_mask)
    assert 0 < mask.sum() < fluid.sum()  # both kinds of fluid cell occur
    flat = np.flatnonzero(mask)
    np.testing.assert_allclose(
        thin._thin_diagonal(*faces, flat), want_diag.ravel()[flat], rtol=1e-6
    )
