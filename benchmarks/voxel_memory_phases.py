"""Memory of the voxel Stokes solver by phase, and the iteration cost of 16-bit directions.

Usage (one thread, as recorded in ``benchmarks/RESULTS.md``)::

    python benchmarks/voxel_memory_phases.py phases 64        # traced peak per solve phase
    python benchmarks/voxel_memory_phases.py phases 64 16     # ... with 16-bit later directions
    python benchmarks/voxel_memory_phases.py phases-subvoxel 64   # ... sub-voxel walls
    python benchmarks/voxel_memory_phases.py phases-fibres        # ... PuMA fibres_32 along z
    python benchmarks/voxel_memory_phases.py rss 200          # resident memory per phase of
    python benchmarks/voxel_memory_phases.py rss 200 notrim   # bench_voxel_scale's 200^3 box
    python benchmarks/voxel_memory_phases.py bits 100 32 16   # iterations, history, K for the
                                                              # first / later direction bits

``phases`` wraps the phases of :func:`solvers.voxel_stokes.solve_voxel_stokes` (set-up, the
percolation check, the work vectors, each MINRES run, the first residual (the body force,
``_force_residual``, since session 49), each true residual, the solution's
extension and its float64 value, the result) and prints the traced numpy memory before, the
peak within (``tracemalloc.reset_peak``) and after each, in bytes per cell of the staircase
Toray-like grid ``bench_voxel.toray_like(n)``.  ``bits`` solves the same grid with the given
direction storage (:data:`solvers.voxel.memory.DIRECTION_BITS` in the first refinement cycle,
:data:`~solvers.voxel.memory.LATER_DIRECTION_BITS` from the second) and prints the iterations,
the refinement history, the mean velocity and the times.
"""

from __future__ import annotations

import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
from bench_voxel import toray_like

import solvers.voxel_stokes as vs
from solvers.voxel import lanczos as lz
from solvers.voxel import memory as vmem

#: The solve's phases the modes time: (owner, attribute, label).
PHASES = [
    (vs, "_setup_grid", "set-up"),
    (vs, "percolates", "percolates"),
    (vs.MinresWork, "of", "work vectors"),
    (vs, "krylov_run", "Krylov run"),
    (vs, "_force_residual", "first residual (force)"),
    (vs, "_true_residual", "true residual"),
    (lz.Solution, "extend", "extension"),
    (lz.Solution, "value", "float64 value"),
    (vs, "_result", "result"),
]


def _wrap(obj: object, name: str, label: str, n_cells: int, log: list) -> None:
    """Replace ``obj.name`` by a wrapper that logs the traced memory around each call; a
    phase an older tree does not have (``_force_residual`` before session 49) is skipped."""
    if not hasattr(obj, name):
        return
    fn = getattr(obj, name)

    def wrapped(*args: object, **kwargs: object) -> object:
        before = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        out = fn(*args, **kwargs)
        cur, peak = tracemalloc.get_traced_memory()
        log.append((label, before / n_cells, peak / n_cells, cur / n_cells))
        return out

    setattr(obj, name, wrapped)


def phases(n: int, subvoxel: bool = False, fibres: bool = False) -> None:
    """Traced bytes per cell before, within and after each phase of one staircase (or
    sub-voxel: the grid's distance field; or PuMA fibres_32 along z, ``fibres``) solve."""
    warm = np.zeros((16, 16, 16), dtype=bool)
    warm[:, :2, :] = True
    vs.solve_voxel_stokes(warm, 1.0, "z")  # kernels compiled / loaded outside the trace
    slab = np.broadcast_to(np.abs(np.arange(16) + 0.5 - 8.0)[None, :, None] - 2.0, (16,) * 3)
    vs.solve_voxel_stokes(slab <= 0.0, 1.0, "x", distance=slab.copy())  # sub-voxel kernels
    dist = toray_like(n, distance=True) * 100e-6 if subvoxel else None
    solid = toray_like(n) if dist is None else dist <= 0.0
    direction, label = "x", f"Toray-like {n}^3"
    if fibres:
        data = Path(__file__).resolve().parents[1] / "tests" / "data" / "fibres_32.npz"
        solid, direction, label = np.load(data)["solid"].astype(bool), "z", "PuMA fibres_32"
    log: list = []
    for obj, name, label in PHASES:
        _wrap(obj, name, label, solid.size, log)
    tracemalloc.start()
    res = vs.solve_voxel_stokes(solid, 100e-6 / solid.shape[0], direction, distance=dist)
    tracemalloc.stop()
    peak = max(top for _, _, top, _ in log) * solid.size  # the wrappers reset the peak
    for phase, before, top, after in log:
        print(f"{phase:22s} before {before:6.1f}  peak {top:6.1f}  after {after:6.1f} B per cell")
    print(
        f"{label} {res.wall_treatment}, {vmem.KRYLOV}, directions "
        f"{vmem.DIRECTION_BITS} then {vmem.LATER_DIRECTION_BITS} bits (MINRES): traced peak "
        f"{peak / solid.size:.1f} B per cell, {res.iterations} iterations",
        flush=True,
    )


def _proc_kib(key: str) -> int:
    """``VmRSS`` / ``VmHWM`` of this process (KiB, ``/proc/self/status``)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


def rss(n: int, trim: bool = True) -> None:
    """Resident memory (``/proc/self/status``) at the entry and exit of each phase of one solve
    of ``bench_voxel_scale``'s ``n`` um Toray-like box (its grid and warm-up), in bytes per
    cell above the RSS before the solve, with or without the solver's
    :func:`solvers.voxel.memory.release_free_heap` (``trim``)."""
    import bench_voxel_scale as bvs

    from solvers import jit

    if not trim:
        vmem.release_free_heap = lambda: False
    jit.COMPILE_PARALLEL_ABOVE = 0
    vs.solve_voxel_stokes(bvs.toray_box(48)[0], 1e-6, "x", tol=1e-3)
    box = [bvs._box(n)[0]]
    cells = box[0].size
    log: list = []
    for obj, name, label in PHASES:
        if not hasattr(obj, name):  # an older tree's (as _wrap)
            continue
        fn = getattr(obj, name)

        def wrapped(*args: object, _fn=fn, _label=label, **kwargs: object) -> object:
            before = _proc_kib("VmRSS")
            out = _fn(*args, **kwargs)
            log.append((_label, before, _proc_kib("VmRSS"), _proc_kib("VmHWM")))
            return out

        setattr(obj, name, wrapped)
    base = _proc_kib("VmRSS")
    cpu = time.process_time()
    res = vs.solve_voxel_stokes(box.pop(), 1e-6, "x", tol=1e-6)
    cpu = time.process_time() - cpu
    per = 1024.0 / cells
    for label, before, after, hwm in log:
        print(
            f"{label:22s} RSS {(before - base) * per:6.1f} -> {(after - base) * per:6.1f}  "
            f"peak so far {(hwm - base) * per:6.1f} B per cell"
        )
    print(
        f"{n}^3 Toray-like staircase, heap trimmed {trim}: RSS before the solve {base} KiB, "
        f"peak {_proc_kib('VmHWM')} KiB: +{(_proc_kib('VmHWM') - base) * per:.1f} B per cell; "
        f"{res.iterations} iterations, mean velocity {res.mean_velocity[0]:.10e} m/s, "
        f"{cpu:.1f} s CPU",
        flush=True,
    )


def bits(n: int) -> None:
    """Iterations, refinement history and K of one staircase solve (tol 1e-6)."""
    solid = toray_like(n)
    t, c = time.perf_counter(), time.process_time()
    res = vs.solve_voxel_stokes(solid, 100e-6 / n, "x", tol=1e-6)
    print(
        f"Toray-like {n}^3 staircase, directions {vmem.DIRECTION_BITS} then "
        f"{vmem.LATER_DIRECTION_BITS} bits: {res.iterations} iterations, history "
        f"{', '.join(f'{h:.2e}' for h in res.history)}, mean velocity "
        f"{res.mean_velocity[0]:.9e} m/s, solve {time.perf_counter() - t:.1f} s wall "
        f"{time.process_time() - c:.1f} s CPU",
        flush=True,
    )


def main(argv: list[str]) -> None:
    mode = argv[1] if len(argv) > 1 else "phases"
    n = int(argv[2]) if len(argv) > 2 else 64
    if mode in ("phases", "phases-subvoxel", "phases-fibres"):
        if len(argv) > 3:
            vmem.LATER_DIRECTION_BITS = int(argv[3])
        phases(n, subvoxel=mode == "phases-subvoxel", fibres=mode == "phases-fibres")
    elif mode == "rss":
        rss(n, trim=not (len(argv) > 3 and argv[3] == "notrim"))
    elif mode == "bits":
        vmem.KRYLOV = "minres"  # the 16-bit directions are MINRES'
        lz.DIRECTION_BITS = int(argv[3]) if len(argv) > 3 else 32  # Directions read it
        vmem.DIRECTION_BITS = lz.DIRECTION_BITS
        vmem.LATER_DIRECTION_BITS = int(argv[4]) if len(argv) > 4 else 32
        bits(n)
    else:
        raise SystemExit(
            f"unknown mode {mode!r}: phases | phases-subvoxel | phases-fibres | rss | bits"
        )


if __name__ == "__main__":
    main(sys.argv)
