"""Where a test run's wall time goes: per test file, its worker, its wall and its CPU (the
worker's, its waited child processes', and numba's compiles), and each worker's idle tail
(session 47, ``benchmarks/RESULTS.md``: "s47-suite").

Usage::

    # 1. the suite with both recorders (pytest plugins; the compile one is compile_census.py)
    NUMBA_CACHE_DIR=/tmp/nc SUITE_TIMING_DIR=/tmp/st CENSUS_DIR=/tmp/st/census \\
        PYTHONPATH=.:benchmarks python -m pytest -n 2 --dist loadfile -p suite_timing \\
        -p compile_census
    # 2. the tables
    python benchmarks/suite_timing.py report /tmp/st

One row per test (setup, call and teardown) in ``$SUITE_TIMING_DIR/<worker>.<pid>.jsonl``,
with the process's own CPU and that of the children it waited for (``RUSAGE_CHILDREN``: a
CLI test's subprocess); ``non-numba`` CPU is both minus the compiles recorded for the file's
tests. A file's wall minus its CPU is time waiting: on the other worker's compile lock, on a
child still running, or for a core when other jobs load the machine.
"""

from __future__ import annotations

import collections
import json
import os
import resource
import sys
import time
from pathlib import Path

import pytest

_ROWS: list[dict] = []


def _cpu(who: int) -> float:
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def _worker() -> str:
    return os.environ.get("PYTEST_XDIST_WORKER", "main")


def _event(name: str) -> None:
    _ROWS.append({"event": name, "t": time.time(), "cpu": _cpu(resource.RUSAGE_SELF)})


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """Plugin: time one test, fixtures included."""
    t0, c0 = time.time(), _cpu(resource.RUSAGE_SELF)
    k0 = _cpu(resource.RUSAGE_CHILDREN)
    yield
    _ROWS.append(
        {
            "nodeid": item.nodeid,
            "start": t0,
            "end": time.time(),
            "cpu": _cpu(resource.RUSAGE_SELF) - c0,
            "child_cpu": _cpu(resource.RUSAGE_CHILDREN) - k0,
        }
    )


def pytest_sessionstart(session) -> None:
    _event("sessionstart")


def pytest_collection_finish(session) -> None:
    _event("collected")


def pytest_unconfigure(config) -> None:
    """Plugin: write this process's rows to ``$SUITE_TIMING_DIR/<worker>.<pid>.jsonl``."""
    _event("end")
    out = Path(os.environ.get("SUITE_TIMING_DIR", "suite_timing"))
    out.mkdir(parents=True, exist_ok=True)
    with open(out / f"{_worker()}.{os.getpid()}.jsonl", "w") as f:
        for row in _ROWS:
            f.write(json.dumps({**row, "worker": _worker()}) + "\n")


def _read(folder: Path) -> tuple[list[dict], list[dict], collections.Counter]:
    """Test rows, events, and compile CPU per test file (``folder/census``, if recorded)."""
    rows, events, compiled = [], [], collections.Counter()
    for path in folder.glob("*.jsonl"):
        for line in path.read_text().splitlines():
            r = json.loads(line)
            (events if "event" in r else rows).append(r)
    for path in (folder / "census").glob("*.jsonl"):
        for line in path.read_text().splitlines():
            r = json.loads(line)
            compiled[r["label"].split("::")[0]] += r["excl_cpu_s"]
    return rows, events, compiled


def per_file(rows: list[dict], compiled: collections.Counter) -> dict[str, dict]:
    """Wall (first start to last end), CPU, child CPU, numba CPU and worker of each file."""
    files: dict[str, dict] = {}
    for r in rows:
        name = r["nodeid"].split("::")[0]
        f = files.setdefault(
            name, {"worker": r["worker"], "start": r["start"], "end": r["end"], "n": 0}
        )
        f["start"], f["end"] = min(f["start"], r["start"]), max(f["end"], r["end"])
        f["n"] += 1
        for key in ("cpu", "child_cpu"):
            f[key] = f.get(key, 0.0) + r[key]
    for name, f in files.items():
        f["numba"] = compiled.get(name, 0.0)
        f["non_numba"] = f["cpu"] + f["child_cpu"] - f["numba"]
        f["wall"] = f["end"] - f["start"]
    return files


def report(folder: Path, top: int = 30) -> None:
    """Print the per-worker and per-file tables of a recorded run."""
    rows, events, compiled = _read(folder)
    files = per_file(rows, compiled)
    t0 = min(e["t"] for e in events if e["event"] == "sessionstart")
    workers: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    for f in files.values():
        w = workers[f["worker"]]
        w["last"] = max(w["last"], f["end"] - t0)
        for key in ("n", "wall", "cpu", "child_cpu", "numba", "non_numba"):
            w[key] += f[key]
    last = max(w["last"] for w in workers.values())
    print("worker  tests  last_end  idle_tail  test_wall  cpu  child_cpu  numba  non_numba (s)")
    for name, w in sorted(workers.items()):
        print(
            f"{name:6s} {w['n']:6d} {w['last']:9.1f} {last - w['last']:9.1f} {w['wall']:9.1f}"
            f" {w['cpu']:6.1f} {w['child_cpu']:9.1f} {w['numba']:6.1f} {w['non_numba']:9.1f}"
        )
    print(f"\nfiles by non-numba CPU (top {top}): non_numba numba cpu child wall tests worker file")
    for name, f in sorted(files.items(), key=lambda kv: -kv[1]["non_numba"])[:top]:
        print(
            f"{f['non_numba']:7.1f} {f['numba']:6.1f} {f['cpu']:6.1f} {f['child_cpu']:6.1f}"
            f" {f['wall']:7.1f} {f['n']:5d} {f['worker']} {name}"
        )


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2 or argv[0] != "report":
        print("usage: suite_timing.py report FOLDER", file=sys.stderr)
        return 2
    report(Path(argv[1]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
