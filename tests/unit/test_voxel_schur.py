"""The coarse Darcy term of the voxel pressure preconditioner (solvers.voxel.schur): symmetric
positive semi-definite, the Poisson permeability of plane channels in closed form, the
connected components the plates cut, and the inverse of the Darcy symbol on a long wave."""

from __future__ import annotations

import numpy as np
import pytest

import solvers.voxel_stokes as vs
from solvers.voxel import schur, thin


def _plates(n: int = 32, period: int = 8, thick: int = 2) -> np.ndarray:
    """Solid plates normal to z: cells ``k % period < thick`` are solid."""
    solid = np.zeros((n, n, n), dtype=bool)
    solid[:, :, (np.arange(n) % period) < thick] = True
    return solid


def _block_index(n: int, f: int, nc: int) -> np.ndarray:
    """Block of each cell along one axis (the last block takes the remainder)."""
    return np.minimum(np.arange(n) // f, nc - 1)


def _coarse(cp: schur.CoarsePressure, r: np.ndarray, z: np.ndarray) -> float:
    """The coarse term alone, ``z = WEIGHT R^T xc`` on the fluid cells with ``xc`` from
    :meth:`~solvers.voxel.schur.CoarsePressure.solve` (the injection in numpy); returns
    ``r . z``."""
    xc = cp.solve(r)
    idx = np.ix_(*[_block_index(n, f, m) for n, f, m in zip(r.shape, cp.f, xc.shape, strict=True)])
    z[...] = schur.WEIGHT * xc[idx] * (cp.fluid != 0)
    return float(np.dot(r.ravel().astype(np.float64), z.ravel().astype(np.float64)))


def _op(solid: np.ndarray, monkeypatch: pytest.MonkeyPatch) -> vs._Stokes:
    monkeypatch.setattr(vs, "COARSE_PRESSURE", True)
    return vs._Stokes.build(solid)


def test_symmetric_positive_semidefinite_and_dot(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(1)
    solid = rng.random((24, 24, 24)) < 0.2
    op = _op(solid, monkeypatch)
    cp = op.coarse_p
    fluid = ~solid
    r1 = (rng.standard_normal(solid.shape) * fluid).astype(np.float32)
    r2 = (rng.standard_normal(solid.shape) * fluid).astype(np.float32)
    z1 = np.zeros_like(r1)
    z2 = np.zeros_like(r2)
    d1 = _coarse(cp, r1, z1)
    _coarse(cp, r2, z2)
    a = float(np.dot(r2.ravel().astype(float), z1.ravel()))
    b = float(np.dot(r1.ravel().astype(float), z2.ravel()))
    assert a == pytest.approx(b, rel=1e-4, abs=1e-4 * abs(d1))
    assert d1 > 0.0
    assert d1 == pytest.approx(float(np.dot(r1.ravel().astype(float), z1.ravel())), rel=1e-5)
    assert not np.any(z1[solid])  # nothing injected into solid cells
    # the whole block: the staircase Schur diagonal plus the coarse term
    z3 = np.zeros_like(r1)
    d3 = cp.apply(r1, z3, op.d, vs.SCHUR_FLOOR)
    z4 = r1 * schur.CODE_TABLE[schur.schur_code(op.d, vs.SCHUR_FLOOR)]
    assert np.allclose(z3, z4 + z1, rtol=1e-5, atol=1e-5 * np.abs(z3).max())
    assert d3 == pytest.approx(float(np.dot(r1.ravel().astype(float), z3.ravel())), rel=1e-5)


# (block, plate period, plate thickness): one channel per block along z, for the former block
# size 8 and the default 4 (``schur.BLOCK``)
_CHANNELS = [(8, 8, 2), (4, 4, 1)]


@pytest.mark.parametrize(("block", "period", "thick"), _CHANNELS)
def test_channel_poisson_permeability_and_components(
    monkeypatch: pytest.MonkeyPatch, block: int, period: int, thick: int
) -> None:
    # plane channels of H fluid cells between plates: the unit-force velocity along x has
    # the superficial mean phi (H^2 / 12 + 1 / 6) (staircase walls half a cell beyond the last
    # fluid face centre); no velocity unknown crosses a plate, so every channel is its own
    # coarse component and there is no coupling along z
    monkeypatch.setattr(schur, "BLOCK", block)
    solid = _plates(period=period, thick=thick)
    op = _op(solid, monkeypatch)
    cp = op.coarse_p
    h = period - thick
    phi = h / period
    want = phi * (h**2 / 12 + 1 / 6)
    for a in (0, 1):
        assert np.allclose(cp.permeability[a], want, rtol=0.02)
    assert cp.n_comp == solid.shape[2] // period
    assert not np.any(cp.mg.levels[0].c[2])


@pytest.mark.parametrize(("block", "period", "thick"), _CHANNELS)
def test_inverts_the_darcy_symbol_on_a_long_wave(
    monkeypatch: pytest.MonkeyPatch, block: int, period: int, thick: int
) -> None:
    # a pressure wave along x in the channels: per fluid cell the coarse term returns
    # phi s^2 r / (K k_b^2): K the superficial Poisson permeability, k_b^2 = 2 (1 - cos(k b)) /
    # b^2 the coarse discretisation of k^2 (b the block size) and s = sin(k b / 2) /
    # (b sin(k / 2)) the block mean of the unit wave (restriction and injection), times the
    # term's weight (schur.WEIGHT, 0.6 since session 11; the closed form is that of weight 1)
    monkeypatch.setattr(schur, "BLOCK", block)
    solid = _plates(period=period, thick=thick)
    op = _op(solid, monkeypatch)
    n = solid.shape[0]
    x = np.arange(n) + 0.5
    k = 2 * np.pi / n
    r = (np.cos(k * x)[:, None, None] * ~solid).astype(np.float32)
    z = np.zeros_like(r)
    _coarse(op.coarse_p, r, z)
    b = schur.BLOCK
    h = period - thick
    phi = h / period
    kperm = phi * (h**2 / 12 + 1 / 6)
    s = np.sin(k * b / 2) / (b * np.sin(k / 2))
    want = schur.WEIGHT * phi * s**2 / (kperm * 2 * (1 - np.cos(k * b)) / b**2)
    ratio = float(np.sum(z * r, dtype=float) / np.sum(r * r, dtype=float))
    assert ratio == pytest.approx(want, rel=0.03)


def test_staircase_scale_code_matches_the_schur_diagonal() -> None:
    # the one-byte code of 1 / sum(1 / A_ff) (uint8 diagonals) against the formula the
    # sub-voxel path stores (w = 1 on the active faces): within half a code step
    rng = np.random.default_rng(4)
    solid = rng.random((12, 10, 9)) < 0.3
    op = vs._Stokes.build(solid)
    s2 = np.zeros(solid.shape)
    for a in range(3):
        da = op.d[a].astype(float)
        q = np.divide(1.0, da, out=np.zeros(da.shape), where=da > 0)
        s2 += q + np.roll(q, -1, axis=a)
    want = 1.0 / np.maximum(s2, vs.SCHUR_FLOOR)
    got = schur.CODE_TABLE[schur.schur_code(op.d, vs.SCHUR_FLOOR)]
    half = 2.0 ** (0.5 / schur.CODE_STEPS)
    assert np.all(got <= want * half * (1 + 1e-6)) and np.all(got >= want / half * (1 - 1e-6))
    assert np.abs(np.log2(got / want)).max() > 0.1 / schur.CODE_STEPS  # really quantised
    # a wall-free box: six faces of diagonal 6, the identity exactly
    free = vs._Stokes.build(np.zeros((6, 6, 6), dtype=bool))
    assert np.all(schur.CODE_TABLE[schur.schur_code(free.d, vs.SCHUR_FLOOR)] == 1.0)


@pytest.mark.parametrize("subvoxel", [False, True])
def test_preconditioner_returns_r_dot_z_with_the_coarse_term(
    subvoxel: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    # every thin piece kept (LOW = inf: no random piece here has a mode below thin.LOW with
    # sub-voxel walls), so that the pressure block's thin term is there in both wall models
    monkeypatch.setattr(thin, "LOW", np.inf)
    rng = np.random.default_rng(9)
    phi = rng.random((24, 24, 16)) - 0.2
    solid = phi <= 0
    op = _op(solid, monkeypatch) if not subvoxel else None
    if subvoxel:
        monkeypatch.setattr(vs, "COARSE_PRESSURE", True)
        op = vs._Stokes.build(solid, phi)
        assert op.schur_scale() is not None
    assert op.coarse_p.live.any()
    r = rng.standard_normal(op.shape).astype(np.float32)
    r[:3] *= np.stack([dd > 0 for dd in op.d])
    r[3] *= op.fluid != 0
    z = np.empty_like(r)
    rz = op.precondition(r, z)
    exact = float(np.dot(r.ravel().astype(np.float64), z.ravel().astype(np.float64)))
    assert rz == pytest.approx(exact, rel=1e-6)
    # the pressure block is the pore-scale part plus the coarse term, plus the thin pieces'
    # exact local solves in place of the pore-scale part there (tests/unit/test_voxel_thin.py)
    zc = np.zeros_like(r[3])
    _coarse(op.coarse_p, r[3], zc)
    if op.thin is not None:
        assert op.thin.n_cells > 0
        op.thin.apply(r[3], zc)
    if subvoxel:
        fine = r[3] * op.schur_scale()
    else:
        fine = r[3] * schur.CODE_TABLE[schur.schur_code(op.d, vs.SCHUR_FLOOR)]
    assert np.allclose(z[3], fine + zc, rtol=1e-5, atol=1e-5 * float(np.abs(z[3]).max()))


@pytest.mark.parametrize("shape", [(19, 16, 21), (8, 9, 17), (5, 24, 8)])
def test_block_sum_and_pressure_block_match_numpy(shape: tuple[int, int, int]) -> None:
    """``block_sum`` is the sum over blocks with remainder (numpy ``add.at``), the fused
    pressure block is ``table[code] r + weight R^T xc`` on fluid cells and returns ``r . z``
    (issue 16: the row-buffer rewrites of these kernels)."""
    rng = np.random.default_rng(7)
    f = (8, 4, 8)
    nc = tuple(max(1, n // b) for n, b in zip(shape, f, strict=True))
    r = rng.standard_normal(shape).astype(np.float32)
    idx = np.ix_(*[_block_index(n, b, m) for n, b, m in zip(shape, f, nc, strict=True)])
    want = np.zeros(nc)
    np.add.at(want, tuple(np.broadcast_arrays(*idx)), r.astype(np.float64))
    got = np.zeros(nc, np.float32)
    schur.block_sum(r, *f, got)
    assert np.allclose(got, want, rtol=1e-6, atol=1e-5)
    fluid = (rng.random(shape) < 0.7).astype(np.uint8)
    code = rng.integers(0, 200, shape).astype(np.uint8)
    xc = rng.standard_normal(nc).astype(np.float32)
    inject = xc[idx].astype(np.float64) * 0.75 * fluid
    scale = schur.CODE_TABLE[code].astype(np.float64)
    z = np.empty(shape, np.float32)
    dot = schur.pressure_block_code(code, schur.CODE_TABLE, fluid, r, xc, *f, 0.75, z)
    assert np.allclose(z, scale * r + inject, rtol=1e-6, atol=1e-6)
    assert dot == pytest.approx(float(np.dot(r.ravel().astype(np.float64), z.ravel())))


def test_code_scales_sixteen_at_a_time_equal_the_table() -> None:
    """band11: ``simd.code_scale16`` (16 mantissas in a register, the power of two added to the
    float32 exponent) gives exactly ``CODE_TABLE[c] = float32(2^((c - 32) / 16))`` for all 256
    codes (the exact bound: bit-identical scales, so the preconditioner is unchanged)."""
    import numba as nb

    from solvers.voxel import simd

    @nb.njit(cache=False)
    def scales(code, mant, out):
        for k in range(0, code.shape[0] - simd.WIDTH + 1, simd.WIDTH):
            simd.code_scale16(code, k, mant, schur.CODE_SHIFT, out)

    code = np.random.default_rng(3).permutation(256).astype(np.uint8)
    out = np.full(256, np.nan, np.float32)
    scales(code, schur.CODE_TABLE[32:48].copy(), out)
    want = (2.0 ** ((code.astype(np.float64) - 32) / 16)).astype(np.float32)
    assert np.array_equal(out.view(np.uint32), want.view(np.uint32))
    assert np.array_equal(out, schur.CODE_TABLE[code])
