"""Where the time of one voxel Stokes solve goes: set-up phases, refinement cycles, iteration parts.

Usage (one size per process; the Toray-like box of ``bench_voxel_scale.py``)::

    /usr/bin/time -v python benchmarks/bench_voxel_parts.py 400 x
    /usr/bin/time -v python benchmarks/bench_voxel_parts.py 400 x nohuge   # 4 KiB pages only

Wraps, for the timed solve only, the solver's Python-level steps with timers (wall, CPU of the
process, minor page faults): the set-up (``_Stokes.build`` and its phases: the component
operators, the multigrid hierarchies, the coarse pressure term, the scale code, the thin
pieces), the first residual (the body force, ``_force_residual``, since session 49), each
Krylov run (refinement cycle) with its iteration count, the true residual between cycles, and
inside the iterations the operator product (``_Stokes.lanczos``), the preconditioner and its
parts (each scalar V-cycle, counted four times per application: three velocity components and
the coarse pressure term's own; the coarse pressure block; the thin pieces' pass) and the
Krylov vector steps (``add_scaled``, ``symmlq_step``). The numba kernels are the solver's own
(a warm-up solve on a 48^3 box loads or compiles them first, as ``bench_voxel_scale.py`` does),
so the sum of the parts is the solve; the printed medians per cycle separate the first call of
a new array (its page faults) from the steady cost.

``nohuge`` turns numpy's ``madvise(MADV_HUGEPAGE)`` of its large arrays off
(``numpy._core.multiarray._set_madvise_hugepage``): with transparent huge pages on ``madvise``
(this machine), each first touch of a new large array allocates 2 MiB pages, compacting memory
when it is fragmented, which made the first call on fresh arrays 2-3x slower at 300^3 under
load.  The same file runs on an older tree (``PYTHONPATH`` there): a part the tree does not
have is skipped.  Written for ``benchmarks/RESULTS.md``, "Issue 16 item 4, per-iteration cost
at 400^3 (gap13)".
"""

from __future__ import annotations

import os
import resource
import sys
import time
from collections import defaultdict
from collections.abc import Callable

import numpy as np

TOTALS: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0, 0])
"""Part name -> [wall s, CPU s, calls, minor faults]."""

CALLS: dict[str, list[tuple[int, float]]] = defaultdict(list)
"""Per-iteration part -> [(cycle, wall s)] of every call."""

STATE = {"on": False, "cycle": 0}


def _stamp() -> tuple[float, float, int]:
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    return time.perf_counter(), time.process_time(), faults


def _add(key: str, t0: tuple[float, float, int], count: int = 1) -> float:
    t1 = _stamp()
    tot = TOTALS[key]
    tot[0] += t1[0] - t0[0]
    tot[1] += t1[1] - t0[1]
    tot[2] += count
    tot[3] += t1[2] - t0[2]
    return t1[0] - t0[0]


def _wrap(owner: object, attr: str, name: str, per_cycle: bool = False) -> None:
    """Time ``owner.attr`` under ``name`` while :data:`STATE` is on (per refinement cycle if
    ``per_cycle``); a missing attribute (an older tree) is skipped."""
    fn: Callable | None = getattr(owner, attr, None)
    if fn is None:
        return

    def timed(*args: object, **kw: object) -> object:
        if not STATE["on"]:
            return fn(*args, **kw)
        t0 = _stamp()
        out = fn(*args, **kw)
        key = f"{name}@{STATE['cycle']}" if per_cycle else name
        wall = _add(key, t0)
        if per_cycle:
            CALLS[name].append((STATE["cycle"], wall))
        return out

    setattr(owner, attr, timed)


def instrument() -> None:
    """Wrap the solver's steps (module docstring)."""
    import solvers.voxel_stokes as vs
    from solvers.voxel import lanczos as lz
    from solvers.voxel import multigrid as mg
    from solvers.voxel import schur

    for owner, attr, name in [
        (vs._Stokes, "build", "setup: _Stokes.build (all)"),
        (mg, "component_operator", "setup: component operators"),
        (mg.ScalarMG, "__init__", "setup: multigrid hierarchies"),
        (schur.CoarsePressure, "__init__", "setup: coarse pressure term"),
        (vs._Stokes, "_mask_in_code", "setup: scale code as mask"),
        (vs._Stokes, "_thin_blocks", "setup: thin pieces"),
        (vs._Stokes, "_drop_couplings", "setup: unit couplings"),
        (vs, "percolates", "setup: percolation check"),
        (vs.MinresWork, "of", "solve: work vectors"),
        (vs.MinresWork, "store_directions", "solve: narrower directions"),
        (vs, "_force_residual", "first residual (force)"),
        (lz.Solution, "extend", "solve: solution extension"),
        (lz.Solution, "value", "solve: solution as float64"),
        (vs, "_result", "post: fluxes and result"),
    ]:
        _wrap(owner, attr, name)
    for owner, attr, name in [
        (vs, "_true_residual", "true residual"),
        (vs._Stokes, "precondition", "preconditioner"),
        (mg.ScalarMG, "apply", "  V-cycle (x4)"),
        (schur.CoarsePressure, "apply", "  coarse pressure block"),
        (vs._Stokes, "lanczos", "operator product"),
        (lz, "add_scaled", "vector: add_scaled"),
        (lz, "symmlq_step", "vector: symmlq_step"),
    ]:
        _wrap(owner, attr, name, per_cycle=True)
    try:
        from solvers.voxel import thin
    except ImportError:  # a tree before the thin pieces
        pass
    else:
        _wrap(thin.ThinBlocks, "apply", "  thin pieces' pass", per_cycle=True)
    run = vs.krylov_run

    def cycle(*args: object, **kw: object) -> tuple[int, str]:
        if not STATE["on"]:
            return run(*args, **kw)
        STATE["cycle"] += 1
        t0 = _stamp()
        its, status = run(*args, **kw)
        _add(f"cycle {STATE['cycle']} (calls = iterations)", t0, its)
        return its, status

    vs.krylov_run = cycle


def report() -> None:
    """Print the totals and the per-cycle medians of the per-iteration parts."""
    for key in sorted(TOTALS):
        wall, cpu, calls, faults = TOTALS[key]
        print(
            f"  {key:44s} wall {wall:8.2f} s  CPU {cpu:8.2f} s  calls {calls:4d}  "
            f"{1e3 * wall / max(calls, 1):8.1f} ms per call  minor faults {faults:.0f}"
        )
    for name, calls in CALLS.items():
        cyc = np.array([c for c, _ in calls])
        wall = 1e3 * np.array([w for _, w in calls])
        for c in np.unique(cyc):
            w = wall[cyc == c]
            print(
                f"  {name.strip():28s} cycle {c}: {w.size:4d} calls, median {np.median(w):7.1f} "
                f"ms, first {w[0]:7.1f} ms, max {w.max():7.1f} ms"
            )


def main(argv: list[str]) -> None:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from bench_voxel_scale import _box, toray_box

    from psdesign.flow.voxel import column_of
    from solvers import jit
    from solvers.voxel_stokes import solve_voxel_stokes

    n = int(argv[1]) if len(argv) > 1 else 100
    direction = argv[2] if len(argv) > 2 else "x"
    if "nohuge" in argv[3:]:
        np._core.multiarray._set_madvise_hugepage(False)
    instrument()
    jit.COMPILE_PARALLEL_ABOVE = 0  # as bench_voxel_scale: the parallel kernels first
    solve_voxel_stokes(toray_box(48)[0], 1e-6, direction, tol=1e-3)
    box = [_box(n)[0]]
    load0 = os.getloadavg()[0]
    STATE["on"] = True
    t0 = _stamp()
    res = solve_voxel_stokes(box.pop(), 1e-6, direction, tol=1e-6)
    wall = _add("solve (all)", t0)
    STATE["on"] = False
    k = column_of(res)["xyz".index(direction)]
    print(
        f"toray box {n}^3: K = {k:.9e} m^2, {res.iterations} iterations, residual "
        f"{res.residual:.2e}, history {[f'{h:.2e}' for h in res.history]}, solve {wall:.1f} s, "
        f"peak RSS {res.peak_memory_mb:.0f} MiB, load {load0:.1f} -> {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    report()


if __name__ == "__main__":
    main(sys.argv)
