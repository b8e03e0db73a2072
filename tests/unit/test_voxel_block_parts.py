"""The split blocks' term of the voxel pressure preconditioner (solvers.voxel.block_parts): the
parts a solid wall cuts out of a block, their transmissibility counted face by face, and the
term's symmetry and energy ``(P r) . T^-1 (P r)``."""

from __future__ import annotations

import numpy as np
import pytest

import solvers.voxel_stokes as vs
from solvers.voxel import block_parts as bp
from solvers.voxel import schur


def _diags(fluid: np.ndarray) -> list[np.ndarray]:
    """Staircase MAC velocity unknowns: active on the face between two fluid cells (the unknown
    ``[i]`` of component ``a`` sits between cell ``i - e_a`` and ``i``, periodic)."""
    return [(fluid & np.roll(fluid, 1, axis=a)).astype(np.float32) for a in range(3)]


def _walls(n: int = 8, wall: int = 1) -> np.ndarray:
    """Fluid everywhere except the solid planes ``i % 4 == wall`` (normal to x)."""
    fluid = np.ones((n, n, n), dtype=bool)
    fluid[np.arange(n) % 4 == wall] = False
    return fluid


def test_a_wall_through_every_block_makes_two_parts_each() -> None:
    # 8^3 cells, 4^3 blocks; the solid plane i = 1 (and 5) splits every block into the slab
    # i = 0 (one cell thick) and the slab i = 2..3 (two cells)
    fluid = _walls()
    cells, part, n_parts = bp.split_block_cells(fluid, _diags(fluid), (4, 4, 4))
    assert n_parts == 2 * 8  # 8 blocks, 2 parts each
    assert cells.size == int(fluid.sum())  # every fluid cell lies in a split block
    idx = np.unravel_index(cells, fluid.shape)
    assert np.all(fluid[idx])
    sizes = np.bincount(part, minlength=n_parts)
    assert sorted(set(sizes.tolist())) == [16, 32]  # 1 x 4 x 4 and 2 x 4 x 4 cells
    # every part lies in one block and on one side of the wall
    for p in range(n_parts):
        i = idx[0][part == p]
        assert len({int(v) // 4 for v in i}) == 1
        assert len({int(v) % 4 == 0 for v in i}) == 1


def test_no_split_block_no_parts() -> None:
    # a wall on the block boundary (i % 4 == 0) leaves each block's fluid in one part
    fluid = _walls(wall=0)
    cells, part, n_parts = bp.split_block_cells(fluid, _diags(fluid), (4, 4, 4))
    assert n_parts == 0 and cells.size == 0 and part.size == 0


def test_part_transmissibility_counts_open_boundary_faces() -> None:
    # a unit per-face transmissibility: T of a part = its open faces on the block boundary.
    # Slab i = 0 (4 x 4 cells): x, its lower face (from i = 7, fluid: open; i = 0 starts a
    # block) 16, its upper face (to the wall) closed; y, the rows j = 0 and j = 3 cross: 4 + 4;
    # z the same: 8; total 32.  Slab i = 2..3: x, only the upper face of i = 3 (i = 4 starts
    # a block) 16; y 2 x 4 x 2 = 16; z 16; total 48.
    fluid = _walls()
    ones = [np.ones((2, 2, 2)) for _ in range(3)]
    sp = bp.SplitParts(fluid, _diags(fluid), (4, 4, 4), ones)
    sizes = np.bincount(sp.part, minlength=sp.n_parts)
    t = 1.0 / sp.inverse
    assert np.allclose(t[sizes == 16], 32.0)
    assert np.allclose(t[sizes == 32], 48.0)


def test_apply_is_symmetric_and_returns_its_energy() -> None:
    fluid = _walls()
    rng = np.random.default_rng(3)
    face = [rng.random((2, 2, 2)) + 0.5 for _ in range(3)]
    sp = bp.SplitParts(fluid, _diags(fluid), (4, 4, 4), face)
    r1 = (rng.standard_normal(fluid.shape) * fluid).astype(np.float32)
    r2 = (rng.standard_normal(fluid.shape) * fluid).astype(np.float32)
    z1, z2 = np.zeros_like(r1), np.zeros_like(r2)
    e1 = sp.apply(r1, z1)
    sp.apply(r2, z2)
    a = float(np.dot(r2.ravel().astype(float), z1.ravel()))
    b = float(np.dot(r1.ravel().astype(float), z2.ravel()))
    assert a == pytest.approx(b, rel=1e-5)
    assert e1 == pytest.approx(float(np.dot(r1.ravel().astype(float), z1.ravel())), rel=1e-5)
    # by hand: the part sums over the part's transmissibility, injected into its cells
    pr = np.bincount(sp.part, r1.ravel()[sp.cells].astype(float), sp.n_parts)
    assert e1 == pytest.approx(float(np.sum(pr * pr * sp.inverse)), rel=1e-6)
    want = np.zeros(fluid.size)
    want[sp.cells] = (pr * sp.inverse)[sp.part]
    assert np.allclose(z1.ravel(), want, rtol=1e-5, atol=1e-7)


def test_coarse_pressure_holds_the_split_parts(monkeypatch: pytest.MonkeyPatch) -> None:
    # the walled grid through the solver's set-up (the term switched on): the coarse term finds
    # the 2 x 64 parts and adds their term to the pressure block (off: the box term alone)
    solid = ~_walls(16)
    monkeypatch.setattr(vs, "COARSE_PRESSURE", True)
    monkeypatch.setattr(schur, "SPLIT_PARTS", True)
    monkeypatch.setattr(schur, "BLOCK", 4)
    op = vs._Stokes.build(solid)
    assert op.coarse_p.parts is not None and op.coarse_p.parts.n_parts == 2 * 64
    rng = np.random.default_rng(0)
    r = (rng.standard_normal(solid.shape) * ~solid).astype(np.float32)
    z_on = np.zeros_like(r)
    e_on = op.coarse_p.apply(r, z_on, op.d, None, vs.SCHUR_FLOOR)
    parts = op.coarse_p.parts
    op.coarse_p.parts = None
    z_off = np.zeros_like(r)
    e_off = op.coarse_p.apply(r, z_off, op.d, None, vs.SCHUR_FLOOR)
    z_p = np.zeros_like(r)
    e_p = parts.apply(r, z_p)
    assert e_p > 0.0
    assert e_on == pytest.approx(e_off + e_p, rel=1e-6)
    assert np.allclose(z_on, z_off + z_p, rtol=1e-5, atol=1e-6 * np.abs(z_on).max())
