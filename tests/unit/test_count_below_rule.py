"""A cell count just under a resolution rule is printed under the rule (session 43, helper
s43-polish, item 1).

Before: ``flow.error`` printed the count with ``:.1f``, so 7.99 voxels per diameter under the
rule of 8 read "8.0 voxels per fiber diameter, need 8" and "only 8.0 voxels ... (< 8)", a
contradiction on the line that explains the status.

Truth: the count itself (``cells_per_diameter``, the thinnest measure over the voxel size): the
printed number must be under the rule, and within 0.01 of the count (no rounding that changes
what it says); the woven cell's thin width 13.99 um at 57 voxels per 100 um gives 7.9765
(tests/unit/test_thin_width.py's closed form of the yarn).
"""

from __future__ import annotations

import re

import pytest

from psdesign.flow.error import (
    FIBER_FLOOR_MIN_CELLS,
    MIN_CELLS_PER_DIAMETER,
    count_below,
    resolution_warnings,
    untrustworthy_reasons,
)


def _shown(line: str, before: str) -> float:
    """The number printed just before ``before`` in ``line``."""
    return float(re.search(r"(\d+\.\d+) " + before, line).group(1))


@pytest.mark.parametrize("cpd", [7.95, 7.96, 7.99, 7.9999])
def test_the_status_reason_shows_a_count_under_the_rule(cpd) -> None:
    (line,) = untrustworthy_reasons(0.05, cpd)
    shown = _shown(line, "voxels per fiber diameter")
    assert shown < MIN_CELLS_PER_DIAMETER, line
    assert abs(shown - cpd) <= 0.01, line


@pytest.mark.parametrize("solver", ["voxel", "fem"])
def test_the_warning_line_shows_a_count_under_the_rule(solver) -> None:
    (line,) = resolution_warnings(7.99, solver, "z")
    assert _shown(line, "(voxels|mesh cells) across") == 7.99, line
    (line,) = resolution_warnings(1.497, solver, "z", fiber_floor=True)
    assert _shown(line, "(voxels|mesh cells) across") < FIBER_FLOOR_MIN_CELLS, line


def test_a_count_away_from_the_rule_keeps_one_decimal() -> None:
    assert count_below(7.0, 8) == "7.0"
    assert count_below(2.44, 8) == "2.4"
    assert untrustworthy_reasons(0.05, 7.3) == ["7.3 voxels per fiber diameter, need 8"]


def test_the_voxel_route_warns_with_a_count_under_the_rule() -> None:
    """The woven cell at 57 voxels per period: 7.9765 voxels through the yarn's thickness; the
    voxel route's warning, its status reason and its warnings_* line all show 7.98 (main: 8.0)."""
    from psdesign.flow.permeability import permeability
    from psdesign.geometry.fibers import woven_cell
    from psdesign.geometry.rve import RVE

    rve = RVE([1e-4] * 3, woven_cell())
    flow = {"viscosity": 1.8e-5, "bc": "periodic"}
    with pytest.warns(UserWarning, match="voxels across the thinnest") as caught:
        res = permeability(rve, rve.voxelize(1e-4 / 57), "z", flow, "voxel")
    assert res["cells_per_diameter"] == pytest.approx(7.9765, abs=2e-4)
    lines = [str(w.message) for w in caught if "voxels across" in str(w.message)]
    lines += [w for w in res["warnings"] if "voxels across" in w]
    assert lines
    for line in lines:
        assert _shown(line, "voxels across") == 7.98, line
