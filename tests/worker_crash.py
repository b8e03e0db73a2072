"""End an xdist run at a crashed worker instead of replacing it.

A worker that dies inside a test (an LLVM abort in a numba compile, a segfault, the OOM killer)
hung ``python -m pytest -n 2 --dist loadfile`` (session 44: both workers idle until stopped at
17 min). pytest-xdist 3.8.0 (the newest release on PyPI) replaces the worker, and its
``loadfile`` scheduler (``LoadScopeScheduling.remove_node``) puts back every file the dead
worker was given, the ones it had finished too; the replacement is handed a finished file, an
empty list of tests, and waits for work forever (pytest-xdist issue 1323; fixed upstream by
pull request 1324, not in any release yet). Without the hang the replacement would still rerun
the crashing test until ``--max-worker-restart`` (8 for ``-n 2``) is spent (issue 1371).

Installed from ``conftest.py``: unless ``--max-worker-restart`` is given, it is 0, so the first
crash ends the run with xdist's ``worker 'gwN' crashed while running '<test id>'`` failure and a
non-zero exit status; the other worker finishes the file it holds (``loadfile`` hands a worker a
whole file at once). The rest of the crashed file is not run.
"""

from __future__ import annotations

import pytest


def no_worker_restart(config: pytest.Config) -> None:
    """Set ``--max-worker-restart`` to 0 unless the command line gave one.

    Parameters
    ----------
    config
        The session's configuration, in ``pytest_configure`` (xdist builds its controller after
        the conftests' ``pytest_configure``, ``trylast``, and reads the option then).
    """
    if getattr(config.option, "maxworkerrestart", "absent") is None:  # xdist loaded, not given
        config.option.maxworkerrestart = "0"
