"""Mesh exports: VTU, Gmsh 2.2 (physical tags), STL, Fluent (own writer), OpenFOAM, mesh.json."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import meshio
import numpy as np

from psdesign.meshing.errors import MeshInputError

if TYPE_CHECKING:
    from psdesign.meshing.pore_mesh import PoreMesh

FORMATS = ("vtu", "msh", "fluent", "stl", "openfoam")
FLUID_TAG = 10
TAG_IDS = {
    "inlet": 1,
    "outlet": 2,
    "wall": 3,
    "side_x0": 4,
    "side_x1": 5,
    "side_y0": 6,
    "side_y1": 7,
    "side_z0": 8,
    "side_z1": 9,
}


def _boundary(pm: PoreMesh) -> tuple[np.ndarray, np.ndarray, list[str]]:
    names = [k for k in TAG_IDS if k in pm.facet_tags and len(pm.facet_tags[k])]
    tris = np.concatenate([pm.facet_tags[k] for k in names]).astype(np.int64)
    ids = np.concatenate([np.full(len(pm.facet_tags[k]), TAG_IDS[k]) for k in names])
    return tris, ids, names


def write_vtu(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """``pore.vtu`` (tets) and ``pore_boundary.vtu`` (triangles with integer ``tag``)."""
    p1, p2 = out / "pore.vtu", out / "pore_boundary.vtu"
    meshio.write(
        p1,
        meshio.Mesh(
            pm.points,
            [("tetra", pm.tets)],
            cell_data={"region": [np.full(len(pm.tets), FLUID_TAG)]},
        ),
    )
    tris, ids, _ = _boundary(pm)
    meshio.write(p2, meshio.Mesh(pm.points, [("triangle", tris)], cell_data={"tag": [ids]}))
    return {"vtu": p1, "vtu_boundary": p2}


def write_gmsh(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """Gmsh 2.2 ASCII with physical groups (boundary names + ``fluid``) for ``gmshToFoam``."""
    path = out / "pore.msh"
    tris, ids, names = _boundary(pm)
    field_data = {k: np.array([TAG_IDS[k], 2]) for k in names}
    field_data["fluid"] = np.array([FLUID_TAG, 3])
    tet_ids = np.full(len(pm.tets), FLUID_TAG)
    mesh = meshio.Mesh(
        pm.points,
        [("triangle", tris), ("tetra", pm.tets)],
        cell_data={"gmsh:physical": [ids, tet_ids], "gmsh:geometrical": [ids, tet_ids]},
        field_data=field_data,
    )
    meshio.write(path, mesh, file_format="gmsh22", binary=False)
    return {"msh": path}


def write_stl(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """Closed, outward-oriented boundary surface of the pore space (binary STL)."""
    path = out / "pore.stl"
    tris, _, _ = _boundary(pm)
    meshio.write(path, meshio.Mesh(pm.points, [("triangle", tris)]), file_format="stl", binary=True)
    return {"stl": path}


def write_json(pm: PoreMesh, out: Path) -> Path:
    """``mesh.json``: counts, tags, areas, quality, bounds."""
    path = out / "mesh.json"
    data = {
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
        "quality": pm.quality,
    }
    path.write_text(json.dumps(data, indent=2, default=_json_default))
    return path


def _json_default(o):
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o))


def export_mesh(pm: PoreMesh, out_dir, formats=("vtu",)) -> dict[str, Path]:
    """Write ``pm`` into ``out_dir`` in the requested formats, plus ``mesh.json``.

    Parameters
    ----------
    pm
        The mesh.
    out_dir
        Output folder (created).
    formats
        Any of ``vtu`` (``pore.vtu`` + ``pore_boundary.vtu``), ``msh`` (Gmsh 2.2 with physical
        names), ``fluent`` (``pore_fluent.msh``, ANSYS Fluent ASCII with named boundary zones),
        ``stl`` (boundary surface), ``openfoam`` (case folder ``openfoam/`` for simpleFoam).

    Returns
    -------
    dict
        Format name -> written path (``json`` always present).
    """
    if isinstance(formats, str):
        formats = (formats,)
    bad = [f for f in formats if f not in FORMATS]
    if bad:
        raise MeshInputError(f"formats {bad} not supported; allowed: {', '.join(FORMATS)}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: dict[str, Path] = {}
    for fmt in formats:
        if fmt == "vtu":
            written.update(write_vtu(pm, out))
        elif fmt == "msh":
            written.update(write_gmsh(pm, out))
        elif fmt == "stl":
            written.update(write_stl(pm, out))
        elif fmt == "fluent":
            from psdesign.meshing.fluent import write_fluent

            written["fluent"] = write_fluent(pm, out / "pore_fluent.msh")
        elif fmt == "openfoam":
            from psdesign.meshing.openfoam import write_openfoam_case

            written["openfoam"] = write_openfoam_case(pm, out / "openfoam")
    written["json"] = write_json(pm, out)
    return written
