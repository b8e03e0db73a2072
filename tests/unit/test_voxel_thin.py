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


def _blocks(faces: list[np.ndarray], fluid: np.ndarray, dinv: np.ndarray, floor: float):
    """:class:`solvers.voxel.thin.ThinBlocks` of the bool ``fluid`` given as the solver gives it,
    its uint8 view (``voxel_stokes._Stokes.fluid``): a bool mask compiled the mask kernels for a
    type no solve passes (benchmarks/RESULTS.md, session 40)."""
    return thin.ThinBlocks(faces, fluid.view(np.uint8), dinv, floor)


def _dinv(faces: list[np.ndarray]) -> np.ndarray:
    """``1 / (sum of the cell's face terms)``, floored: the pore-scale pressure block."""
    s2 = sum(q.astype(np.float64) + np.roll(q, -1, axis=a) for a, q in enumerate(faces))
    return (1.0 / np.maximum(s2, FLOOR)).astype(np.float32)


def _kept(faces: list[np.ndarray], fluid: np.ndarray, every: thin.ThinBlocks) -> list[np.ndarray]:
    """The pieces of ``every`` (all pieces, ``LOW = inf``) that the rule keeps, from the dense
    ``L_P`` cell by cell: a mode of ``D^-1 L_P`` below ``LOW``, or below ``DEAD_END_LOW`` with at
    most ``MOUTHS`` cells whose row of ``L_P`` does not sum to 0 (a face leaving the piece)."""
    kept = []
    for p in range(every.start.size - 1):
        cells = every.cells[every.start[p] : every.start[p + 1]]
        piece = [tuple(int(i) for i in np.unravel_index(c, fluid.shape)) for c in cells]
        lp = _schur_piece(faces, piece)
        dp = np.diag(lp)
        theta = np.linalg.eigvalsh(lp / np.sqrt(np.outer(dp, dp)))[0]
        mouths = int((lp.sum(axis=1) > 1e-6 * dp).sum())
        low = thin.DEAD_END_LOW if mouths <= thin.MOUTHS else thin.LOW
        if theta < low:
            kept.append(cells)
    return kept


def _block(tb: thin.ThinBlocks, dinv: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, float]:
    """``B^-1 r`` and ``r . B^-1 r`` (the diagonal block plus the thin pieces' correction)."""
    z = (dinv * r).astype(np.float32)
    rz = float(np.dot(r.ravel().astype(np.float64), z.ravel()))
    rz += tb.apply(r, z)
    return z, rz


def test_the_dead_end_tube_is_one_piece_solved_exactly(monkeypatch: pytest.MonkeyPatch) -> None:
    # with every mode corrected (LOW = inf) the piece's block is L_P itself
    monkeypatch.setattr(thin, "LOW", np.inf)
    fluid, tube = _tube_grid(5)
    faces = _faces(fluid)
    dinv = _dinv(faces)
    tb = _blocks(faces, fluid, dinv, FLOOR)
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


def test_the_tubes_slow_mode_is_mapped_to_one_and_the_others_keep_d() -> None:
    # D^-1 L_P on the tube has a small eigenvalue (the 1-D Laplacian's slowest mode behind the
    # dead end): the piece's block maps it to 1; its modes at or above DEAD_END_LOW (the tube
    # opens through one cell) keep D (eigenvalue theta_k of D^-1 L_P), which the whole L_P^-1
    # (the former rule) would map to 1 too
    fluid, tube = _tube_grid(6)
    faces = _faces(fluid)
    dinv = _dinv(faces)
    tb = _blocks(faces, fluid, dinv, FLOOR)
    lp = _schur_piece(faces, tube)
    dp = np.diag(lp)
    theta, vecs = np.linalg.eigh(lp / np.sqrt(np.outer(dp, dp)))
    assert theta[0] < 0.1  # the slow mode the diagonal leaves
    assert (lp.sum(axis=1) > 1e-6 * dp).sum() == 1 <= thin.MOUTHS  # a dead end
    low = thin.DEAD_END_LOW
    assert 0 < (theta < low).sum() < len(tube)  # some modes corrected, the others not
    for k in range(len(tube)):
        v = vecs[:, k] / np.sqrt(dp)  # eigenvector of D^-1 L_P with value theta_k
        r = np.zeros(fluid.shape, np.float32)
        for c, val in zip(tube, lp @ v, strict=True):
            r[c] = val
        z, _ = _block(tb, dinv, r)
        want = v if theta[k] < low else theta[k] * v
        np.testing.assert_allclose([z[c] for c in tube], want, rtol=1e-4, atol=1e-5 * abs(v).max())


def test_a_short_dead_end_keeps_its_slow_mode(monkeypatch: pytest.MonkeyPatch) -> None:
    # a tube of 2 cells behind one mouth cell: its slow mode (0.39) is above LOW but below
    # DEAD_END_LOW, so it is corrected as a dead end's; without the dead-end rule (MOUTHS = 0)
    # the piece would keep D
    fluid, tube = _tube_grid(2)
    faces = _faces(fluid)
    dinv = _dinv(faces)
    lp = _schur_piece(faces, tube)
    dp = np.diag(lp)
    theta, vecs = np.linalg.eigh(lp / np.sqrt(np.outer(dp, dp)))
    assert thin.LOW <= theta[0] < thin.DEAD_END_LOW and (lp.sum(axis=1) > 1e-6 * dp).sum() == 1
    tb = _blocks(faces, fluid, dinv, FLOOR)
    assert tb.n_cells == 2
    v = vecs[:, 0] / np.sqrt(dp)
    r = np.zeros(fluid.shape, np.float32)
    for c, val in zip(tube, lp @ v, strict=True):
        r[c] = val
    z, _ = _block(tb, dinv, r)
    np.testing.assert_allclose([z[c] for c in tube], v, rtol=1e-4, atol=1e-5 * abs(v).max())
    monkeypatch.setattr(thin, "MOUTHS", 0)
    assert _blocks(faces, fluid, dinv, FLOOR).n_cells == 0


def test_the_kept_pieces_of_a_random_pore_space(monkeypatch: pytest.MonkeyPatch) -> None:
    # a random 12^3 pore space (65 % fluid): pieces of every kind, among them dead ends and
    # pieces with many mouths whose slowest mode lies between LOW and DEAD_END_LOW
    fluid = np.random.default_rng(5).random((12, 12, 12)) > 0.35
    faces = _faces(fluid)
    dinv = _dinv(faces)
    with monkeypatch.context() as m:
        m.setattr(thin, "LOW", np.inf)
        every = _blocks(faces, fluid, dinv, FLOOR)
    kept = _kept(faces, fluid, every)
    assert 0 < len(kept) < every.start.size - 1
    tb = _blocks(faces, fluid, dinv, FLOOR)
    np.testing.assert_array_equal(np.sort(tb.cells), np.sort(np.concatenate(kept)))


def _corner_channel(nz: int = 6) -> tuple[np.ndarray, list[list[tuple[int, int, int]]]]:
    """Fluid: a square channel along z (x, y = 2..7 of a periodic 8 x 8 plane, the rest solid)
    and its four corner columns (4 open faces each: two along z, two into the channel), the
    thin pieces of a staircase wall's concave corners."""
    fluid = np.zeros((8, 8, nz), bool)
    fluid[2:, 2:, :] = True
    corners = [[(x, y, z) for z in range(nz)] for x in (2, 7) for y in (2, 7)]
    return fluid, corners


def test_a_wall_corner_column_keeps_the_diagonal(monkeypatch: pytest.MonkeyPatch) -> None:
    # Periodic column of identical cells, two faces leaving each (w_x + w_y) and two along z
    # (w_z): D^-1 L_P has the eigenvalues 1 - 2 w_z cos(2 pi k / n) / D, the smallest
    # (w_x + w_y) / D = 0.5 for equal weights (closed form). Its Dirichlet mouth is half of
    # each cell: the exact local solve over-corrects (the cylinder arrays' extra iterations,
    # benchmarks/RESULTS.md "Thin pieces on array grids (thin13)"), so no mode is below LOW
    fluid, corners = _corner_channel()
    faces = _faces(fluid)
    dinv = _dinv(faces)
    for column in corners:
        lp = _schur_piece(faces, column)
        dp = np.diag(lp)
        wz = -lp[0, 1]
        n = len(column)
        want = 1.0 - 2.0 * wz * np.cos(2 * np.pi * np.arange(n) / n) / dp[0]
        theta = np.linalg.eigvalsh(lp / np.sqrt(np.outer(dp, dp)))
        np.testing.assert_allclose(theta, np.sort(want), rtol=1e-6)
        assert 0.4 < theta[0] < 0.6 and theta[0] > thin.LOW
    tb = _blocks(faces, fluid, dinv, FLOOR)
    assert tb.n_cells == 0 and tb.nbytes < 100  # every corner column keeps D
    r = np.zeros(fluid.shape, np.float32)
    r[fluid] = np.random.default_rng(3).standard_normal(int(fluid.sum()))
    z, _ = _block(tb, dinv, r)
    np.testing.assert_array_equal(z, dinv * r)
    monkeypatch.setattr(thin, "LOW", np.inf)  # the former rule: the four columns, exactly
    assert _blocks(faces, fluid, dinv, FLOOR).n_cells == 4 * fluid.shape[2]


def test_an_enclosed_pocket_keeps_the_diagonal() -> None:
    fluid, _ = _tube_grid(3)
    fluid[1, 8:10, 1] = True  # two cells with no face to the rest: L_P singular
    faces = _faces(fluid)
    tb = _blocks(faces, fluid, _dinv(faces), FLOOR)
    pocket = np.ravel_multi_index(([1, 1], [8, 9], [1, 1]), fluid.shape)
    assert not np.isin(pocket, tb.cells).any() and tb.n_cells == 3


@pytest.mark.parametrize("low", [None, np.inf])
def test_a_long_thin_region_is_cut_into_pieces_and_stays_spd(
    low: float | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a slit one cell thick (4 open faces per cell) spanning a periodic plane: 64 x 4 cells of
    # one component, cut into runs of PIECE cells.  Without the knots of thin.JUNCTION: the 8
    # slit cells at a throat have 5 open faces, all into thin cells, and would join the slit to
    # its throats (264 cells, no piece with a mode below LOW); the knots have their own test
    monkeypatch.setattr(thin, "JUNCTION", -1)
    fluid = np.zeros((4, 6, 64), bool)
    fluid[:, 0:3, :] = True  # the thick channel
    fluid[:, 4, :] = True  # the slit (y = 3 and 5 solid)
    fluid[0, 3, ::8] = True  # eight one-cell throats from the slit to the channel
    faces = _faces(fluid)
    dinv = _dinv(faces)
    with monkeypatch.context() as m:
        m.setattr(thin, "LOW", np.inf)
        every = _blocks(faces, fluid, dinv, FLOOR)  # every piece, the former rule
    sizes = np.diff(every.start)
    assert sizes.max() <= thin.PIECE and every.n_cells == 4 * 64 - 8  # the throats: single cells
    if low is not None:
        monkeypatch.setattr(thin, "LOW", low)
    tb = _blocks(faces, fluid, dinv, FLOOR)
    # kept: exactly the pieces the rule keeps on the dense L_P (cell by cell)
    kept = _kept(faces, fluid, every)
    assert 0 < len(kept) < sizes.size or low == np.inf
    np.testing.assert_array_equal(np.sort(tb.cells), np.sort(np.concatenate(kept)))
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
    # on the first piece B^-1 L_P maps the modes of D^-1 L_P below LOW to 1 and keeps the
    # others (theta_k); LOW = inf: B^-1 L_P = I, the piece's block is its own L_P
    first = [np.unravel_index(c, fluid.shape) for c in tb.cells[tb.start[0] : tb.start[1]]]
    first = [tuple(int(i) for i in c) for c in first]
    lp = _schur_piece(faces, first)
    dp = np.diag(lp)
    theta, vecs = np.linalg.eigh(lp / np.sqrt(np.outer(dp, dp)))
    assert theta[0] < thin.LOW
    for k in range(len(first)):
        v = vecs[:, k] / np.sqrt(dp)
        r = np.zeros(fluid.shape, np.float32)
        for c, val in zip(first, lp @ v, strict=True):
            r[c] = val
        z, _ = _block(tb, dinv, r)
        want = v if theta[k] < thin.LOW else theta[k] * v
        np.testing.assert_allclose([z[c] for c in first], want, atol=2e-3 * abs(v).max())


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


def _knot_grid(stem: int = 3, arm: int = 4) -> tuple[np.ndarray, list[tuple[int, int, int]]]:
    """Fluid: the slab of :func:`_tube_grid` (16 x 3 x 16 cells) and a dead-end tree of 1-voxel
    tubes: a stem of ``stem`` cells along +y to a knot cell, from which four arms of ``arm``
    cells run along +-x and +-z. The knot has 5 open faces, all into tube cells."""
    fluid = np.zeros((16, 12, 16), bool)
    fluid[:, 0:3, :] = True
    yk = 3 + stem
    tree = [(8, 3 + t, 8) for t in range(stem)] + [(8, yk, 8)]
    for dx, dz in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        tree += [(8 + dx * t, yk, 8 + dz * t) for t in range(1, arm + 1)]
    for c in tree:
        fluid[c] = True
    return fluid, tree


@pytest.mark.parametrize("junction", [-1, 0])
def test_a_knot_of_thin_branches_joins_them_into_one_piece(
    monkeypatch: pytest.MonkeyPatch, junction: int
) -> None:
    # grow14 (thin.JUNCTION): the tree's slowest mode of D^-1 L_P (dense, Dirichlet at the
    # slab) is 0.0075; cut at the knot (its 5 open faces make it no thin cell: JUNCTION -1,
    # the former rule) the stem and the four arms are five pieces and the tree's smallest
    # eigenvalue of B^-1 L_tree stays at 0.020; with the knot thin the tree is one dead-end piece,
    # whose modes below DEAD_END_LOW go to 1 and the others keep theta >= DEAD_END_LOW
    monkeypatch.setattr(thin, "JUNCTION", junction)
    fluid, tree = _knot_grid()
    faces = _faces(fluid)
    dinv = _dinv(faces)
    tb = _blocks(faces, fluid, dinv, FLOOR)
    flat = np.array([np.ravel_multi_index(c, fluid.shape) for c in tree])
    knot = flat[3]
    lp = _schur_piece(faces, tree)
    dp = np.diag(lp)
    assert np.linalg.eigvalsh(lp / np.sqrt(np.outer(dp, dp)))[0] < 0.01
    binv = np.zeros((len(tree), len(tree)))
    for t, c in enumerate(tree):
        r = np.zeros(fluid.shape, np.float32)
        r[c] = 1.0
        z, _ = _block(tb, dinv, r)
        binv[:, t] = z.ravel()[flat]
    smallest = float(np.linalg.eigvals(binv @ lp).real.min())
    if junction < 0:
        assert knot not in tb.cells and tb.start.size - 1 == 5
        assert smallest < 0.05
    else:
        assert np.array_equal(np.sort(tb.cells), np.sort(flat)) and tb.start.size - 1 == 1
        assert smallest > thin.DEAD_END_LOW - 1e-4


def test_the_junction_pass_counts_the_open_faces_into_thin_cells() -> None:
    # thin._junctions against numpy rolls on random periodic grids (face of component a at
    # cell c between c - e_a and c): pressure cells outside the thin mask with more than
    # MAX_FACES open faces, at most `other` of them into cells outside the mask
    rng = np.random.default_rng(0)
    for t in range(14):  # axes of one and two cells too: the wrap-around selects (session 49)
        shape = tuple(int(n) for n in rng.integers(4 if t < 10 else 1, 9, 3))
        cells = rng.random(shape) < 0.6
        f = []
        for a in range(3):
            act = cells & np.roll(cells, 1, axis=a) & (rng.random(shape) < 0.8)
            f.append(np.where(act, rng.random(shape) + 0.1, 0.0).astype(np.float32))
        mask = np.empty(shape, bool)
        thin._thin_mask(*f, cells.astype(np.uint8), thin.MAX_FACES, mask)
        for other in (0, 1):
            out = np.ones(shape, bool)  # every cell written (the set-up passes np.empty)
            thin._junctions(*f, cells.astype(np.uint8), mask, thin.MAX_FACES, other, out)
            wide = np.zeros(shape, int)
            nopen = np.zeros(shape, int)
            for a, q in enumerate(f):
                lo = q > 0
                up = np.roll(lo, -1, axis=a)
                nopen += lo.astype(int) + up
                wide += (lo & ~np.roll(mask, 1, axis=a)).astype(int) + (
                    up & ~np.roll(mask, -1, axis=a)
                )
            want = cells & ~mask & (nopen > thin.MAX_FACES) & (wide <= other)
            assert np.array_equal(out, want)


def test_the_gershgorin_floor_bounds_the_spectrum_and_skips_only_clear_pieces(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Gershgorin's theorem (Golub & Van Loan, Matrix Computations, Thm 7.2.1): no eigenvalue of
    # a symmetric matrix lies below min_i (m_ii - sum_{j != i} |m_ij|); pieces with their floor
    # above LOW skip eigvalsh (session 49), the correction keeps every bit of the former one
    rng = np.random.default_rng(11)
    sym = rng.normal(size=(500, 6, 6))
    sym = sym + sym.transpose(0, 2, 1)
    assert np.all(np.linalg.eigvalsh(sym)[:, 0] >= thin._gershgorin_floor(sym) - 1e-12)
    # L_P-like blocks: a chain of cells, diagonal = inner faces + a leaving part per cell
    n, size = 400, 5
    w = rng.uniform(0.05, 0.25, (n, size - 1))
    leave = rng.uniform(0.0, 1.0, (n, size)) * (rng.random((n, size)) < 0.6)
    leave[:, 0] += 0.05  # a mouth on every piece: no singular (enclosed) block
    mats = np.zeros((n, size, size))
    idx = np.arange(size - 1)
    mats[:, idx, idx + 1] = mats[:, idx + 1, idx] = -w
    diag = leave.copy()
    diag[:, :-1] += w
    diag[:, 1:] += w
    mats[:, np.arange(size), np.arange(size)] = diag
    dinv = (1.0 / diag * rng.uniform(0.96, 1.04, (n, size))).astype(np.float32)
    batches = []
    eigvalsh = np.linalg.eigvalsh
    monkeypatch.setattr(np.linalg, "eigvalsh", lambda m: batches.append(len(m)) or eigvalsh(m))
    got, active = thin._correction(mats.copy(), dinv)
    # the former code: every piece's eigenvalues (no floor clears any)
    monkeypatch.setattr(thin, "_gershgorin_floor", lambda m: np.full(len(m), -np.inf))
    want, want_active = thin._correction(mats.copy(), dinv)
    assert batches == [batches[0], n] and 0 < batches[0] < n  # some skipped
    assert 0 < active.sum() < n and np.array_equal(active, want_active)
    assert got.tobytes() == want.tobytes()
    # and the documented rule: a mode of D^-1 L_P below LOW, DEAD_END_LOW with <= MOUTHS mouths
    s = np.sqrt(dinv.astype(np.float64))
    theta = eigvalsh(mats * (s[:, :, None] * s[:, None, :]))[:, 0]
    mouths = (leave > 0).sum(axis=1)
    assert np.array_equal(
        active, theta < np.where(mouths <= thin.MOUTHS, thin.DEAD_END_LOW, thin.LOW)
    )


def test_each_size_batch_gets_the_faces_of_its_own_pieces(monkeypatch: pytest.MonkeyPatch) -> None:
    # the faces inside the pieces are grouped by the pieces' size once (session 49; each
    # size's batch scanned every face before): each batch gets exactly its pieces' faces
    fluid = np.random.default_rng(5).random((12, 12, 12)) > 0.35
    faces = _faces(fluid)
    seen = []
    invert = thin.ThinBlocks._invert

    def spy(self, size, which, sel, d, edges, local, owner, dinv):
        seen.append((size, np.unique(owner[edges[0]]), which.copy()))
        return invert(self, size, which, sel, d, edges, local, owner, dinv)

    monkeypatch.setattr(thin, "LOW", np.inf)  # every piece kept, so `owner` is that of the pieces
    monkeypatch.setattr(thin.ThinBlocks, "_invert", spy)
    tb = _blocks(faces, fluid, _dinv(faces), FLOOR)
    assert len(seen) > 3 and sum(w.size for _, _, w in seen) == tb.start.size - 1
    for size, owners, which in seen:
        assert np.array_equal(owners, which)  # every piece of `size` cells is connected
        assert np.all(np.diff(tb.start)[which] == size)


def test_a_pore_space_without_thin_pieces_has_no_blocks() -> None:
    # a slab of fluid five cells thick (every cell 5 or 6 open faces): no thin cell, no piece,
    # nothing stored, and apply adds nothing (the size batches of an empty set)
    fluid = np.zeros((6, 9, 6), bool)
    fluid[:, 2:7, :] = True
    faces = _faces(fluid)
    tb = _blocks(faces, fluid, _dinv(faces), FLOOR)
    assert tb.n_cells == 0 and tb.start.size == 1
    z = np.zeros(fluid.shape, np.float32)
    assert tb.apply(np.ones(fluid.shape, np.float32), z) == 0.0 and not z.any()


@pytest.mark.parametrize("shape", [(12, 12, 12), (14, 13, 1), (12, 2, 12), (2, 11, 2)])
def test_pieces_cleared_from_their_faces_are_those_without_a_low_mode(
    shape, monkeypatch: pytest.MonkeyPatch
) -> None:
    # thin._cleared drops, before any dense block is formed, the pieces whose Gershgorin floor
    # (from the faces) is above both lows (session 49): the stored blocks are bit for bit those
    # of the dense path on every piece, on random pore spaces with axes of one cell (whose face
    # from a cell to itself is no face of a piece: test_voxel_thin_one_cell) and two (two
    # faces between one pair of cells) too
    fluid = np.random.default_rng(sum(shape)).random(shape) > 0.35
    faces = _faces(fluid)
    dinv = _dinv(faces)
    cleared = []
    real = thin._cleared
    monkeypatch.setattr(thin, "_cleared", lambda *a: cleared.append(real(*a)) or cleared[-1])
    tb = _blocks(faces, fluid, dinv, FLOOR)
    monkeypatch.setattr(thin, "_cleared", lambda *a: np.zeros(a[-1], bool))
    want = _blocks(faces, fluid, dinv, FLOOR)
    for name in ("cells", "start", "fstart", "packed"):
        assert getattr(tb, name).tobytes() == getattr(want, name).tobytes(), name
    if shape == (12, 12, 12):
        assert 0 < cleared[0].sum() < cleared[0].size and tb.n_cells > 0
