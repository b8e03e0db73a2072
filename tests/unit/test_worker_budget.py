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
    """Set the machine so that 2 workers' shares are each ``times / 2`` one BASE case's voxel
    need (the second worker's fixed load taken off, ``budget.memory_budget``): one process's
    budget is ``times`` the need plus that fixed load."""
    need = budget.grid_bytes(GRID, "voxel")
    whole = times * need + budget.PROCESS_FIXED_BYTES
    monkeypatch.setattr(budget, "machine_memory", lambda: whole / budget.MEMORY_FRACTION)
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
    assert "rve.voxel" in msg and "shared by 2 workers at once)" in msg, msg
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
    with pytest.raises(
        ValueError, match=r"sizes: at 0.0001 m, rve.voxel: .*2 workers at once.*workers=1"
    ):
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


# ---------------------------------------------------------------- session 54 review (round 2)


def test_a_case_is_held_to_its_share_while_it_runs(monkeypatch):
    """The payload carries the run's workers at once; the case runs inside that share
    (the worker started at 1 and an "auto" permeameter's longer stack was checked against
    the whole machine in each of N workers), and the restack check uses it. Truth: the
    share's closed form (B - F) / 2 and the restack estimate of the same grid."""
    from types import SimpleNamespace

    from psdesign.flow.permeability import _restack_refusal
    from psdesign.study import runner
    from psdesign.study.worker import run_case_inline

    seen = []

    def case_fn(spec, outputs, solver, workdir):
        seen.append((budget.workers_at_once(), budget.memory_budget()))
        return {}

    monkeypatch.setattr(budget, "machine_memory", lambda: 8 * 2**30)
    whole = 4 * 2**30
    run_case_inline({"case_fn": case_fn, "spec": {}, "outputs": [], "solver": None,
                     "at_once": 2, "workers_option": "--workers"}, Path("."))  # fmt: skip
    assert seen[-1][0] == (2, "--workers")
    assert seen[-1][1] == pytest.approx((whole - budget.PROCESS_FIXED_BYTES) / 2)
    run_case_inline({"case_fn": case_fn, "spec": {}, "outputs": [], "solver": None}, Path("."))
    assert seen[-1] == ((1, "workers"), whole)  # an old payload: one process, as before
    # the payloads a run sends carry the share it was checked at
    study = SimpleNamespace(outputs=["porosity"], solver="voxel")
    store = SimpleNamespace(workdir=lambda c: Path("w") / c, out=Path("o"))
    case = SimpleNamespace(case_id="c0", spec={})
    with budget.concurrent_workers(3, "--workers"):
        (p,) = runner._payloads(study, [case], store, {"c0": "c0"}, "m:f", None)
    assert (p["at_once"], p["workers_option"]) == (3, "--workers")
    # a restack that fits the machine's budget but not a worker's share is stopped
    res = {"solver": "voxel", "direction": "z"}
    n = 190
    fields = SimpleNamespace(grid=SimpleNamespace(shape=(n, n, n)))
    need = budget.restack_bytes(res, 3, [float(n)] * 3, 0.2)
    assert (whole - budget.PROCESS_FIXED_BYTES) / 2 < need < whole  # the premise
    assert _restack_refusal(res, 3, fields, {"aux_length": 0.2}) == (None, None)
    with budget.concurrent_workers(2):
        why, reason = _restack_refusal(res, 3, fields, {"aux_length": 0.2})
    assert why == "budget" and "shared by 2 workers at once" in reason, reason


def test_rev_bad_run_keywords_are_one_line_study_errors(tmp_path):
    """``out_option=None`` and ``options={"workers": 2}`` are refused with run_study's own
    line (a TypeError and an AttributeError from the share's set-up, session 54's review)."""
    from psdesign.analysis.rev import rev_study

    spec = tmp_path / "s.toml"
    spec.write_text(BASE.replace("[base.", "["))
    with pytest.raises(StudyError, match=r"^out_option: must be a pair"):
        rev_study(spec, [1e-4], 2, tmp_path / "a", out_option=None, progress=False)
    with pytest.raises(StudyError, match=r"^options: must be a psdesign.study.RunOptions"):
        rev_study(spec, [1e-4], 2, tmp_path / "b", options={"workers": 2}, progress=False)
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_refusal_does_not_spell_a_worker_count_the_user_did_not_type(tmp_path, monkeypatch):
    """``--workers 4`` on a 2-case study runs 2 at once: the refusal said "--workers 2"."""
    _machine_for(monkeypatch, 1.5)
    p = write_study(tmp_path, TWO, TWO_PARAMS)
    with pytest.raises(StudyError) as err:
        run_study(p, tmp_path / "o", workers=4, out_option=("-o", "--force"), progress=False)
    msg = str(err.value)
    assert "shared by 2 workers at once)" in msg and "--workers 2" not in msg, msg
    assert msg.endswith(", or --workers 1)"), msg


@pytest.mark.parametrize("gib", [4.0, 23.5])
@pytest.mark.parametrize("n", [1, 2, 8])
def test_every_process_fixed_load_is_counted_once(monkeypatch, gib, n):
    """n workers at their share hold at most the budget plus the one fixed load a single
    voxel process was never charged (the voxel route's share was B / n: 8 workers on 4 GiB
    could reach B + 8 F), and exactly the budget on the transport route, which counts its
    own; one process is unchanged (B). Truth: the sum over the n processes."""
    monkeypatch.setattr(budget, "machine_memory", lambda: gib * 2**30)
    whole, fixed = budget.MEMORY_FRACTION * gib * 2**30, budget.PROCESS_FIXED_BYTES
    with budget.concurrent_workers(n):
        voxel, transport = budget.memory_budget(), budget.memory_budget(True)
    if voxel == 0.0:  # the other workers' fixed loads alone fill it: nothing fits a share
        assert (n - 1) * fixed >= whole
        return
    assert n * (voxel + fixed) == pytest.approx(whole + fixed)
    assert n * transport == pytest.approx(whole)  # its need has F in it
    if n == 1:
        assert voxel == transport == whole
    # the check uses it: a grid at the share fits, one a tenth over is refused
    per = budget.grid_bytes([100] * 3, "voxel") / 1e6
    edge = (voxel / per) ** (1 / 3)
    with budget.concurrent_workers(n):
        budget.check_grid((0.95 * edge * 1e-6,) * 3, 1e-6, "voxel")
        with pytest.raises(Exception, match="needs about"):
            budget.check_grid((1.05 * edge * 1e-6,) * 3, 1e-6, "voxel")


@pytest.mark.parametrize("key", ["rve.voxel", "image.crop"])
def test_no_voxel_fits_a_share_names_the_workers_that_leave_room(monkeypatch, key):
    """1 GiB, 2 transport workers: each share (0.27 GB) is under one process's fixed load
    (0.35 GB); the refusal said "a crop of at most 0 voxels" / "more memory: no grid fits".
    It names the most workers that leave room and the voxel (crop) at their share, accepted
    when fed back."""
    monkeypatch.setattr(budget, "machine_memory", lambda: 2**30)
    size = (200e-6,) * 3
    with budget.concurrent_workers(2, "--workers"), pytest.raises(Exception) as err:
        budget.check_grid(size, 1e-6, "transport", key)
    allowed = err.value.context["allowed"]
    assert allowed.startswith("at most 1 worker at once (--workers 1), with "), allowed
    assert " 0 voxels" not in allowed and "no grid" not in allowed
    if key == "rve.voxel":
        v = float(re.search(r"voxel >= ([0-9.e+-]+) m", allowed).group(1))
        budget.check_grid(size, v, "transport", key)  # one worker: accepted
    else:
        cube = int(re.search(r"about (\d+)\^3", allowed).group(1))
        edge = cube * 1e-6
        budget.check_grid((edge,) * 3, 1e-6, "transport", key)
    # a machine under one fixed load: nothing fits, said so
    monkeypatch.setattr(budget, "machine_memory", lambda: 0.5e9)
    with budget.concurrent_workers(2), pytest.raises(Exception) as err:
        budget.check_grid(size, 1e-6, "transport", key)
    assert err.value.context["allowed"].startswith("more memory: no grid fits")


def test_optimize_rounds_share_the_first_rounds_workers(tmp_path, monkeypatch, capsys):
    """Inside one_share (study optimize's rounds) the workers at once are the first run's,
    over its pending cases (finished ones hold no memory), and the thread warning prints
    once (round 2 counted all 6 cases of --workers 8: a case accepted in round 1 could be
    refused; the warning repeated each round)."""
    from types import SimpleNamespace

    from psdesign.study import runner
    from psdesign.study.options import RunOptions

    opts = RunOptions(workers=8)
    cases = [SimpleNamespace(case_id=f"c{i}", seed=1, params={}) for i in range(6)]
    monkeypatch.setattr(runner, "match_finished", lambda cs, loaded: {k: k for k in loaded})
    store = tmp_path / "cases"
    store.mkdir()
    for i in range(4):  # four finished cases in the folder: two pending
        (store / f"c{i}.json").write_text(f'{{"case_id": "c{i}", "status": "ok"}}')
    assert runner._at_once(opts, cases, tmp_path) == 2
    assert runner._at_once(opts, cases, tmp_path / "new") == 6
    with runner.one_share():
        assert runner._at_once(opts, cases[:4], tmp_path / "new") == 4
        assert runner._at_once(opts, cases, tmp_path / "new") == 4  # the first round's
        assert [runner._warn_once() for _ in range(3)] == [True, False, False]
    assert runner._warn_once()  # outside: every run warns
    # a resumed optimize whose round 1 had finished counted 0 to run: later rounds one at a time
    for i in range(4, 6):
        (store / f"c{i}.json").write_text(f'{{"case_id": "c{i}", "status": "ok"}}')
    with runner.one_share():
        assert runner._at_once(opts, cases, tmp_path) == 6
        assert runner._at_once(opts, cases[:2], tmp_path / "new") == 6


def test_printed_upper_bounds_are_accepted_when_fed_back():
    """``rve.period <= X`` was rounded to nearest (0.0334 for 100 x 3.337e-4, refused);
    ``intersections.step >= X`` printed with :g (3.33333e-08 for 3.3333337e-08, refused)."""
    from psdesign.schema.spec import validate_spec

    size = (3.337e-4,) * 3
    with pytest.raises(Exception) as err:
        budget.check_copies(size, 1.0)
    top = float(re.search(r"period <= ([0-9.e+-]+) m", err.value.context["allowed"]).group(1))
    budget.check_copies(size, top)
    assert budget.round_down(0.03337) == 0.0333 and budget.round_down(9.999e-6) == 9.99e-6

    def step_bound(step):
        spec = {
            "rve": {"size": [3.3333337e-4] * 3, "voxel": 1e-5},
            "generator": {"porosity": 0.9, "diameter": 2e-5},
            "intersections": {"method": "fast", "step": step},
        }
        try:
            validate_spec(spec)
        except Exception as exc:  # noqa: BLE001 - the spec's one-line error
            m = re.search(r"intersections.step: .*allowed: >= ([0-9.e+-]+) m", str(exc))
            assert m, str(exc)
            return float(m.group(1))
        return None

    least = step_bound(1e-9)
    assert least is not None and step_bound(least) is None


def test_spec_keys_figures_come_from_the_constants(monkeypatch):
    """docs/spec-keys.md's transport figures are the budget's constants (130 B per voxel and
    0.35 GB were written into the text beside the substituted voxel figure)."""
    from psdesign.schema import docs

    text = docs.render()
    per = budget.TRANSPORT_BYTES_PER_VOXEL + budget.GEOMETRY_BYTES_PER_VOXEL
    assert f"transport solve's {per} B per voxel and 0.35 GB" in text
    monkeypatch.setattr(docs, "PROCESS_FIXED_BYTES", 0.5e9)
    monkeypatch.setattr(docs, "TRANSPORT_BYTES_PER_VOXEL", 200)
    assert "transport solve's 216 B per voxel and 0.5 GB" in docs.render()
    assert (Path(__file__).resolve().parents[2] / "docs" / "spec-keys.md").read_text() == text


def test_a_timed_case_child_runs_in_the_share(tmp_path):
    """With a time limit the case runs in a child process fed a JSON job: the job carries
    the share (the child's job check refused the new keys, every timed case failed)."""
    from psdesign.study.worker import execute_case

    payload = {
        "case_id": "c0",
        "spec": {},
        "outputs": ["porosity"],
        "solver": "voxel",
        "workdir": str(tmp_path / "w"),
        "out_dir": str(tmp_path),
        "timeout_s": 120.0,
        "case_fn": "study_cases:share_case",
        "at_once": 3,
        "workers_option": "workers",
    }
    rec = execute_case(payload)
    assert rec["status"] == "ok", rec.get("error")
    assert rec["results"]["at_once"] == 3.0
