"""The ``[transport]`` table of an RVE spec (pydantic v2): diffusivity, conductivity, pores.

:func:`validate_transport` returns the validated table as a plain dict with defaults filled
in; a bad value raises :class:`~psdesign.errors.SpecError` naming ``transport.<key>`` and the
allowed range (one line).  Wired into the main schema by the coordinator; the transport
commands call it directly.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, ValidationError, field_validator

from psdesign.errors import SpecError
from psdesign.schema.errors import spec_error
from psdesign.schema.types import Table, _is_bool, integer, number, short

#: Smallest phase conductivity accepted (any unit): float64's normal range with room for a
#: series mean; below it the effective value is not representable (a fluid of 5e-324 across
#: walls gave 4.9e-324 for 6.6e-324, session 53). 1e-300 itself is solved exactly.
MIN_CONDUCTIVITY = 1e-300
#: Largest phase conductivity (exclusive, any unit): the schema's bound of the two keys.
MAX_CONDUCTIVITY = 1e12


def _g(value: float) -> str:
    """A bound as the messages print it: ``1e-300``, ``1e12`` (``:g`` without its ``+``)."""
    return f"{value:g}".replace("e+", "e")


#: The accepted range, as every message, flag help and key description says it.
CONDUCTIVITY_RANGE = f"[{_g(MIN_CONDUCTIVITY)}, {_g(MAX_CONDUCTIVITY)})"


class TransportSpec(Table):
    """Keys of ``[transport]`` (SI units).

    Attributes
    ----------
    bc : {"periodic", "permeameter"}
        Laplace boundary conditions: periodic (homogenized tensor, unit mean gradient) or
        fixed inlet/outlet values with insulated sides.
    tol : float
        Relative residual of the conjugate-gradient solve.
    max_iter : int
        Conjugate-gradient iteration cap.
    error_estimate : {"resolution", "residual"}
        ``resolution``: a second solve on a grid twice as coarse (``3 |X_h - X_2h| / X_h``,
        at least the staircase floor) plus the flux imbalance; ``residual``: the staircase
        floor doubled plus the flux imbalance (:mod:`psdesign.transport.effective`). A bool
        means what ``flow.error_estimate``'s does (``permeability(error_estimate=False)``: no
        second grid, the doubled floor): ``True`` is ``resolution``, ``False`` ``residual``
        (``diffusivity(error_estimate=False)`` was refused until session 54).
    bulk_diffusivity_m2_s : float
        Molecular (bulk) diffusivity of the gas, m^2/s (default O2 in air, 25 C: 2.0e-5).
    mean_free_path_m : float
        Gas mean free path, m (default air at 25 C, 1 atm: 68 nm; 0 switches Knudsen off).
    solid_conductivity, fluid_conductivity : float
        Phase conductivities (W/m/K or S/m), > 0 (defaults: carbon fibre 120, air 0.026).
    conductivity_unit : {"W/(m K)", "S/m"}
        The unit of both phase conductivities, and so of the effective one (default thermal,
        W/(m K), as the defaults above).
    insulating_phase : {"none", "solid", "fluid"}
        Treat one phase as a perfect insulator (conductivity exactly 0).
    thickness_axis : {"x", "y", "z"}
        Through-plane axis (porosity profile, intrusion inlet face).
    n_radii : int
        Radii of the local-thickness / intrusion scan.
    surface_tension_n_m, contact_angle_deg : float
        Intrusion fluid (default mercury: 0.485 N/m, 140 deg) for the Washburn pressure.
    """

    bc: Literal["periodic", "permeameter"] = Field(
        "periodic", description="periodic | permeameter (default periodic)"
    )
    tol: number(gt=0, lt=1) = Field(
        1e-8, description="relative residual of the CG solve in (0, 1) (default 1e-8)"
    )
    max_iter: integer(ge=1, le=100_000) = Field(
        2000, description="CG iteration cap in [1, 100000] (default 2000)"
    )
    error_estimate: Literal["resolution", "residual"] = Field(
        "resolution",
        description="resolution | residual, or true | false as flow.error_estimate "
        "(default resolution)",
    )
    bulk_diffusivity_m2_s: number(gt=0, lt=1) = Field(
        2.0e-5, description="m^2/s in (0, 1) (default 2.0e-5, O2 in air at 25 C)"
    )
    mean_free_path_m: number(ge=0, lt=1) = Field(
        6.8e-8, description="metres in [0, 1) (default 6.8e-8, air; 0 switches Knudsen off)"
    )
    solid_conductivity: number(ge=MIN_CONDUCTIVITY, lt=MAX_CONDUCTIVITY) = Field(
        120.0,
        description=f"in conductivity_unit, in {CONDUCTIVITY_RANGE} (default 120, carbon fibre)",
    )
    fluid_conductivity: number(ge=MIN_CONDUCTIVITY, lt=MAX_CONDUCTIVITY) = Field(
        0.026, description=f"in conductivity_unit, in {CONDUCTIVITY_RANGE} (default 0.026, air)"
    )
    conductivity_unit: Literal["W/(m K)", "S/m"] = Field(
        "W/(m K)", description="W/(m K) | S/m (default W/(m K))"
    )
    insulating_phase: Literal["none", "solid", "fluid"] = Field(
        "none", description="none | solid | fluid (default none)"
    )
    thickness_axis: Literal["x", "y", "z"] = Field(
        "z", description="x | y | z: through-plane axis (default z)"
    )
    n_radii: integer(ge=4, le=200) = Field(
        16, description="radii of the local-thickness scan in [4, 200] (default 16)"
    )
    surface_tension_n_m: number(gt=0, lt=10) = Field(
        0.485, description="N/m in (0, 10) (default 0.485, mercury)"
    )
    contact_angle_deg: number(gt=90, le=180) = Field(
        140.0, description="degrees in (90, 180] (default 140, mercury)"
    )

    @field_validator("error_estimate", mode="before")
    @classmethod
    def _estimate_bool(cls, value: object) -> object:
        """``True`` / ``False`` as ``flow.error_estimate``'s: ``resolution`` / ``residual``."""
        if _is_bool(value):
            return "resolution" if value else "residual"
        return value


def transport_keyword(transport: object) -> dict:
    """A public entry's ``transport=`` keyword as a table to validate: None -> ``{}`` (the
    defaults), a dict -> a copy, anything else the one-line ``transport: must be a table``.

    The one rule of every entry (conductivity's ``transport_table``, ``relative_diffusivity``,
    ``diffusivity_tensor``): ``transport or {}`` let ``[]`` through as the defaults and
    ``dict(transport)`` took a list of pairs or failed on ``3`` with a TypeError.

    >>> transport_keyword(None), transport_keyword({"bc": "permeameter"})
    ({}, {'bc': 'permeameter'})
    >>> transport_keyword([])
    Traceback (most recent call last):
    ...
    psdesign.errors.SpecError: transport: must be a table, got []
    """
    if transport is None:
        return {}
    _check_table(transport)
    return dict(transport)


def _check_table(table: object) -> None:
    """``transport: must be a table, got ...`` for anything but a dict."""
    if not isinstance(table, dict):
        raise SpecError("transport", f"must be a table, got {short(table)}")


def validate_transport(spec: dict | None) -> dict:
    """The validated ``[transport]`` table of ``spec`` (defaults if absent), a plain dict.

    Parameters
    ----------
    spec : dict or None
        A whole RVE spec (its ``"transport"`` entry is read) or None.

    Raises
    ------
    SpecError
        ``transport.<key>: ...`` for an unknown key or a value out of range.
    """
    table = (spec or {}).get("transport", {})
    _check_table(table)
    try:
        return TransportSpec(**table).model_dump()
    except ValidationError as exc:
        raise spec_error(exc, TransportSpec, prefix="transport") from None


def check_conductivity(value: float, key: str) -> float:
    """A conductivity given outside the spec (CLI): in :data:`CONDUCTIVITY_RANGE`
    (:data:`MIN_CONDUCTIVITY`, :data:`MAX_CONDUCTIVITY`), else SpecError naming key."""
    lo, hi = _g(MIN_CONDUCTIVITY), _g(MAX_CONDUCTIVITY)
    # a bool or a string is no number (float(True) is 1.0, float("2") 2.0: the API took both)
    if isinstance(value, str | bytes) or _is_bool(value):
        raise SpecError(key, f"must be a number >= {lo} and < {hi}, got {short(value)}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SpecError(key, f"must be a number >= {lo}, got {short(value)}") from None
    if not (v >= MIN_CONDUCTIVITY and v < MAX_CONDUCTIVITY):
        # name the way to say "0" where the user is: the CLI flag or the spec key
        zero = "--insulating" if key.startswith("--") else "transport.insulating_phase"
        raise SpecError(key, f"must be >= {lo} and < {hi} (use {zero} for 0), got {v:g}")
    return v
