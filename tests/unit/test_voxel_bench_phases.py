"""The voxel benches time every residual pass of the solver (benchmarks/bench_voxel_parts.py,
benchmarks/voxel_memory_phases.py).

Session 49 (s49-setup) made the first residual the body force, ``solvers.voxel_stokes.
_force_residual`` (no operator pass at x = 0); both benches still timed ``_true_residual``
only, so the first residual's time and memory went into no phase (review of session 49).
"""

from __future__ import annotations

from conftest import load_benchmark

import solvers.voxel_stokes as vs

#: the solver's residual passes: its module functions named ``*_residual``
RESIDUALS = sorted(n for n in dir(vs) if n.endswith("_residual") and callable(getattr(vs, n)))


def test_the_memory_phases_bench_wraps_every_residual_pass_and_skips_an_absent_one(
    monkeypatch,
):
    bench = load_benchmark("voxel_memory_phases")
    assert "_force_residual" in RESIDUALS  # the truth this guards
    timed = [name for obj, name, _ in bench.PHASES if obj is vs and name.endswith("_residual")]
    assert sorted(timed) == RESIDUALS
    # an older tree's solver (no _force_residual): its phase is skipped, not an AttributeError
    monkeypatch.delattr(vs, "_force_residual")
    present = [(obj, name, label) for obj, name, label in bench.PHASES if hasattr(obj, name)]
    for obj, name, _ in present:  # the wrappers undone after the test
        monkeypatch.setattr(obj, name, getattr(obj, name))
    log: list = []
    for obj, name, label in bench.PHASES:
        bench._wrap(obj, name, label, 1, log)
    assert all(getattr(obj, name).__name__ == "wrapped" for obj, name, _ in present)


def test_the_parts_bench_times_every_residual_pass(monkeypatch):
    bench = load_benchmark("bench_voxel_parts")
    wrapped: list[str] = []
    monkeypatch.setattr(bench, "_wrap", lambda owner, attr, *a, **k: wrapped.append(attr))
    monkeypatch.setattr(vs, "krylov_run", vs.krylov_run)  # instrument() replaces it
    bench.instrument()
    assert set(RESIDUALS) <= set(wrapped), wrapped
