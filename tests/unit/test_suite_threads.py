"""The test suite's own thread budget (``tests/conftest.py``): ``pytest -n 2`` on 2 cores must
not run 2 x 2 BLAS threads."""

from __future__ import annotations

import os
import subprocess
import sys

import conftest

_CHILD = (
    "import numpy, scipy.linalg, threadpoolctl\n"
    "print(*[i['num_threads'] for i in threadpoolctl.threadpool_info() if i['user_api'] == 'blas'])"
)


def test_xdist_workers_share_the_blas_threads() -> None:
    """Under pytest-xdist each worker's BLAS (numpy's and scipy's OpenBLAS, found by
    ``threadpoolctl``) runs on the CPUs shared out among the workers, the study runner's rule
    (``runner.threads_per_worker``: 1 thread for 2 workers on 2 cores, where OpenBLAS would start
    2), and the processes tests start inherit ``OPENBLAS_NUM_THREADS``; outside xdist BLAS is
    left alone."""
    import scipy.linalg  # noqa: F401  (scipy's own OpenBLAS, loaded after numpy's)
    from threadpoolctl import threadpool_info

    from psdesign.study.runner import threads_per_worker

    blas = [i for i in threadpool_info() if i["user_api"] == "blas"]
    assert blas, "no BLAS library found by threadpoolctl"
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0"))
    if workers < 2:
        assert conftest.BLAS_THREADS is None
        return
    assert [i["num_threads"] for i in blas] == [threads_per_worker(workers)] * len(blas)
    assert conftest.BLAS_THREADS == threads_per_worker(workers)
    # the processes tests start share them too (the variable's value if set before pytest)
    child = subprocess.run(
        [sys.executable, "-c", _CHILD], capture_output=True, text=True, check=True
    ).stdout.split()
    assert child == [os.environ.get("OPENBLAS_NUM_THREADS", "unset")] * len(child) and child
