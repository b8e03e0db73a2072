"""Design targets: ``"k_z_m2=8e-12"`` (within a tolerance), ``"diffusivity_z>=0.5"``, ``"x<=3"``."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

#: Most design points of one optimization, and per round (``--budget``, ``--batch``; here, in
#: the light module of ``study optimize``, so the command line checks them without importing
#: the optimizer).
MAX_BUDGET = 10_000
MAX_BATCH = 1000

_TARGET = re.compile(
    r"^\s*([A-Za-z0-9_.\-]+)\s*(>=|<=|=)\s*([^\s]+?)\s*(?:\+-\s*([0-9.eE+-]+)\s*%)?\s*$"
)

#: Relative tolerance of an equality target when none is given.
DEFAULT_TOLERANCE = 0.05


@dataclass(frozen=True)
class Target:
    """One target on a study output.

    Attributes
    ----------
    output : str
        A results column, e.g. ``k_z_m2``.
    op : {"=", ">=", "<="}
    value : float
    tolerance : float
        Relative half-width for ``=`` (``|y - value| <= tolerance * |value|``).
    """

    output: str
    op: str
    value: float
    tolerance: float = DEFAULT_TOLERANCE

    @classmethod
    def parse(cls, text: str) -> Target:
        """Parse ``OUTPUT=VALUE[+-P%]``, ``OUTPUT>=VALUE`` or ``OUTPUT<=VALUE``.

        >>> Target.parse("k_z_m2=8e-12+-3%")
        Target(output='k_z_m2', op='=', value=8e-12, tolerance=0.03)
        """
        m = _TARGET.match(text)
        if not m:
            raise ValueError(
                "--target: expected OUTPUT=VALUE[+-P%], OUTPUT>=VALUE or OUTPUT<=VALUE, "
                f"got {text!r}"
            )
        name, op, val, tol = m.groups()
        try:
            value = float(val)
        except ValueError:
            raise ValueError(f"--target: {name} value must be a number, got {val!r}") from None
        if not math.isfinite(value):
            raise ValueError(f"--target: {name} value must be finite, got {val!r}")
        tolerance = DEFAULT_TOLERANCE if tol is None else float(tol) / 100.0
        if op == "=" and not 0 < tolerance < 1:
            raise ValueError(f"--target: {name} tolerance must be in (0, 100) %, got {tol}%")
        if op == "=" and value == 0:
            raise ValueError(f"--target: {name}=0 has no relative tolerance; use <= or >=")
        return cls(name, op, value, tolerance)

    def met(self, y: float) -> bool:
        """Whether a measured value meets the target."""
        if not math.isfinite(y):
            return False
        if self.op == ">=":
            return y >= self.value
        if self.op == "<=":
            return y <= self.value
        return abs(y - self.value) <= self.tolerance * abs(self.value)

    def miss(self, y: float) -> float:
        """Relative distance from meeting the target (0 when met)."""
        if not math.isfinite(y):
            return math.inf
        scale = abs(self.value) or 1.0
        if self.op == ">=":
            return max(0.0, self.value - y) / scale
        if self.op == "<=":
            return max(0.0, y - self.value) / scale
        return max(0.0, abs(y - self.value) / scale - self.tolerance)

    def __str__(self) -> str:
        if self.op == "=":
            return f"{self.output}={self.value:g}+-{100 * self.tolerance:g}%"
        return f"{self.output}{self.op}{self.value:g}"
