"""VTU writer: ``pore.vtu`` (tets, ``region`` and ``zone`` ids) and ``pore_boundary.vtu``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import meshio
import numpy as np

from psdesign.meshing.exports._common import boundary
from psdesign.meshing.tags import FLUID_TAG, REGION_IDS

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh


def write_vtu(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """``pore.vtu`` (tets) and ``pore_boundary.vtu`` (triangles with integer ``tag``)."""
    p1, p2 = out / "pore.vtu", out / "pore_boundary.vtu"
    zone = np.vectorize(REGION_IDS.get, otypes=[np.int64])(pm.tet_regions())
    meshio.write(
        p1,
        meshio.Mesh(
            pm.points,
            [("tetra", pm.tets)],
            cell_data={"region": [np.full(len(pm.tets), FLUID_TAG)], "zone": [zone]},
        ),
    )
    tris, ids, _ = boundary(pm)
    meshio.write(p2, meshio.Mesh(pm.points, [("triangle", tris)], cell_data={"tag": [ids]}))
    return {"vtu": p1, "vtu_boundary": p2}
