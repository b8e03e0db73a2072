"""BLAS thread policy (solvers/blas_threads.py): one BLAS thread unless the user chose.

Session 41 (s41-blas): numpy / scipy's OpenBLAS ran one thread per CPU in every psdesign
process; beside one CPU-bound process the woven cell's tied-layer field search took 316.8 s on
two BLAS threads against 26.9 s on one (benchmarks/bench_blas_threads.py, RESULTS.md).  Truth:
the thread count each loaded BLAS library reports itself (``openblas_get_num_threads`` through
``threadpoolctl.threadpool_info``), read in a fresh interpreter whose environment we control.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from solvers.blas_threads import BLAS_THREAD_VARS

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(
    (os.cpu_count() or 1) < 2, reason="OpenBLAS' own default is one thread on one CPU"
)

# A field relax search of the woven cell (as `psdesign forcefield` runs it), stopped after a
# few evaluations; every PS field evaluation inside the search records the BLAS pools' threads.
SEARCH = """
import json, sys, tempfile, os
{first}
import psdesign
import numpy as np, scipy.linalg
from threadpoolctl import threadpool_info
from psdesign.geometry import model
from psdesign.forcefield.contact import relax_rve_fields
from psdesign.forcefield.relax import _search_options
from psdesign.packing.build import build_rve
from psdesign.schema.spec import load_spec

seen = []
evaluate = model.GeneralizedPS.evaluate
def spy(self, *a, **k):
    if len(seen) < 3:
        seen.append([p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"])
    return evaluate(self, *a, **k)
model.GeneralizedPS.evaluate = spy
path = os.path.join(tempfile.mkdtemp(), "w.toml")
open(path, "w").write('[rve]\\nsize = [100e-6, 100e-6, 100e-6]\\nvoxel = 2e-6\\n'
                      '[[fibers]]\\nshape = "woven-cell"\\nlayers = 1\\n')
rve = build_rve(load_spec(path)).rve
dmin = min(float(f.diameter) for f in rve.fibers) * float(rve.period)
kw = _search_options({{"max_evals": 3}}, dmin, float(rve.period))
relax_rve_fields(rve, kw, 10e-6, None)
child = __import__("subprocess").run(
    [sys.executable, "-c", "import numpy, threadpoolctl; "
     "print([p['num_threads'] for p in threadpoolctl.threadpool_info()])"],
    capture_output=True, text=True).stdout
print(json.dumps({{"search": seen, "child": child.strip(),
                  "env": os.environ.get("OPENBLAS_NUM_THREADS")}}))
"""


def _run(first: str = "", **env_set: str) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARS}
    env.update(env_set, PYTHONPATH=str(ROOT))
    out = subprocess.run(
        [sys.executable, "-c", SEARCH.format(first=first)],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("first", ["", "import numpy, scipy.linalg"])
def test_field_search_runs_blas_on_one_thread_by_default(first) -> None:
    """With no *_NUM_THREADS variable set, every BLAS pool inside the field search reports one
    thread (old code: 2 on a 2-core machine, one per CPU), also when numpy and scipy were
    imported before psdesign, and a process psdesign starts inherits it (study workers)."""
    got = _run(first)
    assert got["search"] and all(n == [1, 1] for n in got["search"]), got
    assert got["child"] == "[1]" and got["env"] == "1", got


@pytest.mark.parametrize("var", ["OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"])
def test_a_thread_count_the_user_set_wins(var) -> None:
    """docs/architecture.md: a BLAS thread variable the user set is kept (here 2 threads)."""
    got = _run(**{var: "2"})
    assert got["search"] and all(n == [2, 2] for n in got["search"]), got
    assert got["child"] == "[2]", got
    assert got["env"] == ("2" if var == "OPENBLAS_NUM_THREADS" else None), got
