"""Where numba's compile time goes: one :mod:`psdesign.warmup` task in this process, on an empty
(or given) numba cache, timed per kernel and per signature by numba's ``numba:compile`` events.

Usage::

    python benchmarks/bench_compile.py serial|parallel [--out FILE.json]

Set ``NUMBA_CACHE_DIR`` to an empty directory first (the script refuses a non-empty one unless
``--allow-warm``).  Prints one line per (kernel, signature): exclusive seconds (its own compile,
without nested compiles of the jitted helpers it calls), inclusive seconds, and the totals with
the process CPU time.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
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


def main(argv: list[str] | None = None) -> int:
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
