"""Memory budget at scale (session 54, mendscale): a multi-worker run holds each case to its
worker's share, a refusal's "allowed" voxel is itself accepted, and a user's solver threads
over the CPUs are said. Truth: the budget's own closed form (half the machine over the
workers at once, ``psdesign.schema.budget``), the refusal fed back to the same check."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/study_cases.py
from study_cases import BASE, write_study  # noqa: E402

from psdesign.schema import budget  # noqa: E402
from psdesign.study import StudyError, run_study  # noqa: E402

TWO = """
name = "two"
design = "full-factorial"
seeds = [1]
outputs = ["porosity", "k_z"]
solver = "voxel"
"""
TWO_PARAMS = """
"generator.porosity" = [0.8, 0.85]
"""
GRID = [100.0] * 3  # BASE: 100 um at 1 um


def _machine_for(monkeypatch, times: float) -> float:
    """Set the machine so that one process's budget is ``times`` one BASE case's voxel need."""
    need = budget.grid_bytes(GRID, "voxel")
    monkeypatch.setattr(budget, "machine_memory", lambda: times * need / budget.MEMORY_FRACTION)
    return need


def test_two_workers_are_held_to_their_share(tmp_path, monkeypatch):
    """Two cases that each fit one process (1.5 x their need) but not half of it: refused
    before any work, naming workers, rve.voxel and the one worker that fits; one worker runs
    them (its check passes). Old code checked each case against the whole budget."""
    from psdesign.study import expand_design, load_study
    from psdesign.study.runner import validate_case_specs

    _machine_for(monkeypatch, 1.5)
    p = write_study(tmp_path, TWO, TWO_PARAMS)
    out = tmp_path / "out"
    with pytest.raises(StudyError) as err:
        run_study(p, out, workers=2, progress=False, report=False)
    msg = str(err.value)
    assert "rve.voxel" in msg and "2 workers at once, workers=2" in msg, msg
    assert msg.endswith(", or workers=1)"), msg
    assert "\n" not in msg and not out.exists()  # one line, no folder
    study = load_study(p)
    with budget.concurrent_workers(1):
        validate_case_specs(expand_design(study), study.solver, study.outputs)  # fits alone
    # the share is the machine's budget over the workers at once, at most one per case
    with budget.concurrent_workers(2):
        assert budget.memory_budget() == pytest.approx(0.75 * budget.grid_bytes(GRID, "voxel"))


def test_rev_workers_share_names_sizes(tmp_path, monkeypatch):
    """``rev --workers 2`` of two cases of a size that fits one process only: the sizes'
    check refuses it (it was accepted, session 54's walk)."""
    from psdesign.analysis.rev import rev_study

    _machine_for(monkeypatch, 1.5)
    spec = tmp_path / "s.toml"
    spec.write_text(BASE.replace("[base.", "["))
    with pytest.raises(ValueError, match=r"sizes: at 0.0001 m, rve.voxel: .*workers=2"):
        rev_study(spec, [100e-6], 2, tmp_path / "rv", workers=2, progress=False)
    assert not (tmp_path / "rv").exists()


def _allowed(size: float, voxel: float, solver: str) -> float | None:
    """The "voxel >= X m" of check_grid's refusal (None: accepted)."""
    try:
        budget.check_grid((size,) * 3, voxel, solver)
    except Exception as exc:  # noqa: BLE001 - the schema's PydanticCustomError
        m = re.search(r"voxel >= ([0-9.e+-]+) m", str(exc.context["allowed"]))
        assert m, exc.context
        return float(m.group(1))
    return None


@pytest.mark.parametrize("solver", ["voxel", "transport"])
@pytest.mark.parametrize("gib", [23.5, 7.7, 31.1])
def test_allowed_voxel_is_accepted(monkeypatch, solver, gib):
    """The printed least voxel, fed back, is accepted (session 54: 500 um at 1 um on the
    23.5 GiB machine printed 1.09e-06 m, refused again as a 459^3 grid needing 11.9 GiB of
    11.8; pores printed 1.6e-06 m, refused as 313^3), and is within 2 % of the continuous
    bound (need scales as voxel^-3)."""
    monkeypatch.setattr(budget, "machine_memory", lambda: gib * 2**30)
    for size in (577e-6, 800e-6, 1e-3):
        v = _allowed(size, 1e-6, solver)
        assert v is not None
        assert _allowed(size, v, solver) is None, (size, v)
        one = budget.grid_bytes([1, 1, 1], solver)
        per = (budget.grid_bytes([2, 2, 2], solver) - one) / 7  # the fixed load apart
        lower = size / ((budget.memory_budget() - one + per) / per) ** (1 / 3)
        assert lower <= v <= 1.02 * lower


def test_round_up():
    assert budget.round_up(1.0853e-6) == 1.09e-6
    assert budget.round_up(1.59e-6) == 1.59e-6
    assert budget.round_up(9.991e-6) == 1e-5


def test_user_threads_over_cpus_warn(monkeypatch):
    """The user's NUMBA_NUM_THREADS / OMP_NUM_THREADS win in every worker; over the CPUs
    (2 x 2 on 2 cores) one line says so; the runner's own share, or a value within the
    CPUs, says nothing."""
    from psdesign.study.runner import oversubscribed

    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    assert oversubscribed(2, cpus=2) is None
    monkeypatch.setenv("NUMBA_NUM_THREADS", "2")
    line = oversubscribed(2, cpus=2)
    assert line and line.startswith("psdesign: warning: NUMBA_NUM_THREADS=2") and "\n" not in line
    assert "2 CPUs" in line and "1 per worker" in line
    assert oversubscribed(2, cpus=4) is None  # 2 x 2 on 4 CPUs
    assert oversubscribed(1, cpus=2) is None
    monkeypatch.setenv("OMP_NUM_THREADS", "1")  # within the share
    assert "OMP" not in oversubscribed(2, cpus=2)


#: Peak RSS (kB, ``/usr/bin/time -v``) of ``psdesign pores|diffusivity|conductivity
#: vox{64,100,150}.toml`` (Toray-like, 1 um voxels; session 54 mendscale,
#: benchmarks/RESULTS.md "## Session 54: mendscale").
TRANSPORT_PEAK_KB = {
    "pores": {64: 321444, 100: 391260, 150: 597772},
    "diffusivity": {64: 346996, 100: 422632, 150: 677656},
    "conductivity": {64: 342468, 100: 427268, 150: 700984},
}
#: Peak RSS (GB) of ``psdesign permeability vox{64,100,150}.toml --direction z
#: --no-error-estimate`` (periodic voxel solve; session 54 walk-scale report, item 4).
VOXEL_PEAK_GB = {64: 0.37, 100: 0.45, 150: 0.65}


@pytest.mark.parametrize("command", sorted(TRANSPORT_PEAK_KB))
def test_transport_estimate_is_an_honest_upper_bound(command):
    """The transport estimate over the measured peak is in [1.0, 1.3] at every size (it was
    4-5x: 400 + 16 B per voxel, no fixed term), never under."""
    for n, kb in TRANSPORT_PEAK_KB[command].items():
        ratio = budget.grid_bytes([n] * 3, "transport") / (kb * 1024)
        assert 1.0 <= ratio <= 1.3, (command, n, ratio)


def test_voxel_solve_line_is_not_below_the_process_peak(monkeypatch):
    """The printed voxel-solve memory is the process's (fixed load + grid), not below the
    measured peak (it printed 0.03 GB for a 0.37 GB process at 64^3) and within 1.3x."""
    from psdesign import progress
    from psdesign.flow.voxel_estimate import announce_voxel_solve

    said = []
    monkeypatch.setattr(progress, "estimate", lambda what, s, gb: said.append(gb))
    for n, peak in VOXEL_PEAK_GB.items():
        announce_voxel_solve("z", (n, n, n))
        assert 1.0 <= said[-1] / peak <= 1.3, (n, said[-1], peak)


@pytest.mark.parametrize(
    "size", [(1e-3,) * 3, (7.77e-4,) * 3, (3.3e-4, 2.1e-4, 5e-4)], ids=["1mm", "777um", "box"]
)
def test_allowed_step_and_period_are_accepted(size):
    """``flow.lattice_step``'s and ``rve.period``'s printed bounds, fed back, are accepted
    (session 54: a 1 mm cube printed "step >= 2.71e-06 m" and "period >= 0.000111 m", both
    refused again: the cube root ignored the grid's rounding, :.3g rounded down)."""

    def bound(check, value, word):
        try:
            check(value)
        except Exception as exc:  # noqa: BLE001 - the schema's PydanticCustomError
            return float(re.search(word + r" >= ([0-9.e+-]+) m", exc.context["allowed"]).group(1))
        return None

    def cells(step):
        budget.check_cells("flow.lattice_step", size, step, budget.MAX_LATTICE_CELLS)

    def copies(period):
        budget.check_copies(size, period)

    for check, value, word in ((cells, 1e-7, "step"), (copies, 1e-6, "period")):
        least = bound(check, value, word)
        assert least is not None and bound(check, least, word) is None, (word, least)
