"""The exit statuses of every ``psdesign`` command: one table, so that a script can tell a
result it should not trust (3) from a run that could not finish (1).

=====  =================  ============================================================
code   name               meaning
=====  =================  ============================================================
0      ``OK``             done; every result's ``status`` is ``ok`` (a force-field search's
                          ``converged`` or ``at_bound``) and every target met
1      ``FAILED``         could not finish: disk full, permissions, a failed or timed-out
                          study case (``study run``, ``study optimize``, ``rev``: the run
                          could not give it), lost workers; the line names the file or case
2      ``BAD_INPUT``      a bad spec, argument or ``-o`` folder, refused before any work
                          (or a ``generator.porosity`` the box cannot reach, found by
                          trying; nothing written)
3      ``NOT_TRUSTED``    finished, outputs complete, but a result's ``status`` is not
                          ``ok`` (``not_converged``, ``untrustworthy``, ``blocked``,
                          ``extrapolated``, ``contact_left``...: read it),
                          ``study optimize`` missed its target, ``rev`` found no size
                          within ``--tol``, or ``study report`` shows a case not ok (its
                          red box: a failed case too, below), a missed optimize target or
                          an untrustworthy surrogate (session 52; its red box too), or
                          fewer cases than the study has (an unfinished study)
130    ``INTERRUPTED``    Ctrl-C (SIGINT); staged outputs removed, a study resumes
143    ``TERMINATED``     SIGTERM (``kill``, ``timeout``, a batch system's cancel)
=====  =================  ============================================================

One rule decides 0 or 3 for every command (:func:`status_code`): a finished result is
trusted when its ``status`` is in :data:`psdesign.status.TRUSTED`. A study's table
(``results.csv``) follows the same rule per case (:func:`case_counts`, :func:`cases_status`):
a failed or timed-out case is 1, a case that finished with a status other than ``ok``, or an
``ok`` case with a value whose own status (``k_z_status``, ``diffusivity_x_status``...) does
not pass (:func:`psdesign.status.passes`), is 3.

``study report`` finishes when it has written the report, whatever the cases it shows: a
table of failed cases is reported faithfully, not a report that could not finish, so it is
never 1 for a case; its results are the cases, so it exits 3 exactly when one is not ok, the
cases its red box counts (``psdesign.cli.study.report_exit_status``: ``case_counts``, a failed
or timed-out case included; no ``--allow-not-converged``), or when the table holds fewer cases
than ``study.json`` plans (an unfinished study: its report says so at the top). Until
session 45 it exited 0, also on a folder whose every case had failed.

Before session 37, 3 was 1: a full disk and an unconverged solve looked the same to a script.
Before session 45, 3 was a convergence flag only: ``permeability``, ``pores``, the transport
commands and ``study run`` exited 0 on a converged result their own status called
``untrustworthy``.

>>> status_code("ok", "ok"), status_code("ok", "untrustworthy"), status_code("not_converged")
(0, 3, 3)
"""

from __future__ import annotations

import sys
from typing import NamedTuple

from psdesign.status import NOT_FINISHED, passes

OK = 0
FAILED = 1
BAD_INPUT = 2
NOT_TRUSTED = 3
INTERRUPTED = 130
TERMINATED = 143

#: The table in one paragraph: ``psdesign --help`` prints it below the commands.
HELP = (
    "exit status: 0 done, every result's status ok (and every target met); 1 could not finish "
    "(disk full, permissions, a failed study case, lost workers); 2 bad input, refused before "
    "any work; 3 finished with complete outputs, but a result's status is not ok "
    "(not_converged, untrustworthy, blocked, extrapolated...: read it), a study optimize "
    "target was missed, no rev size was within --tol, or study report shows a case not ok "
    "(failed too), a missed target or an untrustworthy surrogate, or an unfinished study; "
    "130 Ctrl-C; 143 SIGTERM"
)


def status_code(*statuses: str | None) -> int:
    """The exit status of finished results by their ``status``: ``OK`` when every one
    :func:`~psdesign.status.passes`, else ``NOT_TRUSTED`` (a missing status too: nothing
    says it is ``ok``).

    >>> status_code("converged"), status_code("ok", "blocked"), status_code(None)
    (0, 3, 3)
    >>> status_code("ok", "not_applicable")
    0
    """
    return OK if all(passes(s) for s in statuses) else NOT_TRUSTED


class CaseCounts(NamedTuple):
    """The cases of a study table by what they make the exit status (:func:`cases_status`)."""

    #: failed or timed out (or with no status): the run could not give them
    failed: int
    #: finished ``not_converged`` (what ``--allow-not-converged`` accepts, and only that)
    not_converged: int
    #: ``ok`` cases with a value whose own status does not pass (``untrustworthy``, ``blocked``)
    #: and finished cases with any other status word (a table the runner did not write)
    flagged: int


def case_masks(df):
    """``(failed, not_converged, flagged)`` boolean Series over the rows of a results table
    (:class:`CaseCounts` says which is which), read off each case's status
    (:func:`psdesign.analysis.columns.case_status`: a missing one is ``unknown``, counted
    failed; a table without a ``status`` column is all ``ok``) and the ``ok`` cases' values
    that are not ok by their own status (:func:`psdesign.analysis.columns.flagged_values`:
    ``k_z_status``, ``porosity_status``, ``pore_sizes_status``...; an empty one, an unrated
    value, is not a flag): what the report's red box counts, so ``study report`` exits 3
    exactly when the red box is there.

    >>> import pandas as pd
    >>> df = pd.DataFrame({"status": ["ok", "ok", "timeout", "not_converged", "untrustworthy"],
    ...                    "k_z_status": ["ok", "untrustworthy", None, "ok", None]})
    >>> [m.tolist() for m in case_masks(df)]  # doctest: +NORMALIZE_WHITESPACE
    [[False, False, True, False, False], [False, False, False, True, False],
     [False, True, False, False, True]]
    """
    from psdesign.analysis.columns import (
        MISSING_STATUS,
        case_status,
        flagged_values,
        other_status,
    )

    status = case_status(df)
    failed = status.isin((*NOT_FINISHED, MISSING_STATUS))
    not_converged = status == "not_converged"
    flagged = other_status(status)
    for m in flagged_values(df).values():  # ok cases only
        flagged |= m
    return failed, not_converged, flagged


def case_counts(df) -> CaseCounts:
    """The :class:`CaseCounts` of the study cases (rows of ``results.csv``).

    >>> import pandas as pd
    >>> case_counts(pd.DataFrame({"status": ["ok", "failed", "not_converged", "timeout"]}))
    CaseCounts(failed=2, not_converged=1, flagged=0)
    """
    if not len(df):
        return CaseCounts(0, 0, 0)
    return CaseCounts(*(int(m.sum()) for m in case_masks(df)))


def cases_status(counts: CaseCounts, allow_not_converged: bool = False) -> int:
    """The exit status of a table of study cases: ``FAILED`` when one failed or timed out,
    else ``NOT_TRUSTED`` when one is ``not_converged`` (unless ``allow_not_converged``:
    ``--allow-not-converged`` accepts those cases, and only those) or flagged (a value not
    ``ok``, another status word), else ``OK``.

    >>> cases_status(CaseCounts(0, 1, 0), allow_not_converged=True)
    0
    >>> cases_status(CaseCounts(0, 1, 1), allow_not_converged=True)
    3
    """
    if counts.failed:
        return FAILED
    if counts.flagged or (counts.not_converged and not allow_not_converged):
        return NOT_TRUSTED
    return OK


#: How ``study report``, ``fit``, ``predict`` and ``sensitivity`` show their study folder
#: argument (``metavar``: ``--help`` and the one line of a refusal, :func:`folder_line`).
FOLDER_METAVAR = "OUT"


def folder_line(exc: Exception) -> str:
    """``exc``'s one line with the folder named as the user typed it (:data:`FOLDER_METAVAR`)
    where the library names its Python parameter ``out_dir`` (``write_report``, the readers of
    a study folder): ``study report nodir`` said ``out_dir: no results.csv ...`` until session
    50.

    >>> folder_line(ValueError("out_dir: no results.csv in nodir; run the study first"))
    'OUT: no results.csv in nodir; run the study first'
    >>> folder_line(ValueError("--outputs: unknown"))
    '--outputs: unknown'
    """
    text = " ".join(str(exc).split())
    key, sep, rest = text.partition(": ")
    return f"{FOLDER_METAVAR}{sep}{rest}" if key == "out_dir" else text


def fail(message: str, code: int = BAD_INPUT) -> int:
    """Print ``psdesign: error: message`` (the one line on stderr) and return ``code``."""
    print(f"psdesign: error: {message}", file=sys.stderr)
    return code
