"""Benchmark of the study runner with fake case functions.

Run:  python benchmarks/bench_study.py [--quick]

Measures
1. per-case runner overhead: N cases that sleep a fixed time, 1 worker; overhead per case =
   (wall - N * sleep) / N (includes pool start-up, per-case record + CSV/Parquet rewrite);
   also with a per-case timeout (each case in a killable child process);
2. throughput of 2 workers vs 1 on 8 equal CPU-bound cases (goal >= 1.8x);
3. the same 8 cases on a local Dask cluster (2 workers) vs the process pool (goal within 10 %).

The machine is shared: the load average before each measurement is printed.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

SLEEP_S = 0.2
BURN_ITERS = int(os.environ.get("BENCH_BURN_ITERS", 6_000_000))  # env: workers inherit it


def sleep_case(spec, outputs, solver, workdir):
    """Fake case: fixed sleep."""
    time.sleep(SLEEP_S)
    return {"porosity": spec["generator"]["porosity"], "k_z_m2": 1e-12}


def burn_case(spec, outputs, solver, workdir):
    """Fake case: fixed amount of pure-Python CPU work (same for every case)."""
    t0 = time.perf_counter()
    acc = 0
    for i in range(BURN_ITERS):
        acc += i * i % 7
    return {
        "porosity": spec["generator"]["porosity"],
        "k_z_m2": 1e-12,
        "acc": acc,
        "burn_time_s": time.perf_counter() - t0,
    }


STUDY = """
[base.rve]
size = [100e-6, 100e-6, 100e-6]
voxel = 1e-6
[base.generator]
kind = "straight"
porosity = 0.8
diameter = 7e-6
seed = 1
[study]
name = "bench"
design = "latin-hypercube"
n_samples = {n}
outputs = ["porosity", "k_z"]
solver = "voxel"
[parameters]
"generator.porosity" = {{low = 0.6, high = 0.9}}
"""


def _study(tmp: Path, n: int) -> Path:
    p = tmp / f"study{n}.toml"
    p.write_text(STUDY.format(n=n))
    return p


def _timed(fn):
    la = os.getloadavg()[0]
    t0 = time.perf_counter()
    res = fn()
    return time.perf_counter() - t0, la, res


def _run(study: Path, out: Path, case: str, **kw):
    """``run_study`` on a fake case function, quiet and without a report; timed."""
    from psdesign.study import run_study

    return _timed(
        lambda: run_study(
            study, out, case_fn=f"bench_study:{case}", progress=False, report=False, **kw
        )
    )


def _overhead(tmp: Path, n_over: int) -> None:
    """Measure 1: per-case runner overhead (pool, in-process, --timeout) and a resume."""
    s = _study(tmp, n_over)
    wall, la, _ = _run(s, tmp / "o1", "sleep_case", workers=1)
    ov = (wall - n_over * SLEEP_S) / n_over
    print(
        f"[overhead] {n_over} cases x {SLEEP_S} s sleep, 1 worker: wall {wall:.2f} s, "
        f"overhead {ov * 1e3:.0f} ms/case (incl. pool start-up; load {la:.2f})"
    )
    n_half = n_over // 2
    wall_h, la_h, _ = _run(_study(tmp, n_half), tmp / "o1h", "sleep_case", workers=1)
    marg = ((wall - wall_h) - (n_over - n_half) * SLEEP_S) / (n_over - n_half)
    print(
        f"[overhead] marginal per case (wall({n_over}) - wall({n_half}), pool start "
        f"cancels): {marg * 1e3:.0f} ms/case (load {la_h:.2f})"
    )
    wall, la, _ = _run(s, tmp / "o1b", "sleep_case", workers=0)
    ov0 = (wall - n_over * SLEEP_S) / n_over
    print(
        f"[overhead] same, in-process (workers=0): wall {wall:.2f} s, "
        f"overhead {ov0 * 1e3:.0f} ms/case (storage only; load {la:.2f})"
    )
    wall, la, _ = _run(s, tmp / "o1c", "sleep_case", workers=1, timeout_s=60)
    ovt = (wall - n_over * SLEEP_S) / n_over
    print(
        f"[overhead] same with --timeout (child process per case): wall {wall:.2f} s, "
        f"overhead {ovt * 1e3:.0f} ms/case (load {la:.2f})"
    )
    wall, la, _ = _run(s, tmp / "o1", "sleep_case", workers=1)
    print(f"[resume] rerun of the finished study (all skipped): {wall:.2f} s")


def _scaling(tmp: Path, s8: Path) -> float:
    """Measure 2: 8 CPU-bound cases on 1 and 2 workers; returns the 2-worker wall."""
    w1, la1, df1 = _run(s8, tmp / "w1", "burn_case", workers=1)
    w2, la2, df2 = _run(s8, tmp / "w2", "burn_case", workers=2)
    print(
        f"[scaling] 8 CPU-bound cases (~{df1['burn_time_s'].mean():.2f} s each alone): "
        f"1 worker {w1:.2f} s (load {la1:.2f}), 2 workers {w2:.2f} s (load {la2:.2f}), "
        f"speed-up {w1 / w2:.2f}x"
    )
    # busy fraction: time inside the case functions / (workers x wall); 1.0 = the runner
    # keeps every worker busy (independent of how much CPU other users take)
    print(
        f"[scaling] busy fraction: 1 worker {df1['burn_time_s'].sum() / w1:.2f}, "
        f"2 workers {df2['burn_time_s'].sum() / (2 * w2):.2f}; mean case time "
        f"{df1['burn_time_s'].mean():.2f} s (1 worker) vs {df2['burn_time_s'].mean():.2f} s "
        "(2 workers; > means the 2 cores were not free)"
    )
    return w2


def _dask(tmp: Path, s8: Path, w2: float) -> None:
    """Measure 3: the same cases on a local Dask cluster, started per run and already running."""
    wd, lad, dfd = _run(s8, tmp / "dk", "burn_case", workers=2, scheduler="local")
    print(
        f"[dask] same 8 cases, LocalCluster 2 workers: {wd:.2f} s incl. cluster start "
        f"(load {lad:.2f}); pool 2 workers {w2:.2f} s; ratio {wd / w2:.2f}; "
        f"busy fraction {dfd['burn_time_s'].sum() / (2 * wd):.2f}"
    )
    from distributed import LocalCluster

    t0 = time.perf_counter()
    with LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        t_start = time.perf_counter() - t0
        wc, lac, dfc = _run(
            s8, tmp / "dk2", "burn_case", workers=2, scheduler=cluster.scheduler_address
        )
    print(
        f"[dask] same 8 cases on an already running cluster (tcp://, start took "
        f"{t_start:.1f} s): {wc:.2f} s (load {lac:.2f}); ratio to pool {wc / w2:.2f}; "
        f"busy fraction {dfc['burn_time_s'].sum() / (2 * wc):.2f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="fewer cases")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        print(f"machine: {os.cpu_count()} CPUs, python {sys.version.split()[0]}")
        _overhead(tmp, 10 if args.quick else 20)
        s8 = _study(tmp, 8)
        w2 = _scaling(tmp, s8)
        _dask(tmp, s8, w2)
        wr, _, _ = _timed(
            lambda: __import__("psdesign.report", fromlist=["x"]).write_report(tmp / "w2")
        )
        print(f"[report] write_report on 8 cases: {wr:.2f} s")
    ru_self = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    ru_ch = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(f"[memory] peak RSS: runner {ru_self:.0f} MB, largest child {ru_ch:.0f} MB")


if __name__ == "__main__":
    main()
