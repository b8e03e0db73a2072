"""Intersection removal: geometry primitives, the fast placement, the GA."""

from __future__ import annotations

import numpy as np
import pytest

from psdesign.geometry.rve import RVE
from psdesign.packing.intersections import (
    FiberState,
    GASettings,
    PlacementSettings,
    analytic_omega,
    carrier_lengths,
    crossing_volume,
    genetic,
    place_sequential,
    segment_distance,
)

LO, HI = np.zeros(3), np.ones(3)


def _random_state(n, d=0.07, seed=0, bent=False, fmax=10.0):
    rng = np.random.default_rng(seed)
    return FiberState(
        diameter=np.full(n, d),
        center=rng.uniform(0, 1, (n, 3)),
        theta=rng.uniform(-5, 5, n),
        omega=rng.uniform(0, 180, n),
        u=rng.uniform(0.1, 0.3, n) if bent else np.zeros(n),
        f=rng.uniform(1, fmax, n) if bent else np.ones(n),
        fixed=np.zeros(n, bool),
    )


def _bent_z(centers, d, u, f):
    """Bent fibers along z (theta = omega = 0), fixed, of diameter ``d``, at ``centers``."""
    centers = np.atleast_2d(np.asarray(centers, float))
    n = len(centers)
    return FiberState(
        diameter=np.full(n, d),
        center=centers,
        theta=np.zeros(n),
        omega=np.zeros(n),
        u=np.full(n, u),
        f=np.full(n, f),
        fixed=np.ones(n, bool),
    )


def _min_axis_distance(rve_fibers, lo, hi, n=400):
    """Brute force over densely resampled medial axes (Fiber.medial_axis, independent code)."""
    pts, owner = [], []
    for i, fb in enumerate(rve_fibers):
        for line in fb.medial_axis(lo, hi, n):
            seg = np.linalg.norm(np.diff(line, axis=0), axis=1)
            s = np.r_[0, np.cumsum(seg)]
            t = np.linspace(0, s[-1], max(2, int(s[-1] / 0.002)))
            p = np.column_stack([np.interp(t, s, line[:, k]) for k in range(3)])
            pts.append(p)
            owner.append(np.full(len(p), i))
    pts, owner = np.vstack(pts), np.concatenate(owner)
    from scipy.spatial import cKDTree

    tree = cKDTree(pts)
    pairs = tree.query_pairs(0.2, output_type="ndarray")
    other = owner[pairs[:, 0]] != owner[pairs[:, 1]]
    pairs = pairs[other]
    return np.min(np.linalg.norm(pts[pairs[:, 0]] - pts[pairs[:, 1]], axis=1))


def test_frames_match_make_fiber():
    st = _random_state(20, seed=3)
    for fb, fr in zip(st.to_fibers(), st.frames, strict=True):
        assert np.allclose(fb.direction, fr[0]) and np.allclose(fb.lattice, fr[1:])


def test_segment_distance_against_sampling():
    rng = np.random.default_rng(1)
    p1, q1, p2, q2 = (rng.uniform(-1, 1, (200, 3)) for _ in range(4))
    d, c1, c2 = segment_distance(p1, q1, p2, q2)
    t = np.linspace(0, 1, 801)
    for k in range(0, 200, 20):
        a = p1[k] + t[:, None] * (q1[k] - p1[k])
        b = p2[k] + t[:, None] * (q2[k] - p2[k])
        brute = np.min(np.linalg.norm(a[:, None] - b[None], axis=2))
        assert d[k] <= brute + 1e-12 and d[k] == pytest.approx(brute, abs=2e-3)
        assert np.linalg.norm(c1[k] - c2[k]) == pytest.approx(d[k])


def test_crossing_volume_steinmetz_and_separation():
    r = 0.05
    v = crossing_volume(
        np.array([0.0, 2 * r, 0.03]), np.full(3, r), np.full(3, r), np.array([1.0, 1.0, 1.0])
    )
    assert v[0] == pytest.approx(16 * r**3 / 3, rel=1e-3)  # Steinmetz bicylinder
    assert v[1] == 0.0
    # Monte Carlo of two perpendicular cylinders with axes 0.03 apart
    rng = np.random.default_rng(0)
    p = rng.uniform(-r, r, (400_000, 3))
    inside = (p[:, 1] ** 2 + p[:, 2] ** 2 <= r * r) & (
        p[:, 0] ** 2 + (p[:, 2] - 0.03) ** 2 <= r * r
    )
    mc = inside.mean() * (2 * r) ** 3
    assert v[2] == pytest.approx(mc, rel=0.03)


def test_carrier_length_density_is_one_per_period():
    # a fiber is a lattice of lines with one line per unit cross-section: averaged over
    # uniform lattice offsets, the length inside the box equals its volume
    st = _random_state(3000, seed=2)
    rng = np.random.default_rng(5)
    st.theta = rng.uniform(-90, 90, 3000)
    st.refresh_frames()
    t = rng.uniform(0, 1, (3000, 2))
    st.center = t[:, :1] * st.frames[:, 1] + t[:, 1:] * st.frames[:, 2]
    assert carrier_lengths(st, LO, HI).mean() == pytest.approx(1.0, rel=0.02)


@pytest.mark.parametrize("bent", [False, True])
def test_fast_placement_zero_overlap_and_min_gap(bent):
    gap = 0.01
    st = _random_state(25 if not bent else 18, seed=4, bent=bent, fmax=3.0)
    before = RVE([1e-4] * 3, st.to_fibers()).voxelize(1e-6)
    assert before.intersection_volume_fraction > 0  # the drawn set does intersect
    res = place_sequential(st, LO, HI, PlacementSettings(gap=gap))
    assert len(res.rejected) == 0 and len(res.state) == len(st)
    fibers = res.state.to_fibers()
    vf = RVE([1e-4] * 3, fibers).voxelize(1e-6)
    assert vf.intersection_volume_fraction == 0.0
    dmin = _min_axis_distance(fibers, LO - 0.04, HI + 0.04)
    assert dmin >= 0.07 + gap - 2e-3  # D + gap, up to the resampling step
    # orientations are unchanged when every fiber found a place by translation
    assert np.allclose(res.state.direction, st.direction)
    assert analytic_omega(res.state, LO, HI) == 0.0


def test_fixed_fibers_are_not_moved():
    st = _random_state(15, seed=6)
    st.fixed[:5] = True
    res = place_sequential(st, LO, HI)
    assert np.array_equal(res.state.center[:5], st.center[:5])


def test_ga_stays_in_adjustment_ranges_and_never_worsens():
    st = _random_state(10, seed=7)
    res = genetic(st, LO, HI, np.ones(3), GASettings(population=10, generations=5), seed=1)
    assert res.objective_final <= res.objective_initial
    assert res.objective_initial > 0
    assert np.all(np.abs(res.state.theta - st.theta) <= 1.0 + 1e-9)
    assert np.all(np.abs(res.state.omega - st.omega) <= 1.0 + 1e-9)
    assert np.all(np.abs(res.state.center - st.center) <= 0.1 + 1e-9)
    assert res.objective_final == pytest.approx(analytic_omega(res.state, LO, HI))


def test_carrier_length_times_area_predicts_voxel_solid():
    # sum over single fibers of (exact rod area x carrier length in box) vs voxel counts;
    # per fiber the box edges make +-2 %, the sum over random fibers agrees to < 1 %
    from psdesign.geometry.fibers import rod_cross_section_area

    st = _random_state(12, d=0.1, seed=9)
    pred = rod_cross_section_area(0.1) * carrier_lengths(st, LO, HI)
    vox = [1 - RVE([1e-4] * 3, [fb]).voxelize(0.5e-6).porosity for fb in st.to_fibers()]
    assert np.sum(vox) == pytest.approx(np.sum(pred), rel=0.01)


def test_max_shift_z_bounds_the_through_plane_moves():
    st = _random_state(25, seed=8)
    res = place_sequential(st, LO, HI, PlacementSettings(max_shift_z=0.05, on_reject="skip"))
    assert np.all(np.abs(res.shift[:, 2]) <= 0.05 + 1e-9)
    assert np.max(np.abs(res.shift[:, :2])) > 0.05  # in-plane moves stay free
    vf = RVE([1e-4] * 3, res.state.to_fibers()).voxelize(1e-6)
    assert vf.intersection_volume_fraction == 0.0


def test_ejection_places_every_fiber_and_reports_matching_rows():
    # dense enough that plain sequential placement rejects fibers
    st = _random_state(50, seed=1)
    plain = place_sequential(st, LO, HI, PlacementSettings(max_ejections=0))
    assert len(plain.rejected) > 0
    res = place_sequential(st, LO, HI, PlacementSettings(max_ejections=2))
    assert len(res.rejected) < len(plain.rejected)
    # rows of state / shift refer to res.placed (placement order)
    assert np.allclose(res.state.center - st.center[res.placed], res.shift)
    assert np.allclose(res.state.direction, st.direction[res.placed])
    vf = RVE([1e-4] * 3, res.state.to_fibers()).voxelize(1e-6)
    assert vf.intersection_volume_fraction == 0.0


def test_fine_bends_are_cut_by_diameter_not_by_wave():
    """Session 37 edge audit: at generator.f = 1000 (its upper end) every fiber copy was cut
    into 8 pieces per bend, 8000 per period, and the contact search's pairs within a diameter
    of a 50 um box's eight fibers filled 22.7 GB (killed by the kernel). Pieces are now no
    shorter than D / 64, the chord's sag bounded by twice the amplitude, and contacts stay
    exact: two copies of one bent axis translated by ``gap`` normal to its bend plane are
    ``gap`` apart everywhere (the truth), so they touch iff ``gap < D`` (+ the sag slack)."""
    from psdesign.packing.fiberset import build_pieces, find_contacts

    d, u, f = 0.16, 0.01, 1000.0  # |u| f = 10, the largest allowed
    amp = u / (2 * np.pi)
    for gap, touch in ((0.95 * d, True), (d + 4 * amp + 0.01, False)):
        one = _bent_z([0.5, 0.5, 0.5], d, u, f)
        normal = one.frames[0, 2]  # normal to the bend plane (direction, lattice1)
        st = _bent_z([[0.5, 0.5, 0.5], [0.5, 0.5, 0.5] + gap * normal], d, u, f)
        pieces = build_pieces(st, LO, HI, 0.5 * d, 2 * d)
        per_copy = np.bincount(pieces.copy) / pieces.copy_len
        assert per_copy.max() <= 64 / d + 1  # was 8 f = 8000 per period
        assert pieces.sag.max() <= 2 * amp + 1e-15
        c = find_contacts(st, LO, HI, 0.0)
        assert (len(c) > 0) == touch
        if touch:
            assert c.dist.min() == pytest.approx(gap, rel=1e-9)


def test_fine_bends_give_capsules_a_diameter_apart_and_the_free_shifts_of_a_translated_copy():
    """Session 38 (the edge audit's ``bent_fast_f_max``: generator.f = 1000, 6 fibers in a
    50 um box, ``fast``: past 300 s, 3 of 6 placed in 31 s, in ``sequential``'s capsules):
    each old piece's axial window was cut into sub-intervals of a twelfth of a bend,
    ~3 800 capsules per piece, millions per search. Sub-intervals are now no shorter than
    D / 64 (as the pieces, f70f707). Truth: the fiber's copy translated by t in its lattice
    plane is between |t| - 2 amp and |t| away from it (triangle inequality: the axes differ
    by t plus an axial step plus a bend offset of at most 2 amp along l1), so a shift with
    periodic |t| < D - 2 amp must be blocked and one with |t| >= D + 4 amp (the sag slack of
    the pieces, 2 amp, plus the capsules' sway, amp) must be free."""
    from psdesign.packing.fiberset import MIN_PIECE_DIAMETERS, pieces_for
    from psdesign.packing.sequential import _capsules, _free_shift_raster

    d, u, f = 0.16, 0.01, 1000.0  # |u| f = 10, the largest allowed
    amp = u / (2 * np.pi)
    st = _bent_z([0.5, 0.5, 0.5], d, u, f)
    old = pieces_for(st, LO, HI, 0.0, 0.5 * d)  # as the placer: pieces of half a diameter
    A, B, lim, owner = _capsules(st, old, st.diameter, 0.0)
    window = (np.linalg.norm(old.b - old.a, axis=1).max() + 2 * lim.max()) / (
        MIN_PIECE_DIAMETERS * d
    )
    assert len(A) <= len(old.a) * (window + 2)  # was 1 / (12 f) wide: ~30x as many
    assert np.all(owner == 0)
    k = 25  # the placer's grid: step D / 4
    free = _free_shift_raster(st, old, st.diameter, 0.0, k)
    g = (np.arange(k) - k // 2) / k
    t1, t2 = np.meshgrid(g, g, indexing="ij")
    per = np.hypot(t1 - np.round(t1), t2 - np.round(t2))  # nearest lattice copy
    near, far = per < d - 2 * amp, per >= d + 4 * amp
    assert near.sum() > 20 and far.sum() > 400
    assert not free[near].any()
    assert free[far].all()
