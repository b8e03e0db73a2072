"""Schema of one ``[[fibers]]`` table (an explicit fiber)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from psdesign.geometry.fibers import ROUND_SHAPES, SHAPES
from psdesign.schema.types import Table, Vec3, fail, integer, number

#: Shapes that expand to several fibers.
CELL_SHAPES = ("woven-cell",)
Shape = Literal[tuple(SHAPES + CELL_SHAPES)]  # type: ignore[valid-type]
Angle = number(ge=-360, le=360)
#: Fixed shapes whose equation has a bend term: ``u`` replaces its minor moment.
BENT_FIXED_SHAPES = ("woven", "compressed-bent")
#: The shapes of a fixed equation: ``isovalue`` sets their size, no ``diameter`` or ``f``.
FIXED_SHAPES = tuple(s for s in SHAPES if s not in ROUND_SHAPES)
#: Largest bend slope amplitude ``|u| f`` (Eq. 16; the paper's fibers have u f <= 3).
MAX_SLOPE = 10.0
#: Most bends per period ``f`` (fibers, generator, the force field's two-fiber case).
MAX_BENDS = 1000
#: What a woven cell's keys default to, the one place: applied by :meth:`FiberTable.to_spec`,
#: shown by docs/spec-keys.md (:func:`psdesign.schema.keys.code_defaults`); ``woven_cell``'s
#: own keyword defaults are held to it by tests/unit/test_consistency.py (the geometry
#: cannot import the schema). Three copies until session 53.
WOVEN_DEFAULTS: dict[str, object] = {"thickness_axis": "z", "layers": 1, "layer_shift": (0.0, 0.0)}


class FiberTable(Table):
    """One explicit fiber (lengths in metres, angles in degrees)."""

    shape: Shape = Field("rod", description=" | ".join(SHAPES + CELL_SHAPES) + " (default rod)")
    diameter: number(gt=0) | None = Field(
        None,
        description="metres > 0, below the period and the box edges across the fiber (all "
        "edges unless a rod or cylinder runs along an axis; rod, cylinder, bent-rod only: "
        "required)",
    )
    center: Vec3 | None = Field(
        None, description="[x, y, z] metres, each in [-edge, 2 edge] (default: the box centre)"
    )
    theta: Angle | None = Field(None, description="degrees in [-360, 360] (default 0)")
    omega: Angle | None = Field(None, description="degrees in [-360, 360] (default 0)")
    direction: Vec3 | None = Field(
        None, description="[dx, dy, dz], non-zero (instead of theta/omega)"
    )
    u: number(ge=-10, le=10) = Field(
        0.0,
        description="bent-rod minor moment in [-10, 10]; woven, compressed-bent: the bend "
        "moment (default: the equation's)",
    )
    f: number(gt=0, le=MAX_BENDS) = Field(
        1.0,
        description="bends per period in (0, 1000], with |u| f <= 10 (bent-rod only; a fixed "
        "shape's is its equation's)",
    )
    isovalue: number() | None = Field(
        None,
        description="finite number, fixed shapes only: " + ", ".join(FIXED_SHAPES) + " (default: "
        "the shape's; a rod's, cylinder's, bent-rod's is set by its diameter)",
    )
    thickness_axis: Literal["x", "z"] | None = Field(None, description="x | z (woven-cell only)")
    layers: integer(ge=1, le=8) | None = Field(
        None, description="woven-cell layers stacked along the thickness, integer in [1, 8]"
    )
    layer_shift: tuple[number(ge=-1, le=1), number(ge=-1, le=1)] | None = Field(
        None, description="woven-cell in-plane shift between layers, two numbers in [-1, 1] periods"
    )

    @model_validator(mode="after")
    def _check(self) -> FiberTable:
        given = self.model_fields_set
        if self.shape == "woven-cell":
            extra = sorted(given - {"shape", "thickness_axis", "layers", "layer_shift"})
            if extra:
                raise fail(
                    extra[0],
                    "woven-cell takes only thickness_axis, layers, layer_shift",
                    "thickness_axis, layers, layer_shift",
                )
            return self
        for key in ("thickness_axis", "layers", "layer_shift"):
            if getattr(self, key) is not None:
                raise fail(key, "only used with shape = 'woven-cell'", "woven-cell")
        if self.shape in ROUND_SHAPES and self.diameter is None:
            raise fail("diameter", "missing; give the fiber diameter in metres", "number > 0 m")
        self._check_shape_keys(given)
        if self.direction is not None:
            if "theta" in given or "omega" in given:
                raise fail("direction", "give either direction or theta/omega, not both")
            big = max(abs(c) for c in self.direction)
            if not 1e-12 <= big <= 1e12:
                raise fail("direction", "must have a length in [1e-12, 1e12]", "non-zero vector")
        if abs(self.u) * self.f > MAX_SLOPE:
            raise fail(
                "f",
                f"bend slope |u| f = {abs(self.u) * self.f:g} (a dense zigzag)",
                f"|u| f <= {MAX_SLOPE:g}",
            )
        if self.u and self.shape not in ("bent-rod",) + BENT_FIXED_SHAPES:
            raise fail(
                "u",
                f"bending (u != 0) needs shape = 'bent-rod', got {self.shape!r}",
                "0 unless shape = 'bent-rod', 'woven' or 'compressed-bent'",
            )
        return self

    def _check_shape_keys(self, given: set) -> None:
        """Refuse the keys the shape's geometry ignores (they had no effect: walk-paper,
        session 53): a round fiber's isovalue is set by its diameter (``rod_isovalue``); a
        fixed shape's size by its equation and isovalue, its bend scale by its equation."""
        if self.shape in ROUND_SHAPES and "isovalue" in given:
            raise fail(
                "isovalue",
                f"not used by shape = {self.shape!r} (its diameter sets the isovalue)",
                "only with a fixed shape: " + ", ".join(FIXED_SHAPES),
            )
        # f on a rod or cylinder (u = 0: no bend to scale) was accepted and ignored while the
        # message on a fixed shape said "only with shape = bent-rod" (mendff2, session 53)
        fixed = self.shape in FIXED_SHAPES
        ignored = {"diameter": "set by its equation and isovalue"} if fixed else {}
        if self.shape != "bent-rod":
            ignored["f"] = "set by its equation" if fixed else "it has no bend, u = 0"
        for key, why in ignored.items():
            if key in given:
                raise fail(
                    key,
                    f"not used by shape = {self.shape!r} ({why})",
                    "only with shape = "
                    + ", ".join(ROUND_SHAPES if key == "diameter" else ("bent-rod",)),
                )

    def to_spec(self) -> dict:
        """The plain dict of today's validated spec."""
        if self.shape == "woven-cell":
            return {
                "shape": self.shape,
                "thickness_axis": _or_default(self.thickness_axis, "thickness_axis"),
                "layers": _or_default(self.layers, "layers"),
                "layer_shift": list(_or_default(self.layer_shift, "layer_shift")),
            }
        out: dict = {"shape": self.shape}
        if self.diameter is not None and self.shape in ROUND_SHAPES:
            out["diameter"] = self.diameter
        if self.center is not None:
            out["center"] = list(self.center)
        if self.direction is not None:
            out["direction"] = list(self.direction)
        else:
            out["theta"] = self.theta or 0.0
            out["omega"] = self.omega or 0.0
        out["u"] = self.u
        if self.shape == "bent-rod":  # a fixed shape's bend scale is its equation's
            out["f"] = self.f
        if self.shape in BENT_FIXED_SHAPES and "u" not in self.model_fields_set:
            del out["u"]  # the equation's own bend
        if self.isovalue is not None:
            out["isovalue"] = self.isovalue
        return out


def _or_default(value: object, key: str) -> object:
    """``value``, or the woven cell's default for ``key`` when not given (None)."""
    return WOVEN_DEFAULTS[key] if value is None else value
