"""The voxel Stokes set-up's one-thread numpy passes (issue 16 item 1, session 48): the finest
operators without rolled copies, the staircase's ``1 / A_ff`` from a table and formed once for
the scale code and the thin blocks, the Poisson velocity's first cycle without a copy of its
right-hand side; and (session 49) the first residual formed as the body force, without an
operator pass at x = 0.  Each is checked bit for bit against the numpy definition it replaces (the
former code, kept here as the reference), so the solver's results do not move."""

from __future__ import annotations

import numpy as np
import pytest

import solvers.voxel_stokes as vs
from solvers.voxel import kernels as kr
from solvers.voxel import multigrid as mg
from solvers.voxel import schur


def _rolled_operator(fluid: np.ndarray, a: int) -> tuple[np.ndarray, np.ndarray]:
    """The definition of :func:`solvers.voxel.multigrid.component_operator` by ``np.roll``
    (its code until session 47)."""
    act = fluid & np.roll(fluid, 1, axis=a)
    both_solid = ~fluid & np.roll(~fluid, 1, axis=a)
    diag = np.full(fluid.shape, 6, dtype=np.uint8)
    for b in range(3):
        if b != a:
            diag += np.roll(both_solid, -1, axis=b)
            diag += np.roll(both_solid, 1, axis=b)
    diag[~act] = 0
    c = np.stack([act & np.roll(act, 1, axis=b) for b in range(3)]).astype(np.uint8)
    return diag, c


def _masked_inverse(da: np.ndarray) -> np.ndarray:
    """``1 / A_ff`` by the masked division (the set-up's code until session 47)."""
    return np.divide(1.0, da, out=np.zeros(da.shape, np.float32), where=da > 0)


@pytest.mark.parametrize("shape", [(7, 6, 5), (1, 4, 3), (2, 2, 9), (5, 1, 1)])
def test_component_operator_is_the_rolled_definition(shape, monkeypatch) -> None:
    # periodic neighbours by slices, axes of one and two cells included (where the upper and
    # the lower neighbour are one cell, or the cell itself); and no rolled copy is made
    fluid = np.random.default_rng(sum(shape)).random(shape) < 0.6
    want = [_rolled_operator(fluid, a) for a in range(3)]

    def no_roll(*args, **kwargs):
        raise AssertionError("np.roll copy in component_operator")

    monkeypatch.setattr(np, "roll", no_roll)
    for a in range(3):
        diag, c = mg.component_operator(fluid, a)
        assert diag.dtype == np.uint8 and c.dtype == np.uint8
        assert np.array_equal(diag, want[a][0]) and np.array_equal(c, want[a][1])


def test_unit_inverse_is_the_masked_division_bit_for_bit() -> None:
    every = np.arange(256, dtype=np.uint8).reshape(4, 8, 8)
    got = schur.unit_inverse(every)
    assert got.dtype == np.float32
    assert np.array_equal(got.view(np.uint32), _masked_inverse(every).view(np.uint32))
    assert got[0, 0, 0] == 0.0 and got[0, 0, 3] == np.float32(1.0 / 3.0)
    wide = np.linspace(0.0, 30.0, 61).reshape(1, 61, 1)  # a float diagonal: the division
    assert np.array_equal(schur.unit_inverse(wide), _masked_inverse(wide))


def test_staircase_set_up_forms_each_inverse_once(monkeypatch) -> None:
    # the scale code and the thin blocks share one 1 / A_ff per component (twice before:
    # 6 grid-sized divisions, 0.3 s of one-thread set-up at 200^3); the code is that of the
    # rolled sum of the masked divisions
    solid = np.random.default_rng(5).random((12, 10, 9)) < 0.35
    calls = []
    inverse = schur.unit_inverse
    monkeypatch.setattr(schur, "unit_inverse", lambda da: calls.append(1) or inverse(da))
    op = vs._Stokes.build(solid)
    assert len(calls) == 3 and op.thin is not None
    s2 = np.zeros(solid.shape, np.float32)
    for a in range(3):
        q = _masked_inverse(op.d[a])
        s2 += q
        s2 += np.roll(q, -1, axis=a)
    code = np.clip(
        np.rint(32.0 - schur.CODE_STEPS * np.log2(np.maximum(s2, vs.SCHUR_FLOOR))), 0, 255
    )
    cells = op.fluid != 0
    assert np.array_equal(op.fluid[cells], code.astype(np.uint8)[cells])


def test_poisson_velocity_is_the_zero_start_iteration_bit_for_bit() -> None:
    # the first cycle's V-cycle of b itself (no copy of b, no zero field to add to) against
    # the former loop from u = 0: the same bits
    solid = np.random.default_rng(6).random((16, 12, 10)) < 0.3
    d, c = mg.component_operator(~solid, 0)
    smg = mg.ScalarMG(d, c)
    b = (d > 0).astype(np.float32)
    u = np.zeros(d.shape, np.float32)
    r, e = b.copy(), np.empty(d.shape, np.float32)
    for it in range(schur.CYCLES):
        smg.apply(r, e)
        u += e
        if it + 1 < schur.CYCLES:
            kr.lap_residual(d, c[0], c[1], c[2], u, b, r)
    u *= b
    got = schur.poisson_velocity(smg, d, c, None, schur.CYCLES)
    assert np.abs(got).max() > 0.1  # a real flow, not zeros
    assert np.array_equal(got, u)
    one = schur.poisson_velocity(smg, d, c, None, 1)
    smg.apply(b, e)
    assert np.array_equal(one, e * b)


def _rods_distance(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Two periodic rods of radius 0.2 n across a cube of ``n`` cells: solid and signed
    distance (cells, > 0 in the fluid): cut faces of many weights."""
    g = np.arange(n) + 0.5
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    dist = (
        np.minimum(
            np.hypot((x - 0.3 * n + n / 2) % n - n / 2, (y - 0.4 * n + n / 2) % n - n / 2),
            np.hypot((y - 0.8 * n + n / 2) % n - n / 2, (z - 0.6 * n + n / 2) % n - n / 2),
        )
        - 0.2 * n
    )
    return dist <= 0, dist


@pytest.mark.parametrize("subvoxel", [False, True])
@pytest.mark.parametrize("walls", [None, {1: "slip", 2: "noslip"}])
def test_the_first_residual_is_the_force_bit_for_bit(subvoxel, walls) -> None:
    # r = b - K 0 formed without the operator pass (0.39 s of one thread at 200^3, session 49):
    # every bit of the residual kernel's r at x = 0 (its zero signs too: +0.0 from the
    # staircase kernel, -0.0 from the sub-voxel one) and its two norms, summed in the kernel's
    # order over cut-face weights that are not integers
    solid, dist = _rods_distance(11)
    op = vs._Stokes.build(solid, dist if subvoxel else None, walls)
    if subvoxel:
        assert len({float(w) for w in np.unique(op.weight(0))}) > 10
    for gdir in range(3):
        want = np.empty(op.shape, np.float32)
        norms = op.residual(np.zeros(op.shape, np.float32), gdir, want)
        got = np.full(op.shape, np.nan, np.float32)
        assert vs._force_residual(op, gdir, got) == norms
        assert got.tobytes() == want.tobytes()
        assert norms[0] > 1.0


def test_a_solve_runs_no_operator_pass_at_zero(monkeypatch) -> None:
    # the first refinement cycle starts from r = b: the residual kernel runs only on the
    # cycles' solutions (before session 49 also at x = 0), and the history is the same
    solid, _ = _rods_distance(12)
    zeros = []
    residual = vs._Stokes.residual

    def spy(self, x, gdir, r):
        zeros.append(not np.any(x))
        return residual(self, x, gdir, r)

    monkeypatch.setattr(vs._Stokes, "residual", spy)
    res = vs.solve_voxel_stokes(solid, 1e-6, "x", tol=1e-6)
    assert res.converged and len(zeros) == len(res.history) - 1 and not any(zeros)
    assert res.history[0] == 1.0


def test_the_force_is_formed_before_the_krylov_vectors(monkeypatch) -> None:
    # the sub-voxel force's dense weight (4 B per cell) is a temporary of the first residual:
    # formed before the Krylov work vectors and the solution exist it stays below the solve's
    # peak (formed after them it raised a 96^3 sub-voxel solve's traced peak from 83.8 to 88.2 B
    # per cell, benchmarks/RESULTS.md session 49)
    solid, dist = _rods_distance(12)
    order = []
    force, of = vs._force_residual, vs.MinresWork.of
    monkeypatch.setattr(vs, "_force_residual", lambda *a: order.append("force") or force(*a))
    monkeypatch.setattr(vs.MinresWork, "of", lambda op, k=None: order.append("work") or of(op, k))
    vs.solve_voxel_stokes(solid, 1e-6, "x", tol=1e-3, distance=dist)
    assert order == ["force", "work"]
