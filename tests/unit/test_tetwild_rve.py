"""pytetwild on a small Toray-like RVE: the mesh pore volume against the exact one.

Three straight fibers lie in planes z = const (as in carbon paper), at random in-plane angles,
separated in z by more than a diameter (no overlap) and each entering and leaving through the
side faces x = 0 and x = L away from the box edges. The solid inside the box is then exactly
``sum_i pi R^2 L / cos(omega_i)`` (a cylinder cut by two parallel planes has the volume of the
right cylinder of its axis length), so the pore volume has a closed form independent of the
mesher's own analytic estimate (:mod:`psdesign.meshing.pore_volume`).
"""

from __future__ import annotations

import numpy as np
import pytest

from psdesign.meshing.pore_mesh import mesh_pore_space

L = 60e-6
N = 30
VOX = L / N
R = 0.1 * L
Z_LEVELS = (0.2, 0.5, 0.8)  # fiber axes at z = level * L: gaps of 0.1 L between fibers


def fibers(seed: int = 3) -> tuple[np.ndarray, float]:
    """(signed distance on the voxel grid, exact solid volume in the box)."""
    rng = np.random.default_rng(seed)
    c = (np.arange(N) + 0.5) * VOX
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    d = np.full(x.shape, np.inf)
    solid = 0.0
    for level in Z_LEVELS:
        omega = np.radians(rng.uniform(10.0, 35.0)) * rng.choice([-1.0, 1.0])
        y0 = L * (0.5 + rng.uniform(-0.05, 0.05))  # axis crosses x = L/2 at y0
        u = np.array([np.cos(omega), np.sin(omega)])
        # distance to the axis through (L/2, y0, level L) along (u, 0)
        px, py, pz = x - 0.5 * L, y - y0, z - level * L
        t = px * u[0] + py * u[1]
        dist = np.sqrt(np.maximum(px**2 + py**2 - t**2, 0.0) + pz**2)
        d = np.minimum(d, dist - R)
        solid += np.pi * R**2 * L / np.cos(omega)
    return d, solid


@pytest.fixture(scope="module")
def rve_mesh():
    from psdesign.meshing.tetwild_mesher import NondeterministicMeshWarning

    d, solid = fibers()
    # the product's rule is same spec -> same files; pytetwild breaks it and must say so
    with pytest.warns(
        NondeterministicMeshWarning, match="flow.mesher = 'stuffing' is deterministic"
    ):
        pm = mesh_pore_space(d, VOX, (L, L, L), "z", mesher="pytetwild", edge_length_fac=0.08)
    return pm, L**3 - solid


def test_pytetwild_pore_volume_of_small_rve_is_exact(rve_mesh):
    """Mesh pore volume (RVE part) within 0.1 % of the closed form (measured -1.1e-4; the
    analytic estimate itself -1.1e-4). Without the wall-normal correction
    (``match_volume=False``) the same mesh is +0.50 % off, so this bar fails on it."""
    pm, exact = rve_mesh
    q = pm.quality
    assert q["pore_volume_m3"] == pytest.approx(exact, rel=1e-3, abs=0)
    assert abs(q["pore_volume_rel_diff"]) < 1e-4  # matched to the analytic estimate
    assert q["analytic_pore_volume_m3"] == pytest.approx(exact, rel=1e-3, abs=0)
    assert q["pore_centroid_fraction"] > 0.99


def test_aux_sizing_field_is_linear_through_the_aux_zones():
    """The background mesh tiles the box and its target length is h in the RVE and grows
    linearly to factor * h at the inlet and outlet faces (exact under interpolation)."""
    from psdesign.meshing.options import MeshOptions
    from psdesign.meshing.pore_mesh import MeshInputError
    from psdesign.meshing.tetra import aux_sizing_field, tet_volumes

    lo, hi = np.zeros(3), np.array([1.0, 0.8, 1.4])
    pts, tets, val = aux_sizing_field(lo, hi, 0.2, 1.2, 2, 0.05, 3.0)
    vol = tet_volumes(pts, tets)
    assert (vol > 0).all() and vol.sum() == pytest.approx(np.prod(hi - lo), rel=1e-12)
    # barycentric interpolation at random points of each tet reproduces h(z)
    rng = np.random.default_rng(0)
    w = rng.dirichlet(np.ones(4), size=len(tets))
    p = np.einsum("tk,tkd->td", w, pts[tets])
    h = np.einsum("tk,tk->t", w, val[tets])
    exact = 0.05 * (1.0 + 2.0 * np.maximum(np.maximum(0.2 - p[:, 2], p[:, 2] - 1.2), 0) / 0.2)
    assert h == pytest.approx(exact, rel=1e-12, abs=0)
    with pytest.raises(MeshInputError, match="aux_edge_factor"):
        MeshOptions(mesher="pytetwild", aux_edge_factor=0.5)


def test_drop_slivers_removes_few_pinned_inverted_tets_only():
    """A tiny inverted tet and a flat one on a box plane are dropped (with their orphaned
    vertices); 21 inverted tets (more than allowed), one of 2e-3 of the mesh volume (more than
    ``_MAX_DROPPED_VOLUME``) and one larger than the mean tet are kept for the inverted-tet
    check; one of 5e-4 (a sliver of a 7 000-tet image mesh) is dropped."""
    from psdesign.meshing.tetra import aux_sizing_field, tet_volumes
    from psdesign.meshing.tetwild_mesher import drop_slivers

    lo, hi = np.zeros(3), np.ones(3)
    pts, tets, _ = aux_sizing_field(lo, hi, 0.25, 0.75, 2, 1.0, 1.0)  # 18 positive tets
    n0 = len(pts)
    e = 1e-2
    extra = np.array([[0, 0, 0], [e, 0, 0], [0, e, 0], [0, 0, e], [e, e, 0]], dtype=float)
    p = np.vstack([pts, extra])
    inv = np.array([[n0, n0 + 2, n0 + 1, n0 + 3]])  # reversed corner tet: volume -e^3 / 6
    flat = np.array([[n0, n0 + 1, n0 + 2, n0 + 4]])  # all four on z = 0
    assert tet_volumes(p, inv)[0] < 0
    q, t, n_flat, n_inv = drop_slivers(p, np.vstack([tets, inv, flat]), lo, hi)
    assert (n_flat, n_inv) == (1, 1) and len(t) == len(tets) and len(q) == n0
    assert tet_volumes(q, t).sum() == pytest.approx(1.0, rel=1e-12)
    many = np.repeat(inv, 21, axis=0)
    _, t2, _, n_inv2 = drop_slivers(p, np.vstack([tets, many]), lo, hi)
    assert n_inv2 == 0 and len(t2) == len(tets) + 21
    # the volume bound: a corner tet of edge e has volume e^3 / 6 (mean tet 1 / 18 = 0.056)
    for e, dropped in [(0.144, True), (0.229, False), (0.8, False)]:  # 5e-4, 2e-3, 0.085
        big = np.vstack([pts, e * extra / 1e-2])
        _, t3, _, n_inv3 = drop_slivers(big, np.vstack([tets, inv]), lo, hi)
        assert (n_inv3, len(t3)) == ((1, len(tets)) if dropped else (0, len(tets) + 1)), e


def test_pytetwild_wall_vertices_lie_on_the_field_surface(rve_mesh):
    """``project_walls``: the curved-wall vertices sit on the zero set of the interpolated field,
    moved by the one common volume shift ``s``.

    Bars from what fTetWild guarantees: its boundary lies anywhere within its envelope
    ``epsilon`` (``epsilon_rel`` times the box diagonal, ``psdesign.meshing``) of the input
    surface, so a vertex left where fTetWild put it (projection withdrawn or capped at the
    snap's ``max_move``, shift frozen: at most 2 % here) may be up to ``epsilon + |s|`` off
    (capped: a box-face vertex where fTetWild cut the corner to a fiber, within its envelope of
    the face but 3-8 um from the fiber, 4 of 25 runs in session 20, once 20 |s| in CI); those
    are set aside
    (``wall_phi_dev_snapped_max_m``). A snapped vertex is on the zero set and then moved by
    ``s`` along its mesh normal ``n``: ``|phi + s| = |s| |1 - n . grad phi| + O(s^2 / R)``, a
    fraction of ``|s|`` set by the normal's tilt and the interpolated field's gradient error,
    at most ``|s|`` for any normal within 90 degrees of the gradient: bar ``|s|`` (measured
    0.12-0.19 |s| in 15 runs, 0.031-0.047 epsilon; one outlier vertex at 0.57 |s| = 0.15 epsilon
    in a session-17 CI run failed the former bar 0.5 |s|). The shift is
    within the envelope (the only freedom fTetWild had; measured 0.25 epsilon). The default
    boundary (no projection, the ``rve_mesh`` fixture) is 0.65-1.0 epsilon off on the same
    statistic (3 runs), 2.6-4 times the bar. The bar before that, the 99th percentile below 5 % of
    the envelope, flaked (8.1 % once under load): with more than 1 % of the vertices withdrawn
    the 99th percentile is one of them, anywhere within the envelope."""
    d, _ = fibers()
    pm = mesh_pore_space(
        d, VOX, (L, L, L), "z", mesher="pytetwild", edge_length_fac=0.08, project_walls=True
    )
    q = pm.quality
    envelope = q["epsilon_rel"] * float(np.linalg.norm([L, L, 1.4 * L]))
    shift = abs(q["wall_shift_m"])
    assert q["wall_projection"] and q["n_wall_projected"] > 100
    left = q["n_wall_projection_withdrawn"] + q["n_wall_vertices_frozen"]
    left += q["n_wall_projection_capped"]
    assert left <= 0.02 * (q["n_wall_projected"] + q["n_wall_projection_withdrawn"])
    assert q["wall_phi_p99_before_m"] > 0.3 * envelope  # fTetWild's scatter, before
    assert 0.05 * envelope < shift <= envelope
    assert q["wall_phi_dev_snapped_max_m"] <= shift
    # the vertices set aside, off the box planes: within the envelope of the fiber surface
    # (0.27 envelope in 30 runs); on a box plane fTetWild may cut the corner to a fiber within
    # its envelope of the plane (1.7-5 envelopes from the fiber in 9 of 60 runs, session 20)
    assert q["wall_phi_max_off_box_planes_m"] <= 1.5 * envelope
    old = rve_mesh[0].quality
    assert not old["wall_projection"]
    assert old["wall_phi_dev_snapped_max_m"] > abs(old["wall_shift_m"])
    # the volume correction still holds the analytic pore volume with the projected walls
    assert abs(q["pore_volume_rel_diff"]) < 1e-4


def test_fiber_diameter_envelope_keeps_the_pore_volume_exact():
    """With the fiber diameter known (the spec routes) the default envelope is D / 28 of the
    fibers (:data:`~psdesign.meshing.options.ENVELOPE_PER_DIAMETER`), not half a marching-cubes
    step: 12 um / 28 = 0.43 um here against 1 um, and the pore volume still matches the
    closed form within 0.1 % (and the analytic estimate within 1e-4, the volume correction)."""
    from psdesign.meshing.options import ENVELOPE_PER_DIAMETER

    d, solid = fibers()
    pm = mesh_pore_space(d, VOX, (L, L, L), "z", mesher="pytetwild", fiber_diameter=2 * R)
    q = pm.quality
    diag = float(np.linalg.norm([L, L, 1.4 * L]))
    assert q["epsilon_rel"] * diag == pytest.approx(ENVELOPE_PER_DIAMETER * 2 * R, rel=1e-9, abs=0)
    assert q["edge_length_per_diameter"] == pytest.approx(0.85)
    assert q["pore_volume_m3"] == pytest.approx(L**3 - solid, rel=1e-3, abs=0)
    assert abs(q["pore_volume_rel_diff"]) < 1e-4
