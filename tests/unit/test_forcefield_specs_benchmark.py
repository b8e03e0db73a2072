"""``benchmarks/forcefield_specs.py`` records a relax that stopped on ``max_iter``.

``psdesign forcefield`` exits 3 when the search stops on ``max_iter`` ("finished with complete
outputs, but a result did not converge": README, exit statuses) and writes relaxed.toml and
summary.json. The benchmark kept only exit 0 runs: for exit 3 it printed the "before" state and
no status, moves or "after" state, so docs/paper-reproduction.md section 4's woven row (the
3-layer sample stops on max_iter 200) could not be re-measured with the section's own command
(session 42, helper s42-paper). Nor did an exit 0 run finish: the benchmark read
``wall_time_s`` from summary.json, which keeps no wall times since 6f450a3 (they are in
summary_timings.json, so that the same spec gives a byte-identical summary.json): KeyError.
"""

from __future__ import annotations

import json
from pathlib import Path

from conftest import load_benchmark

ROOT = Path(__file__).resolve().parents[2]

#: Two 10 um rods crossing 3 um apart (tests/unit/test_paper.py's spec), one pattern-search
#: iteration allowed: the contact is not removed, the command exits 3.
TWO_RODS = (
    "[rve]\nsize = [1e-4, 1e-4, 1e-4]\nvoxel = 1e-6\n"
    '[[fibers]]\nshape = "rod"\ndiameter = 10e-6\ncenter = [50e-6, 50e-6, 50e-6]\n'
    '[[fibers]]\nshape = "rod"\ndiameter = 10e-6\ncenter = [50e-6, 50e-6, 53e-6]\n'
    "omega = 90.0\n[forcefield.relax]\nmax_shift = 10e-6\nmax_iter = 1\n"
)


def _script():
    return load_benchmark("forcefield_specs")


def test_a_relax_stopped_on_max_iter_is_recorded_with_its_status_and_after_state(tmp_path):
    path = tmp_path / "two_rods.toml"
    path.write_text(TWO_RODS)
    work = tmp_path / "work"
    work.mkdir()
    rec = _script().run_one(path, work)
    summary = json.loads((work / "out" / "summary.json").read_text())
    assert rec["exit"] == 3
    assert summary["status"] == "not_converged"
    assert rec["status"] == summary["status"] and rec["converged"] is False
    assert rec["n_evals"] == summary["n_evals"]
    # 1 um grid: the rods overlap before (3 um apart, 10 um thick); after is measured too
    assert rec["before"]["omega"] > 2e-4
    assert set(rec["after"]) == {"porosity", "omega", "min_gap_m"}
    # the analytic Omega is recorded with its bars and statuses (session 47): rods overlapping
    # before, so an upper bound only (untrustworthy)
    assert rec["omega_analytic_error"][0] > 0 and rec["omega_analytic_status"][0] == "untrustworthy"
    timings = json.loads((work / "out" / "summary_timings.json").read_text())
    assert rec["relax_s"] == timings["wall_time_s"] > 0
