"""The options several commands share: ``--force``, ``--allow-not-converged`` and
``--workers``, one help each (in ``psdesign.cli.progress`` until session 52)."""

from __future__ import annotations

FORCE_HELP = (
    "write into a non-empty folder psdesign did not create; files psdesign did not write are "
    "still never replaced, and / and the home folder are always refused"
)


def add_force_argument(parser) -> None:
    """Add ``--force`` (see :mod:`psdesign.io.outputs`) to a sub-command parser."""
    parser.add_argument("--force", action="store_true", help=FORCE_HELP)


def add_allow_not_converged_argument(parser) -> None:
    """Add ``--allow-not-converged`` to ``study run`` and ``study optimize``: their exit status
    follows one table of cases (:func:`psdesign.cli.exit_status.cases_status`), so one flag
    accepts the unconverged ones in both, and only those (its name: an ``ok`` case with a
    value flagged ``untrustworthy`` or ``blocked`` still exits 3, session 45)."""
    parser.add_argument(
        "--allow-not-converged",
        action="store_true",
        help="exit 0 even if some cases are not_converged (failed/timeout still exit 1; an ok "
        "case with a value whose own status is not ok, e.g. k_z_status untrustworthy, still "
        "exits 3)",
    )


#: ``--workers`` of ``study run``, ``study optimize`` and ``rev``: one rule
#: (:func:`psdesign.study.runner.check_workers`), one help.
WORKERS_HELP = (
    "worker processes on this machine, 0 to 64 or 4 per CPU, whichever is more; 0 runs the "
    "cases one after another in this process, with no worker process"
)


def add_workers_argument(parser, scheduler: bool, cluster: bool = False) -> None:
    """Add ``--workers N`` to a sub-command parser, its help with the ``--scheduler`` (and
    ``--cluster``) meaning when the command has them; the value is checked by
    :func:`psdesign.study.runner.check_workers` (one line naming ``--workers``)."""
    text = WORKERS_HELP
    if scheduler:
        text += (
            f"; with --scheduler local{' (or --cluster)' if cluster else ''} the number of "
            f"Dask workers{' (batch jobs)' if cluster else ''}, ignored by a remote scheduler; "
            "1 or more with any scheduler"
        )
    parser.add_argument("--workers", type=int, default=1, help=text + " (default 1)")
