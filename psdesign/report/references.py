"""Reference permeability models for fibrous media (used as curves in the study report).

All functions take the porosity ``eps`` (array-like, dimensionless) and the fiber radius ``r``
in metres and return the permeability in m^2.

References
----------
.. [TS93] M. M. Tomadakis and S. V. Sotirchos, "Ordinary and transition regime diffusion in
   random fiber structures", AIChE J. 39 (1993) 397-412; permeability expression and the
   parameters for random fiber structures as tabulated in M. M. Tomadakis and T. J. Robertson,
   "Viscous permeability of random fiber structures: comparison of electrical and diffusional
   estimates with experimental and analytical results", J. Compos. Mater. 39 (2005) 163-188.
   For 2-D random (in-plane isotropic) fiber beds: percolation threshold eps_p = 0.11,
   alpha = 0.521 for flow parallel to the fiber plane (in-plane) and alpha = 0.785 for flow
   normal to it (through-plane); used for GDLs by J. T. Gostick et al., J. Power Sources 162
   (2006) 228-238.
.. [KC] P. C. Carman, "Fluid flow through granular beds", Trans. Inst. Chem. Eng. 15 (1937)
   150-166: Kozeny-Carman equation with the Kozeny constant k_K = 5; written for fibers of
   radius r (hydraulic radius r eps / (2 (1 - eps))) as K = r^2 eps^3 / (4 k_K (1 - eps)^2).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "KOZENY_CONSTANT",
    "TS_ALPHA_IN_PLANE",
    "TS_ALPHA_THROUGH_PLANE",
    "TS_EPS_P",
    "kozeny_carman",
    "tomadakis_sotirchos",
]

#: Percolation threshold of 2-D random fiber structures [TS93].
TS_EPS_P = 0.11
#: Tomadakis-Sotirchos exponent for flow parallel to the fiber plane (in-plane) [TS93].
TS_ALPHA_IN_PLANE = 0.521
#: Tomadakis-Sotirchos exponent for flow normal to the fiber plane (through-plane) [TS93].
TS_ALPHA_THROUGH_PLANE = 0.785
#: Kozeny constant of Carman (1937) [KC].
KOZENY_CONSTANT = 5.0


def _check(eps, r) -> np.ndarray:
    if not np.isscalar(r) or not np.isfinite(r) or r <= 0:
        raise ValueError(f"r: fiber radius must be a finite number > 0 (metres), got {r!r}")
    return np.asarray(eps, dtype=float)


def tomadakis_sotirchos(
    eps, r: float, alpha: float = TS_ALPHA_THROUGH_PLANE, eps_p: float = TS_EPS_P
) -> np.ndarray:
    """Tomadakis-Sotirchos permeability of a random fiber structure.

    ``K = r^2 eps (eps - eps_p)^(alpha + 2) / (8 ln^2(eps) (1 - eps_p)^alpha
    ((alpha + 1) eps - eps_p)^2)``

    Parameters
    ----------
    eps : array_like
        Porosity; NaN is returned outside ``(eps_p, 1)``.
    r : float
        Fiber radius (m).
    alpha : float
        Structure exponent (:data:`TS_ALPHA_IN_PLANE` or :data:`TS_ALPHA_THROUGH_PLANE`).
    eps_p : float
        Percolation threshold.

    Returns
    -------
    numpy.ndarray
        Permeability (m^2).
    """
    e = _check(eps, r)
    ok = (e > eps_p) & (e < 1.0)
    es = np.where(ok, e, 0.5 * (1.0 + eps_p))
    k = (
        r**2
        * es
        * (es - eps_p) ** (alpha + 2.0)
        / (8.0 * np.log(es) ** 2 * (1.0 - eps_p) ** alpha * ((alpha + 1.0) * es - eps_p) ** 2)
    )
    return np.where(ok, k, np.nan)


def kozeny_carman(eps, r: float, k_kozeny: float = KOZENY_CONSTANT) -> np.ndarray:
    """Kozeny-Carman permeability of a bed of fibers of radius ``r``.

    ``K = r^2 eps^3 / (4 k_K (1 - eps)^2)``; NaN outside ``(0, 1)``.
    """
    e = _check(eps, r)
    if not k_kozeny > 0:
        raise ValueError(f"k_kozeny: must be > 0, got {k_kozeny!r}")
    ok = (e > 0.0) & (e < 1.0)
    es = np.where(ok, e, 0.5)
    return np.where(ok, r**2 * es**3 / (4.0 * k_kozeny * (1.0 - es) ** 2), np.nan)
