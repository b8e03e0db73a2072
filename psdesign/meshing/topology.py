"""Face-based topology of a tagged tet mesh (for finite-volume exports)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from psdesign.meshing.errors import MeshFailedError
from psdesign.meshing.tetra import TET_FACES


@dataclass
class FaceTopology:
    """All faces of a tet mesh, OpenFOAM-ordered.

    Interior faces come first, sorted by (owner, neighbour) with owner < neighbour; their vertex
    order gives a normal pointing from owner to neighbour. Boundary faces follow, grouped by
    patch in ``patch_names`` order, normals pointing out of the domain.
    """

    faces: np.ndarray  # (F, 3)
    owner: np.ndarray  # (F,)
    neighbour: np.ndarray  # (n_internal,)
    patch_names: list[str]
    patch_start: list[int]
    patch_size: list[int]

    @property
    def n_internal(self) -> int:
        return int(len(self.neighbour))


def face_keys(tri: np.ndarray, n: int) -> np.ndarray:
    """One integer per triangle, the same for any order of its vertices (``n`` points)."""
    s = np.sort(tri.astype(np.int64), axis=1)
    return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]


def face_topology(
    points: np.ndarray, tets: np.ndarray, patches: dict[str, np.ndarray]
) -> FaceTopology:
    """Build owner/neighbour face lists; ``patches`` maps patch name -> boundary triangles."""
    n = len(points)
    if n >= 2_000_000:
        raise MeshFailedError("face_topology supports meshes with < 2e6 points")
    nt = len(tets)
    allf = tets[:, TET_FACES].reshape(-1, 3)
    cell = np.repeat(np.arange(nt), 4)
    key = face_keys(allf, n)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    first = np.flatnonzero(ks[1:] == ks[:-1])
    a, b = order[first], order[first + 1]
    ca, cb = cell[a], cell[b]
    # orientation of the owner (lower cell index): its outward face points to the neighbour
    own_is_a = ca < cb
    owner = np.where(own_is_a, ca, cb)
    neigh = np.where(own_is_a, cb, ca)
    ifaces = np.where(own_is_a[:, None], allf[a], allf[b])
    srt = np.lexsort((neigh, owner))
    faces = [ifaces[srt]]
    owners = [owner[srt]]
    paired = np.zeros(len(ks), dtype=bool)
    paired[first] = True
    paired[first + 1] = True
    bidx = order[~paired]
    bkey = key[bidx]
    bsort = np.argsort(bkey)
    bkey_sorted = bkey[bsort]
    names, starts, sizes = [], [], []
    start = len(srt)
    n_tagged = 0
    for name, tri in patches.items():
        if len(tri) == 0:
            continue
        k = face_keys(tri, n)
        pos = np.searchsorted(bkey_sorted, k)
        pos = np.minimum(pos, len(bkey_sorted) - 1)
        if not (bkey_sorted[pos] == k).all():
            raise MeshFailedError(f"patch {name!r} contains faces that are not boundary faces")
        src = bidx[bsort[pos]]
        faces.append(allf[src])
        owners.append(cell[src])
        names.append(name)
        starts.append(start)
        sizes.append(len(k))
        start += len(k)
        n_tagged += len(k)
    if n_tagged != len(bidx):
        raise MeshFailedError(
            f"boundary tags cover {n_tagged} faces but the mesh has {len(bidx)} boundary faces"
        )
    return FaceTopology(
        np.concatenate(faces), np.concatenate(owners), neigh[srt], names, starts, sizes
    )
