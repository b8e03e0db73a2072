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


# ---------------------------------------------------------------------------------------------
# Regular cylinder arrays (flowdarcy: error-estimate coverage test, docs/validation.md).
# Lengths are in units of the array spacing L; K is returned as K / L^2. phi = solid fraction.
# ---------------------------------------------------------------------------------------------

#: Sangani & Acrivos (1982), Int. J. Multiphase Flow 8, 193-206, Table 1: square array, flow
#: across the cylinders, dimensionless drag per unit length F / (mu U) with U the superficial
#: velocity, which equals L^2 / K (also tabulated in Basilisk, src/test/cylinders.c).
SANGANI_ACRIVOS_SQUARE_TRANSVERSE = {
    0.05: 15.56,
    0.1: 24.83,
    0.2: 51.53,
    0.3: 102.90,
    0.4: 217.89,
    0.5: 532.55,
    0.6: 1.763e3,
}


def _dt_log(phi: float) -> float:
    import math

    return -math.log(phi)


def drummond_tahir_square_parallel(phi: float) -> float:
    """K / L^2 for flow along a square array: Drummond & Tahir (1984), Int. J. Multiphase Flow
    10, 515-540: K / a^2 = (-ln phi - 1.476 + 2 phi - phi^2 / 2) / (4 phi), a = radius."""
    import math

    a2 = phi / math.pi  # a^2 / L^2
    return a2 * (_dt_log(phi) - 1.476 + 2 * phi - 0.5 * phi**2) / (4 * phi)


def drummond_tahir_hex_parallel(phi: float) -> float:
    """K / L^2 for flow along a hexagonal (equilateral triangular) array of spacing L:
    Drummond & Tahir (1984): K / a^2 = (-ln phi - 1.498 + 2 phi - phi^2 / 2) / (4 phi)."""
    import math

    a2 = phi * math.sqrt(3.0) / (2 * math.pi)  # unit cell area sqrt(3)/2 L^2 per cylinder
    return a2 * (_dt_log(phi) - 1.498 + 2 * phi - 0.5 * phi**2) / (4 * phi)


def drummond_tahir_hex_transverse(phi: float) -> float:
    """K / L^2 for flow across a hexagonal array: Drummond & Tahir (1984), triangular array,
    K / a^2 = (-ln phi - 1.497 + 2 phi - phi^2/2 - 0.739 phi^4 + 2.534 phi^5 / (1 + 1.2758 phi))
    / (8 phi) (a dilute-limit series: use for phi <= 0.3)."""
    import math

    a2 = phi * math.sqrt(3.0) / (2 * math.pi)
    series = (
        _dt_log(phi)
        - 1.497
        + 2 * phi
        - 0.5 * phi**2
        - 0.739 * phi**4
        + 2.534 * phi**5 / (1 + 1.2758 * phi)
    )
    return a2 * series / (8 * phi)


# ----------------------------------------------------------------- end of cylinder arrays ----
