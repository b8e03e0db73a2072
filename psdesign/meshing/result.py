"""The mesher's result type :class:`PoreMesh` (no dependency on the meshers)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from psdesign.meshing import tags as T
from psdesign.meshing.surface import AXES
from psdesign.meshing.tetra import tet_volumes


def triangle_areas(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Areas of triangles ``tris`` (k, 3) over ``points``."""
    p = points
    return 0.5 * np.linalg.norm(
        np.cross(p[tris[:, 1]] - p[tris[:, 0]], p[tris[:, 2]] - p[tris[:, 0]]), axis=1
    )


@dataclass
class PoreMesh:
    """Tetrahedral mesh of the pore space with tagged boundary facets.

    Attributes
    ----------
    points
        (n, 3) vertex coordinates in metres.
    tets
        (m, 4) vertex indices, positively oriented.
    facet_tags
        Boundary triangles (k, 3), outward-oriented, by name (:mod:`psdesign.meshing.tags`):
        ``inlet``, ``outlet``, ``wall`` (fiber surfaces, including fiber end caps facing the
        auxiliary zones) and the four lateral faces ``side_<axis><0|1>``.
    direction
        Flow direction ``'x' | 'y' | 'z'``.
    porous_region
        (start, end) coordinates along the flow axis of the RVE proper (metres).
    bounds
        (2, 3) corners of the meshed box (RVE plus auxiliary zones), metres.
    quality
        Counts, element quality, volume and pore-fraction checks, timings.
    periodic_pairs
        Periodic meshes only: axis name -> (k, 2) vertex indices ``(low face, high face)`` of
        boundary vertices with identical in-plane coordinates; empty for non-periodic meshes.
    """

    points: np.ndarray
    tets: np.ndarray
    facet_tags: dict[str, np.ndarray]
    direction: str
    porous_region: tuple[float, float]
    bounds: np.ndarray
    quality: dict = field(default_factory=dict)
    periodic_pairs: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def axis(self) -> int:
        """Index (0, 1, 2) of the flow axis."""
        return AXES[self.direction]

    @property
    def periodic(self) -> bool:
        """True when the mesh carries periodic face pairings."""
        return bool(self.periodic_pairs)

    def tag_area(self, name: str) -> float:
        """Total area of the facets tagged ``name`` (m^2)."""
        return float(triangle_areas(self.points, self.facet_tags[name]).sum())

    def volume(self) -> float:
        """Total tet volume (m^3)."""
        return float(tet_volumes(self.points, self.tets).sum())

    def tet_regions(self) -> np.ndarray:
        """Region name (:data:`~psdesign.meshing.tags.REGIONS`) of every tet by its centroid."""
        c = self.points[self.tets, self.axis].mean(axis=1)
        start, end = self.porous_region
        out = np.full(len(self.tets), T.RVE, dtype=object)
        out[c < start] = T.AUX_INLET
        out[c > end] = T.AUX_OUTLET
        return out
