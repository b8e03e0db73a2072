"""Inverse design: adaptive sampling toward targets through the resumable study runner.

Round 0 runs a small Latin-hypercube design (``2 d + 2`` points, seeded) over the study's
parameter bounds. Each later round fits a GP surrogate per target output to every finished case
and runs the ``batch`` candidates (from a seeded Sobol set of 2048 points, away from points
already run) with the highest probability of meeting every target under the surrogates
(product over targets of the Gaussian probability, in log10 space for log outputs). The new
points are appended as CSV rows of the same study, so the runner (local pool or Dask) skips
what is done and a stopped optimization resumes. An int parameter is rounded: a candidate
that rounds onto a design point already taken is passed over for the next one (one design
is never run twice), and a box of int parameters whose every point has run ends the search.
It stops when a finished case meets every target by its measured value (every seed of a
design point: :func:`worst_replicates`), or when ``budget`` design points have run, and then
reports the closest case.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdesign.analysis.columns import first_error, trusted
from psdesign.analysis.surrogate import MIN_FIT_CASES, fit_surrogate, from_unit, to_unit
from psdesign.analysis.targets import (
    MAX_BATCH,
    MAX_BUDGET,
    MAX_SEED,
    Target,
    check_targets,
    target_columns,
)

if TYPE_CHECKING:
    import pandas as pd

#: The command an optimization's output folder marker names (it ran ``study run`` before
#: session 43, which the marker said).
OPTIMIZE_COMMAND = "study optimize"
#: The file in the output folder that keeps the search's outcome (the ``--json`` object of
#: ``study optimize``; read back by the report's decision section, :mod:`psdesign.report.outcome`).
OPTIMIZE_FILE = "optimize.json"


@dataclass
class OptimizeResult:
    """Outcome of :func:`optimize_study`.

    Attributes
    ----------
    met : bool
        A finished case meets every target.
    best : dict
        Parameters and outputs of the case closest to the targets (sum of relative misses):
        the worst seed of the best design point (:func:`worst_replicates`), with
        ``replicates``, the number of its trusted cases.
    n_points : int
        Design points run (each once per study seed).
    rounds : int
    history : list of dict
        Per round: points added and the best miss so far.
    message : str
    failed : bool
        The search stopped on its cases' failures (no case, or fewer than ``MIN_FIT_CASES`` to fit,
        finished ok), not on a spent budget: the command's exit status 1, not 3.
    results : DataFrame or None
        The folder's results table after the last round (every case of the search, with its
        ``status``): the command counts its failed cases, as ``study run`` does.
    """

    met: bool
    best: dict
    n_points: int
    rounds: int
    history: list[dict] = field(default_factory=list)
    message: str = ""
    failed: bool = False
    results: pd.DataFrame | None = None


#: What optimize allows of a study's parameters (its refusals' one "allowed" text).
_BOUNDS_ALLOWED = "{low, high}, with levels = N in a full-factorial design"


def _bounds(study) -> dict[str, tuple[float, float, bool]]:
    """The ``(low, high, log)`` box of each parameter; a csv design or a parameter of levels
    is refused, one :class:`~psdesign.errors.StudyError` line naming the study file's key (a
    bare ``ValueError`` until session 47: ``except psdesign.SpecError`` missed it)."""
    from psdesign.errors import StudyError

    if study.design == "csv":  # its columns were refused as parameters.<column>, a key the
        # study file does not have (session 49's review)
        raise StudyError(
            "study.csv: optimize needs {low, high} bounds, not a csv design (allowed: "
            f"[parameters] of {_BOUNDS_ALLOWED})"
        )
    out = {}
    for name, p in study.parameters.items():
        if p.kind != "bounds":
            # the key as the study file and its other refusals spell it, and what a full-
            # factorial design also needs (learnt on a second run until session 49); a range
            # {start, stop, step} gives levels as a list does (it was told "not a list")
            raise StudyError(
                f"parameters.{name}: optimize needs {{low, high}} bounds for every parameter, "
                "not levels (a list or a {start, stop, step} range) (allowed: "
                f"{_BOUNDS_ALLOWED})"
            )
        out[name] = (float(p.low), float(p.high), p.dist == "loguniform")
    return out


def _from_unit(u: np.ndarray, b: list[tuple[float, float, bool]], study) -> np.ndarray:
    """Design points of unit samples ``u``; an int parameter's rounded into its whole numbers
    (:func:`psdesign.study.studyfile.int_range`: 10 was proposed for bounds 10.4-12.2 until
    review s53).

    >>> from types import SimpleNamespace as P
    >>> st = P(parameters={"n": P(value_type="int")})
    >>> _from_unit(np.array([[0.0], [0.01], [0.999]]), [(10.4, 12.2, False)], st).ravel()
    array([11., 11., 12.])
    """
    from psdesign.study.studyfile import int_range

    x = from_unit(u, *zip(*b, strict=True))
    for j, (p, (lo, hi, _)) in enumerate(zip(study.parameters.values(), b, strict=True)):
        if p.value_type == "int":
            x[:, j] = np.clip(np.round(x[:, j]), *int_range(lo, hi))
    return x


def _box_points(study, b: list[tuple[float, float, bool]]) -> float:
    """How many distinct design points the parameter box holds: the product of the int
    parameters' whole numbers (:func:`psdesign.study.studyfile.int_range`, as :func:`_from_unit`
    takes them), ``inf`` when a parameter is a float.

    >>> from types import SimpleNamespace as P
    >>> st = P(parameters={"a": P(value_type="int"), "b": P(value_type="int")})
    >>> _box_points(st, [(10, 11, False), (1, 3, False)])
    6
    """
    from psdesign.study.studyfile import int_range

    n = 1
    for (lo, hi, _), p in zip(b, study.parameters.values(), strict=True):
        if p.value_type != "int":
            return math.inf
        first, last = int_range(lo, hi)
        n *= max(1, last - first + 1)
    return n


def _new_points(x: np.ndarray, order, seen: set, n: int) -> list[list[float]]:
    """Up to ``n`` rows of ``x`` taken in ``order``, each a design point not in ``seen`` (run,
    pending or taken before; ``seen`` is updated): two candidates an int parameter rounds to
    one point are one design, not two runs of the budget.

    >>> seen = {(1.0,)}
    >>> _new_points(np.array([[1.0], [2.0], [2.0], [3.0]]), range(4), seen, 5)
    [[2.0], [3.0]]
    """
    out = []
    for i in order:
        if len(out) >= n:
            break
        key = tuple(float(v) for v in x[i])
        if key not in seen:
            seen.add(key)
            out.append(list(key))
    return out


def _probability(models: dict, targets: list[Target], x: np.ndarray) -> np.ndarray:
    from scipy.stats import norm

    prob = np.ones(len(x))
    for t in targets:
        s = models[t.output]
        m, sd = s.predict_modelled(x)
        sd = np.maximum(sd, 1e-12)
        # a log-modelled output is > 0: a bound at or below 0 is always (>=) or never (<=) met
        tr = (lambda v: math.log10(v) if v > 0 else -math.inf) if s.log_output else (lambda v: v)
        if t.op == ">=":
            prob *= norm.sf(tr(t.value), m, sd)
        elif t.op == "<=":
            prob *= norm.cdf(tr(t.value), m, sd)
        else:
            lo, hi = t.value * (1 - t.tolerance), t.value * (1 + t.tolerance)
            lo, hi = sorted((tr(lo), tr(hi)))
            prob *= norm.cdf(hi, m, sd) - norm.cdf(lo, m, sd)
    return prob


def _score(row: dict, targets: list[Target]) -> float:
    return sum(t.miss(float(row.get(t.output, math.nan))) for t in targets)


def design_points(recs: list[dict], names: list[str]) -> dict[tuple, list[dict]]:
    """The records grouped by design point (their values of ``names``): a point's seeds.

    >>> list(design_points([{"a": 1, "s": 1}, {"a": 2, "s": 1}, {"a": 1, "s": 2}], ["a"]))
    [(1,), (2,)]
    """
    points: dict[tuple, list[dict]] = {}
    for r in recs:
        points.setdefault(tuple(r[n] for n in names), []).append(r)
    return points


def seed_scatter_note(recs: list[dict], names: list[str], best: dict, targets: list[Target]) -> str:
    """Why no design may meet an ``=`` target: the seeds of the closest design point spread
    wider than the target's band (one RVE realization to the next), or ``""``.

    >>> t = [Target("k", "=", 1.0, tolerance=0.05)]
    >>> recs = [{"a": 1, "k": 0.9}, {"a": 1, "k": 1.2}]
    >>> seed_scatter_note(recs, ["a"], recs[1], t)[:60]
    '; its seeds differ by 29 % in k, wider than the target band '
    """
    if not best:
        return ""
    same = design_points(recs, names).get(tuple(best[n] for n in names), [])
    for t in targets:
        values = [
            float(r[t.output]) for r in same if math.isfinite(float(r.get(t.output, math.nan)))
        ]
        if t.op != "=" or len(values) < 2:
            continue
        spread = (max(values) - min(values)) / abs(np.mean(values))
        if spread > 2.0 * t.tolerance:
            return (
                f"; its seeds differ by {100 * spread:.2g} % in {t.output}, wider than the target "
                f"band (+-{100 * t.tolerance:.3g} %): no design meets it for every seed; widen "
                "the tolerance, or a larger rve.size lowers the seed-to-seed scatter"
            )
    return ""


def single_seed_note(best: dict, targets: list[Target]) -> str:
    """Why a met design may still miss on another RVE realization: its point has one trusted
    case (one seed), so the seed-to-seed scatter of its outputs is unknown; ``""`` with two or
    more. In a 40 um cube of the walkthrough (session 43) two seeds of one design differed by
    6-53 % of their mean in K_z, most wider than a +-10 % band.

    >>> t = [Target("k_z_m2", "=", 6e-12, tolerance=0.1)]
    >>> single_seed_note({"seed": 1, "replicates": 1}, t)[:58]
    '; one trusted case (seed 1) at this design point: how much'
    >>> single_seed_note({"seed": 1, "replicates": 2}, t)
    ''
    """
    if not best or best.get("replicates", 0) != 1:
        return ""
    outs = ", ".join(dict.fromkeys(t.output for t in targets))
    return (
        f"; one trusted case (seed {best.get('seed')}) at this design point: how much {outs} "
        "vary from one RVE realization (seed) to the next is unknown; run the point with "
        "more seeds (study.seeds = [1, 2, 3]) before relying on it"
    )


def worst_replicates(recs: list[dict], names: list[str], targets: list[Target]) -> list[dict]:
    """The worst case of each design point: its replicate (seed) farthest from the targets.

    A design meets the targets only if every seed it was run with does: one lucky seed of an
    RVE whose K scatters between seeds is no design. Replicates without a trusted value
    (NaN after :func:`~psdesign.analysis.columns.trusted`) say nothing about the point and
    are passed over while another replicate has one.

    Examples
    --------
    >>> t = [Target("k", "<=", 2.0)]
    >>> recs = [{"a": 1, "k": 1.0}, {"a": 1, "k": 3.0}, {"a": 2, "k": 1.5}, {"a": 2, "k": math.nan}]
    >>> [r["k"] for r in worst_replicates(recs, ["a"], t)]
    [3.0, 1.5]
    >>> eq = [Target("k", "=", 2.0, tolerance=0.1)]  # all met: the farthest from 2
    >>> [r["k"] for r in worst_replicates([{"a": 1, "k": k} for k in (2.1, 1.85, 2.0)], ["a"], eq)]
    [1.85]
    """
    out = []
    for group in design_points(recs, names).values():
        # met seeds all score 0: the one nearest a miss (Target.margin) is the worst, not the
        # last listed (session 53: of 3 met seeds it named the last, 1.972e-11 for a 2e-11
        # target when another seed was farther off)
        scored = [(_score(r, targets), _margin(r, targets), i) for i, r in enumerate(group)]
        finite = [si for si in scored if math.isfinite(si[0])] or scored
        out.append(group[max(finite)[2]] | {"replicates": len(group)})
    return out


def _margin(row: dict, targets: list[Target]) -> float:
    """How near ``row`` is to missing its nearest target: the largest :meth:`Target.margin`
    (a sum let one target met by far hide another about to miss: k 0.05 % from its band's
    edge with porosity 0.9 >= 0.8 ranked safer than k on its value with porosity 0.81)."""
    return max((t.margin(float(row.get(t.output, math.nan))) for t in targets), default=0.0)


def _check_counts(budget: int, batch: int, seed: int) -> tuple[int, int, int]:
    """``budget``, ``batch`` and ``seed`` as ints, else one line naming the keyword and its
    range (``study optimize`` checks its ``--budget`` / ``--batch`` / ``--seed`` as typed:
    only a Python call reaches this, which named the flags until session 47; a NumPy integer
    was refused, ``seed=-1`` was numpy's "expected non-negative integer" and ``seed=True`` or
    ``2**70`` were taken).

    >>> _check_counts(np.int64(3), 1, 0)
    (3, 1, 0)
    >>> _check_counts(20, 1, -1)
    Traceback (most recent call last):
    ...
    psdesign.errors.StudyError: seed: an integer in [0, 4294967294], got -1
    """
    from psdesign.errors import StudyError, short

    checks = (("budget", budget, 1, MAX_BUDGET), ("batch", batch, 1, MAX_BATCH))
    for key, v, lo, hi in (*checks, ("seed", seed, 0, MAX_SEED)):
        if isinstance(v, bool) or not isinstance(v, numbers.Integral) or not lo <= v <= hi:
            raise StudyError(f"{key}: an integer in [{lo}, {hi}], got {short(v)}")
    return int(budget), int(batch), int(seed)


#: Keywords of the runner that the search sets itself, round after round, and why.
_OWN_RUN_KEYWORDS = {
    "report": "each round runs with report=False; write_report(out_dir) after the search",
    "command": "the folder's marker names the search, 'study optimize'",
}


def _sobol_candidates(study, b: list, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """2048 scrambled-Sobol candidates as the design points they run (int parameters
    rounded) and in the unit box."""
    from scipy.stats import qmc

    # a Ctrl-C raised in scipy's Cython set-up of the Sobol direction numbers (its first use
    # in the process: numpy reads them from an .npz) is printed as "Exception ignored" and
    # lost: `study optimize` interrupted at 1.5-4 s ran all its cases and exited 1 (failure
    # audit s36); held, it takes its usual way out once the set-up is done
    from psdesign.study.interrupt import held_signals

    with held_signals():
        sobol = qmc.Sobol(d=len(b), scramble=True, seed=seed + 1)
    cand_x = _from_unit(sobol.random(2048), b, study)
    return cand_x, to_unit(cand_x, *zip(*b, strict=True))


def _check_target_columns(targets: list[Target], ok, df, outputs: list[str], what: str) -> None:
    """After a round with a trusted case: refuse a target whose column the case function wrote
    in no case (a case function of the user's that leaves an output out), one
    :class:`~psdesign.errors.StudyError` line naming ``what`` (the keyword ``targets`` or the
    command's ``--target``) and the columns it did write that a target may name
    (:func:`~psdesign.analysis.targets.target_columns`). Until session 47 this was a
    ``ValueError`` naming ``--target`` from Python too, saying the target "is not an output of
    this study" (it is: :func:`check_targets` passed it) and listing the ``*_m2`` columns and
    the porosity only."""
    from psdesign.errors import StudyError

    if not len(ok):  # no trusted case: the columns of failed cases say nothing
        return
    for t in targets:
        if t.output not in df.columns:
            wrote = [c for c in target_columns(outputs) if c in df.columns]
            raise StudyError(
                f"{what}: {t.output} is an output of this study but the case function wrote no "
                f"{t.output!r} column (the columns it wrote that a target may name: "
                f"{', '.join(wrote) or 'none'})"
            )


def _propose(ok, targets, bounds: dict, points: list, cands: tuple, seen: set, k: int) -> list:
    """Up to ``k`` new design points: the candidates farthest from every run point (> 0.02 in
    the unit box) ranked by the surrogates' probability of meeting every target."""
    names = list(bounds)
    b = [bounds[n] for n in names]
    cand_x, cand_xu = cands
    models = {
        t.output: fit_surrogate(ok, t.output, names, bounds)
        for t in {t.output: t for t in targets}.values()
    }
    done_u = to_unit(np.asarray(points, float), *zip(*b, strict=True))
    dist = np.linalg.norm(cand_xu[:, None, :] - done_u[None, :, :], axis=2)
    far = np.min(dist, axis=1) > 0.02  # also drops a candidate rounded onto a run point
    pool = cand_x[far]
    order = np.argsort(-_probability(models, targets, pool), kind="stable")
    return _new_points(pool, order, seen, k)


def _stop_reason(n_points: int, budget: int, space: float, ok, df, any_ok: bool):
    """Why the search stops with no new point, and whether its cases failed (exit 1) rather
    than the search ending (exit 3)."""
    none_ok = "" if any_ok else f", no case finished ok{first_error(df)}"
    if n_points >= budget:
        return f"budget of {budget} design points spent" + none_ok, not any_ok
    if n_points >= space:  # int parameters only: a small box, all run
        msg = f"every design point of the parameter box has run ({n_points}; its int "
        return msg + "parameters hold no other)" + none_ok, not any_ok
    if len(ok) >= MIN_FIT_CASES:  # every candidate rounds onto a point that has run
        return f"no candidate left that is a new design point ({n_points} run)", False
    msg = f"{len(ok)} of {len(df)} case(s) finished ok, fewer than {MIN_FIT_CASES}; cannot fit"
    return msg + first_error(df), True


def miss_words(n_targets: int) -> tuple[str, str]:
    """The words before and after the closest miss (:meth:`Target.miss`, summed over
    ``n_targets``): the NOT MET line's (:func:`_closest_miss`) and the report's rounds table's
    header (session 51: it said "best miss (relative)").

    >>> miss_words(1)
    ('misses the target band by', 'of the target value')
    """
    if n_targets == 1:
        return "misses the target band by", "of the target value"
    return "misses the target bands by", f"of the target values (summed over {n_targets} targets)"


def _closest_miss(best_miss: float, targets: list[Target]) -> str:
    """How far the closest case is from the targets, for the NOT MET message; with no case
    holding a trusted value of every target's output (all untrustworthy, failed) there is no
    distance: it printed "closest case misses by inf (relative)" (session 43 review). The
    distance (:meth:`Target.miss`, summed over the targets) is to the nearest edge of each
    target's band, over the target value: "misses by" alone read as the distance to the value
    itself until session 51 (0.721 for K 1.077e-11 against 6e-11 +- 10 %, 0.82 from 6e-11).

    >>> t = [Target("k_z_m2", "=", 6e-12, tolerance=0.1)]
    >>> _closest_miss(0.0689, t)
    '; closest case misses the target band by 0.0689 of the target value'
    >>> _closest_miss(math.inf, t)
    '; no case has a trusted value of k_z_m2'
    >>> _closest_miss(0.2, [*t, Target("porosity", ">=", 0.8)])
    '; closest case misses the target bands by 0.2 of the target values (summed over 2 targets)'
    """
    if math.isfinite(best_miss):
        before, after = miss_words(len(targets))
        return f"; closest case {before} {best_miss:.3g} {after}"
    return "; no case has a trusted value of " + " and ".join(
        dict.fromkeys(t.output for t in targets)
    )


def optimize_study(
    study_path: str | Path,
    out_dir: str | Path,
    targets: list[Target],
    budget: int = 20,
    batch: int = 1,
    seed: int = 0,
    *,
    target_option: str = "targets",
    **run_kw,
) -> OptimizeResult:
    """Search the study's parameter box for a design that meets every target.

    Parameters
    ----------
    study_path : str or Path
        A study file whose ``[parameters]`` are all ``{low, high}`` bounds.
    out_dir : str or Path
        Output folder (a normal study folder; rerun to resume).
    targets : list of Target
        At least one (:meth:`Target.parse`); each checked by :meth:`Target.check`.
    budget : int
        Maximum number of design points, in [1, ``MAX_BUDGET``].
    batch : int
        Points per round after the initial design (run in parallel by the runner), in [1,
        ``MAX_BATCH``].
    seed : int
        Seed of the initial design and of the candidate set (same seed -> same path), in
        [0, ``MAX_SEED``].
    target_option : str
        How refusals name the targets: the keyword ``"targets"`` (the default), a command's
        ``"--target"``.
    **run_kw
        Passed to :func:`psdesign.study.runner.run_study` (workers, scheduler, case_fn, ...,
        ``out_option``, ``scheduler_option``; not ``report`` or ``command``, which the search
        sets).

    Raises
    ------
    StudyError
        Before any case or folder, one line naming the keyword (a
        :class:`~psdesign.errors.SpecError`): a count or seed out of its range, a target that
        is not a :class:`Target` or can never be met, a keyword the runner does not take or
        one the search sets, and the runner's refusals of the study and its options
        (:func:`~psdesign.study.runner.run_study`; ``out_dir``'s are an ``OutputError``).
        After the first round, naming ``target_option``: a target whose column the case
        function wrote in no trusted case.
    """
    from scipy.stats import qmc

    from psdesign.study.runner import check_run_keywords, one_share, run_study
    from psdesign.study.studyfile import load_study

    budget, batch, seed = _check_counts(budget, batch, seed)
    # report=True was "got multiple values for keyword argument", an unknown keyword the
    # runner's TypeError naming run_study()
    extra = "budget, batch, seed, target_option"
    check_run_keywords(run_kw, _OWN_RUN_KEYWORDS, "optimize_study", extra)
    study = load_study(study_path, run_kw.get("case_fn"))
    bounds = _bounds(study)
    # names and ranges: before any case or folder
    check_targets(targets, study.outputs, target_option)
    names = list(bounds)
    b = [bounds[n] for n in names]
    n0 = min(budget, 2 * len(names) + 2)
    u0 = qmc.LatinHypercube(d=len(names), seed=seed).random(n0)
    cands = _sobol_candidates(study, b, seed)
    seen: set[tuple] = set()
    points = _new_points(_from_unit(u0, b, study), range(n0), seen, n0)
    # LHS points an int parameter rounded together: topped up by the first new candidates
    points += _new_points(cands[0], range(len(cands[0])), seen, n0 - len(points))
    space = _box_points(study, b)
    history: list[dict] = []
    rounds = 0
    # one memory share and one thread warning for all rounds (each round's run recounted)
    with one_share():
        while True:
            rows = [dict(zip(names, p, strict=True)) for p in points]
            st = dataclasses.replace(study, design="csv", csv_rows=rows, n_samples=None)
            df = run_study(st, out_dir, report=False, command=OPTIMIZE_COMMAND, **run_kw)
            rounds += 1
            ok = trusted(df)  # an untrustworthy K neither wins nor enters the fit
            _check_target_columns(targets, ok, df, study.outputs, target_option)
            recs = worst_replicates(ok.to_dict(orient="records"), names, targets)
            best = min(recs, key=lambda r: _score(r, targets)) if recs else {}
            best_miss = _score(best, targets) if best else math.inf
            history.append({"round": rounds, "n_points": len(points), "best_miss": best_miss})
            n = len(points)
            if best and best_miss == 0.0:
                msg = f"met every target after {n} design points" + single_seed_note(best, targets)
                return OptimizeResult(True, best, n, rounds, history, msg, results=df)
            new: list[list[float]] = []
            if n < min(budget, space) and len(ok) >= MIN_FIT_CASES:
                new = _propose(ok, targets, bounds, points, cands, seen, min(batch, budget - n))
            if not new:
                msg, failed = _stop_reason(n, budget, space, ok, df, bool(recs))
                msg += _closest_miss(best_miss, targets)
                msg += seed_scatter_note(ok.to_dict(orient="records"), names, best, targets)
                return OptimizeResult(False, best, n, rounds, history, msg, failed, df)
            points.extend(new)
