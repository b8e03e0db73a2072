"""Published reference values the tests compare against, each with its source.

One module so that a value is typed once and its citation travels with it.
"""

from __future__ import annotations

import math

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
# Regular cylinder arrays (voxel and FEM validation, error-estimate coverage, docs/validation.md)
# a = radius, L = spacing (nearest neighbours), phi = solid fraction.
# ---------------------------------------------------------------------------------------------

#: Sangani & Acrivos (1982), "Slow flow past periodic arrays of cylinders with application to
#: heat transfer", Int. J. Multiphase Flow 8, 193-206, Table 1: square array, flow across the
#: cylinders, dimensionless drag per unit length F / (mu U) with U the superficial velocity, so
#: that F / (mu U) = L^2 / K (transcribed as in Basilisk's src/test/cylinders.c).
SANGANI_ACRIVOS_SQUARE_TRANSVERSE = {
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
SANGANI_ACRIVOS_SQUARE_DRAG = SANGANI_ACRIVOS_SQUARE_TRANSVERSE  # the same table (L^2 / K)
#: The tabulated values the FEM tests use for flow across (where the dilute series fails).
SANGANI_ACRIVOS_SQUARE_L2_OVER_K = {
    phi: SANGANI_ACRIVOS_SQUARE_TRANSVERSE[phi] for phi in (0.1, 0.2, 0.3)
}
#: Drummond & Tahir (1984), Int. J. Multiphase Flow 10, 515-540, flow along the cylinders:
#: K / a^2 = (-ln phi + c0 + c1 phi + c2 phi^2) / (4 phi); square Eq. (21) (constant as Sparrow &
#: Loeffler 1959), hexagonal (triangular) array. Neglected terms O(phi^4).
SQUARE_ALONG_COEFFS = (-1.476, 2.0, -0.5)
HEX_ALONG_COEFFS = (-1.498, 2.0, -0.5)
#: Sangani & Acrivos / Drummond & Tahir dilute series, square array, flow across:
#: K / a^2 = (-ln phi + c0 + c1 phi + c2 phi^2 + c3 phi^3) / (8 phi); above ~0.2 use the table.
SQUARE_ACROSS_COEFFS = (-1.476, 2.0, -1.774, 4.076)


def _along(phi: float, coeffs: tuple[float, float, float]) -> float:
    import math

    c0, c1, c2 = coeffs
    return (-math.log(phi) + c0 + c1 * phi + c2 * phi**2) / (4 * phi)


def drummond_tahir_along_square(phi: float) -> float:
    """K / a^2 along a square array, Drummond & Tahir (1984)."""
    return _along(phi, SQUARE_ALONG_COEFFS)


def drummond_tahir_along_hexagonal(phi: float) -> float:
    """K / a^2 along a hexagonal (triangular) array, Drummond & Tahir (1984)."""
    return _along(phi, HEX_ALONG_COEFFS)


def drummond_tahir_square_parallel(phi: float) -> float:
    """K / L^2 along a square array of spacing L (a^2 / L^2 = phi / pi)."""
    import math

    return phi / math.pi * drummond_tahir_along_square(phi)


def drummond_tahir_hex_parallel(phi: float) -> float:
    """K / L^2 along a hexagonal array of spacing L (cell area sqrt(3)/2 L^2 per cylinder)."""
    import math

    return phi * math.sqrt(3.0) / (2 * math.pi) * drummond_tahir_along_hexagonal(phi)


def drummond_tahir_hex_transverse(phi: float) -> float:
    """K / L^2 for flow across a hexagonal array: Drummond & Tahir (1984), triangular array,
    K / a^2 = (-ln phi - 1.497 + 2 phi - phi^2/2 - 0.739 phi^4 + 2.534 phi^5 / (1 + 1.2758 phi))
    / (8 phi) (a dilute-limit series: use for phi <= 0.3)."""
    import math

    a2 = phi * math.sqrt(3.0) / (2 * math.pi)
    series = (
        -math.log(phi)
        - 1.497
        + 2 * phi
        - 0.5 * phi**2
        - 0.739 * phi**4
        + 2.534 * phi**5 / (1 + 1.2758 * phi)
    )
    return a2 * series / (8 * phi)


def k_square_along(a: float, phi: float) -> float:
    """K (m^2) along a square array of cylinders of radius ``a`` (m), Drummond & Tahir 1984."""
    return a * a * drummond_tahir_along_square(phi)


def k_square_across(a: float, phi: float) -> float:
    """K (m^2) across a square array of cylinders of radius ``a`` (m), Sangani & Acrivos 1982:
    their Table 1 where ``phi`` is tabulated, else the dilute series (too high above ~0.2)."""
    import math

    for phi_t, l2k in SANGANI_ACRIVOS_SQUARE_L2_OVER_K.items():
        if abs(phi - phi_t) < 1e-12:
            return math.pi * a * a / phi / l2k  # L^2 = pi a^2 / phi
    if phi > 0.3:
        raise ValueError(f"phi: the dilute series is not valid above 0.3 (got {phi})")
    c0, c1, c2, c3 = SQUARE_ACROSS_COEFFS
    return a * a / (8 * phi) * (-math.log(phi) + c0 + c1 * phi + c2 * phi**2 + c3 * phi**3)


# ------------------------------------------------------------------- end of cylinder arrays ---

# ----------------------------------------------------------------------------------------------
# Transport (issue 13): closed forms and published model constants for tests/validation/
# test_transport.py and tests/unit/test_pores.py.  Begin of the transport block.
# ----------------------------------------------------------------------------------------------


def rayleigh_square(f: float, sigma: float) -> float:
    """Transverse sigma_eff / sigma_matrix of a square array of parallel cylinders (area
    fraction ``f``, cylinder / matrix conductivity ratio ``sigma``; 0 = insulating, inf =
    perfectly conducting): Rayleigh's multipole solution (Lord Rayleigh, Phil. Mag. 34, 481,
    1892) as truncated by Perrins, McKenzie & McPhedran, Proc. R. Soc. Lond. A 369, 207 (1979),
    their Eq. for the square array: ``1 - 2f / (T + f - 0.305827 f^4 T / (T^2 - 1.402958 f^8)
    - 0.013362 f^8 / T)`` with ``T = (1 + sigma) / (1 - sigma)``."""
    t = -1.0 if sigma == float("inf") else (1.0 + sigma) / (1.0 - sigma)
    return 1.0 - 2.0 * f / (
        t + f - 0.305827 * f**4 * t / (t * t - 1.402958 * f**8) - 0.013362 * f**8 / t
    )


def rayleigh_hexagonal(f: float, sigma: float) -> float:
    """The same for the hexagonal array (Perrins, McKenzie & McPhedran 1979): sixfold symmetry
    removes the f^4 multipole term; the leading correction is ``0.075422 f^6 / T`` (the next
    ones, O(f^12), change the result by < 1e-4 for f <= 0.6)."""
    t = -1.0 if sigma == float("inf") else (1.0 + sigma) / (1.0 - sigma)
    return 1.0 - 2.0 * f / (t + f - 0.075422 * f**6 / t)


def keller_square_perfect(f: float) -> float:
    """Transverse sigma_eff / sigma_matrix of a square array of perfectly conducting cylinders
    near touching (area fraction ``f`` just below pi / 4): Keller's lubrication asymptote
    (J. B. Keller, J. Appl. Phys. 34, 991, 1963) ``pi^(3/2) / (2 sqrt(pi / 4 - f))``, the
    conductance ``pi sqrt(a / delta)`` of the gap ``delta`` between two neighbours of radius
    ``a``. Finite contrast conducts less (the effective value rises with either phase's
    conductivity), so it bounds a contrast-1000 array from above up to the asymptote's O(1)
    remainder (measured 17.6 against a 2048-pixel finite-volume 15.1 at f = 0.76, contrast
    1000: benchmarks/transport_narrow_gaps.py)."""
    return math.pi**1.5 / (2.0 * math.sqrt(math.pi / 4.0 - f))


def rayleigh_simple_cubic(f: float, sigma: float) -> float:
    """sigma_eff / sigma_matrix of a simple cubic array of spheres (volume fraction ``f``,
    sphere / matrix ratio ``sigma``; inf = perfectly conducting): Rayleigh's formula (Lord
    Rayleigh, Phil. Mag. 34, 481, 1892) ``1 + 3f / (A - f - 1.305 B f^(10/3))`` with
    ``A = (sigma + 2) / (sigma - 1)``, ``B = (sigma - 1) / (sigma + 4/3)`` and the octupole
    coefficient 1.305 of McKenzie, McPhedran & Derrick, Proc. R. Soc. Lond. A 362, 211 (1978).
    The f^(10/3) term moves the result from Maxwell's by up to 0.5 % (insulating) and 2 %
    (conducting, contrast 1000) at f = 0.3; the omitted terms are smaller by about f^(4/3)
    (0.2 at f = 0.3), so the formula is good to ~0.1 % / ~0.4 % there and better below."""
    if sigma == float("inf"):
        a, b = 1.0, 1.0
    else:
        a, b = (sigma + 2.0) / (sigma - 1.0), (sigma - 1.0) / (sigma + 4.0 / 3.0)
    return 1.0 + 3.0 * f / (a - f - 1.305 * b * f ** (10.0 / 3.0))


#: Tomadakis & Sotirchos, AIChE J. 39, 397 (1993), bulk (molecular) diffusion in random fibre
#: structures, ``D_eff / D = eps ((eps - eps_p) / (1 - eps_p))^alpha``: 2-D random (fibres in
#: planes with random in-plane orientation, overlapping): percolation threshold eps_p = 0.11,
#: alpha = 0.521 parallel to the fibre planes (in-plane) and 0.785 normal to them
#: (through-plane); as used for gas-diffusion layers by Nam & Kaviany, Int. J. Heat Mass
#: Transfer 46, 4595 (2003).
TOMADAKIS_SOTIRCHOS_2D = {"eps_p": 0.11, "alpha_in_plane": 0.521, "alpha_through_plane": 0.785}


def tomadakis_sotirchos(eps: float, eps_p: float, alpha: float) -> float:
    """``eps ((eps - eps_p) / (1 - eps_p))^alpha``."""
    return eps * ((eps - eps_p) / (1.0 - eps_p)) ** alpha


# End of the transport block. ------------------------------------------------------------------


# ----------------------------------------------------------------------------------------------
# Simple cubic array of spheres (benchmarks/diffuse3d.py)
# ----------------------------------------------------------------------------------------------

#: Zick & Homsy (1982), "Stokes flow through periodic arrays of spheres", J. Fluid Mech. 115,
#: 13-26, Table 2 (simple cubic): solid fraction c -> dimensionless drag K* with F = 6 pi mu a K*
#: U per sphere (U the superficial velocity), so that the permeability is k = 2 a^2 / (9 c K*)
#: (transcribed as in Basilisk's src/test/spheres.c).
ZICK_HOMSY_SIMPLE_CUBIC = {
    0.027: 2.008,
    0.064: 2.810,
    0.125: 4.292,
    0.216: 7.442,
    0.343: 15.4,
    0.45: 28.1,
    0.5236: 42.1,
}


def zick_homsy_k(c: float) -> float:
    """Zick & Homsy's K* at a tabulated solid fraction ``c`` (within 1e-9)."""
    for c_t, k in ZICK_HOMSY_SIMPLE_CUBIC.items():
        if abs(c - c_t) < 1e-9:
            return k
    raise ValueError(f"c: Zick & Homsy tabulate {sorted(ZICK_HOMSY_SIMPLE_CUBIC)}, got {c}")
