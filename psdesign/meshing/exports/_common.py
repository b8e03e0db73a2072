"""Helpers shared by the mesh writers."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from psdesign.meshing.tags import TAG_IDS, face_name

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh


def boundary(pm: PoreMesh) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """All tagged boundary triangles, their integer tag ids and the tag names present."""
    names = [k for k in TAG_IDS if k in pm.facet_tags and len(pm.facet_tags[k])]
    tris = np.concatenate([pm.facet_tags[k] for k in names]).astype(np.int64)
    ids = np.concatenate([np.full(len(pm.facet_tags[k]), TAG_IDS[k]) for k in names])
    return tris, ids, names


def side_type(flow: dict | None) -> str:
    """Boundary type of the lateral box faces in the OpenFOAM and Fluent exports: ``symmetry``
    for ``flow.sides = "slip"`` (the default), ``wall`` for ``"noslip"`` (the same keywords in
    both formats)."""
    noslip = (flow or {}).get("sides", "slip") == "noslip"
    return "wall" if noslip else "symmetry"  # format keywords


def periodic_faces(pm: PoreMesh) -> list[tuple[str, str, int, np.ndarray, float]]:
    """The linked box faces of a periodic mesh (empty otherwise), per axis with vertex pairs:
    ``(low face tag, high face tag, axis, (k, 2) vertex pairs (low, high), box edge)`` from
    :attr:`~psdesign.meshing.result.PoreMesh.periodic_pairs` (inlet / outlet along the flow)."""
    extent = np.ptp(np.asarray(pm.bounds, dtype=float), axis=0)
    out = []
    for ax, name in enumerate("xyz"):
        pairs = pm.periodic_pairs.get(name)
        if pairs is None or not len(pairs):
            continue
        low, high = (face_name(ax, hi, pm.axis) for hi in (False, True))
        out.append((low, high, ax, pairs, float(extent[ax])))
    return out
