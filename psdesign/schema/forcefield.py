"""Schema of the force-field spec's ``[forcefield]`` table (paper Sec. 6)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from psdesign.schema.fibers import MAX_BENDS, MAX_SLOPE
from psdesign.schema.types import Table, fail, integer, number

Weight = number(ge=0)
#: Free parameters of the six-fiber case, Table II's order (the force field code takes them from
#: here: validating a spec imports no numba kernel).
SIX_NAMES = (
    "mu1", "mu2", "mu3", "mu4", "mu5",
    "kappa1", "kappa2", "kappa3", "kappa4", "kappa5",
    "u1", "u2", "f",
)  # fmt: skip
#: Surface terms of the potential (:mod:`psdesign.forcefield.potentials` takes them from here).
SURFACE_TERMS = ("gaussian", "area", "bending")


class Quadrature(Table):
    """Quadrature of the potentials."""

    h: number(ge=1e-4, le=0.05) = Field(0.005, description="grid step in [1e-4, 0.05]")
    n_s: integer(ge=4, le=4096) = Field(64, description="integer in [4, 4096]")
    n_theta: integer(ge=4, le=4096) = Field(32, description="integer in [4, 4096]")


class TwoFiber(Table):
    """The two-fiber case."""

    isovalue: number() = Field(
        -8.82, description="finite number in (constant - 2 mu, constant) (default -8.82)"
    )
    # mu = 0 is no rod (the isovalue range (constant - 2 mu, constant) is empty): it divided
    # by zero in cases.rod_half_width, a traceback (walk-paper, session 53)
    mu: number(gt=0) = Field(4.5, description="number > 0 (default 4.5)")
    constant: number() = Field(0.0, description="finite number (default 0)")
    seed: integer(ge=0, le=2**63 - 1) = Field(0, description="integer >= 0")
    f0: number(ge=1e-6, le=MAX_BENDS) | None = Field(
        None, description="bends per period in [1e-6, 1000] (default: drawn in [1, 2])"
    )
    f_range: number(ge=0, le=MAX_BENDS) = Field(
        1.0, description="number >= 0, f0 + f_range <= 1000 (default 1)"
    )
    u_range: number(ge=0, le=MAX_SLOPE) = Field(
        0.2, description="number in [0, 10], u_range x (f0 + f_range) <= 10 (default 0.2)"
    )

    @model_validator(mode="after")
    def _check_bends(self) -> TwoFiber:
        # the fibers' rules (psdesign.schema.fibers): f <= 1000 bends per period, |u| f <= 10;
        # f0 = 1e300 ran with overflow warnings and wrote f = 1e300
        f_max = (2.0 if self.f0 is None else self.f0) + self.f_range  # a drawn f0 is <= 2
        if f_max > MAX_BENDS:
            raise fail("f_range", f"f0 + f_range = {f_max:g}", f"f0 + f_range <= {MAX_BENDS}")
        if self.u_range * f_max > MAX_SLOPE:
            raise fail(
                "u_range",
                f"bend slope u_range x (f0 + f_range) = {self.u_range * f_max:g}",
                f"<= {MAX_SLOPE:g}",
            )
        return self


_SIX = Literal[tuple(SIX_NAMES)]  # type: ignore[valid-type]


class SixFiber(Table):
    """The six-fiber case (defaults: paper Table II)."""

    isovalue: number() = Field(
        -6.65,
        description="finite number in the start's range (-6.8, -6.12) for Table II's moments: "
        "a fiber, apart from its neighbours (default -6.65)",
    )
    # fibers 4-6 start at t_x = 0.45 in the unit cube: a translation range beyond half a period
    # lets them leave it; 1e300 overflowed their boxes ("bounds must satisfy hi > lo", exit 2
    # naming no key: walk-paper, session 53)
    t_range: number(ge=0, le=0.5) = Field(
        0.1, description="translation half-range in [0, 0.5] periods (default 0.1)"
    )
    initial: dict[_SIX, number()] = Field(
        default_factory=dict, description=f"table of {', '.join(SIX_NAMES)} (finite numbers)"
    )
    ranges: dict[_SIX, number(ge=0)] = Field(
        default_factory=dict, description=f"table of {', '.join(SIX_NAMES)} (numbers >= 0)"
    )


class ForceFieldTable(Table):
    """Optimization settings of a force-field run."""

    case: Literal["two-fiber", "six-fiber"] = Field(description="two-fiber | six-fiber")
    surface: Literal[tuple(SURFACE_TERMS)] = Field(  # type: ignore[valid-type]
        "area", description=" | ".join(SURFACE_TERMS) + " (default area; gaussian = as printed)"
    )
    weights: Annotated[tuple[Weight, Weight, Weight], Field()] = Field(
        (1e10, 1.0, 1.0), description="three numbers >= 0, not all zero"
    )
    max_iter: integer(ge=1, le=100_000) = Field(200, description="integer in [1, 100000]")
    min_step: number(ge=1e-8, le=0.1) = Field(1e-3, description="in [1e-8, 0.1], below step")
    step: number(ge=1e-6, le=0.5) = Field(0.25, description="in [1e-6, 0.5]")
    workers: integer(ge=1, le=64) = Field(2, description="integer in [1, 64]")
    quadrature: Quadrature = Field(default_factory=Quadrature, description="table h, n_s, n_theta")
    two_fiber: TwoFiber | None = Field(None, description="table (case two-fiber)")
    six_fiber: SixFiber | None = Field(None, description="table (case six-fiber)")

    @model_validator(mode="after")
    def _check(self) -> ForceFieldTable:
        if not any(w > 0 for w in self.weights):
            raise fail("weights", "must not be all zero", "three numbers >= 0, not all zero")
        # the other case's table was read and never used: its values had no effect
        for table, case in (("two_fiber", "two-fiber"), ("six_fiber", "six-fiber")):
            if getattr(self, table) is not None and self.case != case:
                raise fail(table, f"only used with case = {case!r}", f"case = {case!r}")
        if not self.min_step < self.step:
            raise fail(
                "min_step", f"must be below step={self.step}, got {self.min_step}", f"< {self.step}"
            )
        return self
