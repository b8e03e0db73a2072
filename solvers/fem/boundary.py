"""Boundary bookkeeping for the tetrahedral Stokes solver.

All functions are vectorized (numpy / scipy.sparse.csgraph); nothing loops over elements.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


class BoundaryTagError(ValueError):
    """A tagged triangle set is inconsistent with the mesh or the boundary conditions."""


def boundary_triangles(tets: np.ndarray) -> np.ndarray:
    """Triangles that belong to exactly one tetrahedron, with sorted vertex indices.

    Parameters
    ----------
    tets : (m, 4) int array

    Returns
    -------
    (k, 3) int64 array, each row sorted ascending.
    """
    faces = np.concatenate(
        [tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]], tets[:, [1, 2, 3]]]
    )
    faces = np.sort(faces, axis=1).astype(np.int64)
    uniq, counts = np.unique(faces, axis=0, return_counts=True)
    return uniq[counts == 1]


def match_rows(reference: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Index into ``reference`` of each row of ``query`` (rows sorted first), -1 if absent.

    Parameters
    ----------
    reference : (r, 3) int array of unique rows
    query : (q, 3) int array
    """
    ref = np.sort(np.asarray(reference, dtype=np.int64), axis=1)
    qry = np.sort(np.asarray(query, dtype=np.int64).reshape(-1, 3), axis=1)
    if len(qry) == 0:
        return np.zeros(0, dtype=np.int64)
    both = np.concatenate([ref, qry])
    _, inv = np.unique(both, axis=0, return_inverse=True)
    inv = inv.ravel()
    slot = np.full(inv.max() + 1, -1, dtype=np.int64)
    slot[inv[: len(ref)]] = np.arange(len(ref))
    return slot[inv[len(ref) :]]


def triangle_normals(points: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (orientation arbitrary) and areas of triangles."""
    a, b, c = (points[tris[:, i]] for i in range(3))
    cr = np.cross(b - a, c - a)
    area2 = np.linalg.norm(cr, axis=1)
    return cr / np.maximum(area2, np.finfo(float).tiny)[:, None], 0.5 * area2


def slip_axis(points: np.ndarray, tris: np.ndarray, tag: str, max_angle_deg: float = 10.0) -> int:
    """Coordinate axis (0, 1, 2) normal to a flat axis-aligned slip face.

    Raises
    ------
    BoundaryTagError
        If a triangle's normal deviates from that axis by more than ``max_angle_deg``.
    """
    n, area = triangle_normals(points, tris)
    axis = int(np.argmax((np.abs(n) * area[:, None]).sum(axis=0)))
    cos_min = float(np.abs(n[:, axis]).min())
    if cos_min < np.cos(np.radians(max_angle_deg)):
        worst = float(np.degrees(np.arccos(np.clip(cos_min, -1.0, 1.0))))
        raise BoundaryTagError(
            f"slip tag {tag!r}: a facet normal deviates {worst:.1f} deg from axis {'xyz'[axis]}; "
            f"slip needs a flat axis-aligned face (allowed deviation <= {max_angle_deg} deg)"
        )
    return axis


def vertex_components(n_points: int, tets: np.ndarray) -> tuple[int, np.ndarray]:
    """Connected components of the vertex graph of the tetrahedra (vertex sharing).

    Returns
    -------
    n_components, labels (n_points,) ; vertices used by no tetrahedron get their own label.
    """
    rows = np.repeat(tets[:, 0], 3)
    cols = tets[:, 1:].ravel()
    g = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n_points, n_points))
    return connected_components(g, directed=False)
