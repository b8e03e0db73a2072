"""Pore structure against shapes of known size (issue 13): local thickness of a cylinder,
sphere and slit pore, intrusion through a narrow neck (ink bottle), marching-cubes surface of
a sphere and a cylinder, porosity profile, orientation tensor."""

from __future__ import annotations

import numpy as np
import pytest

from psdesign.geometry.rve import VoxelFields, VoxelGrid
from psdesign.transport.pores import (
    orientation_tensor,
    pore_sizes,
    porosity_profile,
    specific_surface,
)

H = 1e-6


def _fields(distance_vox: np.ndarray) -> VoxelFields:
    """VoxelFields from a signed distance in voxels (> 0 pore), H metres per voxel."""
    d = (distance_vox * H).astype(np.float32)
    shape = d.shape
    grid = VoxelGrid(size=np.array(shape, float) * H, shape=shape, spacing=np.full(3, H))
    return VoxelFields(distance=d, count=(d <= 0).astype(np.uint8), grid=grid)


def _coords(shape):
    return np.meshgrid(*[np.arange(n) + 0.5 for n in shape], indexing="ij")


@pytest.mark.parametrize("radius", [6.0, 11.0])
def test_cylinder_pore_local_thickness_is_its_diameter(radius):
    n = 41  # odd: the axis passes through voxel centres
    X, Y, Z = _coords((n, n, 8))
    dist = radius - np.sqrt((X - n / 2) ** 2 + (Y - n / 2) ** 2)
    res = pore_sizes(_fields(dist), n_radii=24)
    assert res.pore_d50_m == pytest.approx(2 * radius * H, abs=res.bin_width_m)
    assert res.pore_d90_m == pytest.approx(2 * radius * H, abs=res.bin_width_m)
    assert res.max_diameter_m == pytest.approx(2 * radius * H, rel=1e-3)
    assert sum(res.volume_fraction) == pytest.approx(1.0)


def test_sphere_pore_local_thickness():
    n, radius = 33, 12.0
    X, Y, Z = _coords((n, n, n))
    dist = radius - np.sqrt((X - n / 2) ** 2 + (Y - n / 2) ** 2 + (Z - n / 2) ** 2)
    res = pore_sizes(_fields(dist), n_radii=24)
    assert res.pore_d50_m == pytest.approx(2 * radius * H, abs=res.bin_width_m)


def test_slit_pore_local_thickness_is_its_width():
    X, Y, Z = _coords((40, 40, 24))
    width = 10.0
    dist = width / 2 - np.abs(Z - 12.5)  # a slit between two plates, gap 10 voxels
    res = pore_sizes(_fields(dist), n_radii=20)
    assert res.pore_d50_m == pytest.approx(width * H, abs=res.bin_width_m)
    # a slit is reached from the inlet face (z = 0 layer is solid) only along x or y
    res_x = pore_sizes(_fields(dist), n_radii=20, thickness_axis="x")
    assert res_x.breakthrough_diameter_m == pytest.approx(width * H, abs=res_x.bin_width_m)


def test_intrusion_ink_bottle_fills_the_cavity_at_the_neck_size():
    """A cavity of radius 10 behind a neck of radius 3 from the inlet face (z = 0): the
    cavity is invaded only when the accessible diameter reaches the neck's."""
    shape = (41, 41, 60)
    X, Y, Z = _coords(shape)
    rxy = np.sqrt((X - 20.5) ** 2 + (Y - 20.5) ** 2)
    neck = 3.0 - rxy  # along z
    cavity = 10.0 - np.sqrt(rxy**2 + (Z - 40.5) ** 2)
    dist = np.maximum(np.where(Z < 40, neck, -1.0), cavity)
    res = pore_sizes(_fields(dist), n_radii=30, thickness_axis="z")
    sat = np.array(res.intrusion_saturation)
    diam = np.array(res.intrusion_diameter_m)
    neck_d = 6.0 * H
    assert np.all(sat[diam > neck_d + res.bin_width_m] == 0.0)  # larger than the neck: nothing
    first = np.nonzero(diam <= neck_d + 1e-12)[0][0]
    assert sat[first] > 0.7  # the cavity (3/4 of the pore volume) fills at the neck size
    assert sat[-1] > 0.9  # what is left are sub-voxel corners at the walls
    # the bottle has a bottom (solid beyond the cavity, z > 50.5): it fills but nothing crosses
    assert res.breakthrough_diameter_m is None
    # local thickness (no access constraint) sees the cavity at its own size
    assert res.max_diameter_m == pytest.approx(20.0 * H, rel=0.02)


def test_specific_surface_of_a_sphere_and_a_cylinder():
    n = 48
    X, Y, Z = _coords((n, n, n))
    r = 15.0
    sphere = np.sqrt((X - 24) ** 2 + (Y - 24) ** 2 + (Z - 24) ** 2) - r  # solid sphere
    s = specific_surface(_fields(sphere))
    assert s.area_m2 == pytest.approx(4 * np.pi * (r * H) ** 2, rel=0.005)
    cyl = np.sqrt((X - 24) ** 2 + (Y - 24) ** 2) - r  # solid cylinder along z, periodic in z
    c = specific_surface(_fields(cyl))
    assert c.area_m2 == pytest.approx(2 * np.pi * r * H * n * H, rel=0.005)
    assert c.specific_surface_m_1 == pytest.approx(c.area_m2 / (n * H) ** 3)
    assert c.rel_error < 0.01


def test_specific_surface_counts_no_wall_at_a_face_the_geometry_does_not_repeat_across():
    """Closed forms: a cylinder (radius r) lying on the z = 0 face of the box is a half
    cylinder inside it, lateral area ``pi r L``; a cylinder along z with a sphere (radius R)
    centred on the top face: ``2 pi r L_z + 2 pi R^2``. The box faces are no surface (session
    52: a wrapped seam added the flat cut, 9731 1/m for 6109 on the walk's spec)."""
    nx, nz = 48, 24
    X, Y, Z = _coords((nx, nx, nz))
    r = 7.0
    half = np.sqrt((Y - 24) ** 2 + Z**2) - r  # along x, axis on the z = 0 face
    s = specific_surface(_fields(half))
    assert s.area_m2 == pytest.approx(np.pi * r * H * nx * H, rel=0.005)
    assert s.extra["periodic_axes"] == "xy"
    assert abs(s.coarse_specific_surface_m_1 / s.specific_surface_m_1 - 1) < 0.01
    rs, big = 4.0, 9.0
    rod = np.sqrt((X - 10) ** 2 + (Y - 10) ** 2) - rs
    cap = np.sqrt((X - 32) ** 2 + (Y - 32) ** 2 + (Z - nz) ** 2) - big
    c = specific_surface(_fields(np.minimum(rod, cap)))
    truth = 2 * np.pi * rs * H * nz * H + 2 * np.pi * (big * H) ** 2
    assert c.area_m2 == pytest.approx(truth, rel=0.01)
    assert c.extra["periodic_axes"] == "xy"
    assert c.rel_error < 0.02


def test_specific_surface_of_a_cylinder_on_a_face_of_an_rve():
    """The RVE's fibres judge the faces (the analytic end-plane test of the permeameter's
    copies): one D = 7 um cylinder on the z = 0 face of a 60x60x30 um box, S_v of the half
    cylinder ``pi (D/2) L / V`` = 6109 1/m within its bar."""
    import psdesign

    spec = {
        "rve": {"size": [60e-6, 60e-6, 30e-6], "voxel": 1e-6},
        "flow": {"solver": "voxel"},
        "fibers": [{"shape": "cylinder", "diameter": 7e-6, "center": [30e-6, 30e-6, 0.0]}],
    }
    m = psdesign.build(spec)
    s = specific_surface(m.fields, rve=m.rve)
    truth = np.pi * 3.5e-6 * 60e-6 / (60e-6 * 60e-6 * 30e-6)
    assert s.specific_surface_m_1 == pytest.approx(truth, rel=0.01)
    assert s.extra["periodic_axes"] == "xy"
    assert abs(s.specific_surface_m_1 / truth - 1) <= max(s.rel_error, 0.005)


def test_porosity_profile_of_layers():
    X, Y, Z = _coords((10, 10, 20))
    dist = np.where(Z < 5, -1.0, 1.0)
    dist[:5, :, 10:] = -1.0  # half of the upper layers solid
    prof = porosity_profile(_fields(dist), "z")
    expect = np.r_[np.zeros(5), np.ones(5), np.full(10, 0.5)]
    assert np.allclose(prof["porosity"], expect)
    assert prof["position_m"][0] == pytest.approx(0.5 * H, rel=1e-6, abs=0)


def test_orientation_tensor():
    from psdesign.geometry.fibers import make_fiber
    from psdesign.geometry.rve import RVE

    fx = make_fiber("rod", diameter=0.07, center=[0.5, 0.5, 0.5], direction=[1, 0, 0])
    fy = make_fiber("rod", diameter=0.07, center=[0.5, 0.3, 0.5], direction=[0, 1, 0])
    a = orientation_tensor(RVE(size=[1e-4] * 3, fibers=[fx, fy]))
    assert np.allclose(a["tensor"], np.diag([0.5, 0.5, 0.0]), atol=1e-9)
    assert sum(a["eigenvalues"]) == pytest.approx(1.0)


@pytest.mark.parametrize("bad", [3, None, "rve.toml"])
def test_orientation_tensor_refuses_what_is_not_an_rve_naming_rve(bad):
    """Session 47: ``orientation_tensor(3)`` raised ``AttributeError`` (product rule: one line
    naming the key, never a traceback)."""
    from psdesign.errors import SpecError

    with pytest.raises(SpecError, match=r"^rve: must be an RVE .*got ") as e:
        orientation_tensor(bad)
    assert "\n" not in str(e.value)


def test_cropped_ball_unions_equal_the_whole_grid_transform():
    """The per-cluster boxes (merged where that is cheaper) give the same ball union, bit for
    bit, as one distance transform of the whole grid: many small clusters, one large one and
    clusters at the grid faces, for radii from 1 to 8 voxels."""
    from scipy import ndimage

    from psdesign.transport import pores

    rng = np.random.default_rng(3)
    field = ndimage.gaussian_filter(rng.standard_normal((48, 40, 36)), 2.0)
    for q in (0.6, 0.95):
        seeds = field > np.quantile(field, q)
        lab, n = ndimage.label(seeds)
        boxes = ndimage.find_objects(lab)
        ids = np.arange(1, n + 1)
        for part in (ids, ids[::2]):
            lut = np.zeros(n + 1, bool)
            lut[part] = True
            for r in (1.0, 3.5, 8.0):
                whole = pores.edt(~lut[lab]) <= r
                np.testing.assert_array_equal(pores._ball_union(lab, boxes, part, r), whole)


@pytest.mark.parametrize(
    "kind,centre,loss",
    [("slit", 12.0, 1.0), ("cylinder", 20.0, np.sqrt(2.0)), ("sphere", 16.0, np.sqrt(3.0))],
)
def test_pore_between_voxel_centres_is_covered_by_the_error_bar(kind, centre, loss):
    """A slit (width 10), cylinder (diameter 12) or sphere (diameter 16) pore whose mid-plane,
    axis or centre lies on a voxel face, edge or corner (exact width from the construction,
    Hildebrand & Ruegsegger 1997's definition): the inscribed balls are centred on voxel centres,
    so the local thickness is low by up to sqrt(3) voxels (one, sqrt 2, sqrt 3 here); the error
    bar must cover it and the error must have its stated sign (never above the truth)."""
    if kind == "slit":
        X, Y, Z = _coords((24, 24, 25))
        true_d, dist, axis = 10.0, 5.0 - np.abs(Z - centre), "x"
    elif kind == "cylinder":
        X, Y, Z = _coords((41, 41, 8))
        true_d, axis = 12.0, "z"
        dist = 6.0 - np.sqrt((X - centre) ** 2 + (Y - centre) ** 2)
    else:
        X, Y, Z = _coords((33, 33, 33))
        true_d, axis = 16.0, "z"
        dist = 8.0 - np.sqrt((X - centre) ** 2 + (Y - centre) ** 2 + (Z - centre) ** 2)
    res = pore_sizes(_fields(dist), n_radii=16, thickness_axis=axis)
    for d in (res.pore_d10_m, res.pore_d50_m, res.pore_d90_m, res.max_diameter_m):
        assert d / H == pytest.approx(true_d - loss, abs=1e-3)  # the centre offset, no more
        assert true_d * H - d <= res.rel_error * res.pore_d50_m + 1e-12  # the bar covers it
    assert res.diameter_error_m == pytest.approx(res.bin_width_m + np.sqrt(3.0) * H)


def test_intrusion_equals_local_thickness_when_every_pore_reaches_the_inlet():
    """Two straight cylinder pores (radii 4 and 9 voxels) along the intrusion axis: every ball
    centre is connected to the inlet, so the intruded fraction at diameter d is exactly the pore
    volume whose local thickness is >= d (PoreSpy's porosimetry vs local_thickness on an
    accessible medium), and it never decreases as the diameter falls."""
    X, Y, Z = _coords((60, 30, 12))
    small = 4.0 - np.sqrt((X - 15.5) ** 2 + (Y - 15.5) ** 2)
    large = 9.0 - np.sqrt((X - 40.5) ** 2 + (Y - 15.5) ** 2)
    res = pore_sizes(_fields(np.maximum(small, large)), n_radii=24, thickness_axis="z")
    sat = np.array(res.intrusion_saturation)  # at decreasing diameters
    assert np.all(np.diff(sat) >= 0)
    above = 1.0 - np.r_[0.0, np.cumsum(res.volume_fraction)][:-1]  # thickness >= d, ascending d
    np.testing.assert_allclose(sat, above[::-1], atol=1e-12)
    large_share = np.count_nonzero(large > 0) / np.count_nonzero(np.maximum(small, large) > 0)
    assert sat[0] == pytest.approx(large_share)  # the first step fills the large pore, whole
    assert res.breakthrough_diameter_m == pytest.approx(18.0 * H, rel=1e-3)


def test_porosity_profile_across_a_cylinder_array_within_its_bound():
    """Square array of cylinders along z (solid fraction 0.5, 32 voxels per spacing) through
    the product path: each x layer's pore fraction against the exact layer average of the
    chord fraction 1 - 2 sqrt(R^2 - (x - c)^2) / L (integrated over the layer), within the
    profile's stated bound (measured: largest error 0.048, bound 0.06-0.31 where the surface
    crosses a layer, mean 0.13, loosest where a layer is tangent to the cylinder)."""
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    a, n, f = 20e-6, 32, 0.5
    radius = np.sqrt(f * a * a / np.pi)
    fiber = {
        "shape": "cylinder",
        "diameter": 2 * radius,
        "center": [a / 2] * 3,
        "direction": [0, 0, 1],
    }
    spec = validate_spec({"rve": {"size": [a] * 3, "voxel": a / n}, "fibers": [fiber]})
    prof = porosity_profile(build_rve(spec).voxelize(a / n), "x")
    h = a / n
    sub = (np.arange(400) + 0.5) / 400  # 400 sub-slices per layer
    x = (np.arange(n)[:, None] + sub[None, :]) * h
    chord = 2 * np.sqrt(np.clip(radius**2 - (x - a / 2) ** 2, 0.0, None))
    truth = (1 - chord / a).mean(axis=1)
    err = np.array(prof["porosity_error"])
    assert np.all(np.abs(np.array(prof["porosity"]) - truth) <= err + 1e-3)
    assert err.mean() < 0.15 and np.abs(np.array(prof["porosity"]) - truth).max() > 0.005


def test_pore_sizes_past_the_box_are_untrustworthy():
    """A d90 above the RVE's smallest edge is no pore size of the material (the session-31
    audit measured d90 = 134 um in the 100 um three-rod cube, rated ok, when the local
    thickness still stopped at open faces). Otherwise the rating is the error bars'."""
    from psdesign.transport.study_outputs import _pore_rating

    base = {"rel_error": 0.05, "specific_surface_rel_error": 0.01, "converged": True}
    base["breakthrough_diameter_m"] = 2e-5  # a path crosses (test above when none does)
    base["surface_short_axes"] = ""  # the S_v bar's coarse grid halves every axis
    inside = _pore_rating({**base, "pore_d90_m": 0.99e-4}, None, 1e-6, 100e-6)
    assert (inside["status"], inside["warnings"]) == ("ok", [])
    past = _pore_rating({**base, "pore_d90_m": 1.01e-4}, None, 1e-6, 100e-6)
    assert past["pore_sizes_status"] == past["status"] == "untrustworthy"
    assert past["specific_surface_status"] == "ok"
    assert past["warnings"] == [
        "pore sizes: d90 1.010e-04 m exceeds the smallest edge the geometry varies along "
        "1.000e-04 m: the RVE is smaller than its pores; use a larger RVE"
    ]


@pytest.mark.parametrize(
    "rel_error, status, shown",
    [(0.2, "ok", None), (0.2000109, "untrustworthy", "20.001"), (0.2049, "untrustworthy", "20.5")],
)
def test_a_bar_just_over_the_limit_does_not_print_as_the_limit(rel_error, status, shown):
    """Session 54 walk: ``pores`` warned "pore sizes: estimated error 20.0 % exceeds 20 %" for a
    bar of 0.2000109. The rule (``rel_error > 0.2``, unrounded) is kept: 0.2 itself is ok; a bar
    over it is printed with the digits that show it is over (``flow.error.over_limit_percent``)."""
    from psdesign.transport.study_outputs import _pore_rating

    base = {"specific_surface_rel_error": 0.01, "converged": True, "pore_d90_m": 1e-5}
    base["breakthrough_diameter_m"] = 2e-5
    base["surface_short_axes"] = ""
    out = _pore_rating({**base, "rel_error": rel_error}, None, 1e-6, 100e-6)
    assert out["pore_sizes_status"] == status
    expected = [] if shown is None else [f"pore sizes: estimated error {shown} % exceeds 20 %"]
    assert out["warnings"] == expected


def test_an_extruded_rve_bounds_its_pores_by_the_edges_it_varies_along():
    """One cylinder along z (square array across, solid fraction 0.2) in a 40 x 40 x 25 um
    box: the geometry does not vary along z, so the 25 um depth bounds no pore. The largest
    periodic sphere sits midway between four axes, ``L / sqrt(2)`` from each (plane geometry):
    diameter ``2 (L / sqrt(2) - R)`` = 36.4 um. Its d90 (32.9 um) lies under that and under the
    40 um edges; it was untrustworthy against the 25 um depth until session 52 (walk-numbers
    finding 3), in ``psdesign pores`` and in a study's ``pore_d90_m`` row alike."""
    import psdesign
    from psdesign.transport.study_outputs import transport_outputs

    L, phi = 40e-6, 0.2
    r = L * np.sqrt(phi / np.pi)
    spec = {
        "rve": {"size": [L, L, 25e-6], "voxel": 2.5e-6},
        "fibers": [
            {"shape": "cylinder", "diameter": 2 * r, "center": [L / 2, L / 2, 12.5e-6],
             "direction": [0, 0, 1]}
        ],
    }  # fmt: skip
    m = psdesign.build(spec)
    assert [m.fields.varies_along(a) for a in range(3)] == [True, True, False]
    out = m.pores()
    largest = 2 * (L / np.sqrt(2) - r)
    assert 25e-6 < out["pore_d90_m"] <= largest + out["diameter_error_m"]
    assert out["pore_sizes_status"] == "ok", out["warnings"]
    assert not any("smallest edge" in w for w in out["warnings"])
    row = transport_outputs(m.rve, m.fields, ["pore_d90_m"], m.spec)
    assert row["pore_d90_m"] == out["pore_d90_m"] and row["pore_sizes_status"] == "ok"


def test_local_thickness_is_periodic():
    """The RVE is periodic, so a periodic shift of the grid must not change the pore sizes,
    and no pore can exceed the largest ball between the periodic fibres.  A square array of
    cylinders along z (spacing 20 voxels, radius 4): the largest ball sits at the cell's
    corner, sqrt(2) 10 - 4 = 10.14 voxels in radius.  With the faces open (before session 31)
    a fibre placed off-centre left the corner far from any solid, and the largest "pore" was
    37 voxels across, more than the box."""
    n, radius = 20, 4.0
    X, Y, _ = _coords((n, n, 6))

    def array_at(cx, cy):
        dx = (X - cx + n / 2) % n - n / 2  # minimum image
        dy = (Y - cy + n / 2) % n - n / 2
        return np.sqrt(dx**2 + dy**2) - radius

    centred = pore_sizes(_fields(array_at(10.5, 10.5)), n_radii=24, thickness_axis="z")
    shifted = pore_sizes(_fields(array_at(4.5, 4.5)), n_radii=24, thickness_axis="z")
    assert shifted.volume_fraction == centred.volume_fraction
    assert shifted.intrusion_saturation == centred.intrusion_saturation
    true_d = 2.0 * (np.sqrt(2.0) * 10.0 - radius) * H
    for res in (centred, shifted):
        assert res.max_diameter_m <= true_d + 1e-12  # never above the truth
        assert true_d - res.max_diameter_m <= res.diameter_error_m


def test_pore_sizes_arguments_are_held_to_their_transport_keys():
    """Session 46 walk of the documented low-level API (docs/transport.md): pore_sizes'
    arguments are the ``[transport]`` keys n_radii, thickness_axis, surface_tension_n_m and
    contact_angle_deg, but were checked apart from the schema: n_radii="a" or 2.5 and
    contact_angle_deg="a" were numpy TypeErrors, n_radii=3 was scanned (the key allows
    [4, 200]), and surface_tension=-1 or contact_angle_deg=10 (a wetting fluid: no intrusion)
    gave negative Washburn pressures without a word. Now one SpecError naming the key and its
    range; effective_conductivity's transport=3 is "transport: must be a table" (it was "'int'
    object is not iterable")."""
    from psdesign.errors import SpecError
    from psdesign.transport.conductivity import effective_conductivity

    X, Y, Z = _coords((12, 12, 8))
    fields = _fields(4.0 - np.sqrt((X - 6) ** 2 + (Y - 6) ** 2))
    for kwargs, key, allowed in (
        ({"n_radii": "a"}, "n_radii", "[4, 200]"),
        ({"n_radii": 2.5}, "n_radii", "[4, 200]"),
        ({"n_radii": 3}, "n_radii", "[4, 200]"),
        ({"thickness_axis": "w"}, "thickness_axis", "'x', 'y' or 'z'"),
        ({"surface_tension": -1.0}, "surface_tension_n_m", "(0, 10)"),
        ({"contact_angle_deg": 10.0}, "contact_angle_deg", "(90, 180]"),
        ({"contact_angle_deg": "a"}, "contact_angle_deg", "(90, 180]"),
    ):
        with pytest.raises(SpecError) as info:
            pore_sizes(fields, **kwargs)
        line = str(info.value)
        assert info.value.key == f"transport.{key}" and allowed in line, line
        assert len(line.splitlines()) == 1
    # accepted: the lower bound, an axis index, a NumPy integer
    assert pore_sizes(fields, n_radii=np.int64(4), thickness_axis=0).pore_d50_m > 0
    with pytest.raises(SpecError, match=r"^transport: must be a table"):
        effective_conductivity(fields, "z", 1.0, 1.0, 3)


def test_every_transport_entry_refuses_a_transport_that_is_not_a_table():
    """Session 46 review: conductivity's ``transport=3`` was refused in one line, the other
    public entries were not: ``diffusivity_tensor(fields, transport=3)`` raised TypeError
    ('int' object is not iterable), ``transport=[("bc", "periodic")]`` went through
    ``dict(...)`` and ``relative_diffusivity(..., transport=[])`` through ``[] or {}``. One
    rule now (psdesign.schema.transport.transport_keyword): None is the defaults, anything
    but a dict is ``transport: must be a table``, before any solve."""
    from psdesign.errors import SpecError
    from psdesign.transport.conductivity import effective_conductivity, transport_table
    from psdesign.transport.diffusivity import diffusivity_tensor, relative_diffusivity

    X, Y, Z = _coords((12, 12, 8))
    fields = _fields(4.0 - np.sqrt((X - 6) ** 2 + (Y - 6) ** 2))
    entries = (
        lambda t: transport_table(transport=t),
        lambda t: effective_conductivity(fields, "z", 1.0, 1.0, t),
        lambda t: relative_diffusivity(fields, "z", transport=t),
        lambda t: diffusivity_tensor(fields, transport=t),
    )
    for entry in entries:
        for bad in (3, [("bc", "periodic")], [], (), ""):
            with pytest.raises(SpecError) as info:
                entry(bad)
            line = str(info.value)
            assert info.value.key == "transport" and "must be a table" in line, (entry, bad)
            assert len(line.splitlines()) == 1
    assert transport_table(transport=None)["bc"] == "periodic"  # None: the defaults


def test_every_transport_entry_refuses_what_is_not_voxel_fields():
    """Session 46 left: the documented transport functions (docs/transport.md) given something
    that is not VoxelFields raised ``AttributeError: 'int' object has no attribute 'grid'``
    (``'solid'`` for the profile). Now one SpecError line naming ``fields``."""
    from psdesign.errors import SpecError
    from psdesign.transport.conductivity import effective_conductivity
    from psdesign.transport.diffusivity import diffusivity_tensor, relative_diffusivity
    from psdesign.transport.pores import porosity_profile, specific_surface

    for call in (
        lambda: relative_diffusivity(3, "z"),
        lambda: diffusivity_tensor(3),
        lambda: effective_conductivity(3, "z", 1.0, 1.0),
        lambda: pore_sizes(None),
        lambda: specific_surface(np.zeros((4, 4, 4))),
        lambda: porosity_profile(3),
    ):
        with pytest.raises(SpecError) as info:
            call()
        assert info.value.key == "fields" and "\n" not in str(info.value)
        assert str(info.value).startswith("fields: must be the voxel fields of a material")


def test_conductivity_of_one_conductivity_in_both_phases_is_it_and_ok():
    """A homogeneous medium (solid and fluid conductivity equal) conducts at that value
    exactly, on any grid (the Wiener bounds meet): 1.0 ``ok`` at 6 voxels per fibre diameter,
    where a real contrast is ``untrustworthy`` (session 52 walk: 1.0, rel_error 0, yet
    untrustworthy, exit 3)."""
    from psdesign.transport.conductivity import effective_conductivity

    X, Y, _ = _coords((12, 12, 8))
    fields = _fields(3.0 - np.sqrt((X - 6) ** 2 + (Y - 6) ** 2))
    same = effective_conductivity(fields, "x", 1.0, 1.0, cells_per_diameter=6.0)
    assert same.wiener_bounds == [1.0, 1.0]
    assert same.effective_conductivity == pytest.approx(1.0, rel=1e-6)
    assert same.status == "ok" and not same.warnings
    contrast = effective_conductivity(fields, "x", 10.0, 1.0, cells_per_diameter=6.0)
    assert contrast.status == "untrustworthy"


@pytest.mark.parametrize("shift", [0, 12])
def test_breakthrough_needs_a_path_across_and_ignores_where_the_box_is_cut(shift):
    """A solid slab x in [0, 8) of a periodic 32-voxel box (walls, a slit pore 24 voxels wide
    along y and z): no non-wetting path crosses along x at any diameter, so the breakthrough is
    None and the report ``blocked`` (exit 3), however the box is cut (np.roll). Along y the
    slit's width, 24 um, less at most the scan's one-sided bar. Session 53 (walk-transport
    finding 1): it was the first diameter with any intruded volume, 23 um ``ok`` with the cut
    at x = 12 and 0 ``ok`` with the cut at x = 0."""
    from psdesign.transport.study_outputs import pore_report

    solid = np.zeros((32, 12, 12), bool)
    solid[:8] = True
    solid = np.roll(solid, shift, axis=0)
    fields = _fields(np.where(solid, -0.5, 0.5))
    across = pore_sizes(fields, n_radii=16, thickness_axis="x")
    assert across.breakthrough_diameter_m is None
    along = pore_sizes(fields, n_radii=16, thickness_axis="y")
    width = 24 * H
    assert width - along.diameter_error_m <= along.breakthrough_diameter_m <= width
    tr = {"n_radii": 16, "thickness_axis": "x", "surface_tension_n_m": 0.485}
    out = pore_report(None, fields, {**tr, "contact_angle_deg": 140.0})
    assert (out["breakthrough_status"], out["status"]) == ("blocked", "blocked")
    assert any("no intrusion path along x" in w for w in out["warnings"])


@pytest.mark.parametrize("hole", [2, 8])
def test_breakthrough_through_a_hole_narrower_than_the_scan_is_unresolved_not_blocked(hole):
    """The walls above (x in [0, 8) of a 32 x 16 x 16 box) pierced by a square hole ``hole``
    voxels wide: a path crosses along x by construction. 8 voxels: its width, less at most
    the one-sided bar. 2 voxels: no scanned ball (diameter 2 voxels and up, centred on voxel
    centres: the hole's centre voxels lie 1/2 voxel from its faces) passes, so the
    breakthrough is unknown (None), but the pore space crosses: ``untrustworthy`` with a
    warning to refine, never ``blocked``, which says no path exists (the diffusivity through
    the 2-voxel hole is 0.048 of bulk). Session 53 review: both were ``blocked``."""
    from psdesign.transport.study_outputs import pore_report

    solid = np.zeros((32, 16, 16), bool)
    solid[:8] = True
    solid[:8, 7 : 7 + hole, 7 : 7 + hole] = False
    fields = _fields(np.where(solid, -0.5, 0.5))
    tr = {"n_radii": 16, "thickness_axis": "x", "surface_tension_n_m": 0.485}
    out = pore_report(None, fields, {**tr, "contact_angle_deg": 140.0})
    assert out["pore_space_crosses"] is True
    if hole == 8:
        bt = out["breakthrough_diameter_m"]
        assert hole * H - out["diameter_error_m"] <= bt <= hole * H
        assert out["breakthrough_status"] == "ok"
        return
    assert out["breakthrough_diameter_m"] is None
    assert out["breakthrough_status"] == out["status"] == "untrustworthy"
    said = "breakthrough: unresolved: the pore space crosses the sample along x"
    assert any(w.startswith(said) for w in out["warnings"])


@pytest.mark.parametrize("cut", [False, True])
def test_breakthrough_along_an_axis_the_geometry_does_not_repeat_joins_its_two_faces(cut):
    """A channel 6 voxels wide (y) climbing from y = 6 to 22 over x in a 32 x 32 x 8 image
    (session 53 review, tilt.npy): its faces normal to x do not match (``periodic_axes``), so
    the path need not wind around the box; one cluster joining the x = 0 and x = 31 layers
    crosses, and the distance there does not see the opposite face's solid. The breakthrough
    lies between the smallest scanned diameter and the channel's width across its axis,
    ``6 / sqrt(1 + (1/2)^2)`` = 5.37 voxels (plane geometry). Cut by a solid layer at x = 16:
    no path at all, ``blocked``. It was ``blocked`` uncut too (D_eff/D 0.136 along it)."""
    from psdesign.image.fields import image_fields
    from psdesign.transport.study_outputs import pore_report

    solid = np.ones((32, 32, 8), bool)
    for x in range(32):
        solid[x, 6 + x // 2 : 12 + x // 2, :] = False
    if cut:
        solid[16] = True
    fields = image_fields(solid, H)
    tr = {"n_radii": 16, "thickness_axis": "x", "surface_tension_n_m": 0.485}
    out = pore_report(None, fields, {**tr, "contact_angle_deg": 140.0})
    assert out["surface_periodic_axes"] == "yz"
    if cut:
        assert out["pore_space_crosses"] is False and out["breakthrough_diameter_m"] is None
        assert out["breakthrough_status"] == "blocked"
        return
    bt = out["breakthrough_diameter_m"]
    assert 2 * H <= bt <= 6 / np.sqrt(1.25) * H
    assert out["breakthrough_status"] == "ok"


@pytest.mark.parametrize("depth", [6, 16])
def test_surface_bar_of_an_extruded_rod_does_not_depend_on_its_depth(depth):
    """A rod of radius 8 voxels along z (32 x 32 cross-section, analytic distance) extruded
    ``depth`` voxels: exact ``S_v = 2 pi R / A_cross`` = 49087 1/m at any depth. The bar's
    coarse grid halves x and y only when z is short; z, along which nothing varies, adds no
    error, so the bar is the deep rod's and covers the true error. Session 53 (walk-transport
    finding 2): under 8 voxels on any axis the bar was 0.0 % and the value ``ok``."""
    from psdesign.transport.pores import surface_status

    X, Y, _ = _coords((32, 32, depth))
    rod = np.sqrt((X - 16) ** 2 + (Y - 16) ** 2) - 8.0  # > 0 in the pore
    res = specific_surface(_fields(rod))
    exact = 2 * np.pi * 8.0 / (32 * 32) / H
    assert res.rel_error > 0.001  # measured 0.0029, true error 0.096 % (49040 1/m)
    assert abs(res.specific_surface_m_1 - exact) <= res.rel_error * res.specific_surface_m_1
    deep = specific_surface(_fields(np.repeat(rod[:, :, :1], 16, axis=2)))
    assert res.rel_error == pytest.approx(deep.rel_error, rel=1e-6)
    assert res.extra["short_axes"] == ""
    assert surface_status(res.rel_error, res.extra["short_axes"], None) == "ok"


def test_surface_along_a_short_axis_the_geometry_varies_along_is_untrustworthy():
    """A rod along x (radius 2.5 voxels in y-z) in a 32 x 32 x 6 box varies along z over 6
    voxels, too few for a coarse grid there: the bar misses that part, so the value is
    ``untrustworthy`` with a warning naming z, never ``ok`` from lack of data."""
    from psdesign.transport.study_outputs import pore_report

    _, Y, Z = _coords((32, 32, 6))
    fields = _fields(np.sqrt((Y - 16) ** 2 + (Z - 3) ** 2) - 2.5)
    assert specific_surface(fields).extra["short_axes"] == "z"
    tr = {"n_radii": 8, "thickness_axis": "x", "surface_tension_n_m": 0.485}
    out = pore_report(None, fields, {**tr, "contact_angle_deg": 140.0})
    assert out["specific_surface_status"] == "untrustworthy"
    assert any(
        w.startswith("S_v: the geometry varies along z over fewer than 8") for w in out["warnings"]
    )


def test_breakthrough_is_the_neck_a_wide_inlet_pore_leads_to():
    """A pore of radius 10 voxels open at the inlet (z < 30) continued to the outlet by a neck
    of radius 3 (z >= 30), periodic along z: the non-wetting phase enters at 20 um but crosses
    only at the neck's 6 um (the scan measures low by at most its bar). It read 20 um, the
    largest diameter that enters, until session 53."""
    X, Y, Z = _coords((41, 41, 60))
    rxy = np.sqrt((X - 20.5) ** 2 + (Y - 20.5) ** 2)
    res = pore_sizes(_fields(np.where(Z < 30, 10.0, 3.0) - rxy), n_radii=30, thickness_axis="z")
    assert res.intrusion_saturation[0] > 0  # the wide pore fills at the largest diameter
    neck = 6.0 * H
    assert neck - res.diameter_error_m <= res.breakthrough_diameter_m <= neck


def test_a_pore_a_face_cuts_is_measured_whole_where_the_geometry_does_not_repeat():
    """A cylinder pore of radius R = 8 voxels along z cut at its axis by the x = 0 face of a
    32 x 40 x 16 image, solid at x = 31: the faces normal to x do not match, so the box is a
    cut of a larger medium there, not one period of it. Closed form (Hildebrand & Ruegsegger
    1997): local thickness 2R = 16 um; the pore reaches the inlet face (z = 0, periodic) and
    crosses, so it fills and breaks through at 2R too; the scan measures low by at most its
    one-sided bar. Until session 54 the scan wrapped x: the half cylinder was closed by the
    solid of the x = 31 face, a D-shaped pore 8 voxels deep: d50 and d90 7.0 um (d10 4.6), the
    intrusion curve filled 0.73 of it at 7.0 um only."""
    from psdesign.image.fields import image_fields

    R = 8.0
    X, Y, _ = _coords((32, 40, 16))
    fields = image_fields(np.sqrt(X**2 + (Y - 20) ** 2) >= R, H)
    assert specific_surface(fields).extra["periodic_axes"] == "yz"
    res = pore_sizes(fields, n_radii=24, thickness_axis="z")
    for d in (res.pore_d10_m, res.pore_d50_m, res.pore_d90_m, res.max_diameter_m):
        assert 2 * R * H - res.diameter_error_m <= d <= 2 * R * H  # measured 14.2 um
    bt = res.breakthrough_diameter_m
    assert 2 * R * H - res.diameter_error_m <= bt <= 2 * R * H
    # the largest ball fills the whole half cylinder but its staircase corners (voxels farther
    # than the smallest ball from any seed: 0.077 of it) at once
    assert res.intrusion_saturation[0] == res.intrusion_saturation[-1] > 0.9


def test_intrusion_crosses_no_face_the_geometry_does_not_repeat_across():
    """Intrusion along z into a 32 x 40 x 32 box whose faces normal to y do not match: a
    cylinder pore (radius 8 voxels) along z cut at its axis by the y = 0 face, and a cavity, a
    sphere of radius 6 cut at its centre by the y = 40 face, which no path inside the box joins
    to the inlet (closed form: the intruded fraction never exceeds the cylinder's share of the
    pore volume, 0.879, and reaches it at the cylinder's 2R). Until session 54 the balls of the
    cylinder reached across the y faces into the cavity: it filled at 14.6 um, saturation 1."""
    X, Y, Z = _coords((32, 40, 32))
    cyl = 8.0 - np.sqrt((X - 16) ** 2 + Y**2)
    cavity = 6.0 - np.sqrt((X - 16) ** 2 + (Y - 40) ** 2 + (Z - 16) ** 2)
    dist = np.maximum(cyl, cavity)
    share = np.count_nonzero(cyl > 0) / np.count_nonzero(dist > 0)
    fields = _fields(dist)
    assert specific_surface(fields).extra["periodic_axes"] == "xz"
    res = pore_sizes(fields, n_radii=24, thickness_axis="z")
    sat = np.array(res.intrusion_saturation)
    assert sat.max() == pytest.approx(share, abs=1e-12)  # the cylinder, whole, and no more
    assert 16 * H - res.diameter_error_m <= res.intrusion_diameter_m[0] <= 16 * H
    assert sat[0] == pytest.approx(share, abs=1e-12)
    # local thickness sees the cavity at its own size: the sphere the face cuts, 12 um
    d = np.array(res.diameters_m)
    cavity_share = 1.0 - share
    near = (d >= 12 * H - res.diameter_error_m) & (d <= 12 * H)
    assert np.array(res.volume_fraction)[near].sum() >= 0.9 * cavity_share


@pytest.mark.parametrize("thickness_axis, throat", [("x", 10.0), ("z", 11.0)])
def test_a_slit_a_face_bounds_lies_inside_the_two_sided_bar(thickness_axis, throat):
    """A slit whose one wall is the y = 0 face of a 24 x 40 x 12 voxel image: pore at
    y < 10 voxels, y < 11 for x < 8 (the step makes the faces normal to y not match, as the
    review's case: y is not periodic; x and z are). Closed form (Hildebrand & Ruegsegger
    1997): a slit's local thickness is its width, 10-11 um, if the medium past the face is a
    wall; any continuation past it holds more pore and reads no less (local thickness is
    monotone in the pore set). The open-face value reads the slit as going on, 20.5 um;
    the session 54 review of s54-poreswrap found main printing it ``+2.5e-06/-0`` (the truth
    below the bar) and ``ok``. The bar must hold 10-11 um, its lower end be the walled scan's
    (the closed form within the resolution bar), and the span (11 um over d50 20.5 um) rate it
    untrustworthy by the one 20 % rule. The walled intrusion curve never exceeds the open one;
    the walled breakthrough is the slit's ``throat``: 10 um along x (the narrow part), 11 um
    along z (the wide part runs along z)."""
    from psdesign.flow.error import UNTRUSTWORTHY_REL_ERROR
    from psdesign.image.fields import image_fields

    X, Y, _ = _coords((24, 40, 12))
    fields = image_fields(~(Y < 10 + (X < 8)), H)
    assert specific_surface(fields).extra["periodic_axes"] == "xz"
    res = pore_sizes(fields, n_radii=24, thickness_axis=thickness_axis)
    above, below = res.diameter_error_m, getattr(res, "diameter_error_below_m", 0.0)
    for d in (res.pore_d10_m, res.pore_d50_m, res.pore_d90_m):
        assert d - below <= 10 * H and 11 * H <= d + above  # the truth inside the bar
        assert 10 * H - above <= d - below  # its lower side the walled slit, within the bar
    assert res.pore_d50_m > 17 * H  # the open-face value: the slit read as going on
    assert res.rel_error > UNTRUSTWORTHY_REL_ERROR
    assert res.walled_axes == "y"
    values = (res.pore_d10_m, res.pore_d50_m, res.pore_d90_m)
    for d, w in zip(values, res.walled_d10_d50_d90_m, strict=True):
        # each walled value is the walled slit's local thickness (closed form 10-11 um) within
        # the resolution bar, and no more than the open one (session 54 review: `d - below <= w`
        # held by below's definition)
        assert 10 * H - above <= w <= 11 * H and w <= d
    walled, opened = np.array(res.intrusion_saturation_walled), np.array(res.intrusion_saturation)
    assert np.all(walled <= opened) and walled[-1] == opened[-1] > 0.99  # the step corners
    bt, bt_walled = res.breakthrough_diameter_m, res.breakthrough_diameter_walled_m
    assert throat * H - above <= bt_walled <= throat * H <= bt + above


def test_a_study_row_carries_the_lower_bar_only_where_a_face_does_not_repeat(tmp_path):
    """Session 54 review: a study row holds ``pore_diameter_error_below_m``
    (:data:`~psdesign.analysis.columns.LOWER_BAR_COLUMN`, the report's and the targets' one
    name of it) only where a face of the box does not repeat. The slit above (y = 0 face its
    wall): the row's lower end reaches the closed-form width (10 um, Hildebrand & Ruegsegger
    1997) and the row is untrustworthy by the larger side; a slit 10 voxels wide in the middle
    of y (every face repeats): no such key, the truth 10 um inside +bar/-0."""
    import psdesign
    from psdesign.analysis.columns import LOWER_BAR_COLUMN
    from psdesign.transport.study_outputs import transport_outputs

    X, Y, _ = _coords((24, 40, 12))
    rows = {}
    for name, solid in (("walled", ~(Y < 10 + (X < 8))), ("periodic", (Y < 15) | (Y >= 25))):
        np.save(tmp_path / f"{name}.npy", solid.astype(np.uint8))
        image = {"path": str(tmp_path / f"{name}.npy"), "voxel_size": H, "solid_label": 1}
        m = psdesign.build({"image": image})
        rows[name] = transport_outputs(m.rve, m.fields, ["pore_d50_m"], m.spec)
    walled, periodic = rows["walled"], rows["periodic"]
    assert walled[LOWER_BAR_COLUMN] > 0
    assert walled["pore_d50_m"] - walled[LOWER_BAR_COLUMN] <= 10 * H < walled["pore_d50_m"]
    assert walled["pore_sizes_status"] == "untrustworthy"
    assert LOWER_BAR_COLUMN not in periodic
    d50, above = periodic["pore_d50_m"], periodic["pore_diameter_error_m"]
    assert d50 <= 10 * H <= d50 + above


def test_a_fully_periodic_slit_keeps_the_one_sided_bar():
    """A periodic slit, 10 voxels wide between plates (every face repeats): one scan, as before
    session 54: the bar ``+bar/-0`` (closed form 10 um between the value and value + bar, never
    below), no walled keys in the report. Fails on a wrong implementation that walls a face
    that repeats (the value would not change, the lower bar would be set)."""
    from psdesign.transport.pores import diameter_bar_text

    X, Y, Z = _coords((24, 24, 40))
    fields = _fields(5.0 - np.abs(Z - 20.0))  # pore for 15 < z < 25, solid to both faces
    assert specific_surface(fields).extra["periodic_axes"] == "xyz"
    res = pore_sizes(fields, n_radii=20, thickness_axis="x")
    assert res.diameter_error_below_m == 0.0 and res.walled_axes == ""
    assert res.intrusion_saturation_walled is None
    assert not {"walled_axes", "diameter_error_below_m"} & set(res.to_dict())
    assert diameter_bar_text(res.diameter_error_m, res.diameter_error_below_m).endswith("/-0")
    for d in (res.pore_d10_m, res.pore_d50_m, res.pore_d90_m):
        assert d <= 10.0 * H <= d + res.diameter_error_m
    assert res.rel_error == pytest.approx(res.diameter_error_m / res.pore_d50_m)
