"""The fibre-structure statistics of ``benchmarks/paper_table3_voxel.py`` on closed-form layouts.

Two parallel rods a known distance apart (nearest-neighbour axis distance, contact fraction),
rods along x and along y (orientation tensor and in-plane angle), a tilted rod (tilt angle).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import load_benchmark

from psdesign.geometry.fibers import make_fiber
from psdesign.geometry.rve import RVE

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def stats():
    return load_benchmark("paper_table3_voxel")


def _rve(fibers) -> RVE:
    return RVE(size=np.array([100e-6] * 3), fibers=fibers)


def test_nearest_neighbour_axis_distance_of_two_parallel_rods(stats):
    d = 0.07  # 7 um in a 100 um period
    a = make_fiber("rod", diameter=d, center=[0.5, 0.30, 0.5], direction=[1, 0, 0])
    b = make_fiber("rod", diameter=d, center=[0.5, 0.42, 0.5], direction=[1, 0, 0])
    out = stats.clustering_stats(_rve([a, b]), step=0.5e-6)
    assert out["nn_axis_mean_m"] == pytest.approx(12e-6, rel=1e-6)
    assert out["nn_axis_gap_min_m"] == pytest.approx(5e-6, rel=1e-6)
    assert out["contact_fraction"] == 0.0
    c = make_fiber("rod", diameter=d, center=[0.5, 0.35, 0.5], direction=[1, 0, 0])
    out = stats.clustering_stats(_rve([a, c]), step=0.5e-6)
    assert out["nn_axis_gap_min_m"] == pytest.approx(-2e-6, rel=1e-6)  # 2 um overlap
    assert out["overlap_axis_fraction"] == 1.0


def test_orientation_of_crossed_and_tilted_rods(stats):
    d = 0.07
    x = make_fiber("rod", diameter=d, center=[0.5, 0.3, 0.3], direction=[1, 0, 0])
    y = make_fiber("rod", diameter=d, center=[0.3, 0.5, 0.7], direction=[0, 1, 0])
    out = stats.orientation_stats(_rve([x, y]))
    assert out["a_xx"] == pytest.approx(0.5, abs=1e-9)
    assert out["a_yy"] == pytest.approx(0.5, abs=1e-9)
    assert out["a_zz"] == pytest.approx(0.0, abs=1e-12)
    assert out["phi_order"] == pytest.approx(0.0, abs=1e-9)  # isotropic in plane
    t = np.radians(4.0)
    tilted = make_fiber("rod", diameter=d, center=[0.5] * 3, direction=[np.cos(t), 0, np.sin(t)])
    out = stats.orientation_stats(_rve([tilted]))
    assert out["tilt_max_deg"] == pytest.approx(4.0, abs=1e-6)
    assert out["a_zz"] == pytest.approx(np.sin(t) ** 2, rel=1e-6)
    assert out["phi_order"] == pytest.approx(1.0, abs=1e-9)


def test_layering_of_a_solid_slab(stats):
    class Fields:  # only ``solid`` is read
        solid = np.zeros((4, 4, 10), bool)

    Fields.solid[:, :, :2] = True  # two solid layers, eight empty ones
    Fields.solid[:2, :, 5] = True  # one half-solid layer
    out = stats.layering_stats(Fields)
    prof = np.array([0, 0, 1, 1, 1, 0.5, 1, 1, 1, 1])
    assert out["layer_porosity_std"] == pytest.approx(prof.std(), rel=1e-12, abs=0)
    assert out["open_layer_fraction"] == pytest.approx(0.7)
    assert out["layer_porosity_min"] == 0.0


def test_single_cylinder_export_drops_the_periodic_copy_at_a_face(stats):
    """A rod on the z = 0 face: the PS rod keeps its copy at the top face, the export does not."""
    from psdesign.packing.fiberset import FiberState

    d, size = 0.07, np.array([100e-6] * 3)
    rod = make_fiber("rod", diameter=d, center=[0.5, 0.5, 0.0], direction=[1, 0, 0])
    st = FiberState.from_fibers([rod], fixed=False)
    cyl = RVE(size=size, fibers=[make_fiber("cylinder", d, center=[0.5, 0.5, 0.0], theta=0.0,
                                            omega=0.0)])  # fmt: skip
    full = 1.0 - cyl.voxelize(0.5e-6).porosity  # whole disc: half at z = 0, half at z = L
    fibers, period = stats._single_cylinders(st, 100e-6)
    assert period == pytest.approx(stats.SINGLE_PERIOD * 100e-6)
    half = 1.0 - RVE(size=size, fibers=fibers, period=period).voxelize(0.5e-6).porosity
    area = np.pi * (3.5e-6) ** 2 / (100e-6) ** 2
    assert full == pytest.approx(area, rel=0.03)
    assert half == pytest.approx(area / 2, rel=0.03)


def test_subcube_is_the_slice_of_the_image(stats):
    rod = make_fiber("cylinder", 0.07, center=[0.5, 0.5, 0.5], theta=-90.0, omega=0.0)  # along z
    fields = _rve([rod]).voxelize(0.5e-6)
    sub = stats.subcube_fields(fields, 25e-6, 50e-6)
    assert sub.distance.shape == (100, 100, 100)
    np.testing.assert_array_equal(sub.distance, fields.distance[50:150, 50:150, 50:150])
    assert np.allclose(sub.grid.size, 50e-6, atol=0)
    assert np.allclose(sub.grid.spacing, 0.5e-6, atol=0)
    # the rod through the middle: solid share pi r^2 / (50 um)^2 of the sub-cube
    assert 1.0 - sub.porosity == pytest.approx(np.pi * 3.5**2 / 50**2, rel=0.03)
