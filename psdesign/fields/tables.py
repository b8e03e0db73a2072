"""Tag tables written as VTK field data: ids of regions and boundary tags with their names.

ParaView shows field data in its Information panel; the same tables go into ``fields.json`` and
``mesh.json``.  Names and ids come from :mod:`psdesign.meshing.tags` only.
"""

from __future__ import annotations

import numpy as np

from psdesign.meshing import tags


def region_table() -> dict[str, int]:
    """Region name -> id (``zone`` / ``region`` cell data): RVE, inlet and outlet zones."""
    return dict(tags.REGION_IDS)


def boundary_table() -> dict[str, int]:
    """Boundary tag name -> id (``tag`` cell data of the boundary files)."""
    return dict(tags.TAG_IDS)


def add_tables(dataset, boundary: bool = False) -> None:
    """Put the region (and boundary) tables into ``dataset.field_data`` (pyvista dataset):
    ``region_ids`` / ``region_names`` and ``boundary_tag_ids`` / ``boundary_tag_names``."""
    reg = region_table()
    dataset.field_data["region_names"] = list(reg)
    dataset.field_data["region_ids"] = np.array(list(reg.values()), np.int32)
    if boundary:
        bnd = boundary_table()
        dataset.field_data["boundary_tag_names"] = list(bnd)
        dataset.field_data["boundary_tag_ids"] = np.array(list(bnd.values()), np.int32)


def region_ids_along(n_total: int, start: int, stop: int) -> np.ndarray:
    """Region id of each of ``n_total`` cell layers along the flow axis: the RVE is
    ``[start, stop)``, the inlet zone before and the outlet zone after it."""
    ids = np.full(n_total, tags.REGION_IDS[tags.RVE], np.int32)
    ids[:start] = tags.REGION_IDS[tags.AUX_INLET]
    ids[stop:] = tags.REGION_IDS[tags.AUX_OUTLET]
    return ids
