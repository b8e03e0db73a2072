"""BLAS / LAPACK thread policy of psdesign: one thread unless the user chose otherwise.

Measured on a 2-core machine shared with other jobs (``python benchmarks/bench_blas_threads.py
--competitor``; ``benchmarks/RESULTS.md``, session 41): OpenBLAS' default of one thread per CPU
spins its threads on shared cores.  The field relax search of the woven cell's tied layer
(``GeneralizedPS.evaluate``'s ``(points x 3) @ (3 x k)`` products) took 316.8 s on two BLAS
threads against 26.9 s on one beside one CPU-bound process, the same optimum bit for bit; the
FEM Krylov loop's short vectors ran 6x slower, batched 64 x 64 eigenvalue problems
(:mod:`solvers.voxel.thin`) 90x.  psdesign's heavy work is numba kernels and sparse algebra,
not large dense products, so nothing it runs was measured faster on more BLAS threads by more
than the 1.1x the loss allowance permits.

* :func:`default_blas_threads` (called on import of :mod:`psdesign` and :mod:`solvers`, like
  :func:`solvers.voxel.threads.passive_wait`): BLAS runs on one thread in this process and in
  the processes it starts, unless the user set one of :data:`BLAS_THREAD_VARS`; a value the
  user set is kept (``OPENBLAS_NUM_THREADS=2 psdesign ...`` gives BLAS two threads).  A
  study's workers inherit it; their numba threads keep the runner's budget
  (:func:`psdesign.study.runner.threads_per_worker`).
* :func:`single_thread_blas`: a context for the paths that lose on any BLAS thread count above
  one (the FEM Krylov loop, the batched thin-piece inverses), whatever the environment says.
"""

from __future__ import annotations

import contextlib
import os
import sys

BLAS_THREAD_VARS = (
    "OPENBLAS_NUM_THREADS",
    "GOTO_NUM_THREADS",
    "OMP_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
)
"""Environment variables through which a user chooses the BLAS thread count (OpenBLAS reads the
first three in this order, MKL and BLIS their own); any one set turns the default off."""

DEFAULT_VARS = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")
"""Set to ``1`` by :func:`default_blas_threads`: read by a BLAS library loaded later (scipy loads
its own OpenBLAS on first use) and by child processes."""


def default_blas_threads() -> None:
    """Run BLAS / LAPACK on one thread unless the user set one of :data:`BLAS_THREAD_VARS`.

    Sets :data:`DEFAULT_VARS` to ``1`` (libraries loaded later, child processes) and, where
    numpy or scipy is already imported, limits their loaded BLAS libraries to one thread
    (``threadpoolctl``; nothing without it)."""
    if any(v in os.environ for v in BLAS_THREAD_VARS):
        return
    for v in DEFAULT_VARS:
        os.environ[v] = "1"
    if "numpy" in sys.modules or "scipy" in sys.modules:
        try:
            from threadpoolctl import threadpool_limits
        except ImportError:  # pragma: no cover - declared dependency
            return
        threadpool_limits(limits=1, user_api="blas")  # kept: no context, no restore


def single_thread_blas() -> contextlib.AbstractContextManager:
    """Context in which BLAS / LAPACK run on one thread (``threadpoolctl``; nothing without it).
    OpenBLAS threading costs more than it gives on small problems: the FEM Krylov loop's short
    vectors ran 6x slower with it, batched 64 x 64 eigenvalue problems (:mod:`solvers.voxel.thin`)
    90x slower on a loaded 2-core machine (0.09 vs 8 ms each)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - optional dependency
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")
