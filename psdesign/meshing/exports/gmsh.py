"""Gmsh 2.2 ASCII writer with physical groups (boundary tag names + ``fluid``)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import meshio
import numpy as np

from psdesign.meshing.exports._common import boundary
from psdesign.meshing.tags import FLUID, FLUID_TAG, TAG_IDS

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh


def write_gmsh(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """``pore.msh``: Gmsh 2.2 with physical names, readable by ``gmshToFoam``."""
    path = out / "pore.msh"
    tris, ids, names = boundary(pm)
    field_data = {k: np.array([TAG_IDS[k], 2]) for k in names}
    field_data[FLUID] = np.array([FLUID_TAG, 3])
    tet_ids = np.full(len(pm.tets), FLUID_TAG)
    mesh = meshio.Mesh(
        pm.points,
        [("triangle", tris), ("tetra", pm.tets)],
        cell_data={"gmsh:physical": [ids, tet_ids], "gmsh:geometrical": [ids, tet_ids]},
        field_data=field_data,
    )
    meshio.write(path, mesh, file_format="gmsh22", binary=False)
    return {"msh": path}
