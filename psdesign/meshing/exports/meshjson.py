"""``mesh.json`` writer: counts, tags (ids, facet counts, areas), quality, bounds, pairs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdesign.io.atomic import json_default
from psdesign.meshing.tags import FLUID_TAG, REGION_IDS, TAG_IDS

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh


def mesh_summary(pm: PoreMesh) -> dict:
    """The JSON-serializable summary written to ``mesh.json``."""
    return {
        "direction": pm.direction,
        "porous_region_m": list(pm.porous_region),
        "bounds_m": np.asarray(pm.bounds).tolist(),
        "n_points": int(len(pm.points)),
        "n_tets": int(len(pm.tets)),
        "tags": {
            k: {"id": TAG_IDS[k], "n_facets": int(len(v)), "area_m2": pm.tag_area(k)}
            for k, v in pm.facet_tags.items()
        },
        "fluid_tag": FLUID_TAG,
        "tag_table": dict(TAG_IDS),  # every boundary tag name -> id (VTU ``tag``, Gmsh)
        "region_table": dict(REGION_IDS),  # region name -> id (VTU ``zone``)
        "periodic": pm.periodic,
        "quality": pm.quality,
    }


def write_json(pm: PoreMesh, out: Path) -> Path:
    """``mesh.json`` in ``out``."""
    path = out / "mesh.json"
    path.write_text(json.dumps(mesh_summary(pm), indent=2, default=json_default))
    return path
