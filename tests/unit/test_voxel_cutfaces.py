"""The sub-voxel operator stored as uint8 diagonals plus cut-face corrections
(:mod:`solvers.voxel.cutfaces`) against the dense coefficients of :mod:`solvers.voxel.boundary`
(the Gibou et al. 2002 ghost-fluid diagonal and the cut-control-volume weights it documents)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from stokes_product import DenseStokes, stokes_product

from solvers import voxel_stokes as vs
from solvers.voxel import boundary as bd
from solvers.voxel import cutfaces as cf


def _phi(shape: tuple[int, int, int], seed: int) -> np.ndarray:
    """Two periodic cylinders of radius 2.3 voxels (off-grid centres) and random small holes:
    cut faces of every kind, lone pressure cells included."""
    g = np.indices(shape).astype(float)
    phi = np.hypot(g[0] - 3.3, g[1] - 4.6) - 2.3
    phi = np.minimum(np.maximum(phi, -(np.hypot(g[1] - 1.2, g[2] - 5.7) - 1.6)), 3.0)
    rng = np.random.default_rng(seed)
    return phi + 0.3 * rng.standard_normal(shape)


def _dense(phi: np.ndarray) -> tuple:
    """Dense diagonals, weights (after the lone-cell release) and pressure cells."""
    res = [bd.component_coefficients(a, phi_faces={a: bd.face_distance(phi, a)}) for a in range(3)]
    weights = [r[3] for r in res]
    cells = bd.pressure_cells([r[2] for r in res], weights)
    return [r[0] for r in res], weights, cells


def test_compressed_coefficients_are_the_dense_ones_within_the_quanta() -> None:
    phi = _phi((10, 9, 8), seed=1)
    diags, weights, cells = _dense(phi)
    op = vs._Stokes.build(phi <= 0, phi)
    assert np.array_equal(op.fluid != 0, cells)  # the lone cells released alike
    released = 0
    for a in range(3):
        d8, diag, w = op.d[a], op.diagonal(a), op.weight(a)
        act = diags[a] > 0
        assert np.array_equal(d8 > 0, act)
        assert np.array_equal(d8[act], np.rint(diags[a][act]))  # the V-cycles' integer operator
        assert np.abs(diag - diags[a]).max() <= 0.5 * cf.DIAG_QUANTUM + 1e-12
        assert np.abs(w - weights[a]).max() <= 0.5 * cf.WEIGHT_QUANTUM + 1e-7
        assert np.array_equal(w == 0, weights[a] == 0)
        released += int(np.count_nonzero(act & (weights[a] == 0)))
        # only the cut faces are stored: the others have an integer diagonal and weight 1
        st = op.cut.start[a]
        n_cut = int(st[-1] - st[0])
        assert n_cut == np.count_nonzero(
            act & ((diags[a] != np.rint(diags[a])) | (weights[a] != 1))
        )
        assert 0 < n_cut < np.count_nonzero(act)
    assert released > 0  # the grid exercises the release of lone cells
    assert op.cut.nbytes <= 6 * op.cut.k.size + 4 * op.cut.start.size


def test_cut_operator_products_are_the_dense_sub_voxel_matrix() -> None:
    """``K x`` of the stored operator (numba kernels) against the matrix of the dense boundary
    coefficients written out in numpy (:mod:`stokes_product`): equal to the quantisation."""
    phi = _phi((9, 10, 7), seed=2)
    diags, weights, cells = _dense(phi)
    op = vs._Stokes.build(phi <= 0, phi)
    dense = SimpleNamespace(
        diagonal=lambda a: diags[a].astype(np.float64),
        weight=lambda a: weights[a],
        fluid=cells.astype(np.uint8),
    )
    rng = np.random.default_rng(3)
    x = rng.standard_normal(op.shape).astype(np.float32)  # the solver's float32 vectors
    for a in range(3):
        x[a] *= diags[a] > 0
    x[3] *= cells
    kx = stokes_product(dense, x)
    y = np.empty(op.shape, np.float32)
    dot = op.lanczos(x, 1.0, 0.0, y)
    scale = np.abs(kx).max()
    assert np.abs(y - kx).max() <= 2e-5 * scale
    assert dot == pytest.approx(float(np.dot(x.ravel(), kx.ravel())), rel=1e-5)
    for gdir in range(3):
        r = np.empty(op.shape, np.float32)
        rn, fn = op.residual(x, gdir, r)
        f = np.zeros(op.shape)
        f[gdir] = weights[gdir]
        assert np.abs(r - (f - kx)).max() <= 2e-5 * scale
        assert fn == pytest.approx(float(np.linalg.norm(f)), rel=1e-5)
    # the in-place update y <- s K x - c1 y
    y0 = rng.standard_normal(op.shape).astype(np.float32)
    y1 = y0.copy()
    op.lanczos(x, 0.7, 0.3, y1)
    assert np.abs(y1 - (0.7 * kx - 0.3 * y0)).max() <= 2e-5 * scale


def test_subvoxel_solve_uses_the_cut_storage_and_keeps_k() -> None:
    # square array of cylinders across the flow, solid fraction 0.2827 (radius 0.3 of the
    # period): the stored operator's K is the dense one's to 1e-6 (the quantisation moves the
    # diagonal by <= 1.5e-5 and the weight by <= 7.6e-6 on the cut faces only)
    n = 24
    c = np.arange(n) + 0.5 - 0.5 * n
    r = np.hypot(c[:, None], c[None, :])
    phi = np.broadcast_to((r - 0.3 * n)[:, :, None], (n, n, 4)).copy()
    op = vs._Stokes.build(phi <= 0, phi)
    assert op.cut is not None and all(d.dtype == np.uint8 for d in op.d)
    assert all(lev.d.dtype == np.uint8 for m in op.mg for lev in m.levels[:2])
    x, info = vs._solve_core(op, 0, 1e-8, 2000)
    assert info["converged"]
    k_cut = float((x[0] * op.weight(0)).mean())
    diags, weights, cells = _dense(phi)
    # the same solve on the dense float32 coefficients (the storage before the cut faces), K x
    # in numpy (stokes_product.DenseStokes)
    dense = DenseStokes(diags, weights, cells, op)
    xd, infod = vs._solve_core(dense, 0, 1e-8, 2000)
    assert infod["converged"]
    k_dense = float((xd[0] * weights[0]).mean())
    assert k_cut == pytest.approx(k_dense, rel=1e-6)


def test_residual_is_float64_accurate_where_the_divergence_cancels() -> None:
    """The refinement needs ``f - K x`` to float64 accuracy: a channel flow along x between
    off-grid walls has a divergence that cancels to the small cross-flow term, which the
    kernel must keep to float32 rounding of each entry (under ``fastmath`` LLVM had narrowed
    it to float32 arithmetic: 4e-8 absolute errors on 7e-8 entries, and the solve stalled)."""
    ny = 12
    y = np.arange(ny) + 0.5
    dist = np.broadcast_to((0.315 * ny - np.abs(y - ny / 2 - 0.17))[None, :, None], (4, ny, 4))
    op = vs._Stokes.build(dist <= 0, dist.copy())
    rng = np.random.default_rng(5)
    x = np.zeros(op.shape, np.float32)
    x[0] = (op.d[0] > 0) * np.float32(1.6 + 0.1 * np.sin(y))[None, :, None]
    x[1] = (op.d[1] > 0) * rng.standard_normal(op.shape[1:]).astype(np.float32) * 1e-7
    x[3] = (op.fluid != 0) * rng.standard_normal(op.shape[1:]).astype(np.float32) * 1e-3
    dense = SimpleNamespace(diagonal=op.diagonal, weight=op.weight, fluid=op.fluid)
    expect = -stokes_product(dense, x.astype(np.float64))
    expect[0] += op.weight(0)
    r = np.empty(op.shape, np.float32)
    op.residual(x, 0, r)
    cont = expect[3][op.fluid != 0]
    assert np.abs(cont).max() < 1e-5  # the divergence really cancels
    err = np.abs(r.astype(np.float64) - expect)
    assert np.all(err <= 1.2e-7 * np.abs(expect) + 1e-15)
