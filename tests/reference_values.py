"""Published reference values the tests compare against, each with its source.

One module so that a value is typed once and its citation travels with it.
"""

from __future__ import annotations

#: NASA PuMA (pumapy 3.2.2) K_zz of ``data/fibres_{32,64}.npz`` in unit-cube lengths squared:
#: Q1-Q1 voxel FEM, periodic sides, unit body force (``data/README-puma.md``).
PUMA_FIBRES_KZZ = {32: 0.009785, 64: 0.010145}
#: Porosity of the same images.
PUMA_FIBRES_POROSITY = {32: 0.96139, 64: 0.96125}

#: Paper Table III permeabilities (m^2), Huang et al., Eng. Comput. 32(1), 2015.
PAPER_TABLE3 = {
    "straight": {"through_plane": 8.07e-12, "in_plane": 1.21e-11},
    "bent": {"through_plane": 7.8e-12, "in_plane": 1.11e-11},
    "woven": {"through_plane": 2.55e-12},
}

# --- voxelbc: cylinder arrays (voxel solver validation) ---------------------------------------
#: Sangani & Acrivos (1982), "Slow flow past periodic arrays of cylinders with application to
#: heat transfer", Int. J. Multiphase Flow 8, 193-206, Table 1: square array, flow across the
#: cylinders, dimensionless drag per unit length F / (mu U) with U the superficial velocity, so
#: that F / (mu U) = L^2 / K for a unit cell of side L (transcribed as in Basilisk's
#: src/test/cylinders.c).  Keys: solid fraction.
SANGANI_ACRIVOS_SQUARE_DRAG = {
    0.05: 15.56,
    0.1: 24.83,
    0.2: 51.53,
    0.3: 102.90,
    0.4: 217.89,
    0.5: 532.55,
    0.6: 1.763e3,
    0.7: 1.352e4,
    0.75: 1.263e5,
}


def drummond_tahir_along_square(phi: float) -> float:
    """K / a^2 for flow along a square array of cylinders (radius a, solid fraction phi):
    ``(-ln phi - 1.476 + 2 phi - phi^2 / 2) / (4 phi)``, Drummond & Tahir (1984), Int. J.
    Multiphase Flow 10, 515-540 (dilute expansion; neglected terms O(phi^4))."""
    import math

    return (-math.log(phi) - 1.476 + 2 * phi - phi**2 / 2) / (4 * phi)


def drummond_tahir_along_hexagonal(phi: float) -> float:
    """K / a^2 for flow along a hexagonal (triangular) array, Drummond & Tahir (1984):
    ``(-ln phi - 1.498 + 2 phi - phi^2 / 2) / (4 phi)`` (leading terms of their expansion)."""
    import math

    return (-math.log(phi) - 1.498 + 2 * phi - phi**2 / 2) / (4 * phi)


# --- end voxelbc -------------------------------------------------------------------------------
