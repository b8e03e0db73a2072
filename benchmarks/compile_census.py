"""Which numba signatures the test suite compiles, for which test, and whether a product path
uses them (session 46, ``benchmarks/RESULTS.md``: "s46-compile").

Usage::

    # 1. the suite on an empty cache, each compile recorded with its test (a pytest plugin)
    NUMBA_CACHE_DIR=/tmp/nc CENSUS_DIR=/tmp/census PYTHONPATH=.:benchmarks \\
        python -m pytest -n 2 --dist loadfile -p compile_census
    # 2. the product's signatures, on a copy of that cache (nearly all loads, seconds)
    cp -a /tmp/nc /tmp/nc2 && NUMBA_CACHE_DIR=/tmp/nc2 python benchmarks/compile_census.py \\
        product /tmp/census
    # 3. the table: CPU per kernel and signature, and the compiles no product path makes
    python benchmarks/compile_census.py report /tmp/census

``product`` runs :func:`psdesign.warmup._task` ``serial`` (every voxel solve of the warm-up,
one thread) and the ``parallel`` plan with each :class:`solvers.jit.TwinKernel` call recorded
as the parallel signature it would compile but run on its serial twin (no parallel compile:
the twins take the same argument types); every signature numba compiles or loads from the
cache is written to ``product.jsonl``.  The quickstart study and others can be added the same
way (the report reads every ``product*.jsonl``).  A test's compile counts as a product one when
its (kernel, signature, parallel flag) is there; nested helpers are attributed to their root.
"""

from __future__ import annotations

import collections
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_compile import CompileRecorder, kernel_name  # noqa: E402

_RECORDER: CompileRecorder | None = None


def pytest_configure(config) -> None:
    """Plugin: record every compile of this pytest process (a worker under xdist)."""
    from numba.core import event

    global _RECORDER
    _RECORDER = CompileRecorder()
    event.register("numba:compile", _RECORDER.listener)


def pytest_runtest_logstart(nodeid, location) -> None:
    if _RECORDER is not None:
        _RECORDER.label = nodeid


def pytest_unconfigure(config) -> None:
    """Plugin: write this process's rows to ``$CENSUS_DIR/<worker>.<pid>.jsonl``."""
    if _RECORDER is None:
        return
    out = Path(os.environ.get("CENSUS_DIR", "compile_census"))
    out.mkdir(parents=True, exist_ok=True)
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    with open(out / f"{worker}.{os.getpid()}.jsonl", "w") as f:
        for row in _RECORDER.rows:
            f.write(json.dumps(row) + "\n")


def product(out: Path) -> None:
    """Record the warm-up's signatures (module docstring) into ``out/product.jsonl``."""
    from numba.core import dispatcher, sigutils

    import solvers.jit as jit
    from psdesign.warmup import _task

    seen: set[tuple] = set()
    compile_ = dispatcher.Dispatcher.compile

    def note(fn, args, parallel: bool) -> None:
        seen.add((kernel_name(fn), ", ".join(map(str, args)), parallel))

    def recorded_compile(self, sig):
        note(self.py_func, sigutils.normalize_signature(sig)[0], self.targetoptions.get("parallel"))
        return compile_(self, sig)

    def on_serial_twin(self, *args):
        d = self.parallel
        note(self.py_func, d.fold_argument_types(tuple(map(d.typeof_pyval, args)), {})[1], True)
        return self.serial(*args)

    twin_call = jit.TwinKernel.__call__
    dispatcher.Dispatcher.compile = recorded_compile
    try:
        _task("serial")
        jit.TwinKernel.__call__ = on_serial_twin
        _task("parallel")
    finally:
        dispatcher.Dispatcher.compile = compile_
        jit.TwinKernel.__call__ = twin_call
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "product.jsonl", "w") as f:
        for kernel, sig, par in sorted(seen):
            f.write(json.dumps({"kernel": kernel, "sig": sig, "parallel": bool(par)}) + "\n")


def report(folder: Path, min_cpu: float = 0.5) -> None:
    """Print the census of ``folder`` (module docstring)."""
    rows, prod = [], set()
    for path in sorted(folder.glob("*.jsonl")):
        for line in path.read_text().splitlines():
            r = json.loads(line)
            if path.name.startswith("product"):
                prod.add((r["kernel"], r["sig"], r["parallel"]))
                if r["parallel"]:  # its serial twin takes the same types
                    prod.add((f"{r['kernel']}__serial", r["sig"], False))
            else:
                rows.append(r)
    roots = [r for r in rows if r["depth"] == 0]
    print(
        f"{len(rows)} compiles, {sum(r['excl_cpu_s'] for r in rows):.1f} s CPU; "
        f"{len(roots)} kernel signatures compiled from Python"
    )
    per = collections.Counter()
    for r in roots:
        per[r["kernel"]] += r["incl_cpu_s"]
    print("CPU s (with nested helpers), signatures, kernel:")
    for k, v in per.most_common():
        if v >= min_cpu:
            print(f"{v:7.1f} {sum(r['kernel'] == k for r in roots):3d}  {k}")
    if not prod:
        return
    project = ("psdesign.", "solvers.")
    lone = [r for r in roots if r["kernel"].startswith(project)]
    lone = [r for r in lone if (r["kernel"], r["sig"], r["parallel"]) not in prod]
    print(
        f"compiled for tests only (no recorded product path): {len(lone)} signatures, "
        f"{sum(r['incl_cpu_s'] for r in lone):.1f} s CPU"
    )
    for r in sorted(lone, key=lambda r: -r["incl_cpu_s"]):
        print(f"{r['incl_cpu_s']:7.1f}  {r['kernel']} ({r['sig']})  <- {r['label']}")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2 or argv[0] not in ("product", "report"):
        print("usage: compile_census.py product|report FOLDER", file=sys.stderr)
        return 2
    (product if argv[0] == "product" else report)(Path(argv[1]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
