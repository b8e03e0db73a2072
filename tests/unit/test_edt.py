"""The periodic Euclidean distance transform (psdesign.geometry.edt) against an independent
truth: scipy's open-faced transform of the mask tiled 3x3x3 (the nearest site of a periodic
medium lies within half a period along each axis, so the middle tile's distances are the
periodic ones), and its memory: a few bytes per voxel, whatever the pore size."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from psdesign.geometry.edt import edt, periodic_edt
from psdesign.image.fields import signed_distance


def _tiled_truth(mask: np.ndarray) -> np.ndarray:
    big = np.tile(mask, (3, 3, 3))
    return distance_transform_edt(big)[tuple(slice(n, 2 * n) for n in mask.shape)]


@pytest.mark.parametrize("seed", range(6))
def test_periodic_edt_is_the_tiled_transform(seed):
    rng = np.random.default_rng(seed)
    shape = tuple(int(n) for n in rng.integers(2, 24, 3))
    mask = rng.random(shape) < rng.uniform(0.5, 0.995)
    mask.flat[rng.integers(mask.size)] = False
    np.testing.assert_allclose(periodic_edt(mask), _tiled_truth(mask), atol=1e-5)


@pytest.mark.parametrize("seed", range(4))
def test_edt_periodic_along_some_axes_is_the_transform_tiled_along_those_only(seed):
    """``periodic`` per axis: the truth tiles the mask 3 times along the periodic axes only
    (scipy's open-faced transform, nothing beyond the other faces); all open = :func:`edt`.
    Used by the breakthrough along an axis the geometry does not repeat across (session 53
    review: a channel reaching the face read 0.5 voxel wide there, the solid of the opposite
    face counted as its neighbour)."""
    rng = np.random.default_rng(100 + seed)
    shape = tuple(int(n) for n in rng.integers(2, 20, 3))
    mask = rng.random(shape) < rng.uniform(0.6, 0.99)
    mask.flat[rng.integers(mask.size)] = False
    periodic = tuple(bool(b) for b in rng.integers(0, 2, 3))
    reps = tuple(3 if p else 1 for p in periodic)
    pairs = zip(shape, periodic, strict=True)
    middle = tuple(slice(n, 2 * n) if p else slice(None) for n, p in pairs)
    truth = distance_transform_edt(np.tile(mask, reps))[middle]
    np.testing.assert_allclose(periodic_edt(mask, periodic), truth, atol=1e-5)
    np.testing.assert_allclose(periodic_edt(mask, (False,) * 3), edt(mask), atol=1e-5)


def test_a_single_site_is_at_most_half_a_period_away():
    """One solid voxel in a 9 x 10 x 11 period: the farthest point is the box's opposite
    corner, (4, 5, 5) voxels away."""
    mask = np.ones((9, 10, 11), bool)
    mask[0, 0, 0] = False
    d = periodic_edt(mask)
    assert d.max() == pytest.approx(np.sqrt(4**2 + 5**2 + 5**2), abs=1e-6)
    assert d[1, 9, 10] == pytest.approx(np.sqrt(3), abs=1e-6)  # across three faces


def test_open_faced_edt_sees_nothing_beyond_the_faces():
    mask = np.ones((1, 1, 6), bool)
    mask[0, 0, 0] = False
    np.testing.assert_allclose(edt(mask)[0, 0], [0, 1, 2, 3, 4, 5])
    np.testing.assert_allclose(periodic_edt(mask)[0, 0], [0, 1, 2, 3, 2, 1])


def test_refuses_a_mask_without_a_site():
    with pytest.raises(ValueError, match="at least one False"):
        periodic_edt(np.ones((3, 3, 3), bool))


def test_signed_distance_memory_does_not_grow_with_the_pores():
    """A slab of solid in a 64^3 image leaves one pore half a period wide: padding the mask by
    that much for scipy's transform peaked at ~410 B per voxel (session 33); the in-place
    transform holds two float32 arrays and a few masks."""
    solid = np.zeros((64, 64, 64), bool)
    solid[:2] = True
    signed_distance(solid[:4, :4, :4], 1e-6)  # compiled before the trace
    tracemalloc.start()
    d = signed_distance(solid, 1e-6)
    peak = tracemalloc.get_traced_memory()[1] / solid.size
    tracemalloc.stop()
    assert peak < 16, peak
    assert d[32, 5, 7] == pytest.approx(30.5e-6, rel=1e-6)  # 31 voxels to the slab, minus 1/2
