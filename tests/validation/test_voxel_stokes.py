"""Tests of the periodic MAC voxel Stokes solver (solvers.voxel_stokes) against independent
truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from conftest import load_benchmark
from reference_values import PUMA_FIBRES_KZZ, PUMA_FIBRES_POROSITY

from psdesign.flow.voxel import column_of, voxel_permeability_tensor
from solvers.voxel_stokes import (
    percolates,
    richardson_extrapolate,
    solve_voxel_stokes,
)

BENCH = Path(__file__).resolve().parents[1] / "data"  # vendored peer geometry (data/README-puma.md)
bench_voxel = load_benchmark("bench_voxel")
toray_like = bench_voxel.toray_like

# Sangani & Acrivos (1982), Int. J. Multiphase Flow 8, 193-206, Table 1 (square array, transverse
# flow): dimensionless drag F / (mu U) per unit length with U the superficial velocity, so that
# F / (mu U) = L^2 / K for a unit cell of side L (as used in Basilisk's src/test/cylinders.c).
SANGANI_ACRIVOS = {0.1: 24.83, 0.2: 51.53, 0.3: 102.90}


def _channel(h_fluid: int, nx: int = 4, nz: int = 4) -> np.ndarray:
    solid = np.zeros((nx, h_fluid + 2, nz), dtype=bool)
    solid[:, :2, :] = True
    return solid


@pytest.mark.parametrize("h_fluid", [6, 14])
def test_poiseuille_channel_matches_discrete_closed_form(h_fluid: int) -> None:
    # MAC with the wall on voxel faces: K = phi (H^2/12 + h^2/6) exactly (derivation in the docs)
    h = 2e-6
    res = solve_voxel_stokes(_channel(h_fluid), h, "z", tol=1e-9)
    phi = h_fluid / (h_fluid + 2)
    exact = phi * ((h_fluid * h) ** 2 / 12 + h**2 / 6)
    assert res.converged
    assert column_of(res)[2] == pytest.approx(exact, rel=1e-6, abs=0)
    assert abs(column_of(res)[0]) < 1e-6 * exact and abs(column_of(res)[1]) < 1e-6 * exact
    assert res.porosity == pytest.approx(phi)


def test_poiseuille_second_order_convergence() -> None:
    width = 1e-5
    errs = []
    for nf in (4, 8, 16):
        res = solve_voxel_stokes(_channel(nf, nx=4, nz=4), width / nf, "x", tol=1e-9)
        phi = nf / (nf + 2)
        errs.append(column_of(res)[0] / (phi * width**2 / 12) - 1.0)
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.allclose(orders, 2.0, atol=0.05)
    # Richardson with order 2 removes the leading error
    ext = richardson_extrapolate(errs[1], errs[2], ratio=2.0, order=2.0)
    assert abs(ext) < 1e-10


def _cylinder_array(n: int, phi_s: float, nz: int = 8) -> np.ndarray:
    c = np.arange(n) + 0.5 - n / 2
    xx, yy = np.meshgrid(c, c, indexing="ij")
    disk = xx**2 + yy**2 < phi_s * n * n / np.pi
    return np.repeat(disk[:, :, None], nz, axis=2)


def test_transverse_flow_square_array_vs_sangani_acrivos() -> None:
    n, phi_s = 32, 0.2
    res = solve_voxel_stokes(_cylinder_array(n, phi_s), 1.0 / n, "x", tol=1e-7, max_iter=80)
    drag = 1.0 / column_of(res)[0]  # L^2 / K with L = 1
    assert res.converged
    assert drag == pytest.approx(SANGANI_ACRIVOS[0.2], rel=0.03)
    # transverse isotropy of the square array and no cross flow
    assert abs(column_of(res)[1]) < 1e-6 * column_of(res)[0]


def test_parallel_flow_exceeds_transverse_flow() -> None:
    # for square arrays K_parallel / K_transverse ~ 2 at low solid fraction (Drummond & Tahir 1984)
    solid = _cylinder_array(16, 0.1, nz=4)
    kx = column_of(solve_voxel_stokes(solid, 1.0, "x"))[0]
    kz = column_of(solve_voxel_stokes(solid, 1.0, "z"))[2]
    assert 1.5 < kz / kx < 2.5


def test_tensor_is_symmetric_on_random_geometry() -> None:
    rng = np.random.default_rng(3)
    solid = rng.random((16, 16, 16)) < 0.2
    k, results = voxel_permeability_tensor(solid, 1e-6, tol=1e-8, max_iter=400)
    assert all(r.converged for r in results)
    scale = np.abs(np.diag(k)).max()
    assert np.abs(k - k.T).max() < 1e-5 * scale
    assert np.all(np.linalg.eigvalsh(0.5 * (k + k.T)) > 0)


def test_puma_fibres_32_kzz() -> None:
    data = np.load(BENCH / "fibres_32.npz")["solid"].astype(bool)
    res = solve_voxel_stokes(data, 1.0 / 32, "z", tol=1e-6)
    assert res.converged
    # MAC (walls on voxel faces) vs PuMA Q1-Q1 FEM (nodes touching solid are fixed, i.e. thicker
    # fibres): both are first order and approach each other from opposite sides
    # (see benchmarks/RESULTS.md).
    # At 32^3 (fibre diameter 2.2 voxels) MAC gives 0.01254, PuMA 0.009785 (32^3) / 0.010145 (64^3).
    assert 0.0100 < column_of(res)[2] < 0.0135
    assert res.porosity == pytest.approx(PUMA_FIBRES_POROSITY[32], abs=1e-4)


@pytest.mark.slow
def test_puma_fibres_richardson_agrees_with_puma_richardson() -> None:
    ks = []
    for n in (32, 64):
        data = np.load(BENCH / f"fibres_{n}.npz")["solid"].astype(bool)
        ks.append(column_of(solve_voxel_stokes(data, 1.0 / n, "z", tol=1e-6))[2])
    ours = richardson_extrapolate(ks[0], ks[1], 2.0, 1.0)
    puma = richardson_extrapolate(PUMA_FIBRES_KZZ[32], PUMA_FIBRES_KZZ[64], 2.0, 1.0)
    assert ours == pytest.approx(puma, rel=0.02)


def test_percolation_detection() -> None:
    solid = np.zeros((6, 6, 6), dtype=bool)
    solid[:, :, 2] = True  # wall normal to z
    assert percolates(solid, 0) and percolates(solid, 1) and not percolates(solid, 2)


def test_blocked_grid_raises() -> None:
    solid = np.zeros((6, 6, 6), dtype=bool)
    solid[:, :, 2] = True
    with pytest.raises(ValueError, match="percolating"):
        solve_voxel_stokes(solid, 1e-6, "z")


@pytest.mark.parametrize(
    ("solid", "kw", "match"),
    [
        (np.zeros((4, 4, 4), dtype=bool), {}, "porosity"),
        (np.ones((4, 4, 4), dtype=bool), {}, "porosity"),
        (np.zeros((4, 4, 4), dtype=np.uint8), {}, "dtype bool"),
        (np.zeros((4, 4), dtype=bool), {}, "3-D"),
        (_channel(4), {"direction": "w"}, "direction"),
        (_channel(4), {"direction": 3}, "direction"),
        (_channel(4), {"voxel_size": -1.0}, "voxel_size"),
        (_channel(4), {"periodic_treatment": "wrap"}, "periodic_treatment"),
    ],
)
def test_bad_input_raises(solid: np.ndarray, kw: dict, match: str) -> None:
    args = {"voxel_size": 1e-6, "direction": "x"} | kw
    with pytest.raises(ValueError, match=match):
        solve_voxel_stokes(solid, args.pop("voxel_size"), args.pop("direction"), **args)


def test_mirror_and_frame_treatments() -> None:
    solid = _channel(6, nx=4, nz=4)
    base = column_of(solve_voxel_stokes(solid, 1.0, "z"))[2]
    mir = solve_voxel_stokes(solid, 1.0, "z", periodic_treatment="mirror")
    assert column_of(mir)[2] == pytest.approx(base, rel=1e-5)  # z-invariant: mirror changes nothing
    frame = solve_voxel_stokes(solid, 1.0, "z", periodic_treatment="frame")
    assert 0 < column_of(frame)[2] < base  # extra walls add drag


# --- independent assembled MAC system (scipy), built from the textbook stencil description ----


def _assemble_mac(solid: np.ndarray, direction: int):
    """Assembled symmetric MAC Stokes matrix [[A, G], [G^T, -delta I]] and body-force rhs.

    Written independently of solvers.voxel: velocity unknowns are the faces between two fluid
    cells; each of the 6 neighbour faces of a face adds 1 to the diagonal and -1 off-diagonal if
    it is an unknown; otherwise the neighbour value is the wall value 0 at distance h (normal
    neighbours and tangential neighbours on a solid surface), or, for a tangential neighbour
    whose two cells are both solid (wall half a cell away), the ghost value -u (diagonal +2).
    """
    fluid = ~solid
    shp = solid.shape
    nfaces = []
    act = [fluid & np.roll(fluid, 1, axis=a) for a in range(3)]
    index = []
    off = 0
    for a in range(3):
        idx = np.full(shp, -1)
        idx[act[a]] = off + np.arange(act[a].sum())
        index.append(idx)
        nfaces.append(int(act[a].sum()))
        off += nfaces[-1]
    nvel = off
    pidx = np.full(shp, -1)
    pidx[fluid] = nvel + np.arange(fluid.sum())
    ntot = nvel + int(fluid.sum())
    rows, cols, vals = [], [], []
    for a in range(3):
        me = index[a][act[a]]
        diag = np.zeros(me.size)
        for b in range(3):
            for s in (-1, 1):
                nb_act = np.roll(act[a], -s, axis=b)[act[a]]
                nb_idx = np.roll(index[a], -s, axis=b)[act[a]]
                diag += 1.0
                rows.append(me[nb_act])
                cols.append(nb_idx[nb_act])
                vals.append(-np.ones(int(nb_act.sum())))
                if b != a:
                    # neighbour face's two cells: (x + s e_b) and (x + s e_b - e_a)
                    c1 = np.roll(solid, -s, axis=b)
                    c0 = np.roll(c1, 1, axis=a)
                    ghost = (c0 & c1)[act[a]]
                    diag += ghost
        rows.append(me)
        cols.append(me)
        vals.append(diag)
        # gradient: face between cells x - e_a and x: p(x) - p(x - e_a)
        rows += [me, me]
        cols += [pidx[act[a]], np.roll(pidx, 1, axis=a)[act[a]]]
        vals += [np.ones(me.size), -np.ones(me.size)]
    a_mat = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(nvel, ntot)
    )
    g_t = a_mat[:, nvel:].T
    k_mat = sp.bmat([[a_mat[:, :nvel], g_t.T], [g_t, -1e-10 * sp.eye(ntot - nvel)]]).tocsc()
    rhs = np.zeros(ntot)
    rhs[index[direction][act[direction]]] = 1.0
    return k_mat, rhs, index, act, nvel


def test_toray_like_small_matches_direct_solve_of_assembled_system() -> None:
    # 12^3 periodic random-fibre grid with 3-voxel fibres: MINRES/multigrid vs sparse LU
    # (5199 unknowns, LU 0.9 s; at 16^3, 11775 unknowns, the LU took 7.8 s for the same check)
    solid = toray_like(12, diameter=0.25, porosity=0.8, seed=1)
    k_mat, rhs, index, act, _ = _assemble_mac(solid, 0)
    lu = spla.splu(k_mat, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0)
    sol = lu.solve(rhs)
    for _ in range(3):  # iterative refinement of the (un-pivoted) LU solution
        sol += lu.solve(rhs - k_mat @ sol)
    assert np.abs(k_mat @ sol - rhs).max() < 1e-10
    k_direct = [sol[index[a][act[a]]].sum() / solid.size for a in range(3)]
    res = solve_voxel_stokes(solid, 1.0, "x", tol=1e-9)
    assert res.converged and res.residual <= 1e-9
    assert np.allclose(column_of(res), k_direct, rtol=1e-6, atol=1e-7 * k_direct[0])


def _toray_check(solid: np.ndarray, direction: int, tol: float) -> None:
    h = 1e-6
    res = solve_voxel_stokes(solid, h, "xyz"[direction], tol=tol, return_velocity=True)
    assert res.converged and res.residual <= tol
    assert 0 < res.iterations < 2000
    assert res.flux_imbalance < 100 * tol
    # energy balance of the solution: dissipation u^T A u equals the work f^T u of the body force
    # (the pressure does no work on a discretely divergence-free field); A assembled independently
    k_mat, rhs, index, act, nvel = _assemble_mac(solid, direction)
    u = np.concatenate([res.velocity[a][act[a]] for a in range(3)]) / h**2  # voxel units
    work = rhs[:nvel] @ u
    dissipation = u @ (k_mat[:nvel, :nvel] @ u)
    assert dissipation == pytest.approx(work, rel=10 * tol)
    # K from the solver's mean velocity vs K from the returned field's work: equal up to the
    # round-off of the two reductions, measured 4.0e-9 (toray_like 48, x). The former rel=1e-12
    # held only through approx's default abs=1e-12 (10 % of this K of 1e-11 m^2; approx17)
    assert column_of(res)[direction] == pytest.approx(work / solid.size * h**2, rel=1e-7, abs=0)


def test_toray_like_48_with_7_voxel_fibres_converges() -> None:
    # the geometry class on which the former Vanka multigrid stalled (7-voxel fibres, phi 0.8)
    solid = toray_like(48, diameter=7.0 / 48, porosity=0.8, seed=0, n_ref=48)
    assert 1.0 - solid.mean() == pytest.approx(0.8, abs=0.02)  # last fibre overshoots
    _toray_check(solid, 0, 1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("direction", [0, 2])
def test_toray_like_100_converges(direction: int) -> None:
    _toray_check(toray_like(100), direction, 1e-6)


@pytest.mark.parametrize("shape", [(64, 64, 4), (30, 18, 5), (8, 40, 1)])
def test_thin_and_odd_grids_converge_to_channel_closed_form(shape: tuple[int, int, int]) -> None:
    # plane channel (walls normal to y, 2 solid layers) on thin / odd-sized periodic grids
    solid = np.zeros(shape, dtype=bool)
    solid[:, :2, :] = True
    h_fluid = shape[1] - 2
    d = 0 if shape[0] > 1 else 2
    res = solve_voxel_stokes(solid, 1.0, d, tol=1e-9)
    phi = h_fluid / shape[1]
    assert res.converged
    assert column_of(res)[d] == pytest.approx(phi * (h_fluid**2 / 12 + 1 / 6), rel=1e-7)


def test_cylinder_array_thin_axis_64_vs_sangani_acrivos() -> None:
    res = solve_voxel_stokes(_cylinder_array(64, 0.2, nz=4), 1.0 / 64, "x", tol=1e-7)
    assert res.converged
    assert 1.0 / column_of(res)[0] == pytest.approx(SANGANI_ACRIVOS[0.2], rel=0.02)


def test_max_iter_exhausted_is_flagged_not_converged() -> None:
    solid = toray_like(24, diameter=0.25, porosity=0.8, seed=2)
    res = solve_voxel_stokes(solid, 1e-6, "x", tol=1e-10, max_iter=5)
    assert not res.converged
    assert res.iterations <= 5 and res.residual > 1e-10
    assert "max_iter" in res.message


def test_progress_reports_monotone_iterations_and_final_true_residual() -> None:
    calls: list[tuple[int, float]] = []
    solid = _cylinder_array(32, 0.2, nz=4)
    res = solve_voxel_stokes(
        solid, 1.0 / 32, "x", tol=1e-8, progress=lambda its, r: calls.append((its, r))
    )
    its = [c[0] for c in calls]
    assert len(calls) >= 3 and its == sorted(its)
    assert calls[-1] == (res.iterations, res.residual)
    assert all(0.0 < r < 1.0 for _, r in calls)


def test_cli_progress_printer_writes_one_line_per_report(capsys) -> None:
    from psdesign.progress import progress_printer

    report = progress_printer("x", every_s=0.0)
    report(25, 1.5e-3)
    err = capsys.readouterr().err
    assert err.startswith("psdesign: voxel solve x: 25 MINRES iterations, residual 1.5e-03")


@pytest.mark.parametrize("shape", [(12, 10, 9), (8, 6, 3), (5, 7, 1)])
def test_fused_residual_restriction_equals_residual_then_sum(shape) -> None:
    from solvers.voxel import kernels as kr
    from solvers.voxel import multigrid as mg

    rng = np.random.default_rng(7)
    fluid = rng.random(shape) > 0.25
    d, c = mg.component_operator(fluid, 0)
    x = (rng.random(shape) * (d > 0)).astype(np.float32)
    b = (rng.random(shape) * (d > 0)).astype(np.float32)
    f = tuple(2 if n >= 4 else 1 for n in shape)
    coarse = tuple(n // m for n, m in zip(shape, f, strict=True))
    r = np.empty(shape, np.float32)
    kr.lap_residual(d, c[0], c[1], c[2], x, b, r)
    expected = np.empty(coarse, np.float32)
    kr.restrict_sum(r, *f, expected)
    fused = np.empty(coarse, np.float32)
    kr.residual_restrict(d, c[0], c[1], c[2], x, b, *f, fused)
    np.testing.assert_allclose(fused, expected, rtol=1e-6, atol=1e-6)
    # and the residual itself against a dense evaluation of A x
    dd = d.astype(float)
    ax = dd * x
    for axis in range(3):
        ax -= c[axis] * np.roll(x, 1, axis=axis) + np.roll(c[axis] * x, -1, axis=axis)
    np.testing.assert_allclose(r, np.where(d > 0, b - ax, 0.0), rtol=1e-5, atol=1e-5)
    # aggregate sums of the fine residual (odd sizes fold the last cell into the last aggregate)
    idx = [np.minimum(np.arange(n) // m, nc - 1) for n, m, nc in zip(shape, f, coarse, strict=True)]
    manual = np.zeros(coarse)
    np.add.at(manual, np.ix_(*idx), r)
    np.testing.assert_allclose(expected, manual, rtol=1e-5, atol=1e-5)
