"""Schema of a generator parameter: a number or a named distribution table."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal

from pydantic import Discriminator, Field, Tag, TypeAdapter, model_validator

from psdesign.schema.types import Table, fail, number

__all__ = ["DIST_MODELS", "DistField", "DIST_ADAPTER"]

Num = number()


class _Dist(Table):
    #: required parameters of this distribution
    required: ClassVar[tuple[str, ...]] = ()

    @model_validator(mode="before")
    @classmethod
    def _needs(cls, data: Any) -> Any:
        if isinstance(data, dict):
            missing = [k for k in cls.required if k not in data]
            if missing:
                kind = data.get("dist")
                raise fail(
                    "",
                    f"{kind} distribution needs {', '.join(sorted(missing))}",
                    ", ".join(cls.model_fields),
                )
        return data

    def _range(self, low: float | None, high: float | None, what: str) -> None:
        lo = -float("inf") if low is None else low
        hi = float("inf") if high is None else high
        if not lo < hi:
            raise fail("", f"{what} needs low < high, got [{low}, {high}]", "low < high")


class Constant(_Dist):
    """``{dist = "constant", value = v}``"""

    required = ("value",)
    dist: Literal["constant"] = Field(description="constant")
    value: Num | None = Field(None, description="the value (a finite number)")


class Uniform(_Dist):
    """``{dist = "uniform", low, high}``"""

    required = ("low", "high")
    dist: Literal["uniform"] = Field(description="uniform")
    low: Num | None = Field(None, description="lower end (finite number)")
    high: Num | None = Field(None, description="upper end (finite number > low)")

    @model_validator(mode="after")
    def _check(self) -> Uniform:
        self._range(self.low, self.high, "uniform")
        return self


class Normal(_Dist):
    """``{dist = "normal", mean, std[, low, high]}`` (truncated to [low, high])"""

    required = ("mean", "std")
    dist: Literal["normal"] = Field(description="normal")
    mean: Num | None = Field(None, description="mean (finite number)")
    std: number(gt=0) | None = Field(None, description="standard deviation > 0")
    low: Num | None = Field(None, description="truncation below (default -inf)")
    high: Num | None = Field(None, description="truncation above (default +inf)")

    @model_validator(mode="after")
    def _check(self) -> Normal:
        self._range(self.low, self.high, "normal truncation")
        lo = -1e308 if self.low is None else self.low
        hi = 1e308 if self.high is None else self.high
        za, zb = (lo - self.mean) / self.std, (hi - self.mean) / self.std
        if za > 30 or zb < -30:
            raise fail("", "normal truncation window lies > 30 std from the mean", "|z| <= 30")
        return self


class Beta(_Dist):
    """``{dist = "beta", a, b[, low, high]}`` scaled to [low, high] (default [0, 1])"""

    required = ("a", "b")
    dist: Literal["beta"] = Field(description="beta")
    a: number(gt=0) | None = Field(None, description="shape a > 0")
    b: number(gt=0) | None = Field(None, description="shape b > 0")
    low: Num | None = Field(None, description="lower end (default 0)")
    high: Num | None = Field(None, description="upper end (default 1)")

    @model_validator(mode="after")
    def _check(self) -> Beta:
        self._range(
            0.0 if self.low is None else self.low,
            1.0 if self.high is None else self.high,
            "beta range",
        )
        return self


class Exponential(_Dist):
    """``{dist = "exponential", mean[, low, high]}`` (location low, truncated at high)"""

    required = ("mean",)
    dist: Literal["exponential"] = Field(description="exponential")
    mean: number(gt=0) | None = Field(None, description="mean > 0")
    low: Num | None = Field(None, description="location (default 0)")
    high: Num | None = Field(None, description="truncation (default +inf)")

    @model_validator(mode="after")
    def _check(self) -> Exponential:
        self._range(0.0 if self.low is None else self.low, self.high, "exponential")
        return self


DIST_MODELS = {
    "constant": Constant,
    "uniform": Uniform,
    "normal": Normal,
    "beta": Beta,
    "exponential": Exponential,
}


def _tag(v: Any) -> str | None:
    if isinstance(v, dict):
        d = v.get("dist")
        return f"dist={d}" if d is not None else None
    return "dist=number"


DistField = Annotated[
    Annotated[Num, Tag("dist=number")]
    | Annotated[Constant, Tag("dist=constant")]
    | Annotated[Uniform, Tag("dist=uniform")]
    | Annotated[Normal, Tag("dist=normal")]
    | Annotated[Beta, Tag("dist=beta")]
    | Annotated[Exponential, Tag("dist=exponential")],
    Discriminator(_tag),
]
DIST_ADAPTER = TypeAdapter(DistField)


def support(value: Any) -> tuple[float, float]:
    """Smallest interval holding every sample of a validated number or distribution."""
    if isinstance(value, float | int):
        return float(value), float(value)
    if isinstance(value, Constant):
        return value.value, value.value
    defaults = {
        "normal": (-float("inf"), float("inf")),
        "beta": (0.0, 1.0),
        "exponential": (0.0, float("inf")),
    }.get(value.dist, (None, None))
    lo = value.low if value.low is not None else defaults[0]
    hi = value.high if value.high is not None else defaults[1]
    return float(lo), float(hi)


def support_text(value: Any, unit: str = "") -> str:
    """What an out-of-range number or distribution gave, for its one-line error.

    A plain number reads ``got 7 m``; a distribution the interval its samples may take,
    with the way to narrow it (``the distribution allows [0, inf] m (truncate with
    low/high)``): a constant read as a distribution before session 42 ("the distribution
    allows [7, 7] m") hid a unit slip behind a hint about truncation.
    """
    lo, hi = support(value)
    unit = f" {unit}" if unit else ""
    if lo == hi:
        return f"got {lo:g}{unit}"
    return f"the distribution allows [{lo:g}, {hi:g}]{unit} (truncate with low/high)"
