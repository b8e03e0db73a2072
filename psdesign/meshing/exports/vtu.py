"""VTU writer: ``pore.vtu`` (tets, ``region`` and ``zone`` ids) and ``pore_boundary.vtu``
(triangles with integer ``tag``); both carry the id -> name tables as field data
(``zone_rve = [10]``, ..., ``tag_inlet = [1]``, ...; :mod:`psdesign.fields.tables`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdesign.io.vtkfile import save_vtk
from psdesign.meshing.exports._common import boundary
from psdesign.meshing.tags import FLUID_TAG, region_ids

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh


def write_vtu(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """``pore.vtu`` (tets) and ``pore_boundary.vtu`` (triangles with integer ``tag``)."""
    import pyvista as pv

    from psdesign.fields.tables import add_tables

    p1, p2 = out / "pore.vtu", out / "pore_boundary.vtu"
    pts = np.asarray(pm.points, float)
    vol = pv.UnstructuredGrid({pv.CellType.TETRA: np.asarray(pm.tets, np.int64)}, pts)
    vol.cell_data["region"] = np.full(len(pm.tets), FLUID_TAG, np.int64)
    vol.cell_data["zone"] = region_ids(pm.tet_regions())
    tris, ids, _ = boundary(pm)
    bnd = pv.UnstructuredGrid({pv.CellType.TRIANGLE: tris}, pts)
    bnd.cell_data["tag"] = np.asarray(ids, np.int64)
    for g, path in ((vol, p1), (bnd, p2)):
        add_tables(g, boundary=True)
        save_vtk(g, path)
    return {"vtu": p1, "vtu_boundary": p2}
