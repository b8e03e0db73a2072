"""Binary STL writer of the closed, outward-oriented pore boundary."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import meshio

from psdesign.meshing.exports._common import boundary

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh


def write_stl(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """``pore.stl``: every tagged boundary triangle."""
    path = out / "pore.stl"
    tris, _, _ = boundary(pm)
    meshio.write(path, meshio.Mesh(pm.points, [("triangle", tris)]), file_format="stl", binary=True)
    return {"stl": path}
