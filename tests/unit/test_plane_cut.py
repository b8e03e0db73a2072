"""The tangent-plane partial volume (psdesign.geometry.plane_cut) against closed forms.

Truths: a unit cube cut by a plane along a face leaves ``1/2 + t`` below it; near a corner the
cut is a tetrahedron of volume ``s^3 / (6 w_1 w_2 w_3)`` (``s`` the plane's offset from the
corner); a cube is centrally symmetric, so ``F(t) + F(-t) = 1``. A half-space in a box has
its pore fraction in closed form. On a circle of radius ``R`` the plane cut errs by the
curvature term: the linearised surface misses ``(1/2) kappa s^2`` over each voxel's chord,
``s`` the tangential offset (mean square ``h^2 / 12`` on every line), summed over the circle
``(h^2 / 24) * 2 pi``, i.e. ``-pi h^2 / (12 L^2)`` of the porosity.
"""

from __future__ import annotations

import numpy as np
import pytest

from psdesign.geometry.fibers import make_fiber
from psdesign.geometry.plane_cut import WIDTH_MIN, cube_fraction_below, plane_partial_porosity
from psdesign.geometry.porosity import partial_volume_porosity
from psdesign.geometry.rve import RVE

L = 1e-4


def test_face_plane_is_the_clip() -> None:
    """Exact to 1e-7 away from the faces; within about WIDTH_MIN / 6 where the plane is a face."""
    t = np.linspace(-0.7, 0.7, 29)
    w = np.tile([0.0, 1.0, 0.0], (t.size, 1))
    got, clip = cube_fraction_below(t, w), np.clip(0.5 + t, 0, 1)
    assert got == pytest.approx(clip, abs=1.01 * WIDTH_MIN / 6)
    away = np.abs(np.abs(t) - 0.5) > 0.01
    assert got[away] == pytest.approx(clip[away], abs=1e-7)


def test_corner_tetrahedron_and_symmetry() -> None:
    rng = np.random.default_rng(4)
    w = np.abs(rng.normal(size=(50, 3)))
    w /= np.linalg.norm(w, axis=1)[:, None]
    s = 0.9 * w.min(axis=1)  # the plane cuts only the corner: a tetrahedron
    t = s - 0.5 * w.sum(axis=1)
    assert cube_fraction_below(t, w) == pytest.approx(s**3 / (6 * w.prod(axis=1)), rel=1e-6)
    u = rng.uniform(-1, 1, 50)
    assert cube_fraction_below(u, w) + cube_fraction_below(-u, w) == pytest.approx(1, abs=1e-9)


def test_half_space_is_exact() -> None:
    """Solid below the plane ``n . x = c`` in a 12^3 box (no wrap): the plane cut gives the
    solid wedge's volume exactly; the clip partial volume does not (a tilted plane)."""
    n = np.array([0.48, 0.6, 0.64])
    axes = np.meshgrid(*[np.arange(12) + 0.5] * 3, indexing="ij")
    d = (n[0] * axes[0] + n[1] * axes[1] + n[2] * axes[2] - 3.1).astype(np.float32)
    true = 1 - 3.1**3 / (6 * n.prod()) / 12**3  # the corner tetrahedron, inside the box
    assert 3.1 / n.max() < 12
    assert plane_partial_porosity(d, 1.0) == pytest.approx(true, abs=1e-6)
    assert abs(partial_volume_porosity(d, 1.0) - true) > 1e-4


@pytest.mark.parametrize(
    "n,dvox,centre",
    [(32, 8, "corner"), (20, 10, "off"), (40, 30, "corner"), (24, 13, "off"), (48, 20, "centre")],
)
def test_circle_error_is_the_curvature_term(n, dvox, centre) -> None:
    """Cylinders along z (8-30 voxels across, any placement): the plane cut's porosity errs by
    ``-pi h^2 / (12 L^2)`` within 25 % (module docstring; it is smooth in h, which the bar's
    two-grid change relies on)."""
    c = {"corner": [0.5, 0.5, 0.5], "centre": [0.5 + 0.5 / n] * 2 + [0.5], "off": [0.31, 0.47, 0.5]}
    fb = make_fiber("cylinder", diameter=dvox / n, center=c[centre], direction=[0, 0, 1])
    f = RVE(size=np.array([L, L, 2 * L / n]), fibers=[fb], period=L).voxelize(L / n)
    true = 1 - np.pi * (dvox / n) ** 2 / 4
    curvature = -np.pi / (12 * n * n)
    assert plane_partial_porosity(f.distance, L / n) - true == pytest.approx(curvature, rel=0.25)


def test_clip_error_on_a_centred_circle_is_not_the_curvature_term() -> None:
    """The cause of session 37's misses: on a circle centred on a voxel corner the clip partial
    volume's error has a lattice part: 1.66x and -1.37x the curvature term on these two."""
    for n, dvox in ((32, 8), (40, 30)):
        fb = make_fiber("cylinder", diameter=dvox / n, center=[0.5] * 3, direction=[0, 0, 1])
        f = RVE(size=np.array([L, L, 2 * L / n]), fibers=[fb], period=L).voxelize(L / n)
        true = 1 - np.pi * (dvox / n) ** 2 / 4
        ratio = (partial_volume_porosity(f.distance, L / n) - true) / (-np.pi / (12 * n * n))
        assert abs(ratio - 1) > 0.5


def test_slabs_do_not_change_the_sum(monkeypatch) -> None:
    """The gradient reaches one plane past each slab: one-plane slabs give the whole grid's
    value (a tilted PS rod, 48 voxels per period)."""
    import psdesign.geometry.plane_cut as plane_cut

    fb = make_fiber("rod", diameter=0.3, center=[0.43, 0.52, 0.5], direction=[0.2, 0.1, 1.0])
    f = RVE(size=np.full(3, L), fibers=[fb]).voxelize(L / 48)
    whole = plane_partial_porosity(f.distance, L / 48)
    monkeypatch.setattr(plane_cut, "SLAB_VOXELS", 1)
    assert plane_partial_porosity(f.distance, L / 48) == pytest.approx(whole, abs=1e-12)
