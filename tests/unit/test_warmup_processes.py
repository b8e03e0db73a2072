"""``psdesign warmup`` runs its ``parallel`` task in two processes that make the same solves in
different orders (``psdesign.warmup._PROCESSES``, ``_parallel_plan``).

Why: on two cores the parallel task alone was 835 of the 848 s of a cold warmup (session 18
lead, ``benchmarks/RESULTS.md``) while the second core idled after the 195 s serial task; a
second process making the same solves in another order (the 48^3 grid first, the Laplace solves
last) compiles the signatures the first one reaches late (``solvers.jit_locks``: one compile
per signature, the other process loads it). Each process alone must still make every solve,
else a kernel signature would be left to the user's first solve. No compile here: the plan is
data, and the pool is replaced by an in-process map.
"""

from __future__ import annotations

import numba
import pytest

from psdesign import warmup

# the eight solves of one pass, written out by hand (both boundary conditions, both wall
# treatments, the Laplace solves, the two tolerances of the longer Krylov storages)
SOLVES = [
    ("stokes", "periodic", "subvoxel"),
    ("stokes", "periodic", "staircase"),
    ("laplace", "periodic", ""),
    ("stokes", "permeameter", "subvoxel"),
    ("stokes", "permeameter", "staircase"),
    ("laplace", "permeameter", ""),
    ("tol", "periodic", 1e-8),
    ("tol", "periodic", 5e-7),
]


def test_parallel_plan_is_three_passes_in_two_orders():
    fine = 48**3
    plan = warmup._parallel_plan(fine)
    assert len(plan) == 24
    assert plan[:8] == [("coarse", 0, s) for s in SOLVES]  # 16^3, every level parallel
    assert plan[8:16] == [("fine", 0, s) for s in SOLVES]  # 48^3, every level parallel
    # 48^3 with the fine level parallel and the coarse levels on the serial twins
    assert plan[16:] == [("fine", 110592, s) for s in SOLVES]
    second = warmup._parallel_plan(fine, second=True)
    assert sorted(second, key=str) == sorted(plan, key=str)  # the same steps
    stokes = [s for s in SOLVES if s[0] != "laplace"]
    laplace = [s for s in SOLVES if s[0] == "laplace"]
    assert second == (
        [("fine", 0, s) for s in stokes]
        + [("fine", 110592, s) for s in stokes]
        + [("coarse", 0, s) for s in stokes]
        + [("fine", 0, s) for s in laplace]
        + [("fine", 110592, s) for s in laplace]
        + [("coarse", 0, s) for s in laplace]
    )


def test_parallel_task_runs_in_two_processes(monkeypatch):
    assert warmup._processes(("serial", "parallel")) == ("serial", "parallel", "parallel-b")
    assert warmup._processes(("parallel",)) == ("parallel", "parallel-b")
    assert warmup._processes(("serial",)) == ("serial",)

    seen: dict = {}

    class InProcessPool:
        def __init__(self, max_workers, mp_context):
            seen["workers"] = max_workers

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def shutdown(self, wait=True, cancel_futures=False):
            seen["shutdown"] = (wait, cancel_futures)

        def map(self, fn, items):
            seen["modes"] = list(items)
            return [(m, float(i)) for i, m in enumerate(seen["modes"])]

    monkeypatch.setattr(warmup, "ProcessPoolExecutor", InProcessPool)
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has one thread: the parallel task is left out")
    out = warmup.warmup(jobs=2)
    assert seen == {
        "workers": 2,
        "modes": ["serial", "parallel", "parallel-b"],
        "shutdown": (True, False),  # a finished pool waits for its workers
    }
    assert (out["serial"], out["parallel"], out["parallel-b"]) == (0.0, 1.0, 2.0)
    warmup.warmup(("parallel",), jobs=8)  # at most one worker per process
    assert seen == {"workers": 2, "modes": ["parallel", "parallel-b"], "shutdown": (True, False)}


_SLOW_TASK = """
import signal, time


def slow_task(mode):  # a kernel compile that takes minutes and loses the Ctrl-C in LLVM
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    time.sleep(600)
    return mode, 600.0
"""

_WARMUP_CHILD = """
import psutil, sys, time
import psdesign.warmup as w
import slow_task_s36

w._task = slow_task_s36.slow_task
try:
    w.warmup(("serial",), jobs=1)
except KeyboardInterrupt:
    print("interrupted", len(psutil.Process().children()), flush=True)
"""


def test_ctrl_c_stops_the_warmup_workers_at_once(tmp_path):
    """Session 36: Ctrl-C 30 s into a cold ``psdesign warmup`` left the pool waiting for its
    workers' kernel compiles (the SIGINT they got with the process group was lost in LLVM's
    callbacks): still compiling 3 min later.  Truth: ``warmup`` raises KeyboardInterrupt within
    seconds of SIGINT while its worker is busy for 10 minutes, and no worker is left (only
    multiprocessing's resource tracker may remain)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    (tmp_path / "slow_task_s36.py").write_text(_SLOW_TASK)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), *sys.path]))
    proc = subprocess.Popen(
        [sys.executable, "-c", _WARMUP_CHILD],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    time.sleep(3)  # the worker has started its task
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole group
    try:
        out, _ = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail("warmup still waited for its worker 2 min after Ctrl-C")
    said, left = out.split()
    assert said == "interrupted" and int(left) <= 1  # the resource tracker at most
