"""Permeability with the voxel Stokes route (``solver = "voxel"``).

The MAC solver (:func:`solvers.voxel_stokes.solve_voxel_stokes`) returns fields and fluxes; K is
formed here, through :mod:`psdesign.flow.darcy` only:

* ``bc = "periodic"`` (default): ``K[:, j] = mu <u> / G`` (:func:`darcy_column`) from the
  superficial mean velocity of the periodic grid driven by the mean gradient ``G``;
* ``bc = "permeameter"``: ``K = mu Q L / (A dP_rve)`` (:func:`darcy_permeability`) with Q the flow
  rate, L and A the RVE length and full cross-section and dP_rve the windowed-dissipation drop
  (:func:`psdesign.flow.darcy.windowed_drop` of the energy flux per unit flow rate on the RVE's face
  planes: the FEM route's definition, without entrance and exit losses), the RVE sitting between
  empty reservoirs of ``flow.aux_length`` x L with lateral walls ``flow.sides``.

Walls are sub-voxel (from the RVE's analytic distance field) unless ``flow.wall_treatment =
"staircase"``; ``"diffuse"`` is the monotonically converging diffuse-domain wall
(:mod:`psdesign.flow.diffuse`: periodic, straight cylinder / rod fibres, small grids).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable

import numpy as np

from psdesign.flow.darcy import (
    axis_of,
    darcy_column,
    darcy_permeability,
    periodic_gradient,
    permeability_tensor,
    windowed_drop,
)
from psdesign.flow.error import (
    MIN_CELLS_PER_DIAMETER,
    cells_per_diameter,
    count_below,
    under_resolved,
)
from psdesign.flow.no_path import no_path_message
from psdesign.flow.stack import plan_copies, stack_fields, unmatched_faces
from psdesign.flow.voxel_estimate import announce_voxel_solve
from psdesign.geometry.rve import RVE, VoxelFields, is_cubic, resolution_measure
from psdesign.schema.budget import check_planned_stack
from psdesign.schema.flow import BC_MODELS as SCHEMA_BC_MODELS
from psdesign.schema.flow import FLOW_TOL, WALL_TREATMENTS, check_solver_bc

#: The ``flow.bc`` models this route applies: every one.
BC_MODELS = SCHEMA_BC_MODELS


class ResolutionWarning(UserWarning):
    """The voxel grid resolves the thinnest fiber with fewer than ``MIN_CELLS_PER_DIAMETER``."""


def face_mismatch(solid: np.ndarray) -> list[float]:
    """Per axis, the fraction of voxels on the first face whose solid/pore state differs
    from the opposite face: 0 for a periodic geometry."""
    out = []
    for ax in range(3):
        first = np.take(solid, 0, axis=ax)
        last = np.take(solid, -1, axis=ax)
        out.append(float(np.mean(first != last)))
    return out


def _seam_notes(name: str, rve: RVE | None, fields: VoxelFields) -> list[str]:
    """A warning when ``bc = "periodic"`` wraps a geometry whose opposite faces differ
    (:func:`psdesign.flow.stack.end_planes`, the FEM route's refusal test): the solve is then
    of the wrapped grid, seams of cut fibers included, not of the RVE's material."""
    faces = unmatched_faces(rve, fields)
    if not faces:
        return []
    return [
        f"K_{name}: bc = 'periodic' on a geometry that is not periodic (its {faces}): the wrapped "
        "grid's seams are part of this K; bc = 'permeameter' measures the sample as it is"
    ]


def column_of(res) -> np.ndarray:
    """Permeability column ``K[:, direction]`` (m^2) of a periodic solve (:func:`darcy_column`)."""
    return darcy_column(res.mean_velocity, res.viscosity, res.pressure_gradient)


def rve_drop(res, periods: int = 1) -> float:
    """The pressure drop (Pa) across the RVE that defines the permeameter K: the windowed
    dissipation drop (:func:`windowed_drop` of ``res.rve_energy_flux_profile`` with the window for
    ``periods`` periods of the structure in the sample, no entrance and exit losses);
    ``res.rve_pressure_drop`` for a periodic solve (``G L``)."""
    profile = getattr(res, "rve_energy_flux_profile", None)
    if profile is None:
        return float(res.rve_pressure_drop)
    return windowed_drop(profile, periods)


def permeameter_k(res, periods: int = 1) -> float:
    """``K = mu Q L / (A dP_rve)`` (m^2) of a solve (:func:`darcy_permeability`) with the drop
    :func:`rve_drop` (``periods``: periods of the structure in the sample); for a periodic solve
    without treatment it equals ``column_of(res)[direction]``."""
    return darcy_permeability(
        res.flow_rate, res.viscosity, res.rve_length, res.rve_area, rve_drop(res, periods)
    )


def voxel_permeability_tensor(
    solid: np.ndarray, voxel_size: float, viscosity: float = 1.0, **kw: object
) -> tuple[np.ndarray, list]:
    """Full 3x3 periodic permeability tensor (m^2) from three solves; column j = flow along j.

    Extra keyword arguments go to :func:`solvers.voxel_stokes.solve_voxel_stokes`.
    Returns ``(K, results)``.
    """
    from solvers.voxel_stokes import solve_voxel_stokes

    results = [
        solve_voxel_stokes(solid, voxel_size, d, viscosity=viscosity, **kw) for d in range(3)
    ]
    return permeability_tensor([column_of(r) for r in results]), results


def _options(flow: dict) -> tuple[str, str]:
    bc = flow.get("bc") or "periodic"
    check_solver_bc(bc=bc)
    wall = flow.get("wall_treatment") or "subvoxel"
    if wall not in WALL_TREATMENTS:
        raise ValueError(
            f"flow.wall_treatment: must be one of {', '.join(WALL_TREATMENTS)}, got {wall!r}"
        )
    return bc, wall


def permeability_voxel(
    fields: VoxelFields,
    direction: str | int,
    flow: dict,
    progress: Callable[[int, float], None] | None = None,
    rve: RVE | None = None,
    capture: Callable[..., None] | None = None,
) -> dict:
    """Permeability along one axis from the voxel Stokes solver.

    ``flow.bc = "periodic"`` (default) treats the grid as periodic. A non-periodic RVE (random
    tilted fibers) is solved as is, as PuMA does; the result reports ``face_mismatch`` (per
    axis, the fraction of face voxels whose state differs from the opposite face) and
    ``geometry_periodic`` (all mismatches below 1 %), and warns when the end planes differ
    (:func:`psdesign.flow.stack.end_planes`, the FEM route's refusal test);
    ``flow.periodic_treatment = "mirror"`` mirrors the grid along the flow instead. ``flow.bc =
    "permeameter"`` puts the RVE between empty reservoirs (``flow.aux_length``, ``flow.sides``,
    ``flow.pressure_drop`` between the reservoir ends) and reports ``K = mu Q L / (A dP_rve)``
    with the windowed-dissipation drop ``pressure_drop_rve_pa`` (:func:`rve_drop`;
    ``pressure_drop_faces_pa``: the drop between the RVE's face planes, entrance and exit losses
    included, a diagnostic).

    ``progress(iterations, residual)`` is passed to the solver. With ``rve`` the result has
    ``cells_per_diameter`` (voxels across the thinnest fiber) and a :class:`ResolutionWarning`
    is issued below ``MIN_CELLS_PER_DIAMETER``. With ``capture`` the solver also returns its
    velocity and pressure fields and ``capture("voxel_flow", solution=..., result=...,
    fields=..., flow=...)`` is called after the solve (:mod:`psdesign.fields`).
    """
    from solvers.voxel_stokes import NoFluidPathError, solve_voxel_stokes, solved_shape

    name, ax = axis_of(direction)
    bc, wall = _options(flow)
    notes = []
    if not fields.analytic_distance:  # a segmented image: no surface to put sub-voxel walls on
        wall = "staircase"
        notes.append(
            f"K_{name}: image input has no analytic surface: wall_treatment = 'staircase' "
            "(first-order walls on the voxel faces)"
        )
    h = _cubic_voxel(fields)
    cpd = cells_per_diameter(rve, h)
    if under_resolved(cpd, MIN_CELLS_PER_DIAMETER):
        warnings.warn(
            f"voxel grid has {count_below(cpd, MIN_CELLS_PER_DIAMETER)} voxels across the "
            f"thinnest {resolution_measure(rve)} (< "
            f"{MIN_CELLS_PER_DIAMETER:g}): K may be off by several per cent; refine rve.voxel",
            ResolutionWarning,
            stacklevel=2,
        )
    t0 = time.perf_counter()
    try:
        if wall == "diffuse":
            plan, solve = None, fields
            res = _diffuse(rve, fields, name, flow, h, bc, progress, capture is not None)
        else:
            plan, solve, kw = _solve_setup(flow, rve, fields, ax, h, bc, wall)
            treatment = flow.get("periodic_treatment") or "periodic"
            aux = kw.get("aux_length", 0.0)
            announce_voxel_solve(name, solved_shape(solve.solid.shape, ax, bc, treatment, aux))
            res = solve_voxel_stokes(
                solve.solid,
                h,
                name,
                viscosity=float(flow["viscosity"]),
                periodic_treatment=flow.get("periodic_treatment", "periodic"),
                progress=progress,
                return_velocity=capture is not None,
                return_pressure=capture is not None,
                **kw,
            )
    except NoFluidPathError as exc:
        distance = fields.distance if fields.analytic_distance else None
        grid = "permeameter" if bc == "permeameter" else flow.get("periodic_treatment")
        line = no_path_message(name, h, distance, ax, wall, rve, grid or "periodic")
        raise NoFluidPathError(line) from exc
    periods = plan.copies * plan.periods if plan is not None else 1
    out = _result(res, fields, (name, ax), bc, flow, periods, cpd, t0)
    # parallel kernels not compiled yet (res.serial_fallback) make a solve slower, not its
    # result less true: said in ``thread_note`` and by the CLI's closing note, not in the
    # result's warnings, which must not depend on the state of numba's cache
    if plan is not None and plan.note:
        notes.append(plan.note)
    if bc == "periodic" and out["periodic_treatment"] == "periodic":
        notes.extend(_seam_notes(name, rve, fields))
    if notes:
        out["warnings"] = notes
    if bc == "permeameter":
        out |= plan.as_dict() | _permeameter_drops(res, flow, periods)
    if capture is not None:
        capture("voxel_flow", solution=res, result=out, fields=solve, flow=flow)
    return out


def refuse_without_path(
    fields: VoxelFields, direction: str | int, flow: dict, rve: RVE | None = None
) -> None:
    """Refuse, before any work, a voxel solve whose grid has no fluid path along
    ``direction``: the solver's own test (:func:`solvers.voxel_stokes.percolates`) of the grid
    it solves (:func:`psdesign.flow.no_path.solved_pore`), the periodic one with its treatment
    (``flow.periodic_treatment``) or the permeameter's planned copies between reservoirs and
    side walls, raised with the route's line (:func:`psdesign.flow.no_path.no_path_message`),
    whose own tests ask the same question of the same grid. The caller runs it before
    the time and memory estimate, so the refusal is the only line (an image without a path
    printed the estimate first: the periodic route until session 43, the permeameter until
    session 44). The diffuse wall's fluid fractions are left to its solve's own test.

    Raises
    ------
    solvers.voxel_stokes.NoFluidPathError
        The pore space of the solved grid has no path along ``direction``.
    """
    from psdesign.flow.no_path import solved_pore
    from psdesign.geometry.throat import percolates
    from solvers.voxel_stokes import NoFluidPathError

    bc, wall = _options(flow)
    if wall == "diffuse":
        return
    name, ax = axis_of(direction)
    treatment = flow.get("periodic_treatment") or "periodic"
    solved = "permeameter" if bc == "permeameter" else treatment
    solid = fields.solid
    if bc == "permeameter":
        reps = [plan_copies(flow, rve, fields, ax).copies if a == ax else 1 for a in range(3)]
        solid = np.tile(solid, reps)
    if percolates(solved_pore(~solid, ax, solved), ax):
        return
    distance = fields.distance if fields.analytic_distance else None
    line = no_path_message(name, _cubic_voxel(fields), distance, ax, wall, rve, solved)
    raise NoFluidPathError(line)


def _diffuse(rve, fields, name, flow, h, bc, progress, return_fields):
    """The diffuse-wall solve (:mod:`psdesign.flow.diffuse`) with the route's resolved ``bc``,
    refused with the reason where it does not apply."""
    from psdesign.flow import diffuse

    treatment = flow.get("periodic_treatment") or "periodic"
    why = diffuse.unsupported(rve, fields, bc, treatment)
    if why is not None:
        raise ValueError(f"flow.wall_treatment: {why}")
    if return_fields:  # the assembled solve keeps no pressure: refused before it runs
        raise ValueError(
            "fields: not with flow.wall_treatment = 'diffuse' (its solve keeps no pressure field)"
        )
    from psdesign.geometry.walls import box_shifts

    images = len(rve.fibers) * len(box_shifts(rve.fibers, rve.size / rve.period)[0])
    announce_voxel_solve(name, fields.solid.shape, diffuse_images=images)
    return diffuse.solve_diffuse(rve, fields, name, flow, h, progress)


def _cubic_voxel(fields: VoxelFields) -> float:
    spacing = fields.grid.spacing
    if not is_cubic(spacing):
        raise ValueError(
            "the voxel route needs cubic voxels; make rve.size a multiple of rve.voxel"
        )
    return float(spacing[0])


def _solve_setup(flow, rve, fields, ax, h, bc, wall):
    """``(plan, grid, solver keywords)``: the copies stacked along the flow for the permeameter
    (:mod:`psdesign.flow.stack`; ``plan`` None for the periodic bc) and what the solver needs
    beyond the grid."""
    kw: dict = {"bc": bc, "tol": float(flow.get("tol") or FLOW_TOL)}
    if wall == "subvoxel":
        kw["distance"] = fields.distance
    if bc != "permeameter":
        # the spec's drop over the RVE's length, as the FEM's periodic solve (a mirrored or
        # framed grid is longer; its mean gradient is still the RVE's)
        kw["pressure_gradient"] = periodic_gradient(flow, fields.grid.shape[ax] * h)
        return None, fields, kw
    from solvers.voxel_stokes import solved_shape

    plan = plan_copies(flow, rve, fields, ax)  # m copies along the flow
    key = "rve.voxel" if fields.analytic_distance else "image.crop"
    check_planned_stack(flow, "voxel", plan.copies, fields.grid.size, h, None, None, key)
    solve = stack_fields(fields, ax, plan.copies)
    if wall == "subvoxel":
        kw["distance"] = solve.distance
    aux = float(flow.get("aux_length", 0.2)) / plan.copies  # reservoirs: one copy's aux
    kw["aux_length"] = aux
    kw["sides"] = flow.get("sides", "slip")
    # the drop is over the whole solved length, reservoirs included (the solver's own rule)
    n_tot = solved_shape(solve.solid.shape, ax, "permeameter", aux_length=aux)[ax]
    kw["pressure_gradient"] = float(flow.get("pressure_drop", 1.0)) / (n_tot * h)
    return plan, solve, kw


def _result(res, fields, direction, bc, flow, periods, cpd, t0) -> dict:
    """The result of one solve (``direction`` = (name, axis); the key order is the JSON's)."""
    name, ax = direction
    column = column_of(res)
    if bc == "periodic":
        k = float(column[ax])
    else:
        k = permeameter_k(res, periods)
        column = column * (k / column[ax])
    mismatch = face_mismatch(fields.solid)
    return {
        "permeability_m2": k,
        "permeability_column_m2": column.tolist(),
        "direction": name,
        "porosity": fields.porosity,
        "porosity_error": fields.porosity_error,
        "solver": "voxel",
        "bc": bc,
        "wall_treatment": res.wall_treatment,
        "cells_per_diameter": cpd,
        "n_cells": int(res.n_cells),
        "converged": bool(res.converged),
        "residual": float(res.residual),
        "iterations": int(res.iterations),
        "flux_imbalance": float(res.flux_imbalance),
        "message": res.message,
        "face_mismatch": mismatch,
        "geometry_periodic": bool(max(mismatch) < 0.01),
        "periodic_treatment": flow.get("periodic_treatment", "periodic"),
        "flow_rate_m3_s": float(res.flow_rate),
        "mean_velocity_m_s": np.asarray(res.mean_velocity, float).tolist(),
        "pressure_gradient_pa_m": float(res.pressure_gradient),
        "wall_time_s": time.perf_counter() - t0,
        "threads_used": int(res.threads_used),
        "thread_note": res.thread_note,
    }


def _permeameter_drops(res, flow: dict, periods: int) -> dict:
    """The permeameter's reservoir set-up and the pressure drops (the defining one and the
    diagnostics)."""
    return {
        "sides": res.sides,
        "aux_length": float(flow.get("aux_length", 0.2)),
        "pressure_drop_applied_pa": float(res.applied_pressure_drop),
        "pressure_drop_rve_pa": rve_drop(res, periods),
        "pressure_drop_faces_pa": float(res.rve_pressure_drop),
        "pressure_drop_plane_window_pa": windowed_drop(res.rve_plane_pressure_profile, periods),
        "rve_length_m": float(res.rve_length),
        "pressure_drop_definition": "windowed-dissipation",
    }
