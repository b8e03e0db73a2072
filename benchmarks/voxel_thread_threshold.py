"""Cost and gain of compiling the parallel voxel kernels on first use (``solvers.jit.
COMPILE_PARALLEL_ABOVE``): one Toray-like staircase solve per process (1 um voxels, periodic,
along x, ``bench_voxel_scale.toray_box``), its wall and CPU time, iterations and the threads
its kernels really ran on (``threads_used``, ``thread_note``).

Usage (one process per line; the compile cost is the difference between a first and a second
``compile`` run in an empty ``NUMBA_CACHE_DIR``, the gain the difference between one and two
threads once the parallel kernels are cached)::

    NUMBA_NUM_THREADS=2 python benchmarks/voxel_thread_threshold.py 48 compile
    NUMBA_NUM_THREADS=1 python benchmarks/voxel_thread_threshold.py 200

``compile`` sets ``COMPILE_PARALLEL_ABOVE = 0`` (compile what is missing, as a grid above the
threshold does); without it a grid below the threshold runs the serial twin of any parallel
kernel that is not compiled and says so.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_voxel_scale as scale  # noqa: E402
import numba  # noqa: E402

import solvers.voxel_stokes as vs  # noqa: E402
from solvers import jit  # noqa: E402


def main(argv: list[str]) -> None:
    n = int(argv[0])
    if "compile" in argv[1:]:
        jit.COMPILE_PARALLEL_ABOVE = 0
    solid = scale.toray_box(n)[0]
    w0, c0 = time.perf_counter(), time.process_time()
    res = vs.solve_voxel_stokes(solid, 1e-6, "x")
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    print(
        f"n={n} numba_threads={numba.get_num_threads()} wall={wall:.2f} s cpu={cpu:.2f} s "
        f"its={res.iterations} flow_rate={res.flow_rate:.8e} threads_used={res.threads_used} "
        f"note={res.thread_note!r} load1={os.getloadavg()[0]:.2f}",
        flush=True,
    )


if __name__ == "__main__":
    main(sys.argv[1:])
