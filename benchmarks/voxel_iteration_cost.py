"""Iterations and time per MINRES iteration of the voxel Stokes solver on the Toray-like box.

``python benchmarks/voxel_iteration_cost.py N [nocoarse]``: one full solve (x, tol 1e-6) of
``bench_voxel_scale._box(N)`` after a warm-up; ``nocoarse`` switches the two-level pressure
block off (``solvers.voxel_stokes.COARSE_PRESSURE``) for a side by side in separate processes.
Prints K, iterations, the solve's wall and CPU time split into the set-up and the MINRES core
(``_solve_core``), per iteration, and the load average.  Under load the CPU time of a one-thread
run (``NUMBA_NUM_THREADS=1``) is the stand-in for its idle wall time.

``python benchmarks/voxel_iteration_cost.py profile N [ITS]``: CPU time per kernel of ``ITS``
MINRES iterations (default 6) on the operator of the same box (second refinement cycle's
48-bit solution), per call and in ns per fine voxel, grouped by grid level: where the time of
one iteration goes (issue 16).
Results: ``benchmarks/RESULTS.md``, "Issue 16 items 2 and 4 (iter, session 5)".
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import bench_voxel_scale as scale  # noqa: E402
import numpy as np  # noqa: E402

import solvers.voxel_stokes as vs  # noqa: E402
from solvers import jit  # noqa: E402

_KERNELS = {
    "solvers.voxel.kernels": ("jacobi2_zero", "residual_restrict", "prolong_jacobi", "jacobi"),
    "solvers.voxel.lanczos": (
        "stokes_lanczos",
        "add_scaled",
        "minres_direction",
        "add_direction",
        "symmlq_step",
    ),
    "solvers.voxel.schur": ("block_sum", "pressure_block_code"),
}


def _warm() -> None:
    jit.COMPILE_PARALLEL_ABOVE = 0
    vs.solve_voxel_stokes(scale.toray_box(48)[0], 1e-6, "x", tol=1e-3)


def _timer(fun, key, acc: dict) -> object:
    def wrapper(*args, **kw):
        k = (key, getattr(args[0], "size", 0) if args else 0)
        c0 = time.process_time()
        try:
            return fun(*args, **kw)
        finally:
            e = acc.setdefault(k, [0.0, 0])
            e[0] += time.process_time() - c0
            e[1] += 1

    return wrapper


def profile(n: int, its: int = 6) -> None:
    """CPU time per kernel and grid level of ``its`` MINRES iterations on the ``n^3`` box."""
    import importlib

    from solvers.voxel import lanczos as lz

    _warm()
    solid, _ = scale._box(n)
    c0 = time.process_time()
    with vs._threads(solid.size):
        op = vs._Stokes.build(solid)
        build = time.process_time() - c0
        acc: dict = {}
        for mod, names in _KERNELS.items():
            m = importlib.import_module(mod)
            for name in names:
                setattr(m, name, _timer(getattr(m, name), name, acc))
        for smg in [*op.mg, op.coarse_p.mg]:
            smg._coarse_solve = _timer(smg._coarse_solve, "coarse LU", acc)
        rhs = np.empty(op.shape, np.float32)
        op.residual(np.zeros(op.shape), 0, rhs)
        work = vs.MinresWork.of(op)
        x = lz.Solution(op.shape, work.packing)
        vs.krylov_run(op, rhs.copy(), x, work, 1e-30, 2)
        x.extend()
        acc.clear()
        c0 = time.process_time()
        t0 = time.perf_counter()
        vs.krylov_run(op, rhs, x, work, 1e-30, its)
        cpu = time.process_time() - c0
        wall = time.perf_counter() - t0
    cells = solid.size
    print(
        f"profile {n}^3 ({vs.numba.get_num_threads()} threads): operator build {build:.1f} s CPU; "
        f"one MINRES iteration {1e3 * cpu / its:.1f} ms CPU ({1e9 * cpu / its / cells:.1f} ns "
        f"per voxel), {1e3 * wall / its:.1f} ms wall; load {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    seen = 0.0
    for (name, size), (c, cnt) in sorted(acc.items(), key=lambda kv: -kv[1][0]):
        seen += c
        print(
            f"  {name:20s} level {size:>10d} cells: {cnt / its:4.1f} calls, "
            f"{1e3 * c / its:8.2f} ms CPU per iteration = {1e9 * c / its / cells:6.2f} ns per "
            "fine voxel",
            flush=True,
        )
    print(f"  Python and the rest: {1e9 * (cpu - seen) / its / cells:.2f} ns per fine voxel")


def main(argv: list[str]) -> None:
    from psdesign.flow.voxel import column_of

    if len(argv) > 1 and argv[1] == "profile":
        profile(int(argv[2]), int(argv[3]) if len(argv) > 3 else 6)
        return
    n = int(argv[1]) if len(argv) > 1 else 100
    if "nocoarse" in argv:
        vs.COARSE_PRESSURE = False
    core = vs._solve_core
    spent: dict[str, float] = {}

    def timed(*args, **kwargs):
        t = time.perf_counter()
        c = time.process_time()
        out = core(*args, **kwargs)
        spent["core"] = time.perf_counter() - t
        spent["core_cpu"] = time.process_time() - c
        return out

    vs._solve_core = timed
    _warm()
    solid, _ = scale._box(n)
    load0 = os.getloadavg()[0]
    t = time.perf_counter()
    c = time.process_time()
    res = vs.solve_voxel_stokes(solid, 1e-6, "x", tol=1e-6)
    wall = time.perf_counter() - t
    cpu = time.process_time() - c
    its = max(res.iterations, 1)
    print(
        f"{n}^3 coarse pressure {vs.COARSE_PRESSURE}: K_xx {column_of(res)[0]:.9e} m^2, "
        f"iterations {res.iterations}, residual {res.residual:.2e}; solve {wall:.2f} s wall / "
        f"{cpu:.2f} s CPU, of which set-up {wall - spent['core']:.2f} s / "
        f"{cpu - spent['core_cpu']:.2f} s CPU; MINRES core {spent['core']:.2f} s / "
        f"{spent['core_cpu']:.2f} s CPU = {1e3 * spent['core'] / its:.0f} ms wall, "
        f"{1e3 * spent['core_cpu'] / its:.0f} ms CPU per iteration; peak RSS "
        f"{res.peak_memory_mb:.0f} MB; {vs.numba.get_num_threads()} threads; load "
        f"{load0:.1f} -> {os.getloadavg()[0]:.1f}",
        flush=True,
    )


if __name__ == "__main__":
    main(sys.argv)
