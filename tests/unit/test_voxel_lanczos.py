"""The in-place MINRES kernels (solvers.voxel.lanczos) against the operator product written
out in numpy (:mod:`stokes_product`) and against scipy's MINRES on the same matrix."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from stokes_product import stokes_product

import solvers.voxel_stokes as vs


def _grid(n: int = 10, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    solid = rng.random((n, n, n)) < 0.15
    solid[:, :, 0] = False  # a straight channel keeps it percolating
    return solid


def test_in_place_product_equals_s_kx_minus_c1_y() -> None:
    op = vs._Stokes.build(_grid())
    rng = np.random.default_rng(0)
    # vectors of the solver's space: zero on the inactive faces and the solid cells
    active = np.stack([*(d > 0 for d in op.d), op.fluid > 0])
    x = (rng.standard_normal(op.shape) * active).astype(np.float32)
    y0 = (rng.standard_normal(op.shape) * active).astype(np.float32)
    kx = stokes_product(op, x)
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
        return stokes_product(op, v.reshape(op.shape)).ravel()

    def prec(v: np.ndarray) -> np.ndarray:
        out = np.empty(op.shape, np.float32)
        op.precondition(v.reshape(op.shape).astype(np.float32), out)
        return out.ravel().astype(float)

    kmat = spla.LinearOperator((n, n), matvec=matvec, dtype=float)
    mmat = spla.LinearOperator((n, n), matvec=prec, dtype=float)
    ref, _ = spla.minres(kmat, b.ravel().astype(float), M=mmat, maxiter=15, rtol=1e-30)
    x = np.zeros(op.shape)
    its, _ = vs._minres(op, b.copy(), x, vs.MinresWork.of(op), 1e-30, 15)
    assert its == 15
    # the same 15 MINRES iterates up to float32 round-off (a wrong direction update is O(1) off)
    assert np.linalg.norm(x.ravel() - ref) <= 1e-3 * np.linalg.norm(ref)


@pytest.mark.parametrize(("nz", "bits"), [(37, 16), (32, 16), (32, 32)])  # per row, block, -
def test_direction_update_on_16_bit_storage_matches_float64(nz: int, bits: int) -> None:
    # u1 <- s z - a1 u1 - a0 u and x += cx u with block-scaled int16 directions and the 48-bit
    # solution: each stored entry within half a quantum of the float64 result
    from solvers.voxel import lanczos as lz

    rng = np.random.default_rng(1)
    shp = (4, 5, 6, nz)
    z = rng.standard_normal(shp).astype(np.float32)
    u, u1 = lz.Directions(shp, bits), lz.Directions(shp, bits)
    for d, scale in ((u, 3.0), (u1, 0.2)):
        d.q[:] = rng.integers(-32767, 32768, shp)
        d.e[:] = scale * rng.random(d.e.shape) / lz.Q_MAX
    assert u.block == (lz.BLOCK if nz % lz.BLOCK == 0 and bits == 16 else nz)
    x = lz.Solution(shp)
    x.hi[:] = rng.standard_normal(shp) * np.array([1.0, 2.0, 3.0, 40.0])[:, None, None, None]
    x.extend()
    x0 = x.value()
    uu, uu1 = (_exact(d) for d in (u, u1))
    s, a1, a0, cx = 0.7, 0.3, -1.1, 1e-3
    want_u1 = s * z.astype(float) - a1 * uu1 - a0 * uu
    want_x = x0 + cx * uu
    lz.minres_direction(z, s, u1.q, u1.e, a1, u.q, u.e, a0, x.hi, x.lo, x.scale, cx)
    b = u1.block
    quantum = np.abs(want_u1.reshape(-1, b)).max(axis=-1, keepdims=True) / lz.Q_MAX
    err = np.abs(_exact(u1) - want_u1).reshape(-1, b)
    assert np.all(err <= 0.5 * quantum + 1e-6 * np.abs(want_u1).max())  # + float32 round-off
    if bits == 16:
        assert np.all(np.abs(u1.q) <= lz.Q_MAX) and np.abs(u1.q).max() == lz.Q_MAX
    # the solution keeps 2^-38 of the field's scale (float32 alone: 2^-24)
    err = np.abs(x.value() - want_x).max(axis=(1, 2, 3))
    assert np.all(err <= x.scale * 0.51)
    assert np.all(x.scale <= 2.0**-36 * np.abs(x0).max(axis=(1, 2, 3)))
    # the flush x += c u
    lz.add_direction(x.hi, x.lo, x.scale, -2.0, u.q, u.e)
    assert np.abs(x.value() - (want_x - 2.0 * uu)).max(axis=(1, 2, 3)).max() <= x.scale.max()


def _exact(d) -> np.ndarray:
    """The value of a :class:`solvers.voxel.lanczos.Directions` in float64."""
    b = d.block
    return (d.q.reshape(-1, b) * d.e[:, None].astype(float)).reshape(d.q.shape)
