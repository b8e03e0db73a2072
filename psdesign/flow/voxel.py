"""Permeability with the periodic voxel Stokes route (``solver = "voxel"``).

Periodic body-force Stokes on the voxel grid (:func:`solvers.voxel_stokes.solve_voxel_stokes`);
K by :func:`psdesign.flow.darcy.darcy_column` from the superficial mean velocity.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from psdesign.flow.darcy import axis_of
from psdesign.geometry.rve import VoxelFields


def face_mismatch(solid: np.ndarray) -> list[float]:
    """Per axis, the fraction of voxels on the first face whose solid/pore state differs
    from the opposite face: 0 for a periodic geometry."""
    out = []
    for ax in range(3):
        first = np.take(solid, 0, axis=ax)
        last = np.take(solid, -1, axis=ax)
        out.append(float(np.mean(first != last)))
    return out


def permeability_voxel(
    fields: VoxelFields,
    direction: str | int,
    flow: dict,
    progress: Callable[[int, float], None] | None = None,
) -> dict:
    """Permeability column along one axis from the periodic voxel Stokes solver.

    The solver treats the grid as periodic. A non-periodic RVE (random tilted fibers) is
    solved as is, as PuMA does: fibers are cut at the faces and meet mismatched
    neighbours across them. The result reports ``face_mismatch`` (per axis, the fraction
    of face voxels whose state differs from the opposite face; compare with the solid
    fraction of the face for random geometry) and ``geometry_periodic`` (all mismatches
    below 1 %); ``flow.periodic_treatment = "mirror"`` mirrors the grid along the flow
    to make it periodic instead. ``progress(iterations, residual)`` is passed to the solver
    (periodic progress reports).
    """
    from solvers.voxel_stokes import solve_voxel_stokes

    name, ax = axis_of(direction)
    spacing = fields.grid.spacing
    if not np.allclose(spacing, spacing[0], rtol=1e-9):
        raise ValueError(
            "the voxel route needs cubic voxels; make rve.size a multiple of rve.voxel"
        )
    t0 = time.perf_counter()
    kw = {}
    if flow.get("tol") is not None:
        kw["tol"] = float(flow["tol"])
    res = solve_voxel_stokes(
        fields.solid,
        float(spacing[0]),
        name,
        viscosity=float(flow["viscosity"]),
        periodic_treatment=flow.get("periodic_treatment", "periodic"),
        progress=progress,
        **kw,
    )
    column = np.asarray(res.permeability, float)
    return {
        "permeability_m2": float(column[ax]),
        "permeability_column_m2": column.tolist(),
        "direction": name,
        "porosity": fields.porosity,
        "solver": "voxel",
        "n_cells": int(res.n_cells),
        "converged": bool(res.converged),
        "residual": float(res.residual),
        "iterations": int(res.iterations),
        "flux_imbalance": float(getattr(res, "flux_imbalance", 0.0)),
        "message": getattr(res, "message", ""),
        "face_mismatch": (mismatch := face_mismatch(fields.solid)),
        "geometry_periodic": bool(max(mismatch) < 0.01),
        "periodic_treatment": flow.get("periodic_treatment", "periodic"),
        "wall_time_s": time.perf_counter() - t0,
    }
