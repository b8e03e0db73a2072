"""The one number validator and the shared field types of the schema.

Every number of every table goes through :func:`number` (finite, not a bool, optional bounds)
or :func:`integer` (a true integer, not a bool, optional bounds), every true / false key
through :data:`flag` (a bool, not a string or a number); the bounds are pydantic
``annotated_types`` constraints, so the error carries them and
:mod:`psdesign.schema.errors` turns them into ``(allowed: ...)``.
"""

from __future__ import annotations

import math
import numbers
from typing import Annotated, Any, ClassVar

import annotated_types as at
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

from psdesign.errors import short  # re-exported: the schema's refusals show values with it

__all__ = ["Table", "Vec3", "fail", "flag", "integer", "number", "short"]


def fail(
    key: str, message: str, allowed: str = "", names: tuple[str, ...] = ()
) -> PydanticCustomError:
    """A schema error at ``key`` (relative to the table validated) with an allowed range;
    ``names``: other spec keys (full dotted paths) the message or range names, as written in
    it, so that a study can spell them as its own file does (``base.rve.voxel``,
    :class:`~psdesign.errors.SpecError` ``.names``)."""
    ctx = {"key": key, "message": message, "allowed": allowed, "names": tuple(names)}
    return PydanticCustomError("psdesign", "{message}", ctx)


def _is_bool(value: Any) -> bool:
    """``True`` / ``False`` and NumPy's bools (a NumPy bool is no ``numbers.Number``)."""
    return isinstance(value, bool) or type(value).__name__ in ("bool_", "bool")


def _finite(value: Any) -> float:
    # numbers.Real: Python ints and floats and NumPy's scalars (np.float32(1e-6) from a
    # notebook is a number; a TOML file never holds one)
    if _is_bool(value) or not isinstance(value, numbers.Real):
        raise PydanticCustomError(
            "number_type", "must be a number, got {got}", {"got": short(value)}
        )
    try:
        v = float(value)
    except OverflowError:
        raise PydanticCustomError(
            "finite_number", "must be a finite number, got {got}", {"got": short(value)}
        ) from None
    if not math.isfinite(v):
        raise PydanticCustomError(
            "finite_number", "must be a finite number, got {got}", {"got": short(value)}
        )
    return v


def _int(value: Any) -> int:
    # numbers.Integral: Python ints and NumPy's integer scalars (np.int64 from np.arange)
    if _is_bool(value) or not isinstance(value, numbers.Integral):
        raise PydanticCustomError(
            "int_type", "must be an integer, got {got}", {"got": short(value)}
        )
    return int(value)


def _flag(value: Any) -> bool:
    # only TOML's true / false (and NumPy's bools from a notebook): pydantic's lax bool took
    # "no", "off", 0 and 1, so a typo'd string silently became a setting
    if not _is_bool(value):
        raise PydanticCustomError(
            "bool_type", "must be true or false, got {got}", {"got": short(value)}
        )
    return bool(value)


#: A true / false key (strings and numbers refused, like bools are refused as numbers).
flag = Annotated[bool, BeforeValidator(_flag)]


def number(
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
) -> Any:
    """A finite float type with optional bounds (the one number validator)."""
    return Annotated[float, BeforeValidator(_finite), at.Interval(gt=gt, ge=ge, lt=lt, le=le)]


def integer(*, ge: int | None = None, le: int | None = None) -> Any:
    """An integer type (bools and floats refused) with optional bounds."""
    return Annotated[int, BeforeValidator(_int), at.Interval(ge=ge, le=le)]


#: Three finite numbers.
Vec3 = Annotated[tuple[number(), number(), number()], Field(description="[x, y, z] numbers")]


class Table(BaseModel):
    """A TOML table: unknown keys are errors with a "did you mean"."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    #: What an entry of this table is called in messages.
    entry: ClassVar[str] = "key"

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data: Any) -> Any:
        if isinstance(data, dict):
            from psdesign.schema.errors import did_you_mean

            allowed = list(cls.model_fields)
            for key in data:
                if key not in allowed:
                    raise fail(
                        str(key),
                        f"unknown {cls.entry}{did_you_mean(str(key), allowed)}",
                        ", ".join(allowed),
                    )
        return data
