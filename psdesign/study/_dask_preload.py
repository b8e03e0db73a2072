"""Dask worker preload of the local cluster ``study run --scheduler local`` starts: the worker
process ignores SIGINT, as a local pool's workers do (the runner decides when they stop).

A Ctrl-C to the process group otherwise reached each Dask worker, whose event loop stopped
with its case and logged "distributed.worker.state_machine - WARNING - Async instruction for
<Task cancelled ...>" above the command's one line (walk-study, session 53).
"""

from __future__ import annotations

import threading


def dask_setup(worker) -> None:  # noqa: ARG001 - dask's preload hook
    """Ignore SIGINT in this worker process (main thread only: elsewhere it cannot be set)."""
    from psdesign.study.interrupt import ignore_sigint

    if threading.current_thread() is threading.main_thread():
        ignore_sigint()
