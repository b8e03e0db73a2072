"""Load and validate study files (TOML).

A study file holds a base RVE spec, a ``[study]`` table (design, seeds, outputs, solver) and a
``[parameters]`` table of dotted spec paths to vary.  Every validation problem raises
:class:`StudyError` with one line naming the offending key and the allowed values.
"""

from __future__ import annotations

import copy
import json
import math
import re
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from psdesign.errors import SpecError, StudyError  # StudyError: re-exported (light module)
from psdesign.schema.budget import MAX_CASES, MAX_LEVELS
from psdesign.schema.document import STUDY_TABLES
from psdesign.schema.errors import did_you_mean, first_error
from psdesign.schema.image import ImageWarning
from psdesign.schema.keys import spec_paths
from psdesign.schema.spec import SpecWarning, check_directions, read_toml
from psdesign.schema.study import (
    DESIGNS,
    FIELDS_FLAG,
    OUTPUTS,
    SOLVERS,
    BoundsParam,
    RangeParam,
    StudyTable,
    k_directions,
    validate_case_spec,
)
from psdesign.schema.types import short

__all__ = [
    "DESIGNS",
    "KNOWN_SPEC_KEYS",
    "OUTPUTS",
    "SOLVERS",
    "ParamSpec",
    "Study",
    "StudyError",
    "load_study",
    "parse_study",
]


STUDY_KEYS = tuple(StudyTable.model_fields)
RANGE_KEYS = frozenset(RangeParam.model_fields)
BOUNDS_KEYS = frozenset(BoundsParam.model_fields)
DISTS = ("uniform", "loguniform")
VALUE_TYPES = ("float", "int")

#: Spec paths a parameter may set even when the base spec does not hold them: every key of the
#: ``rve``, ``generator``, ``intersections`` and ``flow`` tables of the schema (derived from
#: :mod:`psdesign.schema`, see :func:`psdesign.schema.keys.spec_paths`).
KNOWN_SPEC_KEYS: frozenset[str] = frozenset(spec_paths())


@dataclass(frozen=True)
class ParamSpec:
    """How one parameter is varied.

    Attributes
    ----------
    path : str
        Dotted key into the RVE spec, e.g. ``"generator.porosity"``.
    kind : {"values", "bounds"}
        ``values``: an explicit finite list (from a list or a range); ``bounds``: a continuous
        interval for sampling designs.
    values : tuple
        The levels for ``kind == "values"`` (or ``levels`` points for bounds in a factorial).
    low, high : float
        Interval for ``kind == "bounds"``.
    dist : {"uniform", "loguniform"}
        Mapping of unit samples onto ``[low, high]``.
    value_type : {"float", "int"}
        ``int`` rounds sampled values to integers.
    levels : int or None
        Number of evenly spaced levels when a bounds parameter enters a full factorial.
    """

    path: str
    kind: str
    values: tuple = ()
    low: float = math.nan
    high: float = math.nan
    dist: str = "uniform"
    value_type: str = "float"
    levels: int | None = None


@dataclass
class Study:
    """A validated study.

    Attributes
    ----------
    name : str
    design : str
        One of :data:`DESIGNS`.
    base : dict
        The base RVE spec.
    parameters : dict[str, ParamSpec]
        Parameters in file order.
    seeds : list[int]
        Replicate seeds; each design point is run once per seed.
    outputs : list[str]
        Subset of :data:`OUTPUTS`.
    solver : str
        ``"fem"`` or ``"voxel"``.
    n_samples : int or None
        Number of points for Latin-hypercube / Sobol designs.
    timeout_s : float or None
        Per-case time limit in seconds.
    design_seed : int
        Seed of the Latin-hypercube / Sobol scrambling (reproducible designs).
    csv_rows : list[dict] or None
        Rows of a CSV design (column -> value).
    source : Path or None
        The study file.
    """

    name: str
    design: str
    base: dict
    parameters: dict[str, ParamSpec]
    seeds: list[int]
    outputs: list[str]
    solver: str
    n_samples: int | None = None
    timeout_s: float | None = None
    design_seed: int = 0
    csv_rows: list[dict] | None = None
    source: Path | None = None
    description: str = ""
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-friendly summary of the study (without the expanded cases): what ``study.json``
        holds, so nothing of where or when it ran; the study file's path is run metadata
        (``run.json``'s ``study_file``)."""
        return {
            "name": self.name,
            "description": self.description,
            "design": self.design,
            "n_samples": self.n_samples,
            "design_seed": self.design_seed,
            "seeds": list(self.seeds),
            "outputs": list(self.outputs),
            "solver": self.solver,
            "timeout_s": self.timeout_s,
            "parameters": {
                p.path: {
                    "kind": p.kind,
                    "values": list(p.values),
                    "low": None if math.isnan(p.low) else p.low,
                    "high": None if math.isnan(p.high) else p.high,
                    "dist": p.dist,
                    "type": p.value_type,
                    "levels": p.levels,
                }
                for p in self.parameters.values()
            },
            "base": self.base,
        }


# ----------------------------------------------------------------------------- helpers


def _err(key: str, msg: str) -> StudyError:
    return StudyError(f"{key}: {msg}")


def _validate(model: type, value: Any, key: str) -> Any:
    """Validate ``value`` with a schema model; errors become one-line StudyErrors."""
    try:
        return model.model_validate(value)
    except ValidationError as exc:
        k, msg = first_error(exc, model, key)
        raise _err(k, msg) from None


def _lookup(spec: Any, parts: list[str]) -> bool:
    """True if the dotted path exists in ``spec`` (list segments are integer indices)."""
    node = spec
    for part in parts:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif (
            isinstance(node, list)
            and part.lstrip("-").isdigit()
            and -len(node) <= int(part) < len(node)
        ):
            node = node[int(part)]
        else:
            return False
    return True


def check_spec_path(base: dict, path: str, key: str) -> None:
    """Raise StudyError unless ``path`` exists in ``base`` or is in :data:`KNOWN_SPEC_KEYS`."""
    parts = path.split(".")
    if not path or any(p == "" for p in parts):
        raise _err(key, f"empty segment in parameter path {path!r}")
    if _lookup(base, parts) or path in KNOWN_SPEC_KEYS:
        return
    table = parts[0]
    same = sorted(k for k in KNOWN_SPEC_KEYS if k.split(".")[0] == table and k.count(".") == 1)
    allowed = same or sorted(k for k in KNOWN_SPEC_KEYS if "." not in k)
    hint = did_you_mean(path, same or KNOWN_SPEC_KEYS)
    raise _err(  # the hint ends the sentence: "...; did you mean 'x'?" (not "?:")
        key,
        f"unknown parameter path {path!r}: not in the base spec and not a spec key{hint} "
        f"(allowed: {', '.join(allowed)}, their sub-keys, or paths in the base spec)",
    )


def _range_values(key: str, spec: dict) -> tuple:
    missing = RANGE_KEYS - set(spec)
    if missing:
        raise _err(key, f"range needs start, stop and step (missing {', '.join(sorted(missing))})")
    r = _validate(RangeParam, spec, key)
    start, stop, step = spec["start"], spec["stop"], spec["step"]
    if step == 0 or (stop - start) * step < 0:
        raise _err(f"{key}.step", f"must be non-zero and point from start={start} to stop={stop}")
    n_float = (r.stop - r.start) / r.step + 1e-9
    if not n_float < MAX_LEVELS:
        raise _err(key, f"range has {n_float:.3g} values (allowed: at most {MAX_LEVELS})")
    n = int(math.floor(n_float)) + 1
    all_int = all(isinstance(v, int) for v in (start, stop, step))
    vals = [start + i * step for i in range(n)]
    if not all_int:
        vals = [round_level(v) for v in vals]
    return tuple(vals)


def int_range(low: float, high: float) -> tuple[int, int]:
    """The whole numbers an ``type = "int"`` parameter with bounds ``low``-``high`` takes:
    [ceil(low), floor(high)] (10.2-10.8 gave 10 and 11 by rounding), the one rule of the
    designs, their check for an empty range and ``study optimize``'s proposals.

    >>> int_range(10.4, 12.2), int_range(1, 3)
    ((11, 12), (1, 3))
    """
    return math.ceil(low), math.floor(high)


def round_level(v: float) -> float:
    """A float level of a design as the study runs and shows it: 12 decimals, so floating-point
    noise goes (0.1 + 2 * 0.1 is 0.3; bounds 0.8-0.9 at 3 levels give 0.85, not
    0.8500000000000001), or 12 significant digits where 12 decimals would move the value
    itself (below ~1e-3: 3.71234e-11 stays 3.71234e-11, not 3.7e-11)."""
    r = round(float(v), 12)
    return r if abs(r - v) <= 1e-9 * abs(v) else float(f"{float(v):.12g}")


def _param_spec(path: str, value: Any, key: str) -> ParamSpec:
    if isinstance(value, list):
        if not value:
            raise _err(key, "empty list of values; give at least one value")
        if len(value) > MAX_LEVELS:
            raise _err(key, f"{len(value)} levels (allowed: at most {MAX_LEVELS})")
        seen: set[str] = set()
        for v in value:  # a level twice is the same case twice (same spec, same seeds)
            text = json.dumps(v, sort_keys=True, default=str)
            if text in seen:
                raise _err(
                    key,
                    f"level {short(v)} given twice (allowed: distinct values; repeat a case "
                    "with study.seeds or study.replicates)",
                )
            seen.add(text)
        return ParamSpec(path=path, kind="values", values=tuple(value))
    if isinstance(value, dict):
        keys = set(value)
        _refuse_extra_keys(value, key)
        if keys and keys <= RANGE_KEYS:
            return ParamSpec(path=path, kind="values", values=_range_values(key, value))
        if keys and keys <= BOUNDS_KEYS:
            for name in ("low", "high"):
                if name not in value:
                    raise _err(key, f"bounds need low and high (missing {name})")
            b = _validate(BoundsParam, value, key)
            first, last = int_range(b.low, b.high)
            if b.type == "int" and first > last:
                raise _err(
                    key,
                    f"no integer between low = {b.low} and high = {b.high} (allowed: "
                    'type = "int" bounds holding at least one integer)',
                )
            return ParamSpec(
                path=path,
                kind="bounds",
                low=b.low,
                high=b.high,
                dist=b.dist,
                value_type=b.type,
                levels=b.levels,
            )
    raise _err(
        key,
        "a parameter must be a list of values, a range {start=, stop=, step=} or bounds "
        f"{{low=, high=[, dist=, levels=, type=]}}; got {short(value)}",
    )


_FORMS = (
    ("range", ("start", "stop"), tuple(RangeParam.model_fields)),
    ("bounds", ("low", "high"), tuple(BoundsParam.model_fields)),
)
"""The table forms of a parameter: name, the keys that mark it, all its keys."""


def _table_form(value: dict) -> tuple[str, tuple[str, ...]] | None:
    """The form (name, allowed keys) of a table of scalars that has a form's marking keys
    (``start`` and ``stop``, or ``low`` and ``high``), whatever else it holds; else None."""
    if any(isinstance(v, dict | list) for v in value.values()):
        return None
    for name, marks, allowed in _FORMS:
        if all(m in value for m in marks):
            return name, allowed
    return None


def _refuse_extra_keys(value: dict, key: str) -> None:
    """Refuse, by name, a key a range or bounds table does not take: read as nested paths,
    ``{low, high, levels, foo = 1}`` was "unknown parameter path 'generator.porosity.low'"
    (walk-study, session 53)."""
    form = _table_form(value)
    if form is None:
        return
    name, allowed = form
    extra = [k for k in value if k not in allowed]
    if extra:
        raise _err(
            f"{key}.{extra[0]}", f"not a key of a {name} table (allowed: {', '.join(allowed)})"
        )


def _is_param_value(value: Any) -> bool:
    if isinstance(value, list):
        return True
    if isinstance(value, dict):
        keys = set(value)
        scalars = not any(isinstance(v, dict | list) for v in value.values())
        known = keys <= RANGE_KEYS or keys <= BOUNDS_KEYS
        return bool(keys) and scalars and (known or _table_form(value) is not None)
    return True  # scalars: rejected later with a clear message


def _flatten_parameters(table: dict, prefix: str = "") -> list[tuple[str, Any]]:
    """Flatten ``[parameters]``: ``generator.porosity = [...]`` (nested) and
    ``"generator.porosity" = [...]`` (quoted) both give the path ``generator.porosity``."""
    out: list[tuple[str, Any]] = []
    for k, v in table.items():
        path = f"{prefix}{k}"
        if isinstance(v, dict) and not _is_param_value(v):
            out.extend(_flatten_parameters(v, prefix=f"{path}."))
        else:
            out.append((path, v))
    return out


def _read_csv_rows(path: Path, key: str) -> tuple[list[str], list[dict]]:
    import pandas as pd

    if path.is_dir():  # as a spec given as a folder (schema.spec.read_toml); session 52
        raise _err(key, f"{path} is a folder; give a CSV file")
    if not path.is_file():
        raise _err(key, f"CSV file not found: {path}")
    try:
        df = pd.read_csv(path)
    except Exception as exc:  # noqa: BLE001 - any parse problem becomes one clear line
        raise _err(key, f"cannot read CSV {path}: {exc}") from exc
    if df.empty:
        raise _err(key, f"CSV {path} has no rows; the design would be empty")
    rows = []
    for rec in df.to_dict(orient="records"):
        row = {}
        for c, v in rec.items():
            if hasattr(v, "item"):
                v = v.item()
            row[str(c)] = v
        rows.append(row)
    return [str(c) for c in df.columns], rows


# ----------------------------------------------------------------------------- public API


def parse_study(data: dict, source: Path | None = None) -> Study:
    """Validate a parsed study TOML document.

    Parameters
    ----------
    data : dict
        The TOML document as returned by :func:`tomllib.load`.
    source : Path, optional
        The study file; relative ``base``/``csv`` paths are resolved against its folder.

    Returns
    -------
    Study

    Raises
    ------
    StudyError
        With one line naming the bad key and the allowed values.
    """
    try:
        return _parse_study(data, source)
    except RecursionError:
        raise _err("study", "nested too deeply (allowed: a few levels of tables)") from None
    except (OverflowError, MemoryError) as exc:
        raise _err(
            "study", f"cannot validate ({type(exc).__name__}): numbers or sizes too large"
        ) from None


def _read_base(data: dict, root: Path) -> dict:
    if "base" not in data:
        raise _err("base", 'missing: give an inline [base] table or base = "spec.toml"')
    base_raw = data["base"]
    if isinstance(base_raw, str):
        bpath = (root / base_raw).resolve()
        if not bpath.exists():  # a folder or a device: read_toml's line says which
            raise _err("base", f"spec file not found: {bpath}")
        try:
            base = read_toml(bpath, key="base", error=SpecError)
        except SpecError as exc:
            raise _err("base", exc.message) from None
    elif isinstance(base_raw, dict):
        base = copy.deepcopy(base_raw)
    else:
        raise _err("base", f"must be a table or a path string, got {type(base_raw).__name__}")
    if not base:
        raise _err("base", "the base spec is empty; it needs at least an [rve] table")
    # an [image] path is relative to the spec file (or, inline, to the study file)
    image = base.get("image")
    if isinstance(image, dict) and isinstance(image.get("path"), str):
        folder = bpath.parent if isinstance(base_raw, str) else root
        image["path"] = str((folder / Path(image["path"]).expanduser()).resolve())
    return base


def _parse_study(data: dict, source: Path | None) -> Study:
    if not isinstance(data, dict):
        raise _err("study", "the study file must be a TOML document")
    if not set(STUDY_TABLES) & set(data) and {"rve", "image"} & set(data):
        # an RVE spec given where a study goes (session 42: "rve: unknown top-level key")
        raise _err(
            "study",
            "this is an RVE spec ([rve] / [image] table), not a study file: a study names it "
            'as base = "FILE" beside its [study] and [parameters] tables (docs/study-files.md); '
            "`psdesign permeability FILE` solves it alone (allowed: [study], [parameters] and "
            'base = "FILE")',
        )
    for k in data:
        if k not in STUDY_TABLES:
            raise _err(
                k,
                f"unknown top-level key{did_you_mean(k, STUDY_TABLES)} (allowed: "
                f"{', '.join(STUDY_TABLES)})",
            )
    root = source.parent if source is not None else Path.cwd()
    st_raw = data.get("study")
    if not isinstance(st_raw, dict):
        raise _err("study", "missing [study] table (name, design, outputs, solver ...)")
    st = _validate(StudyTable, st_raw, "study")
    base = _read_base(data, root)
    name = st.name if st.name is not None else (source.stem if source is not None else "study")
    if st.seeds is not None:
        seeds = list(st.seeds)
    else:
        reps = st.replicates or 1
        gen = base.get("generator") if isinstance(base.get("generator"), dict) else {}
        s0 = gen.get("seed", 1)
        if not isinstance(s0, int) or isinstance(s0, bool) or not 0 <= s0 < 2**62:
            raise _err("base.generator.seed", f"must be an integer >= 0, got {short(s0)}")
        seeds = [s0 + i for i in range(reps)]
    outputs = [st.outputs] if isinstance(st.outputs, str) else list(st.outputs)
    flow = base.get("flow") if isinstance(base.get("flow"), dict) else {}
    from psdesign.flow.darcy import flow_direction

    default = flow_direction(None, flow)  # the base's direction, as `permeability` takes it
    if "outputs" not in st.model_fields_set and default in ("x", "y", "z"):
        outputs = ["porosity", f"k_{default}"]
    outputs = list(dict.fromkeys(outputs))
    if st.fields:
        outputs.append(FIELDS_FLAG)  # the case writes its fields (psdesign.study.case)
    solver = st.solver or flow.get("solver", "fem")
    if solver not in SOLVERS:
        raise _err("base.flow.solver", f"got {short(solver)}; allowed: {', '.join(SOLVERS)}")

    params, csv_rows = _parameters(data, st, base, root, seeds)
    study = Study(
        name=name.strip(),
        design=st.design,
        base=base,
        parameters=params,
        seeds=seeds,
        outputs=outputs,
        solver=solver,
        n_samples=st.n_samples,
        timeout_s=st.timeout_s,
        design_seed=st.design_seed,
        csv_rows=csv_rows,
        source=source,
        description=st.description,
    )
    check_study_specs(study)
    return study


#: Spec keys a case never reads from its spec: the study's solver and its outputs' directions
#: decide (a ``flow.direction = ["x", "z"]`` parameter solved K_z twice).
NOT_PARAMETERS = {
    "flow.solver": "a study solves with one solver: set study.solver (one study per solver)",
    "flow.direction": "a study solves the directions of its outputs: list k_x / k_y / k_z "
    "(or k_tensor) in study.outputs",
}


def _not_varied(path: str, key: str) -> None:
    """Refuse a parameter (or CSV column) of :data:`NOT_PARAMETERS`."""
    if path in NOT_PARAMETERS:
        raise _err(key, f"not a study parameter: {NOT_PARAMETERS[path]}")


def _parameters(
    data: dict, st: StudyTable, base: dict, root: Path, seeds: list[int]
) -> tuple[dict[str, ParamSpec], list[dict] | None]:
    """The ``[parameters]`` table (and the CSV design's columns), validated."""
    # --- [parameters]
    ptable = data.get("parameters", {})
    if not isinstance(ptable, dict):
        raise _err("parameters", "must be a table of dotted spec paths")
    params: dict[str, ParamSpec] = {}
    for path, value in _flatten_parameters(ptable):
        key = f"parameters.{path}"
        check_spec_path(base, path, key)
        if path == "generator.seed":
            raise _err(key, "vary seeds with study.seeds or study.replicates, not a parameter")
        _not_varied(path, key)
        if path in params:  # "flow.viscosity" = [...] and flow.viscosity = [...]: TOML keeps both
            raise _err(
                key, "given twice (a quoted and a dotted key name the same path); give it once"
            )
        params[path] = _param_spec(path, value, key)

    csv_rows = None
    if st.design == "csv":
        if params:  # the design reads the rows only: the levels were listed, never run
            path = next(iter(params))
            raise _err(
                f"parameters.{path}",
                f"a csv design runs the rows of study.csv only (allowed: no [parameters] with "
                f'design = "csv"; give {path} as a column of {st.csv})',
            )
        cols, csv_rows = _read_csv_rows((root / st.csv).resolve(), "study.csv")
        if len(csv_rows) * (1 if "seed" in cols else len(seeds)) > MAX_CASES:
            raise _err(
                "study.csv",
                f"{len(csv_rows)} rows x {len(seeds)} seeds (allowed: at most {MAX_CASES} cases)",
            )
        for c in cols:
            if c == "seed":
                continue
            check_spec_path(base, c, f"study.csv column {c!r}")
            _not_varied(c, f"study.csv column {c!r}")
            if c not in params:
                params[c] = ParamSpec(path=c, kind="values", values=())
        if "seed" in cols:
            for i, row in enumerate(csv_rows):
                s = row["seed"]
                if isinstance(s, float) and s.is_integer():
                    row["seed"] = int(s)
                elif not isinstance(row["seed"], int):
                    raise _err("study.csv", f"row {i + 1}: seed must be an integer, got {s!r}")
        _check_nesting([c for c in cols if c != "seed"], "study.csv column ")
    else:
        if not params:
            raise _err("parameters", "no parameters to vary; the design would be empty")
        _check_nesting(list(params), "parameters.")
        if st.design == "full-factorial":
            for p in params.values():
                if p.kind == "bounds" and p.levels is None:
                    raise _err(
                        f"parameters.{p.path}",
                        "bounds need levels = N in a full-factorial design (allowed: {low, "
                        "high, levels = N}, a list or a {start, stop, step} range (not with "
                        "study optimize), or study.design = latin-hypercube / sobol with "
                        "study.n_samples)",
                    )
        _check_design_size(st, params, seeds)
    return params, csv_rows


def _check_nesting(paths: list[str], where: str) -> None:
    """Refuse a path set before a parameter that holds it (``"rve.voxel"`` listed before
    ``"rve"``): the cases set parameters in this order, so each level of the outer table
    replaced the inner value and no case used it (identical cases under different labels)."""
    for i, inner in enumerate(paths):
        for outer in paths[i + 1 :]:
            if _under(inner, outer):
                raise _err(
                    f"{where}{inner}",
                    f"lies inside {outer!r}, which comes after it: each level of {outer!r} "
                    f"would replace it and no case would use it (allowed: {inner!r} after "
                    f"{outer!r}, or only one of them)",
                )


def _check_design_size(st: StudyTable, params: dict[str, ParamSpec], seeds: list[int]) -> None:
    """Refuse a design with more than :data:`MAX_CASES` cases, before expanding it."""
    if st.design == "full-factorial":
        n = math.prod(
            len(p.values) if p.kind == "values" else int(p.levels) for p in params.values()
        )
        what = "full factorial"
    else:
        n, what = int(st.n_samples), st.design
    if n * len(seeds) > MAX_CASES:
        raise _err(
            "parameters",
            f"{what} gives {n * len(seeds):.4g} cases ({len(seeds)} seeds) "
            f"(allowed: at most {MAX_CASES})",
        )


def _levels_to_check(p: ParamSpec) -> list:
    if p.kind == "values":
        return list(p.values)
    ends = [p.low, p.high]
    return [int(round(v)) for v in ends] if p.value_type == "int" else ends


def _under(key: str, path: str) -> bool:
    """True if the spec error key ``key`` is at or below the parameter ``path``."""
    dotted = key.replace("[", ".").replace("]", "")
    return dotted == path or dotted.startswith(path + ".")


def study_key(key: str, paths: Iterable[str]) -> str:
    """How the study file spells the spec key ``key``, with parameters at ``paths``: the
    parameter's own key (``parameters.rve.voxel``; a key inside a table parameter as
    ``rve.voxel in parameters.rve``), else the base's (``base.rve.voxel``): the spelling
    :func:`check_study_specs` gives a refused key (``base.KEY`` where no parameter touches
    it, ``parameters.PATH`` where one does), for the keys a refusal's advice names.

    >>> study_key("rve.voxel", ["rve.voxel"]), study_key("flow.edge_length", ["rve.voxel"])
    ('parameters.rve.voxel', 'base.flow.edge_length')
    >>> study_key("rve.voxel", ["rve"])
    'rve.voxel in parameters.rve'
    """
    for path in paths:
        if _under(key, path):
            return f"parameters.{path}" if _under(path, key) else f"{key} in parameters.{path}"
    for path in paths:
        if _under(path, key):  # one element of a list key swept (image.crop.2)
            return f"parameters.{path}"
    return f"base.{key}"


def _respell(message: str, names: Iterable[str], paths: Iterable[str]) -> str:
    """``message`` with each spec key of ``names`` (:attr:`SpecError.names`, the keys its
    advice names) written as :func:`study_key` spells it."""
    for name in names:
        pattern = rf"(?<![\w.\[]){re.escape(name)}(?![\w.\[])"
        message = re.sub(pattern, lambda _m, n=name: study_key(n, list(paths)), message)
    return message


def check_study_specs(study: Study) -> None:
    """Validate the base spec and every parameter level against the schema, before any work.

    The base is validated with the first level of every parameter applied; then each level of
    each parameter (up to 200 per parameter, the others at their first level). An error in a
    key no parameter touches is reported as ``base.KEY``; a level whose own key is invalid, or
    that alone over a valid base breaks another key (a diameter under 2 of the base's voxels;
    beyond the first levels in a full factorial only, where the point checked is a case), as
    ``parameters.PATH``; the keys the error's advice names (a memory refusal's "a coarser
    rve.voxel") are spelled by the same rule (:func:`study_key`). Errors that only arise from
    combinations are left to the runner's per-case check
    (``psdesign.study.runner.validate_case_specs``), which names the case.
    """
    from psdesign.flow.permeability import check_route_keys
    from psdesign.study.design import apply_params

    first: dict = {}
    for p in study.parameters.values():
        levels = _levels_to_check(p)
        if levels:
            first[p.path] = levels[0]
        elif study.csv_rows:
            first[p.path] = study.csv_rows[0].get(p.path)
    seed = study.seeds[0] if study.seeds else None
    solves_k = any(o.startswith("k_") for o in study.outputs)
    directions = k_directions(study.outputs)

    def check(point: dict) -> tuple[str, str] | None:
        """``(key, "key: message")`` of the spec error at ``point``, the advice's keys
        spelled as the study file does (:func:`_respell`), or None."""
        spec = apply_params(study.base, point, seed)
        if isinstance(spec.get("flow"), dict):
            spec["flow"] = {**spec["flow"], "solver": study.solver}
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", SpecWarning)
                warnings.simplefilter("ignore", ImageWarning)  # the run shows them once
                valid = validate_case_spec(spec, study.outputs)
                check_directions(valid, valid["flow"], directions)  # "auto"'s copies along them
            if solves_k:  # a [flow] choice the study's solver would not apply
                check_route_keys(valid["flow"], study.solver)
        except SpecError as exc:
            return exc.key, f"{exc.key}: {_respell(exc.message, exc.names, study.parameters)}"
        return None

    base_ok: list[bool] = []  # check({}) once, when first needed

    def alone(path: str, v: Any) -> tuple[str, str] | None:
        """The error of level ``v`` of ``path`` over a valid base (the other parameters at their
        base values): a key the level does not touch (``rve.voxel`` against the thinnest
        fiber) is then still this level's."""
        if not base_ok:
            base_ok.append(check({}) is None)
        return check({path: v}) if base_ok[0] else None

    bad = check(first)
    if bad and not any(_under(bad[0], p) or _under(p, bad[0]) for p in study.parameters):
        for path, v in first.items():
            why = alone(path, v)
            if why:
                raise _err(f"parameters.{path}", f"level {short(v)} gives {why[1]}")
        raise _err(f"base.{bad[0]}", bad[1].partition(": ")[2])
    _check_overridden_base_values(study, first, check)
    # in a full factorial the point checked is a case, refused by the runner if not here
    factorial = study.design == "full-factorial"
    for p in study.parameters.values():
        for v in _levels_to_check(p)[:200]:
            bad = check({**first, p.path: v})
            if bad and (_under(bad[0], p.path) or factorial and alone(p.path, v)):
                raise _err(f"parameters.{p.path}", f"level {short(v)} gives {bad[1]}")


def _check_overridden_base_values(study: Study, first: dict, check: Callable) -> None:
    """Raise StudyError for a base value that every case overrides but that is itself invalid.

    No case uses such a value, yet it is what a reader of the file takes for the baseline
    (``base.generator.porosity = 1.85`` beside a porosity sweep is a typo, not a choice), so it
    is held to the schema like any other key: the base is checked with that parameter left
    at its base value and the others at their first level.
    """
    for path in study.parameters:
        if not _lookup(study.base, path.split(".")):
            continue
        bad = check({k: v for k, v in first.items() if k != path})
        if bad and _under(bad[0], path):
            raise _err(f"base.{bad[0]}", bad[1].partition(": ")[2])


def load_study(path: str | Path | dict, case_fn: Callable | str | None = None) -> Study:
    """Read and validate a study TOML file (or a study given as a dict).

    Parameters
    ----------
    path : str, Path or dict
        The study file, or its tables as a dict (what :func:`tomllib.load` returns; relative
        ``base`` / ``csv`` paths then resolve against the current folder).
    case_fn : callable or str, optional
        The case function the study will run with (``run_study``'s): psdesign's own (None)
        has its route's memory planned before any work; another is held to the schema's keys
        and its voxel grid's memory only (:func:`psdesign.schema.budget.unplanned_route`).

    Returns
    -------
    Study

    Raises
    ------
    StudyError
        File missing, too large, not UTF-8, TOML syntax error, not a file name or dict, or any
        invalid key (one line naming it).
    """
    from contextlib import nullcontext

    from psdesign.schema.budget import unplanned_route
    from psdesign.study.casefn import check_case_fn_form, runs_pipeline

    # case_fn=3 was taken as a case function of the user's (no route planned); run_study
    # refuses it by the same rule (RunOptions loads it)
    check_case_fn_form(case_fn)
    with nullcontext() if runs_pipeline(case_fn) else unplanned_route():
        return _load_study(path)


def _load_study(path: str | Path | dict) -> Study:
    if isinstance(path, dict):  # a notebook builds the study in Python, as a spec for build()
        return parse_study(path)
    if not isinstance(path, str | PathLike):  # pathlib's TypeError named no key
        raise _err(
            "study", f"must be a study file name (str or Path) or a dict, got {type(path).__name__}"
        )
    p = Path(path)
    try:
        data = read_toml(path, key="study", error=SpecError)  # a str: TOML text is named
    except SpecError as exc:
        raise _err("study", exc.message) from None
    return parse_study(data, source=p.resolve())
