"""The coarse Darcy term of the voxel pressure preconditioner (solvers.voxel.schur): symmetric
positive semi-definite, the Poisson permeability of plane channels in closed form, the
connected components the plates cut, the inverse of the Darcy symbol on a long wave, and the
floor of the transmissibilities against the dense Schur complement of a small sphere pack."""

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
    # term's weight (schur.WEIGHT, 0.6 since session 11; the closed form is that of weight 1).
    # The transmissibility K b is floored at schur.FACE_FLOOR times the interface's sum of
    # 1 / A_ff (grow14): b rows of the channel's H layers, diagonal 6 plus 1 per wall half a
    # cell away (staircase ghost -u), so K is replaced by max(K, FACE_FLOOR (2 / 7 + (H - 2) / 6));
    # it binds in the H = 3 channel (0.905 against K = 0.6875), not in H = 6 (1.90 against 2.375)
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
    kperm = max(phi * (h**2 / 12 + 1 / 6), schur.FACE_FLOOR * (2 / 7 + (h - 2) / 6))
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


@pytest.mark.parametrize("wide", [True, False])
def test_code_scales_sixteen_at_a_time_equal_the_table(wide, monkeypatch) -> None:
    """band11: ``simd.code_scale16`` (16 mantissas in a register, the power of two added to the
    float32 exponent) gives exactly ``CODE_TABLE[c] = float32(2^((c - 32) / 16))`` for all 256
    codes (the exact bound: bit-identical scales, so the preconditioner is unchanged), in both
    forms (``wide``: one 16-lane permute, AVX-512; else band18's two 8-lane permutes per half
    and a blend, the form without AVX-512)."""
    import numba as nb

    from solvers.voxel import simd

    monkeypatch.setattr(simd, "WIDE", wide)

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


def _spheres(n: int, porosity: float, radius: float, seed: int) -> np.ndarray:
    """Periodic random overlapping spheres (voxels) down to ``porosity``."""
    rng = np.random.default_rng(seed)
    solid = np.zeros((n, n, n), dtype=bool)
    g = np.indices(solid.shape).astype(float)
    while 1.0 - solid.mean() > porosity:
        c = rng.random(3) * n
        solid |= sum(((g[a] - c[a] + n / 2) % n - n / 2) ** 2 for a in range(3)) < radius**2
    return solid


def _dense_k(op: vs._Stokes) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """``A`` (velocity block) and ``G`` (velocity x pressure) of the operator on its unknowns,
    probed column by column with the product ``K x``, and the flat indices of each component's
    unknowns (the pressure cells last)."""
    act = [op.d[a] > 0 for a in range(3)] + [op.fluid != 0]
    idx = [np.flatnonzero(m.ravel()) for m in act]
    off = np.cumsum([0] + [i.size for i in idx])
    k = np.zeros((off[-1], off[-1]))
    x = np.zeros(op.shape, np.float32)
    y = np.zeros(op.shape, np.float32)
    for c in range(4):
        for t, q in enumerate(idx[c]):
            x[c].flat[q] = 1.0
            op.lanczos(x, 1.0, 0.0, y)
            x[c].flat[q] = 0.0
            k[:, off[c] + t] = np.concatenate([y[b].ravel()[idx[b]] for b in range(4)])
    nv = off[3]
    return k[:nv, :nv], k[:nv, nv:], idx


def _dense_mp(op: vs._Stokes, cells: np.ndarray) -> np.ndarray:
    """The preconditioner's pressure block ``M_p^-1`` on the pressure cells ``cells`` (flat
    indices), probed column by column, symmetrised."""
    x = np.zeros(op.shape, np.float32)
    mp = np.zeros((cells.size, cells.size))
    z = np.zeros(op.shape, np.float32)
    for t, q in enumerate(cells):
        x[3].flat[q] = 1.0
        op.precondition(x, z)
        x[3].flat[q] = 0.0
        mp[:, t] = z[3].ravel()[cells]
    return 0.5 * (mp + mp.T)


def test_face_floor_against_the_dense_schur_complement(monkeypatch: pytest.MonkeyPatch) -> None:
    """grow14: on a low-porosity sphere pack (12^3, porosity 0.34, blocks of 2 cells: 6^3
    blocks) the Darcy transmissibilities of the coarse term fall below the pore-scale face
    graph in the narrow throats and the term over-corrects: the largest eigenvalue of
    ``M_p^-1 S`` (``S = G^T A^-1 G`` dense) is 3.72; with the floor ``FACE_FLOOR sum 1 / A_ff``
    2.13.  The floor's reason, checked on the same matrices: ``A`` is diagonally dominant, so
    ``A^-1 >= diag(A)^-1 / 2`` and the Galerkin coarse Schur complement ``R S R^T`` is at least
    half of ``R L R^T``, ``L = G^T diag(A)^-1 G``, whose edge weights are the face sums."""
    monkeypatch.setattr(schur, "BLOCK", 2)
    monkeypatch.setattr(vs, "COARSE_PRESSURE", True)
    solid = _spheres(12, 0.35, 2.5, 1)
    mu = {}
    ops = []
    for floor in (0.0, schur.FACE_FLOOR):
        monkeypatch.setattr(schur, "FACE_FLOOR", floor)
        op = vs._Stokes.build(solid.copy())
        if not ops:  # K (A and G) is probed once: the floor changes the preconditioner only
            a, g, idx = _dense_k(op)
            cells = idx[3]
            s = g.T @ np.linalg.solve(a, g)
        else:  # ... checked: the product's arrays are the same, so K x is for every x
            arrays = [(*o.d, *o.c, o.fluid) for o in (ops[0], op)]
            assert all(np.array_equal(u, v) for u, v in zip(*arrays, strict=True))
        ops.append(op)
        mu[floor] = float(np.linalg.eigvals(_dense_mp(op, cells) @ s).real.max())
    assert schur.FACE_FLOOR == 2.0
    assert mu[0.0] > 3.0  # the former rule over-corrects
    assert mu[schur.FACE_FLOOR] < 2.3
    # the Galerkin coarse Schur complement dominates half the face graph (Loewner order)
    cp = op.coarse_p
    ijk = np.unravel_index(cells, solid.shape)
    block = np.ravel_multi_index(
        [np.minimum(ijk[a] // cp.f[a], cp.nc[a] - 1) for a in range(3)], cp.nc
    )
    r = np.zeros((int(np.prod(cp.nc)), cells.size))
    r[block, np.arange(cells.size)] = 1.0
    lap = g.T @ (g / np.diag(a)[:, None])
    lc = r @ lap @ r.T
    ev = np.linalg.eigvalsh(r @ s @ r.T - 0.5 * lc)
    assert ev.min() > -1e-9 * np.abs(ev).max()
    # the face sums the floor uses are the edge weights of R L R^T
    for ax in range(3):
        got = cp._face_conductance(op.d[ax], ax)
        lower = np.roll(np.arange(lc.shape[0]).reshape(cp.nc), 1, axis=ax)
        here = np.arange(lc.shape[0]).reshape(cp.nc)
        # nc = 6 per axis: each interface joins two distinct blocks
        assert np.allclose(got, -lc[here, lower], rtol=1e-5, atol=1e-6)


def test_face_conductance_takes_the_sub_voxel_face_weights(monkeypatch: pytest.MonkeyPatch) -> None:
    """With sub-voxel walls the floor sums ``w_f^2 / A_ff`` (``CutFaces.scale_inverse``) over the
    interface faces: the coarse term's sums against a cell-by-cell loop."""
    monkeypatch.setattr(vs, "COARSE_PRESSURE", True)
    rng = np.random.default_rng(5)
    phi = rng.random((16, 12, 8)) - 0.25
    op = vs._Stokes.build(phi <= 0, phi)
    cp = op.coarse_p
    for a in range(3):
        q = op.cut.scale_inverse(a, op.d[a]).astype(np.float64)
        assert np.any((q > 0) & (q < 1.0 / op.d[a].clip(1)))  # some faces really weighted
        want = np.zeros(cp.nc)
        for i, j, k in zip(*np.nonzero(q), strict=True):
            c = (i, j, k)
            if c[a] % cp.f[a] == 0 and c[a] // cp.f[a] < cp.nc[a]:
                bi = tuple(min(c[b] // cp.f[b], cp.nc[b] - 1) for b in range(3))
                want[bi] += q[c]
        assert np.allclose(cp._face_conductance(op.d[a], a), want, rtol=1e-6)
