"""Pore-space surface: signed-distance field -> fiber solid -> (box with aux slabs) minus solid.

All lengths in this module are in the caller's units (the mesher passes lengths scaled by the
largest box side so that coordinates are O(1)).
"""

from __future__ import annotations

from dataclasses import dataclass

import manifold3d as mf
import numpy as np
from scipy import ndimage
from skimage import measure

from psdesign.meshing import tags as T
from psdesign.meshing.errors import MeshFailedError, PoreTopologyError

AXES = {"x": 0, "y": 1, "z": 2}
_PAD_EDGE = 2  # replicated layers that carry the fiber solid beyond the box faces


@dataclass
class PoreSurface:
    """Closed, outward-oriented triangle surface of the pore space.

    Attributes
    ----------
    verts, faces
        Triangle mesh (float64 (n, 3), int32 (m, 3)), outward normals.
    lo, hi
        Corners of the meshed box (RVE plus auxiliary slabs).
    rve_lo, rve_hi
        Corners of the RVE proper.
    volume
        Enclosed volume of the surface (the pore volume the tet mesh must reproduce).
    solid_volume
        Volume of the fiber solid clipped to the RVE.
    """

    verts: np.ndarray
    faces: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    rve_lo: np.ndarray
    rve_hi: np.ndarray
    volume: float
    solid_volume: float


def close_narrow_gaps(
    distance: np.ndarray, voxel: float, min_gap_voxels: float, periodic: bool = False
) -> tuple[np.ndarray, int]:
    """Morphologically close pore gaps narrower than ``min_gap_voxels`` voxels.

    A pore point x lies in the closing of the solid by a ball of radius r = gap/2 iff no ball
    of radius r that contains x fits entirely in the pore, i.e. iff dist(x, {d >= r}) > r.
    The distance to the set {d >= r} is the Euclidean distance transform to voxel centres;
    a point is closed
    only if it exceeds r by more than one voxel, so that the voxel quantization never erodes a
    convex fiber (an isolated fiber is left untouched; narrow gaps between fibers have
    dist >> r). The field is mirrored across the box faces (they are symmetry planes, not walls),
    or wrapped around when ``periodic``.

    Parameters
    ----------
    distance
        Signed distance at voxel centres, negative in the solid.
    voxel
        Voxel size.
    min_gap_voxels
        Gap width (in voxels) below which pore is turned into solid; 0 disables.
    periodic
        Wrap the field around the box faces instead of mirroring it.

    Returns
    -------
    field, n_closed
        The modified field (a copy if anything changed) and the number of voxels turned solid.
    """
    if min_gap_voxels <= 0:
        return distance, 0
    r = 0.5 * min_gap_voxels * voxel
    k = int(np.ceil(r / voxel)) + 2
    free = np.pad(distance >= r, k, mode="wrap" if periodic else "symmetric")
    if not free.any():
        return distance, 0
    dist_free = ndimage.distance_transform_edt(~free)[
        tuple(slice(k, k + n) for n in distance.shape)
    ]
    gap = (distance > 0) & (dist_free * voxel > r + voxel)
    n_closed = int(gap.sum())
    if n_closed == 0:
        return distance, 0
    field = distance.copy()
    # depth inside the closed region, at least a small negative value
    field[gap] = np.minimum(r + voxel - dist_free[gap] * voxel, -1e-3 * voxel)
    return field, n_closed


def fiber_solid_surface(
    distance: np.ndarray, voxel: float, step: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Closed, outward-oriented marching-cubes surface of the solid ``distance <= 0``.

    The field is extended by replicating its boundary layers (so fibers crossing a box face
    continue straight beyond it) and then capped with a pore layer, which closes the solid
    outside the box; the caller clips it to the box exactly.

    Parameters
    ----------
    distance
        Signed distance at voxel centres ``(i + 0.5) * voxel``, negative in the solid.
    voxel
        Voxel size.
    step
        Sub-sampling step (>= 1): every ``step``-th sample is used (surface coarsening).

    Returns
    -------
    verts, faces
        float64 (n, 3) and int32 (m, 3); empty arrays when there is no solid.
    """
    f = distance[::step, ::step, ::step]
    h = voxel * step
    if not (f <= 0).any():
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int32)
    f = np.pad(f, _PAD_EDGE, mode="edge")
    f = np.pad(f, 1, mode="constant", constant_values=max(h, float(f.max())))
    # negate: marching cubes then wraps the region where -distance >= 0, i.e. the solid
    verts, faces, _, _ = measure.marching_cubes(-f, 0.0, spacing=(h, h, h), allow_degenerate=False)
    verts = verts + (0.5 * voxel - (_PAD_EDGE + 1) * h)
    faces = faces.astype(np.int32)
    if signed_volume(verts, faces) < 0:  # orientation depends on skimage conventions: enforce
        faces = faces[:, ::-1].copy()
    return verts.astype(np.float64), faces


def signed_volume(verts: np.ndarray, faces: np.ndarray) -> float:
    """Enclosed volume of a closed triangle surface (positive for outward normals)."""
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def _manifold(verts: np.ndarray, faces: np.ndarray) -> mf.Manifold:
    mesh = mf.Mesh(
        vert_properties=np.ascontiguousarray(verts, dtype=np.float32),
        tri_verts=np.ascontiguousarray(faces, dtype=np.uint32),
    )
    mesh.merge()
    man = mf.Manifold(mesh)
    if man.status() != mf.Error.NoError:
        raise MeshFailedError(
            f"fiber surface from marching cubes is not a closed manifold ({man.status()}); "
            "check that `distance` is finite everywhere"
        )
    return man


def _box(lo: np.ndarray, hi: np.ndarray) -> mf.Manifold:
    return mf.Manifold.cube(tuple(float(v) for v in hi - lo)).translate(tuple(float(v) for v in lo))


def pore_surface(
    distance: np.ndarray,
    voxel: float,
    size: np.ndarray,
    axis: int,
    aux_length: float,
    step: int = 1,
    simplify_tol: float = 0.0,
) -> PoreSurface:
    """Exact box (RVE plus auxiliary slabs along ``axis``) minus the fiber solid clipped to the RVE.

    Parameters
    ----------
    distance, voxel, step
        See :func:`fiber_solid_surface`.
    size
        RVE side lengths (3,).
    axis
        Flow axis index (0, 1, 2).
    aux_length
        Auxiliary slab length as a fraction of ``size[axis]``.
    simplify_tol
        If > 0, manifold3d's ``simplify`` removes surface vertices that move the surface by less
        than this (surface decimation before tetrahedralization).

    Returns
    -------
    PoreSurface
    """
    size = np.asarray(size, dtype=float)
    rve_lo, rve_hi = np.zeros(3), size.copy()
    lo, hi = rve_lo.copy(), rve_hi.copy()
    lo[axis] -= aux_length * size[axis]
    hi[axis] += aux_length * size[axis]
    outer = _box(lo, hi)
    sv, sf = fiber_solid_surface(distance, voxel, step)
    if len(sf):
        solid = _manifold(sv, sf)
        # clip box: exact along the flow axis, wider laterally (no coplanar faces with `outer`)
        clip_lo, clip_hi = rve_lo - 4.0 * voxel * step, rve_hi + 4.0 * voxel * step
        clip_lo[axis], clip_hi[axis] = rve_lo[axis], rve_hi[axis]
        solid = solid ^ _box(clip_lo, clip_hi)
        solid_volume = solid.volume()
        if solid_volume < 0 or solid_volume > float(np.prod(size)) * (1 + 1e-6):
            raise MeshFailedError(
                f"fiber solid volume {solid_volume:.4g} outside [0, RVE volume]: the fiber surface "
                "is inverted (inward normals would keep the fiber solid as fluid)"
            )
        pore = outer - solid
    else:
        solid_volume = 0.0
        pore = outer
    if simplify_tol > 0:
        pore = pore.simplify(simplify_tol)
    if pore.is_empty() or pore.volume() <= 0:
        raise PoreTopologyError("the pore space is empty: `distance` is <= 0 everywhere")
    if pore.volume() > float(np.prod(hi - lo)) * (1 + 1e-6):
        raise MeshFailedError("pore volume exceeds the box volume: inverted fiber surface")
    mesh = pore.to_mesh()
    verts = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    faces = np.asarray(mesh.tri_verts, dtype=np.int32)
    vol = signed_volume(verts, faces)
    return PoreSurface(verts, faces, lo, hi, rve_lo, rve_hi, vol, float(solid_volume))


def check_voxel_connectivity(field: np.ndarray, axis: int, has_aux: bool) -> None:
    """Fail early when the pore voxels (26-connected) have no inlet-to-outlet path.

    26-connectivity over-connects compared with the marching-cubes surface, so a missing path
    here means a missing path in the mesh too (the tet mesh is checked again afterwards).
    """
    pore = field > 0
    first = np.take(pore, 0, axis=axis)
    last = np.take(pore, -1, axis=axis)
    for face, plane in ((T.INLET, first), (T.OUTLET, last)):
        if not has_aux and not plane.any():
            raise PoreTopologyError(
                f"rve.voxel: the {face} face is fully blocked by solid on the voxel field the "
                f"mesh is built from: no pore at the {face} (allowed: a voxel fine enough to "
                "open a gap there, none if the RVE's face is solid; flow.aux_length > 0 adds "
                "an open zone before the face)"
            )
    labels, n = ndimage.label(pore, structure=np.ones((3, 3, 3), dtype=bool))
    if n == 0:
        raise PoreTopologyError("the pore space is empty: `distance` is <= 0 everywhere")
    a = np.unique(np.take(labels, 0, axis=axis))
    b = np.unique(np.take(labels, -1, axis=axis))
    common = np.intersect1d(a[a > 0], b[b > 0])
    if len(common) == 0:
        raise PoreTopologyError(
            "rve.voxel: disconnected pore space: no pore path from the inlet to the outlet on "
            "the voxel field the mesh is built from, where pore gaps under about a voxel are "
            "closed (allowed: a voxel fine enough to open the path, none if the RVE has no path; "
            "an image's pore space has none at its resolution)"
        )
