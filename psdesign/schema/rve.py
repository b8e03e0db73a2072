"""Schema of the ``[rve]`` table."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from psdesign.schema.types import Table, number

Length = number(gt=0)
Edge = number(ge=1e-9, le=1.0)


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
