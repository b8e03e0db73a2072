"""The in-place MINRES kernels (solvers.voxel.lanczos) against the operator product written
out in numpy (:mod:`stokes_product`) and against scipy's MINRES on the same matrix; SYMMLQ's CG
point against the Galerkin solution on the same Krylov space (Paige & Saunders 1975)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from stokes_product import stokes_product

import solvers.voxel_stokes as vs
from solvers.voxel import lanczos as lz
from solvers.voxel import memory as vmem


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
    op.residual(np.zeros(op.shape, np.float32), 2, b)
    matvec, prec = _operators(op)
    kmat = spla.LinearOperator((n, n), matvec=matvec, dtype=float)
    mmat = spla.LinearOperator((n, n), matvec=prec, dtype=float)
    ref, _ = spla.minres(kmat, b.ravel().astype(float), M=mmat, maxiter=15, rtol=1e-30)
    # the solver's own solution storage (float32 ``hi``; a float64 array here compiled the
    # direction kernels for a dtype no solve passes: benchmarks/RESULTS.md, session 40)
    x = lz.Solution(op.shape)
    its, _ = vs._minres(op, b.copy(), x, vs.MinresWork.of(op, "minres"), 1e-30, 15)
    assert its == 15
    # the same 15 MINRES iterates up to float32 round-off (a wrong direction update is O(1) off)
    assert np.linalg.norm(x.value().ravel() - ref) <= 1e-3 * np.linalg.norm(ref)


def _operators(op):
    """``(K v, M^-1 v)`` of ``op`` as float64 functions of flat vectors (float32 kernels)."""

    def matvec(v: np.ndarray) -> np.ndarray:
        return stokes_product(op, v.reshape(op.shape)).ravel()

    def prec(v: np.ndarray) -> np.ndarray:
        out = np.empty(op.shape, np.float32)
        op.precondition(v.reshape(op.shape).astype(np.float32), out)
        return out.ravel().astype(float)

    return matvec, prec


@pytest.mark.parametrize("rtol", [1e30, 0.3, 0.03])
def test_symmlq_cg_point_is_the_galerkin_solution(rtol: float) -> None:
    # SYMMLQ stops after k Lanczos steps at the CG point x_C = V_k T_k^-1 beta1 e1, the
    # Galerkin solution on the Krylov space K_k(M^-1 K, M^-1 b): b - K x_C is orthogonal to
    # it (Paige & Saunders 1975, sec. 5); the reference is formed densely on that space
    # (orthonormal basis by Arnoldi in float64)
    op = vs._Stokes.build(_grid())
    b = np.empty(op.shape, np.float32)
    op.residual(np.zeros(op.shape, np.float32), 2, b)
    work = vs.MinresWork.of(op, "symmlq")
    sol = lz.Solution(op.shape, work.packing)
    k, status = vs._symmlq(op, b.copy(), sol, work, rtol, 100)
    x = sol.value()
    assert status == "ok" and (k == 1) == (rtol > 1.0)
    matvec, prec = _operators(op)
    basis = [prec(b.ravel().astype(float))]
    basis[0] /= np.linalg.norm(basis[0])
    for _ in range(k - 1):
        v = prec(matvec(basis[-1]))
        for q in basis:
            v -= (q @ v) * q
        basis.append(v / np.linalg.norm(v))
    q = np.stack(basis, axis=1)
    kq = np.stack([matvec(col) for col in q.T], axis=1)
    ref = q @ np.linalg.solve(q.T @ kq, q.T @ b.ravel().astype(float))
    assert np.linalg.norm(x.ravel() - ref) <= 1e-4 * np.linalg.norm(ref)


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


def test_widen_folds_the_int8_extension_into_float32() -> None:
    # Solution.widen: hi + lo * scale rounded to float32 (within half an ulp of the 40-bit
    # value), no extension left, and the next extend is int16 with one scale per field
    op, pk, active, _, rng = _packed_case()
    x = lz.Solution(op.shape, pk)
    x.hi[:] = rng.standard_normal(pk.size) * 10.0 ** rng.uniform(-4, 0, pk.size)
    hi0 = x.hi.copy()
    x.extend(1e-6)
    assert x.lo.dtype == np.int8 and x.short(1e-6)
    x.lo[:] = rng.integers(-127, 128, pk.size)
    v0 = x.value()
    x.widen()
    v1 = x.value()
    assert not x.extended and not x.short(1e-6)
    assert np.all(np.abs(v1 - v0) <= 2.0**-24 * np.abs(v0) * (1 + 1e-9))
    assert np.mean(x.hi != hi0) > 0.5  # the extension was folded in, not dropped
    x.extend(1e-6)
    assert x.lo.dtype == np.int16 and x.scale.size == 4


def test_short_storage_widens_where_it_stalls(monkeypatch) -> None:
    # an int8 extension 6 bits coarser (scale 2^(E - 26)) floors the true residual at ~3e-6
    # on a rod array along the flow (velocities ~80 voxel units), above tol 1e-6: the
    # refinement folds it into float32 and goes on in int16 and float32 directions
    # (Solution.widen, MinresWork.store_directions) and converges, instead of stopping as
    # stalled (with the real int8 scale: hexagonal array
    # along the rods, 82 voxels per spacing, permeameter, stalled at 1.05e-6;
    # benchmarks/RESULTS.md, session 10)
    x, y = np.meshgrid(np.arange(24) + 0.5, np.arange(24) + 0.5, indexing="ij")
    rod = np.repeat(((x - 12) ** 2 + (y - 12) ** 2 < 16)[:, :, None], 8, axis=2)
    op = vs._Stokes.build(rod)
    ref, tight = vs._solve_core(op, 2, 1e-9, 500)
    monkeypatch.setitem(lz.Solution.LO_BITS_BELOW, 1, 26)
    u, info = vs._solve_core(op, 2, 1e-6, 500)
    assert tight["converged"] and info["converged"] and info["residual"] <= 1e-6
    hist = info["history"]
    assert any(b > a for a, b in zip(hist[:-1], hist[1:], strict=True))  # the fold
    assert np.abs(u[:3] - ref[:3]).max() <= 1e-5 * np.abs(ref[:3]).max()


@pytest.mark.parametrize("weighted", [False, True])
def test_packing_keeps_every_vector_of_the_solve(weighted: bool) -> None:
    # lanczos.Packing stores SYMMLQ's direction and the solution on the active unknowns only:
    # the right-hand side, the preconditioned vector and the Lanczos product of the solve
    # vanish elsewhere (both wall treatments), and pack / unpack is the identity there
    rng = np.random.default_rng(5)
    if weighted:
        phi = rng.random((9, 8, 7)) - 0.25
        op = vs._Stokes.build(phi <= 0, phi)
    else:
        op = vs._Stokes.build(_grid(9, seed=4))
    pk = lz.Packing([*op.d, op.fluid])
    active = np.stack([m != 0 for m in pk.masks])
    assert pk.size == int(active.sum()) and 0 < pk.size < active.size
    b = np.empty(op.shape, np.float32)
    op.residual(np.zeros(op.shape, np.float32), 0, b)
    r = (rng.standard_normal(op.shape) * active).astype(np.float32)
    z = np.empty(op.shape, np.float32)
    op.precondition(r, z)
    y = np.full(op.shape, np.nan, np.float32)
    op.lanczos(z, 0.7, 0.0, y)
    for v in (b, z, y):
        assert np.abs(v).max() > 0.0 and not np.any(v[~active])
    out = np.full(op.shape, 7.0, np.float32)
    pk.unpack(z[active], out)
    assert np.array_equal(out, z)


def test_symmlq_and_minres_reach_the_same_solution() -> None:
    # the refinement loop with SYMMLQ on packed vectors and with MINRES on the grid: the same
    # solution to the tolerance (a packing offset error would be O(1) off)

    op = vs._Stokes.build(_grid())
    out = {}
    for krylov in ("minres", "symmlq"):
        old, vmem.KRYLOV = vmem.KRYLOV, krylov
        try:
            out[krylov] = vs._solve_core(op, 2, 1e-8, 500)
        finally:
            vmem.KRYLOV = old
    (xm, im), (xs, info) = out["minres"], out["symmlq"]
    assert im["converged"] and info["converged"] and info["residual"] <= 1e-8
    assert np.abs(xs[:3] - xm[:3]).max() <= 1e-6 * np.abs(xm[:3]).max()


def _round24(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """float32 ``w`` to the 24-bit storage of :func:`solvers.voxel.lanczos.symmlq_step` (upper
    16 bits, next 8), rounded to nearest by integer arithmetic on the bits (independent of the
    kernel's code)."""
    bits = w.astype(np.float32).view(np.uint32).astype(np.uint64) + 0x80
    return (bits >> 16).astype(np.uint16), ((bits >> 8) & 0xFF).astype(np.uint8)


def _packed_case(seed: int = 6):
    """An operator with inactive unknowns, its packing and a Lanczos-like ``z`` (zero off the
    active unknowns)."""
    op = vs._Stokes.build(_grid(9, seed=4))
    pk = lz.Packing([*op.d, op.fluid])
    active = np.stack([m != 0 for m in pk.masks])
    rng = np.random.default_rng(seed)
    z = (rng.standard_normal(op.shape) * active).astype(np.float32)
    return op, pk, active, z, rng


@pytest.mark.parametrize("tol", [1e-6, 5e-7])
def test_symmlq_step_on_24_bit_direction_matches_float64(tol: float) -> None:
    # w <- sn w - cs v and x += zeta (cs w + sn v), v = s z, with the packed solution (int8
    # extension with row scales from tol memory.SHORT_SOLUTION_FROM = 1e-6, int16 with field
    # scales below) and the direction the solver pairs with it (voxel_stokes._later_bits): 24
    # bits (memory.LATER_SYMMLQ_BITS) beside the int8 extension, float32 (``wm`` empty) beside
    # the int16 one, whose pairing with 24 bits no solve runs (it cost the suite a compile of
    # its own, ~13 s; benchmarks/RESULTS.md, session 40). Each stored direction entry within
    # half an ulp of a 16-bit mantissa (2^-16 relative) of the float64 result plus the float32
    # arithmetic's round-off (session 47: at most ~3 float32 ulps of the terms, 2^-21 of
    # |sn w| + |cs v|), the solution within half its scale (+ the finished direction's float32
    # round-off, likewise)
    op, pk, active, z, rng = _packed_case()
    w0 = (rng.standard_normal(pk.size) * 10.0 ** rng.uniform(-3, 3, pk.size)).astype(np.float32)
    short = tol >= vmem.SHORT_SOLUTION_FROM
    if short:
        wt, wm = _round24(w0)
        w = lz.direction24_value(wt, wm).astype(float)
        assert np.all(np.abs(w - w0) <= 2.0**-16 * np.abs(w0))  # the storage itself
    else:
        wt, wm = w0.copy(), np.zeros(0, np.uint8)
        w = w0.astype(float)
    x = lz.Solution(op.shape, pk)
    x.hi[:] = rng.standard_normal(pk.size) * 3.0
    x.extend(tol)
    assert x.lo.dtype == (np.int8 if short else np.int16)
    assert x.scale.size == (4 * 9 * 9 if short else 4)  # per row / per field
    x0 = x.value()[active]
    s, cs, sn, zeta = 0.7, 0.6, 0.8, 0.37
    v = s * z[active].astype(float)
    want_w = sn * w - cs * v
    done = cs * w + sn * v
    lz.symmlq_step(z, s, wt, wm, cs, sn, x.hi, x.lo, x.scale, zeta, *pk.masks, pk.start)
    got = lz.direction24_value(wt, wm).astype(float) if short else wt.astype(float)
    terms_w = np.abs(sn * w) + np.abs(cs * v)  # float32 arithmetic: relative to the terms
    assert np.all(np.abs(got - want_w) <= 2.0**-16 * np.abs(want_w) + 2.0**-21 * terms_w)
    if short:
        assert np.mean(got != want_w.astype(np.float32)) > 0.5  # 24 bits kept, not float32
    err = np.abs(x.value()[active] - (x0 + zeta * done))
    sc = np.zeros(op.shape)
    pk.unpack(np.ones(pk.size, x.lo.dtype), sc, x.scale)  # the scale of every active entry
    terms = np.abs(cs * w) + np.abs(sn * v)
    assert np.all(err <= 0.51 * sc[active] + 2.0**-21 * zeta * terms)


def _two_sum32(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Knuth's TwoSum in numpy float32 (each operation rounded once): ``a + b = s + e``."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@pytest.mark.parametrize("short", [True, False])
def test_symmlq_step_is_float32_arithmetic(short: bool) -> None:
    # symmlq_step's definition since session 47: the rotation in float32 (v = s32 z, finished
    # direction c32 w + n32 v, w <- n32 w - c32 v) and, with the int8 extension, the solution
    # by two TwoSums in float32 (Knuth, TAOCP vol. 2, 4.2.2: hi + d = s + e exactly), lo the
    # rounded remainder in units of the row's scale. Bitwise the numpy float32 evaluation of
    # those expressions: a fused multiply-add or a reassociated sum in the kernel (fastmath's
    # contract / reassoc) or the float64 form before it fails here
    op, pk, active, z, rng = _packed_case(seed=8)
    w0 = (rng.standard_normal(pk.size) * 10.0 ** rng.uniform(-3, 3, pk.size)).astype(np.float32)
    x = lz.Solution(op.shape, pk)
    x.hi[:] = rng.standard_normal(pk.size) * 3.0
    x.extend(1e-6 if short else 5e-7)
    # a solution already moved by earlier steps: lo anywhere in its range
    x.lo[:] = rng.integers(-127, 128, pk.size) if short else 0
    if short:
        wt, wm = _round24(w0)
        w = lz.direction24_value(wt, wm)
    else:
        wt, wm = w0.copy(), np.zeros(0, np.uint8)
        w = w0
    hi0, lo0 = x.hi.copy(), x.lo.copy()
    s, cs, sn, zeta = 0.7, 0.6, 0.8, 0.37
    lz.symmlq_step(z, s, wt, wm, cs, sn, x.hi, x.lo, x.scale, zeta, *pk.masks, pk.start)
    f = np.float32
    v = f(s) * z[active]
    done = f(cs) * w + f(sn) * v
    new_w = f(sn) * w - f(cs) * v
    if short:
        assert np.array_equal(wt, _round24(new_w)[0]) and np.array_equal(wm, _round24(new_w)[1])
        sc = np.zeros(op.shape, np.float32)
        pk.unpack(np.ones(pk.size, np.int8), sc, x.scale)
        sc = sc[active]
        s1, e = _two_sum32(hi0, f(zeta) * done)
        h, rem = _two_sum32(s1, lo0.astype(f) * sc + e)
        assert np.array_equal(x.hi.view(np.uint32), h.view(np.uint32))
        assert np.array_equal(x.lo, np.clip(np.rint(rem / sc), -127, 127).astype(np.int8))
    else:  # float32 direction, int16 extension (float64 update, unchanged)
        assert np.array_equal(wt.view(np.uint32), new_w.view(np.uint32))


def test_short_solution_scales_follow_the_rows() -> None:
    # the int8 extension (tol >= memory.SHORT_SOLUTION_FROM, 1e-6) keeps 2^-31 of each row's
    # largest entry (rows down to 2^-8 of their field's largest), the int16 one 2^-37 of the
    # field's: 40 and 48 bits; unpacked (MINRES) solutions keep int16
    op, pk, active, _, rng = _packed_case()
    x = lz.Solution(op.shape, pk)
    x.hi[:] = rng.standard_normal(pk.size) * 10.0 ** rng.uniform(-4, 0, pk.size)
    grid = np.zeros(op.shape, np.float32)
    pk.unpack(x.hi, grid)
    x.extend(1e-6)
    rows = np.abs(grid).max(axis=-1).ravel()
    field = np.repeat(np.abs(grid).reshape(4, -1).max(axis=1), rows.size // 4)
    ref = np.maximum(rows, 2.0**-8 * field)
    on = rows > 0
    # scale 2^(E - 32) with 2 m in [2^(E-1), 2^E): in (2^-31, 2^-30] of m, error <= scale / 2
    assert np.all(x.scale[on] <= 2.0**-30 * ref[on]) and np.all(x.scale[on] > 2.0**-31 * ref[on])
    assert lz.Solution(op.shape).lo.dtype == np.int16  # before extend
    for packing, tol, dtype in ((None, 1e-6, np.int16), (pk, 5e-7, np.int16), (pk, 1e-8, np.int32)):
        y = lz.Solution(op.shape, packing)
        y.extend(tol)
        assert y.lo.dtype == dtype and y.scale.size == 4


def test_short_storage_reaches_the_tolerance() -> None:
    # at tol >= memory.SHORT_SOLUTION_FROM the later refinement cycles run on the 24-bit
    # direction and the 40-bit solution: the true residual still reaches tol, and the solution
    # is the tight one to that accuracy (a wrong decode of either is O(1) off)
    op = vs._Stokes.build(_grid())
    ref, tight = vs._solve_core(op, 2, 1e-9, 500)
    x, info = vs._solve_core(op, 2, 1e-5, 500)
    assert tight["converged"] and info["converged"] and info["residual"] <= 1e-5
    assert len(info["history"]) >= 3  # a second cycle ran, on the short storage
    assert np.abs(x[:3] - ref[:3]).max() <= 1e-4 * np.abs(ref[:3]).max()


@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("shape", [(6, 5, 1), (5, 6, 2), (7, 6, 9)])
def test_product_on_short_and_odd_rows(shape: tuple[int, int, int], weighted: bool) -> None:
    """``y <- s K x - c1 y`` against the numpy product (:mod:`stokes_product`) on rows of 1, 2
    and 9 entries: the rows' periodic ends (the pressure term of the component along k wraps
    at k = 0) and the masks applied by multiplication (vec10: ``kernels._on``); the inactive
    entries stay zero."""
    rng = np.random.default_rng(21)
    if weighted:
        phi = rng.random(shape) - 0.25
        op = vs._Stokes.build(phi <= 0, phi)
    else:
        op = vs._Stokes.build(rng.random(shape) < 0.3)
    active = np.stack([*(d > 0 for d in op.d), op.fluid > 0])
    x = (rng.standard_normal(op.shape) * active).astype(np.float32)
    y0 = (rng.standard_normal(op.shape) * active).astype(np.float32)
    want = 1.3 * stokes_product(op, x) - 0.4 * y0
    y = y0.copy()
    xy = op.lanczos(x, 1.3, 0.4, y)
    assert np.abs(y - want).max() <= 1e-6 * np.abs(want).max()
    assert np.all(y[~active] == 0.0) and np.abs(want).max() > 1.0
    assert xy == pytest.approx(float(np.dot(x.ravel().astype(np.float64), y.ravel())), rel=1e-6)


def _host_has_avx512f() -> bool:
    import llvmlite.binding as ll

    return bool(ll.get_host_cpu_features().get("avx512f", False))


#: The 16-lane compress (``llvm.x86.avx512.mask.compress``) compiles only for an AVX-512 target:
#: on an AVX2 host LLVM aborts the process ("Do not know how to split the result of this
#: operator", session 43: a crashed xdist worker and a hung suite). The solver picks it only
#: where numba's target has ``avx512f`` (``simd._wide``), so the test does the same.
WIDE_COMPRESS = pytest.param(
    True, marks=pytest.mark.skipif(not _host_has_avx512f(), reason="AVX-512 compress on AVX2")
)


@pytest.mark.parametrize("wide", [WIDE_COMPRESS, False])
@pytest.mark.parametrize("mask_dtype", [np.uint8, np.float32])
def test_gather_keeps_the_active_entries_in_order(mask_dtype, wide, monkeypatch) -> None:
    """``lanczos._gather`` (16 entries at a time by ``simd.compress16``, the rest of the row one
    by one) equals numpy's boolean indexing on rows shorter than, equal to and longer than 16,
    with empty and full masks, in both forms of the compress (``wide``: AVX-512's
    ``compressstore``; else band18's two 8-lane table permutes, the form without AVX-512, whose
    whole-half stores must stay inside the row: the entries past it are checked untouched)."""
    import numba as nb

    from solvers.voxel import simd

    monkeypatch.setattr(simd, "WIDE", wide)

    @nb.njit(cache=False)
    def gather(mr, zr, zc):
        return lz._gather(mr, zr, zc)

    rng = np.random.default_rng(5)
    for n in (1, 15, 16, 17, 40, 203):
        for density in (0.0, 0.3, 0.9, 1.0):
            mr = (rng.random(n) < density).astype(mask_dtype) * rng.integers(1, 4, n)
            mr = mr.astype(mask_dtype)
            zr = rng.standard_normal(n).astype(np.float32)
            buf = np.full(n + 16, np.nan, np.float32)
            c = gather(mr, zr, buf[:n])
            want = zr[mr != 0]
            assert c == want.size
            assert np.array_equal(buf[:c], want)
            assert np.all(np.isnan(buf[n:]))


@pytest.mark.parametrize("twin", ["serial", "parallel"])
@pytest.mark.parametrize("shape", [(3, 1, 9), (4, 2, 1), (3, 3, 2), (4, 5, 3), (3, 7, 37)])
def test_flat_lanczos_product_against_numpy(shape: tuple[int, int, int], twin: str) -> None:
    """The flat prefetching Lanczos product (``lanczos._lanczos_flat_slab``, unit couplings:
    one loop over each equation's plane, the wrap rows and row ends redone apart) against the
    numpy product (:mod:`stokes_product`) on planes of 1, 2, 3, 5 and 7 rows and rows of 1, 2,
    3, 9 and 37 cells (every cell an end, wrap rows only, both, and neither), both twins;
    ``c1 = 0`` with NaN in ``y`` (unread), and the returned ``x . y`` against numpy's."""
    rng = np.random.default_rng(sum(shape))
    op = vs._Stokes.build(rng.random(shape) < 0.25)
    assert all(c.shape[-1] == shape[2] + 1 for c in op.c)  # unit couplings: the flat path
    active = np.stack([*(d > 0 for d in op.d), op.fluid > 0])
    x = (rng.standard_normal(op.shape) * active).astype(np.float32)
    y0 = (rng.standard_normal(op.shape) * active).astype(np.float32)
    kx = stokes_product(op, x)
    kernel = getattr(lz.stokes_lanczos, twin)
    for s, c1 in ((0.7, 0.0), (1.3, 0.4)):
        y = np.full_like(y0, np.nan) if c1 == 0.0 else y0.copy()
        xy = kernel(*op.d, *op.c, op.fluid, x, s, c1, y)
        want = s * kx - c1 * y0
        assert np.abs(want).max() > 1.0
        assert np.abs(y - want).max() <= 1e-6 * np.abs(want).max()
        assert xy == pytest.approx(float(np.dot(x.ravel().astype(float), want.ravel())), rel=1e-6)


def test_general_lanczos_product_twins_agree_bitwise() -> None:
    """The row-loop Lanczos product (couplings that are not all ones: walls, permeameter
    staircases) gives the same bits in both twins.  Until session 48 the parallel twin's slab
    inlined the one-line helpers in numba (``inline="always"``) and the serial twin's called
    them as plain functions: on this 24^3 grid ``y`` differed in the last bits.  Truth: the
    serial twin (``test_voxel_kernels.py`` checks its row loops against the flat product)."""
    from solvers.voxel import multigrid as mg

    rng = np.random.default_rng(2)
    solid = rng.random((24, 24, 24)) < 0.25
    op = vs._Stokes.build(solid)
    full = [mg.component_operator(~solid, a)[1] for a in range(3)]
    assert not any(c.shape == op.c[0].shape for c in full)  # the row loops, not the flat ones
    x = rng.standard_normal(op.shape).astype(np.float32)
    for a in range(3):
        x[a] *= op.d[a] > 0
    x[3] *= op.fluid > 0
    y0 = rng.standard_normal(op.shape).astype(np.float32)
    out = {}
    for twin in ("serial", "parallel"):
        y = y0.copy()
        dot = getattr(lz.stokes_lanczos, twin)(*op.d, *full, op.fluid, x, 1.3, 0.4, y)
        out[twin] = (y, dot)
    assert np.abs(out["serial"][0]).max() > 1.0
    assert np.array_equal(out["serial"][0], out["parallel"][0])
    assert out["serial"][1] == out["parallel"][1]


_CACHE_STATE_CHILD = """
import hashlib
import numpy as np
from solvers import voxel_stokes as vs
from solvers.voxel import lanczos as lz
g = np.indices((24, 24, 24)).astype(float)
solid = ((g[0] - 12) ** 2 + (g[1] - 12) ** 2 < 25) | ((g[1] - 5) ** 2 + (g[2] - 18) ** 2 < 9)
op = vs._Stokes.build(solid)  # periodic staircase: unit couplings, the flat Lanczos loop
x = np.random.default_rng(0).standard_normal(op.shape).astype(np.float32)
for a in range(3):
    x[a] *= op.d[a] > 0
x[3] *= op.fluid > 0
out = []
for twin in ("serial", "parallel"):
    y = np.zeros_like(x)
    dot = getattr(lz.stokes_lanczos, twin)(*op.d, *op.c, op.fluid, x, 0.7, 0.0, y)
    out.append(hashlib.sha256(y.tobytes()).hexdigest()[:16] + " " + repr(dot))
print(" | ".join(out))
"""


@pytest.mark.slow
def test_staircase_product_is_bitwise_the_same_compiled_or_cached(tmp_path, repo_root) -> None:
    """Session 37: the process that compiled ``stokes_lanczos`` and every later process, which
    loads it from numba's cache, gave other last bits (a 32^3 Toray-like grid: y's hash and
    the dot 308246.0391911829 vs 308246.039190907; a staircase K 2.6e-11 apart): the call
    into the flat loop reached its own compile or the copy linked into its caller, whichever
    the process had loaded first. Truth: one process compiling, the next loading, same bits."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "NUMBA_NUM_THREADS": "2"}
    env["PYTHONPATH"] = str(repo_root)
    runs = [
        subprocess.run(
            [sys.executable, "-c", _CACHE_STATE_CHILD],
            env=env,
            cwd=tmp_path,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        for _ in range(2)
    ]
    assert runs[0] == runs[1], runs
    serial, parallel = runs[0].split(" | ")
    assert serial == parallel  # the twins agree, as test_voxel_threads checks on their own
