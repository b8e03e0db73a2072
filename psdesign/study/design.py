"""Designs of experiments: expand a :class:`Study` into concrete cases."""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import os
import re
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from psdesign.schema.budget import MAX_CASES
from psdesign.study.studyfile import ParamSpec, Study, StudyError, int_range, round_level

__all__ = [
    "Case",
    "apply_params",
    "case_hash",
    "content_hash",
    "design_points",
    "expand_design",
    "match_finished",
]


@dataclass(frozen=True)
class Case:
    """One case of a study.

    Attributes
    ----------
    case_id : str
        ``c<index:04d>-<8 hex>``; the hex part is a hash of the full case spec, outputs and
        solver (:func:`content_hash`), which changes when anything that affects the result
        changes.  The index part is the position in the design, so the ids depend only on
        the study; a resumed case finished at another position keeps its record under the id
        it ran with (:func:`match_finished`).
    index : int
        Position in the design (rows of the results table are in this order).
    params : dict
        Parameter path -> value for this case.
    seed : int
        Replicate seed (written to ``generator.seed`` when the spec has a generator).
    spec : dict
        The base spec with ``params`` applied.
    """

    case_id: str
    index: int
    params: dict
    seed: int
    spec: dict

    def to_dict(self) -> dict:
        return {
            "case_id": self.case_id,
            "index": self.index,
            "params": self.params,
            "seed": self.seed,
            "spec": self.spec,
        }


def _py(v: Any) -> Any:
    """numpy scalars -> Python scalars (JSON and hashing friendly)."""
    if isinstance(v, np.generic):
        return v.item()
    return v


def apply_params(base: dict, params: dict, seed: int | None = None) -> dict:
    """Return a deep copy of ``base`` with dotted ``params`` set (and ``generator.seed``).

    Missing intermediate tables are created; integer segments index into lists.
    """
    spec = copy.deepcopy(base)
    for path, value in params.items():
        parts = path.split(".")
        node: Any = spec
        for part in parts[:-1]:
            if isinstance(node, list):
                node = node[int(part)]
            else:
                nxt = node.get(part)
                if not isinstance(nxt, dict | list):
                    nxt = {}
                    node[part] = nxt
                node = nxt
        last = parts[-1]
        if isinstance(node, list):
            node[int(last)] = copy.deepcopy(value)
        else:
            node[last] = copy.deepcopy(value)
    if seed is not None and isinstance(spec.get("generator"), dict):
        spec["generator"]["seed"] = int(seed)
    return spec


_DIGESTS: dict[tuple, str] = {}


def file_digest(path: str) -> str | None:
    """``"sha256:<hex>"`` of a file's bytes (cached per path, size and mtime), or None when it
    cannot be read (the spec check names it later). A folder or pattern of TIFF slices: of
    its slices' bytes in slice order (:func:`psdesign.image.slices.slices_digest`)."""
    from psdesign.image.slices import is_slice_path, signature, slices_digest

    try:
        if is_slice_path(path):
            key = (str(path), signature(path))
            if key not in _DIGESTS:
                _DIGESTS[key] = slices_digest(path)
            return _DIGESTS[key]
        st = os.stat(path)
        key = (str(path), st.st_size, st.st_mtime_ns)
        if key not in _DIGESTS:
            with open(path, "rb") as fh:
                _DIGESTS[key] = "sha256:" + hashlib.file_digest(fh, "sha256").hexdigest()
        return _DIGESTS[key]
    except (OSError, ValueError):  # ValueError: slices refused (the spec check names it)
        return None


def _hashed_spec(spec: dict) -> dict:
    """``spec`` as its case hash sees it: an ``[image]`` by its file's content, not its path.

    The study resolves ``image.path`` to an absolute path, so hashing the path made every case
    id (file names, the ``case_id`` column) depend on where the project folder lies (audit
    s35: the same study and image copied to another folder ran under other ids, and a moved
    project re-ran every case); the content also notices an image replaced in place."""
    image = spec.get("image")
    if not isinstance(image, dict) or not isinstance(image.get("path"), str):
        return spec
    digest = file_digest(image["path"])
    if digest is None:
        return spec
    return {**spec, "image": {**image, "path": digest}}


def case_hash(spec: dict, outputs: list[str], solver: str) -> str:
    """8 hex digits identifying a case's full input (an image by its content, not its path)."""
    blob = json.dumps(
        {"spec": _hashed_spec(spec), "outputs": list(outputs), "solver": solver},
        sort_keys=True,
        separators=(",", ":"),
        default=str,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:8]


def _levels(p: ParamSpec) -> list:
    if p.kind == "values":
        return list(p.values)
    n = int(p.levels or 1)
    if n == 1:
        pts = np.array([0.5])
    else:
        pts = np.linspace(0.0, 1.0, n)
    # dict.fromkeys: integer levels can coincide (levels = 5 over 1..3); each runs once
    return list(dict.fromkeys(_map_unit(p, pts, ends=True)))


def _map_unit(p: ParamSpec, u: np.ndarray, ends: bool = False) -> list:
    """Map unit samples ``u`` in [0, 1) onto the parameter's domain (``ends``: ``u`` in
    [0, 1], levels from one end to the other).

    Float levels are rounded as ranges are (:func:`round_level`); float samples are not (a
    sample has no tidier value, and rounding it changed the case id of every case of an older
    latin-hypercube / Sobol folder: review s53).  Integers lie in :func:`int_range` and,
    sampled, each has an equal share of [0, 1) (rounding low + u (high - low) gave the two ends
    half a share each)."""
    u = np.asarray(u, dtype=float)
    if p.kind == "values":
        n = len(p.values)
        idx = np.minimum((u * n).astype(int), n - 1)
        return [p.values[i] for i in idx]
    low, high = p.low, p.high
    if p.value_type == "int":
        low, high = int_range(p.low, p.high)
        if not ends:
            low, high = low - 0.5, high + 0.5
    if p.dist == "loguniform":
        x = np.exp(np.log(low) + u * (np.log(high) - np.log(low)))
    else:
        x = low + u * (high - low)
    if p.value_type == "int":
        lo, hi = int_range(p.low, p.high)
        return [min(max(int(round(v)), lo), hi) for v in x]
    return [round_level(v) for v in x] if ends else [float(v) for v in x]


def point_key(point: dict) -> str:
    """One text per design point (parameter path -> value): two points are the same design
    point exactly when their keys are equal."""
    return json.dumps(point, sort_keys=True, default=str)


def design_points(study: Study) -> list[dict]:
    """The design's parameter points (without seeds), in design order.

    Returns
    -------
    list of dict
        Each dict maps parameter path -> value; for CSV designs a ``"seed"`` key may be present.
    """
    params = list(study.parameters.values())
    if study.design == "full-factorial":
        grids = [_levels(p) for p in params]
        total = math.prod(len(g) for g in grids)
        if total * len(study.seeds) > MAX_CASES:
            raise StudyError(
                f"parameters: full factorial gives {total * len(study.seeds)} cases; "
                f"allowed at most {MAX_CASES}"
            )
        return [
            {p.path: _py(v) for p, v in zip(params, combo, strict=True)}
            for combo in itertools.product(*grids)
        ]
    if study.design in ("latin-hypercube", "sobol"):
        from scipy.stats import qmc

        d = len(params)
        n = int(study.n_samples or 0)
        if study.design == "latin-hypercube":
            sampler = qmc.LatinHypercube(d=d, seed=study.design_seed)
            u = sampler.random(n)
        else:
            from psdesign.study.interrupt import held_signals

            with held_signals():  # a Ctrl-C in scipy's Cython set-up was lost (s36)
                sampler = qmc.Sobol(d=d, scramble=True, seed=study.design_seed)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # balance warning for n != 2^m
                u = sampler.random(n)
        cols = [_map_unit(p, u[:, j]) for j, p in enumerate(params)]
        points = [{p.path: _py(cols[j][i]) for j, p in enumerate(params)} for i in range(n)]
        # samples over list levels (or integers) can coincide: the same case (hash and seed)
        # ran twice (walk-study, session 53); each distinct point runs once
        unique: dict[str, dict] = {}
        for pt in points:
            unique.setdefault(point_key(pt), pt)
        return list(unique.values())
    if study.design == "csv":
        rows = []
        for row in study.csv_rows or []:
            pt = {}
            for k, v in row.items():
                if isinstance(v, float) and math.isnan(v):
                    raise StudyError(f"study.csv: empty cell in column {k!r}")
                pt[k] = _py(v)
            rows.append(pt)
        return rows
    raise StudyError(f"study.design: got {study.design!r}")  # pragma: no cover - validated


def expand_design(study: Study) -> list[Case]:
    """Expand a study into its cases (design points x seeds).

    Parameters
    ----------
    study : Study, str, Path or dict
        A loaded study, or what :func:`~psdesign.study.studyfile.load_study` takes (a study
        file or its tables), as :func:`~psdesign.study.runner.run_study` does.

    Returns
    -------
    list of Case
        In design order: for each design point, one case per seed.  A CSV row with a ``seed``
        column gives exactly one case with that seed.

    Raises
    ------
    StudyError
        If the study is invalid (an int gave an AttributeError), the design empty or too large.
    """
    if not isinstance(study, Study):
        from psdesign.study.studyfile import load_study

        study = load_study(study)
    cases: list[Case] = []
    for pt in design_points(study):
        if "seed" in pt:
            seeds = [int(pt.pop("seed"))]
        else:
            seeds = list(study.seeds)
        for seed in seeds:
            spec = apply_params(study.base, pt, seed)
            h = case_hash(spec, study.outputs, study.solver)
            idx = len(cases)
            cases.append(
                Case(case_id=f"c{idx:04d}-{h}", index=idx, params=dict(pt), seed=seed, spec=spec)
            )
    if not cases:
        raise StudyError("parameters: the design is empty (no cases to run)")
    ids = [c.case_id for c in cases]
    if len(set(ids)) != len(ids):  # pragma: no cover - index prefix makes ids unique
        raise StudyError("parameters: duplicate case ids")
    return cases


_ID = re.compile(r"^c(\d+)-([0-9a-f]{8})$")


def content_hash(case_id: str) -> str | None:
    """The content-hash part of a case id (``c0007-3fa2b91c`` -> ``3fa2b91c``), or None."""
    m = _ID.match(case_id)
    return m.group(2) if m else None


def match_finished(cases: list[Case], finished_ids: Iterable[str]) -> dict[str, str]:
    """The finished record of each case: a record id of the same content, if any.

    A record is stored under the id its case ran with; dropping a seed or a level moves
    later cases, so an identical case (same hash) would otherwise look new and be re-run.
    An exact id match wins; among records of equal hash (duplicate contents) the earliest
    position goes first.  A case's id can never equal another case's record id: that
    record would match it exactly.

    Parameters
    ----------
    cases : list of Case
        The design, from :func:`expand_design`.
    finished_ids : iterable of str
        Ids of the records in the output folder.

    Returns
    -------
    dict
        Case id -> the id of its record (the case's own id or a moved one's), for the cases
        with a finished record; each record is used once.
    """
    finished = set(finished_ids)
    exact = {c.case_id for c in cases} & finished
    spare: dict[str, list[str]] = {}
    for rid in sorted(finished - exact, key=_position):
        if (h := content_hash(rid)) is not None:
            spare.setdefault(h, []).append(rid)
    out = {c: c for c in exact}
    for c in cases:
        pool = [] if c.case_id in exact else spare.get(content_hash(c.case_id) or "", [])
        if pool:
            out[c.case_id] = pool.pop(0)
    return out


def _position(case_id: str) -> tuple[int, str]:
    m = _ID.match(case_id)
    return (int(m.group(1)) if m else -1, case_id)
