"""Tag tables written as VTK field data: ids of regions and boundary tags with their names.

ParaView shows field data in its Information panel; the same tables go into ``fields.json`` and
``mesh.json``.  Names and ids come from :mod:`psdesign.meshing.tags` only.
"""

from __future__ import annotations

import numpy as np

from psdesign.meshing import tags


def region_table() -> dict[str, int]:
    """Region name -> id (``zone`` cell data): RVE, inlet and outlet zones (the ``region``
    array holds the whole fluid's :data:`~psdesign.meshing.tags.FLUID_TAG`)."""
    return dict(tags.REGION_IDS)


def boundary_table() -> dict[str, int]:
    """Boundary tag name -> id (``tag`` cell data of the boundary files)."""
    return dict(tags.TAG_IDS)


#: Field-data name prefixes of the tables: ``zone_<region>`` and ``tag_<boundary tag>``.
ZONE_PREFIX, TAG_PREFIX = "zone_", "tag_"


def add_tables(dataset, boundary: bool = False) -> None:
    """Put the region (and boundary) tables into ``dataset.field_data`` (pyvista dataset): one
    one-value integer array per name, ``zone_rve = [10]``, ..., ``tag_inlet = [1]``, ... (numeric
    arrays only: meshio does not read VTK string arrays)."""
    for name, i in region_table().items():
        dataset.field_data[ZONE_PREFIX + name] = np.array([i], np.int32)
    if boundary:
        for name, i in boundary_table().items():
            dataset.field_data[TAG_PREFIX + name] = np.array([i], np.int32)


def read_tables(field_data) -> dict[str, dict[str, int]]:
    """``{"regions": {name: id}, "boundary_tags": {name: id}}`` back from field data (any
    mapping of array name -> array, e.g. pyvista's or meshio's)."""
    out: dict[str, dict[str, int]] = {"regions": {}, "boundary_tags": {}}
    for key, value in field_data.items():
        for prefix, table in ((ZONE_PREFIX, "regions"), (TAG_PREFIX, "boundary_tags")):
            if key.startswith(prefix):
                out[table][key[len(prefix) :]] = int(np.ravel(value)[0])
    return out


def region_ids_along(n_total: int, start: int, stop: int) -> np.ndarray:
    """Region id of each of ``n_total`` cell layers along the flow axis: the RVE is
    ``[start, stop)``, the inlet zone before and the outlet zone after it."""
    ids = np.full(n_total, tags.REGION_IDS[tags.RVE], np.int32)
    ids[:start] = tags.REGION_IDS[tags.AUX_INLET]
    ids[stop:] = tags.REGION_IDS[tags.AUX_OUTLET]
    return ids
