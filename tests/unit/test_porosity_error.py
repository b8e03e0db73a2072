"""The voxel-count porosity's error estimate (psdesign.geometry.porosity) against closed forms.

Truths: a solid slab between two planes has the pore fraction ``1 - w / L`` exactly; a
straight cylinder along z has the solid fraction ``pi d^2 / 4`` per unit cell and the PS rod
(Eq. 4) the exact cross-section ``rod_cross_section_area`` (a 1-D quadrature, 1e-12).
"""

from __future__ import annotations

import numpy as np
import pytest

from psdesign.geometry.fibers import make_fiber, rod_cross_section_area
from psdesign.geometry.plane_cut import plane_partial_porosity
from psdesign.geometry.porosity import partial_volume_porosity, porosity_error
from psdesign.geometry.rve import RVE, VoxelFields, VoxelGrid
from psdesign.transport.pores import porosity_profile

L = 1e-4  # one period, metres


def _slab_fields(n: int, centre: float, width: float) -> VoxelFields:
    """A solid slab ``|x - centre| <= width / 2`` (metres) in a periodic ``n^3`` box of edge L:
    its exact signed distance at the voxel centres."""
    h = L / n
    x = (np.arange(n) + 0.5) * h
    rel = (x - centre + L / 2) % L - L / 2
    d = (np.abs(rel) - width / 2).astype(np.float32)
    distance = np.broadcast_to(d[:, None, None], (n, n, n)).copy()
    count = (distance <= 0).astype(np.uint8)
    return VoxelFields(distance=distance, count=count, grid=VoxelGrid.from_voxel(np.full(3, L), h))


@pytest.mark.parametrize(
    "centre,width", [(0.31e-4, 0.237e-4), (0.5e-4, 0.4e-4), (0.77e-4, 0.11e-4)]
)
def test_slab_estimate_is_the_true_error(centre, width) -> None:
    """Planes along voxel faces: the clip partial volume is exact on both grids, so the
    estimate is the count's error (float32 distances: 1e-6) plus the tangent-plane partial
    volume's two-grid change, 0 but where a gradient's difference straddles the slab's
    mid-plane (the thinnest slab, 2.6 voxels: 4 % of the error)."""
    f = _slab_fields(24, centre, width)
    true = 1.0 - width / L
    h = L / 24
    assert partial_volume_porosity(f.distance, h) == pytest.approx(true, abs=1e-6)
    coarse = np.ascontiguousarray(f.distance[::2, ::2, ::2])
    change = abs(plane_partial_porosity(f.distance, h) - plane_partial_porosity(coarse, 2 * h))
    assert f.porosity_error == pytest.approx(abs(f.porosity - true) + change, abs=1e-6)
    assert change <= 0.05 * abs(f.porosity - true)
    assert f.porosity_error > 1e-3  # the count is off: a slab face inside a voxel


def _z_fibres(seed: int) -> list[tuple[float, float, float]]:
    """(count error, estimate, cut-voxel bound) of cylinders and rods along z at 20 and 40
    voxels per period, random diameters 0.15-0.6 periods and centres."""
    rng = np.random.default_rng(seed)
    out = []
    for shape in ("cylinder", "rod"):
        for _ in range(4):
            d = rng.uniform(0.15, 0.6)
            fb = make_fiber(
                shape, diameter=d, center=[*rng.uniform(0, 1, 2), 0.5], direction=[0, 0, 1]
            )
            area = np.pi * d * d / 4 if shape == "cylinder" else rod_cross_section_area(d)
            for n in (20, 40):
                f = RVE(size=np.full(3, L), fibers=[fb]).voxelize(L / n)
                cut = float(np.mean(porosity_profile(f, "z")["porosity_error"]))
                out.append((abs(f.porosity - (1.0 - area)), f.porosity_error, cut))
    return out


def test_fibre_estimate_covers_the_count_error_and_is_tighter_than_the_bound() -> None:
    """Coverage of the true error over 16 cases, and the estimate's size: it must cover (a zero
    covers none, the count-partial difference alone 7 of 16), and be a small multiple of the error,
    far below the rigorous cut-voxel bound (a median 100x the error or more)."""
    rows = np.array(_z_fibres(3))
    err, est, cut = rows.T
    assert np.mean(err <= est) >= 14 / 16
    assert np.median(est / err) < 20.0
    assert np.all(est < cut)


def test_image_porosity_is_exact() -> None:
    """A segmented image is its own geometry: its count has no error."""
    from psdesign.image.fields import image_fields

    solid = np.zeros((8, 8, 8), bool)
    solid[2:5] = True
    f = image_fields(solid, 1e-6)
    assert f.porosity == pytest.approx(1 - 3 / 8, abs=1e-15)
    assert f.porosity_error == 0.0


def test_estimate_shrinks_with_the_voxel() -> None:
    """One rod (d = 0.3 periods): the estimate at 64 voxels per period is below a third of the
    one at 16 (the count converges as h^1-h^1.5 on a smooth surface)."""
    fb = make_fiber("rod", diameter=0.3, center=[0.43, 0.52, 0.5], direction=[0.2, 0.1, 1.0])
    rve = RVE(size=np.full(3, L), fibers=[fb])
    coarse, fine = (rve.voxelize(L / n).porosity_error for n in (16, 64))
    assert fine < coarse / 3
    assert porosity_error(rve.voxelize(L / 64).distance, L / 64, 0.5) > 0.1  # a wrong count shows


def test_intersection_estimate_covers_the_steinmetz_volume():
    """Omega of two perpendicular cylinders of radius r crossing at their centres: the
    Steinmetz solid, 16 r^3 / 3 exactly. On 60 cases (20 pairs at 16, 24 and 32 voxels per
    period; not the calibration set) the estimate (count_fraction_error) covers the count's true
    error in at least 90 % and is a small multiple of it; its two-grid term alone (a wrong
    estimate without the rounding of runs of faces) covers less, and no intersection gives 0."""
    rng = np.random.default_rng(12)
    err, est, two_grid = [], [], []
    for _ in range(20):
        d, c = rng.uniform(0.15, 0.4), rng.uniform(0, 1, 3)
        pair = [
            make_fiber("cylinder", diameter=d, center=c, direction=u)
            for u in ([1, 0, 0], [0, 0, 1])
        ]
        for n in (16, 24, 32):
            f = RVE(size=np.full(3, L), fibers=pair).voxelize(L / n)
            err.append(abs(f.intersection_volume_fraction - 16 * (d / 2) ** 3 / 3))
            est.append(f.intersection_error)
            m = f.count >= 2
            two_grid.append(abs(m.mean() - m[::2, ::2, ::2].mean()))
    err, est, two_grid = np.array(err), np.array(est), np.array(two_grid)
    assert np.mean(err <= est) >= 0.9
    assert np.median(est / err) < 15.0
    assert np.mean(err <= two_grid) < np.mean(err <= est)
    apart = [
        make_fiber("cylinder", diameter=0.2, center=[0.5, 0.5, z], direction=[1, 0, 0])
        for z in (0.2, 0.6)
    ]
    assert RVE(size=np.full(3, L), fibers=apart).voxelize(L / 16).intersection_error == 0.0


def _z_cylinder(n: int, d: float, centre: list[float]) -> VoxelFields:
    """One cylinder along z (diameter ``d`` periods) on ``n`` voxels per period, two deep."""
    fb = make_fiber("cylinder", diameter=d, center=centre, direction=[0, 0, 1])
    return RVE(size=np.array([L, L, 2 * L / n]), fibers=[fb], period=L).voxelize(L / n)


@pytest.mark.parametrize(
    "n,solid,on",
    [
        (32, 0.05, "corner"),  # session 37's cyl_d_8vox_phi0.05: 0.94922 +- 6.5e-4, 0.83x
        (40, 0.7, "corner"),  # session 37's cyl_phi0.7_across: 0.2975 +- 2.2e-3, 0.87x
        (16, 0.2, "corner"),
        (32, 0.6, "corner"),
        (40, 0.05, "centre"),
    ],
)
def test_voxel_aligned_circle_is_covered(n, solid, on) -> None:
    """A cylinder along z centred on a voxel corner or centre: the count is a 2-D lattice-point
    count (Gauss's circle problem) repeated along z, and the clip partial volume's own error
    has a lattice part that the coarse grid, sharing the placement's symmetry, repeats; session
    32's bar missed these by 0.65-0.87x. Truth: the solid fraction ``pi d^2 / 4`` per cell
    exactly (Sangani & Acrivos' square array, session 37's rows)."""
    d = np.sqrt(4 * solid / np.pi)
    centre = [0.5, 0.5, 0.5] if on == "corner" else [0.5 + 0.5 / n, 0.5 + 0.5 / n, 0.5]
    f = _z_cylinder(n, d, centre)
    assert abs(f.porosity - (1.0 - solid)) > 5e-4  # a real miss to cover
    assert abs(f.porosity - (1.0 - solid)) <= f.porosity_error


def test_aligned_bar_is_a_small_multiple_of_the_error() -> None:
    """40 cylinders along z, diameters 4-24 voxels at 20 and 32 voxels per period, random
    centres (not the calibration cases): the bar covers every analytic porosity ``1 - pi d^2 /
    4`` and, where the count's error is resolvable (> 1e-4), is a median under 2.5x it and
    within 5x it in at least 3 of 4 cases (a bar twice as wide fails both)."""
    rng = np.random.default_rng(21)
    err, bar = [], []
    for _ in range(40):
        n, dvox = int(rng.choice([20, 32])), rng.uniform(4, 24)
        f = _z_cylinder(n, dvox / n, [*rng.uniform(0, 1, 2), 0.5])
        err.append(abs(f.porosity - (1 - np.pi * (dvox / n) ** 2 / 4)))
        bar.append(f.porosity_error)
    err, bar = np.array(err), np.array(bar)
    assert np.all(err <= bar)
    ratio = (bar / err)[err > 1e-4]
    assert len(ratio) >= 30
    assert np.median(ratio) < 2.5
    assert np.mean(ratio <= 5.0) >= 0.75
