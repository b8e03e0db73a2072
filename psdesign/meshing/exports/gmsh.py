"""Gmsh 2.2 ASCII writer with physical groups (boundary tag names + ``fluid``); a periodic
mesh's opposite faces are linked in a ``$Periodic`` section (:func:`periodic_links`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import meshio
import numpy as np

from psdesign.meshing.exports._common import boundary, periodic_faces
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
        gmsh_periodic=periodic_links(pm) or None,
    )
    meshio.write(path, mesh, file_format="gmsh22", binary=False)
    return {"msh": path}


def periodic_links(pm: PoreMesh) -> list:
    """Gmsh's ``$Periodic`` entries of a periodic mesh (empty otherwise): per axis, the high
    face (entity = its tag id, slave) linked to the low face (master) by a translation of one
    box edge (``Affine``, the 4 x 4 matrix row by row), with the node pairs of
    :attr:`~psdesign.meshing.result.PoreMesh.periodic_pairs` (slave, master)."""
    links = []
    for low, high, ax, pairs, edge in periodic_faces(pm):
        affine = np.eye(4)
        affine[ax, 3] = edge  # master (low) + edge = slave (high)
        links.append((2, (TAG_IDS[high], TAG_IDS[low]), affine, pairs[:, ::-1]))
    return links
