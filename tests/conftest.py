"""Shared test set-up.

This folder is on ``sys.path`` (pytest's rootdir conftest), so tests import the shared helpers
by name: :mod:`reference_values` (published values with sources), :mod:`meshes` (small tagged
tet meshes), :mod:`study_cases` (fake case functions that pickle to workers).
"""

from __future__ import annotations

import os
from pathlib import Path

import approx_guard
import pytest

approx_guard.install()  # a stated rel bar is the enforced one (approx_guard's docstring)


def share_blas_threads() -> int | None:
    """BLAS threads of this pytest-xdist worker: the CPUs shared out among the workers, as the
    study runner shares them among its pool workers (``runner.threads_per_worker``); ``None``
    (left alone) outside xdist.  Without it ``pytest -n 2`` on 2 cores ran 2 x 2 OpenBLAS
    threads, whose spinning cost 26 % of the CPU of the dense-algebra test files (session 41,
    ``benchmarks/RESULTS.md``).  Numba's threads are left alone: the parallel-twin tests need
    two; the whole default suite passes either way (session 41).  The processes tests start
    (``psdesign`` commands, study workers) inherit ``OPENBLAS_NUM_THREADS`` unless it was set:
    13 % less CPU in the six files that start most of them."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0"))
    if workers < 2:
        return None
    import scipy.linalg  # noqa: F401  (loads scipy's own OpenBLAS, limited with numpy's below)
    from threadpoolctl import threadpool_limits

    from psdesign.study.runner import threads_per_worker

    n = threads_per_worker(workers)
    threadpool_limits(limits=n, user_api="blas")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", str(n))  # the commands tests start, too
    return n


BLAS_THREADS = share_blas_threads()

TESTS_DIR = Path(__file__).resolve().parent
REPO_ROOT = TESTS_DIR.parent
DATA_DIR = TESTS_DIR / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """``tests/data``: small vendored inputs (every file named in ``data/README-puma.md``)."""
    return DATA_DIR


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT
