"""BLAS threads side by side: each route's wall time with psdesign's default BLAS threads,
with OpenBLAS on every CPU (its own default, psdesign's before session 41) and on one thread,
interleaved in one process, with and without a CPU-bound competitor.

Run:  PYTHONPATH=. python benchmarks/bench_blas_threads.py [--repeat 2] [--competitor]
      [--cases ff_woven,ff_tied,ff_two,fem,voxel,transport]

``--competitor`` starts ``python -c "while 1: pass"`` (its own process group, stopped at the
end).  Arm ``default``: the process as psdesign sets it up (:mod:`solvers.blas_threads`); arm
``N``: ``threadpool_limits(N)`` around the whole case (paths under
:func:`solvers.blas_threads.single_thread_blas` stay on one thread in every arm).  Prints one
markdown row per case: wall times, the ratios to one thread and whether the results (search
optimum, K, D) are bitwise equal across the arms.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import subprocess
import sys
import time

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

import psdesign  # noqa: F401 - its BLAS thread policy, as in a user's process

BOX = "[rve]\nsize = [100e-6, 100e-6, 100e-6]\nvoxel = 2e-6\n"
WOVEN = BOX + '[[fibers]]\nshape = "woven-cell"\nlayers = 1\n'
CYL = {
    "rve": {"size": [60e-6, 60e-6, 30e-6], "voxel": 2e-6},
    "fibers": [{"shape": "cylinder", "diameter": 25e-6, "direction": [0, 0, 1]}],
}


def _field_relax(tmp: str, opts: dict, grid: float, gap: float | None):
    from psdesign.forcefield.contact import relax_rve_fields
    from psdesign.forcefield.relax import _search_options
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    path = os.path.join(tmp, "woven.toml")
    with open(path, "w") as f:
        f.write(WOVEN)
    rve = build_rve(load_spec(path)).rve
    period = float(rve.period)
    dmin = min(float(fb.diameter) for fb in rve.fibers) * period
    kw = _search_options(opts, dmin, period)
    kw["tie_bend"] = opts.get("tie_bend", False)
    with contextlib.redirect_stderr(open(os.devnull, "w")):
        _, res = relax_rve_fields(rve, kw, grid, gap)
    return np.asarray(res.x)


def ff_woven(tmp: str):
    """Field relax of the woven cell (grid 5 um, shifts 10 um, u_max 0.6): s41-refit's case."""
    return _field_relax(tmp, {"max_shift": 10e-6, "u_max": 0.6}, 5e-6, None)


def ff_tied(tmp: str):
    """The woven cell's tied layer (grid 3 um, gap 1.5 um, tie_bend): s41-refit's 11-142 s."""
    opts = {"max_shift": 10e-6, "u_max": 0.6, "tie_bend": True}
    return _field_relax(tmp, opts, 3e-6, 1.5e-6)


def ff_two(tmp: str):
    """Paper Sec. 6.1 two-fiber case on one worker, coarse quadrature."""
    from psdesign.forcefield.cases import two_fiber_problem

    prob = two_fiber_problem(h=0.01, n_s=32, n_theta=16)
    return np.asarray(prob.solve(workers=1).x)


def fem(tmp: str):

    return np.asarray(
        [psdesign.build(CYL).permeability("z", solver="fem", bc="periodic").permeability_m2]
    )


def voxel(tmp: str):

    return np.asarray(
        [psdesign.build(CYL).permeability("z", solver="voxel", bc="periodic").permeability_m2]
    )


def transport(tmp: str):

    return np.asarray([psdesign.build(CYL).diffusivity("x").relative_diffusivity])


CASES = {f.__name__: f for f in (ff_woven, ff_tied, ff_two, fem, voxel, transport)}


def run_arm(case, n: int | None, tmp: str) -> tuple[float, np.ndarray]:
    """Wall time and result of ``case``; ``n`` BLAS threads (None: as the process is)."""
    limit = contextlib.nullcontext() if n is None else threadpool_limits(limits=n, user_api="blas")
    with limit:
        t0 = time.perf_counter()
        out = case(tmp)
        return time.perf_counter() - t0, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--competitor", action="store_true")
    args = ap.parse_args()
    import scipy.linalg  # noqa: F401 - load scipy's OpenBLAS too, so both pools are limited

    ncpu = os.cpu_count() or 1
    comp = None
    if args.competitor:
        comp = subprocess.Popen([sys.executable, "-c", "while 1: pass"], start_new_session=True)
    tmp = f"/tmp/bench_blas_{os.getpid()}"
    os.makedirs(tmp, exist_ok=True)
    pools = [(p["internal_api"], p["num_threads"]) for p in threadpool_info()]
    print(f"# BLAS threads: default, {ncpu}, 1; competitor {bool(comp)}; default pools {pools}")
    print(f"start {time.strftime('%H:%M:%S', time.gmtime())} UTC load {os.getloadavg()}")
    arms: list[int | None] = [None, ncpu, 1]
    print(f"| case | default s | blas={ncpu} s | blas=1 s | default/1 | {ncpu}/1 | results equal |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    try:
        for name in args.cases.split(","):
            case = CASES[name]
            case(tmp)  # warm: imports, numba caches
            times: dict = {n: [] for n in arms}
            outs: dict = {}
            for _ in range(args.repeat):
                for n in arms:
                    dt, out = run_arm(case, n, tmp)
                    times[n].append(dt)
                    outs[n] = out
            med = {n: float(np.median(times[n])) for n in arms}
            eq = all(np.array_equal(outs[n], outs[1]) for n in arms)
            cols = " | ".join(", ".join(f"{t:.2f}" for t in times[n]) for n in arms)
            print(
                f"| {name} | {cols} | {med[None] / med[1]:.2f} | {med[ncpu] / med[1]:.2f} | {eq} |",
                flush=True,
            )
    finally:
        if comp is not None:
            os.killpg(comp.pid, signal.SIGTERM)
            comp.wait()
    print(f"end {time.strftime('%H:%M:%S', time.gmtime())} UTC load {os.getloadavg()}")


if __name__ == "__main__":
    main()
