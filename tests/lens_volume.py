"""The closed-form truth of an overlap lens, for tests of Omega and its status."""

from __future__ import annotations

import numpy as np
from scipy.integrate import quad


def crossing_lens(ri: float, rj: float, s: float) -> float:
    """Exact volume common to two infinite cylinders of radii ``ri``, ``rj`` crossing at right
    angles with axes ``s`` apart, by Cavalieri's principle: a plane at distance y from the first
    axis, parallel to both, cuts them in strips of widths ``2 sqrt(ri^2 - y^2)`` and
    ``2 sqrt(rj^2 - (y - s)^2)`` that meet in a rectangle (s = 0, equal radii: the Steinmetz
    solid ``16 r^3 / 3``), by adaptive quadrature.

    >>> round(crossing_lens(1.0, 1.0, 0.0), 9) == round(16 / 3, 9)
    True
    """

    def area(y: float) -> float:
        return 4 * np.sqrt(max(ri * ri - y * y, 0)) * np.sqrt(max(rj * rj - (y - s) ** 2, 0))

    lo, hi = max(-ri, s - rj), min(ri, s + rj)
    return quad(area, lo, hi, epsabs=1e-30, epsrel=1e-12)[0] if hi > lo else 0.0
