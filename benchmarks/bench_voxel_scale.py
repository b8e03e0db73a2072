"""Scale of the voxel Stokes solver: a Toray-like fibre RVE of ``n`` um at 1 um voxels.

Usage (one size per process, for the peak memory)::

    /usr/bin/time -v python benchmarks/bench_voxel_scale.py 400     # 400 um cube, 64 M voxels
    /usr/bin/time -v python benchmarks/bench_voxel_scale.py 100 x   # direction (default x)
    python benchmarks/bench_voxel_scale.py memory 64   # traced bytes per cell (tracemalloc)
    python benchmarks/bench_voxel_scale.py schur 100 200   # coarse pressure term off / on
    python benchmarks/bench_voxel_scale.py schur-cost 100  # preconditioner time off / on
    python benchmarks/bench_voxel_scale.py cycles 100 [block]  # iterations per refinement cycle,
                                                    # Ritz values (coarse pressure block size)

The material is that of ``bench_voxel.py toray`` (7 um straight fibres with a random centre and
a direction flattened towards the x-y plane, z-component scaled by 0.3, periodic by minimum
image, porosity 0.8), but in a box of ``n`` um instead of 100 um, so the number of fibres grows
with the volume (789 at 400 um: they span the box) and ``n = 100`` is exactly
``toray_like(100)``.  The fibres are rasterised one at a time near their own axis (samples
every half voxel along it, the same exact minimum-image test as ``bench_voxel._rasterise``),
so the grid costs O(fibres x fibre length) instead of O(fibres x n^3), and the porosity is
counted on the grid itself (the grid is kept in ``/tmp/psdesign_scale_box_<n>.npz`` for the
next run).  A warm-up solve on a 48^3 box compiles (or loads) the parallel kernels first, so
every size runs the same kernels on numba's default threads.  Prints the generation time, K,
iterations, residual, solve time, the solver's own peak RSS and the load average before and
after.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numba as nb
import numpy as np

DIAMETER_UM = 7.0
POROSITY = 0.8


@nb.njit(cache=False)  # no cache: a benchmark file
def _add_fibre(n, c, d, radius, out):
    """Mark the cells of ``out`` (``n^3``, unit box) whose centre lies within ``radius`` of the
    periodic straight fibre through ``c`` along ``d`` (minimum image around ``c``); returns the
    number of cells newly marked."""
    half = int(radius * n) + 2
    step = 0.5 / n
    tmax = 0.87 + radius
    new = 0
    m = int(2.0 * tmax / step) + 1
    for s in range(m + 1):
        t0 = -tmax + s * step
        ci = int(np.floor((c[0] + t0 * d[0]) * n))
        cj = int(np.floor((c[1] + t0 * d[1]) * n))
        ck = int(np.floor((c[2] + t0 * d[2]) * n))
        for di in range(-half, half + 1):
            i = (ci + di) % n
            x = (i + 0.5) / n
            for dj in range(-half, half + 1):
                j = (cj + dj) % n
                y = (j + 0.5) / n
                for dk in range(-half, half + 1):
                    k = (ck + dk) % n
                    if out[i, j, k]:
                        continue
                    z = (k + 0.5) / n
                    rx = x - c[0]
                    ry = y - c[1]
                    rz = z - c[2]
                    rx -= np.floor(rx + 0.5)
                    ry -= np.floor(ry + 0.5)
                    rz -= np.floor(rz + 0.5)
                    t = rx * d[0] + ry * d[1] + rz * d[2]
                    px = rx - t * d[0]
                    py = ry - t * d[1]
                    pz = rz - t * d[2]
                    if px * px + py * py + pz * pz < radius * radius:
                        out[i, j, k] = True
                        new += 1
    return new


def toray_box(n: int, seed: int = 0) -> tuple[np.ndarray, int]:
    """Solid mask of a Toray-like RVE of ``n`` um at 1 um voxels and its number of fibres."""
    rng = np.random.default_rng(seed)
    out = np.zeros((n, n, n), dtype=bool)
    radius = 0.5 * DIAMETER_UM / n
    solid = 0
    fibres = 0
    while 1.0 - solid / out.size > POROSITY:
        d = rng.normal(size=3)
        d[2] *= 0.3
        d /= np.linalg.norm(d)
        c = rng.random(3)
        solid += _add_fibre(n, c, d, radius, out)
        fibres += 1
    return out, fibres


def traced_memory(n: int) -> None:
    """Traced peak (numpy allocations) per solved cell of one solve: PuMA fibres_32 and the
    ``bench_voxel.toray_like(n)`` grid, staircase and sub-voxel (kernels loaded first)."""
    import tracemalloc

    from bench_voxel import toray_like

    from solvers.voxel_stokes import solve_voxel_stokes

    warm = np.zeros((16, 16, 16), dtype=bool)
    warm[:, :2, :] = True
    solve_voxel_stokes(warm, 1.0, "z")
    slab = np.broadcast_to(np.abs(np.arange(16) + 0.5 - 8.0)[None, :, None] - 2.0, (16,) * 3)
    solve_voxel_stokes(slab <= 0.0, 1.0, "x", distance=slab.copy())  # sub-voxel kernels
    data = Path(__file__).resolve().parents[1] / "tests" / "data" / "fibres_32.npz"
    dist = toray_like(n, distance=True) * 100e-6
    cases = [
        ("PuMA fibres_32 staircase", np.load(data)["solid"].astype(bool), None, "z"),
        (f"Toray-like {n}^3 staircase", toray_like(n), None, "x"),
        (f"Toray-like {n}^3 sub-voxel", dist <= 0.0, dist, "x"),
    ]
    for label, solid, distance, direction in cases:
        h = 100e-6 / solid.shape[0]
        tracemalloc.start()
        res = solve_voxel_stokes(solid, h, direction, distance=distance)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        print(
            f"{label}: traced peak {peak / solid.size:.1f} B per cell, K-column mean velocity "
            f"{res.mean_velocity['xyz'.index(direction)]:.9e} m/s, {res.iterations} iterations, "
            f"residual {res.residual:.2e}",
            flush=True,
        )


def _box(n: int) -> tuple[np.ndarray, int]:
    """The ``n`` um box, from ``/tmp/psdesign_scale_box_<n>.npz`` if a former run left it."""
    cache = Path(f"/tmp/psdesign_scale_box_{n}.npz")
    if cache.exists():
        with np.load(cache) as f:
            return f["solid"], int(f["fibres"])
    solid, fibres = toray_box(n)
    np.savez(cache, solid=solid, fibres=fibres)
    return solid, fibres


def schur_side_by_side(sizes: list[int], direction: str = "x") -> None:
    """MINRES iterations and time per iteration without and with the coarse Darcy term of the
    pressure preconditioner (:mod:`solvers.voxel.schur`), one after the other per size, in one
    process, with the load average and the coarse term's memory."""
    import solvers.voxel_stokes as vs
    from psdesign.flow.voxel import column_of

    vs.solve_voxel_stokes(toray_box(48)[0], 1e-6, direction, tol=1e-3)  # compile both paths
    for n in sizes:
        solid, fibres = _box(n)
        for on in (False, True):
            vs.COARSE_PRESSURE = on
            load0 = os.getloadavg()[0]
            res = vs.solve_voxel_stokes(solid, 1e-6, direction, tol=1e-6)
            extra = ""
            if on:
                op = vs._Stokes.build(solid)
                extra = f" coarse term {op.coarse_p.nbytes / solid.size:.2f} B per voxel"
                del op
            print(
                f"{n}^3 coarse pressure {'on ' if on else 'off'}: MINRES iterations "
                f"{res.iterations} solve {res.wall_time_s:.1f} s "
                f"({1e3 * res.wall_time_s / max(res.iterations, 1):.0f} ms per iteration incl. "
                f"set-up) K = {column_of(res)[('xyz').index(direction)]:.9e} m^2 residual "
                f"{res.residual:.1e}{extra} load {load0:.1f} -> {os.getloadavg()[0]:.1f}",
                flush=True,
            )
    vs.COARSE_PRESSURE = True


def schur_cost(n: int, repeats: int = 10) -> None:
    """Time of one preconditioner application (three V-cycles and the pressure block) and of
    one operator product, with and without the coarse pressure term, interleaved in one
    process (median of ``repeats``), and the set-up time of the coarse term."""
    import solvers.voxel_stokes as vs

    solid, _ = _box(n)
    ops = {}
    for on in (False, True):
        vs.COARSE_PRESSURE = on
        t = time.perf_counter()
        ops[on] = vs._Stokes.build(solid)
        print(f"{n}^3 coarse {'on ' if on else 'off'}: build {time.perf_counter() - t:.2f} s")
    vs.COARSE_PRESSURE = True
    rng = np.random.default_rng(0)
    r = rng.standard_normal(ops[True].shape).astype(np.float32)
    r[3][solid] = 0.0
    z = np.empty_like(r)
    y = np.empty_like(r)
    times = {False: [], True: [], "K": []}
    for _ in range(repeats):
        for on in (False, True):
            t = time.perf_counter()
            ops[on].precondition(r, z)
            times[on].append(time.perf_counter() - t)
        t = time.perf_counter()
        ops[True].lanczos(r, 1.0, 0.0, y)
        times["K"].append(time.perf_counter() - t)
    med = {k: 1e3 * float(np.median(v)) for k, v in times.items()}
    print(
        f"{n}^3 preconditioner off {med[False]:.1f} ms, on {med[True]:.1f} ms "
        f"(ratio {med[True] / med[False]:.3f}); operator product {med['K']:.1f} ms; "
        f"coarse term {ops[True].coarse_p.nbytes / solid.size:.2f} B per voxel; "
        f"load {os.getloadavg()[0]:.1f}",
        flush=True,
    )


def cycles(n: int, block: int | None = None, direction: str = "x") -> None:
    """Iterations, true residual and Lanczos (Ritz) spectrum of each refinement cycle of one
    solve of the ``n`` um box (tol 1e-6), optionally with ``schur.BLOCK = block``: where the
    iterations grow with the box (``benchmarks/RESULTS.md``, "Issue 16 item 4, iteration
    growth").  The Ritz values are the eigenvalues of the tridiagonal Lanczos matrix of each
    Krylov run: estimates of the extreme eigenvalues of the preconditioned operator, negative
    ones from the pressure block."""
    import solvers.voxel_stokes as vs
    from psdesign.flow.voxel import column_of
    from solvers.voxel import schur

    if block is not None:
        schur.BLOCK = block
    runs: list[tuple[list[float], list[float]]] = []
    step0, run0 = vs._lanczos_step, vs.krylov_run

    def step(op, z, r1, r2, beta, oldb, first):  # record alpha_k and beta_k
        out = step0(op, z, r1, r2, beta, oldb, first)
        if first:
            runs.append(([], []))
        runs[-1][0].append(out[1])
        runs[-1][1].append(beta)
        return out

    rtols: list[float] = []

    def run(op, b, x, work, rtol, maxit, report=None):
        rtols.append(rtol)
        return run0(op, b, x, work, rtol, maxit, report)

    vs._lanczos_step, vs.krylov_run = step, run
    solid, _ = _box(n)
    load0 = os.getloadavg()[0]
    cpu = time.process_time()
    res = vs.solve_voxel_stokes(solid, 1e-6, direction, tol=1e-6)
    cpu = time.process_time() - cpu
    vs._lanczos_step, vs.krylov_run = step0, run0
    print(
        f"{n}^3 block {schur.BLOCK}: K = {column_of(res)['xyz'.index(direction)]:.9e} m^2 "
        f"{res.iterations} iterations, {cpu:.1f} s CPU, load {load0:.1f} -> "
        f"{os.getloadavg()[0]:.1f}",
        flush=True,
    )
    for i, ((alpha, beta), rtol) in enumerate(zip(runs, rtols, strict=True)):
        k = len(alpha)
        ev = np.linalg.eigvalsh(np.diag(alpha) + np.diag(beta[1:k], 1) + np.diag(beta[1:k], -1))
        neg, pos = ev[ev < 0], ev[ev > 0]
        print(
            f"  cycle {i + 1}: rtol {rtol:.2e}, {k} iterations, true residual "
            f"{res.history[i]:.2e} -> {res.history[i + 1]:.2e}; Ritz negative "
            f"[{neg.min():.4f}, {neg.max():.5f}], positive [{pos.min():.5f}, {pos.max():.4f}]",
            flush=True,
        )


def main(argv: list[str]) -> None:
    from psdesign.flow.voxel import column_of
    from solvers import jit
    from solvers.voxel_stokes import solve_voxel_stokes

    if len(argv) > 1 and argv[1] == "memory":
        traced_memory(int(argv[2]) if len(argv) > 2 else 64)
        return
    if len(argv) > 1 and argv[1] == "schur-cost":
        schur_cost(int(argv[2]) if len(argv) > 2 else 100)
        return
    if len(argv) > 1 and argv[1] == "cycles":
        cycles(int(argv[2]), int(argv[3]) if len(argv) > 3 else None)
        return
    if len(argv) > 1 and argv[1] == "schur":
        schur_side_by_side([int(a) for a in argv[2:]] or [100, 200])
        return
    n = int(argv[1]) if len(argv) > 1 else 100
    direction = argv[2] if len(argv) > 2 else "x"
    # warm-up outside the timings: compile (or load from numba's cache) the parallel kernels
    # that every size then uses, on a grid just above the one-thread threshold
    jit.COMPILE_PARALLEL_ABOVE = 0
    solve_voxel_stokes(toray_box(48)[0], 1e-6, direction, tol=1e-3)
    load0 = os.getloadavg()[0]
    t = time.perf_counter()
    solid, fibres = _box(n)
    gen = time.perf_counter() - t
    print(f"toray box {n} um at 1 um: {fibres} fibres, generated in {gen:.1f} s", flush=True)
    cells = solid.size
    box = [solid]  # no reference kept here: the solver frees the grid after its set-up
    del solid
    t = time.perf_counter()
    cpu = time.process_time()
    res = solve_voxel_stokes(box.pop(), 1e-6, direction, tol=1e-6)
    wall = time.perf_counter() - t
    cpu = time.process_time() - cpu
    print(
        f"toray box {n}^3 ({res.wall_treatment}): K[:,{direction}] = {column_of(res)} "
        f"porosity {res.porosity:.4f} converged {res.converged} MINRES iterations "
        f"{res.iterations} residual {res.residual:.2e} flux imbalance {res.flux_imbalance:.1e} "
        f"solve {wall:.1f} s ({cpu:.1f} s CPU, {1e9 * cpu / cells:.0f} ns CPU per voxel) "
        f"peak RSS {res.peak_memory_mb:.0f} MiB ({res.peak_memory_mb * 2**20 / cells:.1f} B "
        "per voxel) "
        f"load average before {load0:.1f} after {os.getloadavg()[0]:.1f}",
        flush=True,
    )


if __name__ == "__main__":
    main(sys.argv)
