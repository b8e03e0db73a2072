"""Periodic identification of opposite box faces of a tetrahedral mesh (vectorized).

A mesh is periodic along an axis when the boundary triangles lying on the two box planes
normal to it are translates of each other (same vertices after a shift by the box length,
same triangles). The P2 (vertex + edge) and P1 (vertex) unknowns of the upper face are then
identified with those of the lower face; nodes on box edges and corners are identified through
every periodic axis they touch.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from solvers.fem.boundary import BoundaryTagError, match_rows

AXES = "xyz"


class PeriodicMeshError(BoundaryTagError):
    """Opposite box faces of the mesh do not match, so periodic conditions cannot be imposed."""


def _face(points: np.ndarray, tris: np.ndarray, axis: int, value: float, tol: float):
    on = np.all(np.abs(points[tris][:, :, axis] - value) <= tol, axis=1)
    return tris[on]


def face_partners(
    points: np.ndarray,
    boundary_tris: np.ndarray,
    axes,
    lo: np.ndarray,
    hi: np.ndarray,
    rel_tol: float = 1e-7,
) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """Vertex partners across each pair of opposite periodic faces.

    Parameters
    ----------
    points : (n, 3) array
    boundary_tris : (k, 3) int array
        Boundary triangles of the mesh.
    axes : sequence of int
        Periodic axes.
    lo, hi : (3,) arrays
        Box corners.
    rel_tol : float
        Matching tolerance relative to the largest box side.

    Returns
    -------
    list of ``(axis, partner, on_upper)``: ``partner`` (n,) maps each vertex of the upper face
    to its translate on the lower face (identity elsewhere); ``on_upper`` (n,) bool marks the
    upper-face vertices.

    Raises
    ------
    PeriodicMeshError
        If a face has no fluid triangles, or the vertices or triangles of two opposite faces are
        not translates of each other (the message names the face).
    """
    n = len(points)
    tol = rel_tol * float(np.max(hi - lo))
    out = []
    for ax in axes:
        name = AXES[ax]
        f0 = _face(points, boundary_tris, ax, lo[ax], tol)
        f1 = _face(points, boundary_tris, ax, hi[ax], tol)
        if len(f0) == 0 or len(f1) == 0:
            empty = f"{name}0" if len(f0) == 0 else f"{name}1"
            raise PeriodicMeshError(
                f"periodic: box face {empty} has no fluid triangles; the mesh must reach both "
                f"faces normal to {name}"
            )
        v0, v1 = np.unique(f0), np.unique(f1)
        if len(v0) != len(v1):
            raise PeriodicMeshError(
                f"periodic: face {name}1 has {len(v1)} vertices, face {name}0 has {len(v0)}: the "
                f"mesh is not periodic along {name} (mesh it with matching opposite faces)"
            )
        shift = np.zeros(3)
        shift[ax] = hi[ax] - lo[ax]
        dist, j = cKDTree(points[v0]).query(points[v1] - shift)
        bad = dist > tol
        if np.any(bad):
            worst = points[v1[np.argmax(dist)]]
            raise PeriodicMeshError(
                f"periodic: {int(bad.sum())} vertices of face {name}1 have no partner on face "
                f"{name}0 (e.g. at {np.round(worst, 12).tolist()} m): the mesh is not periodic "
                f"along {name}"
            )
        partner = np.arange(n, dtype=np.int64)
        partner[v1] = v0[j]
        if len(np.unique(partner[v1])) != len(v1):
            raise PeriodicMeshError(f"periodic: face {name}1 vertices pair twice onto face {name}0")
        if np.any(match_rows(f0, partner[f1]) < 0):
            raise PeriodicMeshError(
                f"periodic: the triangles of face {name}1 differ from those of face {name}0 "
                f"(same vertices, other triangulation): the mesh is not periodic along {name}"
            )
        on_upper = np.zeros(n, dtype=bool)
        on_upper[v1] = True
        out.append((ax, partner, on_upper))
    return out


def _match_pairs(ref: np.ndarray, query: np.ndarray, n: int) -> np.ndarray:
    """Index into ``ref`` (sorted pairs, (r, 2)) of each sorted pair in ``query``, -1 if absent.

    The keys are int64 whatever the input: scikit-fem stores ``edges`` as int32, whose
    ``i * n + j`` wraps above 46 341 vertices."""
    ref, query, n = ref.astype(np.int64), query.astype(np.int64), int(n)
    key_r = ref[:, 0] * n + ref[:, 1]
    key_q = query[:, 0] * n + query[:, 1]
    order = np.argsort(key_r, kind="stable")
    pos = np.clip(np.searchsorted(key_r[order], key_q), 0, len(ref) - 1)
    idx = order[pos]
    return np.where(key_r[idx] == key_q, idx, -1)


def p2_representatives(partners, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Representative of every P1 node (vertex) and P2 node (vertices, then ``edges`` (2, n_e)).

    An edge is identified across a face pair when both its end vertices lie on the upper face;
    the identifications of all periodic axes are composed (box edges and corners).

    Raises
    ------
    PeriodicMeshError
        If the translate of a face edge is not an edge of the mesh.
    """
    nv = edges.max() + 1 if edges.size else 0
    nv = max(nv, max((len(p) for _, p, _ in partners), default=0))
    e = np.sort(edges.T, axis=1)
    vrep = np.arange(nv, dtype=np.int64)
    erep = np.arange(len(e), dtype=np.int64)
    for ax, partner, on_upper in partners:
        in_face = on_upper[e[:, 0]] & on_upper[e[:, 1]]
        emap = np.arange(len(e), dtype=np.int64)
        if in_face.any():
            idx = _match_pairs(e, np.sort(partner[e[in_face]], axis=1), nv)
            if np.any(idx < 0):
                raise PeriodicMeshError(
                    f"periodic: {int((idx < 0).sum())} edges of face {AXES[ax]}1 have no "
                    f"partner edge on face {AXES[ax]}0"
                )
            emap[in_face] = idx
        vrep = partner[vrep]
        erep = emap[erep]
    return vrep, np.concatenate([vrep, nv + erep])


def identification(rep: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
    """Prolongation ``P`` (n, n_masters) with ``P[i, k] = 1`` iff node i is master k's copy.

    Returns
    -------
    P, masters : the matrix and the node index of each master (``rep[masters] == masters``).
    """
    masters, col = np.unique(rep, return_inverse=True)
    n = len(rep)
    P = sp.csr_matrix((np.ones(n), (np.arange(n), col.ravel())), shape=(n, len(masters)))
    return P, masters
