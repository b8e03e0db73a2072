"""Thread policy of the voxel Stokes solver (solvers.voxel.threads)."""

from __future__ import annotations

import os
import subprocess
import sys

import numba
import numpy as np
import pytest

from solvers.voxel import multigrid as mg
from solvers.voxel.threads import PARALLEL_MIN_CELLS, level_threads, solve_min_cells, solve_threads


def _wait_policy(env_value: str | None) -> str:
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if env_value is not None:
        env["OMP_WAIT_POLICY"] = env_value
    code = "import os, psdesign; print(os.environ.get('OMP_WAIT_POLICY'))"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    return out.stdout.strip()


def test_import_makes_idle_threads_sleep_but_keeps_a_user_choice() -> None:
    assert _wait_policy(None) == "PASSIVE"
    assert _wait_policy("ACTIVE") == "ACTIVE"


def test_small_levels_run_on_one_thread() -> None:
    assert level_threads(PARALLEL_MIN_CELLS - 1, 8) == 1
    assert level_threads(PARALLEL_MIN_CELLS, 8) == 8
    assert level_threads(10**9, 1) == 1


def test_small_solves_run_on_one_thread() -> None:
    """A 64^3 solve with one competing process ran 1.16-1.59x its one-thread time on two
    threads (issue 16 item 1, session 21, benchmarks/RESULTS.md): it runs on one; 100^3 on
    all."""
    assert solve_threads(64**3, 2) == 1
    assert solve_threads(100**3, 2) == 2
    assert solve_threads(100**3, 1) == 1
    assert solve_min_cells() >= PARALLEL_MIN_CELLS


def test_vcycle_restores_the_callers_thread_count() -> None:
    fluid = np.ones((8, 8, 8), dtype=bool)
    fluid[:, :2, :] = False
    d, c = mg.component_operator(fluid, 0)
    m = mg.ScalarMG(d, c, max_coarse=8)
    before = numba.get_num_threads()
    out = np.zeros(d.shape, np.float32)
    m.apply(np.ones(d.shape, np.float32), out)
    assert numba.get_num_threads() == before
    assert np.all(out[d == 0] == 0.0) and np.all(out[d > 0] > 0.0)


def _twin_kernels() -> list:
    """Every :class:`solvers.jit.TwinKernel` of the loaded solver modules."""
    from solvers.jit import TwinKernel

    mods = [m for name, m in list(sys.modules.items()) if name.startswith("solvers.") and m]
    return [k for m in mods for k in vars(m).values() if isinstance(k, TwinKernel)]


@pytest.mark.parametrize("case", ["not_compiled", "compiled", "small_grid"])
def test_result_states_the_threads_its_kernels_ran_on(case: str, monkeypatch) -> None:
    """Session 11: with the parallel kernels not in numba's cache a two-thread solve below
    ``jit.COMPILE_PARALLEL_ABOVE`` cells ran the serial twins, about 2x slower, and said
    nothing.  Two threads are simulated (numba's thread count as the solver reads and sets
    it; the run needs one real thread only); a "compiled" parallel kernel runs its serial
    twin's code."""
    from solvers import jit
    from solvers import voxel_stokes as vs
    from solvers.voxel import threads as vthreads

    threads = [2]
    monkeypatch.setattr(numba, "get_num_threads", lambda: threads[0])
    monkeypatch.setattr(numba, "set_num_threads", lambda n: threads.__setitem__(0, n))
    if case != "small_grid":
        monkeypatch.setattr(vthreads, "PARALLEL_MIN_CELLS", 0)
        monkeypatch.setattr(vthreads, "SOLVE_PARALLEL_MIN_CELLS", 0)
    monkeypatch.setattr(jit.TwinKernel, "_parallel_ready", lambda self, args: case == "compiled")
    for kernel in _twin_kernels():
        monkeypatch.setattr(kernel, "parallel", kernel.serial)
    solid = np.zeros((12, 12, 12), dtype=bool)
    solid[:, 3:7, 3:7] = True  # a square rod along x, flow along y
    res = vs.solve_voxel_stokes(solid, 1e-6, "y", tol=1e-6)
    assert res.converged and threads == [2]  # the caller's count restored
    if case == "not_compiled":
        assert res.threads_used == 1
        assert "psdesign warmup" in res.thread_note and "1 of 2 threads" in res.thread_note
        assert "stokes_lanczos" in res.serial_fallback
    elif case == "compiled":
        assert (res.threads_used, res.thread_note, res.serial_fallback) == (2, "", ())
    else:
        assert res.threads_used == 1 and res.serial_fallback == ()
        assert res.thread_note == f"ran on 1 of 2 threads: grid below {solve_min_cells()} cells"


def test_partly_compiled_kernels_are_named() -> None:
    from solvers.voxel.threads import thread_use

    n, note = thread_use(2, 2, {"jacobi"}, {"stokes_lanczos"})
    assert n == 2 and note.startswith("1 kernels ran on 1 of 2 threads (jacobi): ")
    assert thread_use(1, 1, set(), set()) == (1, "")
    assert thread_use(2, 2, set(), {"jacobi"}) == (2, "")


def _scaled_sum(x, scale=None):
    """A parallel kernel with a parameter left to its default (as ``stream`` on s28-stream)."""
    acc = 0.0
    for i in numba.prange(x.size):
        acc += x[i]
    return acc if scale is None else acc * scale


def test_a_compiled_kernel_is_found_when_a_default_is_omitted() -> None:
    """Session 28: numba compiles a call that omits a defaulted parameter under the signature
    ``(..., omitted(default=None))``; ``TwinKernel`` looked it up without that entry, never found
    the compiled parallel kernel and ran the serial twin (on branch s28-stream, where the Jacobi
    sweeps had gained ``stream=None``, the 100^3 level of every V-cycle of a 200^3 solve ran on
    one thread)."""
    from solvers.jit import TwinKernel

    kern = TwinKernel(_scaled_sum)
    x = np.ones(64)
    assert not kern._parallel_ready((x,))
    assert kern.parallel(x) == 64.0  # compiles it, as psdesign warmup does
    kern._ready.clear()
    assert kern._parallel_ready((x,)) and kern._parallel_ready((x, 2.0)) is False


def test_a_solve_on_uncompiled_kernels_gives_the_same_warnings(monkeypatch) -> None:
    """Session 35 (reproducibility audit): a voxel solve whose parallel kernels were not in
    numba's cache added "K_z: voxel solve ran on 1 of 2 threads: parallel kernels not compiled
    yet ..." to the result's ``warnings``, so ``fields.json`` and a study's ``warnings_z``
    column depended on the cache, not on the spec and seed.  The note is kept in
    ``thread_note`` (run metadata: ``thread_note_z`` is a timing column of the study table);
    the warnings are those of a solve on compiled kernels."""
    import dataclasses

    import solvers.voxel_stokes as vsm
    from psdesign.flow import voxel as fv
    from psdesign.geometry.fibers import make_fiber
    from psdesign.geometry.rve import RVE
    from psdesign.study.store import is_timing_column
    from solvers.jit import WARMUP_NOTE

    fib = make_fiber(
        "cylinder", diameter=0.45, center=np.array([0.5, 0.5, 0.5]), theta=None, omega=None,
        direction=[1, 0, 0], u=0.0, f=1.0, isovalue=None,
    )  # fmt: skip
    rve = RVE(size=np.full(3, 20e-6), fibers=[fib])
    fields = rve.voxelize(1e-6)
    real = vsm.solve_voxel_stokes
    results = {}
    for compiled in (True, False):
        note = "" if compiled else f"ran on 1 of 2 threads: {WARMUP_NOTE}"
        fallback = () if compiled else ("stokes_lanczos",)

        def solve(*a, _note=note, _fallback=fallback, **k):
            res = real(*a, **k)  # the real solve, then the cache state of a cold install
            return dataclasses.replace(res, thread_note=_note, serial_fallback=_fallback)

        monkeypatch.setattr(vsm, "solve_voxel_stokes", solve)
        results[compiled] = fv.permeability_voxel(
            fields, "y", {"bc": "periodic", "viscosity": 1e-3, "tol": 1e-6}, rve=rve
        )
    cold, warm = results[False], results[True]
    assert cold["thread_note"].endswith(WARMUP_NOTE) and warm["thread_note"] == ""
    assert cold.get("warnings") == warm.get("warnings")
    assert not any(WARMUP_NOTE in w for w in cold.get("warnings", []))
    assert cold["permeability_m2"] == warm["permeability_m2"]
    assert is_timing_column("thread_note_y") and not is_timing_column("warnings_y")
