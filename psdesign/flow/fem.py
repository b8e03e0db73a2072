"""Permeability with the tet mesh + Taylor-Hood route (``solver = "fem"``).

Two boundary-condition models (``flow.bc``, see ``docs/permeability.md``):

``"permeameter"`` (default)
    Pore-space tet mesh with empty auxiliary inlet/outlet zones
    (:func:`psdesign.meshing.pore_mesh.mesh_pore_space`), Taylor-Hood Stokes with prescribed
    pressures (:func:`solvers.fem_stokes.solve_stokes`). The pressure drop across the RVE is
    defined by the windowed dissipation (section "FEM permeameter: definition of the pressure
    drop"): ``dp = Phi_w / (Q int w dt)`` with ``Phi_w = int w mu |grad u|^2 dV`` and the window
    of :func:`psdesign.flow.darcy.window`: for two or more periods of the structure in the sample
    a flat-top window of whole periods in its middle (exact, zero near the faces, so the entrance
    and exit losses drop out); for one period ``w = sin^2(pi s / L)``.
``"periodic"``
    Mesh without auxiliary zones, periodic on all faces, driven by a mean pressure gradient
    (:func:`solvers.fem_stokes.solve_stokes_periodic`); K from the superficial mean velocity.
    Needs matching opposite faces (the lattice mesher gives them for periodic geometry);
    otherwise :class:`solvers.fem_stokes.PeriodicMeshError` says which face differs.

K always comes from :mod:`psdesign.flow.darcy`.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from psdesign import progress
from psdesign.errors import SpecError
from psdesign.flow.darcy import (  # noqa: F401 (rve_window: moved to darcy, re-exported)
    axis_of,
    darcy_column,
    darcy_permeability,
    periodic_gradient,
    rve_window,
    windowed_drop,
    windowed_drop_from_dissipation,
)
from psdesign.flow.fem_field import (
    FIELD_MAX_VOXELS,
    FIELD_VOXELS_PER_DIAMETER,
    fem_field,
    spec_grid_step,
)
from psdesign.flow.stack import plan_copies, stack_fields, stacked_flow, unmatched_faces
from psdesign.geometry.rve import RVE, VoxelFields, is_cubic
from psdesign.meshing import tags
from psdesign.meshing.options import (
    mesher_options,  # noqa: F401 (moved; re-exported)
    thinnest_fiber_diameter,
)
from psdesign.schema.budget import check_planned_stack, round_up
from psdesign.schema.flow import BC_MODELS as SCHEMA_BC_MODELS
from psdesign.schema.flow import FLOW_TOL, check_solver_bc, coarser_advice, resolution_key
from solvers.fem.memory import ESTIMATE_VERB, MemoryLimitError

#: The ``flow.bc`` models this route applies: every one.
BC_MODELS = SCHEMA_BC_MODELS


#: Layers of the plane-pressure profile whose windowed drop (:func:`windowed_drop`) is the
#: second estimator of the FEM permeameter's drop (error bar's window term): at least this many,
#: rounded up to a multiple of the periods in the sample so that a period is whole layers and the
#: estimator is exact in the periodic interior, like the dissipation form.
PLANE_PROFILE_LAYERS = 60


def _pressure_grid(points: np.ndarray, tets: np.ndarray, pressure: np.ndarray):
    import pyvista as pv

    cells = np.hstack([np.full((len(tets), 1), 4), tets]).ravel()
    grid = pv.UnstructuredGrid(cells, np.full(len(tets), pv.CellType.TETRA), points)
    grid.point_data["p"] = np.nan_to_num(pressure)
    return grid


def plane_average_pressure(
    points: np.ndarray, tets: np.ndarray, pressure: np.ndarray, axis: int, position: float
) -> float:
    """Area-averaged P1 pressure over the cross-section of a tet mesh at ``position``."""
    return _plane_average(_pressure_grid(points, tets, pressure), points, axis, position)


def plane_pressure_profile(
    points: np.ndarray,
    tets: np.ndarray,
    pressure: np.ndarray,
    axis: int,
    span: tuple[float, float],
    layers: int = PLANE_PROFILE_LAYERS,
) -> np.ndarray:
    """Area-averaged P1 pressure on ``layers + 1`` equally spaced planes from ``span[0]`` to
    ``span[1]`` (the input of :func:`psdesign.flow.darcy.windowed_drop`)."""
    grid = _pressure_grid(points, tets, pressure)
    planes = np.linspace(span[0], span[1], layers + 1)
    return np.array([_plane_average(grid, points, axis, s) for s in planes])


def _plane_average(grid, points: np.ndarray, axis: int, position: float) -> float:
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


def cells_per_diameter(rve: RVE, mesh) -> float | None:
    """Thinnest fiber diameter over the mean edge length of the RVE's tets (auxiliary zones
    excluded); None without fibers."""
    from psdesign.meshing.options import thinnest_fiber_diameter

    d_min = thinnest_fiber_diameter(rve)
    if d_min is None:
        return None
    pts, tets = mesh.points, mesh.tets
    start, end = mesh.porous_region
    centre = pts[tets].mean(axis=1)[:, mesh.axis]
    inside = tets[(centre > start) & (centre < end)]
    if len(inside) == 0:
        inside = tets
    pairs = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
    e = np.concatenate([pts[inside[:, i]] - pts[inside[:, j]] for i, j in pairs])
    return float(d_min / np.sqrt((e * e).sum(axis=1)).mean())


def _mesh(
    rve: RVE,
    fields: VoxelFields,
    name: str,
    flow: dict,
    bc: str,
    refinement: int = 1,
    step: dict | None = None,
):
    """Pore mesh of ``fields`` (the RVE or its stack). ``refinement > 1``: ``fields`` is the
    FEM's own field (:mod:`psdesign.flow.fem_field`), ``refinement`` times finer than the spec's
    grid. ``step``: the lattice step override (:func:`~psdesign.flow.fem_field.spec_grid_step`;
    None: the mesher's default)."""
    from psdesign.meshing.options import MeshOptions, thinnest_fiber_diameter
    from psdesign.meshing.pore_mesh import mesh_pore_space

    spacing = fields.grid.spacing
    if not is_cubic(spacing):
        raise ValueError("the fem route needs cubic voxels; make rve.size a multiple of rve.voxel")
    from psdesign.flow.no_path import says_closed_pore_space
    from psdesign.image.fields import mesh_overrides

    target = mesh_overrides(fields)  # an image: match the mesh to the voxel count
    # pytetwild's default edge length is a fraction of the thinnest fiber diameter
    target["fiber_diameter"] = thinnest_fiber_diameter(rve)
    size = np.asarray(fields.grid.size, float)  # rve.size, or the stack's (psdesign.flow.stack)
    target |= step or {}
    if bc != "periodic":
        opts = MeshOptions.from_flow(flow, periodic=False, **target)
        with says_closed_pore_space(fields, name, periodic=False):
            return mesh_pore_space(fields.distance, float(spacing[0]), size, name, opts)
    from psdesign.meshing.errors import MeshFailedError
    from solvers.fem.periodic import PeriodicMeshError

    if refinement == 1:  # else checked on the spec's grid (permeability_fem): the same tolerance
        check_periodic_geometry(rve, fields)
    opts = MeshOptions.from_flow(flow, aux_length=0.0, periodic=True, **target)
    try:
        with says_closed_pore_space(fields, name, periodic=True):
            return mesh_pore_space(fields.distance, float(spacing[0]), size, name, opts)
    except MeshFailedError as exc:  # a check failed on the mesh of the wrapped field
        raise PeriodicMeshError(f"flow.bc = 'periodic': {exc}") from None


def fem_mesh(
    rve: RVE, fields: VoxelFields, direction: str, flow: dict, bc: str, copies: int = 1
) -> tuple:
    """The FEM route's pore mesh of ``rve`` along ``direction`` and its field.

    The mesh is made on the FEM's own field (:func:`psdesign.flow.fem_field.fem_field`: the
    analytic geometry sampled fine enough for the thinnest fiber, independent of the spec's
    ``fields`` where those are coarser), ``copies`` copies along the flow for the permeameter,
    at the default lattice step of the spec's grid within the memory budget
    (:func:`psdesign.flow.fem_field.spec_grid_step`) unless ``flow.lattice_step`` is given.

    Returns
    -------
    (PoreMesh, dict, str or None)
        The mesh, :meth:`~psdesign.flow.fem_field.FemField.as_dict` of its field (the field
        itself is not kept: the solve does not need it), and the note of a default lattice step
        coarsened to fit the memory budget (None if it was not).
    """
    from psdesign.meshing.options import thinnest_fiber_diameter

    ax = axis_of(direction)[1]
    own = fem_field(rve, fields, flow.get("mesher") or "stuffing", copies)
    if bc == "periodic" and own.refinement > 1:
        check_periodic_geometry(rve, fields)  # on the spec's grid: the same tolerance
    step, note = spec_grid_step(
        flow,
        float(fields.grid.spacing[0]),
        fields.grid.size,
        thinnest_fiber_diameter(rve),
        copies,
        float(fields.porosity),
    )
    stacked = stack_fields(own.fields, ax, copies)
    mesh = _mesh(rve, stacked, direction, stacked_flow(flow, copies), bc, own.refinement, step)
    return mesh, own.as_dict(), note


def check_periodic_geometry(rve: RVE | None, fields: VoxelFields) -> None:
    """Refuse ``bc = "periodic"`` on a geometry whose opposite faces differ
    (:func:`psdesign.flow.stack.end_planes`: the same test as the stacked permeameter's).

    The mesher would mesh the wrapped field, whose faces then meet at seams of cut fibers: not
    the RVE's material, and at the default lattice step the seams leave solid tet centroids
    (measured: 4 % within two voxels of the faces of six tilted rods). The one rule of the fem
    route and of ``psdesign mesh``'s periodic exports (session 54: mesh wrote cyclic patches of
    such a geometry, exit 0).

    Parameters
    ----------
    rve : RVE or None
        The analytic RVE (its union field decides near the surface); None for an image (its
        voxel layers decide).
    fields : VoxelFields
        Its voxel fields on the spec's grid (the tolerance is a length, the same on every grid).

    Raises
    ------
    solvers.fem.periodic.PeriodicMeshError
        One line naming ``flow.bc`` and the faces that differ (the CLI exits 2 with it).
    """
    from solvers.fem.periodic import PeriodicMeshError

    faces = unmatched_faces(rve, fields)
    if faces:
        raise PeriodicMeshError(
            f"flow.bc = 'periodic': the geometry is not periodic, its {faces}: "
            "the FEM needs a periodic RVE; use bc = 'permeameter', or solver = 'voxel' (it "
            "solves the wrapped grid as it is and reports face_mismatch)"
        )


def _common(res, mesh, rve, fields, name, flow, bc, t0, t_mesh) -> dict:
    notes = []
    if not fields.analytic_distance:
        v = mesh.quality.get("volume_target_m3")
        notes.append(
            f"K_{name}: image input has no analytic pore volume: the mesh matched the voxel "
            f"count ({v:.4g} m^3)"
        )
    return {
        "warnings": notes,
        "direction": name,
        "porosity": fields.porosity,
        "porosity_error": fields.porosity_error,
        "solver": "fem",
        "bc": bc,
        "element": res.element,
        "n_dofs": res.n_dofs,
        "n_tets": res.n_tets,
        "n_points": res.n_points,
        "converged": bool(res.converged),
        "residual": float(res.residual),
        "iterations": int(res.iterations),
        "flux_imbalance": float(res.flux_imbalance),
        "cells_per_diameter": cells_per_diameter(rve, mesh),
        "mesh_quality": mesh.quality,
        "pore_volume_target": mesh.quality.get("volume_target"),
        "pore_volume_target_m3": mesh.quality.get("volume_target_m3"),
        "wall_time_s": time.perf_counter() - t0,
        "timings_s": {"mesh": t_mesh, **res.timings},
        "peak_memory_gb": float(res.peak_memory_gb),
    }


def permeability_fem(
    rve: RVE, fields: VoxelFields, direction: str | int, flow: dict, mesh=None, capture=None
) -> dict:
    """Permeability along one axis with the tet mesh + Taylor-Hood route.

    Parameters
    ----------
    rve : RVE
    fields : VoxelFields
        Voxelized RVE (its distance field is meshed).
    direction : 'x' | 'y' | 'z'
    flow : dict
        The spec's ``[flow]`` table: viscosity, bc ('permeameter' | 'periodic', default
        'permeameter'), aux_length, sides ('slip' | 'noslip'), pressure_drop, optional
        edge_length (fraction), lattice_step, tol, max_memory_gb.
    mesh : PoreMesh, optional
        A mesh made earlier for this direction (and BC: without auxiliary zones for periodic).
    capture : callable, optional
        Called as ``capture("fem_flow", solution=StokesResult, result=dict, mesh=PoreMesh,
        flow=dict)`` after the solve (:mod:`psdesign.fields` writes the fields).

    Returns
    -------
    dict
        ``permeability_m2``, ``direction``, ``porosity``, ``solver``, ``bc``, ``n_dofs``,
        ``wall_time_s``, ``flux_imbalance``, ``converged``, ``residual``, ``iterations``,
        ``cells_per_diameter``, mesh size and quality; permeameter: ``sides``, ``aux_length``,
        ``flow_rate_m3_s``, ``pressure_drop_applied_pa``, ``pressure_drop_rve_pa`` (the
        windowed-dissipation drop that defines K) and ``pressure_drop_faces_pa`` (drop of
        the plane-averaged pressure between the RVE faces, includes entrance/exit losses);
        periodic: ``mean_velocity_m_s`` (superficial, 3 components), ``pressure_gradient_pa_m``
        and ``permeability_column_m2`` (K[:, j]); ``fem_field``: the meshed field
        (:meth:`psdesign.flow.fem_field.FemField.as_dict`; None for a mesh given by the caller).

    Raises
    ------
    ValueError
        Unknown ``bc``; :class:`solvers.fem_stokes.PeriodicMeshError` when ``bc='periodic'``
        and the mesh's opposite faces do not match.
    """
    name, ax = axis_of(direction)
    bc = flow.get("bc") or "permeameter"
    check_solver_bc(bc=bc)
    t0 = time.perf_counter()
    plan = plan_copies(flow, rve, fields, ax) if bc == "permeameter" else None
    own, note = None, None
    if mesh is None:  # the permeameter meshes plan.copies copies along the flow
        copies = plan.copies if plan is not None else 1
        spacing, porosity = float(fields.grid.spacing[0]), float(fields.porosity)
        d = thinnest_fiber_diameter(rve)
        check_planned_stack(flow, "fem", copies, fields.grid.size, spacing, porosity, d)
        mesh, own, note = fem_mesh(rve, fields, name, flow, bc, copies)
        if note:
            progress.stage(f"K_{name}: {note}")
    elif plan is not None:  # a mesh made by the caller: its RVE part says how many copies
        start, end = mesh.porous_region
        plan = replace(plan, copies=max(1, round((end - start) / float(rve.size[ax]))))
    t_mesh = time.perf_counter() - t0
    try:
        if plan is None:
            res, out = _periodic(rve, fields, name, ax, flow, mesh, t0, t_mesh)
        else:
            periods = plan.copies * plan.periods  # of the structure in the sample: the window
            res, out = _permeameter(rve, fields, name, ax, flow, mesh, t0, t_mesh, periods)
    except MemoryLimitError as exc:  # the solver's "... or pass force=True": no spec key
        raise memory_error(exc, mesh, flow.get("max_memory_gb"), flow.get("mesher")) from None
    if plan is not None:
        out |= plan.as_dict()
        if plan.note:
            out["warnings"].append(plan.note)
    out["fem_field"] = own
    if note:
        out["warnings"].append(f"K_{name}: {note}")
    if own is not None and own["rel_error"] > 0:
        out["warnings"].append(
            f"K_{name}: the FEM's field has {own['voxels_per_diameter']:.1f} voxels across the "
            f"thinnest fiber (< {FIELD_VOXELS_PER_DIAMETER:g}; refined x{own['refinement']} of "
            f"x{own['wanted_refinement']} wanted, at most {FIELD_MAX_VOXELS:.3g} voxels): the "
            f"mesh's solid volume may be under-counted, {100 * own['rel_error']:.1f} % in the "
            "error bar; refine rve.voxel"
        )
    if capture is not None:
        capture("fem_flow", solution=res, result=out, mesh=mesh, flow=flow)
    return out


#: Rough FEM solve rate for the up-front estimate (s per unknown; measured: 31 k unknowns of
#: an unstructured P2-P1 mesh in 3 s, the quickstart's ~200 k in 20-30 s on 2 cores).
FEM_SECONDS_PER_UNKNOWN = 1.2e-4


def memory_error(
    exc: MemoryLimitError, mesh, cap: float | None, mesher: str | None = None
) -> SpecError:
    """The solve's memory refusal as the spec's one line naming ``flow.max_memory_gb``
    (``cap``; without it the limit is 80 % of the free memory), where the solver's line said
    "pass force=True", no key of a spec or option of a command. The coarser mesh it advises is
    the key of the route's ``mesher`` (``flow.mesher``,
    :func:`psdesign.schema.flow.resolution_key`): ``flow.edge_length`` for pytetwild, which
    ignores the lattice step the line named before session 41."""
    if exc.estimate_gb is None:
        return SpecError("flow.max_memory_gb", str(exc))
    limit = "the cap" if cap is not None else "80 % of the free memory"
    advice = coarser_advice(resolution_key("fem", mesher))
    return SpecError(
        "flow.max_memory_gb",
        f"the FEM solve of {len(mesh.tets)} tets {ESTIMATE_VERB} about {exc.estimate_gb:.3g} GB, "
        f"over {limit} ({exc.limit_gb:.3g} GB) (allowed: >= {round_up(exc.estimate_gb):.3g} GB, "
        f"or {advice})",
    )


def _announce(mesh, name: str) -> None:
    """Time and memory estimate of the Taylor-Hood solve of ``mesh`` on stderr (CLI only)."""
    from solvers.fem.memory import estimate_memory_gb
    from solvers.fem.memory import unknowns as count_unknowns

    n_p, n_t = len(mesh.points), len(mesh.tets)
    unknowns = count_unknowns(n_p, n_t)
    progress.estimate(
        f"FEM solve {name} ({unknowns:.3g} unknowns)",
        FEM_SECONDS_PER_UNKNOWN * unknowns,
        estimate_memory_gb(n_p, n_t),
    )


def _solver_options(flow: dict, name: str):
    """The FEM solve's :class:`~solvers.fem.options.StokesOptions` from the ``[flow]`` table
    (``tol``, ``max_memory_gb``) with the CLI's progress lines for ``K_<name>``."""
    from solvers.fem.options import StokesOptions

    return StokesOptions(
        tol=float(flow.get("tol") or FLOW_TOL),
        max_memory_gb=flow.get("max_memory_gb"),
        progress=progress.iterations(f"FEM solve {name}", "GMRES"),
        stage=lambda message: progress.stage(f"FEM solve {name}: {message}"),
        assembly_progress=progress.counted(f"FEM solve {name}: assembling", "elements"),
    )


def _periodic(rve, fields, name, ax, flow, mesh, t0, t_mesh) -> dict:
    from solvers.fem_stokes import solve_stokes_periodic

    mu = float(flow["viscosity"])
    grad = periodic_gradient(flow, rve.size[ax])
    _announce(mesh, name)
    res = solve_stokes_periodic(
        mesh.points,
        mesh.tets,
        mesh.facet_tags,
        axis=ax,
        pressure_gradient=grad,
        viscosity=mu,
        options=_solver_options(flow, name),
    )
    u = np.asarray(res.mean_velocity, dtype=float)
    col = darcy_column(u, mu, grad)
    return res, {
        "permeability_m2": float(col[ax]),
        **_common(res, mesh, rve, fields, name, flow, "periodic", t0, t_mesh),
        "permeability_column_m2": col.tolist(),
        "mean_velocity_m_s": u.tolist(),
        "pressure_gradient_pa_m": grad,
        "wall_time_s": time.perf_counter() - t0,
    }


def _permeameter(rve, fields, name, ax, flow, mesh, t0, t_mesh, periods: int = 1) -> dict:
    from solvers.fem_stokes import solve_stokes

    sides = [t for t in mesh.facet_tags if tags.is_side(t)]
    slip = sides if flow.get("sides", "slip") == "slip" else []
    noslip = [tags.WALL] + ([] if slip else sides)
    dp = float(flow.get("pressure_drop", 1.0))
    mu = float(flow["viscosity"])
    _announce(mesh, name)
    res = solve_stokes(
        mesh.points,
        mesh.tets,
        mesh.facet_tags,
        p_inlet=dp,
        p_outlet=0.0,
        viscosity=mu,
        noslip=noslip,
        slip=slip,
        options=_solver_options(flow, name),
    )
    start, end = mesh.porous_region
    q = abs(res.flux[tags.OUTLET])
    length = end - start
    area = float(np.prod(np.delete(rve.size, ax)))
    # windowed dissipation (psdesign.flow.darcy): Phi_w = G Q L int w dt -> dp_rve = G L
    window = rve_window(ax, start, end, periods)
    dp_rve = windowed_drop_from_dissipation(res.dissipation(window), q, periods)
    k = darcy_permeability(q, mu, length, area, dp_rve)
    layers = periods * math.ceil(PLANE_PROFILE_LAYERS / periods)  # whole layers per period
    profile = plane_pressure_profile(mesh.points, mesh.tets, res.pressure, ax, (start, end), layers)
    p_start, p_end = profile[0], profile[-1]
    return res, {
        "permeability_m2": k,
        **_common(res, mesh, rve, fields, name, flow, "permeameter", t0, t_mesh),
        "flow_rate_m3_s": q,
        "pressure_drop_applied_pa": dp,
        "pressure_drop_rve_pa": dp_rve,
        "pressure_drop_faces_pa": float(p_start - p_end),
        # second windowed estimator (plane pressure): its gap to dp_rve is the error bar's
        # window term, as on the voxel route (psdesign.flow.error.window_rel_error)
        "pressure_drop_plane_window_pa": windowed_drop(profile, periods),
        "pressure_drop_definition": "windowed-dissipation",
        "rve_length_m": float(length),
        "sides": "slip" if slip else "noslip",
        "aux_length": float(flow["aux_length"]),
        "wall_time_s": time.perf_counter() - t0,
    }
