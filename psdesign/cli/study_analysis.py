"""``psdesign study fit | predict | sensitivity``: surrogates and global sensitivity of a study."""

from __future__ import annotations

import argparse
import sys

from psdesign.cli.exit_status import (
    FAILED,
    FOLDER_METAVAR,
    NOT_TRUSTED,
    OK,
    CaseCounts,
    case_masks,
    cases_status,
    fail,
    folder_line,
    status_code,
)
from psdesign.cli.lines import print_json


def int_in(lo: int, hi: int, what: str):
    """An argparse ``type``: an integer in ``[lo, hi]``, else one line naming the range."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{what}: an integer in [{lo}, {hi}], got {text!r}"
            ) from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{what}: an integer in [{lo}, {hi}], got {v}")
        return v

    return parse


def _cmd_fit(args: argparse.Namespace) -> int:
    from psdesign.analysis.prediction import fit_status
    from psdesign.analysis.surrogate import SURROGATE_FILE, fit_study

    skipped: dict[str, str] = {}
    try:
        models = fit_study(args.out, args.outputs or None, skipped)
    except (FileNotFoundError, ValueError) as exc:
        return fail(folder_line(exc))
    for reason in skipped.values():  # "k_z_m2: need at least 3 ..."
        print(f"psdesign: warning: not fitted: {reason}", file=sys.stderr)
    rows = {}
    for name, m in models.items():
        status, warnings = fit_status(m)
        rows[name] = {
            "cv_rmse": m.cv_rmse,
            "cv_rel_error": m.cv_rel_error,
            "cv_level_rel_error": m.cv_level_rel_error,
            "cv_between_rel_error": m.cv_between_rel_error,
            "log_output": m.log_output,
            "n_cases": len(m.y),
            "params": m.params,
            "fixed_params": m.fixed_inputs(),
            "status": status,
            "warnings": warnings,
        }
    for name, r in rows.items():
        for w in filter(None, [*r["warnings"], models[name].sparse_design()]):
            print(f"psdesign: warning: {w}", file=sys.stderr)
    if args.json:
        print_json(rows)
    else:
        for name, r in rows.items():
            space = "log10 " if r["log_output"] else ""
            fixed = r["fixed_params"]
            over = ", ".join(p for p in r["params"] if p not in fixed) or "no varied parameter"
            held = ", ".join(f"{p} = {v:g}" for p, v in fixed.items())
            held = f" ({held} in every case)" if held else ""
            # a grid's design-point error is measured at its levels only; the inner-level one
            # is an upper estimate of the error between them (surrogate.inner_level_error)
            lv = models[name].level_error_text()
            print(
                f"{name}: GP over {over}{held} from {r['n_cases']} cases, "
                f"cross-validated error {100 * r['cv_rel_error']:.3g} % ({space}RMSE "
                f"{r['cv_rmse']:.3g}){lv}  [{r['status']}]"
            )
        print(f"wrote {args.out}/{SURROGATE_FILE}")
    # written either way; 3 when a surrogate is rated untrustworthy (0 until session 45)
    return status_code(*(r["status"] for r in rows.values()))


def _predict_one(
    m, at: str, ints: frozenset[str] = frozenset(), study: dict | None = None
) -> tuple[dict, str]:
    """One surrogate's prediction at ``--at`` with its bar and status (``extrapolated``
    outside the fitted cases, else the fit's status as `study fit` gives it,
    :func:`~psdesign.analysis.prediction.fit_status`, whose reasons are returned too, and
    ``untrustworthy`` also when the point's own bar is too wide,
    :func:`~psdesign.analysis.surrogate.wide_prediction`, with that reason).
    ``std`` is the printed bar: the GP std, never below the fit's hold-out figure for where
    the point is (:func:`~psdesign.analysis.prediction.holdout_bar`: between the design points
    inside the box, the largest hold-out error outside it; the GP std alone held the truth
    within 2 std at 21-42 % of a grid's box, session 43); ``gp_std`` the GP's own.
    ``study``: ``study.json``'s table, whose base spec the point's values are checked in
    (:func:`~psdesign.analysis.surrogate.parse_point`)."""
    from psdesign.analysis.prediction import bar_error, fit_status, holdout_bar, prediction_bar
    from psdesign.analysis.surrogate import outside_range, parse_point, wide_prediction

    x = parse_point(at, m.params, ints, study)
    mean, gp_std = (float(v[0]) for v in m.predict(x[None, :]))
    outside = outside_range(m, x)
    fit, why = fit_status(m)  # the one rule of study fit, sensitivity and the report
    status = "extrapolated" if outside else fit
    if outside:
        wide = ""
    elif fit == "ok":
        wide = wide_prediction(m, mean, gp_std)
    else:  # an untrustworthy fit says why here too (until session 53 only `study fit` did)
        wide = "; ".join(why)
    held, words = bar_error(m, inside=not outside)
    bar = holdout_bar(m, mean, inside=not outside)
    row = {
        "mean": mean,
        "std": float(prediction_bar(m, mean, gp_std, inside=not outside)),
        "gp_std": gp_std,
        "error_from": words if bar > gp_std else "GP std",
        "holdout_rel_error": held,
        "cv_rel_error": m.cv_rel_error,
        "cv_level_rel_error": m.cv_level_rel_error,
        "cv_between_rel_error": m.cv_between_rel_error,
        "status": "untrustworthy" if wide else status,
        "outside": outside,
    }
    return row, wide


def _cmd_predict(args: argparse.Namespace) -> int:
    from psdesign.analysis.columns import study_table
    from psdesign.analysis.surrogate import load_study_surrogates

    try:
        models = load_study_surrogates(args.out)
        study = study_table(args.out)  # its base: each --at value held to the schema
        ints = frozenset(
            p for p, info in study["parameters"].items() if (info or {}).get("type") == "int"
        )
        rows = {name: _predict_one(m, args.at, ints, study) for name, m in models.items()}
    except (FileNotFoundError, ValueError) as exc:
        return fail(folder_line(exc))
    out = {name: row for name, (row, _) in rows.items()}
    wide = [w for _, w in rows.values() if w]
    for w in wide:
        print(f"psdesign: warning: {w}", file=sys.stderr)
    outside = list(dict.fromkeys(o for r in out.values() for o in r["outside"]))
    if outside:
        print(
            f"psdesign: warning: extrapolating beyond the fitted cases ({'; '.join(outside)}); "
            "the predictions are not trustworthy",
            file=sys.stderr,
        )
    untrusted = [n for n, (r, w) in rows.items() if r["status"] == "untrustworthy" and not w]
    if untrusted:
        print(
            f"psdesign: warning: the surrogate of {', '.join(untrusted)} is untrustworthy "
            "(`psdesign study fit` says why)",
            file=sys.stderr,
        )
    if args.json:
        print_json(out)
    else:
        from psdesign.analysis.prediction import bar_text
        from psdesign.status import passes

        for name, r in out.items():
            # an ok one says so too, as study fit's [ok] (its line had no word: session 49);
            # capitals exactly where the exit reads 3 (the one rule, session 52: != "ok")
            w = r["status"]
            flag = f"  [{w}]" if passes(w) else f"  ({w.upper()})"
            print(f"{name} = {r['mean']:.4g} +- {r['std']:.2g} ({bar_text(r)}){flag}")
    # a printed prediction flagged extrapolated / untrustworthy is a result not to trust, as
    # an unconverged solve (exit_status's rule; it exited 0 before session 43)
    return status_code(*(r["status"] for r in out.values()))


def _surrogate_flag(model) -> tuple[str, str]:
    """``(status, "surrogate cross-validated error 3.1 %")`` of a fitted surrogate; an
    untrustworthy one is also said on stderr (its indices describe the fit, not the study)."""
    from psdesign.analysis.prediction import fit_status

    status, _ = fit_status(model)
    if status != "ok":
        print(
            f"psdesign: warning: the surrogate of {model.output} is {status} (`psdesign study "
            "fit` says why): its sensitivity indices are not reliable",
            file=sys.stderr,
        )
    return status, f"surrogate cross-validated error {100 * model.cv_rel_error:.3g} %"


def _cmd_sensitivity(args: argparse.Namespace) -> int:
    from psdesign.analysis.sensitivity import (
        few_levels,
        morris_screening,
        no_indices_reason,
        sobol_indices,
    )
    from psdesign.analysis.surrogate import load_study_surrogates

    try:
        models = load_study_surrogates(args.out)
    except (FileNotFoundError, ValueError) as exc:
        return fail(folder_line(exc))
    names = args.outputs or list(models)
    unknown = [n for n in names if n not in models]
    if unknown:
        return fail(f"--outputs: no surrogate for {unknown[0]!r}; fitted: {', '.join(models)}")
    result = {}
    skipped = []
    for name in names:
        why = no_indices_reason(models[name])
        if why:  # said in our words (SALib's raw warnings on a constant output, before)
            print(f"psdesign: note: {name}: no sensitivity indices: {why}", file=sys.stderr)
            skipped.append(f"{name}: {why}")
            result[name] = []
            continue
        fn = sobol_indices if args.method == "sobol" else morris_screening
        table = fn(models[name], seed=args.seed)
        for p, v in models[name].fixed_inputs().items():
            print(
                f"psdesign: note: {name}: {p} was {v:g} in every fitted case; no index "
                "(the cases say nothing about it)",
                file=sys.stderr,
            )
        status, cv_text = _surrogate_flag(models[name])
        advice = few_levels(models[name])  # a 2 x 2 factorial: what to run, in one line
        for w in filter(None, [advice, models[name].sparse_design()]):
            print(f"psdesign: warning: {w}", file=sys.stderr)
        # each row carries the trust of the surrogate its index was computed from
        trust = {
            "surrogate_status": status,
            "surrogate_cv_rel_error": models[name].cv_rel_error,
            "advice": advice,
        }
        result[name] = [r | trust for r in table.to_dict(orient="records")]
        if not args.json:
            space = "log10 " if models[name].log_output else ""
            print(f"{name} ({args.method}, of {space}{name}; {cv_text}) [{status}]:")
            # 4 significant digits: Morris' mu* and sigma carry the output's unit (a K's are
            # ~1e-12 m^2, which a fixed 3 decimals printed as 0.000)
            print(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    if len(skipped) == len(names):
        return fail(f"no sensitivity indices for any output ({'; '.join(skipped)})")
    if args.json:
        print_json(result)
    # 3 when an index comes from a surrogate rated untrustworthy (0 until session 45)
    return status_code(*(rows[0]["surrogate_status"] for rows in result.values() if rows))


def _cmd_optimize(args: argparse.Namespace) -> int:
    from psdesign.study.address import SchedulerError, check_scheduler_address

    try:  # a typo in the address refused before the seconds of the imports below and dask's
        if args.scheduler is not None:  # checked: its host looked up here, once for the run
            args.scheduler = check_scheduler_address(args.scheduler)
    except (SchedulerError, ValueError) as exc:  # StudyError is a ValueError
        return fail(str(exc))
    from psdesign.analysis.columns import is_design_parameter
    from psdesign.analysis.optimize import optimize_study
    from psdesign.analysis.targets import Target, measured_text, no_closest_case, target_report
    from psdesign.study.runner import WorkersLost, check_workers

    try:
        # the runner's rule, as typed; optimize has --scheduler, no --cluster
        check_workers(args.workers, args.scheduler, "--workers", more="--scheduler")
        targets = [Target.parse(t, "--target") for t in args.target]
        _check_outcome_files(args.out)  # a file of yours under these names: refused first
        res = optimize_study(
            args.study,
            args.out,
            targets,
            budget=args.budget,
            batch=args.batch,
            seed=args.seed,
            workers=args.workers,
            scheduler=args.scheduler,
            case_fn=args.case_fn,
            progress=not args.quiet,
            force=args.force,
            out_option=("-o", "--force"),  # messages name this command's flags
            scheduler_option="--scheduler",
            target_option="--target",
        )
    except (SchedulerError, ValueError) as exc:  # StudyError is a ValueError
        return fail(str(exc))
    except WorkersLost as exc:  # as `study run` (exit 1; finished cases are saved)
        return fail(str(exc), FAILED)
    except KeyboardInterrupt as exc:  # as `study run`: the cases are saved, a rerun resumes
        from psdesign.cli.study import stopped

        return stopped(exc)
    from psdesign.analysis.columns import case_warnings

    targets_out = [target_report(t, res.best) for t in targets]
    case = res.best.get("case_id")
    n_failed, unconverged, flagged = _case_tally(res.results)
    summary = {
        "met": res.met,
        "message": res.message,
        "n_failed_cases": n_failed,  # failed or timed out: exit 1 even when met (session 43)
        "not_converged_cases": unconverged,  # exit 3 even when met, as `study run` (s44)
        "flagged_value_cases": flagged,  # an ok case with a value not ok: exit 3 too (s45)
        "n_points": res.n_points,
        "rounds": res.rounds,
        "targets": targets_out,
        "best": res.best,
        # the chosen case's solver warnings, which were in results.csv only (session 43)
        "warnings": [
            {"case_id": case, "column": k, "warning": v} for k, v in case_warnings(res.best).items()
        ],
        "history": res.history,
    }
    try:
        _write_outcome(args.out, summary)
    except ValueError as exc:  # OutputError: a file of yours appeared under one of the names
        return fail(str(exc))
    except OSError as exc:  # StorageError (disk full, permissions): the cases are saved
        return fail(str(exc), FAILED)
    if args.json:
        print_json(summary)
    else:
        print(f"{'MET' if res.met else 'NOT MET'}: {res.message}{_tally_text(summary)}")
        for r in targets_out:
            print(f"  {r['target']}: {measured_text(r)}")
        params = {k: v for k, v in res.best.items() if is_design_parameter(k)}
        at = ", ".join(f"{k}={v:.4g}" for k, v in params.items()) or "(no case)"
        n = res.best.get("replicates", 0)
        why = no_closest_case(targets_out) or (f"the worst of its {n} seeds" if n > 1 else "")
        print(f"  at {at}" + (f" ({why})" if why else ""))
        for w in summary["warnings"]:  # one line each: what the solve said about this K
            print(f"  warning: case {w['case_id']} ({w['column']}): {w['warning']}")
    # every case it ran by `study run`'s table (a failed case 1, a not_converged one or a
    # flagged value 3, met or not; before session 44 a not_converged case the search did not
    # choose exited 0, before session 45 a flagged value did)
    counts = CaseCounts(n_failed, len(unconverged), len(flagged))
    code = FAILED if res.failed else cases_status(counts, args.allow_not_converged)
    return NOT_TRUSTED if code == OK and not res.met else code


def _case_tally(df) -> tuple[int, list[str], list[str]]:
    """``(failed, not_converged ids, flagged ids)`` of the cases a search ran
    (``results.csv``'s rows): the table ``study run`` decides its exit status by
    (:func:`~psdesign.cli.exit_status.case_masks`), with the ids of the cases that make it 3
    to name them (flagged: an ``ok`` case with a value whose own status is not ``ok``)."""
    if df is None or not len(df):
        return 0, [], []
    failed, nc, flagged = case_masks(df)
    return int(failed.sum()), df.loc[nc, "case_id"].tolist(), df.loc[flagged, "case_id"].tolist()


def _tally_text(summary: dict) -> str:
    """After the MET / NOT MET line: the cases that failed, those that did not converge and
    the ``ok`` ones with a value flagged (its own status not ``ok``).

    >>> _tally_text({"n_failed_cases": 1, "not_converged_cases": ["c0002-ab", "c0005-cd"]})
    ' (1 case(s) failed or timed out; 2 case(s) not_converged: c0002-ab, c0005-cd; see results.csv)'
    >>> _tally_text({"n_failed_cases": 0, "not_converged_cases": [],
    ...              "flagged_value_cases": ["c0003-ef"]})
    ' (1 case(s) with a value not ok: c0003-ef; see results.csv)'
    >>> _tally_text({"n_failed_cases": 0, "not_converged_cases": []})
    ''
    """
    n, nc = summary["n_failed_cases"], summary["not_converged_cases"]
    fl = summary.get("flagged_value_cases", [])
    parts = [f"{n} case(s) failed or timed out"] if n else []
    parts += [f"{len(nc)} case(s) not_converged: {', '.join(nc)}"] if nc else []
    parts += [f"{len(fl)} case(s) with a value not ok: {', '.join(fl)}"] if fl else []
    return f" ({'; '.join(parts)}; see results.csv)" if parts else ""


def _check_outcome_files(out: str) -> None:
    """Refuse (``OutputError``, one line) an output folder where ``optimize.json`` or
    ``report.html`` is a file psdesign did not write, before any case runs: the files
    ``study optimize`` adds to its study folder once the search ends."""
    from psdesign.analysis.optimize import OPTIMIZE_FILE
    from psdesign.study.store import check_study_files

    check_study_files(out, (OPTIMIZE_FILE, "report.html"), "study optimize", option="-o")


def _write_outcome(out: str, summary: dict) -> None:
    """Keep the search's outcome in the folder: ``optimize.json`` (the ``--json`` object:
    met, the best design point, each target's measured value with its bar and status, the
    rounds) and the study's ``report.html`` over every case run (the printed lines alone were
    lost with the terminal, and the folder had no report)."""
    from pathlib import Path

    from psdesign.analysis.optimize import OPTIMIZE_FILE
    from psdesign.io.outputs import claim_output_dir
    from psdesign.report import write_report
    from psdesign.study.store import (
        atomic_write_bytes,
        check_study_files,
        is_timing_column,
        json_text,
    )

    checked = check_study_files(out, [OPTIMIZE_FILE], "study optimize", option="-o")
    claim_output_dir(checked, [OPTIMIZE_FILE])
    # same study and seed -> the same file: the best case's run metadata (when, where, how long)
    # stays in results.csv and the case record, as for every other output
    best = {k: v for k, v in summary["best"].items() if not is_timing_column(k)}
    text = json_text({**summary, "best": best}, indent=1) + "\n"
    atomic_write_bytes(Path(out) / OPTIMIZE_FILE, text.encode("utf-8"))
    if (Path(out) / "results.csv").is_file():  # no case ran: nothing to report
        write_report(out)


def register_study_commands(sub: argparse._SubParsersAction) -> None:
    """Add ``fit``, ``predict`` and ``sensitivity`` to the ``study`` sub-commands."""
    from psdesign.analysis.targets import MAX_BATCH, MAX_BUDGET, MAX_SEED  # light: no numpy
    from psdesign.cli.options import (
        add_allow_not_converged_argument,
        add_force_argument,
        add_workers_argument,
    )

    fit = sub.add_parser("fit", help="fit a Gaussian-process surrogate per output of a study")
    fit.add_argument("out", metavar=FOLDER_METAVAR, help="study output folder")
    fit.add_argument(
        "--outputs",
        nargs="*",
        default=None,
        help="columns to fit (default: porosity, K and the transport values diffusivity_<d>, "
        "tortuosity_<d>, conductivity_<d> the study has)",
    )
    fit.add_argument("--json", action="store_true", help="print one JSON object")
    fit.set_defaults(func=_cmd_fit)

    pred = sub.add_parser("predict", help="predict outputs at a design point from the surrogates")
    pred.add_argument("out", metavar=FOLDER_METAVAR, help="study output folder (after `study fit`)")
    pred.add_argument(
        "--at", required=True, help='e.g. "generator.porosity=0.82,generator.diameter=8e-6"'
    )
    pred.add_argument("--json", action="store_true", help="print one JSON object")
    pred.set_defaults(func=_cmd_predict)

    sens = sub.add_parser(
        "sensitivity", help="Sobol indices or Morris screening from the surrogates"
    )
    sens.add_argument("out", metavar=FOLDER_METAVAR, help="study output folder (after `study fit`)")
    sens.add_argument(
        "--method",
        choices=("sobol", "morris"),
        default="sobol",
        help="Sobol indices or Morris screening (default sobol)",
    )
    sens.add_argument(
        "--outputs",
        nargs="*",
        default=None,
        help="fitted columns to analyse (default: every output `study fit` fitted)",
    )
    sens.add_argument(
        "--seed",
        type=int_in(0, MAX_SEED, "seed"),
        default=0,
        help=f"seed of the sample drawn from the surrogates, 0-{MAX_SEED} (default 0)",
    )
    sens.add_argument("--json", action="store_true", help="print one JSON object")
    sens.set_defaults(func=_cmd_sensitivity)

    opt = sub.add_parser(
        "optimize", help="adaptive sampling toward target outputs (runs cases through the runner)"
    )
    opt.add_argument(
        "study",
        help="study TOML file; every parameter a {low, high} range (with levels = N in a "
        "full-factorial design, the default; the search samples the box itself)",
    )
    opt.add_argument("-o", "--out", required=True, help="output folder (resumed if it exists)")
    opt.add_argument(
        "--target",
        action="append",
        required=True,
        help='"OUTPUT=VALUE[+-P%%]", "OUTPUT>=VALUE" or "OUTPUT<=VALUE" (repeat for more)',
    )
    opt.add_argument(
        "--budget",
        type=int_in(1, MAX_BUDGET, "design points"),
        default=20,
        help=f"maximum design points, 1-{MAX_BUDGET} (default 20)",
    )
    opt.add_argument(
        "--batch",
        type=int_in(1, MAX_BATCH, "points per round"),
        default=1,
        help=f"points per round, 1-{MAX_BATCH} (default 1)",
    )
    opt.add_argument(
        "--seed",
        type=int_in(0, MAX_SEED, "seed"),
        default=0,
        help=f"seed of the search's design points, 0-{MAX_SEED} (default 0)",
    )
    add_workers_argument(opt, scheduler=True)
    opt.add_argument(
        "--scheduler",
        default=None,
        help="Dask scheduler address, or 'local' (default: local process pool)",
    )
    add_allow_not_converged_argument(opt)
    add_force_argument(opt)  # the refusal of a non-empty folder names it, as study run's
    opt.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    opt.add_argument("--json", action="store_true", help="print one JSON object")
    opt.add_argument("--case-fn", default=None, help=argparse.SUPPRESS)
    opt.set_defaults(func=_cmd_optimize)
