"""Thread policy of the voxel Stokes kernels: how many numba threads each grid level uses.

Measured on a 2-core machine shared with other jobs (``python benchmarks/bench_voxel.py
threads``; ``benchmarks/RESULTS.md``):

* numba's OpenMP layer (libgomp) spins while a thread waits at the end of a parallel region.
  With another process on the second core the spinning thread steals the CPU its partner needs,
  so two threads ran up to 42x slower than one.  ``OMP_WAIT_POLICY=PASSIVE`` (waiting threads
  sleep) is therefore set as the default before any parallel region runs
  (:func:`passive_wait`, called on import of :mod:`psdesign` and :mod:`solvers`); a value set
  by the user is kept.
* numba picks its threading layer at the first parallel region, TBB first when ``libtbb`` is
  installed (Debian's ``openfoam`` package brings it, for one).  The thread policy here was
  measured on OpenMP, so OpenMP comes first (:func:`prefer_openmp`; TBB, then numba's
  workqueue where OpenMP is missing); a layer or order set by the user is kept.  The results do
  not depend on the layer: every kernel's final sum has one order
  (:func:`solvers.reduction.ordered_sum`).
* A parallel region also costs a wake-up of every thread (a scheduler time slice on a busy
  machine), so grids or multigrid levels below ``PARALLEL_MIN_CELLS`` cells run on one thread
  (:func:`level_threads`); only the fine levels, where the work is, use all threads.
"""

from __future__ import annotations

import os
import sys

PARALLEL_MIN_CELLS = 100_000
"""Grids (and multigrid levels) with fewer cells run the numba kernels on one thread.  Measured
on an idle 2-core machine with the row-vectorised kernels, two threads are faster from 32^3 up
(100^3: 9.5 s -> 5.4 s, 150^3: 32.9 s -> 18.3 s); on a machine whose cores are busy with other
work the start-up latency of a parallel region (~15 ms under load) can make one thread faster
for small grids, so the tiny grids of tests and screening and the coarse multigrid levels stay
on one thread."""


SOLVE_PARALLEL_MIN_CELLS = 300_000
"""A solve whose grid has fewer cells runs every level on one thread, even where a level has
``PARALLEL_MIN_CELLS`` or more.  Measured (``python benchmarks/bench_voxel.py threads 64``,
session 21, ``benchmarks/RESULTS.md``): with one CPU-bound competitor a 64^3 solve (262 k
cells) with its fine level on two threads took 1.16-1.59x its one-thread time in three runs,
and 0.96x on an idle machine; the work per parallel region there is too small to pay the
wake-ups.  A 200^3 solve keeps its 125 k-cell level parallel (1.36-1.46x faster than one
thread idle, against 1.24-1.25x with that level serial)."""


def passive_wait() -> None:
    """Make idle OpenMP threads sleep instead of spin (``OMP_WAIT_POLICY=PASSIVE``) unless the
    user chose otherwise.  Must run before the first numba parallel region of the process (the
    OpenMP runtime reads it when it starts)."""
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


OPENMP_FIRST = ("omp", "tbb", "workqueue")
"""numba's threading layers in the order psdesign prefers them (numba's own: TBB first)."""


def prefer_openmp() -> None:
    """Make numba try its OpenMP layer first (then TBB, then its workqueue) unless the user set
    ``NUMBA_THREADING_LAYER`` or ``NUMBA_THREADING_LAYER_PRIORITY``.  Must run before the first
    numba parallel region of the process (numba picks the layer then); works after ``import
    numba`` too."""
    if "NUMBA_THREADING_LAYER" in os.environ or "NUMBA_THREADING_LAYER_PRIORITY" in os.environ:
        return
    os.environ["NUMBA_THREADING_LAYER_PRIORITY"] = " ".join(OPENMP_FIRST)  # child processes
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba read the environment at its import
        config.THREADING_LAYER_PRIORITY = list(OPENMP_FIRST)


def level_threads(n_cells: int, available: int) -> int:
    """Numba threads for a grid (or multigrid level) of ``n_cells`` cells: all ``available``
    from ``PARALLEL_MIN_CELLS`` cells up, else one."""
    return available if n_cells >= PARALLEL_MIN_CELLS else 1


def solve_threads(n_cells: int, available: int) -> int:
    """Numba threads for a whole solve on a grid of ``n_cells`` cells: one below
    :func:`solve_min_cells`, else all ``available`` (each level then takes
    :func:`level_threads`' count)."""
    return available if n_cells >= solve_min_cells() else 1


def solve_min_cells() -> int:
    """The smallest grid a solve runs on more than one thread (the larger threshold)."""
    return max(SOLVE_PARALLEL_MIN_CELLS, PARALLEL_MIN_CELLS)


def thread_use(
    threads: int, available: int, fallback: set[str], parallel: set[str]
) -> tuple[int, str]:
    """Threads a solve's fine-grid kernels really ran on, and why that is fewer than numba's
    ``available`` (``""`` when it is not): ``threads`` is what :func:`level_threads` gave the
    solve, ``fallback`` the kernels that ran their serial twin only because their parallel
    version was not compiled and ``parallel`` those that ran in parallel
    (:class:`solvers.jit.KernelLog`).  If every kernel ran its serial twin the solve ran on
    one thread; if only some did, the note names them."""
    if threads == 1:
        if available == 1:
            return 1, ""
        return 1, f"ran on 1 of {available} threads: grid below {solve_min_cells()} cells"
    if not fallback:
        return threads, ""
    from solvers.jit import WARMUP_NOTE  # numba is not imported with this module

    if not parallel:
        return 1, f"ran on 1 of {threads} threads: {WARMUP_NOTE}"
    names = ", ".join(sorted(fallback))
    return (
        threads,
        f"{len(fallback)} kernels ran on 1 of {threads} threads ({names}): {WARMUP_NOTE}",
    )
