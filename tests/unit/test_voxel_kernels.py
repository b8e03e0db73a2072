"""Fused multigrid kernels of the voxel Stokes solver against their unfused compositions.

The fused passes (``jacobi2_zero``, ``prolong_jacobi``, the dot products returned by
``jacobi`` and the pressure block) must give the values of the separate kernels they
replace (``jacobi_zero`` + ``jacobi``, ``prolong_add`` + ``jacobi``, ``dot``) to float32
round-off, on every level type (uint8 finest operators, float32 Galerkin operators), odd and
degenerate row lengths, and inactive unknowns.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
from stokes_product import stokes_product

from solvers.voxel import boundary as bd
from solvers.voxel import cutfaces as cf
from solvers.voxel import kernels as kr
from solvers.voxel import lanczos as lz
from solvers.voxel import multigrid as mg


def _fluid(shape: tuple[int, int, int], seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.random(shape) > 0.3


def _operators(shape: tuple[int, int, int]):
    """Finest (uint8) and first Galerkin (float32) operator of component 0 of a random grid."""
    d, c = mg.component_operator(_fluid(shape), 0)
    f = tuple(2 if n >= 4 else 1 for n in shape)
    nc = tuple(n // m for n, m in zip(shape, f, strict=True))
    dc = np.empty(nc, np.float32)
    cc = np.empty((3, *nc), np.float32)
    kr.galerkin(d, *c, *f, dc, *cc)
    return [(d, c, f), (dc, cc, None)]


def _close(a: np.ndarray, b: np.ndarray) -> None:
    scale = max(float(np.abs(b).max()), 1e-30)
    assert np.abs(a - b).max() <= 2e-6 * scale


SHAPES = [(8, 8, 8), (7, 9, 5), (6, 5, 1), (5, 4, 2), (4, 6, 3)]


@pytest.fixture(params=[1, 2, 3])
def chunks(request) -> int:
    """Number of x-chunks of the plane-rolling kernels (each chunk starts its own planes)."""
    return request.param


@pytest.mark.parametrize("shape", SHAPES)
def test_two_jacobi_sweeps_from_zero_in_one_pass(shape: tuple[int, int, int], chunks) -> None:
    rng = np.random.default_rng(1)
    for d, c, _ in _operators(shape):
        b = (rng.standard_normal(d.shape) * (d > 0)).astype(np.float32)
        x1 = np.empty(d.shape, np.float32)
        ref = np.empty(d.shape, np.float32)
        kr.jacobi_zero(d, b, x1, 0.9)
        kr.jacobi(d, *c, x1, b, ref, 0.9)
        out = np.full(d.shape, np.nan, np.float32)
        kr.jacobi2_zero(d, *c, b, out, 0.9, chunks)
        _close(out, ref)
        assert np.all(out[d == 0] == 0.0)
        assert np.abs(ref).max() > 0.1  # not a trivial comparison


@pytest.mark.parametrize("shape", SHAPES)
def test_prolongation_fused_into_the_first_post_sweep(shape: tuple[int, int, int], chunks) -> None:
    rng = np.random.default_rng(2)
    d, c, f = _operators(shape)[0]
    nc = tuple(n // m for n, m in zip(shape, f, strict=True))
    xc = rng.standard_normal(nc).astype(np.float32)
    x = (rng.standard_normal(shape) * (d > 0)).astype(np.float32)
    b = (rng.standard_normal(shape) * (d > 0)).astype(np.float32)
    x_ref = x.copy()
    kr.prolong_add(d, xc, *f, 1.6, x_ref)
    ref = np.empty(shape, np.float32)
    dot_ref = kr.jacobi(d, *c, x_ref, b, ref, 0.9)
    x_before = x.copy()
    out = np.full(shape, np.nan, np.float32)
    dot = kr.prolong_jacobi(d, *c, x, xc, *f, 1.6, b, out, 0.9, chunks)
    _close(out, ref)
    assert np.array_equal(x, x_before)  # x' is never stored
    exact = float(np.dot(b.ravel().astype(np.float64), out.ravel().astype(np.float64)))
    assert dot == pytest.approx(exact, rel=1e-9, abs=1e-9)  # stored couplings: summed
    assert dot_ref == pytest.approx(exact, rel=1e-5)
    out_unit = np.full(shape, np.nan, np.float32)  # unit couplings (the finest level): not summed
    assert (
        kr.prolong_jacobi(d, *kr.unit_couplings(shape[2]), x, xc, *f, 1.6, b, out_unit, 0.9, chunks)
        == 0.0
    )


def _reference_vcycle(m: mg.ScalarMG, b: np.ndarray) -> np.ndarray:
    """The V-cycle of :class:`ScalarMG` from the unfused kernels (one sweep per pass)."""
    lv = m.levels
    xs = [np.zeros(lev.d.shape, np.float32) for lev in lv]
    bs = [b] + [np.zeros(lev.d.shape, np.float32) for lev in lv[1:]]
    t = [np.zeros(lev.d.shape, np.float32) for lev in lv]
    for li in range(len(lv) - 1):
        lev = lv[li]
        kr.jacobi_zero(lev.d, bs[li], xs[li], m.omega)
        for _ in range(m.pre - 1):
            kr.jacobi(lev.d, *lev.c, xs[li], bs[li], t[li], m.omega)
            xs[li], t[li] = t[li], xs[li]
        r = np.zeros(lev.d.shape, np.float32)
        kr.lap_residual(lev.d, *lev.c, xs[li], bs[li], r)
        kr.restrict_sum(r, *lev.f, bs[li + 1])
    m._coarse_solve(bs[-1], xs[-1])
    for li in range(len(lv) - 2, -1, -1):
        lev = lv[li]
        kr.prolong_add(lev.d, xs[li + 1], *lev.f, m.alpha, xs[li])
        for _ in range(m.pre):
            kr.jacobi(lev.d, *lev.c, xs[li], bs[li], t[li], m.omega)
            xs[li], t[li] = t[li], xs[li]
    return xs[0]


@pytest.mark.parametrize("pre", [1, 2, 3])
def test_fused_vcycle_matches_the_unfused_one_and_returns_b_dot_out(pre: int) -> None:
    d, c = mg.component_operator(_fluid((12, 10, 9), seed=3), 1)
    m = mg.ScalarMG(d, c, pre=pre, max_coarse=8)
    assert m.n_levels >= 3
    b = (np.random.default_rng(4).standard_normal(d.shape) * (d > 0)).astype(np.float32)
    out = np.empty(d.shape, np.float32)
    dot = m.apply(b, out)
    _close(out, _reference_vcycle(m, b))
    exact = float(np.dot(b.ravel().astype(np.float64), out.ravel().astype(np.float64)))
    assert dot == pytest.approx(exact, rel=1e-9)
    assert dot > 0.0  # the V-cycle is SPD


def test_pre_smoothing_sweeps_must_be_positive() -> None:
    d, c = mg.component_operator(_fluid((6, 6, 6)), 0)
    with pytest.raises(ValueError, match="pre"):
        mg.ScalarMG(d, c, pre=0)


def test_multigrid_refuses_the_unit_coupling_stand_in() -> None:
    """Session 28: built on ``unit_couplings`` the Galerkin product read past its one row of
    ones, and the V-cycle's values changed from process to process (|M u| 0.6-15.6 for one
    ``u``); the solver swaps the stand-in in only after the set-up (``_drop_couplings``)."""
    d, c = mg.component_operator(_fluid((6, 6, 6)), 0)
    with pytest.raises(
        ValueError, match=r"c \(couplings\) .* = \(3, 6, 6, 6\), got \(3, 1, 1, 7\)"
    ):
        mg.ScalarMG(d, kr.unit_couplings(6))


@pytest.mark.parametrize("scaled", [False, True])
def test_stokes_preconditioner_returns_r_dot_z(scaled: bool, monkeypatch) -> None:
    from solvers import voxel_stokes as vs

    # the one-level pressure block (identity / stored scale); the two-level default is
    # checked in tests/unit/test_voxel_schur.py
    monkeypatch.setattr(vs, "COARSE_PRESSURE", False)
    solid = ~_fluid((10, 8, 6), seed=5)
    op = vs._Stokes.build(solid)
    if scaled:
        op.p_scale = np.random.default_rng(6).random(solid.shape).astype(np.float32)
    r = (np.random.default_rng(7).standard_normal(op.shape)).astype(np.float32)
    r[:3] *= np.stack([dd > 0 for dd in op.d])
    z = np.empty_like(r)
    rz = op.precondition(r, z)
    p_ref = r[3] * op.p_scale if scaled else r[3]
    assert np.array_equal(z[3], p_ref)
    exact = float(np.dot(r.ravel().astype(np.float64), z.ravel().astype(np.float64)))
    assert rz == pytest.approx(exact, rel=1e-9)
    # the four fields as one three-axis array, the multigrid's type (the same rows of the last
    # axis; a four-axis pair compiled kernels.dot for a type no solve passes)
    r3, z3 = (v.reshape(-1, *v.shape[2:]) for v in (r, z))
    assert rz == pytest.approx(kr.dot(r3, z3), rel=1e-12)


@pytest.mark.parametrize("weighted", [False, True])
def test_one_residual_kernel_for_both_wall_treatments(weighted: bool) -> None:
    """The float64 residual (``kernels.stokes_residual``; ``cutfaces.stokes_residual_cut``
    for sub-voxel walls) and the Lanczos product with ``s = 1, c1 = 0`` give ``f - K x`` and
    ``K x`` of the matrix written out in numpy from the stencil description
    (:mod:`stokes_product`)."""
    from solvers import voxel_stokes as vs

    shape = (9, 8, 7)
    rng = np.random.default_rng(8)
    if weighted:
        phi = rng.random(shape) - 0.25  # sub-voxel walls: float32 weights in (0, 1]
        op = vs._Stokes.build(phi <= 0, phi)
        w0 = op.weight(0)
        assert op.cut is not None and 0.0 < float(w0[w0 > 0].min()) < 1.0
    else:
        op = vs._Stokes.build(~_fluid(shape, seed=9))
    x = rng.standard_normal(op.shape).astype(np.float32)
    for a in range(3):
        x[a] *= op.d[a] > 0
    x[3] *= op.fluid > 0
    kx = stokes_product(op, x)
    y = np.empty_like(x)
    dot = op.lanczos(x, 1.0, 0.0, y)
    assert np.abs(y - kx).max() <= 1e-6 * np.abs(kx).max()
    assert dot == pytest.approx(float(np.dot(x.ravel().astype(np.float64), kx.ravel())), rel=1e-6)
    r = np.empty(op.shape, np.float32)
    rn, fn = op.residual(x, 1, r)  # float32, as the solver passes it
    f = np.zeros(op.shape)
    f[1] = op.weight(1) if weighted else (op.d[1] > 0)
    expect = f - kx
    assert np.abs(r - expect).max() <= 1e-5 * np.abs(expect).max()
    assert rn == pytest.approx(float(np.linalg.norm(expect)), rel=1e-5)
    assert fn == pytest.approx(float(np.linalg.norm(f)), rel=1e-12)


@pytest.mark.parametrize("weighted", [False, True])
def test_unit_couplings_give_the_products_of_the_stored_ones(weighted: bool, chunks) -> None:
    """``kernels.unit_couplings`` (no stored finest couplings, 9 B per cell) against the stored
    ``c_b = act & roll(act)`` of the same grid: every finest-level kernel gives the same numbers
    on vectors that vanish on the inactive unknowns, and the solver's operator uses them only on
    grids whose couplings are exactly those (periodic; not the permeameter's box walls)."""
    from solvers import voxel_stokes as vs

    shape = (9, 8, 7)
    rng = np.random.default_rng(11)
    if weighted:
        phi = rng.random(shape) - 0.25
        full = [bd.component_coefficients(a, phi_faces=[bd.face_distance(phi, b) for b in
                range(3)]) for a in range(3)]  # fmt: skip
        op = vs._Stokes.build(phi <= 0, phi)
    else:
        fluid = _fluid(shape, seed=12)
        full = [mg.component_operator(fluid, a) for a in range(3)]
        op = vs._Stokes.build(~fluid)
    unit = kr.unit_couplings(shape[2])
    assert all(c.shape == unit.shape for c in op.c)  # the stored couplings are dropped
    cs = [f[1] for f in full]
    x = rng.standard_normal(op.shape).astype(np.float32)
    for a in range(3):
        x[a] *= op.d[a] > 0
    x[3] *= op.fluid > 0
    # the float64 residual
    r_unit, r_full = np.empty_like(x), np.empty_like(x)
    if weighted:
        cf.stokes_residual_cut(*op.d, *cs, op.fluid, *op.cut.arrays, x, 0, r_full)
    else:
        kr.stokes_residual(*op.d, *cs, op.fluid, x, 0, r_full)
    op.residual(x, 0, r_unit)
    assert np.array_equal(r_unit, r_full) and np.abs(r_full).max() > 1.0
    # the in-place Lanczos product (solvers.voxel.lanczos inlines the rows of this module)
    l_unit, l_full = np.full_like(x, 0.5), np.full_like(x, 0.5)
    dot_unit = op.lanczos(x, 0.7, 0.3, l_unit)
    if weighted:
        dot_full = cf.stokes_lanczos_cut(*op.d, *cs, op.fluid, *op.cut.arrays, x, 0.7, 0.3, l_full)
    else:
        dot_full = lz.stokes_lanczos(*op.d, *cs, op.fluid, x, 0.7, 0.3, l_full)
    # with unit couplings the product is band15's flat prefetching loop
    # (lanczos._lanczos_flat_slab): the same expressions, contracted differently by fastmath
    _close(l_unit, l_full)
    assert dot_unit == pytest.approx(float(dot_full), rel=1e-6)
    # the multigrid's finest-level kernels
    d, c = op.d[0], cs[0]
    b = x[0].copy()
    out_u, out_f = np.empty_like(b), np.empty_like(b)
    dot_u = kr.jacobi(d, *unit, x[0], b, out_u, 0.9)
    dot_f = kr.jacobi(d, *c, x[0], b, out_f, 0.9)
    # band14: with unit couplings the multigrid's sweeps are flat loops per plane (stencil and
    # update in one expression, other vector widths): the same values to float32 round-off,
    # not the same bits
    _close(out_u, out_f)
    assert dot_u == pytest.approx(dot_f, rel=1e-6)
    kr.jacobi2_zero(d, *unit, b, out_u, 0.9, chunks)
    kr.jacobi2_zero(d, *c, b, out_f, 0.9, chunks)
    _close(out_u, out_f)
    f = (2, 2, 2)
    xc = rng.standard_normal(tuple(n // 2 for n in shape)).astype(np.float32)
    kr.prolong_jacobi(d, *unit, x[0], xc, *f, 1.6, b, out_u, 0.9, chunks)
    kr.prolong_jacobi(d, *c, x[0], xc, *f, 1.6, b, out_f, 0.9, chunks)
    _close(out_u, out_f)
    rc_u, rc_f = (np.empty(tuple(n // 2 for n in shape), np.float32) for _ in range(2))
    kr.residual_restrict(d, *unit, x[0], b, *f, rc_u)
    kr.residual_restrict(d, *c, x[0], b, *f, rc_f)
    _close(rc_u, rc_f)
    # a vector that does not vanish on the inactive unknowns sees the difference
    dense = rng.standard_normal(shape).astype(np.float32)
    kr.lap_residual(d, *unit, dense, b, out_u)
    kr.lap_residual(d, *c, dense, b, out_f)
    assert not np.array_equal(out_u, out_f)


def test_box_walls_keep_the_stored_couplings() -> None:
    from solvers import voxel_stokes as vs

    solid = ~_fluid((8, 7, 6), seed=13)
    op = vs._Stokes.build(solid, walls={1: "slip", 2: "slip"})
    assert [c.shape for c in op.c] == [(3, 8, 7, 6)] * 3


@pytest.mark.parametrize("pre", [1, 2, 3])
def test_vcycle_with_one_work_array_smooths_into_its_output(pre: int) -> None:
    """``ScalarMG(work=[w])``: the finest level smooths between ``w`` and the output (no array
    of its own) and gives the V-cycle of the two-array version, bit for bit, on repeated calls
    with different outputs; the first coarse level of the integer operator is uint8."""
    d, c = mg.component_operator(_fluid((12, 10, 9), seed=3), 1)
    ref = mg.ScalarMG(d, c, pre=pre, max_coarse=8)
    work = np.full(d.shape, np.nan, np.float32)
    one = mg.ScalarMG(d, c, pre=pre, max_coarse=8, work=[work])
    assert one.levels[1].d.dtype == np.uint8 and one.levels[1].c.dtype == np.uint8
    assert ref.levels[1].d.max() > 0
    rng = np.random.default_rng(14)
    for _ in range(2):
        b = (rng.standard_normal(d.shape) * (d > 0)).astype(np.float32)
        out_ref = np.empty(d.shape, np.float32)
        out = np.full(d.shape, np.nan, np.float32)
        assert one.apply(b, out) == ref.apply(b, out_ref)
        assert np.array_equal(out, out_ref)


def _numpy_apply(d: np.ndarray, c: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``A x`` of the 7-point operator in float64 numpy (the stencil of the kernels' module
    docstring), 0 on inactive unknowns: an independent reference for the row kernels."""
    x64 = x.astype(np.float64)
    ax = d * x64
    for b in range(3):
        cb = c[b].astype(np.float64)
        ax -= cb * np.roll(x64, 1, axis=b) + np.roll(cb * x64, -1, axis=b)
    return np.where(d > 0, ax, 0.0)


@pytest.mark.parametrize("shape", SHAPES)
def test_jacobi_sweep_against_numpy(shape: tuple[int, int, int]) -> None:
    """One damped Jacobi sweep ``x + omega D^-1 (b - A x)`` (band9: ``omega / d`` and the update
    in float32, the stencil without multiplications for unit couplings) against float64 numpy,
    to float32 round-off, on both level types and with the unit couplings; the returned dot
    product is that of the stored output."""
    rng = np.random.default_rng(21)
    for d, c, _ in _operators(shape):
        x = (rng.standard_normal(d.shape) * (d > 0)).astype(np.float32)
        b = (rng.standard_normal(d.shape) * (d > 0)).astype(np.float32)
        ref = np.where(d > 0, x + 0.9 * (b - _numpy_apply(d, c, x)) / np.where(d > 0, d, 1), 0)
        couplings = [c] + ([kr.unit_couplings(shape[2])] if d.dtype == np.uint8 else [])
        for cc in couplings:
            out = np.full(d.shape, np.nan, np.float32)
            dot = kr.jacobi(d, *cc, x, b, out, 0.9)
            _close(out, ref)
            exact = float(np.dot(b.ravel().astype(np.float64), out.ravel().astype(np.float64)))
            assert dot == pytest.approx(exact, rel=1e-9, abs=1e-9)
        zero = np.full(d.shape, np.nan, np.float32)
        kr.jacobi_zero(d, b, zero, 0.9)
        _close(zero, np.where(d > 0, 0.9 * b / np.where(d > 0, d, 1), 0))


@pytest.mark.parametrize("twin", ["serial", "parallel"])
@pytest.mark.parametrize(
    "shape", [(3, 1, 5), (4, 2, 1), (3, 3, 2), (5, 3, 3), (4, 7, 17), (3, 5, 150), (6, 9, 37)]
)
def test_flat_prefetching_jacobi_against_numpy(shape: tuple[int, int, int], twin: str) -> None:
    """band14: the finest-level Jacobi sweep with unit couplings is one flat loop over the
    interior rows of each plane (``kernels._jacobi_flat``: its k-neighbours at the row ends come
    from the neighbouring rows and are redone, the rows 0 and ``ny - 1`` wrap along y, and it
    prefetches ``PREFETCH`` cells ahead, past the array's end on the last planes).  Against the
    float64 numpy sweep on the stored couplings to float32 round-off, on planes of 1, 2, 3 and
    more rows (no interior, one interior row), rows of 1, 2, 3 cells (every cell a row end) and
    rows longer than a ``BLOCK``; inactive unknowns exactly 0; the returned value is the float64
    ``b . xnew`` of the stored output."""
    rng = np.random.default_rng(70 + shape[1] * shape[2])
    d, c = mg.component_operator(_fluid(shape, seed=shape[2]), 0)
    x = (rng.standard_normal(shape) * (d > 0)).astype(np.float32)
    b = (rng.standard_normal(shape) * (d > 0)).astype(np.float32)
    ref = np.where(d > 0, x + 0.9 * (b - _numpy_apply(d, c, x)) / np.where(d > 0, d, 1), 0)
    out = np.full(shape, np.nan, np.float32)
    dot = getattr(kr.jacobi, twin)(d, *kr.unit_couplings(shape[2]), x, b, out, 0.9)
    _close(out, ref)
    assert np.all(out[d == 0] == 0.0)
    exact = float(np.dot(b.ravel().astype(np.float64), out.ravel().astype(np.float64)))
    assert dot == pytest.approx(exact, rel=1e-9, abs=1e-9)
    assert np.abs(ref).max() > 0.1  # not a trivial comparison


def test_prefetch_at_changes_nothing() -> None:
    """``simd.prefetch_at`` is a hint: prefetching every element and far past the end of an
    array (as the flat sweep does on its last planes) leaves every array as it was."""
    from solvers.voxel import simd

    @numba.njit(cache=False)
    def fetch(a, far):
        for q in range(a.size + far):
            simd.prefetch_at(a, q)

    for a in (np.arange(100, dtype=np.float32), np.arange(7, dtype=np.uint8)):
        before = a.copy()
        fetch(a, 4096)
        assert np.array_equal(a, before)


@pytest.mark.parametrize("shape", SHAPES + [(5, 7, 150), (7, 3, 37)])
def test_residual_restriction_against_numpy(shape: tuple[int, int, int]) -> None:
    """``residual_restrict`` (band9: the residual rows of an aggregate summed into one float64
    row, then along k; band14: with unit couplings the residual planes by the flat prefetching
    loop, rows longer than its block too) is ``P^T (b - A x)``: the float64 numpy residual
    summed over each aggregate (the last one of an odd axis takes the remainder), to float32
    round-off, on both level types and with the unit couplings."""
    rng = np.random.default_rng(22)
    for d, c, _ in _operators(shape):
        shp = d.shape
        f = tuple(2 if n >= 4 else 1 for n in shp)
        nc = tuple(n // m for n, m in zip(shp, f, strict=True))
        x = (rng.standard_normal(shp) * (d > 0)).astype(np.float32)
        b = (rng.standard_normal(shp) * (d > 0)).astype(np.float32)
        r = np.where(d > 0, b - _numpy_apply(d, c, x), 0.0)
        ref = np.zeros(nc)
        idx = [np.minimum(np.arange(n) // m, q - 1) for n, m, q in zip(shp, f, nc, strict=True)]
        np.add.at(ref, np.ix_(*idx), r)
        couplings = [c] + ([kr.unit_couplings(shp[2])] if d.dtype == np.uint8 else [])
        for cc in couplings:
            rc = np.full(nc, np.nan, np.float32)
            kr.residual_restrict(d, *cc, x, b, *f, rc)
            _close(rc, ref)
        assert np.abs(ref).max() > 0.1  # not a trivial comparison


@pytest.mark.parametrize("ny", [1, kr.AHEAD - 1, kr.AHEAD, kr.AHEAD + 1, 2 * kr.AHEAD + 3])
def test_prefetching_sweeps_at_the_grid_ends(ny: int, chunks) -> None:
    """band11: the row loops prefetch row ``(i, j + AHEAD)``, past the last row the next plane's
    (``kernels._fetch``, ``simd.prefetch_row``), which must never change a value nor read out of
    the grid: the Jacobi sweep, the two sweeps from zero and the prolongation fused into the
    first post sweep against float64 numpy on grids with fewer, as many and more rows than
    ``AHEAD`` (the last plane wraps to plane 0), stored and unit couplings."""
    shape = (5, ny, 7)
    d, c, f, x, xc, b, sweep = _sweep_case(shape, 30 + ny, ny)
    x_pro, x1 = _sweep_starts(d, f, x, xc, b)
    for cc in (c, kr.unit_couplings(shape[2])):
        out = np.full(shape, np.nan, np.float32)
        kr.jacobi(d, *cc, x, b, out, 0.9)
        _close(out, sweep(x))
        kr.jacobi2_zero(d, *cc, b, out, 0.9, chunks)
        _close(out, sweep(x1))
        kr.prolong_jacobi(d, *cc, x, xc, *f, 1.6, b, out, 0.9, chunks)
        _close(out, sweep(x_pro))
    for a in (d, x, np.zeros((2, 3, 0), np.float32)):
        before = a.copy()
        _fetch_all(a)
        assert np.array_equal(a, before)


@numba.njit
def _fetch_all(a):
    """Every row's prefetch of ``a`` (``kernels._fetch``) and an empty row's
    (``simd.prefetch_row``): one dispatcher for all the grid-end cases (a closure in the test
    compiled anew for each of its 15 cases)."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            kr._fetch(a, i, j)
            kr.simd.prefetch_row(a[i, j, :0])  # an empty row: no line


@pytest.mark.parametrize("ny", [1, 2, 3, 9, 19])
def test_plane_sweeps_with_flat_runs_against_numpy(ny: int, chunks) -> None:
    """band12 / band14: ``jacobi2_zero`` and ``prolong_jacobi`` (unit couplings: one flat loop
    over the interior rows of the buffered planes, the plane two ahead prefetched) against
    float64 numpy, with the stored couplings too, on planes without interior rows (1, 2 rows),
    with one and with several."""
    shape = (6, ny, 9)
    d, c, f, x, xc, b, sweep = _sweep_case(shape, 50 + ny, 7 + ny)
    x_pro, x1 = _sweep_starts(d, f, x, xc, b)
    for cc in (c, kr.unit_couplings(shape[2])):
        out = np.full(shape, np.nan, np.float32)
        kr.jacobi2_zero(d, *cc, b, out, 0.9, chunks)
        _close(out, sweep(x1))
        kr.prolong_jacobi(d, *cc, x, xc, *f, 1.6, b, out, 0.9, chunks)
        _close(out, sweep(x_pro))


def _sweep_case(shape: tuple[int, int, int], seed: int, fluid_seed: int):
    """Operator of a random fluid mask, random fine/coarse vectors and one float64 damped Jacobi
    sweep (omega 0.9) in numpy: the reference of the plane-sweep tests."""
    rng = np.random.default_rng(seed)
    d, c = mg.component_operator(_fluid(shape, seed=fluid_seed), 0)
    f = tuple(2 if n >= 4 else 1 for n in shape)
    nc = tuple(n // m for n, m in zip(shape, f, strict=True))
    x = (rng.standard_normal(shape) * (d > 0)).astype(np.float32)
    b = (rng.standard_normal(shape) * (d > 0)).astype(np.float32)
    xc = rng.standard_normal(nc).astype(np.float32)
    dd = np.where(d > 0, d, 1).astype(np.float64)

    def sweep(x0: np.ndarray) -> np.ndarray:
        return np.where(d > 0, x0 + 0.9 * (b - _numpy_apply(d, c, x0)) / dd, 0.0)

    return d, c, f, x, xc, b, sweep


def _sweep_starts(d, f, x, xc, b):
    """The prolonged start ``x + 1.6 P xc`` and the first sweep from zero ``0.9 b / d``."""
    nc = xc.shape
    idx = np.ix_(
        *[np.minimum(np.arange(n) // m, q - 1) for n, m, q in zip(d.shape, f, nc, strict=True)]
    )
    x_pro = np.where(d > 0, x + 1.6 * xc[idx].astype(np.float64), 0.0)
    x1 = np.where(d > 0, 0.9 * b / np.where(d > 0, d, 1).astype(np.float64), 0.0)
    return x_pro, x1


@pytest.mark.parametrize(
    "twin",
    [
        "serial",
        # compiles five parallel kernels (minutes on a cold cache); after `psdesign warmup` a
        # two-thread solve runs these. With noalias they differed (session 20 review)
        pytest.param("parallel", marks=pytest.mark.slow),
    ],
)
@pytest.mark.parametrize("shape", [(6, 23, 4), (5, 9, 16)])
def test_fused_sweeps_are_bitwise_jacobis(shape, chunks, twin) -> None:
    """band20: with unit couplings (the flat sweeps) and stored ones (the row loops) the fused
    passes must give *bitwise* the values of ``jacobi_zero`` + ``jacobi`` and ``prolong_add`` +
    ``jacobi``, not only to round-off: MINRES needs a symmetric preconditioner, i.e. every
    smoothing sweep of the V-cycle the same operator.  Variants compiled with ``noalias`` summed
    the row ends ``k = nz - 1`` in another order (three plane arrays) or vectorised
    ``jacobi``'s row loops differently (an ulp off on 3-5 % of the cells) and took up to 5
    more MINRES iterations on small array cases (``benchmarks/RESULTS.md``, band20).

    Where numba compiles for AVX-512 (16 float32 lanes) the stored-coupling row loops of rows
    of 16 or more cells vectorise differently in the two kernels (measured on a host with
    avx512f, session 23: 32 of 720 cells of shape (5, 9, 16) differ, by at most 3e-8 = 0.25 ulp
    of the largest value; bitwise with ``NUMBA_CPU_FEATURES`` without avx512): there they must
    agree to round-off (:func:`_agree`), everywhere else bitwise."""
    rng = np.random.default_rng(5)
    d, c = mg.component_operator(_fluid(shape, seed=3), 0)
    b = (rng.standard_normal(shape) * (d > 0)).astype(np.float32)
    f = tuple(2 if n >= 4 else 1 for n in shape)
    xc = rng.standard_normal(tuple(n // m for n, m in zip(shape, f, strict=True)))
    xc = xc.astype(np.float32)
    x = (rng.standard_normal(shape) * (d > 0)).astype(np.float32)
    jacobi_zero, jacobi, jacobi2_zero, prolong_add, prolong_jacobi = (
        getattr(k, twin)
        for k in (kr.jacobi_zero, kr.jacobi, kr.jacobi2_zero, kr.prolong_add, kr.prolong_jacobi)
    )
    for cc in (kr.unit_couplings(shape[2]), c):  # the flat sweeps, the row loops
        x1 = np.empty(shape, np.float32)
        ref = np.empty(shape, np.float32)
        jacobi_zero(d, b, x1, 0.9)
        jacobi(d, *cc, x1, b, ref, 0.9)
        out = np.full(shape, np.nan, np.float32)
        jacobi2_zero(d, *cc, b, out, 0.9, chunks)
        _agree(out, ref, bitwise=cc is not c or shape[2] < 16 or not _numba_targets_avx512())
        xp = x.copy()
        prolong_add(d, xc, *f, 1.6, xp)
        jacobi(d, *cc, xp, b, ref, 0.9)
        prolong_jacobi(d, *cc, x, xc, *f, 1.6, b, out, 0.9, chunks)
        _agree(out, ref, bitwise=cc is not c or shape[2] < 16 or not _numba_targets_avx512())
        assert np.abs(ref).max() > 0.1  # not a trivial comparison


def _numba_targets_avx512() -> bool:
    """Does numba compile for AVX-512 here (the host's features, or ``NUMBA_CPU_FEATURES``)?"""
    from numba.core import config

    if config.CPU_FEATURES is not None:
        return "+avx512f" in config.CPU_FEATURES.split(",")
    import llvmlite.binding as ll

    return bool(ll.get_host_cpu_features().get("avx512f", False))


def _agree(out: np.ndarray, ref: np.ndarray, bitwise: bool) -> None:
    """Bitwise equal, or (``bitwise`` False) equal to 1 float32 ulp of the largest value."""
    if bitwise:
        assert np.array_equal(out, ref)
    else:
        tol = float(np.spacing(np.float32(np.abs(ref).max())))
        np.testing.assert_allclose(out, ref, rtol=0, atol=tol)


def test_flat_is_a_view_of_every_entry() -> None:
    """``simd.flat``: the 1-D view ``reshape(-1)`` gives (numpy's own, the independent truth),
    sharing the array's memory (a write through it lands in the array), and typing fails for an
    array that is not C-contiguous."""
    from numba.core.errors import TypingError

    from solvers.voxel import simd

    @numba.njit(cache=False)
    def through_flat(a, q, v):
        f = simd.flat(a)
        f[q] = v
        return f.copy()

    a = np.arange(60, dtype=np.float32).reshape(3, 4, 5)
    got = through_flat(a, 37, -1.0)
    want = np.arange(60, dtype=np.float32)
    want[37] = -1.0
    assert got.shape == (60,) and np.array_equal(got, want)
    assert a[1, 3, 2] == -1.0  # entry 37 of the C order
    with pytest.raises(TypingError):
        through_flat(a[:, :, ::2], 0, 0.0)


def test_parallel_twins_of_the_sweeps_are_compiled_with_overlap_checks() -> None:
    """The parallel twins of ``jacobi``, ``jacobi2_zero`` and ``prolong_jacobi`` must not be
    compiled with :class:`solvers.jit.NoAliasCompiler` while they hold the stored-coupling row
    loops (session 49; s48's 4e39655 did, and was reverted).  numba then marks every array
    parameter of the parfor gufunc ``noalias``, also the arrays ``jacobi`` reshapes to keep its
    row loops compiled as without the flag (a trick that works in the serial twin only), and the
    row loops give other bits: the row ends ``k = nz - 1`` of ``jacobi`` in a process that
    compiled them (1 281 cells of a 72^3 staircase sweep), the vector bodies of ``jacobi`` and
    ``prolong_jacobi`` in one that loaded them from numba's cache (54 881 / 48 063 cells).  The
    two-thread solve of ``test_voxel_threads`` then started at 1.79826e-4 or 1.80488e-4 against
    1.81817e-4, and the slow parallel cases of :func:`test_fused_sweeps_are_bitwise_jacobis` fail
    (``benchmarks/RESULTS.md``, session 49).  Fails on 4e39655."""
    from solvers.jit import NoAliasCompiler

    for k in (kr.jacobi, kr.jacobi2_zero, kr.prolong_jacobi):
        assert k.serial._compiler.pipeline_class is NoAliasCompiler
        assert k.parallel._compiler.pipeline_class is not NoAliasCompiler
    # the chunk bodies the parallel twins of the fused sweeps call (session 50; its review found
    # them compiled with NoAliasCompiler: other bits when loaded from the cache)
    for body in (kr._jacobi2_zero_chunk, kr._prolong_jacobi_chunk):
        assert body._compiler.pipeline_class is not NoAliasCompiler


def test_multigrid_takes_strided_inputs_and_refuses_a_strided_output() -> None:
    """Session 52 I/O review, finding 6: ``ScalarMG(d, c)`` and ``.apply(b, out)`` on a
    Fortran-ordered or strided ``d``, ``c``, ``b`` or ``out`` failed with numba's multi-page
    TypingError (the kernels are compiled for C order). The inputs (the operator the class
    keeps, the right-hand side it reads) are copied to C order: the V-cycle is then the same
    numbers as on the C-ordered arrays, bit for bit; the output buffer is the caller's, so a
    strided or Fortran one is refused with one line."""
    d, c = mg.component_operator(_fluid((12, 10, 9), seed=3), 1)
    b = (np.random.default_rng(4).standard_normal(d.shape) * (d > 0)).astype(np.float32)
    want = np.empty(d.shape, np.float32)
    dot = mg.ScalarMG(d, c, max_coarse=8).apply(b, want)
    strided_b = np.stack([b, b], axis=-1)[..., 0]  # every other float32 of a wider array
    assert not strided_b.flags.c_contiguous and not np.asfortranarray(d).flags.c_contiguous
    for dd, cc, bb in (
        (np.asfortranarray(d), np.asfortranarray(c), np.asfortranarray(b)),
        (d, c, strided_b),
        (np.stack([d, d], axis=-1)[..., 0], np.stack([c, c], axis=-1)[..., 0], b),
    ):
        out = np.empty(d.shape, np.float32)
        assert mg.ScalarMG(dd, cc, max_coarse=8).apply(bb, out) == dot
        assert np.array_equal(out, want)
    m = mg.ScalarMG(d, c, max_coarse=8)
    for bad in (np.empty(d.shape, np.float32, order="F"), np.stack([b, b], axis=-1)[..., 0]):
        with pytest.raises(ValueError, match=r"^out must be a C-contiguous array of shape") as e:
            m.apply(b, bad)
        assert "\n" not in str(e.value)
