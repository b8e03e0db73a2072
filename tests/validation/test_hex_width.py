"""Hexagonal array on a cubic voxel grid (issue 12 item 3): the cell width ``sqrt(3) L`` is not a
whole number of voxels; rounded, it stretches the lattice, and that (not the solver) put the
hexagonal array across at solid fraction 0.2 at -1.2 % at 40 voxels per spacing.

Independent truth: Drummond & Tahir (1984), hexagonal array across (``reference_values``).
"""

from __future__ import annotations

import math

import pytest
from arrays import HEX_NEAR_WHOLE, array_spec, exact_k, hex_width_error, hex_width_voxels

from psdesign.flow.permeability import permeability
from psdesign.packing.build import build_rve
from psdesign.schema.spec import validate_spec


def _hex_across_error(n: int, width: int | None = None, phi: float = 0.2) -> float:
    """True error of the voxel route (periodic, sub-voxel walls) on the hexagonal array across."""
    spec = array_spec("hex", phi, n, width_voxels=width)
    spec["flow"] |= {"solver": "voxel", "bc": "periodic"}
    spec = validate_spec(spec)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    res = permeability(built.rve, fields, "x", spec["flow"], "voxel", error_estimate=False)
    assert res["converged"]
    return res["permeability_m2"] / exact_k("hex", "across", phi) - 1.0


def test_hex_width_rounding() -> None:
    assert hex_width_voxels(40) == 69
    assert hex_width_error(40) == pytest.approx(69 / (40 * math.sqrt(3)) - 1, rel=1e-12, abs=0)
    assert hex_width_error(40) < -4e-3  # the stretched builder cell at 40 voxels per spacing
    assert all(abs(hex_width_error(n)) < 2e-4 for n in HEX_NEAR_WHOLE)
    spec = array_spec("hex", 0.2, 40, width_voxels=70)
    assert spec["rve"]["size"][1] == pytest.approx(70 * 40e-6 / 40, rel=1e-12, abs=0)


def test_hex_across_within_1_percent_at_41_voxels() -> None:
    # 41 x 71 voxels (width -0.020 %): measured -0.05 % (it was -1.21 % at 40 x 69)
    assert abs(_hex_across_error(41)) < 0.01


@pytest.mark.slow
def test_hex_across_at_40_voxels_is_off_by_the_stretch_only() -> None:
    # the rounded cell (69 for 69.28) is more than 1 % low; interpolated between widths 69 and 70
    # to the exact width the same resolution is within 0.3 % (measured -1.18 % / +0.04 %)
    e69, e70 = _hex_across_error(40, 69), _hex_across_error(40, 70)
    assert e69 < -0.01
    w69, w70 = hex_width_error(40, 69), hex_width_error(40, 70)
    exact = e69 - (e70 - e69) * w69 / (w70 - w69)
    assert abs(exact) < 3e-3
    # and the stretch alone predicts the shift: the slope d ln K / d ln width at 41 voxels
    # (measured 2.96) times the width error at 40 is within 0.3 % of the measured error
    e70_41, e72_41 = _hex_across_error(41, 70), _hex_across_error(41, 72)
    slope = (e72_41 - e70_41) / (hex_width_error(41, 72) - hex_width_error(41, 70))
    assert 2.0 < slope < 4.0
    assert e69 == pytest.approx(slope * w69, abs=3e-3)
