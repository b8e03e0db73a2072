"""Representative-volume check: grow the RVE at fixed statistics and watch K settle.

The spec's box is scaled to each requested edge length (cubes; the voxel size stays, so the
resolution per fiber is the same; a generator ``n_fibers`` keeps its solid fraction, a porosity
target stays), every size is built with ``seeds`` independent seeds through the study runner,
and each output's mean, std and Student-t 95 % confidence interval are reported per size. The
REV size is the smallest edge from which on every output's relative CI half-width stays below
``tol``. A size whose K CI half-width exceeds
:data:`psdesign.flow.error.UNTRUSTWORTHY_REL_ERROR` (20 %) is ``untrustworthy``, as a single K
with such an error bar is. A permeability's CI lower bound is clipped at 0
(:func:`psdesign.analysis.replicates.replicate_summary`).

Output folder: a study folder (``results.csv``, ``summary.csv``, ``cases/`` ...; no
``report.html``) plus :data:`REV_FILES`; a user's own file of those names is refused before any
work starts, and the marker lists them once written.
"""

from __future__ import annotations

import contextlib
import copy
import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from psdesign.analysis.columns import case_status, first_error, flagged_values
from psdesign.analysis.replicates import ci95_half, replicate_summary
from psdesign.flow.error import UNTRUSTWORTHY_REL_ERROR
from psdesign.schema.budget import MAX_SEEDS  # as for a study file's seeds
from psdesign.schema.flow import SOLVERS

#: What ``rev`` writes in its output folder beside the study's files.
REV_FILES = ("rev.csv", "rev.json")
#: The command ``rev``'s output folder marker names (:mod:`psdesign.io.outputs`).
REV_COMMAND = "rev"
#: The arguments of :func:`rev_study` its refusals name, by the names ``psdesign rev`` gives
#: them (its flags); from Python they are named as the keywords.
REV_FLAGS = {k: f"--{k}" for k in ("sizes", "seeds", "tol", "directions", "solver")}
#: The solvers a REV check runs (``--solver``): every solver (:data:`psdesign.schema.flow.
#: SOLVERS`, not a second list), its default, voxel, first (many sizes and seeds).
REV_SOLVERS = tuple(sorted(SOLVERS, key=lambda s: s != "voxel"))
#: Keywords of the runner that :func:`rev_study` sets itself, and why.
_OWN_RUN_KEYWORDS = {"command": "the folder's marker names the REV check, 'rev'"}


def _no_report_unless_asked(run_kw: dict) -> dict:
    """``run_kw`` with ``report=False`` unless the caller chose (``report`` or ``options``, whose
    ``report`` field then holds): rev writes no report.html (module doc, :func:`rev_folder_files`);
    from Python the runner's default wrote one (session 47)."""
    chose = "report" in run_kw or run_kw.get("options") is not None
    return run_kw if chose else {**run_kw, "report": False}


def rev_folder_files() -> tuple[str, ...]:
    """Every file ``rev`` writes in its output folder: the study's (no ``report.html``: rev
    runs the study without a report) and :data:`REV_FILES`."""
    from psdesign.study.store import STUDY_FILES_NO_REPORT

    return (*STUDY_FILES_NO_REPORT, *REV_FILES)


def check_rev_dir(out_dir: str | Path):
    """Check ``rev``'s output folder before any work (:func:`~psdesign.study.runner.
    check_study_dir` with :func:`rev_folder_files`): a user's own ``rev.csv`` / ``rev.json``
    (or ``results.csv`` ...) there is refused (:class:`psdesign.io.outputs.OutputError`)."""
    from psdesign.study.runner import check_study_dir

    return check_study_dir(
        out_dir, force_option=None, files=rev_folder_files(), command=REV_COMMAND
    )


class RevFailed(RuntimeError):
    """No case of the REV study finished ``ok``: there is nothing to summarize."""


@dataclass
class RevResult:
    """Outcome of :func:`rev_study`.

    Attributes
    ----------
    table : DataFrame
        One row per size: ``size_m``, ``n`` and per output ``X_mean``, ``X_std``,
        ``X_ci95_low``, ``X_ci95_high`` (clipped to the physical range: K >= 0, porosity in
        [0, 1]), ``X_ci95_half`` (the Student half-width), ``X_ci_rel`` (``X_ci95_half`` /
        |mean|), and ``status`` (``"ok"``, or ``"untrustworthy: ..."`` naming
        which values of the size are not ok by their own status (``k_<d>_status``,
        ``porosity_status``) and which K's CI half-width is above 20 %).
    rev_size_m : float or None
        Smallest edge whose (and every larger edge's) relative CI half-width is below ``tol``
        for every output, and whose mean K (and every larger edge's) is within ``tol`` of the
        largest edge's or its 95 % CI overlaps that one's (the largest edge alone only when no
        smaller edge inside the CI ``tol`` was refused on its mean); None when no size reaches
        it.
    tol : float
    outputs : list of str
    still_changes : str
        Why the sizes inside the CI ``tol`` are no REV (the first K mean that still moves with
        the size, from the smallest of them), or ``""``.
    """

    table: pd.DataFrame
    rev_size_m: float | None
    tol: float
    outputs: list[str] = field(default_factory=list)
    still_changes: str = ""


def _check_sizes(spec: dict, rows: list[dict], solver: str, what: str, share=None) -> None:
    """Validate the spec at each size of ``rows`` (:func:`_rows`), with the solver the cases
    run (``--solver``, not the spec's flow.solver), before any work: an edge outside
    ``rve.size``'s range, or a grid beyond that solver's memory budget at the spec's voxel, is
    refused naming ``what`` (``sizes``, ``--sizes``; the study's own check named
    ``parameters`` and a case id); inside ``share``, the workers' (:func:`_workers_share`)."""
    from psdesign.errors import SpecError
    from psdesign.schema.spec import validate_spec

    with share or contextlib.nullcontext():
        for row in rows:
            sized = copy.deepcopy(spec)
            sized["rve"]["size"] = [row[f"rve.size.{i}"] for i in range(3)]
            sized["flow"] = {**sized["flow"], "solver": solver}
            if "generator.n_fibers" in row:
                sized["generator"]["n_fibers"] = row["generator.n_fibers"]
            try:
                validate_spec(sized)
            except SpecError as exc:
                raise SpecError(what, f"at {row['rve.size.0']:g} m, {exc}") from None


def _workers_share(run_kw: dict, n_cases: int):
    """The sizes' checks at one worker's share of the memory, as the run's own check of its
    cases (:func:`psdesign.study.runner.concurrent_cases`): ``--workers 2`` of two 10.5 GiB
    cases was accepted against one process's 11.8 GiB budget until session 54."""
    from psdesign.schema.budget import concurrent_workers
    from psdesign.study.options import RunOptions
    from psdesign.study.runner import concurrent_cases, workers_option

    opts = run_kw.get("options")
    out_option = run_kw.get("out_option", ("out_dir", None))
    well_formed = (
        isinstance(out_option, tuple | list) and out_option and isinstance(out_option[0], str)
    )
    if not (isinstance(opts, RunOptions | None) and well_formed):
        # run_study refuses them with its one line (a TypeError / AttributeError here, s54)
        return contextlib.nullcontext()
    opts = opts or RunOptions()
    workers = run_kw.get("workers", opts.workers)
    scheduler = run_kw.get("scheduler", opts.scheduler)
    option = workers_option(out_option)
    return concurrent_workers(concurrent_cases(workers, scheduler, n_cases), option)


def _rows(spec: dict, sizes: list[float]) -> list[dict]:
    """A study row per cube edge: its size and, for an ``n_fibers`` spec, the count that keeps
    the solid fraction (:func:`~psdesign.packing.generators.n_fibers_at_edges`: as edge^2 for
    the default period, near the same for a given one, by the measured solid per fiber; by the
    volume until session 53, which measured porosity 0.81 / 0.76 / 0.59 at 20 / 30 / 60 um for
    6 fibers of 7 um in 30 um)."""
    from psdesign.packing.generators import n_fibers_at_edges

    rows = [{f"rve.size.{i}": float(edge) for i in range(3)} for edge in sizes]
    if (spec.get("generator") or {}).get("n_fibers") is not None:
        for row, n in zip(rows, n_fibers_at_edges(spec, sizes), strict=True):
            row["generator.n_fibers"] = n
    return rows


def _is_real(v: object) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def _names(option_names: object) -> dict[str, str]:
    """How refusals name the arguments: the keywords, with ``option_names`` (None, or a dict
    from some of :data:`REV_FLAGS`' keys to non-empty texts) over them; else one
    :class:`StudyError` line naming ``option_names`` (``option_names=3`` was Python's
    "'int' object is not iterable" until session 48, and a misspelled key was taken)."""
    from psdesign.errors import StudyError, short

    names = {k: k for k in REV_FLAGS}
    given = {} if option_names is None else option_names
    ok = isinstance(given, dict) and set(given) <= set(REV_FLAGS)
    if not (ok and all(isinstance(v, str) and v.strip() for v in given.values())):
        raise StudyError(
            f"option_names: must be None or a dict from some of {', '.join(REV_FLAGS)} to the "
            f"names refusals use (e.g. psdesign rev's flags --sizes ...), got {short(option_names)}"
        )
    return names | given


def _check_rev_args(sizes, seeds, tol, directions, solver, names: dict[str, str]):
    """``sizes`` as floats, ``seeds`` as an int, ``tol`` as a float, each checked with
    ``directions`` and ``solver`` before any work; else one :class:`StudyError` line naming
    the argument by ``names`` (a ``ValueError``; named ``--sizes`` ... from Python too until
    session 47, and a NumPy array of sizes or ``seeds=np.int64(3)`` were refused with a
    contradiction or raised Python's own errors)."""
    from psdesign.errors import StudyError, short

    n = names
    # each item checked before NumPy sees the whole (``np.ndim`` of ragged sizes such as
    # [[1e-4, 1e-4], [2e-4]] or [1e-4, [2e-4]] raised NumPy's ValueError until session 48)
    ok = isinstance(sizes, list | tuple) or (isinstance(sizes, np.ndarray) and sizes.ndim == 1)
    if not (ok and len(sizes)) or not all(_is_real(s) and 0 < s < math.inf for s in sizes):
        raise StudyError(f"{n['sizes']}: need edge lengths > 0 in metres, got {short(sizes)}")
    sizes = [float(s) for s in sizes]
    if len(set(sizes)) < len(sizes):
        raise StudyError(f"{n['sizes']}: each edge length once, got {short(sizes)}")
    if isinstance(seeds, bool) or not isinstance(seeds, numbers.Integral) or seeds < 2:
        raise StudyError(
            f"{n['seeds']}: need >= 2 seeds for a confidence interval, got {short(seeds)}"
        )
    if seeds > MAX_SEEDS:
        raise StudyError(f"{n['seeds']}: need 2..{MAX_SEEDS} seeds, got {seeds}")
    if not (_is_real(tol) and 0 < tol <= UNTRUSTWORTHY_REL_ERROR):  # also NaN
        # a REV's mean K must itself be trustworthy
        raise StudyError(
            f"{n['tol']}: must be in (0, {UNTRUSTWORTHY_REL_ERROR:g}], got {short(tol)}"
        )
    d = directions
    if not isinstance(d, str) or not d or set(d) - set("xyz") or len(set(d)) < len(d):
        raise StudyError(
            f"{n['directions']}: a subset of xyz, each axis once (e.g. z or xz), got {short(d)}"
        )
    if solver not in REV_SOLVERS:
        raise StudyError(
            f"{n['solver']}: must be one of {', '.join(REV_SOLVERS)}, got {short(solver)}"
        )
    return sizes, int(seeds), float(tol)


def rev_study(
    spec_path: str | Path,
    sizes: list[float],
    seeds: int,
    out_dir: str | Path,
    *,
    solver: str = "voxel",
    directions: str = "xyz",
    tol: float = 0.1,
    option_names: dict[str, str] | None = None,
    **run_kw,
) -> RevResult:
    """Run the REV study; ``run_kw`` go to :func:`psdesign.study.runner.run_study` (not
    ``command``, which the check sets).

    (Nine parameters: the spec, sizes, seeds and folder, then the check's independent knobs,
    the naming and the runner's keywords, keyword-only since session 47.)

    ``option_names``: how refusals name ``sizes``, ``seeds``, ``tol``, ``directions`` and
    ``solver``: by the keywords (None, the default), or ``psdesign rev``'s :data:`REV_FLAGS`.
    Refusals before any work are one :class:`~psdesign.errors.StudyError` line (a
    ``ValueError``), as are a keyword the runner does not take and ``command``.
    """
    from psdesign.schema.spec import load_spec
    from psdesign.study.runner import check_run_keywords, run_study
    from psdesign.study.studyfile import ParamSpec, Study

    names = _names(option_names)
    sizes, seeds, tol = _check_rev_args(sizes, seeds, tol, directions, solver, names)
    extra = "solver, directions, tol, option_names"
    check_run_keywords(run_kw, _OWN_RUN_KEYWORDS, "rev_study", extra)
    spec = load_spec(spec_path)
    check_rev_dir(out_dir)  # a user's rev.csv / rev.json: refused before hours of work
    if "generator" not in spec:
        raise ValueError("generator: the REV check needs a [generator] (random fibers) spec")
    rows = _rows(spec, sorted(sizes))
    _check_sizes(spec, rows, solver, names["sizes"], _workers_share(run_kw, len(rows) * seeds))
    params = {
        k: ParamSpec(path=k, kind="values", values=tuple(r[k] for r in rows)) for k in rows[0]
    }
    outputs = ["porosity", *[f"k_{d}" for d in directions]]
    study = Study(
        name="rev",
        design="csv",
        base=spec,
        parameters=params,
        seeds=list(range(1, seeds + 1)),
        outputs=outputs,
        solver=solver,
        csv_rows=rows,
        # the file's name, not the path as typed: study.json is the same from any cwd or copy;
        # the path is run metadata (run.json's study_file)
        description=f"REV check of {Path(spec_path).name}: sizes {sorted(sizes)} m, {seeds} seeds",
        source=Path(spec_path).resolve(),
    )
    df = run_study(study, out_dir, command=REV_COMMAND, **_no_report_unless_asked(run_kw))
    status = case_status(df)  # a missing one "unknown" (as the exit counts it), not ok
    if not (status == "ok").any():
        raise RevFailed(
            f"rev: no case finished ok ({len(df)} case(s): "
            f"{', '.join(f'{k} {v}' for k, v in status.value_counts().items())})"
            f"{first_error(df)}; see {Path(out_dir) / 'results.csv'}"
        )
    df["size_m"] = df["rve.size.0"]
    table = replicate_summary(df, ["size_m"]).sort_values("size_m").reset_index(drop=True)
    names = ["porosity", *[f"k_{d}_m2" for d in directions]]
    for c in names:
        if f"{c}_mean" in table:  # the Student half-width (the interval itself is clipped)
            table[f"{c}_ci_rel"] = ci95_half(table, c) / table[f"{c}_mean"].abs()
    keep = [
        "size_m",
        "n",
        *[
            f"{c}_{s}"
            for c in names
            for s in ("mean", "std", "ci95_low", "ci95_high", "ci95_half", "ci_rel")
            if f"{c}_{s}" in table
        ],
    ]
    table = table[keep]
    k_cols = [f"{c}_ci_rel" for c in names if c != "porosity" and f"{c}_ci_rel" in table]
    table["status"] = _size_status(df, table, directions)
    rev, still = _rev_size(table, k_cols, tol)
    from psdesign.io.outputs import claim_output_dir
    from psdesign.study.store import atomic_write_bytes, atomic_write_json

    out = Path(out_dir)
    claim_output_dir(check_rev_dir(out), REV_FILES)  # listed in the marker: ours to replace
    atomic_write_bytes(out / "rev.csv", table.to_csv(index=False).encode())
    atomic_write_json(
        out / "rev.json",
        {
            "rev_size_m": rev,
            "tol": tol,
            "still_changes": still or None,
            "outputs": names,
            "table": table.to_dict(orient="records"),
        },
    )
    return RevResult(table, rev, tol, names, still)


def _rev_size(table: pd.DataFrame, k_cols: list[str], tol: float) -> tuple[float | None, str]:
    """``(REV edge or None, why K still changes)`` of the sorted size table: the smallest
    edge from which on every ``k_cols`` CI half-width is within ``tol`` and no mean still moves
    (:func:`_still_changes`); the reason is the smallest such tail's that moves. A tail that
    moves does not end the search: means 12 / 6 / 5.95 / 5.9e-12 m^2 at 20 / 40 / 80 / 160 um
    are settled from 40 um on (until session 53 the 20 um tail's move refused every size).
    The largest size alone is no REV once a longer tail moved: nothing is left to compare."""
    ok = (table[k_cols] <= tol).all(axis=1).to_numpy()
    ks = [c.removesuffix("_ci_rel") for c in k_cols]
    first = ""
    for i in range(len(ok)):
        if not ok[i:].all() or (first and i == len(ok) - 1):
            continue
        still = _still_changes(table.iloc[i:], ks, tol)
        if not still:
            return float(table["size_m"].iloc[i]), ""
        first = first or still
    return None, first


def _still_changes(rows: pd.DataFrame, ks: list[str], tol: float) -> str:
    """Why the sizes of ``rows`` (sorted, each inside the CI ``tol``) are no REV, or ``""``:
    a K's mean at a size differs from the largest size's by more than ``tol`` and their 95 %
    intervals do not overlap, so K still changes with the box (a wall or finite-size bias),
    whatever its scatter. Until session 53 the CI alone named the REV: K = 5e-12 (1 + 30 um /
    L) with 1 % scatter named 20 um, its means 12.4 / 8.7 / 6.8 / 5.9e-12 m^2 (walk-design)."""
    last = rows.iloc[-1]
    for _, row in rows.iloc[:-1].iterrows():
        for c in ks:
            rel = row[f"{c}_mean"] / last[f"{c}_mean"] - 1.0
            apart = row[f"{c}_ci95_low"] > last[f"{c}_ci95_high"] or (
                last[f"{c}_ci95_low"] > row[f"{c}_ci95_high"]
            )
            if abs(rel) > tol and apart:
                return (
                    f"{c} still changes with size: mean {row[f'{c}_mean']:.3e} m^2 at "
                    f"{row['size_m']:.4g} m is {100 * rel:+.3g} % from {last[f'{c}_mean']:.3e} "
                    f"m^2 at {last['size_m']:.4g} m (95 % CIs apart, beyond the {100 * tol:g} % "
                    "tolerance)"
                )
    return ""


def _size_status(df: pd.DataFrame, table: pd.DataFrame, directions) -> list[str]:
    """Per size: ``"ok"``, or ``"untrustworthy: ..."`` naming

    * which values of its ``ok`` cases are not ok by their own status (e.g. ``k_z 2 of 3``,
      ``porosity 1 of 3``: :func:`~psdesign.analysis.columns.flagged_values`, what the exit
      counts; until session 46 a flagged porosity exited 3 with this status ``ok``): those
      values stay in the size's statistics (the REV is about their scatter), this says they
      cannot be trusted one by one;
    * which K's 95 % CI half-width is above :data:`UNTRUSTWORTHY_REL_ERROR` (e.g. ``k_z CI
      above 20 % (n=2)``) or unknown: the size's mean K is then no trustworthy number,
      as a single K with such an error bar is not.
    """
    out = []
    for _, row in table.iterrows():
        size = row["size_m"]
        rows = df[df["size_m"] == size]
        n_ok = int((case_status(rows) == "ok").sum())
        bad = [
            f"{st.removesuffix('_status')} {int(m.sum())} of {n_ok}"
            for st, m in flagged_values(rows).items()
        ]
        for d in directions:
            rel = row.get(f"k_{d}_m2_ci_rel", math.nan)
            if not rel <= UNTRUSTWORTHY_REL_ERROR:  # also NaN: no spread known
                n = int(row.get(f"k_{d}_m2_n", row["n"]))
                bad.append(
                    f"k_{d} CI above {100 * UNTRUSTWORTHY_REL_ERROR:g} % (n={n})"
                    if math.isfinite(rel)
                    else f"k_{d} CI unknown (n={n})"
                )
        out.append("ok" if not bad else "untrustworthy: " + ", ".join(bad))
    return out
