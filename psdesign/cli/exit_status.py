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
                          ``status`` says so) or ``study optimize`` missed its target
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
    "any work; 3 finished with complete outputs, but a result did not converge or a target "
    "was missed (read its status); 130 Ctrl-C; 143 SIGTERM"
)


def converged_status(converged: bool) -> int:
    """``OK`` for a converged result, ``NOT_TRUSTED`` for one written but not converged."""
    return OK if converged else NOT_TRUSTED


def fail(message: str, code: int = BAD_INPUT) -> int:
    """Print ``psdesign: error: message`` (the one line on stderr) and return ``code``."""
    print(f"psdesign: error: {message}", file=sys.stderr)
    return code
