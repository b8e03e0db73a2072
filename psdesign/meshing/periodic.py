"""Periodic face pairing of a pore mesh: vertices of opposite box faces with equal in-plane
coordinates (the lattice mesher produces them by construction, see
:func:`psdesign.meshing.stuffing.stuff_pore_space` with ``periodic=True``)."""

from __future__ import annotations

import numpy as np

from psdesign.meshing import tags as T
from psdesign.meshing.errors import MeshFailedError


def face_vertices(facet_tags: dict, axis: int, high: bool, flow_axis: int) -> np.ndarray:
    """Sorted unique vertex indices of the box-face tag normal to ``axis``."""
    f = facet_tags.get(T.face_name(axis, high, flow_axis))
    return np.unique(f) if f is not None else np.zeros(0, dtype=np.int64)


def periodic_pairs(
    points: np.ndarray, facet_tags: dict, flow_axis: int, rtol: float = 1e-9
) -> dict[str, np.ndarray]:
    """Pair the vertices of opposite box faces per axis.

    Parameters
    ----------
    points
        (n, 3) vertex coordinates.
    facet_tags
        Boundary tags (:mod:`psdesign.meshing.tags`).
    flow_axis
        Index of the flow axis (its faces are ``inlet`` / ``outlet``).
    rtol
        Allowed in-plane mismatch relative to the box size (the stuffing faces match exactly).

    Returns
    -------
    dict
        ``'x' | 'y' | 'z'`` -> (k, 2) int64 ``(vertex on the low face, vertex on the high face)``.

    Raises
    ------
    MeshFailedError
        The two faces of a pair do not carry the same vertices.
    """
    extent = float(np.ptp(points, axis=0).max())
    out: dict[str, np.ndarray] = {}
    for ax in range(3):
        lo_v = face_vertices(facet_tags, ax, False, flow_axis)
        hi_v = face_vertices(facet_tags, ax, True, flow_axis)
        other = [a for a in range(3) if a != ax]
        if len(lo_v) != len(hi_v):
            raise MeshFailedError(
                f"periodic faces normal to {'xyz'[ax]} do not match: {len(lo_v)} vs "
                f"{len(hi_v)} vertices"
            )
        pl, ph = points[lo_v][:, other], points[hi_v][:, other]
        ol = np.lexsort((pl[:, 1], pl[:, 0]))
        oh = np.lexsort((ph[:, 1], ph[:, 0]))
        mismatch = float(np.abs(pl[ol] - ph[oh]).max()) if len(ol) else 0.0
        if mismatch > rtol * extent:
            raise MeshFailedError(
                f"periodic faces normal to {'xyz'[ax]} do not match: in-plane mismatch "
                f"{mismatch:.3g} (box extent {extent:.3g})"
            )
        out["xyz"[ax]] = np.stack([lo_v[ol], hi_v[oh]], axis=1).astype(np.int64)
    return out
