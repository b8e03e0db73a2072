"""What bounds a finest-level Jacobi sweep on one core: the product's ``jacobi`` beside bare
loops of the same arithmetic on the same arrays (issue 16, item 2).

    python benchmarks/bench_sweep_floor.py [N] [ROUNDS]      # default 200 4
    python benchmarks/bench_sweep_floor.py offsets [N] [ROUNDS]   # 4 KiB aliasing, 200 3
    python benchmarks/bench_sweep_floor.py precondition-offsets [N] [ROUNDS]   # 200 4

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
* ``3d quads``: four x-planes per loop (six plane streams for four planes, 18 streams in all);
* ``3d strips 16``: 2.5-D blocking, strips of 16 y-rows each walked through every x-plane (the
  neighbour planes from L1, every memory stream restarting every 16 rows);
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

``offsets``: the bare 3-D sweep, ``jacobi`` and ``jacobi2_zero`` with their four arrays at one
offset from a 4 KiB boundary and at staggered ones (4 KiB aliasing of loads with stores);
``precondition-offsets``: the product's preconditioner with its input vector and diagonals
moved.  Session 31's figures for these and for quads and strips: ``benchmarks/RESULTS.md``,
"Session 31 lead".
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


@nb.njit(parallel=True, pipeline_class=NoAliasCompiler, **_JIT)
def _quads(fd, fx, fb, fo, nx, nz, om):
    """``_bare`` in 3-D for four x-planes per loop (six plane streams of the iterate for four
    planes, but 18 streams in all)."""
    pl = _U(fd.size // nx)
    one = _U(1)
    unz = _U(nz)
    for h in nb.prange((nx - 4) // 4):
        base = _U(2 + 4 * h) * pl
        for q in range(base, base + pl):
            r = q + pl
            s = r + pl
            t = s + pl
            s0 = fx[q - pl] + fx[r] + fx[q - unz] + fx[q + unz] + fx[q - one] + fx[q + one]
            s1 = fx[q] + fx[s] + fx[r - unz] + fx[r + unz] + fx[r - one] + fx[r + one]
            s2 = fx[r] + fx[t] + fx[s - unz] + fx[s + unz] + fx[s - one] + fx[s + one]
            s3 = fx[s] + fx[t + pl] + fx[t - unz] + fx[t + unz] + fx[t - one] + fx[t + one]
            fo[q] = kr._jacobi_cell(fd, fx, fb, q, q, s0, om)
            fo[r] = kr._jacobi_cell(fd, fx, fb, r, r, s1, om)
            fo[s] = kr._jacobi_cell(fd, fx, fb, s, s, s2, om)
            fo[t] = kr._jacobi_cell(fd, fx, fb, t, t, s3, om)
    return 0.0


@nb.njit(parallel=True, pipeline_class=NoAliasCompiler, **_JIT)
def _strips(fd, fx, fb, fo, nx, ny, nz, rows, om):
    """``_bare`` in 3-D by strips of ``rows`` y-rows, each strip walked through all x-planes
    (2.5-D blocking: the three x-planes of a strip stay in L1, but every stream from memory
    restarts every ``rows nz`` cells)."""
    pl = _U(ny * nz)
    one = _U(1)
    unz = _U(nz)
    span = _U(rows * nz)
    for s in nb.prange((ny - 2) // rows):
        for i in range(2, nx - 2):
            base = _U(i) * pl + _U((1 + s * rows) * nz)
            for c in range(base, base + span):
                sm = fx[c - pl] + fx[c + pl] + fx[c - unz] + fx[c + unz] + fx[c - one] + fx[c + one]
                fo[c] = kr._jacobi_cell(fd, fx, fb, c, c, sm, om)
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
        "3d quads": lambda: _quads(fd, fx, fb, fo, n, n, om),
        "3d strips 16": lambda: _strips(fd, fx, fb, fo, n, n, n, 16, om),
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


def _at(arr: np.ndarray, offset: int) -> np.ndarray:
    """A copy of ``arr`` whose data start ``offset`` bytes past a 4 KiB boundary."""
    raw = np.empty(arr.nbytes + 8192, np.uint8)
    start = (-raw.ctypes.data) % 4096 + offset
    out = raw[start : start + arr.nbytes].view(arr.dtype).reshape(arr.shape)
    out[...] = arr
    return out


def _offset_cases(x, b, d, out, cc, n: int, threads: int) -> dict:
    """The sweeps :func:`offsets` times on one layout of its arrays."""
    fx, fb, fd, fo = x.ravel(), b.ravel(), d.ravel(), out.ravel()
    om = np.float32(0.9)
    return {
        "3d": lambda: _bare(fd, fx, fb, fo, n, n * n, n, om),
        "jacobi": lambda: kr.jacobi(d, *cc, x, b, out, 0.9),
        "jacobi2_zero": lambda: kr.jacobi2_zero(d, *cc, b, out, 0.9, threads),
    }


def offsets(n: int = 200, rounds: int = 3) -> None:
    """The bare 3-D sweep, ``jacobi`` and ``jacobi2_zero`` with ``x, b, d, out`` at the same
    offset from a 4 KiB boundary (as numpy's large allocations all are: a page plus glibc's
    16-byte header) and at staggered ones (4 KiB aliasing of the loads with the stores), ns per
    cell on one thread and on all of numba's threads."""
    from bench_voxel import _best_ms, _warm_parallel, sweep_operands

    _warm_parallel()
    d, cc, x, b, out = sweep_operands(n)
    layouts = {
        "page": (0, 0, 0, 0),
        "page+16": (16, 16, 16, 16),
        "staggered": (16, 2064, 1040, 3088),
    }
    arrays = {
        k: [_at(a, o) for a, o in zip((x, b, d, out), v, strict=True)] for k, v in layouts.items()
    }
    avail = nb.get_num_threads()
    for threads in sorted({1, avail}):
        nb.set_num_threads(threads)
        for _ in range(rounds):
            row = []
            for k, (xx, bb, dd, oo) in arrays.items():
                cases = _offset_cases(xx, bb, dd, oo, cc, n, threads)
                for f in cases.values():
                    f()
                cells = {c: _best_ms(f, 5) * 1e6 / n**3 for c, f in cases.items()}
                row.append(f"{k}: " + ", ".join(f"{c} {v:.3f}" for c, v in cells.items()))
            print(f"{n}^3, {threads} thread(s), ns per cell: " + "; ".join(row), flush=True)
    nb.set_num_threads(avail)


def precondition_offsets(n: int = 200, rounds: int = 4) -> None:
    """The product's preconditioner (three V-cycles and the pressure block) on the Toray-like
    ``n^3`` operator with its arrays as allocated, and with the input vector and the three
    component diagonals moved to other offsets from a 4 KiB boundary (ms, best of 7, and the
    ratio to as allocated; the layouts interleaved in each round)."""
    from bench_voxel import _best_ms, _grid, _warm_parallel, triad_bandwidth

    from solvers import voxel_stokes as vs

    _warm_parallel()
    solid = _grid(n)
    with vs._threads(solid.size):
        op = vs._Stokes.build(solid, None)
        x = np.random.default_rng(0).random(op.shape, dtype=np.float32)
        d0 = list(op.d)
        layouts = {
            "as allocated": (x, d0),
            "x +1 KiB": (_at(x, 1040), d0),
            "x +1 KiB, d staggered": (
                _at(x, 1040),
                [_at(d, o) for d, o in zip(d0, (528, 1552, 2576), strict=True)],
            ),
        }

        def run(xx, ds):
            for a, d in enumerate(ds):
                op.d[a] = op.mg[a].levels[0].d = d
            return _best_ms(lambda: op.precondition(xx, op.z), 7)

        for v in layouts.values():  # the first application of a layout costs more
            run(*v)
        for _ in range(rounds):
            tb = triad_bandwidth(reps=3)
            ms = {k: run(*v) for k, v in layouts.items()}
            base = ms["as allocated"]
            print(
                f"{n}^3 preconditioner, triad {tb / 1e9:.1f} GB/s: "
                + ", ".join(f"{k} {v:.2f} ms ({v / base:.3f})" for k, v in ms.items()),
                flush=True,
            )
        run(*layouts["as allocated"])


if __name__ == "__main__":
    if sys.argv[1:2] == ["offsets"]:
        offsets(*[int(a) for a in sys.argv[2:4]])
    elif sys.argv[1:2] == ["precondition-offsets"]:
        precondition_offsets(*[int(a) for a in sys.argv[2:4]])
    else:
        main(*[int(a) for a in sys.argv[1:3]])
