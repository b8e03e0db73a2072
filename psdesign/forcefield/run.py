"""Force-field specs (TOML) -> problem -> optimization -> output folder.

Spec layout (all keys optional except ``case``)::

    [forcefield]
    case = "two-fiber"            # two-fiber | six-fiber
    surface = "area"              # area (default: surface area, continuous fibers) |
                                  # gaussian (the printed term, to reproduce the paper) | bending
    weights = [1e10, 1.0, 1.0]    # w1 (volume), w2 (surface interaction), w3 (surface)
    max_iter = 200                # pattern-search polls
    min_step = 1e-3               # mesh size (fraction of each range) for convergence
    step = 0.25                   # initial mesh size
    workers = 2                   # processes evaluating poll points (same result for any value)

    [forcefield.quadrature]
    h = 0.005                     # volume-interaction grid step (normalized)
    n_s = 64                      # tube quadrature nodes along each fiber
    n_theta = 32                  # ... and around it

    [forcefield.two_fiber]        # see psdesign.forcefield.cases.two_fiber_problem
    isovalue = -8.82
    mu = 4.5
    constant = 0.0
    seed = 5                      # f0 ~ U[1, 2] (seed 5: 1.805); or give f0 = 1.5
    f_range = 1.0
    u_range = 0.2

    [forcefield.six_fiber]        # see six_fiber_problem; initial/ranges default to Table II
    isovalue = -6.65
    t_range = 0.1
    [forcefield.six_fiber.initial]   # optional overrides, e.g. mu1 = 3.9
    [forcefield.six_fiber.ranges]    # optional overrides, e.g. mu1 = 0.2
"""

from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np
from pydantic import ValidationError

from psdesign.errors import SpecError
from psdesign.forcefield.cases import (
    TABLE_II_INITIAL,
    TABLE_II_RANGE,
    ForceFieldProblem,
    six_fiber_problem,
    two_fiber_problem,
)
from psdesign.forcefield.fields import NoFiberError
from psdesign.forcefield.pattern import PatternSearchResult, poll_bars
from psdesign.schema.errors import did_you_mean, spec_error
from psdesign.schema.forcefield import ForceFieldTable, SixFiber, TwoFiber
from psdesign.schema.spec import read_toml

CASES = ("two-fiber", "six-fiber")
#: Default surface term S_j: the surface area (Sec. 6's stated aim, "the fibers have the
#: minimum surface area"). The printed Gaussian-curvature integral is fixed by topology
#: (Gauss-Bonnet) on closed surfaces and pinches the woven fibers at the cube faces.
DEFAULT_SURFACE = "area"
_TOP = set(ForceFieldTable.model_fields)

#: Every file ``psdesign forcefield`` can write into its folder, on any route (the paper cases'
#: search, the relax routes' summary.json and relaxed.toml): what its ``-o`` check expects and
#: what a rerun removes when it did not write it again (``--no-pictures``, another route:
#: walk-cli finding 3, session 52, left the first run's before.png / after.png).
OUTPUT_FILES = (
    "rve.json",
    "history.csv",
    "before.png",
    "after.png",
    "rve_timings.json",
    "summary.json",
    "summary_timings.json",
    "relaxed.toml",
)


#: What the numbers of a paper case's rve.json and history.csv are: the paper's Sec. 6 cases have
#: no physical period, so no SI length exists to write (an RVE spec's relax route writes its
#: lengths in metres, its U in the search's units: :data:`RELAX_UNITS`).
PAPER_UNITS = (
    "dimensionless: the paper's unit cell (lengths and the quadrature step h in periods; U, its "
    "terms and the weights in the paper's normalized units)"
)

#: What the numbers of the relax route's summary.json (and rve.json's ``forcefield``) are: the
#: search runs on the normalized box, so U, its terms and the moves are not SI; its ``*_m``
#: keys are metres. They said nothing until session 49 (``potentials.area`` 1.2566 for two
#: rods of 6 um in a 30 um box: pi D L in periods^2).
RELAX_UNITS = (
    "keys ending in _m in metres; U, its terms (potentials) and the weights in the force "
    "field's normalized units: lengths in periods of rve.period metres (an area in period^2), "
    "the crossing volume as a fraction of the box; variables: shifts in periods, u and f "
    "dimensionless"
)


def _validated(ff: dict) -> ForceFieldTable:
    try:
        return ForceFieldTable.model_validate(ff)
    except ValidationError as exc:
        raise spec_error(exc, ForceFieldTable, "forcefield") from None


def load_forcefield_spec(path: str | Path) -> dict:
    """Read and validate a force-field spec file; returns the ``[forcefield]`` table.

    Every key is validated here by :class:`psdesign.schema.forcefield.ForceFieldTable`
    (before any work); other tables are errors. An RVE spec (with ``[rve]``) is relaxed as
    a fiber set (:mod:`psdesign.forcefield.relax`); its optional ``[forcefield.relax]`` table
    holds the options.
    """
    data = read_toml(path)
    if "rve" in data or "image" in data:  # an RVE spec ([rve] is optional beside [image])
        from psdesign.schema.spec import validate_spec

        ff = data.get("forcefield") or {}
        if not isinstance(ff, dict) or sorted(set(ff) - {"relax"}):
            raise SpecError("forcefield", "in an RVE spec [forcefield] takes only a relax table")
        from psdesign.forcefield.relax import check_relax_route, check_relax_table

        spec = {k: v for k, v in data.items() if k != "forcefield"}
        valid = validate_spec(spec, base=Path(path).parent)  # [image] paths: from its folder
        rve = valid["rve"]
        check_relax_table(ff.get("relax", {}), rve["period"] or max(rve["size"]))
        check_relax_route(valid, ff.get("relax", {}))
        return {"case": "relax", "relax": ff.get("relax", {}), "spec": spec}
    from psdesign.schema.document import STUDY_TABLES

    if set(STUDY_TABLES) & set(data):  # a study file given here ("base: unknown table" before)
        raise SpecError(
            "forcefield",
            "no [forcefield] table: this is a study file ([study] / [parameters] / [base.*] "
            "tables), not a force-field spec; run it with `psdesign study run FILE -o OUT` "
            "(allowed: [forcefield] case = ..., or an RVE spec with [rve] to relax)",
        )
    for key in data:
        if key != "forcefield":
            raise SpecError(
                key, f"unknown table{did_you_mean(key, ['forcefield'])} (allowed: forcefield)"
            )
    ff = data.get("forcefield")
    if not isinstance(ff, dict):
        raise SpecError(
            "forcefield", "missing [forcefield] table (allowed: [forcefield] case = ...)"
        )
    try:
        _validated(ff)
    except RecursionError:
        raise SpecError("forcefield", "nested too deeply") from None
    return ff


def problem_from_spec(ff: dict) -> ForceFieldProblem:
    """Build the optimization problem a force-field table describes (validated here)."""
    v = _validated(ff)
    q = v.quadrature
    common = dict(
        weights=tuple(float(w) for w in v.weights),
        surface=v.surface,
        h=q.h,
        n_s=q.n_s,
        n_theta=q.n_theta,
    )
    where = f"forcefield.{v.case.replace('-', '_')}"
    try:
        if v.case == "two-fiber":
            t = v.two_fiber or TwoFiber()
            return two_fiber_problem(
                isovalue=t.isovalue,
                mu=t.mu,
                constant=t.constant,
                f0=t.f0,
                seed=t.seed,
                f_range=t.f_range,
                u_range=t.u_range,
                **common,
            )
        six = v.six_fiber or SixFiber()
        init = {**TABLE_II_INITIAL, **six.initial}
        rng = {**TABLE_II_RANGE, **six.ranges}
        return six_fiber_problem(
            isovalue=six.isovalue, initial=init, ranges=rng, t_range=six.t_range, **common
        )
    except ValueError as exc:  # infeasible ranges / constraints, bad isovalue
        raise SpecError(where, str(exc)) from None


def run_forcefield(ff: dict, out_dir: str | Path, pictures: bool = True) -> dict:
    """Optimize the spec's problem and write ``out_dir`` (rve.json, history.csv, pictures).

    Returns the summary written to ``rve.json``.
    """
    from psdesign.io.atomic import staged_directory
    from psdesign.io.timings import write_record

    if ff.get("case") == "relax":
        from psdesign.forcefield.relax import relax_spec
        from psdesign.schema.spec import validate_spec

        relax = ff.get("relax", {})
        if not isinstance(relax, dict):
            raise SpecError("forcefield.relax", "must be a table")
        return relax_spec(validate_spec(ff["spec"]), relax, out_dir)
    prob = problem_from_spec(ff)
    v = _validated(ff)
    max_iter, min_step, step, workers = v.max_iter, v.min_step, v.step, v.workers
    t0 = time.perf_counter()
    from psdesign.progress import search_progress

    report = search_progress(f"force field {prob.name}")
    res = prob.solve(
        max_iter=max_iter, step=step, min_step=min_step, workers=workers, callback=report
    )
    wall = time.perf_counter() - t0
    summary = summarize(prob, res, wall)
    summary["workers"] = workers
    with staged_directory(out_dir, replaces=OUTPUT_FILES) as tmp:  # no old before.png left
        write_record(tmp, "rve.json", summary)  # its wall time in rve_timings.json
        write_history(tmp / "history.csv", res)
        if pictures:
            from psdesign.forcefield.render import render_fibers

            before, after = picture_titles(summary)
            render_fibers(prob.fields(prob.x0), tmp / "before.png", before)
            render_fibers(prob.fields(res.x), tmp / "after.png", after)
    return summary


def u_text(u: float, u_error: float, status: str | None) -> str:
    """``U = 0.434199 +- 5.8e-04 [at_bound]``: U with its quadrature bar and its status (none
    for ``status`` None), as ``generate``'s preview title spells a value
    (:func:`psdesign.report.preview.preview_title`).

    >>> u_text(0.4341988, 0.00058, "at_bound"), u_text(0.5, float("inf"), "untrustworthy")
    ('U = 0.434199 +- 5.8e-04 [at_bound]', 'U = 0.5 +- unknown [untrustworthy]')
    """
    bar = f"{u_error:.1e}" if np.isfinite(u_error) else "unknown"
    return f"U = {u:.6g} +- {bar}" + ("" if status is None else f" [{status}]")


#: What after.png calls the end point of a search of each status (:func:`search_status`, or
#: ``untrustworthy`` for an unknown bar); any other status: the ``best point``.
END_POINT = {"converged": "optimum", "at_bound": "constrained optimum"}


def start_status(start: dict) -> str | None:
    """The status of the search's start (``summary["start"]``) in the run's own words, as
    rve.json records it: ``no_fiber`` where a fiber breaks there, ``untrustworthy`` where its
    bar is unknown (the coarser quadrature broke a fiber, :data:`UNKNOWN_BAR`), else None (a
    start is not a search result: its bar is all there is to say).

    >>> start_status({"U": 0.5, "U_error": 1e-3}), start_status({"U": 0.5, "U_error": np.inf})
    (None, 'untrustworthy')
    """
    if "no_fiber" in start:
        return "no_fiber"
    return None if np.isfinite(start["U_error"]) else "untrustworthy"


def picture_titles(summary: dict) -> tuple[str, str]:
    """The titles of before.png and after.png of a run's ``summary`` (:func:`summarize`).

    Each carries U with its bar (:func:`u_text`) and the run's own status words: after.png
    the run's ``status``, the end point the ``optimum`` when ``converged``, the ``constrained
    optimum`` when ``at_bound`` (a trusted stop on the box the spec set), else the ``best
    point`` (:data:`END_POINT`); before.png the start's (:func:`start_status`). Walk-woven s54:
    both titles printed U alone and called every end point the optimum; its first mend called
    an ``at_bound`` stop the best point and the start ``ok`` (the preview's word).

    >>> titles = picture_titles({"case": "six-fiber", "surface_term": "area", "U": 0.4342,
    ...     "U_error": 0.0006, "status": "at_bound", "start": {"U": 0.51, "U_error": 0.001}})
    >>> titles[0]
    'six-fiber: start, U = 0.51 +- 1.0e-03'
    >>> titles[1]
    'six-fiber: constrained optimum (area), U = 0.4342 +- 6.0e-04 [at_bound]'
    """
    start, name, status = summary["start"], summary["case"], summary["status"]
    before = u_text(start["U"], start["U_error"], start_status(start))
    after = u_text(summary["U"], summary["U_error"], status)
    end = END_POINT.get(status, "best point")
    return f"{name}: start, {before}", f"{name}: {end} ({summary['surface_term']}), {after}"


def summarize(prob: ForceFieldProblem, res: PatternSearchResult, wall: float) -> dict:
    """JSON-ready record of an optimization run."""
    fields = prob.fields(res.x)
    # a neighbour where a fiber breaks (U = +inf) bounds the optimum as a box bound does
    on_wall = [prob.param.free[i] for i in res.infeasible]
    on = set(at_bounds(prob.param.free, res.x, prob.lower, prob.upper)) | set(on_wall)
    at_bound = [n for n in prob.param.free if n in on]
    status = search_status(not res.converged, at_bound, False)
    pot = prob.potential(res.x)
    err = prob.potential_error(res.x, fine=pot)  # one coarser evaluation: the quadrature bar
    notes = list(prob.notes)
    if not np.isfinite(err["U"]):  # the coarse quadrature broke a fiber: no bar (it crashed)
        notes.append(UNKNOWN_BAR)
        status = "untrustworthy" if status in ("converged", "at_bound") else status
    out = {
        "case": prob.name,
        "units": PAPER_UNITS,
        "surface_term": prob.surface,
        "weights": prob.weights.tolist(),
        "quadrature": {"h": prob.h, "n_s": prob.n_s, "n_theta": prob.n_theta},
        "free_variables": dict(zip(prob.param.free, map(float, res.x), strict=True)),
        "free_variables_error": poll_bars(prob.param.free, prob.lower, prob.upper, res.poll_step),
        "bounds": {
            n: [float(a), float(b)]
            for n, a, b in zip(prob.param.free, prob.lower, prob.upper, strict=True)
        },
        "parameters": prob.params(res.x),
        "U": res.fun,
        "U_error": err["U"],
        "potentials": pot.to_dict(),
        "potentials_error": err,
        "converged": res.converged and not at_bound,
        "status": status,
        "at_bound": at_bound,
        "at_breaking_wall": on_wall,
        "message": res.message,
        "n_iter": res.n_iter,
        "n_evals": res.n_evals,
        "n_speculative": res.n_speculative,
        "wall_time_s": wall,
        "start": _with_error(prob, prob.x0),
        "notes": notes,
        "fibers": [
            {"index": i + 1, "isovalue": f.isovalue, "ps_model": f.model.to_dict()}
            for i, f in enumerate(fields)
        ],
    }
    if prob.paper is not None:
        xp = prob.free_of(prob.paper)
        inside = bool(np.all((xp >= prob.lower - 1e-12) & (xp <= prob.upper + 1e-12)))
        out["paper_optimum"] = {
            **_with_error(prob, xp),
            "inside_bounds": inside,
            "reported": prob.paper,
        }
    return out


#: The note of a run whose error bar is unknown (mendff2, session 53: it was a traceback).
UNKNOWN_BAR = (
    "U's quadrature bar is unknown (U_error inf, status untrustworthy): the coarser "
    "quadrature of the bar (h doubled, n_s and n_theta halved, fewer sections checked for a "
    "neck) breaks a fiber at the optimum, which lies on the fiber-breaking wall within the "
    "quadrature's resolution"
)


def _with_error(prob: ForceFieldProblem, x) -> dict:
    """Parameters, potentials and U's quadrature bar at ``x`` (one extra, coarser evaluation:
    :meth:`ForceFieldProblem.potential_error`); ``U`` and its bar ``inf`` and the reason in
    ``no_fiber`` where a fiber breaks at ``x`` (e.g. the paper's optimum beyond the wall)."""
    try:
        pot = prob.potential(x)
    except NoFiberError as exc:
        return {"parameters": prob.params(x), "U": np.inf, "U_error": np.inf, "no_fiber": str(exc)}
    return {
        "parameters": prob.params(x),
        **pot.to_dict(),
        "U_error": prob.potential_error(x, fine=pot)["U"],
    }


def search_status(limit_stop: bool, at_bound: list[str], contact_left: bool) -> str:
    """Status of a force-field run: ``not_converged`` when the pattern search stopped on its
    iteration or evaluation limit (its last point is no optimum, whatever bound it touches),
    else ``contact_left`` (an overlap left, whether or not a variable is on its bound: the
    relaxation failed at its job, exit 3; the bound stays listed in ``at_bound``), else
    ``at_bound`` (a constrained stop) or ``converged``.

    Parameters
    ----------
    limit_stop
        The search hit ``max_iter`` or ``max_evals`` before its mesh size fell below
        ``min_step``.
    at_bound
        Free variables on a bound of their box (:func:`at_bounds`).
    contact_left
        The final fibers still overlap (relax routes).

    Returns
    -------
    str
        ``not_converged``, ``at_bound``, ``contact_left`` or ``converged``.
    """
    if limit_stop:
        return "not_converged"
    # the overlap before the bound: a spec's relaxation that stopped on a bound with the
    # fibres still crossing was "at_bound", exit 0 (session 52 walk: 9 contacts before, 9 after)
    if contact_left:
        return "contact_left"
    return "at_bound" if at_bound else "converged"


def at_bounds(names, x, lower, upper, rel: float = 1e-6) -> list[str]:
    """Free variables lying on a bound of their feasible box (within ``rel`` of its width).

    A pattern-search optimum with a variable on its bound is a constrained stop, not a
    stationary point of U: it is reported, not called converged.
    """
    x, lower, upper = (np.asarray(a, float) for a in (x, lower, upper))
    tol = rel * np.maximum(upper - lower, 1e-300)
    on = (x <= lower + tol) | (x >= upper - tol)
    return [str(n) for n, flag in zip(names, on, strict=True) if flag]


#: history.csv's header (``iter,n_evals,U,step`` until session 53, which said no units).
HISTORY_COLUMNS = ("iter", "n_evals", "U_normalized", "step_fraction_of_range")


def write_history(path: str | Path, res: PatternSearchResult) -> None:
    """history.csv: one row per pattern-search iteration (best U so far)."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        # U in the paper's normalized units; the mesh size a fraction of each variable's range
        w.writerow(HISTORY_COLUMNS)
        for h in res.history:
            w.writerow([h["iter"], h["n_evals"], repr(h["fun"]), repr(h["step"])])
