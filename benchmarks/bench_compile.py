"""Where numba's compile time goes: one :mod:`psdesign.warmup` task in this process, on an empty
(or given) numba cache, timed per kernel and per signature by numba's ``numba:compile`` events.

Usage::

    python benchmarks/bench_compile.py serial|parallel [--out FILE.json]
    python benchmarks/bench_compile.py speed OLD_TREE [--sizes 100 200] [--its 10] [--reps 2]
    python benchmarks/bench_compile.py kernels REV N [REPS]

Set ``NUMBA_CACHE_DIR`` to an empty directory first (the script refuses a non-empty one unless
``--allow-warm``).  Prints one line per (kernel, signature): exclusive seconds (its own compile,
without nested compiles of the jitted helpers it calls), inclusive seconds, CPU and wall (run it
with ``NUMBA_NUM_THREADS=1`` so that numba's idle OpenMP threads add no CPU), and the totals
with the process CPU time.  A helper that is not inlined (plain ``@nb.njit``) is compiled once
per signature in its own event, so its row shows what the kernels that call it no longer pay.

``speed``: CPU ms per MINRES iteration of this tree and of ``OLD_TREE`` (a checkout of another
commit) side by side, one thread, alternating, each run in its own process
(``voxel_iteration_cost.py profile N ITS`` of each tree, with its own numba cache dir under
``OLD_TREE/../numba_cache_{old,new}``: warmed by a first untimed run), and the ratio new / old.
Under load it is noisy (separate processes; kernels that did not change differed by 10-20 %).

``kernels``: the finest-level multigrid kernels, ``stokes_lanczos``, ``symmlq_step`` and
``pressure_block_code`` of git revision ``REV`` (its ``simd.py``, ``kernels.py``, ``lanczos.py``
and ``schur.py``, imported as copies) and of this tree in
one process, on the same arrays of the Toray-like ``N^3`` staircase operator, timed interleaved
(the serial twins and CPU time with ``NUMBA_NUM_THREADS=1``, else the parallel kernels and wall
time); checks whether both give bitwise the same output and prints best and median ratios new /
old.
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


def kernel_name(fn) -> str:
    """A jitted function's name in the compile tables: ``module.qualname`` of its Python
    function (a dispatcher's ``py_func``; a serial twin's qualname ends in ``__serial``,
    :mod:`solvers.jit`). The one spelling of :class:`CompileRecorder` and of
    ``compile_census.py product``, whose rows the census matches by it."""
    return f"{fn.__module__}.{fn.__qualname__}"


def _sig(data: dict) -> str:
    args = data.get("args")
    return ", ".join(str(a) for a in args) if args is not None else "?"


class CompileRecorder:
    """numba ``numba:compile`` listener: one row per compile (kernel, signature, inclusive and
    exclusive wall and CPU seconds, ``parallel`` flag, nesting ``depth`` and the ``root``
    kernel whose compile it is part of, and :attr:`label`, e.g. the running test).  Exclusive
    means without the nested compiles of the jitted helpers it calls."""

    def __init__(self) -> None:
        from numba.core import event

        self.rows: list[dict] = []
        self.label = ""
        self._stack: list[list] = []
        recorder = self

        class _Listener(event.Listener):
            def on_start(self, ev):
                recorder._start(ev)

            def on_end(self, ev):
                recorder._end(ev)

        self.listener = _Listener()

    def _start(self, ev) -> None:
        kernel = kernel_name(ev.data["dispatcher"].py_func)
        self._stack.append([time.perf_counter(), 0.0, time.process_time(), 0.0, kernel])

    def _end(self, ev) -> None:
        t0, child, c0, cchild, kernel = self._stack.pop()
        dt = time.perf_counter() - t0
        dc = time.process_time() - c0
        if self._stack:
            self._stack[-1][1] += dt
            self._stack[-1][3] += dc
        disp = ev.data["dispatcher"]
        self.rows.append(
            {
                "kernel": kernel,
                "sig": _sig(ev.data),
                "parallel": bool(disp.targetoptions.get("parallel")),
                "incl_s": dt,
                "excl_s": dt - child,
                "incl_cpu_s": dc,
                "excl_cpu_s": dc - cchild,
                "depth": len(self._stack),
                "root": self._stack[0][4] if self._stack else kernel,
                "label": self.label,
            }
        )


def profile(mode: str) -> dict:
    """Run warmup task ``mode`` in this process with the compile events recorded."""
    from numba.core import event

    from psdesign.warmup import _task

    rec = CompileRecorder()
    t0 = time.perf_counter()
    c0 = time.process_time()
    with event.install_listener("numba:compile", rec.listener):
        _task(mode)
    return {
        "mode": mode,
        "wall_s": time.perf_counter() - t0,
        "cpu_s": time.process_time() - c0,
        "maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "rows": rec.rows,
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


def _old_modules(rev: str):
    """Import ``solvers/voxel/simd.py``, ``kernels.py``, ``lanczos.py`` and ``schur.py`` of git
    revision ``rev`` as the modules ``old_simd``, ``old_kernels``, ``old_lanczos`` and
    ``old_schur`` (copies in a temporary directory, importing one another); returns the last
    three."""
    import importlib
    import tempfile

    repo = Path(__file__).resolve().parents[1]
    tmp = Path(tempfile.mkdtemp(prefix="old_kernels_"))

    def show(path: str) -> str:
        src = subprocess.run(
            ["git", "-C", str(repo), "show", f"{rev}:{path}"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        src = src.replace("from solvers.voxel import simd", "import old_simd as simd")
        src = src.replace("from solvers.voxel import kernels as kr", "import old_kernels as kr")
        return src.replace("from solvers.voxel.kernels import", "from old_kernels import")

    for name in ("simd", "kernels", "lanczos", "schur"):
        (tmp / f"old_{name}.py").write_text(show(f"solvers/voxel/{name}.py"))
    sys.path.insert(0, str(tmp))
    return tuple(importlib.import_module(f"old_{name}") for name in ("kernels", "lanczos", "schur"))


def _time_old_and_new(runs: dict, reps: int, clock, label: str) -> None:
    """Time each kernel of ``runs["old"]`` / ``runs["new"]`` alternately, ``reps`` rounds of three
    calls, and print the best of each and the new / old ratios (best and median)."""
    import numpy as np

    tim = {name: {"old": [], "new": []} for name in runs["old"]}
    for _ in range(reps):
        for name in tim:
            for key in ("old", "new"):
                t = clock()
                for _ in range(3):
                    runs[key][name]()
                tim[name][key].append((clock() - t) / 3 * 1e3)
    for name, t in tim.items():
        bo, bn = min(t["old"]), min(t["new"])
        med = float(np.median(t["new"]) / np.median(t["old"]))
        print(
            f"{label} {name:18s} old {bo:7.2f} ms  new {bn:7.2f} ms (best of {reps}): "
            f"new / old {bn / bo:.3f} best, {med:.3f} median",
            flush=True,
        )


def kernels_side_by_side(rev: str, n: int, reps: int = 7) -> None:
    """See the module docstring (``kernels``)."""
    import numpy as np

    sys.path.insert(0, str(Path(__file__).parent))
    import bench_voxel_scale as scale
    import numba

    import solvers.voxel_stokes as vs
    from solvers.voxel import kernels as kr
    from solvers.voxel import lanczos as lz
    from solvers.voxel import schur

    ok, ol, osc = _old_modules(rev)
    nth = numba.get_num_threads()
    mode = "serial" if nth == 1 else "parallel"
    clock = time.process_time if nth == 1 else time.perf_counter
    op = vs._Stokes.build(scale._box(n)[0])
    l0, l1 = op.mg[0].levels[0], op.mg[0].levels[1]
    rng = np.random.default_rng(0)
    b, x = (rng.standard_normal(l0.d.shape).astype(np.float32) for _ in range(2))
    xc = rng.standard_normal(l1.d.shape).astype(np.float32)
    big_x, big_y = (rng.standard_normal(op.shape).astype(np.float32) for _ in range(2))
    c = l0.c
    # symmlq_step's packed direction and 40-bit solution (float32 + int8 per-row extension)
    pk = lz.Packing([*op.d, op.fluid])
    sol = lz.Solution(op.shape, pk)
    sol.hi[:] = rng.standard_normal(pk.size)
    sol.extend()
    w0 = rng.standard_normal(pk.size).astype(np.float32)
    masks = (*pk.masks, pk.start)
    # the staircase pressure block: scale codes of the operator, a coarse field on 4^3 blocks
    code = schur.schur_code(list(op.d), 1e-4)
    pc = tuple(max(1, min(schur.BLOCK, m)) for m in op.fluid.shape)
    pshape = tuple(m // f for m, f in zip(op.fluid.shape, pc, strict=True))
    pxc = rng.standard_normal(pshape).astype(np.float32)

    def cases(m, mz, ms, out, rc, y, w):
        return {
            "jacobi": lambda: (getattr(m.jacobi, mode)(l0.d, *c, x, b, out, 0.9), out),
            "jacobi2_zero": lambda: (
                getattr(m.jacobi2_zero, mode)(l0.d, *c, b, out, 0.9, nth),
                out,
            ),
            "prolong_jacobi": lambda: (
                getattr(m.prolong_jacobi, mode)(l0.d, *c, x, xc, *l0.f, 1.6, b, out, 0.9, nth),
                out,
            ),
            "residual_restrict": lambda: (
                getattr(m.residual_restrict, mode)(l0.d, *c, x, b, *l0.f, rc),
                rc,
            ),
            "stokes_lanczos": lambda: (
                getattr(mz.stokes_lanczos, mode)(*op.d, *op.c, op.fluid, big_x, 0.7, 0.3, y),
                y,
            ),
            "symmlq_step": lambda: (
                getattr(mz.symmlq_step, mode)(
                    big_x, 0.7, w, w[:0].view(np.uint8), 0.6, 0.8, *sols[id(w)], 0.3, *masks
                ),
                w,
            ),
            "pressure_block_code": lambda: (
                getattr(ms.pressure_block_code, mode)(
                    code, schur.CODE_TABLE, op.fluid, big_x[3], pxc, *pc, 0.6, y[3]
                ),
                y[3],
            ),
        }

    runs, ys, ws, sols = {}, {}, {}, {}
    for key, (m, mz, ms) in {"old": (ok, ol, osc), "new": (kr, lz, schur)}.items():
        ys[key] = big_y.copy()
        ws[key] = w0.copy()
        sols[id(ws[key])] = (sol.hi.copy(), sol.lo.copy(), sol.scale.copy())
        runs[key] = cases(
            m, mz, ms, np.zeros_like(x), np.zeros(l1.d.shape, np.float32), ys[key], ws[key]
        )
    for name in runs["old"]:
        outs = []
        for key in ("old", "new"):
            ys[key][...] = big_y  # the same input for both
            ws[key][...] = w0
            hi, lo, _ = sols[id(ws[key])]
            hi[...], lo[...] = sol.hi, sol.lo
            r, arr = runs[key][name]()
            outs.append((r, arr.copy()))
        same = outs[0][0] == outs[1][0] and np.array_equal(outs[0][1], outs[1][1])
        print(f"{name}: old and new bitwise equal: {same}", flush=True)
    _time_old_and_new(runs, reps, clock, f"{n}^3 {mode}")
    print(f"load {os.getloadavg()[0]:.1f}")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "kernels":
        kernels_side_by_side(argv[1], int(argv[2]), int(argv[3]) if len(argv) > 3 else 7)
        return 0
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
    rows = sorted(res["rows"], key=lambda r: -r["excl_cpu_s"])
    print("exclusive CPU s, inclusive CPU s, exclusive wall s, kernel (signature):")
    for r in rows:
        if r["excl_cpu_s"] >= 0.2:
            print(
                f"{r['excl_cpu_s']:7.2f} {r['incl_cpu_s']:7.2f} {r['excl_s']:7.2f}  "
                f"{r['kernel']}  ({r['sig']})"
            )
    per: dict[str, float] = {}
    for r in rows:
        per[r["kernel"]] = per.get(r["kernel"], 0.0) + r["excl_cpu_s"]
    print("per kernel (exclusive CPU s, number of signatures):")
    for k, v in sorted(per.items(), key=lambda kv: -kv[1]):
        n = sum(1 for r in rows if r["kernel"] == k)
        if v >= 0.2:
            print(f"{v:7.2f}  {n}  {k}")
    tot = sum(r["excl_s"] for r in rows)
    tot_cpu = sum(r["excl_cpu_s"] for r in rows)
    print(
        f"mode {res['mode']}: wall {res['wall_s']:.1f} s, CPU {res['cpu_s']:.1f} s, "
        f"compile events {tot:.1f} s wall / {tot_cpu:.1f} s CPU over {len(rows)} compiles, "
        f"max RSS {res['maxrss_mb']:.0f} MB, load {os.getloadavg()[0]:.1f}"
    )
    if args.out:
        args.out.write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
