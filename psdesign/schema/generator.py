"""Schema of the ``[generator]`` and ``[intersections]`` tables (paper Sec. 7.1)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal

from pydantic import Field, ValidationInfo, field_validator, model_validator

from psdesign.packing.ga_settings import PAPER_MAX_SHIFT
from psdesign.schema.distributions import DistField, support, support_text
from psdesign.schema.fibers import MAX_BENDS, MAX_SLOPE
from psdesign.schema.types import Table, fail, flag, integer, number

METHODS = ("none", "ga", "fast")
DEFAULT_TOLERANCE = 0.005
#: Hard cap of generated fibers (time budget: placement is O(n^2) candidate tests).
MAX_FIBERS_CAP = 100_000
_DIST = "a number or { dist = constant | uniform | normal | beta | exponential, ... }"
#: ``[intersections]`` keys only one method reads (psdesign.packing.generators: ``_fast_options``,
#: ``_ga``); ``none`` reads none of them. ``min_gap = 0`` (the default) is allowed with any method.
METHOD_KEYS = {
    "fast": (
        "min_gap",
        "max_rotation_deg",
        "orientation_tries",
        "step",
        "max_shift_z",
        "max_shift",
        "exceed_bounds",
        "exceed_rotation_deg",
        "max_ejections",
    ),
    "ga": (
        "population",
        "generations",
        "objective",
        "ga_voxel",
        "angle_range_deg",
        "shift_range",
        "time_limit_s",
    ),
}


class Orientation(Table):
    """Schulz et al. (2007) orientation density."""

    # beta^2 overflows above ~1e154 (the sampled directions were NaN and the build failed
    # with "R must be a 3x3 orthogonal matrix"); 1e6 is already a flat in-plane layer
    anisotropy: number(gt=0, le=1e6) = Field(
        1.0, description="beta in (0, 1e6] (1 = isotropic, large = in-plane)"
    )


class GeneratorTable(Table):
    """Random fibers: counts, diameters and Sec. 7.1 parameter distributions."""

    kind: Literal["straight", "bent"] = Field("straight", description="straight | bent")
    porosity: number(gt=0, lt=1) | None = Field(
        None,
        description="target in (0, 1): below one fiber's porosity and 1 - porosity_tolerance; "
        "above the densest packing for fast/ga (or give n_fibers)",
    )
    n_fibers: integer(ge=1, le=MAX_FIBERS_CAP) | None = Field(
        None, description="integer in [1, max_fibers] (or give porosity)"
    )
    diameter: DistField = Field(description=f"metres in (0, period / 2): {_DIST}")
    seed: integer(ge=0, le=2**63 - 1) = Field(0, description="integer >= 0 (default 0)")
    theta: DistField | None = Field(None, description=f"degrees in [-360, 360]: {_DIST}")
    omega: DistField | None = Field(None, description=f"degrees in [-360, 360]: {_DIST}")
    orientation: Orientation | None = Field(
        None, description="{ anisotropy = beta } instead of theta/omega"
    )
    tx: DistField | None = Field(None, description=f"fraction of the x edge in [-1, 2]: {_DIST}")
    ty: DistField | None = Field(None, description=f"fraction of the y edge in [-1, 2]: {_DIST}")
    tz: DistField | None = Field(None, description=f"fraction of the z edge in [-1, 2]: {_DIST}")
    u: DistField | None = Field(None, description=f"bent only, in (-pi, pi): {_DIST}")
    f: DistField | None = Field(
        None,
        description=f"bent only, in (0, 1000], max |u| x max f <= 10: {_DIST}",
    )
    porosity_tolerance: number(gt=0, lt=0.5) = Field(
        DEFAULT_TOLERANCE, description="in (0, 0.5) (default 0.005)"
    )
    max_fibers: integer(ge=1, le=MAX_FIBERS_CAP) = Field(
        5000, description=f"integer in [1, {MAX_FIBERS_CAP}] (default 5000)"
    )

    @field_validator("diameter", "tx", "ty", "tz", "theta", "omega", "u", "f")
    @classmethod
    def _check_range(cls, value: object, info: ValidationInfo) -> object:
        # each key's own range as a field's check, not in the model rule: pydantic runs that
        # rule only when every field passed, so a design point checked without its study
        # (psdesign.study.point: a table missing its diameter, or another key out of range)
        # let generator.f = 5000 through and named a later key before a wrong diameter
        if value is not None:
            inside, unit, allowed = _RANGES[info.field_name]
            if not inside(*support(value)):
                raise fail("", support_text(value, unit), allowed)
        return value

    @model_validator(mode="after")
    def _check(self) -> GeneratorTable:
        """The rules between keys (each key's own range is its field's: ``_check_range``)."""
        given = self.model_fields_set
        if ("porosity" in given) == ("n_fibers" in given):
            raise fail("", "give exactly one of porosity or n_fibers", "porosity or n_fibers")
        if self.orientation is not None and ({"theta", "omega"} & given):
            raise fail("orientation", "give either orientation or theta/omega")
        if self.n_fibers is not None and self.n_fibers > self.max_fibers:
            raise fail(
                "n_fibers",
                f"{self.n_fibers} exceeds max_fibers = {self.max_fibers}",
                f"<= {self.max_fibers}",
            )
        if self.kind == "bent":
            self._check_slope()
        else:
            for k in ("u", "f"):
                if k in given:
                    raise fail(k, "only used with kind = 'bent'", "kind = 'bent'")
        return self

    def _check_slope(self) -> None:
        """A bent generator's ``u`` and ``f`` together (each one's range: ``_check_range``)."""
        umax = max(abs(v) for v in support(self.u)) if self.u is not None else 0.3
        fmax = support(self.f)[1] if self.f is not None else 10.0
        if umax * fmax > MAX_SLOPE:
            raise fail(
                "f",
                f"bend slope max |u| x max f = {umax * fmax:g} (a dense zigzag)",
                f"max |u| x max f <= {MAX_SLOPE:g}",
            )


def _within(lo: float, hi: float) -> Callable[[float, float], bool]:
    """Does a support ``[a, b]`` lie in the closed interval ``[lo, hi]``?"""
    return lambda a, b: lo <= a and b <= hi


#: The ranges of the generator's distributed keys that need no other key: (is the support
#: (low, high) inside, unit, allowed). The diameter's half-period bound needs the rve:
#: psdesign.schema.document.
_RANGES: dict[str, tuple[Callable[[float, float], bool], str, str]] = {
    "diameter": (lambda a, b: a > 0, "m", "(0, period / 2) m"),
    **{k: (_within(-1, 2), "", "[-1, 2]") for k in ("tx", "ty", "tz")},
    **{k: (_within(-360, 360), "degrees", "[-360, 360]") for k in ("theta", "omega")},
    "u": (lambda a, b: max(abs(a), abs(b)) < math.pi, "", "(-pi, pi)"),
    "f": (lambda a, b: 0 < a <= b <= MAX_BENDS, "", f"(0, {MAX_BENDS:g}]"),
}


class IntersectionsTable(Table):
    """Intersection removal: none, the paper's GA, or fast sequential placement."""

    method: Literal["none", "ga", "fast"] = Field("none", description="none | ga | fast")
    min_gap: number() = Field(
        0.0, description="fast only: metres in [-d_min / 2, period / 2) (default 0)"
    )
    max_rotation_deg: number(ge=0, le=360) | None = Field(
        None, description="fast only: degrees in [0, 360]"
    )
    orientation_tries: integer(ge=0, le=1000) | None = Field(
        None, description="fast only: integer in [0, 1000]"
    )
    step: number(gt=0) | None = Field(
        None, description="fast only: metres > 0, >= smallest edge / 1e4"
    )
    max_shift_z: number(gt=0) | None = Field(None, description="fast only: metres > 0")
    max_shift: number(gt=0) | None = Field(
        None,
        description=f"fast: largest move in metres > 0 (default {PAPER_MAX_SHIFT:g} of the period, "
        "Sec. 7.1)",
    )
    exceed_bounds: flag | None = Field(
        None,
        description="true | false: fast may exceed the bounds when a fiber fits nowhere (reported)",
    )
    exceed_rotation_deg: number(ge=0, le=360) | None = Field(
        None,
        description="fast: rotation beyond the bounds, degrees in [0, 360]",
    )
    max_ejections: integer(ge=0, le=10_000) | None = Field(
        None, description="fast only: integer in [0, 10000]"
    )
    population: integer(ge=2, le=10_000) | None = Field(
        None, description="GA population, integer in [2, 10000]"
    )
    generations: integer(ge=2, le=100_000) | None = Field(
        None, description="GA generations, integer in [2, 100000]"
    )
    objective: Literal["analytic", "voxel"] | None = Field(
        None, description="GA only: analytic | voxel"
    )
    ga_voxel: number(gt=0) | None = Field(
        None, description="GA only: metres > 0, GA voxel grid within the memory budget"
    )
    angle_range_deg: number(gt=0, le=360) | None = Field(
        None, description="GA only: degrees in (0, 360]"
    )
    shift_range: number(gt=0, le=1) | None = Field(None, description="GA only: fraction in (0, 1]")
    time_limit_s: number(gt=0, le=604_800) | None = Field(
        None, description="GA only: seconds in (0, 604800] (one week)"
    )

    @model_validator(mode="after")
    def _keys_of_method(self) -> IntersectionsTable:
        """A key of one method refused with another: the other method never reads it (a GA
        with ``min_gap = 3e-6`` placed the fibres as with none, and its report said 3e-6)."""
        given = self.model_fields_set
        for method, keys in METHOD_KEYS.items():
            if self.method == method:
                continue
            for k in keys:
                if k in given and getattr(self, k) is not None and (k != "min_gap" or self.min_gap):
                    raise fail(
                        k,
                        f"only used with intersections.method = {method!r}",
                        f"intersections.method = {method!r}",
                        names=("intersections.method",),
                    )
        return self
