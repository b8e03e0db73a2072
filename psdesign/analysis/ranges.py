"""The physical range of each study output (a light module: no pandas, for the command line)."""

from __future__ import annotations

import math

#: The physical range of each result column whose range is certain:
#: ``column -> (low, low_open, high, high_open, what)`` (a target value outside can never be
#: met). K (m^2) is > 0; porosity and D_eff/D are fractions; the rest are >= 0 or > 0.
_POSITIVE_K = "a permeability target must be > 0 (m^2)"
RANGES: dict[str, tuple[float, bool, float, bool, str]] = {
    "porosity": (0.0, False, 1.0, False, "porosity targets must be in [0, 1]"),
    **{f"k_{d}_m2": (0.0, True, math.inf, False, _POSITIVE_K) for d in "xyz"},
    **{f"k_{d}{d}_m2": (0.0, True, math.inf, False, _POSITIVE_K) for d in "xyz"},
    **{
        f"diffusivity_{d}": (
            0.0,
            False,
            1.0,
            False,
            "a relative diffusivity D_eff/D target must be in [0, 1]",
        )
        for d in "xyz"
    },
    **{
        f"tortuosity_{d}": (0.0, True, math.inf, False, "a tortuosity target must be > 0")
        for d in "xyz"
    },
    **{
        f"conductivity_{d}": (0.0, False, math.inf, False, "a conductivity target must be >= 0")
        for d in "xyz"
    },
    **{
        f"pore_d{q}_m": (0.0, False, math.inf, False, "a pore diameter target must be >= 0 (m)")
        for q in (10, 50, 90)
    },
    "specific_surface_m-1": (
        0.0,
        False,
        math.inf,
        False,
        "a specific surface target must be >= 0 (1/m)",
    ),
}
