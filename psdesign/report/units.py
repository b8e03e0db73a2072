"""Permeability units the report can show (the data stay in m^2; SI in every file)."""

from __future__ import annotations

#: Factor from m^2 to each display unit (1 darcy = 9.869233e-13 m^2).
K_UNITS = {"m2": 1.0, "um2": 1e12, "darcy": 1.0 / 9.869233e-13}
K_UNIT_LABELS = {"m2": "m²", "um2": "µm²", "darcy": "darcy"}
