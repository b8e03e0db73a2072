"""Schema of the ``[rve]`` table."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from psdesign.schema.types import Table, number

Length = number(gt=0)
Edge = number(ge=1e-9, le=1.0)

#: Fewest voxels along any axis of a grid, the one rule of ``rve.voxel`` (at most a quarter of
#: the smallest edge: :class:`psdesign.schema.document.SpecDocument`), of an image
#: (:mod:`psdesign.schema.image`) and of fields built by hand given to ``psdesign.permeability``
#: (:func:`psdesign.flow.permeability.check_grid_voxels`; until session 50 solved and rated).
MIN_VOXELS_PER_EDGE = 4
#: The range they name when refusing.
MIN_VOXELS_TEXT = f"at least {MIN_VOXELS_PER_EDGE} voxels per axis"


class RveTable(Table):
    """The box, its sampling step and the PS period (metres)."""

    size: Annotated[tuple[Edge, Edge, Edge], Field(description="[x, y, z] lengths in [1e-9, 1] m")]
    voxel: Length | None = Field(
        None,
        description="sampling step > 0 m, <= a quarter of the smallest edge, >= 2 voxels across "
        "the thinnest fiber, grid within the memory budget (default: smallest edge / 100)",
    )
    period: Length | None = Field(
        None,
        description="metres per PS period > 0: at most 1000 periodic copies of a fiber in the box, "
        "<= 100 x the largest edge "
        "(default: the largest edge)",
    )
