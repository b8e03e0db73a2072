"""FEM boundary conditions (issue 12): periodic solve, and a permeameter K without entrance bias.

Truth: plane Poiseuille flow (exact in P2-P1); the power identity (dissipation = Q dp); the
published square-array series (``reference_values``: Drummond & Tahir 1984 along, Sangani &
Acrivos 1982 across); and the FEM's own periodic solution at the same resolution, which the
permeameter must reproduce for any number of cells (2-5) once entrance and exit losses are
excluded. Before the fix the permeameter K was 5-13 % low along the cylinders (5 to 2 cells).
"""

from __future__ import annotations

import numpy as np
import pytest
from fem_arrays import array_k
from meshes import box_mesh, tag_box_boundary

from solvers.fem_stokes import (
    PeriodicMeshError,
    StokesOptions,
    solve_stokes,
    solve_stokes_periodic,
)

W, H, LZ = 1e-5, 2e-5, 3e-5
MU, G = 1.8e-5, 7.0


@pytest.mark.parametrize(
    ("direct_max_dofs", "krylov"),
    [(10**6, "gmres"), (0, "minres"), (0, "gmres")],
    ids=["direct", "minres", "gmres"],
)
def test_periodic_plane_poiseuille_exact(direct_max_dofs, krylov):
    """Periodic in x and z, walls y = 0, H: <u_z> = G H^2 / (12 mu) over the box, exactly."""
    pts, tets = box_mesh((0, 0, 0), (W, H, LZ), (3, 4, 5))
    res = solve_stokes_periodic(
        pts,
        tets,
        axis=2,
        pressure_gradient=G,
        viscosity=MU,
        periodic_axes=(0, 2),
        options=StokesOptions(tol=1e-10, direct_max_dofs=direct_max_dofs, krylov=krylov),
    )
    assert res.converged
    assert res.method == ("direct" if direct_max_dofs else f"{krylov}+amg-sa")
    u_mean = res.mean_velocity
    assert u_mean[2] == pytest.approx(G * H**2 / (12 * MU), rel=1e-9, abs=0)
    assert np.all(np.abs(u_mean[:2]) < 1e-9 * u_mean[2])
    # flow rate through the periodic faces z0 / z1: <u_z> W H, in and out
    assert res.flux["z1"] == pytest.approx(u_mean[2] * W * H, rel=1e-9, abs=0)
    y = pts[:, 1]
    np.testing.assert_allclose(
        res.velocity[:, 2], G * y * (H - y) / (2 * MU), atol=1e-9 * G * H**2 / MU
    )
    assert res.flux_imbalance < 1e-12
    # the power input G <u> V equals the dissipation
    assert res.dissipation() == pytest.approx(G * u_mean[2] * W * H * LZ, rel=1e-9, abs=0)


def test_periodic_without_walls_is_refused():
    """An empty box periodic on all faces has no no-slip facets: velocity undetermined."""
    pts, tets = box_mesh((0, 0, 0), (W, H, LZ), (2, 2, 2))
    with pytest.raises(ValueError, match="no no-slip facets"):
        solve_stokes_periodic(pts, tets, axis=2)


def test_periodic_mismatched_face_is_named():
    pts, tets = box_mesh((0, 0, 0), (W, H, LZ), (2, 4, 4))
    inner = (pts[:, 0] > 0) & (pts[:, 0] < W) & (pts[:, 1] > 0) & (pts[:, 1] < H)
    on_top = np.nonzero(np.isclose(pts[:, 2], LZ, atol=0) & inner)[0]
    pts = pts.copy()
    pts[on_top[0], 0] += 0.1 * W / 2  # move one vertex within the face z = LZ
    with pytest.raises(PeriodicMeshError, match="face z1"):
        solve_stokes_periodic(pts, tets, axis=2, periodic_axes=(0, 2))


def test_bad_periodic_arguments():
    pts, tets = box_mesh((0, 0, 0), (W, H, LZ), (2, 2, 2))
    for kw, match in (
        ({"axis": 3}, "axis"),
        ({"axis": 2, "pressure_gradient": 0.0}, "pressure_gradient"),
        ({"axis": 1, "periodic_axes": (0, 2)}, "periodic_axes"),
        ({"axis": 2, "periodic_axes": ()}, "periodic_axes"),
    ):
        with pytest.raises(ValueError, match=match):
            solve_stokes_periodic(pts, tets, **kw)


def test_permeameter_dissipation_is_the_power_input():
    """int mu |grad u|^2 = Q dp for the pressure-driven solve; a sin^2 window halves it when
    the dissipation is uniform along the flow (plane Poiseuille)."""
    pts, tets = box_mesh((0, 0, 0), (W, H, LZ), (2, 4, 8))
    tags = tag_box_boundary(pts, tets, (0, 0, 0), (W, H, LZ), 2)
    res = solve_stokes(
        pts,
        tets,
        tags,
        p_inlet=5.0,
        viscosity=MU,
        noslip=("side_y0", "side_y1"),
        slip=("side_x0", "side_x1"),
        options=StokesOptions(tol=1e-11),
    )
    power = res.flux["outlet"] * 5.0
    assert res.dissipation() == pytest.approx(power, rel=1e-9, abs=0)
    half = res.dissipation(lambda x: np.sin(np.pi * x[:, 2] / LZ) ** 2)
    assert half == pytest.approx(0.5 * power, rel=1e-9, abs=0)


# ------------------------------------------------------------------ square arrays (pipeline)
STEP = 4e-6  # lattice step: 6 cells across the cylinder diameter at phi = 0.3


def test_permeameter_along_array_matches_periodic_two_cells():
    """Along a square array, phi = 0.3, RVE two cells long: the permeameter K equals the
    periodic K (same lattice) within 1 % (measured 0.01 %; the old faces-drop K was -12 %)."""
    per = array_k("along", 0.3, 1, "periodic", STEP)
    perm = array_k("along", 0.3, 2, "permeameter", STEP)
    assert per["converged"] and perm["converged"]
    assert per["bc"] == "periodic" and perm["bc"] == "permeameter"
    assert perm["permeability_m2"] == pytest.approx(per["permeability_m2"], rel=0.01, abs=0)
    # the drop between the RVE faces carries the entrance/exit losses: K from it is far lower
    k_faces = (
        perm["permeability_m2"] * perm["pressure_drop_rve_pa"] / perm["pressure_drop_faces_pa"]
    )
    assert k_faces < 0.95 * per["permeability_m2"]
    # the second windowed estimator (plane-averaged pressure on 61 planes, the error bar's
    # window term) is exact for two periods too: measured -0.05 % from the periodic K
    k_plane = k_faces * perm["pressure_drop_faces_pa"] / perm["pressure_drop_plane_window_pa"]
    assert k_plane == pytest.approx(per["permeability_m2"], rel=0.01, abs=0)
    assert perm["rve_length_m"] == pytest.approx(2 * 40e-6)
    # published series (coarse lattice, voxel-matched volume: measured -2.0 %)
    assert per["permeability_m2"] == pytest.approx(per["k_ref"], rel=0.03, abs=0)
    assert 4 < per["cells_per_diameter"] < 8


#: (kind, phi, step, cells) of the slow sweep; along 0.3 at STEP with 2 cells is the default
#: test above (the same two solves, a superset of these asserts), so it is not solved twice
BC_SWEEP = [
    (kind, phi, step, n)
    for kind, phi, step in (("along", 0.3, STEP), ("across", 0.2, 2e-6))
    for n in (2, 3, 4, 5)
    if (kind, phi, step, n) != ("along", 0.3, STEP, 2)
]


@pytest.mark.slow
@pytest.mark.parametrize(("kind", "phi", "step", "n"), BC_SWEEP)
def test_permeameter_matches_periodic_for_2_to_5_cells(kind, phi, step, n):
    """The 1 % bar of issue 12 item 2: permeameter vs the periodic K at the same lattice
    (measured: along <= 0.3 %, across <= 0.7 %, largest at 2 cells). Against the published
    values the periodic K is off by the mesh's pore volume, which the mesher matches to the
    voxel count (measured along phi 0.3 at 4 um: -2.0 %; across phi 0.2 at 2 um: +1.6 %)."""
    per = array_k(kind, phi, 1, "periodic", step)
    perm = array_k(kind, phi, n, "permeameter", step)
    assert per["converged"] and perm["converged"]
    assert perm["permeability_m2"] == pytest.approx(per["permeability_m2"], rel=0.01, abs=0)
    assert per["permeability_m2"] == pytest.approx(per["k_ref"], rel=0.03, abs=0)


def test_periodic_route_on_non_periodic_geometry_names_the_face():
    """A cylinder cut by the face x = 0 only: the x faces differ, so bc="periodic" refuses.

    The period is twice the box (no PS copy of the cylinder at x = L); with the default period
    (the box's largest edge) the copy at x = L makes the same RVE periodic, and the route then
    meshes it with matching faces (the mesher used to make z faces that did not match: "in-plane
    mismatch 0.2", which passed for the refusal)."""
    from fem_arrays import MU, S

    from psdesign.flow.fem import _mesh, permeability_fem
    from psdesign.geometry.fibers import make_fiber
    from psdesign.geometry.rve import RVE

    size = np.array([S, S, 8e-6])

    def cut_cylinder(period_boxes: float) -> RVE:
        fiber = make_fiber(
            "cylinder",
            diameter=0.3 / period_boxes,
            center=np.array([0.1, 0.5, 0.1]) / period_boxes,
            theta=None,
            omega=None,
            direction=[0, 0, 1],
            u=0.0,
            f=1.0,
            isovalue=None,
        )
        return RVE(size=size, fibers=[fiber], period=period_boxes * S)

    rve = cut_cylinder(2.0)
    flow = {"viscosity": MU, "bc": "periodic", "mesher": "stuffing", "lattice_step": 4e-6}
    # the geometry check (or the solver's face matching) names the faces that differ
    with pytest.raises(PeriodicMeshError, match=r"face x1|faces normal to [xyz] do not match"):
        permeability_fem(rve, rve.voxelize(2e-6), "x", flow)
    periodic = cut_cylinder(1.0)
    mesh = _mesh(periodic, periodic.voxelize(2e-6), "x", flow, "periodic")
    assert {k: len(v) > 0 for k, v in mesh.periodic_pairs.items()} == dict.fromkeys("xyz", True)
    with pytest.raises(ValueError, match="flow.bc"):
        permeability_fem(rve, rve.voxelize(2e-6), "x", dict(flow, bc="mirror"))
