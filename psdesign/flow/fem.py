"""Permeability with the tet mesh + Taylor-Hood route (``solver = "fem"``).

Pore-space tet mesh with empty auxiliary inlet/outlet zones
(:func:`psdesign.meshing.pore_mesh.mesh_pore_space`), Taylor-Hood Stokes with prescribed
pressures (:func:`solvers.fem_stokes.solve_stokes`), K by
:func:`psdesign.flow.darcy.darcy_permeability`
from the outlet flow rate and the drop of the cross-section-averaged pressure between the RVE's
own inlet and outlet planes.
"""

from __future__ import annotations

import time

import numpy as np

from psdesign.flow.darcy import axis_of, darcy_permeability
from psdesign.geometry.rve import RVE, VoxelFields
from psdesign.meshing import tags
from psdesign.meshing.options import mesher_options  # noqa: F401 (moved; re-exported)


def plane_average_pressure(
    points: np.ndarray, tets: np.ndarray, pressure: np.ndarray, axis: int, position: float
) -> float:
    """Area-averaged P1 pressure over the cross-section of a tet mesh at ``position``."""
    import pyvista as pv

    cells = np.hstack([np.full((len(tets), 1), 4), tets]).ravel()
    grid = pv.UnstructuredGrid(cells, np.full(len(tets), pv.CellType.TETRA), points)
    grid.point_data["p"] = np.nan_to_num(pressure)
    normal = np.eye(3)[axis]
    origin = np.asarray(points).mean(axis=0)
    lo, hi = np.min(points[:, axis]), np.max(points[:, axis])
    eps = 1e-9 * (hi - lo)
    origin[axis] = min(max(position, lo + eps), hi - eps)  # a cut on the boundary is empty
    cut = grid.slice(normal=normal, origin=origin)
    if cut.n_points == 0:
        raise ValueError(f"no mesh cross-section at {'xyz'[axis]} = {position}")
    integ = cut.integrate_data()
    area = float(integ["Area"][0])
    return float(integ.point_data["p"][0] / area)


def permeability_fem(
    rve: RVE, fields: VoxelFields, direction: str | int, flow: dict, mesh=None
) -> dict:
    """Permeability along one axis with the tet mesh + Taylor-Hood route.

    Parameters
    ----------
    rve : RVE
    fields : VoxelFields
        Voxelized RVE (its distance field is meshed).
    direction : 'x' | 'y' | 'z'
    flow : dict
        The spec's ``[flow]`` table: viscosity, aux_length, sides ('slip' | 'noslip'),
        pressure_drop, optional edge_length (fraction), tol, max_memory_gb.
    mesh : PoreMesh, optional
        A mesh made earlier for this direction.

    Returns
    -------
    dict
        ``permeability_m2``, ``direction``, ``porosity``, ``solver``, ``n_dofs``,
        ``wall_time_s``, ``flux_imbalance``, ``converged``, ``residual``, ``iterations``,
        mesh size and quality, ``sides``, pressure drops.
    """
    from psdesign.meshing.pore_mesh import mesh_pore_space
    from solvers.fem_stokes import solve_stokes

    name, ax = axis_of(direction)
    t0 = time.perf_counter()
    spacing = fields.grid.spacing
    if not np.allclose(spacing, spacing[0], rtol=1e-9):
        raise ValueError("the fem route needs cubic voxels; make rve.size a multiple of rve.voxel")
    if mesh is None:
        mesh = mesh_pore_space(
            fields.distance,
            float(spacing[0]),
            rve.size,
            name,
            aux_length=float(flow["aux_length"]),
            **mesher_options(flow),
        )
    t_mesh = time.perf_counter() - t0
    sides = [t for t in mesh.facet_tags if tags.is_side(t)]
    slip = sides if flow.get("sides", "slip") == "slip" else []
    noslip = [tags.WALL] + ([] if slip else sides)
    dp = float(flow.get("pressure_drop", 1.0))
    res = solve_stokes(
        mesh.points,
        mesh.tets,
        mesh.facet_tags,
        p_inlet=dp,
        p_outlet=0.0,
        viscosity=float(flow["viscosity"]),
        noslip=noslip,
        slip=slip,
        tol=float(flow.get("tol") or 1e-6),
        max_memory_gb=flow.get("max_memory_gb"),
    )
    start, end = mesh.porous_region
    p_start = plane_average_pressure(mesh.points, mesh.tets, res.pressure, ax, start)
    p_end = plane_average_pressure(mesh.points, mesh.tets, res.pressure, ax, end)
    dp_rve = p_start - p_end
    q = abs(res.flux[tags.OUTLET])
    length = rve.size[ax]
    area = float(np.prod(np.delete(rve.size, ax)))
    mu = float(flow["viscosity"])
    k = darcy_permeability(q, mu, length, area, dp_rve)
    # diagnostic: the drop across the middle half of the RVE (free of entrance/exit effects)
    q1, q3 = start + 0.25 * (end - start), start + 0.75 * (end - start)
    dp_core = plane_average_pressure(
        mesh.points, mesh.tets, res.pressure, ax, q1
    ) - plane_average_pressure(mesh.points, mesh.tets, res.pressure, ax, q3)
    k_core = darcy_permeability(q, mu, q3 - q1, area, dp_core)
    return {
        "permeability_m2": k,
        "permeability_core_m2": k_core,
        "direction": name,
        "porosity": fields.porosity,
        "solver": "fem",
        "element": res.element,
        "n_dofs": res.n_dofs,
        "n_tets": res.n_tets,
        "n_points": res.n_points,
        "converged": bool(res.converged),
        "residual": float(res.residual),
        "iterations": int(res.iterations),
        "flux_imbalance": float(res.flux_imbalance),
        "flow_rate_m3_s": q,
        "pressure_drop_applied_pa": dp,
        "pressure_drop_rve_pa": dp_rve,
        "sides": "slip" if slip else "noslip",
        "aux_length": float(flow["aux_length"]),
        "mesh_quality": mesh.quality,
        "wall_time_s": time.perf_counter() - t0,
        "timings_s": {"mesh": t_mesh, **res.timings},
        "peak_memory_gb": float(res.peak_memory_gb),
    }
