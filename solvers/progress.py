"""How often the iterative solvers call their ``progress`` callback.

The solvers know nothing of psdesign's printer: they call ``progress(iterations, residual)``
(or ``progress(done, total)`` for counted work such as assembly) and the caller throttles
what it prints (:meth:`psdesign.progress.Printer.throttled`).
"""

PROGRESS_EVERY = 1
"""Iterations between two progress reports: every one, the caller's printer throttles
(25 left 13 s without a line at 200^3 on a loaded machine, over a minute at 400^3)."""
