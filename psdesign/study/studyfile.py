"""Load and validate study files (TOML).

A study file holds a base RVE spec, a ``[study]`` table (design, seeds, outputs, solver) and a
``[parameters]`` table of dotted spec paths to vary.  Every validation problem raises
:class:`StudyError` with one line naming the offending key and the allowed values.
"""

from __future__ import annotations

import copy
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from psdesign.transport.study_outputs import TRANSPORT_KEYS, TRANSPORT_OUTPUTS  # issue 13

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

DESIGNS = ("full-factorial", "latin-hypercube", "sobol", "csv")
OUTPUTS = ("porosity", "k_x", "k_y", "k_z", "k_tensor") + TRANSPORT_OUTPUTS
SOLVERS = ("fem", "voxel")
STUDY_KEYS = (
    "name",
    "design",
    "csv",
    "n_samples",
    "seeds",
    "replicates",
    "outputs",
    "solver",
    "timeout_s",
    "design_seed",
    "description",
)
RANGE_KEYS = frozenset({"start", "stop", "step"})
BOUNDS_KEYS = frozenset({"low", "high", "dist", "levels", "type"})
DISTS = ("uniform", "loguniform")
VALUE_TYPES = ("float", "int")

#: Spec keys a parameter may set even when the base spec does not hold them (optional keys of
#: the RVE spec, see /work/shared/design.md).  Extend this list when the spec grows.
KNOWN_SPEC_KEYS: set[str] = {
    "rve.size",
    "rve.voxel",
    "rve.period",
    "generator.kind",
    "generator.porosity",
    "generator.n_fibers",
    "generator.diameter",
    "generator.seed",
    "generator.theta",
    "generator.theta.dist",
    "generator.theta.low",
    "generator.theta.high",
    "generator.omega",
    "generator.omega.dist",
    "generator.omega.low",
    "generator.omega.high",
    "generator.u",
    "generator.f",
    "generator.layers",
    "generator.orientation",
    "generator.tx",
    "generator.ty",
    "generator.tz",
    "generator.porosity_tolerance",
    "generator.max_fibers",
    *(
        f"intersections.{k}"
        for k in (
            "method",
            "min_gap",
            "max_rotation_deg",
            "orientation_tries",
            "step",
            "population",
            "generations",
            "objective",
            "ga_voxel",
            "angle_range_deg",
            "shift_range",
            "time_limit_s",
        )
    ),
    *(
        f"flow.{k}"
        for k in (
            "solver",
            "viscosity",
            "aux_length",
            "direction",
            "sides",
            "pressure_drop",
            "tol",
            "edge_length",
            "max_memory_gb",
        )
    ),
}
KNOWN_SPEC_KEYS |= set(TRANSPORT_KEYS)  # issue 13: the [transport] table


class StudyError(ValueError):
    """Invalid study file or study argument (the CLI maps it to exit status 2)."""


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
        """JSON-friendly summary of the study (without the expanded cases)."""
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
            "source": str(self.source) if self.source else None,
        }


# ----------------------------------------------------------------------------- helpers


def _err(key: str, msg: str) -> StudyError:
    return StudyError(f"{key}: {msg}")


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


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
    known = sorted(KNOWN_SPEC_KEYS)
    raise _err(
        key,
        f"unknown parameter path {path!r}: not in the base spec and not a known spec key "
        f"(known: {', '.join(known)})",
    )


def _range_values(key: str, spec: dict) -> tuple:
    missing = RANGE_KEYS - set(spec)
    if missing:
        raise _err(key, f"range needs start, stop and step (missing {', '.join(sorted(missing))})")
    start, stop, step = spec["start"], spec["stop"], spec["step"]
    for name, v in (("start", start), ("stop", stop), ("step", step)):
        if not _is_number(v) or not math.isfinite(v):
            raise _err(f"{key}.{name}", f"must be a finite number, got {v!r}")
    if step == 0 or (stop - start) * step < 0:
        raise _err(f"{key}.step", f"must be non-zero and point from start={start} to stop={stop}")
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    if n > 100_000:
        raise _err(key, f"range has {n} values; allowed at most 100000")
    all_int = all(isinstance(v, int) for v in (start, stop, step))
    vals = [start + i * step for i in range(n)]
    if not all_int:
        vals = [round(float(v), 12) for v in vals]
    return tuple(vals)


def _param_spec(path: str, value: Any, key: str) -> ParamSpec:
    if isinstance(value, list):
        if not value:
            raise _err(key, "empty list of values; give at least one value")
        return ParamSpec(path=path, kind="values", values=tuple(value))
    if isinstance(value, dict):
        keys = set(value)
        if keys and keys <= RANGE_KEYS:
            vals = _range_values(key, value)
            return ParamSpec(path=path, kind="values", values=vals)
        if keys and keys <= BOUNDS_KEYS:
            for name in ("low", "high"):
                if name not in value:
                    raise _err(key, f"bounds need low and high (missing {name})")
                if not _is_number(value[name]) or not math.isfinite(value[name]):
                    raise _err(f"{key}.{name}", f"must be a finite number, got {value[name]!r}")
            low, high = float(value["low"]), float(value["high"])
            if not low < high:
                raise _err(key, f"low must be < high, got low={low}, high={high}")
            dist = value.get("dist", "uniform")
            if dist not in DISTS:
                raise _err(f"{key}.dist", f"got {dist!r}; allowed: {', '.join(DISTS)}")
            if dist == "loguniform" and low <= 0:
                raise _err(f"{key}.low", f"loguniform needs low > 0, got {low}")
            vtype = value.get("type", "float")
            if vtype not in VALUE_TYPES:
                raise _err(f"{key}.type", f"got {vtype!r}; allowed: {', '.join(VALUE_TYPES)}")
            levels = value.get("levels")
            if levels is not None and (
                not isinstance(levels, int) or isinstance(levels, bool) or levels < 1
            ):
                raise _err(f"{key}.levels", f"must be an integer >= 1, got {levels!r}")
            return ParamSpec(
                path=path,
                kind="bounds",
                low=low,
                high=high,
                dist=dist,
                value_type=vtype,
                levels=levels,
            )
    raise _err(
        key,
        "a parameter must be a list of values, a range {start=, stop=, step=} or bounds "
        f"{{low=, high=[, dist=, levels=, type=]}}; got {value!r}",
    )


def _is_param_value(value: Any) -> bool:
    if isinstance(value, list):
        return True
    if isinstance(value, dict):
        keys = set(value)
        scalars = not any(isinstance(v, dict | list) for v in value.values())
        return bool(keys) and scalars and (keys <= RANGE_KEYS or keys <= BOUNDS_KEYS)
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


def _int_list(key: str, v: Any) -> list[int]:
    if not isinstance(v, list) or not v:
        raise _err(key, f"must be a non-empty list of integers, got {v!r}")
    for s in v:
        if not isinstance(s, int) or isinstance(s, bool):
            raise _err(key, f"must be a list of integers, got element {s!r}")
    if len(set(v)) != len(v):
        raise _err(key, f"seeds must be distinct, got {v!r}")
    return list(v)


def _read_csv_rows(path: Path, key: str) -> tuple[list[str], list[dict]]:
    import pandas as pd

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
    if not isinstance(data, dict):
        raise _err("study", "the study file must be a TOML document")
    top_allowed = {"base", "study", "parameters"}
    for k in data:
        if k not in top_allowed:
            raise _err(k, f"unknown top-level key; allowed: {', '.join(sorted(top_allowed))}")
    root = source.parent if source is not None else Path.cwd()

    # --- base spec
    if "base" not in data:
        raise _err("base", 'missing: give an inline [base] table or base = "spec.toml"')
    base_raw = data["base"]
    if isinstance(base_raw, str):
        bpath = (root / base_raw).resolve()
        if not bpath.is_file():
            raise _err("base", f"spec file not found: {bpath}")
        try:
            with open(bpath, "rb") as fh:
                base = tomllib.load(fh)
        except tomllib.TOMLDecodeError as exc:
            raise _err("base", f"cannot parse {bpath}: {exc}") from exc
    elif isinstance(base_raw, dict):
        base = copy.deepcopy(base_raw)
    else:
        raise _err("base", f"must be a table or a path string, got {type(base_raw).__name__}")
    if not base:
        raise _err("base", "the base spec is empty; it needs at least an [rve] table")

    # --- [study]
    st = data.get("study")
    if not isinstance(st, dict):
        raise _err("study", "missing [study] table (name, design, outputs, solver ...)")
    for k in st:
        if k not in STUDY_KEYS:
            raise _err(f"study.{k}", f"unknown key; allowed: {', '.join(STUDY_KEYS)}")
    name = st.get("name", source.stem if source is not None else "study")
    if not isinstance(name, str) or not name.strip():
        raise _err("study.name", f"must be a non-empty string, got {name!r}")
    design = st.get("design", "full-factorial")
    if design not in DESIGNS:
        raise _err("study.design", f"got {design!r}; allowed: {', '.join(DESIGNS)}")

    n_samples = st.get("n_samples")
    if design in ("latin-hypercube", "sobol"):
        if n_samples is None:
            raise _err("study.n_samples", f"required for design {design!r} (integer >= 1)")
    if n_samples is not None and (
        not isinstance(n_samples, int) or isinstance(n_samples, bool) or n_samples < 1
    ):
        raise _err("study.n_samples", f"must be an integer >= 1, got {n_samples!r}")
    if n_samples is not None and n_samples > 1_000_000:
        raise _err("study.n_samples", f"must be <= 1000000, got {n_samples}")

    design_seed = st.get("design_seed", 0)
    if not isinstance(design_seed, int) or isinstance(design_seed, bool) or design_seed < 0:
        raise _err("study.design_seed", f"must be an integer >= 0, got {design_seed!r}")

    if "seeds" in st and "replicates" in st:
        raise _err("study.seeds", "give either seeds = [...] or replicates = N, not both")
    if "seeds" in st:
        seeds = _int_list("study.seeds", st["seeds"])
    else:
        reps = st.get("replicates", 1)
        if not isinstance(reps, int) or isinstance(reps, bool) or reps < 1:
            raise _err("study.replicates", f"must be an integer >= 1, got {reps!r}")
        gen = base.get("generator") if isinstance(base.get("generator"), dict) else {}
        s0 = gen.get("seed", 1)
        if not isinstance(s0, int) or isinstance(s0, bool):
            raise _err("base.generator.seed", f"must be an integer, got {s0!r}")
        seeds = [s0 + i for i in range(reps)]

    outputs = st.get("outputs", ["porosity", "k_z"])
    if isinstance(outputs, str):
        outputs = [outputs]
    if not isinstance(outputs, list) or not outputs:
        raise _err("study.outputs", f"must be a non-empty list among {', '.join(OUTPUTS)}")
    for o in outputs:
        if o not in OUTPUTS:
            raise _err("study.outputs", f"unknown output {o!r}; allowed: {', '.join(OUTPUTS)}")
    outputs = list(dict.fromkeys(outputs))

    flow = base.get("flow") if isinstance(base.get("flow"), dict) else {}
    solver = st.get("solver", flow.get("solver", "fem"))
    if solver not in SOLVERS:
        raise _err("study.solver", f"got {solver!r}; allowed: {', '.join(SOLVERS)}")

    timeout_s = st.get("timeout_s")
    if timeout_s is not None:
        if not _is_number(timeout_s) or not math.isfinite(timeout_s) or timeout_s <= 0:
            raise _err("study.timeout_s", f"must be a number > 0 (seconds), got {timeout_s!r}")
        timeout_s = float(timeout_s)

    description = st.get("description", "")
    if not isinstance(description, str):
        raise _err("study.description", "must be a string")

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
        params[path] = _param_spec(path, value, key)

    csv_rows = None
    if design == "csv":
        if "csv" not in st:
            raise _err("study.csv", "required for design 'csv' (path to a CSV file)")
        if not isinstance(st["csv"], str):
            raise _err("study.csv", f"must be a path string, got {st['csv']!r}")
        cols, csv_rows = _read_csv_rows((root / st["csv"]).resolve(), "study.csv")
        for c in cols:
            if c == "seed":
                continue
            check_spec_path(base, c, f"study.csv column {c!r}")
            if c not in params:
                params[c] = ParamSpec(path=c, kind="values", values=())
        if "seed" in cols:
            for i, row in enumerate(csv_rows):
                s = row["seed"]
                if isinstance(s, float) and s.is_integer():
                    row["seed"] = int(s)
                elif not isinstance(row["seed"], int):
                    raise _err("study.csv", f"row {i + 1}: seed must be an integer, got {s!r}")
    else:
        if "csv" in st:
            raise _err("study.csv", f"only allowed with design = 'csv' (design is {design!r})")
        if not params:
            raise _err("parameters", "no parameters to vary; the design would be empty")
        if design == "full-factorial":
            for p in params.values():
                if p.kind == "bounds" and p.levels is None:
                    raise _err(
                        f"parameters.{p.path}",
                        "bounds need levels = N in a full-factorial design (or give a list/range)",
                    )
    return Study(
        name=name.strip(),
        design=design,
        base=base,
        parameters=params,
        seeds=seeds,
        outputs=outputs,
        solver=solver,
        n_samples=n_samples,
        timeout_s=timeout_s,
        design_seed=design_seed,
        csv_rows=csv_rows,
        source=source,
        description=description,
    )


def load_study(path: str | Path) -> Study:
    """Read and validate a study TOML file.

    Parameters
    ----------
    path : str or Path
        The study file.

    Returns
    -------
    Study

    Raises
    ------
    StudyError
        File missing, TOML syntax error, or any invalid key (one line naming it).
    """
    p = Path(path)
    if not p.is_file():
        raise _err("study", f"file not found: {p}")
    try:
        with open(p, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise _err("study", f"cannot parse {p}: {exc}") from exc
    return parse_study(data, source=p.resolve())
