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
