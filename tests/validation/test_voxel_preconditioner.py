"""The sub-voxel pressure preconditioner (inverse diagonal of the weighted Schur complement,
``solvers.voxel_stokes.PRESSURE_SCALING``): wall-free value and iteration count on fibres."""

from __future__ import annotations

import numpy as np
from conftest import load_benchmark

from solvers import voxel_stokes as vs

bench_voxel = load_benchmark("bench_voxel")


def test_schur_diagonal_is_one_away_from_walls() -> None:
    # one wall-aligned slab: cells two and more voxels from it see six full faces of diagonal 6
    n = 12
    phi = np.tile(np.abs(np.arange(n) - 5.5)[None, :, None] - 2.0, (4, 1, 4))
    op = vs._Stokes.build(phi <= 0, phi)
    far = np.abs(np.arange(n) - 5.5) > 5.0  # rows 0 and 11: 3.5+ voxels of fluid around
    scale = op.schur_scale()
    assert np.allclose(scale[:, far, :], 1.0, rtol=1e-6)
    # cut cells next to the wall need a larger scale (their faces are stiffer and lighter)
    assert scale[:, 3, :].min() > 1.0 and scale[:, 8, :].min() > 1.0


def test_subvoxel_iterations_stay_near_the_staircase_on_random_fibres() -> None:
    # Toray-like 24^3 (7 um fibres, 24 um box: 1.7 voxels per diameter): measured 134 sub-voxel
    # vs 109 staircase MINRES iterations; the former estimate sum(w^2) / 6 needed 425
    n = 24
    phi = bench_voxel.toray_like(n, distance=True, n_ref=n) * n
    solid = phi <= 0
    its = {}
    for label, dist in (("subvoxel", phi), ("staircase", None)):
        op = vs._Stokes.build(solid, dist)
        _, info = vs._solve_core(op, 0, 1e-6, 2000)
        assert info["converged"]
        its[label] = info["iterations"]
    assert its["subvoxel"] <= 1.5 * its["staircase"]
