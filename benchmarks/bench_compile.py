"""Where numba's compile time goes: one :mod:`psdesign.warmup` task in this process, on an empty
(or given) numba cache, timed per kernel and per signature by numba's ``numba:compile`` events.

Usage::

    python benchmarks/bench_compile.py serial|parallel [--out FILE.json]
    python benchmarks/bench_compile.py speed OLD_TREE [--sizes 100 200] [--its 10] [--reps 2]

Set ``NUMBA_CACHE_DIR`` to an empty directory first (the script refuses a non-empty one unless
``--allow-warm``).  Prints one line per (kernel, signature): exclusive seconds (its own compile,
without nested compiles of the jitted helpers it calls), inclusive seconds, and the totals with
the process CPU time.

``speed``: CPU ms per MINRES iteration of this tree and of ``OLD_TREE`` (a checkout of another
commit) side by side, one thread, alternating, each run in its own process
(``voxel_iteration_cost.py profile N ITS`` of each tree, with its own numba cache dir under
``OLD_TREE/../numba_cache_{old,new}``: warmed by a first untimed run), and the ratio new / old.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _sig(data: dict) -> str:
    args = data.get("args")
    return ", ".join(str(a) for a in args) if args is not None else "?"


def profile(mode: str) -> dict:
    """Run warmup task ``mode`` in this process with the compile events recorded."""
    from numba.core import event

    from psdesign.warmup import _task

    rows: list[dict] = []
    stack: list[list] = []

    class Listener(event.Listener):
        def on_start(self, ev):
            stack.append([time.perf_counter(), 0.0])

        def on_end(self, ev):
            t0, child = stack.pop()
            dt = time.perf_counter() - t0
            if stack:
                stack[-1][1] += dt
            disp = ev.data["dispatcher"]
            rows.append(
                {
                    "kernel": f"{disp.py_func.__module__}.{disp.py_func.__qualname__}",
                    "sig": _sig(ev.data),
                    "incl_s": dt,
                    "excl_s": dt - child,
                }
            )

    t0 = time.perf_counter()
    c0 = time.process_time()
    with event.install_listener("numba:compile", Listener()):
        _task(mode)
    return {
        "mode": mode,
        "wall_s": time.perf_counter() - t0,
        "cpu_s": time.process_time() - c0,
        "maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "rows": rows,
    }


_ITER = re.compile(r"one MINRES iteration ([0-9.]+) ms CPU")


def _iteration_ms(tree: Path, cache: Path, n: int, its: int) -> float:
    """CPU ms per MINRES iteration of ``tree``'s solver at ``n^3`` (one thread, own process)."""
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": str(cache)}
    env.update(NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    script = tree / "benchmarks" / "voxel_iteration_cost.py"
    out = subprocess.run(
        [sys.executable, str(script), "profile", str(n), str(its)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return float(_ITER.search(out).group(1))


def speed(old: Path, sizes: list[int], its: int, reps: int) -> None:
    """Side-by-side iteration cost of this tree vs ``old`` (see the module docstring)."""
    new = Path(__file__).resolve().parents[1]
    trees = {"old": old.resolve(), "new": new}
    caches = {k: old.resolve().parent / f"numba_cache_{k}" for k in trees}
    for k, tree in trees.items():  # compile (or load) outside the timings
        caches[k].mkdir(exist_ok=True)
        _iteration_ms(tree, caches[k], 24, 2)
    for n in sizes:
        ms: dict[str, list[float]] = {"old": [], "new": []}
        for _ in range(reps):
            for k, tree in trees.items():
                ms[k].append(_iteration_ms(tree, caches[k], n, its))
        best = {k: min(v) for k, v in ms.items()}
        print(
            f"{n}^3, one thread, {its} iterations x {reps}: old {ms['old']} ms, new {ms['new']} "
            f"ms CPU per iteration; best new / old = {best['new'] / best['old']:.3f}; "
            f"load {os.getloadavg()[0]:.1f}",
            flush=True,
        )


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "speed":
        sp = argparse.ArgumentParser(description="side-by-side iteration cost")
        sp.add_argument("old", type=Path)
        sp.add_argument("--sizes", type=int, nargs="+", default=[100, 200])
        sp.add_argument("--its", type=int, default=10)
        sp.add_argument("--reps", type=int, default=2)
        a = sp.parse_args(argv[1:])
        speed(a.old, a.sizes, a.its, a.reps)
        return 0
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("serial", "parallel"))
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--allow-warm", action="store_true")
    args = ap.parse_args(argv)
    cache = os.environ.get("NUMBA_CACHE_DIR")
    if not args.allow_warm and (not cache or any(Path(cache).iterdir())):
        print("set NUMBA_CACHE_DIR to an empty directory (or --allow-warm)", file=sys.stderr)
        return 2
    res = profile(args.mode)
    rows = sorted(res["rows"], key=lambda r: -r["excl_s"])
    for r in rows:
        if r["excl_s"] >= 0.2:
            print(f"{r['excl_s']:7.2f} {r['incl_s']:7.2f}  {r['kernel']}  ({r['sig']})")
    per: dict[str, float] = {}
    for r in rows:
        per[r["kernel"]] = per.get(r["kernel"], 0.0) + r["excl_s"]
    print("per kernel (exclusive s, number of signatures):")
    for k, v in sorted(per.items(), key=lambda kv: -kv[1]):
        n = sum(1 for r in rows if r["kernel"] == k)
        if v >= 0.2:
            print(f"{v:7.2f}  {n}  {k}")
    tot = sum(r["excl_s"] for r in rows)
    print(
        f"mode {res['mode']}: wall {res['wall_s']:.1f} s, CPU {res['cpu_s']:.1f} s, "
        f"compile events {tot:.1f} s over {len(rows)} compiles, max RSS {res['maxrss_mb']:.0f} MB"
    )
    if args.out:
        args.out.write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
