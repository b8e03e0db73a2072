"""Thin pieces on a voxel grid with an axis of one cell (solvers.voxel.thin).

On such a grid the periodic face along that axis joins a cell to itself: the operator has no
pressure difference across it and no divergence term (``p[c] - p[c]``, ``w[c] - w[c]`` in
``kernels.stokes_residual``), so it is no face of ``L = G^T diag(A)^-1 G``.  Until session 49
:class:`~solvers.voxel.thin.ThinBlocks` took it for a face inside the piece and wrote its
``-w`` over ``L_P``'s diagonal: every piece of a 14 x 13 x 1 grid had a negative diagonal, the
pressure block went indefinite and the solves broke down (``psdesign.permeability`` on
one-voxel-thick RVEs: 8 of 8 not converged, residual 0.5 to 1e6).

Independent truth: ``L_P`` assembled cell by cell (``test_voxel_thin._schur_piece``: a face's
two cells, each side counted, so a face from a cell to itself cancels) and dense linear algebra
on it; plane Poiseuille flow in closed form.
"""

from __future__ import annotations

import numpy as np
import pytest
import test_voxel_thin as tvt

from solvers.voxel import thin
from solvers.voxel_stokes import solve_voxel_stokes

# the grids of benchmarks/RESULTS.md, "Session 49: ... (helper s49-setup)": 9 of 9 and 12 of 12
# pieces had a negative diagonal in their dense L_P; on an axis of two cells two faces join one
# pair and the dense block kept the last (4 of 9 and 7 of 18 pieces off by up to 0.61)
_SHAPES = [(14, 13, 1), (20, 20, 1), (1, 16, 15), (14, 13, 2), (2, 16, 15)]


def _random(shape: tuple[int, int, int]) -> np.ndarray:
    """The s49-setup grids: 65 % fluid, seeded by the shape."""
    return np.random.default_rng(sum(shape)).random(shape) > 0.35


def _pieces(tb: thin.ThinBlocks, shape: tuple[int, ...]) -> list[list[tuple[int, ...]]]:
    """The cells of each stored piece, as grid indices."""
    out = []
    for p in range(tb.start.size - 1):
        cells = tb.cells[tb.start[p] : tb.start[p + 1]]
        out.append([tuple(int(i) for i in np.unravel_index(c, shape)) for c in cells])
    return out


def _unpacked(tb: thin.ThinBlocks, p: int) -> np.ndarray:
    """The symmetric ``E_P`` of piece ``p`` from its packed lower triangle."""
    s = int(tb.start[p + 1] - tb.start[p])
    li, lj = np.tril_indices(s)
    e = np.zeros((s, s))
    e[li, lj] = tb.packed[tb.fstart[p] : tb.fstart[p + 1]]
    e[lj, li] = e[li, lj]
    return e


@pytest.mark.parametrize("shape", _SHAPES)
def test_the_pieces_are_the_operators_blocks(
    shape: tuple[int, int, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    # every mode corrected (LOW = inf): D_P^-1 + E_P is L_P^-1, L_P the operator's block
    monkeypatch.setattr(thin, "LOW", np.inf)
    fluid = _random(shape)
    faces = tvt._faces(fluid)
    dinv = tvt._dinv(faces)
    tb = tvt._blocks(faces, fluid, dinv, tvt.FLOOR)
    pieces = _pieces(tb, shape)
    assert len(pieces) >= 5
    for p, piece in enumerate(pieces):
        lp = tvt._schur_piece(faces, piece)
        assert np.all(np.diag(lp) > 0)
        block = _unpacked(tb, p) + np.diag([float(dinv[c]) for c in piece])
        np.testing.assert_allclose(block @ lp, np.eye(len(piece)), atol=2e-5)


@pytest.mark.parametrize("shape", _SHAPES)
def test_the_pressure_blocks_stay_positive_definite(shape: tuple[int, int, int]) -> None:
    # the rule's own blocks (slow modes only): D_P^-1 + E_P SPD on every piece, as on a 3-D grid
    fluid = _random(shape)
    faces = tvt._faces(fluid)
    dinv = tvt._dinv(faces)
    tb = tvt._blocks(faces, fluid, dinv, tvt.FLOOR)
    for p, piece in enumerate(_pieces(tb, shape)):
        block = _unpacked(tb, p) + np.diag([float(dinv[c]) for c in piece])
        assert np.linalg.eigvalsh(block)[0] > 0, (shape, p)


def _slot_and_pocket(nz: int) -> tuple[np.ndarray, int]:
    """Solid with fluid: a slot of ``h`` = 4 cells along x (plates y = 0 and y = 5..19), and
    apart from it a closed pocket (x 4..19, y 7..11) with five dead-end slits one cell wide
    (y 12..15): the slits are thin pieces whose mouths open into the pocket."""
    solid = np.ones((24, 20, nz), bool)
    h = 4
    solid[:, 1 : 1 + h, :] = False
    solid[4:20, 7:12, :] = False
    solid[5:19:3, 12:16, :] = False
    return solid, h


def test_plane_poiseuille_flow_on_a_grid_one_cell_thick() -> None:
    # plane Poiseuille flow (e.g. F. M. White, Viscous Fluid Flow, 3rd ed., 2006, Sec. 3-3.2):
    # u = G y (h - y) / (2 mu), mean G h^2 / (12 mu).  The staircase MAC grid (wall half a cell
    # beyond the last velocity node, ghost -u) is exact for the parabola shifted by G dx^2 /
    # (8 mu): cell-mean G (h^2 / 12 + dx^2 / 6) / mu, the formula of test_voxel_schur's channels.
    # No flow through the closed pocket: the superficial K = (h / ny) (h^2 / 12 + 1 / 6) dx^2.
    # The pocket's pressure (the body force balanced by p = g x) goes through its slits' thin
    # blocks: with the self-face on L_P's diagonal the solve broke down after 7 iterations
    # (K +17 %, residual 2.2, not converged); now 54 iterations (78 with the self-face's 2 w
    # kept on the diagonal; two cells thick 97 while its block kept one of the two faces per
    # pair, 68 with both).
    solid, h = _slot_and_pocket(1)
    res = solve_voxel_stokes(solid, 1.0, "x", tol=1e-8, max_iter=400)
    want = h / solid.shape[1] * (h**2 / 12 + 1 / 6)
    assert res.converged
    assert res.mean_velocity[0] == pytest.approx(want, rel=1e-6)
    # the same flow two cells thick (no axis of one cell): the same K
    two = solve_voxel_stokes(_slot_and_pocket(2)[0], 1.0, "x", tol=1e-8, max_iter=400)
    assert two.mean_velocity[0] == pytest.approx(want, rel=1e-6)
    assert two.iterations <= 80  # 97 with one of the two faces per pair in the blocks


def test_the_pocket_slits_are_thin_pieces() -> None:
    # the Poiseuille test exercises the thin blocks: the slits' cells are in kept pieces
    solid, _ = _slot_and_pocket(1)
    fluid = ~solid
    faces = tvt._faces(fluid)
    tb = tvt._blocks(faces, fluid, tvt._dinv(faces), tvt.FLOOR)
    slits = {(x, y, 0) for x in range(5, 19, 3) for y in range(12, 16)}
    kept = {c for piece in _pieces(tb, solid.shape) for c in piece}
    assert slits & kept
