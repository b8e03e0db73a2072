"""The in-place MINRES kernels (solvers.voxel.lanczos) against the plain operator product and
against scipy's MINRES on the same matrix."""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla

import solvers.voxel_stokes as vs


def _grid(n: int = 10, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    solid = rng.random((n, n, n)) < 0.15
    solid[:, :, 0] = False  # a straight channel keeps it percolating
    return solid


def test_in_place_product_equals_s_kx_minus_c1_y() -> None:
    op = vs._Stokes.build(_grid())
    rng = np.random.default_rng(0)
    x = rng.standard_normal(op.shape).astype(np.float32)
    y0 = rng.standard_normal(op.shape).astype(np.float32)
    kx = np.empty(op.shape, np.float32)
    op.apply(x, kx)
    for s, c1 in ((0.7, 0.0), (1.3, 0.4)):
        y = y0.copy()
        xy = op.lanczos(x, s, c1, y)
        want = s * kx - (c1 * y0 if c1 else 0.0)
        assert np.allclose(y, want, rtol=1e-5, atol=1e-5)
        assert np.isclose(xy, float(np.dot(x.ravel().astype(float), y.ravel())), rtol=1e-6)


def test_minres_matches_scipy_on_the_same_matrix() -> None:
    op = vs._Stokes.build(_grid())
    n = int(np.prod(op.shape))
    b = np.empty(op.shape, np.float32)
    op.residual(np.zeros(op.shape), 2, b)

    def matvec(v: np.ndarray) -> np.ndarray:
        out = np.empty(op.shape, np.float32)
        op.apply(v.reshape(op.shape).astype(np.float32), out)
        return out.ravel().astype(float)

    def prec(v: np.ndarray) -> np.ndarray:
        out = np.empty(op.shape, np.float32)
        op.precondition(v.reshape(op.shape).astype(np.float32), out)
        return out.ravel().astype(float)

    kmat = spla.LinearOperator((n, n), matvec=matvec, dtype=float)
    mmat = spla.LinearOperator((n, n), matvec=prec, dtype=float)
    ref, _ = spla.minres(kmat, b.ravel().astype(float), M=mmat, maxiter=15, rtol=1e-30)
    x = np.zeros(op.shape)
    bufs = [op.z] + [np.empty(op.shape, np.float32) for _ in range(3)]
    its, _ = vs._minres(op, b.copy(), x, bufs, 1e-30, 15)
    assert its == 15
    # the same 15 MINRES iterates up to float32 round-off (a wrong direction update is O(1) off)
    assert np.linalg.norm(x.ravel() - ref) <= 1e-3 * np.linalg.norm(ref)
