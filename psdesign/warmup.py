"""Fill numba's on-disk cache ahead of the first solve (``psdesign warmup``).

The numba kernels (voxel Stokes, voxel Laplace, rasterization) compile on first use and are
cached on disk (``cache=True``: ``__pycache__`` beside the sources, or ``NUMBA_CACHE_DIR``).
A first solve in a fresh install otherwise pays the compilation (see ``benchmarks/RESULTS.md``,
"Cold start"). :func:`warmup` runs tiny solves that call every kernel with the argument types
the real solves use, in separate processes so the compilation runs on all cores:

* ``serial``: the one-thread twins (small grids, ``NUMBA_NUM_THREADS=1``; see
  :mod:`solvers.jit`);
* ``parallel``: the ``parallel=True`` kernels (grids from
  :data:`solvers.voxel.threads.PARALLEL_MIN_CELLS` cells on more than one thread), then a
  48^3 pass whose fine grid runs in parallel and whose coarse levels run the serial twins, as a
  real multi-thread solve does; skipped when numba has one thread only.  It runs in two
  processes that make the same solves in different orders (:data:`_PROCESSES`), so that both
  cores compile parallel kernels once the serial task is done.

Each task covers the voxel Stokes routes (periodic and permeameter, sub-voxel and staircase
walls at the default tolerance, whose later Krylov cycles store the solution and direction in
fewer bits, :data:`solvers.voxel.memory.SHORT_SOLUTION_FROM`; a tolerance below it and one below
:data:`solvers.voxel.memory.TIGHT_TOL_BELOW`, whose solutions keep 48 and 64 bits) and the
voxel Laplace solves (periodic and permeameter); ``serial`` also compiles the force-field kernels
(:mod:`psdesign.forcefield`: PS values and derivatives, tube roots, pair grid, lens guard),
about 20 s that the first relaxation would otherwise pay.
The cache stays valid until the sources (of the kernel's module or of a project module it
imports, :class:`solvers.jit.DependencyLocator`) or numba change; a second ``warmup`` only
loads it.
Two processes (the default on two cores) and one (``jobs=1``) cost the same CPU, 320 vs 325 s;
two take less wall time, 295 vs 326 s (``benchmarks/RESULTS.md``).
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

__all__ = ["TASKS", "warmup"]

TASKS = ("serial", "parallel")

_PROCESSES = {"serial": ("serial",), "parallel": ("parallel", "parallel-b")}
"""The processes of each task.  ``parallel`` runs in two that make the same solves
(:func:`_parallel_plan`) in different orders: each compiles the signatures it meets first and
loads the others from the cache (a signature another process is compiling waits for it,
:mod:`solvers.jit_locks`), so on two cores the second core compiles parallel kernels once the
serial task is done instead of idling (the parallel task alone was 835 of 848 s of a cold
warmup on a 2-core AVX2 host; ``benchmarks/RESULTS.md``, compile19).  Either process alone
compiles everything its task needs."""

#: a 16^3 grid with two crossing rods: percolating, analytic distance (sub-voxel walls)
_SPEC = {
    "rve": {"size": [32e-6, 32e-6, 32e-6], "voxel": 2e-6},
    "fibers": [
        {"shape": "rod", "diameter": 10e-6, "center": [16e-6, 8e-6, 8e-6]},
        {"shape": "rod", "diameter": 10e-6, "center": [8e-6, 16e-6, 24e-6], "omega": 90.0},
    ],
}


def _task(mode: str) -> tuple[str, float]:
    """Compile (or load) every kernel of one process of :data:`_PROCESSES`; returns ``(mode,
    seconds)``."""
    import warnings

    import numba

    import psdesign.geometry.raster as raster
    import solvers.jit as jit
    import solvers.voxel.threads as vthreads
    from psdesign.geometry.edt import periodic_edt
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    warnings.simplefilter("ignore")  # resolution warnings of the tiny grid
    t0 = time.perf_counter()
    if mode == "serial":
        numba.set_num_threads(1)
    else:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        vthreads.PARALLEL_MIN_CELLS = 0  # all grids and levels parallel
        vthreads.SOLVE_PARALLEL_MIN_CELLS = 0
        jit.COMPILE_PARALLEL_ABOVE = 0  # compile the parallel kernels, not their twins
        raster.rasterize_copy.serial_below = 0
    spec = validate_spec(_SPEC)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    if mode == "serial":
        for solve in _SOLVES:
            _solve(built, fields, spec, solve)
        _forcefield()
        periodic_edt(~fields.solid)  # the image route's and the pore scan's distance
        return mode, time.perf_counter() - t0
    # a real multi-thread solve also meets Galerkin levels of float32 diagonals with
    # one-byte couplings, in parallel (a 400^3 solve's 200^3 and 100^3 levels) and on the
    # serial twins (its small coarse levels): the 16^3 grid has none, the 48^3 grid has
    # them (after the 16^3 pass alone a 100^3 solve compiled 5 kernels, ~19 s)
    fine = built.voxelize(spec["rve"]["voxel"] / 3)
    grids = {"coarse": fields, "fine": fine}
    for grid, threshold, solve in _parallel_plan(int(fine.solid.size), mode == "parallel-b"):
        vthreads.PARALLEL_MIN_CELLS = threshold
        _solve(built, grids[grid], spec, solve)
    return mode, time.perf_counter() - t0


_SOLVES: tuple[tuple[str, str, str | float], ...] = (
    ("stokes", "periodic", "subvoxel"),
    ("stokes", "periodic", "staircase"),
    ("laplace", "periodic", ""),
    ("stokes", "permeameter", "subvoxel"),
    ("stokes", "permeameter", "staircase"),
    ("laplace", "permeameter", ""),
    # the int32- and int16-extension Krylov variants (the default 1e-6: int8)
    ("tol", "periodic", 1e-8),
    ("tol", "periodic", 5e-7),
)
"""The voxel solves of one warm-up pass: ``(kind, bc, wall treatment or tolerance)``; both
boundary conditions, both wall treatments, the three solution storages, the Laplace solves."""


def _parallel_plan(fine_cells: int, second: bool = False) -> list[tuple[str, int, tuple]]:
    """The steps of a ``parallel`` process: ``(grid, PARALLEL_MIN_CELLS, solve)`` with
    ``grid`` ``"coarse"`` (the 16^3 grid) or ``"fine"`` (48^3, ``fine_cells`` cells) and
    ``solve`` one of :data:`_SOLVES`.

    Three passes: every solve on the 16^3 grid with every level parallel, on the 48^3 grid with
    every level parallel, then on the 48^3 grid with its fine level parallel and the coarse
    levels on the serial twins (as a real multi-thread solve).  ``second``: the order of the
    task's second process (:data:`_PROCESSES`), which starts when the serial task ends: the
    Stokes solves before the Laplace solves and the 48^3 grid before the 16^3 grid, so that it
    first compiles what the first process reaches last (the 48^3 grid's coarse levels) and meets
    the Laplace kernels, which the first process compiles early, last.
    """
    steps = [
        (grid, threshold, solve)
        for grid, threshold in (("coarse", 0), ("fine", 0), ("fine", int(fine_cells)))
        for solve in _SOLVES
    ]
    if second:  # a stable sort: the passes keep their order within each group
        steps.sort(key=lambda st: (st[2][0] == "laplace", st[0] == "coarse"))
    return steps


def _solve(built, fields, spec: dict, solve: tuple) -> None:
    """Run one of :data:`_SOLVES` on ``fields`` (flow along z)."""
    from psdesign.flow.permeability import route_result
    from psdesign.transport.diffusivity import relative_diffusivity

    kind, bc, arg = solve
    if kind == "laplace":
        relative_diffusivity(fields, "z", {"bc": bc})
        return
    flow = {**spec["flow"], "solver": "voxel", "bc": bc}
    flow.update({"wall_treatment": arg} if kind == "stokes" else {"tol": arg})
    route_result(built.rve, fields, "z", flow, "voxel")


def _forcefield() -> None:
    """Evaluate the six-fiber potential where two crossings overlap (lens guard, pair grid,
    tube quadrature, Gauss-Bonnet ends) and the two-fiber one: every force-field kernel."""
    import numpy as np

    from psdesign.forcefield.cases import six_fiber_problem, two_fiber_problem
    from psdesign.forcefield.kernels import lens_candidates

    six = six_fiber_problem()
    x = six.x0.copy()
    x[six.param.free.index("u1")] = 0.4
    six.objective(x)
    two = two_fiber_problem(f0=1.5)
    two.objective(two.x0)
    two.potential(two.x0, surface="bending")  # the curvature kernel (gaussian uses the ends)
    lens_candidates(np.zeros((3, 3, 3)))  # the lens guard of fields without a slope bound


def _processes(tasks: tuple[str, ...]) -> tuple[str, ...]:
    """The worker processes that run ``tasks`` (:data:`_PROCESSES`), in start order."""
    return tuple(p for t in tasks for p in _PROCESSES[t])


def warmup(tasks: tuple[str, ...] = TASKS, jobs: int | None = None) -> dict[str, float]:
    """Compile the kernels into numba's cache, one process per entry of :data:`_PROCESSES`.

    Parameters
    ----------
    tasks
        Subset of :data:`TASKS`.
    jobs
        Processes at once (default: the number of CPUs, at most the number of processes).

    Returns
    -------
    dict
        Process (``serial``, ``parallel``, ``parallel-b``) -> seconds it took,
        ``"total"`` -> wall time.
    """
    import numba

    bad = [t for t in tasks if t not in TASKS]
    if bad:
        raise ValueError(f"warmup tasks {bad}: allowed {', '.join(TASKS)}")
    if numba.config.NUMBA_NUM_THREADS < 2:
        tasks = tuple(t for t in tasks if t != "parallel")
    procs = _processes(tasks)
    t0 = time.perf_counter()
    n = max(1, min(jobs or os.cpu_count() or 1, len(procs)))
    out = _run_pool(procs, n)
    out["total"] = time.perf_counter() - t0
    return out


def _run_pool(procs: tuple[str, ...], n: int) -> dict[str, float]:
    """:func:`_task` of each of ``procs`` in ``n`` spawned processes.  On Ctrl-C or SIGTERM the
    workers are terminated at once: leaving the pool waited for each worker's kernel compile to
    end (a SIGINT to the process group was lost in LLVM's callbacks there), minutes on a cold
    cache (session 36: Ctrl-C 30 s into a cold warmup, still compiling 3 min later).  numba
    writes each cache file whole, so a killed compile leaves nothing broken."""
    from psdesign.study.interrupt import _children_now, held_signals, stop_children

    before = _children_now()
    with held_signals():  # its named semaphores whole, as the study runner's pool (_new_pool)
        pool = ProcessPoolExecutor(max_workers=n, mp_context=get_context("spawn"))
    try:
        out = dict(pool.map(_task, procs))
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        stop_children(keep=before)
        raise
    pool.shutdown()
    return out
