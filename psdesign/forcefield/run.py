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
import tomllib
from pathlib import Path

import numpy as np

from psdesign.errors import SpecError
from psdesign.forcefield.cases import (
    SIX_NAMES,
    TABLE_II_INITIAL,
    TABLE_II_RANGE,
    ForceFieldProblem,
    six_fiber_problem,
    two_fiber_problem,
)
from psdesign.forcefield.pattern import PatternSearchResult
from psdesign.forcefield.potentials import SURFACE_TERMS

CASES = ("two-fiber", "six-fiber")
#: Default surface term S_j: the surface area (Sec. 6's stated aim, "the fibers have the
#: minimum surface area"). The printed Gaussian-curvature integral is fixed by topology
#: (Gauss-Bonnet) on closed surfaces and pinches the woven fibers at the cube faces.
DEFAULT_SURFACE = "area"
_TOP = {
    "case",
    "surface",
    "weights",
    "max_iter",
    "min_step",
    "step",
    "workers",
    "quadrature",
    "two_fiber",
    "six_fiber",
}


def _num(table: dict, key: str, where: str, default, lo=None, hi=None, integer=False):
    val = table.get(key, default)
    if val is None:
        return None
    ok = isinstance(val, int | float) and not isinstance(val, bool)
    if integer:
        ok = ok and float(val).is_integer()
    if (
        not ok
        or not np.isfinite(val)
        or (lo is not None and val < lo)
        or (hi is not None and val > hi)
    ):
        rng = f" in [{lo}, {hi}]" if lo is not None or hi is not None else ""
        kind = "an integer" if integer else "a number"
        raise SpecError(f"{where}.{key}", f"must be {kind}{rng}, got {val!r}")
    return int(val) if integer else float(val)


def load_forcefield_spec(path: str | Path) -> dict:
    """Read and validate a force-field spec file; returns the ``[forcefield]`` table.

    An RVE spec (with ``[rve]``) is relaxed as a fiber set (:mod:`psdesign.forcefield.relax`);
    its optional ``[forcefield.relax]`` table holds the options.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise SpecError("spec", f"file not found: {path}") from None
    except tomllib.TOMLDecodeError as exc:
        raise SpecError("spec", f"not valid TOML: {exc}") from None
    ff = data.get("forcefield")
    if "rve" in data:  # an RVE spec: relax its fiber set (psdesign.forcefield.relax)
        ff = {} if ff is None else ff
        if not isinstance(ff, dict) or sorted(set(ff) - {"relax"}):
            raise SpecError("forcefield", "in an RVE spec [forcefield] takes only a relax table")
        spec = {k: v for k, v in data.items() if k != "forcefield"}
        return {"case": "relax", "relax": ff.get("relax", {}), "spec": spec}
    if not isinstance(ff, dict):
        raise SpecError("forcefield", "missing [forcefield] table")
    unknown = sorted(set(ff) - _TOP)
    if unknown:
        raise SpecError(f"forcefield.{unknown[0]}", f"unknown key; allowed: {sorted(_TOP)}")
    return ff


def problem_from_spec(ff: dict) -> ForceFieldProblem:
    """Build the optimization problem a validated spec describes."""
    case = ff.get("case")
    if case not in CASES:
        raise SpecError("forcefield.case", f"must be one of {', '.join(CASES)}, got {case!r}")
    surface = ff.get("surface", DEFAULT_SURFACE)
    if surface not in SURFACE_TERMS:
        raise SpecError(
            "forcefield.surface", f"must be one of {', '.join(SURFACE_TERMS)}, got {surface!r}"
        )
    w = ff.get("weights", [1e10, 1.0, 1.0])
    if (
        not isinstance(w, list)
        or len(w) != 3
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in w)
        or not all(np.isfinite(v) and v >= 0 for v in w)
        or not any(v > 0 for v in w)
    ):
        raise SpecError(
            "forcefield.weights", f"must be three finite numbers >= 0, not all zero; got {w!r}"
        )
    q = ff.get("quadrature", {})
    if not isinstance(q, dict):
        raise SpecError("forcefield.quadrature", "must be a table")
    quad = dict(
        h=_num(q, "h", "forcefield.quadrature", 0.005, 1e-4, 0.05),
        n_s=_num(q, "n_s", "forcefield.quadrature", 64, 4, 4096, True),
        n_theta=_num(q, "n_theta", "forcefield.quadrature", 32, 4, 4096, True),
    )
    common = dict(weights=tuple(float(v) for v in w), surface=surface, **quad)
    key = case.replace("-", "_")
    sub = ff.get(key, {})
    if not isinstance(sub, dict):
        raise SpecError(f"forcefield.{key}", "must be a table")
    where = f"forcefield.{key}"
    try:
        if case == "two-fiber":
            allowed = {"isovalue", "mu", "constant", "seed", "f0", "f_range", "u_range"}
            bad = sorted(set(sub) - allowed)
            if bad:
                raise SpecError(f"{where}.{bad[0]}", f"unknown key; allowed: {sorted(allowed)}")
            return two_fiber_problem(
                isovalue=_num(sub, "isovalue", where, -8.82),
                mu=_num(sub, "mu", where, 4.5, 0.0),
                constant=_num(sub, "constant", where, 0.0),
                f0=_num(sub, "f0", where, None, 1e-6),
                seed=_num(sub, "seed", where, 0, 0, integer=True),
                f_range=_num(sub, "f_range", where, 1.0, 0.0),
                u_range=_num(sub, "u_range", where, 0.2, 0.0),
                **common,
            )
        allowed = {"isovalue", "t_range", "initial", "ranges"}
        bad = sorted(set(sub) - allowed)
        if bad:
            raise SpecError(f"{where}.{bad[0]}", f"unknown key; allowed: {sorted(allowed)}")
        init = dict(TABLE_II_INITIAL)
        rng = dict(TABLE_II_RANGE)
        for name, target in (("initial", init), ("ranges", rng)):
            tab = sub.get(name, {})
            if not isinstance(tab, dict):
                raise SpecError(f"{where}.{name}", "must be a table")
            for k in tab:
                if k not in SIX_NAMES:
                    raise SpecError(
                        f"{where}.{name}.{k}", f"unknown parameter; allowed: {list(SIX_NAMES)}"
                    )
                target[k] = _num(tab, k, f"{where}.{name}", None, 0.0 if name == "ranges" else None)
        return six_fiber_problem(
            isovalue=_num(sub, "isovalue", where, -6.65),
            initial=init,
            ranges=rng,
            t_range=_num(sub, "t_range", where, 0.1, 0.0),
            **common,
        )
    except SpecError:
        raise
    except ValueError as exc:  # infeasible ranges / constraints, bad isovalue
        raise SpecError(where, str(exc)) from None


def run_forcefield(ff: dict, out_dir: str | Path, pictures: bool = True) -> dict:
    """Optimize the spec's problem and write ``out_dir`` (rve.json, history.csv, pictures).

    Returns the summary written to ``rve.json``.
    """
    from psdesign.io.atomic import staged_directory, write_json

    if ff.get("case") == "relax":
        from psdesign.forcefield.relax import relax_spec
        from psdesign.schema.spec import validate_spec

        relax = ff.get("relax", {})
        if not isinstance(relax, dict):
            raise SpecError("forcefield.relax", "must be a table")
        return relax_spec(validate_spec(ff["spec"]), relax, out_dir)
    prob = problem_from_spec(ff)
    max_iter = _num(ff, "max_iter", "forcefield", 200, 1, 100000, True)
    min_step = _num(ff, "min_step", "forcefield", 1e-3, 1e-8, 0.1)
    step = _num(ff, "step", "forcefield", 0.25, 1e-6, 0.5)
    if not min_step < step:
        raise SpecError("forcefield.min_step", f"must be below step={step}, got {min_step}")
    workers = _num(ff, "workers", "forcefield", 2, 1, 64, True)
    t0 = time.perf_counter()
    res = prob.solve(max_iter=max_iter, step=step, min_step=min_step, workers=workers)
    wall = time.perf_counter() - t0
    summary = summarize(prob, res, wall)
    summary["workers"] = workers
    with staged_directory(out_dir) as tmp:
        write_json(tmp / "rve.json", summary)
        write_history(tmp / "history.csv", res)
        if pictures:
            from psdesign.forcefield.render import render_fibers

            render_fibers(
                prob.fields(prob.x0),
                tmp / "before.png",
                f"{prob.name}: start, U = {summary['start']['U']:.6g}",
            )
            render_fibers(
                prob.fields(res.x),
                tmp / "after.png",
                f"{prob.name}: optimum ({prob.surface}), U = {res.fun:.6g}",
            )
    return summary


def summarize(prob: ForceFieldProblem, res: PatternSearchResult, wall: float) -> dict:
    """JSON-ready record of an optimization run."""
    fields = prob.fields(res.x)
    at_bound = at_bounds(prob.param.free, res.x, prob.lower, prob.upper)
    if at_bound:
        status = "at_bound"
    else:
        status = "converged" if res.converged else "not_converged"
    out = {
        "case": prob.name,
        "surface_term": prob.surface,
        "weights": prob.weights.tolist(),
        "quadrature": {"h": prob.h, "n_s": prob.n_s, "n_theta": prob.n_theta},
        "free_variables": dict(zip(prob.param.free, map(float, res.x), strict=True)),
        "bounds": {
            n: [float(a), float(b)]
            for n, a, b in zip(prob.param.free, prob.lower, prob.upper, strict=True)
        },
        "parameters": prob.params(res.x),
        "U": res.fun,
        "potentials": prob.potential(res.x).to_dict(),
        "converged": res.converged and not at_bound,
        "status": status,
        "at_bound": at_bound,
        "message": res.message,
        "n_iter": res.n_iter,
        "n_evals": res.n_evals,
        "n_speculative": res.n_speculative,
        "wall_time_s": wall,
        "start": {"parameters": prob.params(prob.x0), **prob.potential(prob.x0).to_dict()},
        "notes": prob.notes,
        "fibers": [
            {"index": i + 1, "isovalue": f.isovalue, "ps_model": f.model.to_dict()}
            for i, f in enumerate(fields)
        ],
    }
    if prob.paper is not None:
        xp = prob.free_of(prob.paper)
        inside = bool(np.all((xp >= prob.lower - 1e-12) & (xp <= prob.upper + 1e-12)))
        pot = prob.potential(xp)
        out["paper_optimum"] = {
            "parameters": prob.params(xp),
            **pot.to_dict(),
            "inside_bounds": inside,
            "reported": prob.paper,
        }
    return out


def at_bounds(names, x, lower, upper, rel: float = 1e-6) -> list[str]:
    """Free variables lying on a bound of their feasible box (within ``rel`` of its width).

    A pattern-search optimum with a variable on its bound is a constrained stop, not a
    stationary point of U: it is reported, not called converged.
    """
    x, lower, upper = (np.asarray(a, float) for a in (x, lower, upper))
    tol = rel * np.maximum(upper - lower, 1e-300)
    on = (x <= lower + tol) | (x >= upper - tol)
    return [str(n) for n, flag in zip(names, on, strict=True) if flag]


def write_history(path: str | Path, res: PatternSearchResult) -> None:
    """history.csv: one row per pattern-search iteration (best U so far)."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["iter", "n_evals", "U", "step"])
        for h in res.history:
            w.writerow([h["iter"], h["n_evals"], repr(h["fun"]), repr(h["step"])])
