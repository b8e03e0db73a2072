"""The capsule rasterizer of ``fast`` placement (``sequential._mark_capsules``) and the RVEs
it gives: a faster rasterizer must clear exactly the grid points the plain one did, so the same
spec and seed give the same RVE bit for bit (RESULTS "geom21": bent placement took 140 s, 84 s
of it in the rasterizer; "fix22": the skip of cleared points and rows)."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from psdesign.packing.build import rve_document
from psdesign.packing.generators import build_fibers
from psdesign.packing.sequential import _mark_capsules
from psdesign.schema.spec import validate_spec


def _brute_force(free: np.ndarray, A, B, lim) -> np.ndarray:
    """Every grid point against every capsule, over all of the point's periodic images in
    the capsule's window (the window and the distance test of the docstring: a point at
    integer (i, j), grid point ((i + k//2) % k, (j + k//2) % k), is cleared if its distance
    to segment A-B is below lim)."""
    free = free.copy()
    k = free.shape[0]
    half = k // 2
    for (ax, ay), (bx, by), r in zip(A, B, lim, strict=True):
        ex, ey = bx - ax, by - ay
        L2 = max(ex * ex + ey * ey, 1e-30)
        i = np.arange(int(np.floor(min(ax, bx) - r)), int(np.ceil(max(ax, bx) + r)) + 1)
        j = np.arange(int(np.floor(min(ay, by) - r)), int(np.ceil(max(ay, by) + r)) + 1)
        px, py = np.meshgrid(i - ax, j - ay, indexing="ij")
        t = np.clip((px * ex + py * ey) / L2, 0.0, 1.0)
        dx, dy = px - t * ex, py - t * ey
        hit = dx * dx + dy * dy < r * r
        ii, jj = np.meshgrid((i + half) % k, (j + half) % k, indexing="ij")
        free[ii[hit], jj[hit]] = False
    return free


@pytest.mark.parametrize("seed", range(6))
def test_rasterizer_clears_exactly_the_points_of_a_brute_force_check(seed):
    # capsules of every kind: points (A = B), long ones, radii from below a grid step to
    # wider than the torus (many images of one point), off-torus coordinates, a grid partly
    # cleared already; few capsules (most points stay free) and many (all cleared early)
    rng = np.random.default_rng(seed)
    k = int(rng.integers(5, 40))
    n = int(rng.choice([3, 40, 400]))
    A = rng.uniform(-1.5 * k, 1.5 * k, (n, 2))
    B = A + rng.normal(0, k / 4, (n, 2)) * (rng.random((n, 1)) < 0.7)
    lim = rng.choice([0.3, 2.0, 6.0, 1.2 * k], n) * rng.uniform(0.5, 1.0, n)
    lim[: n // 10] = np.hypot(*(B - A)[: n // 10].T) / 2  # radius = half length: ties at t
    free = rng.random((k, k)) < 0.8
    want = _brute_force(free, A, B, lim)
    got = free.copy()
    _mark_capsules(got, A, B, lim)
    np.testing.assert_array_equal(got, want)


def test_rasterizer_clears_a_last_free_point_and_keeps_one_outside_every_capsule():
    # the rasterizer stops early once nothing is free: the last free point must still go,
    # and a point outside every capsule must stay (grid point (i, j) sits at i - k//2, j - k//2)
    k = 9
    A, B, lim = np.array([[0.0, 0.0], [3.0, 3.0]]), np.array([[0.0, 0.0], [3.0, 3.0]]), np.ones(2)
    for last, cleared in (((4, 4), True), ((7, 7), True), ((0, 0), False)):
        free = np.zeros((k, k), bool)
        free[last] = True
        _mark_capsules(free, A, B, lim)
        assert free.any() != cleared, last


def _rve_sha256(spec: dict) -> str:
    result = build_fibers(validate_spec(spec))
    return hashlib.sha256(json.dumps(rve_document(result.rve), sort_keys=True).encode()).hexdigest()


BENT = {"kind": "bent", "diameter": 7e-6}
GAP = {"method": "fast", "min_gap": 0.5e-6}


def test_bent_fast_rve_is_bit_for_bit_the_one_before_the_faster_rasterizer():
    # hash of rve.json's document computed once on main 1edeb1d (before the rasterizer
    # change; `git archive 1edeb1d` into a scratch folder, 2026-12-04 05:30 UTC): 40 um cube,
    # bent 7 um fibers (f in [1, 10]) at 0.85, seed 2; 6 fibers after 38 ejections (17.5 s
    # there, 5.6 s here)
    spec = {
        "rve": {"size": [40e-6] * 3, "voxel": 1e-6},
        "generator": {**BENT, "porosity": 0.85, "seed": 2, "porosity_tolerance": 0.02},
        "intersections": GAP,
    }
    assert _rve_sha256(spec) == SMALL_SHA256[_simd_class()]


@pytest.mark.slow  # about 70 s idle
def test_geom21_bent_case_is_bit_for_bit_the_one_before_the_faster_rasterizer():
    # geom21's bent case (60 um cube, 7 um fibers at 0.8, f in [1, 10], 0.5 um gap, seed 1;
    # 18 fibers after 234 ejections; 145 s on main 1edeb1d, hash computed there once,
    # 2026-12-04 05:30 UTC)
    spec = {
        "rve": {"size": [60e-6] * 3, "voxel": 0.6e-6},
        "generator": {**BENT, "porosity": 0.8, "seed": 1},
        "intersections": GAP,
    }
    assert _rve_sha256(spec) == BENT10_SHA256[_simd_class()]


def _simd_class() -> str:
    """The hashes hold per class of x86 host: numba (fastmath), numpy's dispatched loops and
    OpenBLAS all pick AVX-512 code paths where the CPU has them, whose roundings differ from the
    AVX2 ones, and the packing's accept/eject decisions follow the roundings (session 23: the
    old and the new rasterizer give the same hash on an avx512f host, another than on the AVX2
    host; with numba, numpy and OpenBLAS held to Haswell code it is the AVX2 host's)."""
    import llvmlite.binding as ll

    return "avx512" if ll.get_host_cpu_features().get("avx512f", False) else "avx2"


# computed on main 1edeb1d (the rasterizer before the change) on each class of host: avx2 on
# 2026-12-04 05:30 UTC; avx512 on 2026-12-04 12:50 UTC (`git archive 1edeb1d`, PYTHONPATH)
SMALL_SHA256 = {
    "avx2": "2fbd60478e33219207a2eda62c061801e2d0a559ef3f9fe2df399f375fa35221",
    "avx512": "3c78460898f6cff7bc21eaafd86fe61ce580f4ea07620ecfb4bf481fae985a17",
}
BENT10_SHA256 = {
    "avx2": "428f67a9ea92506c12bfb3345c75b7255eb34113d48683eb0e865ea78d287bb1",
    "avx512": "f8104099941a37f99c541050c3abc3431ad2ef53b13eecbffef852db7e9451df",
}
