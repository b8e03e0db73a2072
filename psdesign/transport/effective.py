"""Effective property of a voxel conductivity map from one Laplace solve, with an error
estimate (shared by diffusivity and conductivity).

``value = <J_a> / |grad T|`` (superficial mean flux over the box per unit applied gradient, in
the units of the conductivity map), and for periodic BC the whole column ``<J_b> / |grad T|``.
The error estimate combines the solver's flux imbalance with, for
``error_estimate = "resolution"``, a second solve on the grid coarsened by two (the signed
distance averaged over 2x2x2 blocks, so the surface is re-sampled, not eroded):
``rel_error = max(flux_imbalance, |X_h - X_2h| / X_h)`` (the voxel staircase error is first
order in ``h``, so ``X_h - X_2h`` estimates the error of ``X_h``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from psdesign.flow.darcy import axis_of
from psdesign.geometry.rve import VoxelFields

BC_NAMES = ("periodic", "permeameter")


@dataclass
class Effective:
    """One effective-property solve (see module docstring)."""

    direction: str
    bc: str
    value: float
    column: list[float]
    converged: bool
    residual: float
    iterations: int
    flux_imbalance: float
    rel_error: float
    error_method: str
    blocked: bool
    message: str
    n_cells: int
    wall_time_s: float
    coarse_value: float | None = None
    extra: dict = field(default_factory=dict)


def fields_from_solid(solid: np.ndarray, voxel: float) -> VoxelFields:
    """VoxelFields of a voxel image (True = solid) with cubic voxels of ``voxel`` metres; the
    distance field is a binary +-voxel/2 (no sub-voxel surface)."""
    from psdesign.image.fields import image_fields

    solid = np.asarray(solid, bool)
    h = float(voxel)
    return image_fields(solid, h, distance=np.where(solid, -0.5 * h, 0.5 * h).astype(np.float32))


def coarsen_solid(distance: np.ndarray) -> np.ndarray:
    """Solid mask on the grid coarsened by 2 (odd trailing layers dropped): the block-mean
    distance is <= 0."""
    n = [s - s % 2 for s in distance.shape]
    d = distance[: n[0], : n[1], : n[2]].astype(np.float64)
    d = d.reshape(n[0] // 2, 2, n[1] // 2, 2, n[2] // 2, 2).mean(axis=(1, 3, 5))
    return d <= 0.0


def check_bc(bc: str) -> str:
    """The bc name, or ValueError naming ``transport.bc``."""
    if bc not in BC_NAMES:
        raise ValueError(f"transport.bc: must be 'periodic' or 'permeameter', got {bc!r}")
    return bc


def solve_effective(
    sigma_of: Callable[[np.ndarray], np.ndarray],
    fields: VoxelFields,
    direction: str | int,
    transport: dict,
    progress: Callable[[int, float], None] | None = None,
    capture: Callable[..., None] | None = None,
) -> Effective:
    """Solve for the effective property along ``direction``.

    Parameters
    ----------
    sigma_of : callable
        Maps a solid mask to the voxel conductivity map (called on the fine and, for the
        resolution estimate, the coarse mask).
    fields : VoxelFields
        Cubic voxels.
    direction : "x", "y", "z" or 0..2
    transport : dict
        Validated ``[transport]`` table (``bc``, ``tol``, ``max_iter``, ``error_estimate``).
    progress : callable, optional
        ``progress(iteration, residual)`` passed to the solver.
    capture : callable, optional
        Called as ``capture(solution=LaplaceResult, conductivity=array, fields=fields)`` after
        the fine solve (the potential field for :mod:`psdesign.fields`).
    """
    from solvers.transport import solve_laplace

    t0 = time.perf_counter()
    name, ax = axis_of(direction)
    spacing = fields.grid.spacing
    if not np.allclose(spacing, spacing[0], rtol=1e-9):
        raise ValueError("transport needs cubic voxels; make rve.size a multiple of rve.voxel")
    bc = check_bc(transport.get("bc", "periodic"))
    kw = {
        "tol": float(transport.get("tol", 1e-8)),
        "max_iter": int(transport.get("max_iter", 2000)),
    }
    sigma = sigma_of(fields.solid)
    res = solve_laplace(sigma, ax, bc=bc, progress=progress, **kw)
    if capture is not None:
        capture(solution=res, conductivity=sigma, fields=fields)
    del sigma
    column = (res.mean_flux / res.gradient).tolist()
    value = float(column[ax])
    rel_error = float(res.flux_imbalance)
    method = "flux_imbalance"
    coarse_value = None
    if transport.get("error_estimate", "resolution") == "resolution" and not res.blocked:
        coarse = coarsen_solid(fields.distance)
        if min(coarse.shape) >= 4:
            rc = solve_laplace(sigma_of(coarse), ax, bc=bc, **kw)
            coarse_value = float(rc.mean_flux[ax] / rc.gradient)
            if value > 0:
                rel_error = max(rel_error, abs(value - coarse_value) / value)
                method = "resolution (h vs 2h) and flux imbalance"
    return Effective(
        direction=name,
        bc=bc,
        value=value,
        column=[float(c) for c in column],
        converged=bool(res.converged),
        residual=float(res.residual),
        iterations=int(res.iterations),
        flux_imbalance=float(res.flux_imbalance),
        rel_error=float(rel_error),
        error_method=method,
        blocked=bool(res.blocked),
        message=res.message,
        n_cells=int(np.prod(fields.grid.shape)),
        wall_time_s=time.perf_counter() - t0,
        coarse_value=coarse_value,
    )
