"""argparse glue for ``psdesign study run`` and ``psdesign study report``.

The main CLI registers these with::

    from psdesign.cli.study import register
    register(subparsers)      # subparsers of the top-level parser
    ...
    args = parser.parse_args(argv)
    return args.func(args)   # exit status (psdesign.cli.exit_status): 0 ok, 1 failed /
                             # timeout cases or storage error, 2 bad input (also a refused
                             # -o), 3 not_converged cases or flagged values (``study
                             # report``: any case not ok, failed too, or a case of
                             # study.json not run), 130 Ctrl-C
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from psdesign.cli.exit_status import (
    BAD_INPUT,
    FAILED,
    FOLDER_METAVAR,
    INTERRUPTED,
    NOT_TRUSTED,
    OK,
    TERMINATED,
    case_counts,
    cases_status,
    fail,
    folder_line,
)
from psdesign.cli.options import (
    add_allow_not_converged_argument,
    add_force_argument,
    add_workers_argument,
)

if TYPE_CHECKING:
    from psdesign.report import ReportAlert

__all__ = ["cmd_study_report", "cmd_study_run", "main"]


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {v}")
    return v


def _timeout_seconds(text: str) -> float:
    """``--timeout``: seconds in (0, MAX_TIMEOUT_S], the range of ``study.timeout_s``."""
    from psdesign.schema.budget import MAX_TIMEOUT_S

    what = f"expected seconds > 0 and <= {MAX_TIMEOUT_S:.0f} (as study.timeout_s), got"
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} {text!r}") from None
    if not 0 < v <= MAX_TIMEOUT_S:  # also NaN and inf
        raise argparse.ArgumentTypeError(f"{what} {v}")
    return v


def register(subparsers) -> argparse.ArgumentParser:
    """Add ``study run`` / ``study report`` to an argparse sub-parser collection.

    Each leaf parser sets ``func`` to a handler ``handler(args) -> int``.

    Returns
    -------
    argparse.ArgumentParser
        The ``study`` parser.
    """
    study = subparsers.add_parser("study", help="run parameter studies and report on them")
    sub = study.add_subparsers(dest="study_command", required=True)

    run = sub.add_parser("run", help="run (or resume) a study file")
    run.add_argument("study", help="study TOML file")
    run.add_argument("-o", "--out", required=True, help="output folder (resumed if it exists)")
    add_workers_argument(run, scheduler=True, cluster=True)
    run.add_argument(
        "--scheduler",
        default=None,
        help="Dask scheduler address tls://HOST:PORT or tcp://HOST:PORT (unencrypted: a "
        "warning unless on this machine), or 'local' for a local Dask cluster "
        "(default: local process pool)",
    )
    run.add_argument(
        "--cluster",
        choices=("slurm", "pbs"),
        default=None,
        help="submit one batch job per worker (dask-jobqueue; see docs/study-files.md)",
    )
    # the --cluster-* defaults are ClusterOptions'; None here tells "not given" (refused
    # without --cluster, which alone uses them)
    run.add_argument(
        "--cluster-cores",
        type=_positive_int,
        default=None,
        help="cores per job, all for one case at a time (default 2)",
    )
    run.add_argument("--cluster-memory", default=None, help="memory per job (default 8GB)")
    run.add_argument("--cluster-walltime", default=None, help="HH:MM:SS per job (default 01:00:00)")
    run.add_argument("--cluster-queue", default=None, help="partition / queue")
    run.add_argument("--cluster-account", default=None, help="project account")
    run.add_argument(
        "--cluster-wait",
        default=None,
        help="seconds a --cluster or --scheduler run waits for a worker (the first batch job "
        "to connect, or any worker once all have left) before stopping (default 600; a "
        "refused submission stops at once)",
    )
    run.add_argument("--tls-ca-file", default=None, help="CA certificate for a tls:// scheduler")
    run.add_argument("--tls-cert", default=None, help="client certificate for a tls:// scheduler")
    run.add_argument("--tls-key", default=None, help="client private key for a tls:// scheduler")
    run.add_argument(
        "--timeout",
        type=_timeout_seconds,
        default=None,
        help="per-case time limit in seconds (default: the study's study.timeout_s, else none)",
    )
    run.add_argument(
        "--retry-failed", action="store_true", help="re-run cases recorded as failed or timeout"
    )
    run.add_argument(
        "--retry-not-converged",
        action="store_true",
        help="re-run cases recorded as not_converged (otherwise they count as finished)",
    )
    add_allow_not_converged_argument(run)
    add_force_argument(run)
    run.add_argument(
        "--no-report",
        action="store_true",
        help="do not write report.html (an earlier run's is removed: `study report` writes it)",
    )
    run.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    run.add_argument("--case-fn", default=None, help=argparse.SUPPRESS)  # module:function
    run.set_defaults(func=cmd_study_run)

    rep = sub.add_parser("report", help="write OUT/report.html from a study output folder")
    rep.add_argument("out", metavar=FOLDER_METAVAR, help="study output folder")
    rep.set_defaults(func=cmd_study_report)

    from psdesign.cli.study_analysis import register_study_commands

    register_study_commands(sub)
    return study


def _cluster(args: argparse.Namespace, wait_s: float | None):
    """The :class:`~psdesign.study.cluster.ClusterOptions` of ``--cluster``, or None
    (``wait_s``: ``--cluster-wait``, checked by :func:`_cluster_wait`)."""
    from psdesign.study.studyfile import StudyError

    resources = {
        "cores": args.cluster_cores,
        "memory": args.cluster_memory,
        "walltime": args.cluster_walltime,
        "queue": args.cluster_queue,
        "account": args.cluster_account,
    }
    given = {k: v for k, v in resources.items() if v is not None}
    if not args.cluster:
        if given:  # they were ignored: the cases ran on this machine
            flag = f"--cluster-{next(iter(given))}"
            raise StudyError(f"{flag}: only with --cluster slurm|pbs; add --cluster or drop {flag}")
        return None
    if args.scheduler:
        raise StudyError("--cluster: give either --cluster or --scheduler, not both")
    from psdesign.study.cluster import ClusterOptions, cluster_flag

    try:
        return ClusterOptions(
            args.cluster, **given, **({} if wait_s is None else {"wait_s": wait_s})
        )
    except StudyError as exc:  # it names its field: spelled as the flag typed
        raise StudyError(f"{cluster_flag(exc.key)}: {exc.message}") from None


def _cluster_wait(args: argparse.Namespace) -> float | None:
    """``--cluster-wait`` in seconds (None: the default); StudyError for a bad value, or for
    one given to a run without ``--cluster`` or ``--scheduler`` (it would do nothing)."""
    from psdesign.study.cluster import check_wait_s
    from psdesign.study.studyfile import StudyError

    text = args.cluster_wait
    if text is None:
        return None
    if not (args.cluster or args.scheduler):
        raise StudyError(
            "--cluster-wait: only with --cluster or --scheduler (a run on local workers has "
            "no worker to wait for)"
        )
    try:
        value = float(text)
    except ValueError:
        value = text  # refused, quoted, by check_wait_s
    try:
        return check_wait_s(value)
    except ValueError as exc:
        raise StudyError(str(exc)) from None


def cmd_study_run(args: argparse.Namespace) -> int:
    """Handler of ``psdesign study run``; returns the exit status."""
    from psdesign.errors import SpecError
    from psdesign.study.address import SchedulerError, check_scheduler_address

    try:  # a typo in the address refused before the seconds of the imports below and dask's
        if args.scheduler is not None:  # checked: its host looked up here, once for the run
            args.scheduler = check_scheduler_address(args.scheduler)
    except (SpecError, SchedulerError) as exc:
        return fail(str(exc), BAD_INPUT)
    from psdesign.study.runner import (
        WorkersLost,
        check_workers,
        run_study,
        scheduler_security,
    )
    from psdesign.study.store import StorageError
    from psdesign.study.studyfile import StudyError

    try:
        # the runner's cap on local workers, named as typed (a --cluster's are not local)
        check_workers(
            args.workers,
            args.scheduler or ("cluster" if args.cluster else None),
            "--workers",
            more="--scheduler or --cluster",
        )
        security = scheduler_security(args.tls_ca_file, args.tls_cert, args.tls_key)
        if security is not None and not str(args.scheduler or "").startswith("tls://"):
            # they were ignored: only a tls:// scheduler uses them
            raise StudyError("--tls-ca-file: only with --scheduler tls://HOST:PORT")
        wait_s = _cluster_wait(args)
        scheduler = _cluster(args, wait_s) or args.scheduler
        df = run_study(
            args.study,
            args.out,
            workers=args.workers,
            scheduler=scheduler,
            case_fn=args.case_fn,
            progress=not args.quiet,
            timeout_s=args.timeout,
            retry_failed=args.retry_failed,
            report=not args.no_report,
            force=args.force,
            retry_not_converged=args.retry_not_converged,
            security=security,
            worker_wait_s=wait_s,
            out_option=("-o", "--force"),  # messages name this command's flags
            scheduler_option="--scheduler",
        )
    except (SpecError, SchedulerError) as exc:  # StudyError is a SpecError
        return fail(str(exc), BAD_INPUT)
    except (StorageError, WorkersLost) as exc:
        return fail(str(exc), FAILED)
    except KeyboardInterrupt as exc:  # Ctrl-C, and SIGTERM (Terminated)
        return stopped(exc)
    return study_exit_status(df, allow_not_converged=args.allow_not_converged)


def stopped(exc: KeyboardInterrupt) -> int:
    """The one line and exit status of a study command (``study run``, ``study optimize``)
    stopped by Ctrl-C (130) or SIGTERM (143, :class:`~psdesign.study.interrupt.Terminated`): its
    finished cases are in the folder and a rerun resumes. ``study optimize`` said only
    "psdesign: interrupted" until session 52 (walk-cli finding 5), though it resumes too."""
    from psdesign.study.interrupt import Terminated

    note = "finished cases are saved, rerun the command to resume"
    if isinstance(exc, Terminated):
        return fail(f"terminated; {note}", TERMINATED)
    return fail(f"interrupted; {note}", INTERRUPTED)


def study_exit_status(df, allow_not_converged: bool = False) -> int:
    """The exit status of a study's table (:func:`psdesign.cli.exit_status.cases_status`): 0
    when every case and every value in it is ``ok`` (``not_converged`` cases allowed by the
    flag); 1 when a case failed or timed out; else 3 (a ``not_converged`` case, or an ``ok``
    case with a value flagged ``untrustworthy`` or ``blocked``); one line per kind why."""
    # here, not at the top: analysis.columns imports pandas, which no CLI start may pay for
    from psdesign.analysis.columns import FLAGGED_KEPT, flagged_text

    counts = case_counts(df)
    if counts.flagged:  # exit 3 since session 45 (0 and a warning before)
        print(f"psdesign: {flagged_text(df)}; {FLAGGED_KEPT}", file=sys.stderr)
    if counts.failed:
        print(
            f"psdesign: {counts.failed} case(s) failed or timed out (their error in "
            "results.csv, the traceback in cases/<stored_as>/error.txt); --retry-failed to "
            "re-run them",
            file=sys.stderr,
        )
    if counts.not_converged and not allow_not_converged:
        print(
            f"psdesign: {counts.not_converged} case(s) not_converged (a solve did not converge "
            "or was flagged); --allow-not-converged to accept them, --retry-not-converged to "
            "re-run them",
            file=sys.stderr,
        )
    return cases_status(counts, allow_not_converged)


def cmd_study_report(args: argparse.Namespace) -> int:
    """Handler of ``psdesign study report``; returns the exit status."""
    from psdesign.report import write_report_alerts
    from psdesign.study.readback import read_results
    from psdesign.study.store import StorageError

    try:
        path, alerts = write_report_alerts(args.out)
    except ValueError as exc:  # ReportError, OutputError, a damaged file (study.readback)
        return fail(folder_line(exc), BAD_INPUT)
    except StorageError as exc:
        return fail(str(exc), FAILED)
    print(path)
    return report_exit_status(read_results(args.out), alerts)


def report_exit_status(df, alerts: Sequence[ReportAlert] = ()) -> int:
    """The exit status of ``study report`` (session 45): the report finished and is complete,
    so never ``FAILED`` for a case (``FAILED`` is a run that could not give it: ``study run``'s
    exit); ``NOT_TRUSTED`` when a case it shows is not ok (failed, timed out, not_converged, or
    an ok case with a value not ok: :func:`psdesign.cli.exit_status.case_counts`, the cases its
    red box counts), with one line saying so; else ``OK``. Until session 45 it exited 0 on a
    folder whose every case had failed. It takes no ``--allow-not-converged``: its exit says
    whether a red box is there: since session 52 also 3 for each of the report's ``alerts``
    (:func:`psdesign.report.html.render_report`: an unfinished study, since session 53 one of
    them, a missed ``study optimize`` target, an untrustworthy surrogate it draws), one line
    each: ``psdesign: <what>: <todo>``.

    >>> import pandas as pd
    >>> report_exit_status(pd.DataFrame({"status": ["ok", "ok"]}))
    0
    >>> report_exit_status(pd.DataFrame({"status": ["failed", "failed"]}))  # and one line
    3
    """
    counts = case_counts(df)
    for alert in alerts:  # an unfinished study: finished, but not the study: 3, not 1
        print(f"psdesign: {alert.what}: {alert.todo}", file=sys.stderr)
    if not any(counts):
        return NOT_TRUSTED if alerts else OK
    print(
        f"psdesign: the report shows {sum(counts)} of {len(df)} case(s) not ok ({counts.failed} "
        f"failed or timed out, {counts.not_converged} not_converged, {counts.flagged} ok with a "
        "value not ok): read its red box",
        file=sys.stderr,
    )
    return NOT_TRUSTED


def main(argv: list[str] | None = None) -> int:
    """Stand-alone entry (``python -m psdesign.cli.study study run ...``) for testing."""
    parser = argparse.ArgumentParser(prog="psdesign")
    subparsers = parser.add_subparsers(dest="command", required=True)
    register(subparsers)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
