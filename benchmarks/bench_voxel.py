"""Benchmark of the periodic MAC voxel Stokes solver (solvers.voxel_stokes).

Usage::

    python benchmarks/bench_voxel.py puma            # PuMA geometries 32^3 and 64^3 (K_zz vs PuMA)
    python benchmarks/bench_voxel.py toray 100 200   # Toray-like fibrous grids of the given sizes
    python benchmarks/bench_voxel.py toray-subvoxel 100  # the same with the exact fibre distance
    python benchmarks/bench_voxel.py base            # warm-up only: the numba/Python RSS baseline
    python benchmarks/bench_voxel.py cylinders       # square arrays vs Sangani & Acrivos (1982)
    python benchmarks/bench_voxel.py arrays          # sub-voxel vs staircase, square/hex arrays
    python benchmarks/bench_voxel.py kernels 200     # per-kernel and per-iteration times (ms)
    python benchmarks/bench_voxel.py kernels 200 subvoxel  # ... Toray-like, sub-voxel walls
    python benchmarks/bench_voxel.py threads 64 200  # 1 vs 2 threads, with and without a competitor
    python benchmarks/bench_voxel.py threads 200 reps=1 its=10  # fewer repetitions / iterations
    python benchmarks/bench_voxel.py threads 200 its=0 modes=default competitor=no \
        mincells=30000,300000        # full solves; 1 thread / default only; coarse thresholds
    python benchmarks/bench_voxel.py speedup 200     # idle check: both wall ratios + bandwidth
    python benchmarks/bench_voxel.py sweep-cost      # one-thread ns per cell of the fine sweeps
    python benchmarks/bench_voxel.py sweep-vs-triad 200 25  # a sweep beside the triad's levels

Run each case in its own process under ``/usr/bin/time -v`` for the peak memory, e.g.
``/usr/bin/time -v python benchmarks/bench_voxel.py toray 200``.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numba as nb
import numpy as np

from psdesign.flow.voxel import column_of
from solvers.jit import kernel_log
from solvers.voxel_stokes import solve_voxel_stokes

BENCH = Path(__file__).resolve().parents[1] / "tests" / "data"  # vendored peer geometry
# PuMA K_zz, s, MB as recorded from another machine run (tests/data/README-puma.md), printed as
# labels only; bench_puma.py runs PuMA itself beside psdesign in one run.
PUMA = {32: (0.009785, 77.7, 211), 64: (0.010145, 1201.0, 500)}


@nb.njit(parallel=True)  # no cache: the tests load this file by path
def _rasterise(n, p0, dirs, radius, out):
    """Mark cells whose centre lies within ``radius`` of any periodic straight fibre (unit box)."""
    for i in nb.prange(n):
        for j in range(n):
            for k in range(n):
                x = (i + 0.5) / n
                y = (j + 0.5) / n
                z = (k + 0.5) / n
                for f in range(p0.shape[0]):
                    rx = x - p0[f, 0]
                    ry = y - p0[f, 1]
                    rz = z - p0[f, 2]
                    rx -= np.floor(rx + 0.5)
                    ry -= np.floor(ry + 0.5)
                    rz -= np.floor(rz + 0.5)
                    t = rx * dirs[f, 0] + ry * dirs[f, 1] + rz * dirs[f, 2]
                    px = rx - t * dirs[f, 0]
                    py = ry - t * dirs[f, 1]
                    pz = rz - t * dirs[f, 2]
                    if px * px + py * py + pz * pz < radius * radius:
                        out[i, j, k] = True
                        break


@nb.njit(parallel=True)  # no cache: the tests load this file by path
def _distance(n, p0, dirs, radius, out):
    """Signed distance (box lengths, > 0 outside) to the union of periodic straight fibres."""
    for i in nb.prange(n):
        for j in range(n):
            for k in range(n):
                x = (i + 0.5) / n
                y = (j + 0.5) / n
                z = (k + 0.5) / n
                best = 1e30
                for f in range(p0.shape[0]):
                    rx = x - p0[f, 0]
                    ry = y - p0[f, 1]
                    rz = z - p0[f, 2]
                    rx -= np.floor(rx + 0.5)
                    ry -= np.floor(ry + 0.5)
                    rz -= np.floor(rz + 0.5)
                    t = rx * dirs[f, 0] + ry * dirs[f, 1] + rz * dirs[f, 2]
                    px = rx - t * dirs[f, 0]
                    py = ry - t * dirs[f, 1]
                    pz = rz - t * dirs[f, 2]
                    dist = np.sqrt(px * px + py * py + pz * pz) - radius
                    best = min(best, dist)
                out[i, j, k] = best


def toray_like(
    n: int,
    diameter: float = 0.07,
    porosity: float = 0.8,
    seed: int = 0,
    n_ref: int = 100,
    distance: bool = False,
) -> np.ndarray:
    """Toray-like fibrous grid: random straight fibres in a periodic unit box, ``n^3`` voxels.

    Fibres (diameter ``diameter`` box lengths, 7 voxels at n = 100 by default, i.e. 7 um fibres
    in a 100 um box) get a uniformly random centre point and a random direction flattened
    towards the x-y plane (paper-type GDL, z-component scaled by 0.3), and wrap periodically
    (minimum image), so the grid is periodic.  Fibres are added (fixed ``seed``) until the
    porosity of an ``n_ref^3`` rasterisation reaches ``porosity``; the same fibre set is then
    rasterised at ``n``, so different ``n`` are refinements of one geometry.  With
    ``distance=True`` the exact signed distance to the fibres (box lengths, > 0 in the pore) is
    returned instead of the solid mask (``solid = distance <= 0``).
    """
    rng = np.random.default_rng(seed)
    centres = np.zeros((0, 3))
    dirs = np.zeros((0, 3))
    ref = np.zeros((n_ref,) * 3, dtype=bool)
    while 1.0 - ref.mean() > porosity:
        d = rng.normal(size=3)
        d[2] *= 0.3
        d /= np.linalg.norm(d)
        c = rng.random(3)
        _rasterise(n_ref, c[None], d[None], 0.5 * diameter, ref)
        centres = np.vstack([centres, c])
        dirs = np.vstack([dirs, d])
    if distance:
        dist = np.zeros((n,) * 3)
        _distance(n, centres, dirs, 0.5 * diameter, dist)
        dist[dist == 0.0] = -1e-12  # the rasteriser's solid test is strict (<)
        return dist
    out = np.zeros((n,) * 3, dtype=bool)
    _rasterise(n, centres, dirs, 0.5 * diameter, out)
    return out


def run(
    solid: np.ndarray,
    h: float,
    label: str,
    direction: str = "z",
    distance: np.ndarray | None = None,
) -> None:
    """Solve one direction and print K column, convergence data, time and peak RSS."""
    load = os.getloadavg()
    t = time.perf_counter()
    res = solve_voxel_stokes(solid, h, direction, tol=1e-6, distance=distance)
    wall = time.perf_counter() - t
    print(
        f"{label} ({res.wall_treatment}): K[:,{direction}] = {column_of(res)} "
        f"porosity {res.porosity:.4f} "
        f"converged {res.converged} MINRES iterations {res.iterations} residual "
        f"{res.residual:.2e} flux imbalance {res.flux_imbalance:.1e} solve {wall:.1f} s "
        f"peak RSS {res.peak_memory_mb:.0f} MB (load average before {load[0]:.1f})",
        flush=True,
    )


SANGANI_ACRIVOS = {0.1: 24.83, 0.2: 51.53, 0.3: 102.90}  # Table 1, L^2 / K, transverse flow


def cylinders(sizes: tuple[int, ...] = (16, 32, 64, 128)) -> None:
    """Transverse flow through square cylinder arrays, grids (n, n, 4): deviation of L^2/K."""
    for phi_s, ref in SANGANI_ACRIVOS.items():
        row = []
        for n in sizes:
            c = np.arange(n) + 0.5 - n / 2
            xx, yy = np.meshgrid(c, c, indexing="ij")
            disk = xx**2 + yy**2 < phi_s * n * n / np.pi
            solid = np.repeat(disk[:, :, None], 4, axis=2)
            res = solve_voxel_stokes(solid, 1.0 / n, "x", tol=1e-7)
            dev = 100.0 * (1.0 / column_of(res)[0] / ref - 1.0)
            row.append(f"n={n}: {dev:+.1f} % ({res.iterations} its, converged {res.converged})")
        print(f"solid fraction {phi_s} (S&A {ref}): " + " | ".join(row), flush=True)


def arrays(sizes: tuple[int, ...] = (32, 40, 64, 96)) -> None:
    """Sub-voxel vs staircase on cylinder arrays: deviation from the published / collocation
    reference and MINRES iterations (tol 1e-7 across, 1e-9 along)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from arrays import along_array_k, array_distance, radius_of

    hexes = {32: (30, 52), 40: (41, 71), 64: (56, 97), 96: (97, 168)}
    for phis in (0.1, 0.2, 0.3, 0.4, 0.5):
        for case in ("across square", "along square", "along hexagonal"):
            row = []
            kind = case.split()[1]
            for n in sizes:
                shape = (n, n) if kind == "square" else hexes[n]
                along = case.startswith("along")
                phi = array_distance((*shape, 1 if along else 4), kind, phis)
                out = []
                for dist in (phi, None):
                    res = solve_voxel_stokes(
                        phi <= 0,
                        1.0,
                        "z" if along else "x",
                        distance=dist,
                        tol=1e-9 if along else 1e-7,
                    )
                    k = column_of(res)[2 if along else 0]
                    if along:
                        ref = along_array_k(phis, kind) * radius_of(phis, kind, shape[0]) ** 2
                        dev = 100.0 * (k / ref - 1.0)
                    else:
                        dev = 100.0 * (n * n / k / SANGANI_ACRIVOS_FULL[phis] - 1.0)
                    out.append(f"{dev:+.2f} % ({res.iterations})")
                row.append(f"{n}: {out[0]} / {out[1]}")
            print(f"phi_s {phis} {case}: " + " | ".join(row), flush=True)


SANGANI_ACRIVOS_FULL = {0.1: 24.83, 0.2: 51.53, 0.3: 102.90, 0.4: 217.89, 0.5: 532.55}


@nb.njit(parallel=True, cache=False)
def _triad(a, b, c, s):
    for q in nb.prange(a.size):
        a[q] = b[q] + s * c[q]


def triad_bandwidth(n: int = 32_000_000, reps: int = 5) -> float:
    """Best-of-``reps`` STREAM triad ``a = b + s c`` on float32 arrays (12 bytes per element
    counted, the STREAM convention), in bytes per second."""
    a = np.zeros(n, np.float32)
    b = np.ones(n, np.float32)
    c = np.ones(n, np.float32)
    _triad(a, b, c, 0.5)
    best = float("inf")
    for _ in range(reps):
        t0 = time.perf_counter()
        _triad(a, b, c, 0.5)
        best = min(best, time.perf_counter() - t0)
    return 12.0 * n / best


def _vcycle_bytes(mg0, fused: bool = True) -> float:
    """Bytes one V-cycle must stream (every array touched once per pass; neighbours from
    cache), summed over the levels above the coarsest (the LU is negligible).  ``fused``: the
    kernels as the multigrid runs them now (two sweeps from zero in one pass, prolongation in
    the first post-smoothing sweep); ``False``: one pass per sweep (before the fusions)."""
    total = 0.0
    levels = mg0.levels
    for li, lev in enumerate(levels[:-1]):
        n = lev.d.size
        vec = 4.0
        opb = (lev.d.nbytes + lev.c.nbytes) / n  # the stored couplings (unit_couplings: ~0)
        coarse = levels[li + 1].d.size * vec / n
        sweep = opb + 3 * vec  # d, c, x, b read; x_new written
        if fused:
            per = opb + 2 * vec  # two sweeps from zero: d, c, b read; x_new written
            per += (mg0.pre - 2) * sweep
            per += opb + 2 * vec + coarse  # residual + restriction
            per += sweep + coarse  # prolongation + first post sweep (x_c read)
            per += (mg0.pre - 1) * sweep
        else:
            per = lev.d.itemsize + 2 * vec  # Jacobi from zero
            per += (mg0.pre - 1) * sweep  # remaining pre-smoothing sweeps
            per += opb + 2 * vec + coarse  # residual + restriction
            per += lev.d.itemsize + 2 * vec + coarse  # prolongation (x read and written)
            per += mg0.pre * sweep  # post-smoothing
        total += per * n
    return total


def iteration_bytes(op, fused: bool = True, lo_bytes: int = 2, w_bytes: int = 4) -> float:
    """Bytes one Krylov iteration must stream (the kernels of :func:`solvers.voxel_stokes._symmlq`
    or ``_minres`` by :data:`solvers.voxel.memory.KRYLOV` as they are fused now, each array read
    or written once per kernel; ``fused=False``: before the multigrid fusions, with the separate
    preconditioned dot product, float32 directions and the float64 solution).  ``lo_bytes``: the
    width of the solution's extension (:class:`solvers.voxel.lanczos.Solution`: 1 for the int8
    one of a tol >= 1e-6 SYMMLQ solve, which the timed iterations use; 2 for int16);
    ``w_bytes``: the width of SYMMLQ's packed direction (3 for the 24-bit one that goes with the
    int8 extension, :data:`solvers.voxel.memory.LATER_SYMMLQ_BITS`; 4 for float32)."""
    n = op.fluid.size
    vec4 = 16.0  # one 4-field float32 vector per cell
    sol = 4 * (4.0 + lo_bytes)  # the solution: float32 + its extension, 4 fields
    # the operator as stored: the unit_couplings stand-in (periodic grids) streams no couplings
    ops = sum((d.nbytes + c.nbytes) / n for d, c in zip(op.d, op.c, strict=True)) + 1.0
    if getattr(op, "cut", None) is not None:  # the cut faces, read once by each product
        ops += op.cut.nbytes / n
    apply = ops + 3 * vec4  # z read; r1 read and overwritten by s K z - c1 r1 (in place)
    lanczos = 3 * vec4  # r2 <- r1 - (alfa / beta) r2 (solvers.voxel.lanczos.add_scaled)
    # pressure block: r read, z written, plus the stored scale (4 B) or the staircase code (1 B)
    # and the fluid mask (1 B) of the two-level block, whose restriction reads r once more
    pblock = 8.0 if op.p_scale is None else 12.0
    if getattr(op, "coarse_p", None) is not None:
        pblock += 4.0 + 1.0 + (0.0 if op.p_scale is not None else 1.0)
    prec = sum(_vcycle_bytes(m, fused) for m in op.mg) / n + pblock
    dot = 0.0 if fused else 2 * vec4  # fused: returned by the last sweeps
    from solvers.voxel import memory as vmem

    if fused and vmem.KRYLOV == "symmlq":  # z read; the packed w (float32) and x (float32 +
        # extension) read + written on the active unknowns (solvers.voxel.lanczos.Packing)
        active = (sum(np.count_nonzero(d) for d in op.d) + np.count_nonzero(op.fluid)) / (4 * n)
        masks = sum(d.itemsize for d in op.d) + 1.0  # the activity of each row's entries
        update = vec4 + masks + active * (2 * 4.0 * w_bytes + 2 * sol)
    elif fused:  # z read; w read, w1 read + written (memory.DIRECTION_BITS: float32 or int16 +
        # a scale per 16); x = float32 + extension read + written
        direction = 16.0 if vmem.DIRECTION_BITS == 32 else 9.0
        update = vec4 + 3 * direction + 2 * sol
    else:  # z, w read; w1 read + written (float32); x (float64) read + written
        update = 4 * vec4 + 2 * 32.0
    return n * (apply + lanczos + prec + dot + update)


def _best_ms(fun, reps: int, cpu: bool = False) -> float:
    """Best of ``reps`` timings of ``fun()`` after one warm-up call (ms): wall time, or the
    process CPU time with ``cpu=True`` (on a loaded machine the CPU time of a one-thread run is
    the better estimate of its idle wall time)."""
    clock = time.process_time if cpu else time.perf_counter
    fun()
    best = float("inf")
    for _ in range(reps):
        t0 = clock()
        fun()
        best = min(best, clock() - t0)
    return best * 1e3


def _fusion_pairs(op, reps: int) -> dict[str, tuple[float, ...]]:
    """Separate kernels vs the fused pass that replaced them, timed alternately on the finest
    level of component 0: best of ``reps`` wall times (separate, fused) and CPU times
    (separate, fused), ms."""
    from solvers.voxel import kernels as kr

    mg0 = op.mg[0]
    lev, lev1 = mg0.levels[0], mg0.levels[1]
    rng = np.random.default_rng(1)
    b = (rng.random(lev.d.shape, dtype=np.float32) * (lev.d > 0)).astype(np.float32)
    xc = rng.random(lev1.d.shape, dtype=np.float32)
    x = np.empty_like(b)
    t = np.empty_like(b)
    r = rng.random(op.shape, dtype=np.float32)
    z = np.empty_like(r)
    om, al = mg0.omega, mg0.alpha

    def sep_zero():
        kr.jacobi_zero(lev.d, b, x, om)
        kr.jacobi(lev.d, *lev.c, x, b, t, om)

    def sep_prolong():
        kr.prolong_add(lev.d, xc, *lev.f, al, x)
        kr.jacobi(lev.d, *lev.c, x, b, t, om)

    def sep_prec():
        op.precondition(r, z)
        kr.dot(r, z)

    pairs = {
        "2 Jacobi sweeps from zero": (
            sep_zero,
            lambda: kr.jacobi2_zero(lev.d, *lev.c, b, t, om, nb.get_num_threads()),
        ),
        "prolongation + first post sweep": (
            sep_prolong,
            lambda: kr.prolong_jacobi(
                lev.d, *lev.c, x, xc, *lev.f, al, b, t, om, nb.get_num_threads()
            ),
        ),
        "preconditioner + dot product": (sep_prec, lambda: op.precondition(r, z)),
    }
    out = {}
    for name, (sep, fused) in pairs.items():
        best = [float("inf")] * 4
        for _ in range(reps):  # alternate, so both see the same load
            for q, (fun, cpu) in enumerate(
                ((sep, False), (fused, False), (sep, True), (fused, True))
            ):
                best[q] = min(best[q], _best_ms(fun, 1, cpu))
        out[name] = tuple(best)
    return out


READ_WRITE = {
    "stokes_lanczos": (10,),
    "stokes_lanczos_cut": (14,),
    "add_scaled": (0,),
    "symmlq_step": (2, 5, 6),
}
"""Array arguments a kernel reads *and* writes in place (streamed twice: in and out); every
other array argument is streamed once (read, or written)."""


def _call_bytes(name: str, args: tuple) -> float:
    """Bytes a kernel call streams: each array argument once (neighbours from cache; the STREAM
    convention counts a write once), the in-place ones of :data:`READ_WRITE` twice."""
    rw = READ_WRITE.get(name, ())
    return float(
        sum(a.nbytes * (2 if q in rw else 1) for q, a in enumerate(args) if hasattr(a, "nbytes"))
    )


class KernelLog:
    """Wall time and streamed bytes of every call of the wrapped kernels, keyed by kernel name
    and the grid of its first array argument (the multigrid level): a per-kernel, per-level
    breakdown (:func:`vcycle_breakdown`, :func:`iteration_breakdown`)."""

    def __init__(self) -> None:
        self.rows: dict[tuple[str, str], list[float]] = {}
        self._saved: list[tuple[object, str, object]] = []

    def wrap(self, mod, names: tuple[str, ...]) -> None:
        for name in names:
            fun = getattr(mod, name)
            self._saved.append((mod, name, fun))
            setattr(mod, name, self._wrapper(name, fun))

    def _wrapper(self, name: str, fun):
        def timed(*args, **kw):
            t0 = time.perf_counter()
            c0 = time.process_time()
            out = fun(*args, **kw)
            dt = time.perf_counter() - t0
            dc = time.process_time() - c0
            key = (name, "x".join(str(n) for n in args[0].shape[-3:]))  # the grid (level)
            row = self.rows.setdefault(key, [0.0, 0.0, 0.0, 0.0])
            row[0] += 1
            row[1] += dt
            row[2] += _call_bytes(name, args)
            row[3] += dc
            return out

        return timed

    def restore(self) -> None:
        for mod, name, fun in reversed(self._saved):
            setattr(mod, name, fun)
        self._saved.clear()

    def report(self, calls: int, bw: float, title: str) -> tuple[float, float]:
        """Print ms and MB per ``calls`` (per V-cycle / per iteration) and the ratio to the triad
        time of those bytes; returns the summed (ms, bytes)."""
        print(f"  {title} (per call of the whole; ideal = bytes / triad):")
        tot_t = tot_b = 0.0
        for (name, grid), (n, t, b, c) in self.rows.items():
            ms = t / calls * 1e3
            mb = b / calls
            tot_t += ms
            tot_b += mb
            ideal = mb / bw * 1e3
            print(
                f"    {name:22s} {grid:>12s} x{n / calls:4.1f}: {ms:7.2f} ms (CPU "
                f"{c / calls * 1e3:7.2f}), {mb / 1e6:7.1f} MB, ideal {ideal:6.2f} ms = "
                f"{ms / ideal if ideal else float('inf'):5.2f} x"
            )
        ideal = tot_b / bw * 1e3
        print(f"    sum of kernels: {tot_t:.2f} ms, {tot_b / 1e6:.1f} MB, ideal {ideal:.2f} ms")
        return tot_t, tot_b


MG_KERNELS = ("jacobi2_zero", "jacobi_zero", "jacobi", "residual_restrict", "prolong_jacobi")


def vcycle_breakdown(mg0, b: np.ndarray, out: np.ndarray, bw: float, reps: int = 10) -> None:
    """Per level and kernel of one V-cycle (component 0): time vs streamed bytes, the coarsest
    LU solve, and the rest of the V-cycle's wall time (Python, thread switches)."""
    from solvers.voxel import kernels as kr

    mg0.apply(b, out)
    t0 = time.perf_counter()
    for _ in range(reps):
        mg0.apply(b, out)
    plain = (time.perf_counter() - t0) / reps * 1e3
    log = KernelLog()
    log.wrap(kr, MG_KERNELS)
    lu = mg0._coarse_solve
    acc = [0.0]

    def timed_lu(bb, xx):
        t1 = time.perf_counter()
        lu(bb, xx)
        acc[0] += time.perf_counter() - t1

    mg0._coarse_solve = timed_lu
    try:
        t0 = time.perf_counter()
        for _ in range(reps):
            mg0.apply(b, out)
        wrapped = (time.perf_counter() - t0) / reps * 1e3
    finally:
        log.restore()
        mg0._coarse_solve = lu
    shapes = " ".join("x".join(map(str, lev.d.shape)) for lev in mg0.levels)
    print(f"  one V-cycle, levels {shapes}: {plain:.2f} ms (instrumented {wrapped:.2f} ms)")
    kt, kb = log.report(reps, bw, "V-cycle kernels")
    lu_ms = acc[0] / reps * 1e3
    print(
        f"    coarsest LU solve: {lu_ms:.2f} ms; rest (Python, thread switches): "
        f"{wrapped - kt - lu_ms:.2f} ms; V-cycle / ideal of its bytes: "
        f"{plain / (kb / bw * 1e3):.2f} x"
    )


def iteration_breakdown(op, rhs, e, work, bw: float, its: int) -> None:
    """Per kernel of the Krylov iteration: time vs streamed bytes (the three V-cycles are one
    row per kernel and level, summed over the components), and the rest of the wall time."""
    from solvers import voxel_stokes as vs
    from solvers.voxel import cutfaces as cf
    from solvers.voxel import kernels as kr
    from solvers.voxel import lanczos as lz
    from solvers.voxel import schur

    log = KernelLog()
    log.wrap(kr, MG_KERNELS + ("copy_dot", "scale_dot"))
    log.wrap(lz, ("stokes_lanczos", "add_scaled", "symmlq_step"))
    log.wrap(schur, ("block_sum", "pressure_block_code"))
    log.wrap(cf, ("stokes_lanczos_cut",))
    b = rhs.copy()  # outside the timing (its fresh pages, session 50)
    try:
        t0 = time.perf_counter()
        vs.krylov_run(op, b, e, work, 1e-30, its)
        wall = (time.perf_counter() - t0) / its * 1e3
    finally:
        log.restore()
    print(f"  one Krylov iteration instrumented: {wall:.2f} ms")
    kt, kb = log.report(its, bw, "iteration kernels")
    print(f"    rest (Python, coarse levels' LU and pressure cycle): {wall - kt:.2f} ms")


def _print_iteration_summary(
    pairs, paired, ratios, *, need, before, cells, bw, bw_before, bw_after
) -> None:
    """Print :func:`kernels`' fusion pairs and its iteration against the triad: the ideal at the
    run's highest triad, then each batch at the triads beside it (keyword-only: the byte counts
    and bandwidths are easy to swap)."""
    ideal = need / bw * 1e3
    best = int(np.argmin(ratios))
    meas = paired[best][0]
    for name, (t_sep, t_fused, c_sep, c_fused) in pairs.items():
        print(
            f"  {name}: separate {t_sep:.1f} ms, fused {t_fused:.1f} ms wall "
            f"(fused / separate {t_fused / t_sep:.2f}); CPU {c_sep:.1f} / {c_fused:.1f} ms "
            f"({c_fused / c_sep:.2f})"
        )
    print(
        f"  triad bandwidth {bw / 1e9:.1f} GB/s, the highest of this run (before "
        f"{bw_before / 1e9:.1f}, after {bw_after / 1e9:.1f}); one MINRES iteration streams "
        f"{need / cells:.0f} B per voxel (before the fusions {before / cells:.0f}) "
        f"= {need / 1e9:.2f} GB: ideal {ideal:.1f} ms at it"
    )
    print("  each batch of iterations against the triad measured just before and after it:")
    for (w, c, tb, ta, m), ratio in zip(paired, ratios, strict=True):
        print(
            f"    {w:6.1f} ms (CPU {c:6.1f}), triad {tb / 1e9:4.1f} / {ta / 1e9:4.1f} GB/s: "
            f"{ratio:.2f} x ideal at the higher, "
            f"{w / (need / min(tb, ta) * 1e3):.2f} x at the lower; marginal {m:6.1f} ms = "
            f"{m / (need / max(tb, ta) * 1e3):.2f} x"
        )
    marg = [m / (need / max(tb, ta) * 1e3) for _w, _c, tb, ta, m in paired]
    print(
        f"  marginal iteration (the run's start and end left out): best "
        f"{min(p[4] for p in paired):.1f} ms = {min(marg):.2f} x, median ratio "
        f"{float(np.median(marg)):.2f} x"
    )
    print(
        f"  best batch {meas:.1f} ms = {ratios[best]:.2f} x its ideal; median batch ratio "
        f"{float(np.median(ratios)):.2f} x, worst {max(ratios):.2f} x",
        flush=True,
    )


def later_cycle_state(op, rhs: np.ndarray) -> tuple:
    """``(work, solution)`` of a solve on ``op`` in its later refinement cycles, as
    :func:`solvers.voxel_stokes._solve_core` stores them at the default tol 1e-6: SYMMLQ's 24-bit
    direction, then the int8 extension, after two iterations of the first cycle.  Until session
    46 the direction stayed float32 here, a pairing no solve makes, whose parallel kernel
    ``psdesign warmup`` never compiles: ``symmlq_step`` ran on one thread (56 of ~180 ms per
    iteration at 200^3, wall = CPU)."""
    from solvers import voxel_stokes as vs
    from solvers.voxel import lanczos as lz

    work = vs.MinresWork.of(op)
    e = lz.Solution(op.shape, work.packing)
    vs.krylov_run(op, rhs.copy(), e, work, 1e-30, 2)
    work.store_directions(vs._later_bits(work, e.short(1e-6)))
    e.extend(1e-6)
    # compile / load the kernels of the extended solution here, not in the first timed batch
    # (a stale numba cache made that batch 6x the others, session 31)
    vs.krylov_run(op, rhs.copy(), e, work, 1e-30, 2)
    return work, e


def kernels(n: int, reps: int = 5, subvoxel: bool = False, batches: int = 6) -> dict[str, float]:
    """Time the solver's kernels and one MINRES iteration on the Toray-like ``n^3`` grid
    (``subvoxel``: with its exact fibre distance, sub-voxel walls), and compare the iteration
    with the bytes it must stream over the measured triad bandwidth (printed; also returned:
    ``bytes_per_voxel``, ``ideal_ms``, ``iteration_ms``, ``ratio``, ``triad_before``,
    ``triad_after``).

    The iteration is timed in ``batches`` runs of 20 iterations, each between two triad
    measurements (:func:`paired_batches`): the machine's memory bandwidth moves with the host's
    other tenants, so a batch is compared with the higher of the two triads beside it (the
    bandwidth the machine showed that minute; the ratio at the lower one is printed beside it).
    The best batch ratio is returned as ``ratio``, the median and the worst too
    (``ratio_median``, ``ratio_worst``).  The per-kernel tables use the highest triad of the
    run."""
    from solvers import voxel_stokes as vs
    from solvers.voxel import kernels as kr

    _warm_parallel()
    phi = toray_like(n, distance=True) * n if subvoxel else None
    solid = _grid(n) if phi is None else phi <= 0
    bw_before = triad_bandwidth()
    with vs._threads(solid.size):
        op = vs._Stokes.build(solid, phi)
        del phi
        rng = np.random.default_rng(0)
        x = rng.random(op.shape, dtype=np.float32)
        y = np.empty_like(x)
        z = np.empty_like(x)
        mg0 = op.mg[0]
        lev = mg0.levels[0]
        b = x[0].copy()
        t = np.empty_like(b)
        rows = {
            "operator product (Lanczos kernel, + dot)": _best_ms(
                lambda: op.lanczos(x, 1.0, 0.0, y), reps
            ),
            "preconditioner (3 V-cycles + dot)": _best_ms(lambda: op.precondition(x, z), reps),
            "one V-cycle": _best_ms(lambda: mg0.apply(b, t), reps),
            "Jacobi sweep (finest)": _best_ms(lambda: kr.jacobi(lev.d, *lev.c, b, b, t, 0.9), reps),
            "dot product (4 fields)": _best_ms(lambda: kr.dot(x, y), reps),
        }
        pairs = _fusion_pairs(op, reps)
        rhs = np.empty(op.shape, np.float32)
        op.residual(np.zeros(op.shape), 0, rhs)
        its = 20
        work, e = later_cycle_state(op, rhs)
        need = iteration_bytes(op, lo_bytes=e.lo.itemsize, w_bytes=3 if work.wm.size else 4)
        with kernel_log() as klog:
            paired = paired_batches(_krylov_batch(op, rhs, e, work), its, batches)
        if klog.fallback:  # a timed kernel on one thread would be timed under the name of two
            print(f"  WARNING: on one thread (parallel twin not compiled): {sorted(klog.fallback)}")
        ratios = [w / (need / max(tb, ta) * 1e3) for w, _c, tb, ta, _m in paired]
        best = int(np.argmin(ratios))
        rows["one MINRES iteration"] = paired[best][0]
        rows["one MINRES iteration, median of the batches"] = float(
            np.median([p[0] for p in paired])
        )
        rows["one MINRES iteration, CPU time (all threads)"] = paired[best][1]
        bw_after = triad_bandwidth()
        bw = max([bw_before, bw_after] + [max(p[2], p[3]) for p in paired])
        before = iteration_bytes(op, fused=False)
        load = os.getloadavg()[0]
        print(f"kernels at {n}^3 ({nb.get_num_threads()} threads available, load {load:.1f}):")
        for name, val in rows.items():
            print(f"  {name}: {val:.1f} ms")
        vcycle_breakdown(mg0, b, t, bw)
        iteration_breakdown(op, rhs, e, work, bw, its)
    ideal = need / bw * 1e3
    meas = rows["one MINRES iteration"]
    med = rows["one MINRES iteration, median of the batches"]
    _print_iteration_summary(
        pairs,
        paired,
        ratios,
        need=need,
        before=before,
        cells=solid.size,
        bw=bw,
        bw_before=bw_before,
        bw_after=bw_after,
    )
    return {
        "bytes_per_voxel": need / solid.size,
        "ideal_ms": ideal,
        "iteration_ms": meas,
        "ratio": ratios[best],
        "iteration_median_ms": med,
        "ratio_median": float(np.median(ratios)),
        "ratio_worst": max(ratios),
        "marginal_ms": min(p[4] for p in paired),
        "ratio_marginal_median": float(
            np.median([r * p[4] / p[0] for r, p in zip(ratios, paired, strict=True)])
        ),
        "triad_before": bw_before,
        "triad_after": bw_after,
    }


def paired_batches(run, its: int, batches: int) -> list[tuple[float, ...]]:
    """Time ``batches`` calls of ``run(its)`` (``its`` Krylov iterations each), each between two
    triad measurements (best of 3): per batch the wall and CPU ms per iteration, the triad
    before and after it (B/s) and the marginal wall ms of one iteration, ``(T(its) - T(1)) /
    (its - 1)`` with ``T(1)`` timed right after it.  The host's bandwidth moves between two
    levels from minute to minute (37-39 or 57-64 GB/s on this VM, under every wait policy,
    session 26), so a batch is only compared with the bandwidth measured beside it.

    ``run(k)`` must set up its right-hand side outside its timed part (:func:`_krylov_batch`):
    a run's start (the preconditioner of the right-hand side, clearing the direction) and its
    end (the move to the CG point) are one pass each per run, not per iteration; in batches of
    20 they add about (65 + 22) / 20 ms per iteration at 200^3 idle (8-14 ms measured at load 6,
    session 50), where a solve's runs are ~180 iterations long; the marginal time leaves them
    out."""
    out = []
    for _ in range(batches):
        tb = triad_bandwidth(reps=3)
        wall, cpu = run(its)
        one, _ = run(1)
        marginal = (wall - one) / (its - 1) * 1e3
        out.append((wall / its * 1e3, cpu / its * 1e3, tb, triad_bandwidth(reps=3), marginal))
    return out


def _krylov_batch(op, rhs: np.ndarray, e, work):
    """``run(k)`` for :func:`paired_batches`: ``k`` Krylov iterations from ``rhs`` on ``op``,
    returning their wall and CPU seconds; the right-hand side is copied into a buffer kept
    between runs before the clock starts (a fresh ``rhs.copy()`` inside the timing faulted in
    128 MB of new pages at 200^3 every batch, up to 0.5 s on a busy host, session 50)."""
    from solvers import voxel_stokes as vs

    buf = np.empty_like(rhs)

    def run(k: int) -> tuple[float, float]:
        np.copyto(buf, rhs)
        t0 = time.perf_counter()
        c0 = time.process_time()
        vs.krylov_run(op, buf, e, work, 1e-30, k)
        return time.perf_counter() - t0, time.process_time() - c0

    return run


THREAD_MODES = {
    "1 thread": {"NUMBA_NUM_THREADS": "1"},
    "default": {},
    "libgomp spin (old default)": {"_SPIN": "1"},
    "libgomp short spin (GOMP_SPINCOUNT=10000)": {"_SPIN": "1", "GOMP_SPINCOUNT": "10000"},
    "workqueue layer": {"NUMBA_THREADING_LAYER": "workqueue"},
}


def _grid(n: int) -> np.ndarray:
    """Test grid of the thread benchmark: PuMA fibres_64 at 64, else Toray-like (cached)."""
    if n == 64:
        return np.load(BENCH / "fibres_64.npz")["solid"].astype(bool)
    cache = Path(f"/tmp/psdesign_bench_toray_{n}.npy")
    if not cache.exists():
        np.save(cache, toray_like(n))
    return np.load(cache)


def _timed(mod, name: str, acc: dict[str, float]) -> None:
    """Wrap ``mod.name`` so that its wall time adds up in ``acc[name]`` (benchmark only)."""
    fun = getattr(mod, name)

    def wrapper(*args, **kw):
        t0 = time.perf_counter()
        try:
            return fun(*args, **kw)
        finally:
            acc[name] = acc.get(name, 0.0) + time.perf_counter() - t0

    setattr(mod, name, wrapper)


def _warm_parallel() -> None:
    """Compile (or load) the kernels a solve uses, the parallel ones too, outside the timings.

    Grids below :data:`solvers.jit.COMPILE_PARALLEL_ABOVE` cells (200^3 is) run the serial
    twins when the parallel kernels are not in numba's cache yet, which would time one thread
    under the name of two; the warm-up solve is on a grid above the one-thread threshold.  A
    second warm-up solve loads the serial twins, which a solve below
    :func:`solvers.voxel.threads.solve_min_cells` runs even with two threads available: without
    it a 64^3 timing with two threads available paid their loading (~0.1 s, session 22), the
    one-thread timing did not."""
    import solvers.jit as jit
    from solvers.voxel import threads as vthreads

    before = jit.COMPILE_PARALLEL_ABOVE, vthreads.SOLVE_PARALLEL_MIN_CELLS
    jit.COMPILE_PARALLEL_ABOVE = vthreads.SOLVE_PARALLEL_MIN_CELLS = 0
    try:
        warm = np.zeros((48, 48, 48), dtype=bool)
        warm[:, :4, :] = True
        warm[:4, :, :] = True
        solve_voxel_stokes(warm, 1.0, "z", max_iter=3)
    finally:
        jit.COMPILE_PARALLEL_ABOVE, vthreads.SOLVE_PARALLEL_MIN_CELLS = before
    solve_voxel_stokes(warm[:24, :24, :24], 1.0, "z", max_iter=3)  # the serial twins


def thread_case(n: int, its: int, min_cells: int | None = None) -> None:
    """One timing in this process (prints one JSON line): generation of the grid, then one
    ``solve_voxel_stokes`` (at most ``its`` MINRES iterations; 0 = to convergence), split into
    the set-up (``_setup_grid``: operator build and multigrid set-up; ``percolates``), the
    iterations (``_solve_core``) and the rest (checks, result).  ``min_cells`` replaces the
    per-level threshold :data:`solvers.voxel.threads.PARALLEL_MIN_CELLS` and the solve's
    :data:`~solvers.voxel.threads.SOLVE_PARALLEL_MIN_CELLS`."""
    if os.environ.pop("_SPIN", None):
        os.environ.pop("OMP_WAIT_POLICY", None)  # before the first parallel region
    from solvers import voxel_stokes as vs
    from solvers.voxel import threads as vthreads

    if min_cells is not None:  # both thresholds: the sweep sets where two threads start
        vthreads.PARALLEL_MIN_CELLS = vthreads.SOLVE_PARALLEL_MIN_CELLS = min_cells
    _warm_parallel()
    if n > 64:  # warm the parallel generation kernel outside the timing
        _rasterise(8, np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]]), 0.1, np.zeros((8,) * 3, bool))
    acc: dict[str, float] = {}
    for name in ("_setup_grid", "percolates", "_solve_core"):
        _timed(vs, name, acc)
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    solid = np.load(BENCH / "fibres_64.npz")["solid"].astype(bool) if n == 64 else toray_like(n)
    t_gen = time.perf_counter() - t0
    res = solve_voxel_stokes(solid, 1.0 / n, "x", tol=1e-6, max_iter=its or 2000)
    wall = time.perf_counter() - t0
    row = {
        "wall": wall,
        "cpu": time.process_time() - cpu0,
        "its": res.iterations,
        "generate": t_gen,
        "setup": acc["_setup_grid"] + acc["percolates"],
        "operator+multigrid": acc["_setup_grid"],
        "percolates": acc["percolates"],
        "iterations": acc["_solve_core"],
        "solve": res.wall_time_s,
    }
    print(json.dumps(row))


PHASES = ("wall", "generate", "solve", "setup", "iterations")


def _run_modes(n: int, its: int, reps: int, modes: dict[str, dict[str, str]], extra: dict) -> dict:
    """Every mode ``reps`` times, each timing in its own process, the modes interleaved."""
    here = Path(__file__).resolve()
    times: dict[str, list[dict]] = {m: [] for m in modes}
    for _ in range(reps):
        for mode, env in modes.items():
            args = [sys.executable, str(here), "_threadcase", str(n), str(its)]
            if mode in extra:
                args.append(str(extra[mode]))
            out = subprocess.run(
                args, env={**os.environ, **env}, capture_output=True, text=True, check=True
            )
            times[mode].append(json.loads(out.stdout.strip().splitlines()[-1]))
    return times


def _print_modes(times: dict[str, list[dict]]) -> dict[str, dict[str, float]]:
    """Medians of each phase per mode and the ratio 1-thread / mode (speed-up, > 1 = faster)."""
    med = {
        m: {k: statistics.median(r[k] for r in rows) for k in (*PHASES, "cpu", "its")}
        for m, rows in times.items()
    }
    ref = med["1 thread"]
    for mode, m in med.items():
        runs = ", ".join(f"{r['wall']:.2f}" for r in times[mode])
        print(
            f"  {mode:30s} wall {m['wall']:7.2f} s (runs {runs}) cpu {m['cpu']:7.2f} s "
            f"its {m['its']:.0f} | generate {m['generate']:.2f} s, solve {m['solve']:.2f} s "
            f"(set-up {m['setup']:.2f} s, iterations {m['iterations']:.2f} s)",
            flush=True,
        )
        print(
            "  "
            + " " * 30
            + " speed-up vs 1 thread: "
            + ", ".join(f"{k} {ref[k] / m[k]:.2f}x" for k in PHASES),
            flush=True,
        )
    return med


def threads(
    sizes: list[int],
    reps: int = 2,
    its: int = 20,
    modes: str = "all",
    competitor: str = "both",
    min_cells: tuple[int, ...] = (),
) -> None:
    """Default thread setting vs one thread (and the other modes), side by side, without and
    with one CPU-bound competing process (a busy loop started here); every timing in its own
    process, the modes interleaved.  Prints the medians of the whole run (generation + solve),
    the set-up and the iterations, and each one's speed-up over one thread.  ``min_cells``:
    extra default-thread modes with that coarse-level threshold."""
    sel = THREAD_MODES if modes == "all" else {m: THREAD_MODES[m] for m in ("1 thread", "default")}
    sel = dict(sel)
    extra = {}
    for mc in min_cells:
        sel[f"default, levels >= {mc} cells"] = {}
        extra[f"default, levels >= {mc} cells"] = mc
    states = {"both": (False, True), "no": (False,), "yes": (True,)}[competitor]
    for n in sizes:
        for comp in states:
            busy = None
            if comp:
                busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            load = os.getloadavg()[0]
            try:
                times = _run_modes(n, its, reps, sel, extra)
            finally:
                if busy is not None:
                    busy.kill()
                    busy.wait()
            what = "full solve" if its == 0 else f"at most {its} MINRES iterations"
            print(
                f"{n}^3 ({what}), {'with' if comp else 'without'} a competitor, "
                f"load average before {load:.1f}:",
                flush=True,
            )
            _print_modes(times)


def speedup(n: int = 200, reps: int = 1) -> None:
    """The idle check of issue 16 in one command: 1 thread vs the default, full solves of the
    Toray-like ``n^3`` grid (whole run and iterations only), then the bandwidth ratio of one
    MINRES iteration with the default threads (:func:`kernels`), in its own process."""
    threads([n], reps=reps, its=0, modes="default", competitor="no")
    here = Path(__file__).resolve()
    subprocess.run([sys.executable, str(here), "kernels", str(n)], check=True)


def sweep_cost(sizes: tuple[int, ...] = (64, 100, 200), reps: int = 20) -> None:
    """One-thread cost per cell (ns, best of ``reps``) of the finest-level multigrid kernels
    (serial twins, unit couplings, a random 80 % fluid operator) at each size: at 64^3-100^3
    their arrays (3-13 MB) sit in L3, so the figure is mostly their instructions; at 200^3
    they stream from memory.  Session 26: ``jacobi`` 0.52-0.60 ns per cell from L3, 0.83-0.87
    from memory, where its 13 B per cell at the one-thread triad (33 GB/s) would take 0.39:
    the sweeps are bound by their instructions as much as by bandwidth (a bare flat loop of
    the same arithmetic, no row ends, no dot, no prefetch blocks: 0.29 from L3)."""
    for n in sizes:
        cost = _sweep_cost_at(n, reps)
        print(
            f"  {n}^3, one thread, ns per cell: "
            + ", ".join(f"{k} {v:.3f}" for k, v in cost.items())
        )


def _sweep_cost_at(n: int, reps: int) -> dict[str, float]:
    """:func:`sweep_cost` at ``n^3``: ns per cell of each kernel."""
    from solvers.voxel import kernels as kr

    rng = np.random.default_rng(0)
    d = np.where(rng.random((n, n, n)) < 0.8, 6, 0).astype(np.uint8)
    cc = kr.unit_couplings(n)
    x = (rng.random((n, n, n), dtype=np.float32) * (d > 0)).astype(np.float32)
    b, out = x.copy(), np.empty_like(x)
    xc = rng.random((n // 2,) * 3, dtype=np.float32)
    rc = np.empty_like(xc)
    calls = {
        "jacobi": lambda: kr.jacobi.serial(d, *cc, x, b, out, 0.9),
        "jacobi2_zero": lambda: kr.jacobi2_zero.serial(d, *cc, b, out, 0.9, 1),
        "residual_restrict": lambda: kr.residual_restrict.serial(d, *cc, x, b, 2, 2, 2, rc),
        "prolong_jacobi": lambda: kr.prolong_jacobi.serial(
            d, *cc, x, xc, 2, 2, 2, 1.6, b, out, 0.9, 1
        ),
        "jacobi_zero (one row loop)": lambda: kr.jacobi_zero.serial(d, b, out, 0.9),
    }
    return {k: _best_ms(f, reps) * 1e6 / n**3 for k, f in calls.items()}


def sweep_operands(n: int):
    """``d, couplings, x, b, out`` of one finest-level Jacobi sweep at ``n^3``: the component
    operator of a random 80 % fluid grid (seed 0), its unit couplings, a random iterate (0 on
    inactive unknowns), ``b = x`` and an output array."""
    from solvers.voxel import kernels as kr
    from solvers.voxel import multigrid as mg

    rng = np.random.default_rng(0)
    d, _ = mg.component_operator(rng.random((n, n, n)) > 0.2, 0)
    x = (rng.standard_normal(d.shape) * (d > 0)).astype(np.float32)
    return d, kr.unit_couplings(n), x, x.copy(), np.empty_like(x)


def sweep_vs_triad(n: int = 200, rounds: int = 25, reps: int = 5) -> None:
    """Does a Jacobi sweep follow the two levels of the two-thread triad?  Per round: the triad
    (best of 3), ``jacobi`` at ``n^3`` on the default threads and on one (best of ``reps``,
    ns per cell; a random 80 % fluid component operator, unit couplings), the triad again.
    Session 28 (``n = 200``): one thread 0.86-1.04 ns per cell at either level; two threads
    0.52-0.67 (1.3-1.8x) beside a 30-45 GB/s triad, 0.43-0.59 (1.5-2.1x; most 0.43-0.50 at
    1.8-2.1x) beside 50-67 GB/s.  At the higher level the sweep scales with the threads: each
    thread is then bound by its own instructions and memory latency, not the shared bandwidth."""
    from solvers.voxel import kernels as kr

    _warm_parallel()  # else below COMPILE_PARALLEL_ABOVE "two threads" could be the serial twin
    d, cc, x, b, out = sweep_operands(n)
    avail = nb.get_num_threads()

    def sweep(threads: int) -> float:
        nb.set_num_threads(threads)
        try:
            return _best_ms(lambda: kr.jacobi(d, *cc, x, b, out, 0.9), reps) * 1e6 / n**3
        finally:
            nb.set_num_threads(avail)

    sweep(1), sweep(avail)  # compile / load both twins
    for _ in range(rounds):
        before, two, one = triad_bandwidth(reps=3), sweep(avail), sweep(1)
        after = triad_bandwidth(reps=3)
        print(
            f"  triad {before / 1e9:5.1f} / {after / 1e9:5.1f} GB/s; jacobi {n}^3, ns per cell: "
            f"{avail} threads {two:.3f}, 1 thread {one:.3f} ({one / two:.2f}x)",
            flush=True,
        )


def main(argv: list[str]) -> None:
    what = argv[1] if len(argv) > 1 else "puma"
    if what == "_threadcase":
        thread_case(int(argv[2]), int(argv[3]), int(argv[4]) if len(argv) > 4 else None)
        return
    if what == "threads":  # sizes, then optional reps=R its=I modes=default competitor=no
        opts = dict(a.split("=") for a in argv[2:] if "=" in a)
        sizes = [int(a) for a in argv[2:] if "=" not in a] or [64, 200]
        cells = tuple(int(c) for c in opts["mincells"].split(",")) if "mincells" in opts else ()
        threads(
            sizes,
            int(opts.get("reps", 2)),
            int(opts.get("its", 20)),
            opts.get("modes", "all"),
            opts.get("competitor", "both"),
            cells,
        )
        return
    if what == "sweep-cost":
        sweep_cost(tuple(int(a) for a in argv[2:]) or (64, 100, 200))
        return
    if what == "speedup":
        speedup(*[int(a) for a in argv[2:3]] or [200])
        return
    if what == "sweep-vs-triad":
        sweep_vs_triad(*[int(a) for a in argv[2:4]])
        return
    # warm-up: compile the numba kernels outside the timings
    warm = np.zeros((16, 16, 16), dtype=bool)
    warm[:, :2, :] = True
    res0 = solve_voxel_stokes(warm, 1.0, "z")
    if what == "cylinders":
        cylinders()
    elif what == "arrays":
        arrays(tuple(int(a) for a in argv[2:]) or (32, 40, 64, 96))
    elif what == "kernels":
        sub = "subvoxel" in argv[2:]
        for n in [int(a) for a in argv[2:] if a != "subvoxel"] or [200]:
            kernels(n, subvoxel=sub)
    elif what == "base":
        print(f"baseline after warm-up: peak RSS {res0.peak_memory_mb:.0f} MB")
    elif what == "puma":
        sizes = [int(a) for a in argv[2:]] or [32, 64]
        for n in sizes:
            solid = np.load(BENCH / f"fibres_{n}.npz")["solid"].astype(bool)
            run(solid, 1.0 / n, f"PuMA fibres_{n} (PuMA K_zz {PUMA[n][0]}, {PUMA[n][1]} s)")
    elif what == "toray-subvoxel":
        for n in [int(a) for a in argv[2:]] or [100]:
            dist = toray_like(n, distance=True) * 100e-6
            run(dist <= 0.0, 100e-6 / n, f"toray {n}^3", "x", distance=dist)
    else:
        for n in [int(a) for a in argv[2:]] or [100]:
            t = time.perf_counter()
            solid = toray_like(n)
            print(f"toray {n}^3 generated in {time.perf_counter() - t:.1f} s", flush=True)
            run(solid, 100e-6 / n, f"toray {n}^3", "x")


if __name__ == "__main__":
    main(sys.argv)
