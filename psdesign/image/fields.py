"""Voxel fields of an image: the signed distance from the voxel centres to the solid surface.

A segmented image has no analytic surface; the surface is put half-way between a solid and a
pore voxel centre, and the signed distance (metres, > 0 in the pore) comes from two Euclidean
distance transforms (scipy.ndimage): ``d = EDT(pore) - 1/2`` in the pore and
``-(EDT(solid) - 1/2)`` in the solid, times the voxel size. This is what the mesher's level set
and the transport solvers need; solvers that use the analytic distance for sub-voxel walls
see ``wall_treatment = "staircase"`` for images.
"""

from __future__ import annotations

import numpy as np

from psdesign.geometry.rve import VoxelFields, VoxelGrid


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
) -> VoxelFields:
    """:class:`VoxelFields` of an image (``count`` = 1 in the solid: no fiber identities).

    ``distance`` (metres, > 0 in the pore) defaults to :func:`signed_distance`.
    """
    solid = np.asarray(solid, dtype=bool)
    shape = solid.shape
    size = np.array(shape, float) * voxel
    grid = VoxelGrid(size=size, shape=tuple(int(n) for n in shape), spacing=np.full(3, voxel))
    if distance is None:
        distance = signed_distance(solid, voxel)
    return VoxelFields(distance=distance, count=solid.astype(np.uint8), grid=grid)
