"""ANSYS Fluent ASCII mesh (.msh) with named boundary zones.

meshio's Fluent writer emits cells only (no face zones), which Fluent and OpenFOAM's
``fluent3DMeshToFoam`` reject; this writer emits the face-based format of the Fluent user guide
(appendix "Mesh File Format"): node zone, one fluid cell zone, an interior face zone and one face
zone per boundary tag, with zone names/types in ``(45 ...)`` sections. Indices are hexadecimal
and 1-based; each face line is ``n0 n1 n2 c0 c1``, with the nodes ordered so that the
right-handed normal points into c0, and c1 = 0 on boundary faces.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdesign.meshing import tags as T
from psdesign.meshing.exports._common import side_type
from psdesign.meshing.topology import face_topology

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh

BC_TYPES = {  # Fluent zone-type ids
    "interior": 2,
    "wall": 3,  # format keyword, not a tag
    "pressure-inlet": 4,
    "pressure-outlet": 5,
    "symmetry": 7,
}
ZONE_TYPE = {
    T.INLET: "pressure-inlet",
    T.OUTLET: "pressure-outlet",
    T.WALL: "wall",  # format keyword
}


def _hex_rows(rows: np.ndarray) -> str:
    ncol = rows.shape[1]
    buf = io.StringIO()
    np.savetxt(buf, rows, fmt=" ".join(["%x"] * ncol))
    return buf.getvalue()


def write_fluent(pm: PoreMesh, path: Path, flow: dict | None = None) -> Path:
    """Write ``pm`` as a Fluent 3-D ASCII mesh with zones fluid/interior/<tag names>; the side
    zones are ``symmetry`` with ``flow.sides = "slip"`` (default), ``wall`` with ``"noslip"``."""
    side = side_type(flow)
    patches = {k: v for k, v in pm.facet_tags.items() if len(v)}
    topo = face_topology(pm.points, pm.tets, patches)
    n_nodes, n_cells, n_faces = len(pm.points), len(pm.tets), len(topo.faces)
    out = io.StringIO()
    out.write('(0 "psdesign pore-space mesh")\n(0 "Dimensions:")\n(2 3)\n')
    out.write(f"(10 (0 1 {n_nodes:x} 0 3))\n(12 (0 1 {n_cells:x} 0))\n(13 (0 1 {n_faces:x} 0))\n")
    out.write(f"(10 (1 1 {n_nodes:x} 1 3)(\n")
    np.savetxt(out, pm.points, fmt="%.12e")
    out.write("))\n")
    out.write(f"(12 (2 1 {n_cells:x} 1 2))\n")
    # interior: OpenFOAM normal points owner -> neighbour, so c0 = neighbour, c1 = owner
    ni = topo.n_internal
    zones = [(3, "interior", "interior-fluid")]
    rows = np.column_stack([topo.faces[:ni] + 1, topo.neighbour + 1, topo.owner[:ni] + 1])
    out.write(f"(13 (3 1 {ni:x} {BC_TYPES['interior']} 3)(\n")
    out.write(_hex_rows(rows))
    out.write("))\n")
    zone_id = 4
    for name, start, size in zip(topo.patch_names, topo.patch_start, topo.patch_size, strict=True):
        ztype = ZONE_TYPE.get(name, side)
        sl = slice(start, start + size)
        # boundary faces are stored outward; reverse so that the normal points into c0
        tri = topo.faces[sl][:, ::-1] + 1
        rows = np.column_stack([tri, topo.owner[sl] + 1, np.zeros(size, dtype=np.int64)])
        out.write(f"(13 ({zone_id:x} {start + 1:x} {start + size:x} {BC_TYPES[ztype]} 3)(\n")
        out.write(_hex_rows(rows))
        out.write("))\n")
        zones.append((zone_id, ztype, name))
        zone_id += 1
    out.write(f"(45 (2 fluid {T.FLUID})())\n")
    for zid, ztype, name in zones:
        out.write(f"(45 ({zid} {ztype} {name})())\n")
    path = Path(path)
    path.write_text(out.getvalue())
    return path
