"""Iterations and time per MINRES iteration of the voxel Stokes solver on the Toray-like box.

``python benchmarks/voxel_iteration_cost.py N [nocoarse]``: one full solve (x, tol 1e-6) of
``bench_voxel_scale._box(N)`` after a warm-up; ``nocoarse`` switches the two-level pressure
block off (``solvers.voxel_stokes.COARSE_PRESSURE``) for a side by side in separate processes.
Results: ``benchmarks/RESULTS.md``, "Issue 16, idle re-measure ... session-4 merges".
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import bench_voxel_scale as scale  # noqa: E402

import solvers.voxel_stokes as vs  # noqa: E402
from solvers import jit  # noqa: E402


def main(argv: list[str]) -> None:
    n = int(argv[1]) if len(argv) > 1 else 100
    if "nocoarse" in argv:
        vs.COARSE_PRESSURE = False
    core = vs._solve_core
    spent: dict[str, float] = {}

    def timed(*args, **kwargs):
        t = time.perf_counter()
        out = core(*args, **kwargs)
        spent["core"] = time.perf_counter() - t
        return out

    vs._solve_core = timed
    jit.COMPILE_PARALLEL_ABOVE = 0
    vs.solve_voxel_stokes(scale.toray_box(48)[0], 1e-6, "x", tol=1e-3)
    solid, _ = scale._box(n)
    t = time.perf_counter()
    res = vs.solve_voxel_stokes(solid, 1e-6, "x", tol=1e-6)
    wall = time.perf_counter() - t
    print(
        f"{n}^3 coarse pressure {vs.COARSE_PRESSURE}: iterations {res.iterations} solve "
        f"{wall:.2f} s, MINRES core {spent['core']:.2f} s, "
        f"{1e3 * spent['core'] / res.iterations:.0f} ms per iteration",
        flush=True,
    )


if __name__ == "__main__":
    main(sys.argv)
