"""Audit "an interrupt prints ONE line" for ``psdesign study run`` stopped as its pool starts
(session 54, fixsem).

Each trial starts an 8-case, 2-worker ``study run`` of slow fake cases (each sleeps 60 s; no
solver runs) in its own process group, waits for its ``[study] ... to run on`` line, sleeps
``delay`` seconds and sends the group SIGINT (as a terminal's Ctrl-C does; ``--sig TERM``:
SIGTERM).  Checked per trial: the exit status (130 / 143) and every stderr line that is not a
``[study]`` progress line: exactly one, ``psdesign: error: interrupted; ...`` (or
``terminated``).  Extra lines are counted and classed (``resource_tracker`` leaked-semaphore
warning, traceback, other).  Session 53's last CI saw the resource tracker's 2-line "There
appear to be 1 leaked semaphore objects to clean up at shutdown" under the one line in ~1 of 25
stops at 0.0 s.

``--inject``: the same in one process, deterministically: the pool is made once per line of
multiprocessing's code that its making runs, with SIGINT sent at that line.

    python benchmarks/audit_interrupt_lines.py --trials 10 --delays 0 0.01 0.03 0.1 0.3 0.5

Prints one row per trial and a summary per delay; exit 1 if any trial had an extra line or a
wrong exit status.  The trials run in the order delay-major, so a load burst spreads over
delays rather than hitting one.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent

STUDY = """
[base.rve]
size = [100e-6, 100e-6, 100e-6]
voxel = 1e-6
[base.generator]
kind = "straight"
porosity = 0.8
diameter = 7e-6
seed = 1
[base.flow]
solver = "voxel"
[study]
design = "full-factorial"
outputs = ["porosity", "k_z"]
solver = "voxel"
[parameters]
"generator.porosity" = [0.7, 0.75, 0.8, 0.85]
"generator.diameter" = [6e-6, 7e-6]
"""


def slow_case(spec, outputs, solver, workdir):  # noqa: ARG001 - a case function's signature
    """A fake case that sleeps 60 s (the run is always stopped before it ends)."""
    time.sleep(60)
    return {"porosity": float(spec["generator"]["porosity"])}


def one_stop(
    work: Path, sig: int, delay_s: float, root: Path = ROOT
) -> tuple[int | None, list[str], float]:
    """Run one stopped ``study run`` of the psdesign code in ``root`` in ``work``; return (exit
    status or None if still running 30 s after the signal, its non-progress stderr lines,
    seconds from start to the signal)."""
    work.mkdir(parents=True)
    (work / "s.toml").write_text(STUDY)
    argv = [sys.executable, "-m", "psdesign", "study", "run", str(work / "s.toml"), "-o"]
    argv += [str(work / "out"), "--workers", "2", "--no-report"]
    argv += ["--case-fn", "audit_interrupt_lines:slow_case"]
    path = [str(root), str(HERE), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(path)}
    t0 = time.monotonic()
    proc = subprocess.Popen(
        argv,
        env=env,
        cwd=work,  # python -m puts the cwd first on sys.path, before PYTHONPATH (``root``)
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    lines: list[bytes] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stderr), daemon=True)
    reader.start()
    deadline = time.monotonic() + 120.0
    while not any(b"to run on" in ln for ln in lines) and time.monotonic() < deadline:
        if proc.poll() is not None:
            break
        time.sleep(0.002)
    time.sleep(delay_s)
    t_sig = time.monotonic() - t0
    procs = [psutil.Process(proc.pid)]
    try:
        procs += psutil.Process(proc.pid).children(recursive=True)
        os.killpg(proc.pid, sig)
    except (psutil.Error, ProcessLookupError):
        pass
    try:
        status = proc.wait(timeout=30.0)
    except subprocess.TimeoutExpired:
        status = None
    for p in procs:
        try:
            p.kill()
        except psutil.Error:
            pass
    proc.wait()
    reader.join(10.0)
    text = b"".join(lines).decode(errors="replace").splitlines()
    return status, [ln for ln in text if ln.strip() and not ln.startswith("[study]")], t_sig


def classify(extra: list[str]) -> str:
    """The kind of the extra stderr lines: ``tracker``, ``traceback``, ``other`` or ``""``."""
    if not extra:
        return ""
    joined = "\n".join(extra)
    if "resource_tracker" in joined:
        return "tracker"
    if "Traceback" in joined:
        return "traceback"
    return "other"


def inject_points(root: Path) -> tuple[int, int, str]:
    """Make the study runner's process pool once per line event of multiprocessing's code run
    while it is made, sending SIGINT at that line (Python's own handler raises
    KeyboardInterrupt at the next check).  Returns (line events, events after which a named
    semaphore was registered with the resource tracker without a finalizer: leaked).  Runs
    in a child process on the code in ``root``; ``_new_pool`` if it has one, else the pool
    as session 53's ``_run_pool`` made it."""
    code = """
import concurrent.futures as cf, gc, multiprocessing as mp, os, signal, sys
import multiprocessing.resource_tracker as rt, multiprocessing.synchronize as syn
from multiprocessing import util
from psdesign.study import runner
by_point, unregistered = {}, set()
real, real_un = rt._resource_tracker.register, rt._resource_tracker.unregister
def spy(name, rtype):
    real(name, rtype)
    by_point.setdefault(n, []).append(name)
def spy_un(name, rtype):
    real_un(name, rtype)
    unregistered.add(name)
rt.register, rt.unregister = spy, spy_un
def make():
    if hasattr(runner, "_new_pool"):
        return runner._new_pool(2)
    return cf.ProcessPoolExecutor(max_workers=2, mp_context=mp.get_context("spawn"),
                                  initializer=runner._init_worker, initargs=(os.getpid(),))
signal.signal(signal.SIGINT, signal.default_int_handler)
n = 0
make().shutdown()  # the resource tracker runs from here on, as after a first pool
while True:
    n += 1
    seen = [0]
    def tracer(frame, event, arg):
        if event == "line" and "multiprocessing" in frame.f_code.co_filename:
            seen[0] += 1
            if seen[0] == n:
                os.kill(os.getpid(), signal.SIGINT)
        return tracer
    pool = None
    sys.settrace(tracer)
    try:
        pool = make()
    except KeyboardInterrupt:
        pass
    finally:
        sys.settrace(None)
    if pool is not None:
        pool.shutdown()
    del pool
    if seen[0] < n:
        break
gc.collect()
live = {f._args[0] for f in list(util._finalizer_registry.values())
        if getattr(f, "_callback", None) is syn.SemLock._cleanup}
leaky = [k for k, names in by_point.items() if set(names) - unregistered - live]
print(n - 1, len(leaky), file=sys.stdout, flush=True)
"""  # the resource tracker's own warning at this process's exit counts the same semaphores
    env = {**os.environ, "PYTHONPATH": str(root)}
    # cwd: python -c puts it first on sys.path, before PYTHONPATH
    run = [sys.executable, "-c", code]
    out = subprocess.run(run, env=env, cwd=root, capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(out.stderr)
    tracker = [ln for ln in out.stderr.splitlines() if "leaked semaphore" in ln]
    events, leaks = out.stdout.split()
    return int(events), int(leaks), (tracker[0].split("UserWarning: ")[-1] if tracker else "")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=10, help="trials per delay and root")
    ap.add_argument("--delays", type=float, nargs="+", default=[0.0, 0.01, 0.03, 0.1, 0.3])
    ap.add_argument("--sig", choices=["INT", "TERM"], default="INT")
    ap.add_argument(
        "--roots",
        type=Path,
        nargs="+",
        default=[ROOT],
        help="psdesign source trees to compare (e.g. an old one from git archive), interleaved",
    )
    ap.add_argument("--inject", action="store_true", help="also the line-by-line injection")
    args = ap.parse_args()
    print(f"# load: {os.getloadavg()}; python {sys.version.split()[0]}")
    if args.inject:
        for root in args.roots:
            events, leaks, tracker = inject_points(root)
            print(f"# inject {root}: SIGINT at each of {events} lines: {leaks} leaked a semaphore")
            print(f"#   its resource tracker at exit: {tracker or 'no warning'}")
    sig = signal.SIGINT if args.sig == "INT" else signal.SIGTERM
    want = 130 if sig == signal.SIGINT else 143
    word = "psdesign: error: " + ("interrupted" if sig == signal.SIGINT else "terminated")
    summary: dict[tuple[Path, float], list[str]] = {}
    with tempfile.TemporaryDirectory(prefix="audit_interrupt_") as tmp:
        for trial in range(args.trials):
            for delay in args.delays:
                for r, root in enumerate(args.roots):
                    work = Path(tmp) / f"t{trial}_{delay:g}_{r}"
                    status, lines, t_sig = one_stop(work, sig, delay, root)
                    ours = [ln for ln in lines if ln.startswith(word)]
                    extra = [ln for ln in lines if not ln.startswith(word)]
                    bad = status != want or len(ours) != 1 or extra
                    kind = classify(extra) or ("status" if bad else "ok")
                    summary.setdefault((root, delay), []).append(kind)
                    print(
                        f"{root.name:>10} delay {delay:6.3f} s trial {trial:2d} t_sig {t_sig:5.2f}"
                        f" s exit {status} lines {len(lines)} {kind}"
                        + (f" {extra!r}" if extra else "")
                    )
    print("\n| code | delay (s) | stops | extra lines | tracker warning | other bad |")
    print("|---|---|---|---|---|---|")
    total_bad = 0
    for (root, delay), kinds in summary.items():
        n_bad = sum(k != "ok" for k in kinds)
        total_bad += n_bad
        n_tr = kinds.count("tracker")
        print(f"| {root} | {delay:g} | {len(kinds)} | {n_bad} | {n_tr} | {n_bad - n_tr} |")
    n = sum(len(k) for k in summary.values())
    print(f"\n{total_bad} of {n} stops not exactly one line + exit {want}; load {os.getloadavg()}")
    return 1 if total_bad else 0


if __name__ == "__main__":
    sys.exit(main())
