"""Input validation and the scaled, gap-closed field both meshers start from."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from psdesign.meshing.errors import MeshInputError
from psdesign.meshing.options import MeshOptions
from psdesign.meshing.pore_volume import analytic_pore_volume
from psdesign.meshing.surface import AXES, check_voxel_connectivity, close_narrow_gaps


def validate_inputs(distance, voxel, size, direction, opts: MeshOptions):
    """Check the field, voxel, size and direction; returns (float64 field, voxel, size)."""
    distance = np.asarray(distance)
    if distance.ndim != 3 or min(distance.shape) < 2:
        raise MeshInputError(
            f"distance must be a 3-D array with at least 2 samples per axis, got shape "
            f"{distance.shape}"
        )
    if not np.issubdtype(distance.dtype, np.floating) or not np.isfinite(distance).all():
        raise MeshInputError("distance must be a finite floating-point array")
    if not (np.isfinite(voxel) and voxel > 0):
        raise MeshInputError(f"voxel must be a positive length in metres, got {voxel}")
    size = np.asarray(size, dtype=float)
    if size.shape != (3,) or not (np.isfinite(size).all() and (size > 0).all()):
        raise MeshInputError(f"size must be three positive lengths in metres, got {size}")
    expected = np.asarray(distance.shape) * voxel
    if not np.allclose(expected, size, rtol=1e-6):
        raise MeshInputError(
            f"size {size.tolist()} does not match distance.shape * voxel = {expected.tolist()}"
        )
    if direction not in AXES:
        raise MeshInputError(f"direction must be 'x', 'y' or 'z', got {direction!r}")
    step = opts.surface_step
    if step is not None and (int(step) != step or not (1 <= step <= min(distance.shape) // 2)):
        raise MeshInputError(
            f"surface_step must be an integer in [1, {min(distance.shape) // 2}], got {step}"
        )
    return distance.astype(np.float64, copy=False), float(voxel), size


@dataclass
class ScaledField:
    """The field in units of the largest box side (coordinates O(1)), gaps closed.

    Attributes
    ----------
    scale
        Metres per unit.
    d, voxel, size
        Original field, voxel and RVE size in units.
    closed
        Field after closing narrow gaps (``n_closed`` voxels turned solid).
    analytic_rve
        Sub-voxel pore volume of the original field's RVE (units^3).
    analytic_closed
        The same for the closed field (the pore the mesh must carry).
    voxel_rve
        Voxel-count pore volume of the closed field's RVE.
    """

    scale: float
    d: np.ndarray
    voxel: float
    size: np.ndarray
    axis: int
    closed: np.ndarray
    n_closed: int
    analytic_rve: float
    analytic_closed: float
    voxel_rve: float

    @property
    def rve_volume(self) -> float:
        return float(np.prod(self.size))


def scaled_field(distance, voxel, size, direction, opts: MeshOptions) -> ScaledField:
    """Scale, close narrow gaps, check voxel connectivity and estimate the pore volumes."""
    axis = AXES[direction]
    scale = float(size.max())
    d_s, v_s, size_s = distance / scale, voxel / scale, size / scale
    closed, n_closed = close_narrow_gaps(d_s, v_s, opts.min_gap_voxels, periodic=opts.periodic)
    check_voxel_connectivity(closed, axis, opts.aux_length > 0)
    analytic = analytic_pore_volume(d_s, v_s)
    analytic_closed = analytic_pore_volume(closed, v_s) if n_closed else analytic
    rve = float(np.prod(size_s))
    return ScaledField(
        scale=scale,
        d=d_s,
        voxel=v_s,
        size=size_s,
        axis=axis,
        closed=closed,
        n_closed=n_closed,
        analytic_rve=analytic,
        analytic_closed=analytic_closed,
        voxel_rve=float((closed > 0).mean()) * rve,
    )
