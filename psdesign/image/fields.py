"""Voxel fields of an image: the signed distance from the voxel centres to the solid surface.

A segmented image has no analytic surface; the surface is put half-way between a solid and a
pore voxel centre, and the signed distance (metres, > 0 in the pore) comes from two Euclidean
distance transforms (scipy.ndimage): ``d = EDT(pore) - 1/2`` in the pore and
``-(EDT(solid) - 1/2)`` in the solid, times the voxel size. This is what the mesher's level set
and the transport solvers need; solvers that use the analytic distance for sub-voxel walls
see ``wall_treatment = "staircase"`` for images.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from psdesign.geometry.rve import VoxelFields, VoxelGrid


@dataclass(frozen=True)
class ImageFields(VoxelFields):
    """:class:`VoxelFields` of a segmented image: the distance comes from the voxels (EDT),
    not from an analytic surface, so walls are staircase and volumes are voxel counts."""

    analytic_distance: ClassVar[bool] = False


def signed_distance(solid: np.ndarray, voxel: float) -> np.ndarray:
    """Signed distance (float32, metres) of a solid mask, positive in the pore."""
    from scipy.ndimage import distance_transform_edt

    solid = np.asarray(solid, dtype=bool)
    d = np.empty(solid.shape, dtype=np.float32)
    pore = ~solid
    if pore.all() or solid.all():
        d.fill(np.float32(voxel * max(solid.shape)) * (1 if pore.all() else -1))
        return d
    d[pore] = distance_transform_edt(pore)[pore] - 0.5
    d[solid] = -(distance_transform_edt(solid)[solid] - 0.5)
    return d * np.float32(voxel)


def image_fields(
    solid: np.ndarray, voxel: float, distance: np.ndarray | None = None
) -> ImageFields:
    """:class:`ImageFields` of an image (``count`` = 1 in the solid: no fiber identities).

    ``distance`` (metres, > 0 in the pore) defaults to :func:`signed_distance`.
    """
    solid = np.asarray(solid, dtype=bool)
    shape = solid.shape
    size = np.array(shape, float) * voxel
    grid = VoxelGrid(size=size, shape=tuple(int(n) for n in shape), spacing=np.full(3, voxel))
    if distance is None:
        distance = signed_distance(solid, voxel)
    return ImageFields(distance=distance, count=solid.astype(np.uint8), grid=grid)


def resample(fields: VoxelFields, shape: tuple[int, int, int]) -> ImageFields:
    """The image on a coarser (or finer) grid of the same box: the signed distance is
    interpolated (trilinear) at the new voxel centres, solid where it is <= 0, and the
    distance of the new mask recomputed by :func:`signed_distance`.

    Used for the second resolution of the error bar (an image has no geometry to sample
    again). The box must hold a whole number of cubic voxels of the new grid.
    """
    from scipy.ndimage import map_coordinates

    size = np.asarray(fields.grid.size, float)
    h_new = size / np.asarray(shape, float)
    if not np.allclose(h_new, h_new[0], rtol=1e-9):
        raise ValueError(f"resample: shape {list(shape)} does not give cubic voxels")
    h_old = np.asarray(fields.grid.spacing, float)
    axes = [(np.arange(n) + 0.5) * h_new[a] / h_old[a] - 0.5 for a, n in enumerate(shape)]
    coords = np.meshgrid(*axes, indexing="ij")
    d = map_coordinates(fields.distance, coords, order=1, mode="nearest")
    return image_fields(d <= 0.0, float(h_new[0]))


def mesh_overrides(fields: VoxelFields) -> dict:
    """Mesher options an image needs: its pore volume is the voxel count (no analytic
    surface to estimate a sub-voxel volume from); ``{}`` for analytic fields."""
    return {} if fields.analytic_distance else {"volume_target": "voxel"}
