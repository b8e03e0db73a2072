"""Equality constraints as a parametrization: every model parameter is ``a * x_k + b``.

The paper's constraints (Sec. 6.1: same f, |u1| = |u2|; Sec. 6.2: mu1 - mu2 = 1,
mu4 = mu5, kappa3 = 3 kappa1 = ..., f = 1.5 kappa1, u1 = -u2) all tie one parameter to one
free variable linearly, so the feasible set is a box in the free variables: the
intersection of the ranges each tied parameter allows. An empty intersection is an
infeasible problem and raises :class:`ValueError`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Tie:
    """Parameter ``name = a * free[var] + b`` with allowed range ``[low, high]``."""

    name: str
    var: str
    a: float = 1.0
    b: float = 0.0
    low: float = -np.inf
    high: float = np.inf


@dataclass(frozen=True)
class Parametrization:
    """Free variables and the parameters tied to them.

    Parameters
    ----------
    free : tuple of str
        Names of the free (optimized) variables.
    ties : tuple of Tie
        Every model parameter, each tied to one free variable.
    """

    free: tuple[str, ...]
    ties: tuple[Tie, ...]

    def __post_init__(self) -> None:
        for t in self.ties:
            if t.var not in self.free:
                raise ValueError(f"parameter {t.name!r} is tied to unknown variable {t.var!r}")
            if t.a == 0 or not np.isfinite(t.a) or not np.isfinite(t.b):
                raise ValueError(f"parameter {t.name!r}: tie coefficient must be finite, non-zero")
            if t.low > t.high:
                raise ValueError(f"parameter {t.name!r}: range [{t.low}, {t.high}] is empty")

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Box of the free variables allowed by all parameter ranges.

        Raises
        ------
        ValueError
            If the ranges of parameters tied to one variable do not overlap.
        """
        lo = np.full(len(self.free), -np.inf)
        hi = np.full(len(self.free), np.inf)
        who_lo = [""] * len(self.free)
        who_hi = [""] * len(self.free)
        for t in self.ties:
            k = self.free.index(t.var)
            a, b = (t.low - t.b) / t.a, (t.high - t.b) / t.a
            tl, th = min(a, b), max(a, b)
            if tl > lo[k]:
                lo[k], who_lo[k] = tl, t.name
            if th < hi[k]:
                hi[k], who_hi[k] = th, t.name
        for k, name in enumerate(self.free):
            if lo[k] > hi[k] + 1e-12:
                raise ValueError(
                    f"constraints leave no feasible value of {name!r}: the range of "
                    f"{who_lo[k]!r} needs {name} >= {lo[k]:.6g} but the range of "
                    f"{who_hi[k]!r} needs {name} <= {hi[k]:.6g}"
                )
            if not (np.isfinite(lo[k]) and np.isfinite(hi[k])):
                raise ValueError(
                    f"variable {name!r} needs a finite range (give its parameters low/high bounds)"
                )
            hi[k] = max(hi[k], lo[k])
        return lo, hi

    def expand(self, x) -> dict[str, float]:
        """Model parameters for free variables ``x``."""
        x = np.asarray(x, float)
        return {t.name: float(t.a * x[self.free.index(t.var)] + t.b) for t in self.ties}

    def free_from(self, params: dict[str, float]) -> np.ndarray:
        """Free variables from parameter values (first tie of each variable that is given)."""
        out = np.full(len(self.free), np.nan)
        for t in self.ties:
            k = self.free.index(t.var)
            if np.isnan(out[k]) and t.name in params:
                out[k] = (params[t.name] - t.b) / t.a
        if np.any(np.isnan(out)):
            missing = [n for n, v in zip(self.free, out, strict=True) if np.isnan(v)]
            raise ValueError(f"no parameter value given for free variable(s) {missing}")
        return out

    def inconsistencies(self, params: dict[str, float], tol: float = 1e-9) -> list[str]:
        """Parameters whose given value differs from the value the constraints imply."""
        x = self.free_from(params)
        implied = self.expand(x)
        return [
            f"{n}: given {params[n]:.6g}, constraints imply {implied[n]:.6g}"
            for n in implied
            if n in params and abs(params[n] - implied[n]) > tol
        ]
