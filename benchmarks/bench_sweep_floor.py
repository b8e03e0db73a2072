"""What bounds a finest-level Jacobi sweep on one core: the product's ``jacobi`` beside bare
loops of the same arithmetic on the same arrays (issue 16, item 2).

    python benchmarks/bench_sweep_floor.py [N] [ROUNDS]      # default 200 4

Per round, ns per cell (best of 5), on one thread and then on all of numba's threads, each
beside the triad measured just before and after the round on that many threads (the higher
of the two) and as a multiple of the triad time of the sweep's 13 bytes per cell (the reading
of issue 16's item 2):

* ``stream``: ``out = x + b + d``, the sweep's 13 bytes per cell with no stencil;
* ``1d``, ``2d``, ``3d``: the bare flat sweep (``kernels._jacobi_cell``'s expression, no row
  ends, no dot, no prefetch) with its six neighbours at +-1, +-1 and +-nz, and +-nz and +-nz ny:
  the same loads and arithmetic, the neighbour rows from L1 in ``1d``/``2d`` and the neighbour
  x-planes (160 KB apart at 200^3) from L2/L3 in ``3d``;
* ``3d pairs``: ``3d`` for the x-planes ``i, i + 1`` in one loop (four plane streams for two
  planes instead of six);
* ``jacobi``: the product's sweep (row ends, wrap rows, the returned dot).

Session 29 (200^3, 23:39, load 0.3-1.1; one thread / two threads): stream 0.44-0.46 /
0.36-0.37, 1d 0.44 / 0.33-0.35, 2d 0.49-0.50 / 0.34-0.36, 3d 0.71-0.72 / 0.45-0.46, 3d pairs
0.59 / 0.46-0.48, jacobi 0.88-0.94 / 0.63-0.65.  The arithmetic is cheap (1d runs at the
stream's rate); the two extra x-plane streams cost the bare sweep ~0.25 ns per cell on one
thread, and the product's row ends, wrap rows and dot another ~0.2 (``benchmarks/RESULTS.md``,
session 29).  Session 30 (00:18-00:20, load 0.3, 60 rounds per thread count; two-thread
triads 36-41 GB/s, the lower of the host's two levels): on two threads the stream ran at
0.80-1.36x the triad time of its bytes (median 0.89), the bare 3-D sweep at 1.01-1.25x
(median 1.11), two planes per loop 0.95-1.17x (1.02), the product's ``jacobi`` (f7a88d9)
1.49-1.71x (1.60).  Beside the higher level (01:32-01:38, load 1.2-1.3, 72 two-thread
rounds at 58-71 GB/s): stream 0.85x (medians), 1d 1.05x, 2d 1.19x, 3d 1.65x (1.54-2.01x),
3d pairs 1.32x, ``jacobi`` 2.27x: there even the bare 3-D sweep is above item 2's 1.4x.
"""

from __future__ import annotations

import sys

import numba as nb
import numpy as np

from solvers.jit import NoAliasCompiler
from solvers.voxel import kernels as kr

_U = np.uint64
_JIT = {"fastmath": True, "boundscheck": False, "error_model": "numpy"}


@nb.njit(parallel=True, pipeline_class=NoAliasCompiler, **_JIT)
def _bare(fd, fx, fb, fo, nx, far, near, om):
    """The bare sweep over planes 2 .. nx - 3 with neighbours at +-1, +-near, +-far."""
    pl = _U(fd.size // nx)
    one = _U(1)
    far, near = _U(far), _U(near)
    for h in nb.prange(nx - 4):
        base = _U(2 + h) * pl
        for q in range(base, base + pl):
            sm = fx[q - far] + fx[q + far] + fx[q - near] + fx[q + near] + fx[q - one] + fx[q + one]
            fo[q] = kr._jacobi_cell(fd, fx, fb, q, q, sm, om)
    return 0.0


@nb.njit(parallel=True, pipeline_class=NoAliasCompiler, **_JIT)
def _pairs(fd, fx, fb, fo, nx, nz, om):
    """``_bare`` in 3-D for two x-planes per loop."""
    pl = _U(fd.size // nx)
    one = _U(1)
    unz = _U(nz)
    for h in nb.prange((nx - 4) // 2):
        base = _U(2 + 2 * h) * pl
        for q in range(base, base + pl):
            r = q + pl
            s0 = fx[q - pl] + fx[r] + fx[q - unz] + fx[q + unz] + fx[q - one] + fx[q + one]
            s1 = fx[q] + fx[r + pl] + fx[r - unz] + fx[r + unz] + fx[r - one] + fx[r + one]
            fo[q] = kr._jacobi_cell(fd, fx, fb, q, q, s0, om)
            fo[r] = kr._jacobi_cell(fd, fx, fb, r, r, s1, om)
    return 0.0


@nb.njit(parallel=True, **_JIT)
def _stream(fd, fx, fb, fo):
    for q in nb.prange(fd.size):
        fo[q] = fx[q] + fb[q] + np.float32(fd[q])


def main(n: int = 200, rounds: int = 4) -> None:
    from bench_voxel import _best_ms, _warm_parallel, sweep_operands, triad_bandwidth

    _warm_parallel()  # else on two threads below COMPILE_PARALLEL_ABOVE jacobi runs its twin
    d, cc, x, b, out = sweep_operands(n)
    fd, fx, fb, fo = d.ravel(), x.ravel(), b.ravel(), out.ravel()
    om = np.float32(0.9)
    cases = {
        "stream": lambda: _stream(fd, fx, fb, fo),
        "1d": lambda: _bare(fd, fx, fb, fo, n, 1, 1, om),
        "2d": lambda: _bare(fd, fx, fb, fo, n, n, n, om),
        "3d": lambda: _bare(fd, fx, fb, fo, n, n * n, n, om),
        "3d pairs": lambda: _pairs(fd, fx, fb, fo, n, n, om),
        "jacobi": lambda: kr.jacobi(d, *cc, x, b, out, 0.9),
    }
    sweep_bytes = fd.nbytes + fx.nbytes + fb.nbytes + fo.nbytes  # 13 B per cell, STREAM count
    avail = nb.get_num_threads()
    for threads in sorted({1, avail}):
        nb.set_num_threads(threads)
        for fn in cases.values():
            fn()  # compile / load
        for _ in range(rounds):
            before = triad_bandwidth(reps=3)
            cells = {k: _best_ms(f, 5) * 1e6 / n**3 for k, f in cases.items()}
            triad = max(before, triad_bandwidth(reps=3))
            ideal = sweep_bytes / triad * 1e9 / n**3  # ns per cell at the triad beside it
            print(
                f"{n}^3, {threads} thread(s), triad {triad / 1e9:.1f} GB/s ({ideal:.3f} ns per "
                "cell for its 13 B), ns per cell (x that): "
                + ", ".join(f"{k} {v:.3f} ({v / ideal:.2f})" for k, v in cells.items()),
                flush=True,
            )
    nb.set_num_threads(avail)


if __name__ == "__main__":
    main(*[int(a) for a in sys.argv[1:3]])
