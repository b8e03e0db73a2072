"""``psdesign rev SPEC --sizes ... --seeds N -o OUT``: is the RVE a representative volume?"""

from __future__ import annotations

import argparse
import math
import re
import sys

from psdesign.cli.exit_status import (
    FAILED,
    NOT_TRUSTED,
    OK,
    case_counts,
    case_masks,
    cases_status,
    fail,
)
from psdesign.cli.lines import print_json


def _cmd_rev(args: argparse.Namespace) -> int:
    from psdesign.analysis.rev import REV_FLAGS, RevFailed, check_rev_dir, rev_study
    from psdesign.study.runner import check_workers

    # rev has no --force: the refusal names none; a user's rev.csv / rev.json is refused now
    check_rev_dir(args.out)
    try:
        # the runner's rule, named as typed; rev has no way to more workers to advise
        check_workers(args.workers, what="--workers", more="")
        res = rev_study(
            args.spec,
            args.sizes,
            args.seeds,
            args.out,
            solver=args.solver,
            directions=args.directions,
            tol=args.tol,
            workers=args.workers,
            progress=not args.quiet,
            report=False,
            out_option=("-o", None),  # messages name this command's flags: it has no --force
            option_names=REV_FLAGS,
        )
    except ValueError as exc:
        return fail(str(exc))
    except RevFailed as exc:
        return fail(" ".join(str(exc).split()), FAILED)
    if args.json:  # strict JSON: a size with one trusted value has no CI (null, not NaN)
        print_json(
            {
                "rev_size_m": res.rev_size_m,
                "tol": res.tol,
                "still_changes": res.still_changes or None,
                "table": res.table.to_dict(orient="records"),
            }
        )
        return _rev_status(args.out, res.rev_size_m, res.outputs)
    for _, row in res.table.iterrows():
        parts = [f"{row['size_m']:.4g} m (n={int(row['n'])})"]
        for c in res.outputs:
            if f"{c}_mean" in row and c != "porosity":
                rel = row[f"{c}_ci_rel"]  # NaN for one value: no interval ("+- nan %" before)
                bar = "+- n/a (one value)" if math.isnan(rel) else f"+- {100 * rel:.1f} %"
                parts.append(f"{c} {row[f'{c}_mean']:.3e} {bar}")
        parts.append(str(row.get("status", "ok")))
        print("  ".join(parts))
    if res.still_changes:
        print(f"no REV: {res.still_changes}: grow the RVE")
    elif res.rev_size_m is None:
        print(f"no size reached a 95 % CI half-width below {100 * res.tol:g} %: grow the RVE")
    else:
        print(f"REV: {res.rev_size_m:.4g} m (95 % CI half-width below {100 * res.tol:g} %)")
    return _rev_status(args.out, res.rev_size_m, res.outputs)


def _rev_status(out: str, rev_size_m: float | None, outputs: list[str]) -> int:
    """The cases' exit status (:func:`_cases_status`), and ``NOT_TRUSTED`` (3) when every case
    finished but no size reached the ``--tol`` CI: the answer the command was asked for is
    "not representative", a missed target as ``study optimize``'s (exit 3). Until session 43
    it exited 0, so ``psdesign rev ... && echo representative`` passed an RVE whose K
    scattered 35 % between seeds. ``outputs``: the values the sizes' intervals hold
    (:attr:`psdesign.analysis.rev.RevResult.outputs`)."""
    status = _cases_status(out, outputs)
    return NOT_TRUSTED if status == OK and rev_size_m is None else status


def _cases_status(out: str, outputs: list[str]) -> int:
    """The exit status of the table in :mod:`psdesign.cli.exit_status`, as ``study run`` gives
    it: 1 when a case failed or timed out, else 3 when one did not converge or an ``ok`` case
    has a value flagged (``k_<d>_status``, ``porosity_status``; it exited 0 with a warning until
    session 45), else 0; one stderr line per kind naming ``results.csv``, the flagged one
    ``study run``'s (:func:`~psdesign.analysis.columns.flagged_text`) and which of the flagged
    values the sizes' intervals hold (``outputs``: the porosity and K; Omega and any other
    rated value of the cases are in ``results.csv`` only)."""
    from psdesign.analysis.columns import first_error, flagged_text, flagged_values, status_column
    from psdesign.study.readback import read_results

    df = read_results(out)
    counts = case_counts(df)
    if counts.failed:
        bad = df[case_masks(df)[0]]
        print(
            f"psdesign: {counts.failed} case(s) failed or timed out{first_error(bad)}; "
            f"left out of the sizes' rows; see {out}/results.csv (tracebacks: "
            "cases/<id>/error.txt)",
            file=sys.stderr,
        )
    if counts.not_converged:
        print(
            f"psdesign: {counts.not_converged} case(s) not_converged (a solve did not converge "
            f"or was flagged; the error column of {out}/results.csv says which); left out of "
            "the sizes' rows",
            file=sys.stderr,
        )
    if counts.flagged:  # study run's sentence: a flagged porosity was "a K flagged" (s46)
        held = {status_column(c): c.removesuffix("_m2") for c in outputs}
        kept = ", ".join(dict.fromkeys(held[st] for st in flagged_values(df) if st in held))
        print(
            f"psdesign: {flagged_text(df)}; their values are kept in {out}/results.csv"
            + (f", {kept} also in the sizes' intervals" if kept else ""),
            file=sys.stderr,
        )
    return cases_status(counts)


def register(sub: argparse._SubParsersAction) -> None:
    """Register ``rev``."""
    from psdesign.cli.options import add_workers_argument

    p = sub.add_parser("rev", help="grow the RVE at fixed statistics: K with 95 %% CI vs size")
    # argparse takes "-30e-6" for an option (its negative-number pattern has no exponent), so
    # `--sizes -30e-6` ended in "expected at least one argument" instead of the range message
    p._negative_number_matcher = re.compile(r"^-\d*\.?\d+(?:[eE][-+]?\d+)?$")
    p.add_argument("spec", help="RVE spec with a [generator] table")
    p.add_argument("--sizes", type=float, nargs="+", required=True, help="cube edges in metres")
    p.add_argument("--seeds", type=int, default=3, help="seeds per size (2-1000, default 3)")
    p.add_argument("-o", "--out", required=True, help="output folder (a study folder; resumes)")
    p.add_argument(
        "--solver",
        # analysis.rev.REV_SOLVERS, written out: --help imports no pydantic nor pandas
        # (tests/unit/test_rev.py checks the two agree)
        choices=("voxel", "fem"),
        default="voxel",
        help="solver of every case (default voxel, whatever the spec's flow.solver: many sizes "
        "and seeds; fem for the body-fitted check)",
    )
    p.add_argument(
        "--directions", default="xyz", help="subset of xyz, each axis once (default xyz)"
    )
    p.add_argument(
        "--tol",
        type=float,
        default=0.1,
        help="relative 95 %% CI half-width of K that makes a size the REV, in (0, 0.2], and "
        "how far its mean K may be from the largest size's (unless their CIs overlap) "
        "(default 0.1; above 0.2 a K is untrustworthy)",
    )
    add_workers_argument(p, scheduler=False)
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_rev)
