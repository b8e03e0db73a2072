"""Benchmark of the periodic MAC voxel Stokes solver (solvers.voxel_stokes).

Usage::

    python benchmarks/bench_voxel.py puma            # PuMA geometries 32^3 and 64^3 (K_zz vs PuMA)
    python benchmarks/bench_voxel.py toray 100 200   # Toray-like fibrous grids of the given sizes
    python benchmarks/bench_voxel.py toray-subvoxel 100  # the same with the exact fibre distance
    python benchmarks/bench_voxel.py base            # warm-up only: the numba/Python RSS baseline
    python benchmarks/bench_voxel.py cylinders       # square arrays vs Sangani & Acrivos (1982)
    python benchmarks/bench_voxel.py arrays          # sub-voxel vs staircase, square/hex arrays
    python benchmarks/bench_voxel.py kernels 200     # per-kernel and per-iteration times (ms)
    python benchmarks/bench_voxel.py threads 64 200  # 1 vs 2 threads, with and without a competitor
    python benchmarks/bench_voxel.py threads 200 reps=1 its=10  # fewer repetitions / iterations

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
from solvers.voxel_stokes import solve_voxel_stokes

BENCH = Path(__file__).resolve().parents[1] / "tests" / "data"  # vendored peer geometry
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


def _vcycle_bytes(mg0) -> float:
    """Bytes one V-cycle must stream (every array touched once per pass; neighbours from
    cache), summed over the levels above the coarsest (the LU is negligible)."""
    total = 0.0
    levels = mg0.levels
    for li, lev in enumerate(levels[:-1]):
        n = lev.d.size
        vec = 4.0
        opb = lev.d.itemsize + 3 * lev.c.itemsize
        coarse = levels[li + 1].d.size * vec / n
        sweep = opb + 3 * vec  # d, c, x, b read; x_new written
        per = lev.d.itemsize + 2 * vec  # Jacobi from zero
        per += (mg0.pre - 1) * sweep  # remaining pre-smoothing sweeps
        per += opb + 2 * vec + coarse  # residual + restriction
        per += lev.d.itemsize + 2 * vec + coarse  # prolongation (x read and written)
        per += mg0.pre * sweep  # post-smoothing
        total += per * n
    return total


def iteration_bytes(op) -> float:
    """Bytes one MINRES iteration must stream (the kernels of :func:`solvers.voxel_stokes._minres`
    as they are fused now, each array read or written once per kernel)."""
    n = op.fluid.size
    vec4 = 16.0  # one 4-field float32 vector per cell
    ops = sum(d.itemsize + 3 * c.itemsize for d, c in zip(op.d, op.c, strict=True)) + 1.0
    if op.w is not None:
        ops += 12.0
    apply = ops + 3 * vec4  # z, K z, r1
    lanczos = 4 * vec4
    prec = sum(_vcycle_bytes(m) for m in op.mg) / n + (8.0 if op.p_scale is None else 12.0)
    dot = 2 * vec4
    update = 4 * vec4 + 2 * 32.0  # z, w read; w1 read + written; x (float64) read + written
    return n * (apply + lanczos + prec + dot + update)


def kernels(n: int, reps: int = 5) -> None:
    """Time the solver's kernels and one MINRES iteration on the Toray-like ``n^3`` grid, and
    compare the iteration with the bytes it must stream over the measured triad bandwidth."""
    from solvers import voxel_stokes as vs
    from solvers.voxel import kernels as kr

    solid = _grid(n)
    bw = triad_bandwidth()
    with vs._threads(solid.size):
        op = vs._Stokes.build(solid)
        rng = np.random.default_rng(0)
        x = rng.random(op.shape, dtype=np.float32)
        y = np.empty_like(x)
        z = np.empty_like(x)
        mg0 = op.mg[0]
        lev = mg0.levels[0]
        b = x[0].copy()
        t = np.empty_like(b)

        def ms(fun) -> float:
            fun()
            t0 = time.perf_counter()
            for _ in range(reps):
                fun()
            return (time.perf_counter() - t0) / reps * 1e3

        rows = {
            "operator product (+2 dots)": ms(lambda: op.apply(x, y, z)),
            "preconditioner (3 V-cycles)": ms(lambda: op.precondition(x, z)),
            "one V-cycle": ms(lambda: mg0.apply(b, t)),
            "Jacobi sweep (finest)": ms(lambda: kr.jacobi(lev.d, *lev.c, b, b, t, 0.9)),
            "dot product (4 fields)": ms(lambda: kr.dot(x, y)),
        }
        rhs = np.empty(op.shape, np.float32)
        op.residual(np.zeros(op.shape), 0, rhs)
        bufs = [np.empty(op.shape, np.float32) for _ in range(5)]
        e = np.zeros(op.shape)
        its = 20
        vs._minres(op, rhs.copy(), e, bufs, 1e-30, 2)
        t0 = time.perf_counter()
        vs._minres(op, rhs.copy(), e, bufs, 1e-30, its)
        rows["one MINRES iteration"] = (time.perf_counter() - t0) / its * 1e3
        need = iteration_bytes(op)
    load = os.getloadavg()[0]
    print(f"kernels at {n}^3 ({nb.get_num_threads()} threads available, load {load:.1f}):")
    for name, val in rows.items():
        print(f"  {name}: {val:.1f} ms")
    ideal = need / bw * 1e3
    meas = rows["one MINRES iteration"]
    print(
        f"  triad bandwidth {bw / 1e9:.1f} GB/s; one MINRES iteration streams "
        f"{need / solid.size:.0f} B per voxel = {need / 1e9:.2f} GB: ideal {ideal:.1f} ms, "
        f"measured {meas:.1f} ms = {meas / ideal:.2f} x ideal"
    )


THREAD_MODES = {
    "1 thread": {"NUMBA_NUM_THREADS": "1"},
    "default": {},
    "libgomp spin (old default)": {"_SPIN": "1"},
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


def thread_case(n: int, its: int) -> None:
    """One timing in this process: the full solve at 64^3, ``its`` MINRES iterations (solver
    core only) above; prints one JSON line."""
    if os.environ.pop("_SPIN", None):
        os.environ.pop("OMP_WAIT_POLICY", None)  # before the first parallel region
    from solvers import voxel_stokes as vs

    warm = np.zeros((16, 16, 16), dtype=bool)
    warm[:, :2, :] = True
    solve_voxel_stokes(warm, 1.0, "z")
    solid = _grid(n)
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    if n == 64:
        res = solve_voxel_stokes(solid, 1.0 / n, "z", tol=1e-6)
        iters = res.iterations
    else:
        op = vs._Stokes.build(solid)
        with vs._threads(solid.size):
            vs._solve_core(op, 0, 1e-6, 2)  # warm the caches of this grid
            cpu0 = time.process_time()
            t0 = time.perf_counter()
            _, info = vs._solve_core(op, 0, 1e-6, its)
        iters = info["iterations"]
    wall = time.perf_counter() - t0
    print(json.dumps({"wall": wall, "cpu": time.process_time() - cpu0, "its": iters}))


def threads(sizes: list[int], reps: int = 2, its: int = 20) -> None:
    """Default thread setting vs one thread, side by side, without and with one CPU-bound
    competing process (a busy loop started here); every timing in its own process, the modes
    interleaved.  Prints the medians and the ratio to the 1-thread time."""
    here = Path(__file__).resolve()
    for n in sizes:
        for competitor in (False, True):
            busy = None
            if competitor:
                busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            times: dict[str, list[tuple[float, float]]] = {m: [] for m in THREAD_MODES}
            load = os.getloadavg()[0]
            try:
                for _ in range(reps):
                    for mode, env in THREAD_MODES.items():
                        out = subprocess.run(
                            [sys.executable, str(here), "_threadcase", str(n), str(its)],
                            env={**os.environ, **env},
                            capture_output=True,
                            text=True,
                            check=True,
                        )
                        row = json.loads(out.stdout.strip().splitlines()[-1])
                        times[mode].append((row["wall"], row["cpu"]))
            finally:
                if busy is not None:
                    busy.kill()
                    busy.wait()
            what = "full solve" if n == 64 else f"{its} MINRES iterations"
            print(
                f"{n}^3 ({what}), {'with' if competitor else 'without'} a competitor, "
                f"load average before {load:.1f}:",
                flush=True,
            )
            ref = statistics.median(w for w, _ in times["1 thread"])
            for mode, vals in times.items():
                wall = statistics.median(w for w, _ in vals)
                cpu = statistics.median(c for _, c in vals)
                runs = ", ".join(f"{w:.2f}" for w, _ in vals)
                print(
                    f"  {mode:28s} wall {wall:7.2f} s (runs {runs})"
                    f"  cpu {cpu:7.2f} s  wall / 1-thread {wall / ref:.2f}",
                    flush=True,
                )


def main(argv: list[str]) -> None:
    what = argv[1] if len(argv) > 1 else "puma"
    if what == "_threadcase":
        thread_case(int(argv[2]), int(argv[3]))
        return
    if what == "threads":  # sizes, then optional reps=R its=I
        opts = dict(a.split("=") for a in argv[2:] if "=" in a)
        sizes = [int(a) for a in argv[2:] if "=" not in a] or [64, 200]
        threads(sizes, int(opts.get("reps", 2)), int(opts.get("its", 20)))
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
        for n in [int(a) for a in argv[2:]] or [200]:
            kernels(n)
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
