"""Whether a periodic mesher's pore space winds around the box along the flow.

A periodic mesh pairs all three pairs of opposite box faces (:mod:`psdesign.meshing.periodic`),
so its pore path may leave through a side face and come back through the opposite one: a
channel that climbs along z while stepping across the x faces is a path of the periodic box
(the voxel route solves it, K_z 9.47e-15 m^2 on the 16^3 image of session 44's review) though
no single piece of it touches both the inlet and the outlet. The periodic mesher's checks ask
this test, on the voxel field (26-connected, :func:`voxels_wind`) and on the tet mesh
(:func:`mesh_winds`): the pieces, linked across the box faces with the lattice offset of each
link, hold a loop whose net offset along the flow is not zero (the voxel solver's own test,
:func:`solvers.voxel_stokes.percolates`, face-connected, does the same).
"""

from __future__ import annotations

import itertools
from collections import deque

import numpy as np
from scipy import ndimage


def winds(links: np.ndarray, axis: int) -> bool:
    """Whether the graph of ``links`` holds a loop of non-zero net offset along ``axis``.

    Parameters
    ----------
    links : ndarray of int, shape (k, 5)
        ``(piece, other piece, offset x, offset y, offset z)``: ``other`` is reached from
        ``piece`` across the box faces, in the neighbouring box at that lattice offset.
    axis : int
        The flow's axis.

    >>> winds(np.array([[1, 2, 0, 0, 1], [2, 1, 0, 0, 0]]), 2)  # 1 -> 2 up one box, 2 -> 1
    True
    >>> winds(np.array([[1, 2, 0, 0, 1], [2, 1, 0, 0, -1]]), 2)  # there and back
    False
    """
    adj: dict[int, list[tuple[int, np.ndarray]]] = {}
    for s, t, *off in np.unique(np.asarray(links, np.int64).reshape(-1, 5), axis=0):
        o = np.asarray(off, np.int64)
        adj.setdefault(int(s), []).append((int(t), o))
        adj.setdefault(int(t), []).append((int(s), -o))
    pot: dict[int, np.ndarray] = {}
    for start in adj:
        if start in pot:
            continue
        pot[start] = np.zeros(3, np.int64)
        queue = deque([start])
        while queue:
            x = queue.popleft()
            for y, off in adj[x]:
                py = pot[x] + off
                if y not in pot:
                    pot[y] = py
                    queue.append(y)
                elif pot[y][axis] != py[axis]:
                    return True
    return False


def voxels_wind(pore: np.ndarray, axis: int) -> bool:
    """Whether the True voxels of ``pore`` (26-connected, as the mesher's check counts them:
    :func:`psdesign.meshing.surface.check_voxel_connectivity`) wind around the periodic box
    along ``axis``.

    >>> m = np.zeros((4, 4, 4), bool); m[0, 0, :2] = m[1, 1, 2:] = True  # steps across x, y
    >>> voxels_wind(m, 2), voxels_wind(m, 0)
    (True, False)
    """
    labels, n = ndimage.label(pore, structure=np.ones((3, 3, 3), bool))
    if n == 0:
        return False
    ghost = np.pad(labels, 1, mode="wrap")  # each voxel's neighbours across the box faces
    shape = labels.shape
    # lattice offset of each padded index per axis: -1 before the box, +1 after it
    offsets = [np.r_[-1, np.zeros(s, np.int64), 1] for s in shape]
    links = []
    for delta in itertools.product((-1, 0, 1), repeat=3):
        if not any(delta):
            continue
        sl = tuple(slice(1 + d, 1 + d + s) for d, s in zip(delta, shape, strict=True))
        other = ghost[sl]
        off = [offsets[a][sl[a]] for a in range(3)]
        grid = np.stack(np.broadcast_arrays(*np.ix_(*off)), axis=-1)
        hit = (labels > 0) & (other > 0) & grid.any(axis=-1)
        if hit.any():
            links.append(np.column_stack([labels[hit], other[hit], grid[hit]]))
    return bool(links) and winds(np.concatenate(links), axis)


def mesh_winds(
    points: np.ndarray, vertex_piece: np.ndarray, lo: np.ndarray, hi: np.ndarray, axis: int
) -> bool:
    """Whether the pieces of a periodic tet mesh wind around the box along ``axis``: the
    vertices of opposite box faces with equal in-plane coordinates are one point of the
    periodic box (:func:`psdesign.meshing.periodic.periodic_pairs` pairs them so for the
    solve; the stuffing lattice makes them match exactly), linking their pieces across it.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
        Vertex coordinates.
    vertex_piece : ndarray of int, shape (n,)
        The connected piece of each vertex (-1: in no tet).
    lo, hi : ndarray, shape (3,)
        The box's corners.
    axis : int
        The flow's axis.
    """
    tol = 1e-6 * float(np.max(hi - lo))  # the stuffing faces match exactly; well under a step
    links = []
    for a in range(3):
        low = np.flatnonzero((np.abs(points[:, a] - lo[a]) <= tol) & (vertex_piece >= 0))
        high = np.flatnonzero((np.abs(points[:, a] - hi[a]) <= tol) & (vertex_piece >= 0))
        other = [b for b in range(3) if b != a]
        key_lo = np.round((points[low][:, other] - lo[other]) / tol).astype(np.int64)
        key_hi = np.round((points[high][:, other] - lo[other]) / tol).astype(np.int64)
        common, i, j = _matches(key_lo, key_hi)
        if not common:
            continue
        off = np.zeros((len(i), 3), np.int64)
        off[:, a] = 1  # the low face's point, reached from the high face, is one box on
        links.append(np.column_stack([vertex_piece[high[j]], vertex_piece[low[i]], off]))
    return bool(links) and winds(np.concatenate(links), axis)


def _matches(a: np.ndarray, b: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """Rows equal in ``a`` and ``b`` (integer keys, unique within each): their count and
    indices."""
    if not len(a) or not len(b):
        return 0, np.zeros(0, np.int64), np.zeros(0, np.int64)
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    ka = a.view([("", a.dtype)] * a.shape[1]).ravel()
    kb = b.view([("", b.dtype)] * b.shape[1]).ravel()
    _, i, j = np.intersect1d(ka, kb, return_indices=True)
    return len(i), i, j
