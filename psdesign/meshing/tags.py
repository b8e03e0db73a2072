"""Boundary and region tag names of the pore mesh (the one place they are spelled out).

Boundary facets
    ``INLET`` / ``OUTLET``: the two box faces normal to the flow axis (low / high coordinate);
    ``SIDE_X0`` ... ``SIDE_Z1``: the other box faces (``<axis><0 = low | 1 = high>``);
    ``WALL``: every fiber surface, including fiber end caps facing the auxiliary zones.
Regions (tets)
    ``RVE``: the porous RVE proper; ``AUX_INLET`` / ``AUX_OUTLET``: the empty auxiliary zones
    before and after it along the flow axis (Gmsh physical volumes); ``FLUID`` is the name of
    the whole pore domain (the Fluent cell zone).

Solvers take these names as arguments (``solvers/`` does not import :mod:`psdesign`); the
integer ids are those of the Gmsh / VTU exports.
"""

from __future__ import annotations

INLET = "inlet"
OUTLET = "outlet"
WALL = "wall"
SIDE_X0, SIDE_X1 = "side_x0", "side_x1"
SIDE_Y0, SIDE_Y1 = "side_y0", "side_y1"
SIDE_Z0, SIDE_Z1 = "side_z0", "side_z1"
SIDE_PREFIX = "side_"
SIDES = (SIDE_X0, SIDE_X1, SIDE_Y0, SIDE_Y1, SIDE_Z0, SIDE_Z1)
BOUNDARY_TAGS = (INLET, OUTLET, WALL, *SIDES)

RVE = "rve"
AUX_INLET = "aux_inlet"
AUX_OUTLET = "aux_outlet"
FLUID = "fluid"
REGIONS = (RVE, AUX_INLET, AUX_OUTLET)

#: integer ids of the boundary tags (Gmsh physical surfaces, VTU ``tag`` cell data)
TAG_IDS = {
    INLET: 1,
    OUTLET: 2,
    WALL: 3,
    SIDE_X0: 4,
    SIDE_X1: 5,
    SIDE_Y0: 6,
    SIDE_Y1: 7,
    SIDE_Z0: 8,
    SIDE_Z1: 9,
}
#: integer id of the whole pore domain (VTU ``region`` cell data, mesh.json ``fluid_tag``): not
#: one of :data:`REGION_IDS` (until session 52 it was 10, the ``rve`` region's id too)
FLUID_TAG = 13
#: integer ids of the regions (VTU ``zone`` cell data, Gmsh physical volumes)
REGION_IDS = {RVE: 10, AUX_INLET: 11, AUX_OUTLET: 12}


def region_ids(regions, dtype: str = "int64"):
    """The id (:data:`REGION_IDS`) of each tet's region name in ``regions`` (a mesh's
    ``tet_regions()``), as an array of ``dtype``: one rule for the .vtu, .msh and field
    writers (review G, session 52: three copies of it).

    >>> region_ids(["rve", "aux_inlet", "aux_outlet"]).tolist()
    [10, 11, 12]
    """
    import numpy as np

    return np.vectorize(REGION_IDS.get, otypes=[np.dtype(dtype)])(regions)


def side_name(axis: int, high: bool) -> str:
    """Tag of the box face normal to ``axis`` (0, 1, 2) at its low or high end."""
    return SIDES[2 * int(axis) + int(bool(high))]


def face_name(axis: int, high: bool, flow_axis: int) -> str:
    """Tag of a box face: inlet/outlet when normal to the flow axis, else a side."""
    if int(axis) == int(flow_axis):
        return OUTLET if high else INLET
    return side_name(axis, high)


def is_side(name: str) -> bool:
    """True for the lateral box-face tags (``side_*``)."""
    return name.startswith(SIDE_PREFIX)
