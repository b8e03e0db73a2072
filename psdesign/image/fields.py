"""Voxel fields of an image: the signed distance from the voxel centres to the solid surface.

A segmented image has no analytic surface; the surface is put half-way between a solid and a
pore voxel centre, and the signed distance (metres, > 0 in the pore) comes from two Euclidean
distance transforms (:func:`psdesign.geometry.edt.periodic_edt`) of the periodic medium the
image is one period of:
``d = EDT(pore) - 1/2`` in the pore and ``-(EDT(solid) - 1/2)`` in the solid, times the voxel
size. This is what the mesher's level set and the transport solvers need; solvers that use
the analytic distance for sub-voxel walls see ``wall_treatment = "staircase"`` for images.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from psdesign.geometry.edt import periodic_edt
from psdesign.geometry.rve import VoxelFields, VoxelGrid, is_cubic
from psdesign.image.reader import box_size


@dataclass(frozen=True)
class ImageFields(VoxelFields):
    """:class:`VoxelFields` of a segmented image: the distance comes from the voxels (EDT),
    not from an analytic surface, so walls are staircase and volumes are voxel counts."""

    analytic_distance: ClassVar[bool] = False


def signed_distance(solid: np.ndarray, voxel: float) -> np.ndarray:
    """Signed distance (float32, metres) of a solid mask, positive in the pore.

    Periodic (:func:`periodic_edt`), as the analytic distance of an RVE of fibers: a pore
    voxel next to a face is as close to the solid across that face as the solvers see it.
    """
    solid = np.asarray(solid, dtype=bool)
    d = np.empty(solid.shape, dtype=np.float32)
    pore = ~solid
    if pore.all() or solid.all():
        d.fill(np.float32(voxel * max(solid.shape)) * (1 if pore.all() else -1))
        return d
    # in place, one transform held at a time: the fields' peak is a few bytes per voxel
    d = periodic_edt(pore)
    d -= np.float32(0.5)
    inside = periodic_edt(solid)
    inside -= np.float32(0.5)
    np.negative(inside, out=inside)
    np.copyto(d, inside, where=solid)
    del inside
    d *= np.float32(voxel)
    return d


def image_fields(
    solid: np.ndarray, voxel: float, distance: np.ndarray | None = None
) -> ImageFields:
    """:class:`ImageFields` of an image (``count`` = 1 in the solid: no fiber identities).

    ``distance`` (metres, > 0 in the pore) defaults to :func:`signed_distance`.
    """
    solid = np.asarray(solid, dtype=bool)
    shape = solid.shape
    size = np.array(box_size(shape, voxel))  # 12 x 1.25 um is 1.5e-05 m, as the spec says
    grid = VoxelGrid(size=size, shape=tuple(int(n) for n in shape), spacing=np.full(3, voxel))
    if distance is None:
        distance = signed_distance(solid, voxel)
    return ImageFields(distance=distance, count=solid.astype(np.uint8), grid=grid)


def _overlap(n_old: int, n_new: int) -> np.ndarray:
    """(n_new, n_old) weights: the fraction of coarse cell i covered by fine cell j."""
    r = n_old / n_new
    lo = np.arange(n_new)[:, None] * r
    j = np.arange(n_old)[None, :]
    return (np.clip(np.minimum(lo + r, j + 1) - np.maximum(lo, j), 0.0, None) / r).astype(
        np.float64
    )


def _box_average(a: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """Volume average of ``a`` over the cells of a coarser grid of the same box."""
    out = np.asarray(a, np.float64)
    for ax, n in enumerate(shape):
        n_old = out.shape[ax]
        if n_old % n == 0:  # whole blocks: a reshape
            k = n_old // n
            s = list(out.shape)
            out = out.reshape(s[:ax] + [n, k] + s[ax + 1 :]).mean(axis=ax + 1)
        else:
            out = np.moveaxis(np.tensordot(_overlap(n_old, n), out, axes=(1, ax)), 0, ax)
    return out


def resample(fields: VoxelFields, shape: tuple[int, int, int]) -> ImageFields:
    """The image on a coarser grid of the same box, with the same solid volume fraction.

    Each coarse voxel gets the volume average of the fine mask (its solid fraction); the
    ``round(solid fraction x n_coarse)`` voxels with the highest fraction (ties: the lower
    mean signed distance) are solid, and the distance is recomputed by
    :func:`signed_distance`. A plain majority vote shrinks convex solids and interpolating
    the distance grows them (3-4 % of the solid volume on cylinders of 6-12 voxels); keeping
    the porosity is what the error bar's second resolution needs (an image has no geometry
    to sample again). The box must hold a whole number of cubic voxels of the new grid.
    """
    size = np.asarray(fields.grid.size, float)
    h_new = size / np.asarray(shape, float)
    if not is_cubic(h_new):
        raise ValueError(f"resample: shape {list(shape)} does not give cubic voxels")
    fine = fields.solid
    frac = _box_average(fine, shape).ravel()
    n_solid = int(round(np.count_nonzero(fine) / fine.size * frac.size))
    h = float(np.min(fields.grid.spacing))
    key = frac - 1e-3 * np.clip(_box_average(fields.distance, shape).ravel() / h, -100, 100)
    solid = np.zeros(frac.size, bool)
    if n_solid > 0:
        solid[np.argpartition(-key, n_solid - 1)[:n_solid]] = True
    return image_fields(solid.reshape(shape), float(h_new[0]))


def mesh_overrides(fields: VoxelFields) -> dict:
    """Mesher options an image needs: its pore volume is the voxel count (no analytic
    surface to estimate a sub-voxel volume from); ``{}`` for analytic fields."""
    return {} if fields.analytic_distance else {"volume_target": "voxel"}
