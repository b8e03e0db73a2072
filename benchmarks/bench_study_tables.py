"""Results-table upkeep of the study runner: old (rebuild after every case) vs new (throttled).

The runner used to rebuild ``results.csv`` / ``results.parquet`` / the summary after every
finished case: N rebuilds of up to N rows, quadratic.  :class:`psdesign.study.runner.TableWriter`
rebuilds at most every ``TABLE_INTERVAL_S`` (longer when a rebuild is slow) and at the end.
Both are timed here side by side on the same N fake records (a 2-parameter study, 4 seeds, the
columns a voxel case writes), the cases arriving ``--every`` simulated seconds apart (a clock
that adds that much per case to the real time, so the throttle sees a realistic arrival rate
without sleeping).  The old way is skipped above ``--old-max`` cases (it takes minutes).

    python benchmarks/bench_study_tables.py --n 250 500 1000 2000 --every 0.05
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from psdesign.study.runner import TABLE_INTERVAL_S, TableWriter
from psdesign.study.store import CaseStore

PARAMS = ["generator.porosity", "generator.diameter"]


def fake_records(n: int) -> list[dict]:
    """``n`` finished-case records shaped like a voxel study's (reproducible values)."""
    rng = np.random.default_rng(0)
    recs = []
    for i in range(n):
        eps, d, seed = 0.6 + 0.3 * rng.random(), 5e-6 + 3e-6 * rng.random(), 1 + i % 4
        results = {"porosity": eps, "n_fibers": int(rng.integers(5, 50))}
        for a in "xyz":
            results[f"k_{a}_m2"] = 1e-11 * rng.random()
            results[f"converged_{a}"] = True
            results[f"iterations_{a}"] = int(rng.integers(50, 500))
            results[f"k_{a}_rel_error"] = 0.02
            results[f"k_{a}_status"] = "ok"
        recs.append(
            {
                "case_id": f"c{i:05d}-{i:08x}",
                "index": i,
                "params": {PARAMS[0]: eps, PARAMS[1]: d},
                "seed": seed,
                "status": "ok",
                "error": None,
                "results": results,
                "wall_time_s": 100 * rng.random(),
                "started_at": "2026-01-01T00:00:00+00:00",
                "finished_at": "2026-01-01T00:01:00+00:00",
                "host": "h",
                "pid": 1,
            }
        )
    return recs


def old_way(store: CaseStore, recs: list[dict]) -> tuple[float, int]:
    """Rebuild after every case, then once at the end (the runner before this change)."""
    records: dict = {}
    t0 = time.perf_counter()
    for r in recs:
        records[r["case_id"]] = r
        store.write_tables(records.values(), PARAMS)
    store.write_tables(records.values(), PARAMS)
    return time.perf_counter() - t0, len(recs) + 1


def new_way(store: CaseStore, recs: list[dict], every_s: float) -> tuple[float, int]:
    """TableWriter.changed() per case, flush at the end; cases ``every_s`` simulated s apart."""
    records: dict = {}
    n_done = [0]
    clock = lambda: time.perf_counter() + n_done[0] * every_s  # noqa: E731
    writer = TableWriter(store, records, PARAMS, TABLE_INTERVAL_S, clock=clock)
    rebuilds = [0]
    real = store.write_tables

    def counted(*a):
        rebuilds[0] += 1
        return real(*a)

    store.write_tables = counted
    t0 = time.perf_counter()
    for r in recs:
        records[r["case_id"]] = r
        n_done[0] += 1
        writer.changed()
    writer.flush()
    return time.perf_counter() - t0, rebuilds[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[250, 500, 1000])
    ap.add_argument("--every", type=float, default=0.05, help="simulated s between two cases")
    ap.add_argument("--old-max", type=int, default=2000, help="largest N timed the old way")
    a = ap.parse_args()
    print(f"interval {TABLE_INTERVAL_S:g} s, a case every {a.every:g} simulated s")
    print(f"{'N':>7} {'old s':>9} {'old rebuilds':>13} {'new s':>8} {'new rebuilds':>13}")
    for n in a.n:
        recs = fake_records(n)
        with tempfile.TemporaryDirectory() as tmp:
            old = old_way(CaseStore(Path(tmp)), recs) if n <= a.old_max else (float("nan"), 0)
        with tempfile.TemporaryDirectory() as tmp:
            new = new_way(CaseStore(Path(tmp)), recs, a.every)
        print(f"{n:>7} {old[0]:>9.2f} {old[1]:>13} {new[0]:>8.2f} {new[1]:>13}")


if __name__ == "__main__":
    main()
