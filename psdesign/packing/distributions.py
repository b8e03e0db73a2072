"""Named probability distributions for generator parameters (spec tables).

A parameter in the ``[generator]`` table is either a plain number (a constant) or a
table naming a distribution::

    diameter = 7e-6
    theta = { dist = "uniform", low = -5.0, high = 5.0 }
    tz = { dist = "beta", a = 4, b = 4 }                      # scaled to [low, high] = [0, 1]
    d = { dist = "normal", mean = 7e-6, std = 0.5e-6, low = 5e-6, high = 9e-6 }
    omega = { dist = "exponential", mean = 22.9, high = 180 }  # location ``low`` (default 0)

Supported: ``constant`` (``value``), ``uniform`` (``low``, ``high``), ``normal``
(``mean``, ``std``, optional truncation ``low``/``high``), ``beta`` (``a``, ``b``, scaled to
``[low, high]``, default [0, 1]), ``exponential`` (``mean``, location ``low`` default 0,
optional truncation ``high``).

The fiber orientation density of Schulz et al. (2007), as used by GeoDict for gas
diffusion layers, is :class:`AnisotropicOrientation`: polar angle density (from the
through-plane z axis)

    p(theta) = beta sin(theta) / (2 (1 + (beta^2 - 1) cos^2 theta)^(3/2)),  theta in [0, pi]

with uniform azimuth; ``beta = 1`` is isotropic, ``beta -> inf`` puts every fiber in the
x-y plane. Its CDF in ``c = cos(theta)`` is ``(1 + beta c / sqrt(1 + (beta^2 - 1) c^2)) / 2``,
which is inverted in closed form for sampling.

All sampling uses a caller-provided :class:`numpy.random.Generator`, so a seed
reproduces every draw.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from psdesign.errors import SpecError
from psdesign.schema.distributions import DIST_MODELS

#: Distribution names (from the schema, :mod:`psdesign.schema.distributions`).
DISTRIBUTIONS = tuple(DIST_MODELS)


@dataclass(frozen=True)
class Distribution:
    """A validated one-dimensional distribution.

    Attributes
    ----------
    kind : str
        One of :data:`DISTRIBUTIONS`.
    params : dict
        Parameters (floats); truncation bounds ``low``/``high`` may be ``-inf``/``inf``.
    key : str
        Spec key it came from (for error messages).
    """

    kind: str
    params: dict
    key: str = "?"

    # ---------------------------------------------------------------- build
    @classmethod
    def from_spec(cls, key: str, spec, default: Distribution | None = None) -> Distribution:
        """Parse a number or a ``{dist = ...}`` table; ``None`` gives ``default``.

        Raises
        ------
        SpecError
            Unknown distribution, missing/unknown keys, or invalid parameters.
        """
        if spec is None:
            if default is None:
                raise SpecError(key, "is required")
            return cls(default.kind, dict(default.params), key)
        from pydantic import ValidationError

        from psdesign.schema.distributions import DIST_ADAPTER, DistField
        from psdesign.schema.errors import spec_error

        try:
            value = DIST_ADAPTER.validate_python(spec)
        except ValidationError as exc:
            raise spec_error(exc, DistField, key) from None
        return cls.from_model(key, value)

    @classmethod
    def from_model(cls, key: str, value) -> Distribution:
        """From a validated schema value (a float or a distribution model)."""
        if isinstance(value, int | float):
            return cls("constant", {"value": float(value)}, key)
        p = {k: v for k, v in value.model_dump().items() if k != "dist" and v is not None}
        defaults = {
            "normal": {"low": -np.inf, "high": np.inf},
            "beta": {"low": 0.0, "high": 1.0},
            "exponential": {"low": 0.0, "high": np.inf},
        }.get(value.dist, {})
        for k, v in defaults.items():
            p.setdefault(k, v)
        return cls(value.dist, {k: float(v) for k, v in p.items()}, key)

    @classmethod
    def uniform(cls, low: float, high: float, key: str = "?") -> Distribution:
        return cls("uniform", {"low": float(low), "high": float(high)}, key)

    @classmethod
    def constant(cls, value: float, key: str = "?") -> Distribution:
        return cls("constant", {"value": float(value)}, key)

    # ------------------------------------------------------------ queries
    @property
    def support(self) -> tuple[float, float]:
        """Smallest interval holding every sample."""
        p = self.params
        if self.kind == "constant":
            return p["value"], p["value"]
        return p["low"], p["high"]

    def mean(self) -> float:
        """Closed-form mean (of the truncated distribution where truncated)."""
        p = self.params
        if self.kind == "constant":
            return p["value"]
        if self.kind == "uniform":
            return 0.5 * (p["low"] + p["high"])
        if self.kind == "normal":
            return float(self._truncnorm().mean())
        if self.kind == "beta":
            return p["low"] + (p["high"] - p["low"]) * p["a"] / (p["a"] + p["b"])
        return float(self._truncexpon().mean())

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Draw ``n`` samples with ``rng``."""
        p = self.params
        if self.kind == "constant":
            return np.full(n, p["value"])
        if self.kind == "uniform":
            return rng.uniform(p["low"], p["high"], n)
        if self.kind == "normal":
            return self._truncnorm().rvs(size=n, random_state=rng)
        if self.kind == "beta":
            return p["low"] + (p["high"] - p["low"]) * rng.beta(p["a"], p["b"], n)
        # exponential, location low, truncated at high: inverse CDF of the truncated law
        span = p["high"] - p["low"]
        top = 1.0 if not np.isfinite(span) else -np.expm1(-span / p["mean"])
        q = rng.uniform(0.0, top, n)
        return p["low"] - p["mean"] * np.log1p(-q)

    def _truncnorm(self):
        p = self.params
        a, b = (p["low"] - p["mean"]) / p["std"], (p["high"] - p["mean"]) / p["std"]
        return stats.truncnorm(a, b, loc=p["mean"], scale=p["std"])

    def _truncexpon(self):
        p = self.params
        b = (p["high"] - p["low"]) / p["mean"]
        if not np.isfinite(b):
            return stats.expon(loc=p["low"], scale=p["mean"])
        return stats.truncexpon(b, loc=p["low"], scale=p["mean"])

    def to_dict(self) -> dict:
        out = {"dist": self.kind}
        out.update({k: (v if np.isfinite(v) else None) for k, v in self.params.items()})
        return out


@dataclass(frozen=True)
class AnisotropicOrientation:
    """Schulz et al. (2007) / GeoDict fiber orientation density with anisotropy ``beta``.

    Parameters
    ----------
    anisotropy : float
        ``beta >= 1`` (1 = isotropic, large = in-plane); ``0 < beta < 1`` favours the
        through-plane direction.
    """

    anisotropy: float

    @classmethod
    def from_spec(cls, key: str, spec) -> AnisotropicOrientation:
        from pydantic import ValidationError

        from psdesign.schema.errors import spec_error
        from psdesign.schema.generator import Orientation

        try:
            return cls(Orientation.model_validate(spec).anisotropy)
        except ValidationError as exc:
            raise spec_error(exc, Orientation, key) from None

    def pdf_polar(self, theta: np.ndarray) -> np.ndarray:
        """Density of the polar angle (radians, from +z) on [0, pi]."""
        b = self.anisotropy
        c = np.cos(theta)
        return b * np.sin(theta) / (2.0 * (1.0 + (b * b - 1.0) * c * c) ** 1.5)

    def sample_directions(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Unit direction vectors, shape (n, 3), by inverse-CDF sampling of cos(theta)."""
        b = self.anisotropy
        q = rng.uniform(0.0, 1.0, (n, 2))  # row-wise: the first k draws do not depend on n
        g = 2.0 * q[:, 0] - 1.0
        c = g / np.sqrt(b * b - (b * b - 1.0) * g * g)
        phi = 2.0 * np.pi * q[:, 1]
        s = np.sqrt(np.clip(1.0 - c * c, 0.0, None))
        return np.column_stack([s * np.cos(phi), s * np.sin(phi), c])

    def sample_angles(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Sec. 7.1 angles (theta, omega) in degrees for sampled directions.

        The placed direction is ``(cos t cos w, cos t sin w, -sin t)``; a fiber is a line,
        so ``d`` and ``-d`` are identified and ``omega`` is returned in [0, 180).
        """
        return angles_from_directions(self.sample_directions(rng, n))


def angles_from_directions(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sec. 7.1 angles (theta, omega) in degrees of unit line directions, omega in [0, 180)."""
    d = np.asarray(d, float).reshape(-1, 3)
    theta = np.degrees(-np.arcsin(np.clip(d[:, 2], -1.0, 1.0)))
    omega = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    flip = (omega < 0.0) | (omega >= 180.0)
    omega = np.where(flip, omega + 180.0 * np.where(omega < 0, 1, -1), omega)
    theta = np.where(flip, -theta, theta)
    omega = np.mod(omega, 180.0)
    return theta, omega
