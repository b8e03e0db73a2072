"""Every key of the schema, as dotted paths with type, default and allowed range.

The study runner derives the parameter paths that may vary from :func:`spec_paths`; the docs
key tables (``docs/spec-keys.md``) are generated from :func:`key_rows`.
"""

from __future__ import annotations

import typing

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from psdesign.schema.distributions import DIST_MODELS
from psdesign.schema.document import SpecDocument
from psdesign.schema.errors import _models
from psdesign.schema.fibers import WOVEN_DEFAULTS
from psdesign.schema.study import BoundsParam, RangeParam, StudyTable

__all__ = ["code_defaults", "key_rows", "spec_paths", "study_rows", "table_model"]

#: Tables whose keys a study parameter may set although the base spec lacks them.
_VARIABLE_TABLES = ("rve", "generator", "intersections", "flow", "transport", "image")


def _is_dist(annotation) -> bool:
    return any(m in DIST_MODELS.values() for m in _models(annotation))


def _rows(model: type[BaseModel], prefix: str) -> list[tuple[str, str, str]]:
    """(key, default, allowed) of a table and its sub-tables."""
    out = []
    for name, info in model.model_fields.items():
        key = f"{prefix}{name}"
        default = "" if info.is_required() else _default(info)
        out.append((key, default, info.description or ""))
        subs = [m for m in _models(info.annotation) if m not in DIST_MODELS.values()]
        if subs and typing.get_origin(info.annotation) is not dict:
            for sub in subs:
                out += _rows(sub, f"{key}.")
    return out


def _default(info) -> str:
    if info.default_factory is not None:
        return "(table)"
    return "" if info.default in (None, PydanticUndefined) else repr(info.default)


def code_defaults() -> dict[str, str]:
    """The defaults the code applies to keys the schema leaves None (so that a study can tell
    a given value from none), read from the one place each is defined: ``fast``'s
    (:data:`~psdesign.packing.placement_settings.FAST_SPEC_DEFAULTS`), the GA's
    (:class:`~psdesign.packing.ga_settings.GASettings`), the generator's distributions
    (:data:`~psdesign.packing.generators.DEFAULT_UNIFORM`), a woven cell's
    (:data:`~psdesign.schema.fibers.WOVEN_DEFAULTS`, which ``to_spec`` applies) and ``flow.tol``
    (:data:`~psdesign.schema.flow.FLOW_TOL`). docs/spec-keys.md's default column showed none
    of them until session 53."""
    # imported here: psdesign.packing imports the schema
    from psdesign.packing.ga_settings import GA_VOXEL_RVE_VOXELS, GASettings
    from psdesign.packing.generators import DEFAULT_UNIFORM
    from psdesign.packing.placement_settings import DEFAULT_STEP_DIAMETERS, FAST_SPEC_DEFAULTS
    from psdesign.schema.flow import DIFFUSE_FLOW_TOL, FLOW_TOL

    ga = GASettings()
    out = {f"generator.{k}": f"uniform [{lo:g}, {hi:g}]" for k, (lo, hi) in DEFAULT_UNIFORM.items()}
    out |= {f"fibers[].{k}": repr(v) for k, v in WOVEN_DEFAULTS.items()}
    out |= {f"intersections.{k}": repr(v) for k, v in FAST_SPEC_DEFAULTS.items()}
    out["intersections.step"] = f"{DEFAULT_STEP_DIAMETERS:g} x the thinnest diameter"
    out["intersections.ga_voxel"] = f"{GA_VOXEL_RVE_VOXELS} x rve.voxel"
    for k in ("population", "generations", "objective", "angle_range_deg", "shift_range"):
        out[f"intersections.{k}"] = repr(getattr(ga, k))
    out["flow.tol"] = f"{FLOW_TOL!r} ({DIFFUSE_FLOW_TOL!r} with wall_treatment diffuse)"
    return out


def key_rows() -> dict[str, list[tuple[str, str, str]]]:
    """Key rows per RVE spec table (``fibers`` keys as ``fibers[].key``); a key the schema
    leaves None shows the code's default (:func:`code_defaults`)."""
    code = code_defaults()
    tables: dict[str, list[tuple[str, str, str]]] = {}
    for name, info in SpecDocument.model_fields.items():
        prefix = f"{name}[]." if name == "fibers" else f"{name}."
        model = _models(info.annotation)[0]
        tables[name] = [(k, d or code.get(k, ""), a) for k, d, a in _rows(model, prefix)]
    dist_keys = sorted({k for m in DIST_MODELS.values() for k in m.model_fields})
    tables["distribution"] = [
        (f"<dist>.{k}", "", f"distribution table key ({_dist_users(k)})") for k in dist_keys
    ]
    return tables


def _dist_users(key: str) -> str:
    return ", ".join(n for n, m in DIST_MODELS.items() if key in m.model_fields)


def study_rows() -> dict[str, list[tuple[str, str, str]]]:
    """Key rows of the study file: top level, ``[study]`` and the parameter value forms."""
    top = [
        ("base", "", "inline table (an RVE spec) or path of a spec file"),
        ("study", "", "table (required)"),
        ("parameters", "", "table of dotted spec paths -> list | range | bounds"),
    ]
    return {
        "study file": top,
        "study": _rows(StudyTable, "study."),
        "parameter range": _rows(RangeParam, "<range>."),
        "parameter bounds": _rows(BoundsParam, "<bounds>."),
    }


def table_model(table: str) -> type[BaseModel]:
    """The model of the spec's top-level table ``table`` (``"generator"`` ->
    :class:`~psdesign.schema.generator.GeneratorTable`); ``KeyError`` for another name."""
    return _models(SpecDocument.model_fields[table].annotation)[0]


def spec_paths() -> set[str]:
    """Dotted paths a study parameter may vary (``rve.size.2``, ``generator.theta.high``)."""
    paths: set[str] = set()
    dist_keys = {k for m in DIST_MODELS.values() for k in m.model_fields}
    for table in _VARIABLE_TABLES:
        model = table_model(table)
        paths.add(table)
        for name, info in model.model_fields.items():
            key = f"{table}.{name}"
            paths.add(key)
            if _is_dist(info.annotation):
                paths.update(f"{key}.{k}" for k in dist_keys)
            for sub in _models(info.annotation):
                if sub not in DIST_MODELS.values():
                    paths.update(f"{key}.{k}" for k in sub.model_fields)
    paths.update(f"rve.size.{i}" for i in range(3))
    return paths
