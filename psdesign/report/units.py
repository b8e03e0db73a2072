"""Permeability units the report can show (the data stay in m^2; SI in every file), and the
unit of each study parameter (from the schema's range text) for axis titles and legends."""

from __future__ import annotations

import re
from functools import lru_cache

#: Factor from m^2 to each display unit (1 darcy = 9.869233e-13 m^2).
K_UNITS = {"m2": 1.0, "um2": 1e12, "darcy": 1.0 / 9.869233e-13}
K_UNIT_LABELS = {"m2": "m²", "um2": "µm²", "darcy": "darcy"}


#: Units of study parameters the schema's range text does not spell as a unit word.
_SUFFIX_UNITS = (
    ("_m2_s", "m²/s"),
    ("_gb", "GB"),
    ("_n_m", "N/m"),
    ("_deg", "deg"),
    ("_m", "m"),
    ("_s", "s"),
)
_TEXT_UNITS = (
    (r"\bmetres\b|(?:\d|\]|0) m\b", "m"),
    (r"\bdegrees\b", "deg"),
    (r"^Pa s\b", "Pa s"),
    (r"\bPa in\b", "Pa"),
    (r"kg/m\^3", "kg/m³"),
    (r"\bseconds\b", "s"),
    (r"\bfraction\b", "-"),
)


@lru_cache(maxsize=1)
def _allowed() -> dict[str, str]:
    """Dotted spec key -> the schema's allowed-range text (imported on first use)."""
    from psdesign.schema.keys import key_rows

    return {k: a for rows in key_rows().values() for k, _, a in rows}


def _schema_key(key: str) -> str:
    """The schema's name of a parameter path with list indices: ``fibers.0.diameter`` ->
    ``fibers[].diameter`` (an element's key), ``rve.size.2`` -> ``rve.size`` (an element).

    >>> _schema_key("fibers.0.diameter"), _schema_key("rve.size.2"), _schema_key("rve.voxel")
    ('fibers[].diameter', 'rve.size', 'rve.voxel')
    """
    parts = key.split(".")
    out: list[str] = []
    for i, part in enumerate(parts):
        if part.isdigit() and out:
            if i < len(parts) - 1:
                out[-1] += "[]"
            continue
        out.append(part)
    return ".".join(out)


def parameter_unit(key: str) -> str:
    """The SI unit of a study parameter (a dotted spec key), ``"-"`` for a fraction, or ``""``.

    Read from the schema's range text (``docs/spec-keys.md``: "metres", "degrees", "Pa s",
    "[1e-9, 1] m", ...) and from unit suffixes of key names (``_m``, ``_deg``, ``_m2_s``).
    """
    if key.endswith("porosity"):
        return "-"
    key = _schema_key(key)
    leaf = key.rsplit(".", 1)[-1]
    for suffix, unit in _SUFFIX_UNITS:
        if leaf.endswith(suffix):
            return unit
    text = _allowed().get(key, "")
    for pattern, unit in _TEXT_UNITS:
        if re.search(pattern, text):
            return unit
    return ""


def parameter_label(key: str) -> str:
    """``key (unit)`` for axis titles and legends; the bare key when the unit is unknown."""
    unit = parameter_unit(key)
    return f"{key} ({unit})" if unit else key


def output_unit(column: str, study: dict | None = None) -> str:
    """The SI unit of a study output column, ``"-"`` for a ratio, or ``""`` when unknown.

    ``study`` (the ``[study]`` table of ``study.json``, with its ``base`` spec) gives the
    conductivity's unit (``transport.conductivity_unit``, default ``W/(m K)``); a study that
    varies that key has no one unit.

    >>> [output_unit(c) for c in ("porosity", "k_z_m2", "diffusivity_z", "tortuosity_x",
    ...                           "conductivity_y", "pore_d50_m", "specific_surface_m-1",
    ...                           "intersection_volume_fraction")]
    ['-', 'm²', '-', '-', 'W/(m K)', 'm', '1/m', '-']
    >>> output_unit("conductivity_z", {"base": {"transport": {"conductivity_unit": "S/m"}}})
    'S/m'
    """
    ratios = (
        "porosity",
        "anisotropy",
        "intersection_volume_fraction",
        "omega_before",
        "omega_after",
    )
    if column in ratios or column.startswith(("diffusivity_", "tortuosity_")):
        return "-"  # Omega (the overlap) is a fraction of the box, as the porosity
    if column.startswith("conductivity_"):
        study = study or {}
        if "transport.conductivity_unit" in (study.get("parameters") or {}):
            return ""
        base = study.get("base") if isinstance(study.get("base"), dict) else {}
        return str((base.get("transport") or {}).get("conductivity_unit", "W/(m K)"))
    for suffix, unit in (("_m2", "m²"), ("_m-1", "1/m"), ("_m", "m")):
        if column.endswith(suffix):
            return unit
    return ""


def output_label(column: str, study: dict | None = None) -> str:
    """An axis title for a study output: ``column (unit)``, with what a ratio is a ratio of
    (``diffusivity_z: D_eff/D (-)``); the bare column when its unit is unknown."""
    what = {"diffusivity": ": D_eff/D", "anisotropy": " K_in-plane / K_z"}.get(
        column.split("_")[0], ""
    )
    unit = output_unit(column, study)
    return f"{column}{what} ({unit})" if unit else column
