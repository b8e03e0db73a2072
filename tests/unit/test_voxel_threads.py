"""Thread policy of the voxel Stokes solver (solvers.voxel.threads)."""

from __future__ import annotations

import os
import subprocess
import sys

import numba
import numpy as np

from solvers.voxel import multigrid as mg
from solvers.voxel.threads import PARALLEL_MIN_CELLS, level_threads


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
