"""The exit statuses of every ``psdesign`` command: one table, so that a script can tell a
result it should not trust (3) from a run that could not finish (1).

=====  =================  ============================================================
code   name               meaning
=====  =================  ============================================================
0      ``OK``             done; every result converged (and every target met)
1      ``FAILED``         could not finish: disk full, permissions, a failed or timed-out
                          study case, lost workers; the line names the file or the case
2      ``BAD_INPUT``      a bad spec, argument or ``-o`` folder, refused before any work
3      ``NOT_TRUSTED``    finished, outputs complete, but a result did not converge (its
                          ``status`` says so), ``study optimize`` missed its target,
                          ``rev`` found no size within ``--tol`` or a ``study predict``
                          prediction is ``extrapolated`` or ``untrustworthy``
130    ``INTERRUPTED``    Ctrl-C (SIGINT); staged outputs removed, a study resumes
143    ``TERMINATED``     SIGTERM (``kill``, ``timeout``, a batch system's cancel)
=====  =================  ============================================================

Before session 37, 3 was 1: a full disk and an unconverged solve looked the same to a script.

>>> from psdesign.cli.exit_status import NOT_TRUSTED, converged_status
>>> converged_status(True), converged_status(False) == NOT_TRUSTED
(0, True)
"""

from __future__ import annotations

import sys

OK = 0
FAILED = 1
BAD_INPUT = 2
NOT_TRUSTED = 3
INTERRUPTED = 130
TERMINATED = 143


#: The table in one paragraph: ``psdesign --help`` prints it below the commands.
HELP = (
    "exit status: 0 done, every result converged (and every target met); 1 could not finish "
    "(disk full, permissions, a failed study case, lost workers); 2 bad input, refused before "
    "any work; 3 finished with complete outputs, but a result did not converge, a study "
    "optimize target was missed, no rev size was within --tol or a study prediction is not "
    "trusted (read its status); 130 Ctrl-C; 143 SIGTERM"
)


def converged_status(converged: bool) -> int:
    """``OK`` for a converged result, ``NOT_TRUSTED`` for one written but not converged."""
    return OK if converged else NOT_TRUSTED


def case_counts(df) -> tuple[int, int]:
    """``(failed, not_converged)``: the study cases (rows of ``results.csv``) that failed or
    timed out, and those that finished ``not_converged``.

    >>> import pandas as pd
    >>> case_counts(pd.DataFrame({"status": ["ok", "failed", "not_converged", "timeout"]}))
    (2, 1)
    """
    if not len(df):
        return 0, 0
    status = df["status"].astype(str)
    n_nc = int((status == "not_converged").sum())
    return int((status != "ok").sum()) - n_nc, n_nc


def cases_status(n_failed: int, n_not_converged: int) -> int:
    """The exit status of a table of study cases: ``FAILED`` when one failed or timed out, else
    ``NOT_TRUSTED`` when one did not converge, else ``OK``."""
    return FAILED if n_failed else NOT_TRUSTED if n_not_converged else OK


def fail(message: str, code: int = BAD_INPUT) -> int:
    """Print ``psdesign: error: message`` (the one line on stderr) and return ``code``."""
    print(f"psdesign: error: {message}", file=sys.stderr)
    return code
