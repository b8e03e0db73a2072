"""Gmsh 2.2 ASCII writer with physical groups (boundary tag names + the regions ``rve``,
``aux_inlet``, ``aux_outlet``, ids :data:`~psdesign.meshing.tags.REGION_IDS`); a periodic
mesh's opposite faces are linked in a ``$Periodic`` section (:func:`periodic_links`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import meshio
import numpy as np

from psdesign.meshing.exports._common import boundary, periodic_faces
from psdesign.meshing.tags import REGION_IDS, TAG_IDS, region_ids

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh


def write_gmsh(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """``pore.msh``: Gmsh 2.2 with physical names, readable by ``gmshToFoam`` (one cellZone per
    region present: a periodic mesh has the ``rve`` alone)."""
    path = out / "pore.msh"
    tris, ids, names = boundary(pm)
    field_data = {k: np.array([TAG_IDS[k], 2]) for k in names}
    # each tet's region (mesh.json's region_table, pore.vtu's zone): one fluid volume id 10
    # lost the auxiliary zones, and 10 meant "rve" in the other files (session 52 walk-mesh 5)
    tet_ids = region_ids(pm.tet_regions())
    for name, i in REGION_IDS.items():
        if (tet_ids == i).any():
            field_data[name] = np.array([i, 3])
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
