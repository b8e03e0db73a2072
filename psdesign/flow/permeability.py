"""Permeability by Darcy's law from a built-in Stokes solve (paper Sec. 7.2).

Two routes, both geometry-agnostic below this module:

* ``fem``: pore-space tet mesh with empty auxiliary inlet/outlet zones
  (:func:`psdesign.meshing.pore_mesh.mesh_pore_space`), Taylor-Hood Stokes with prescribed
  pressures (:func:`solvers.fem_stokes.solve_stokes`), and

      K = mu Q L / (A dP_rve)

  with Q the outlet flow rate, L and A the RVE length and full cross-section (so
  Q/A is the superficial velocity), and dP_rve the drop of the cross-section-averaged
  pressure between the RVE's own inlet and outlet planes. The auxiliary zones carry
  part of the applied drop (entrance and exit losses where the flow enters and leaves
  the pores); measuring across the porous RVE alone removes that, so K does not
  depend on ``aux_length``.
* ``voxel``: periodic body-force Stokes on the voxel grid
  (:func:`solvers.voxel_stokes.solve_voxel_stokes`), K from the mean velocity.
"""

from __future__ import annotations

from collections.abc import Callable

from psdesign.flow.fem import mesher_options, permeability_fem, plane_average_pressure
from psdesign.flow.voxel import face_mismatch, permeability_voxel
from psdesign.geometry.rve import RVE, VoxelFields

__all__ = [
    "face_mismatch",
    "mesher_options",
    "permeability",
    "permeability_fem",
    "permeability_voxel",
    "plane_average_pressure",
]


def permeability(
    rve: RVE,
    fields: VoxelFields,
    direction: str | int,
    flow: dict,
    solver: str | None = None,
    progress: Callable[[int, float], None] | None = None,
) -> dict:
    """Dispatch to :func:`permeability_fem` or :func:`permeability_voxel` (``progress`` is
    used by the voxel route only)."""
    solver = solver or flow.get("solver", "fem")
    if solver == "fem":
        return permeability_fem(rve, fields, direction, flow)
    if solver == "voxel":
        return permeability_voxel(fields, direction, flow, progress=progress, rve=rve)
    raise ValueError(f"solver must be 'fem' or 'voxel', got {solver!r}")
