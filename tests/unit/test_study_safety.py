"""Study runner safety (issue 11, item 4): lock before clean-up, psdesign's own temp names only,
no pickle read back from disk, ``not_converged`` status, Ctrl-C, Dask security and junk peers."""

from __future__ import annotations

import contextlib
import json
import os
import pickle
import signal
import socket
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd
import pytest
from study_cases import FAC_PARAMS, FACTORIAL, TESTS_DIR, fake_case, write_study

from psdesign.io.outputs import OutputError
from psdesign.study import SchedulerError, StudyError, run_study
from psdesign.study import runner as runner_mod
from psdesign.study.exchange import CaseExchangeError, read_result, result_paths
from psdesign.study.worker import untrusted_reason

HERE = Path(__file__).resolve().parent
ONE = 'design = "full-factorial"\noutputs = ["porosity", "k_x", "k_z"]\nsolver = "voxel"'


# ----------------------------------------------------------------------------- case functions
# Module-level: imported by name in worker and per-case child processes.


def unconverged_case(spec, outputs, solver, workdir):
    out = fake_case(spec, outputs, solver, workdir)
    if spec["generator"]["porosity"] == 0.8:
        out["converged_z"] = False
    return out


def flagged_case(spec, outputs, solver, workdir):
    out = fake_case(spec, outputs, solver, workdir)
    out["status_x"] = "entrance_bias"
    return out


def planting_case(spec, outputs, solver, workdir):
    """Plays the attacker who can write the output folder, then the child dies."""

    class Evil:
        def __reduce__(self):
            return (Path.touch, (Path(workdir) / "PWNED",))

    (Path(workdir) / ".case_output.pkl").write_bytes(pickle.dumps({"ok": True, "results": Evil()}))
    result, _ = result_paths(Path(workdir))
    result.write_text('{"ok": true, "results": [1, 2]}')
    os._exit(0)


def slow_unless_flag_case(spec, outputs, solver, workdir):
    """Sleeps 60 s while ``FLAG`` (beside the output folder) exists, else a fast fake case."""
    flag = Path(workdir).resolve().parents[2] / "FLAG"  # workdir = <tmp>/out/cases/<id>
    if flag.exists() and spec["generator"]["porosity"] != 0.7:
        (Path(workdir) / "pid.txt").write_text(str(os.getpid()))
        time.sleep(60)
    return fake_case(spec, outputs, solver, workdir)


# ----------------------------------------------------------------------------- lock, temp files


def test_cleanup_after_lock_and_only_psdesign_temp_files(tmp_path):
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    user_tmp = [out / ".notes.tmp", out / "cases" / ".draft.tmp", out / "cases" / ".x.json.tmp"]
    for f in user_tmp:
        f.write_text("the user's")
    ours = [out / ".psdesign-results.csv.99999.tmp", out / "cases" / ".psdesign-c.json.1.tmp"]
    for f in ours:
        f.write_text("stale")
    # a live run holds the lock: nothing may be deleted, not even psdesign's temp files
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        (out / ".lock").write_text(json.dumps({"pid": sleeper.pid, "host": socket.gethostname()}))
        with pytest.raises(StudyError, match="in use by a running study"):
            run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
        assert all(f.exists() for f in user_tmp + ours)
    finally:
        sleeper.kill()
        sleeper.wait()
    run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    assert all(f.read_text() == "the user's" for f in user_tmp)
    assert not any(f.exists() for f in ours)


def test_study_output_folder_rules(tmp_path):
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    user = tmp_path / "user"
    user.mkdir()
    (user / "results.csv").write_text("my own table")
    with pytest.raises(OutputError, match="non-empty folder psdesign did not create"):
        run_study(p, user, workers=0, case_fn=fake_case, progress=False)
    with pytest.raises(OutputError, match="results.csv exists and was not written by psdesign"):
        run_study(p, user, workers=0, case_fn=fake_case, progress=False, force=True)
    assert sorted(x.name for x in user.iterdir()) == ["results.csv"]
    # --force beside unrelated user files works and keeps them
    (user / "results.csv").rename(user / "mine.csv")
    df = run_study(p, user, workers=0, case_fn=fake_case, progress=False, report=False, force=True)
    assert len(df) == 12 and (user / "mine.csv").read_text() == "my own table"
    # an old study folder (no marker) is still resumed
    (user / ".psdesign-output.json").unlink()
    (user / "mine.csv").unlink()
    again = run_study(p, user, workers=0, case_fn=fake_case, progress=False, report=False)
    assert len(again) == 12


@pytest.mark.parametrize("name", ["summary.csv", "summary.parquet"])
def test_user_summary_is_refused_even_with_force(tmp_path, name):
    """audit (session 31): ``study run -o user --force`` replaced a user's ``summary.csv`` /
    ``summary.parquet`` with the study's table, and the marker did not list them. Rule: refused
    before the run (one line), the folder left byte-identical; psdesign's own are recorded."""
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    user = tmp_path / "user"
    user.mkdir()
    mine = b"my own summary\n\x00\xff"
    (user / name).write_bytes(mine)
    with pytest.raises(OutputError, match=f"{name} exists and was not written by psdesign"):
        run_study(p, user, workers=0, case_fn=fake_case, progress=False, force=True)
    assert [x.name for x in user.iterdir()] == [name] and (user / name).read_bytes() == mine
    # psdesign's own summary files are listed in the marker: a rerun replaces them
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    files = json.loads((out / ".psdesign-output.json").read_text())["files"]
    assert {"summary.csv", "summary.parquet"} <= set(files)
    (out / "summary.csv").write_text("stale")
    run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    assert len(pd.read_csv(out / "summary.csv")) == 6


# ----------------------------------------------------------------------------- no pickle


def test_timeout_mode_never_unpickles_what_it_reads_back(tmp_path):
    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7]')
    out = tmp_path / "out"
    df = run_study(
        p, out, workers=0, case_fn=planting_case, progress=False, report=False, timeout_s=60
    )
    (workdir,) = [d for d in (out / "cases").iterdir() if d.is_dir()]
    assert not (workdir / "PWNED").exists()
    assert df["status"].tolist() == ["failed"]
    assert "unreadable case result" in df["error"].iloc[0]


def test_timeout_mode_round_trips_arrays_through_json_and_npz(tmp_path):
    p = write_study(
        tmp_path, ONE.replace('"k_z"]', '"k_z", "k_tensor"]'), '"generator.porosity" = [0.7]'
    )
    a = run_study(p, tmp_path / "a", workers=0, case_fn=fake_case, progress=False, report=False)
    b = run_study(
        p, tmp_path / "b", workers=0, case_fn=fake_case, progress=False, report=False, timeout_s=60
    )
    assert b["status"].tolist() == ["ok"]
    cols = [c for c in a.columns if c.startswith("k_")]
    assert len(cols) == 11  # k_x, k_z and the 9 tensor entries (sent as an npz array)
    pd.testing.assert_frame_equal(a[cols], b[cols])
    assert not list((tmp_path / "b").rglob("*.pkl"))


@pytest.mark.parametrize(
    "text",
    ["", "not json", "[1]", '{"ok": "yes"}', '{"ok": true, "results": 1}', '{"ok": false}'],
)
def test_read_result_validates(tmp_path, text):
    result, _ = result_paths(tmp_path)
    result.write_text(text)
    with pytest.raises(CaseExchangeError):
        read_result(tmp_path)


def test_read_result_refuses_object_arrays(tmp_path):
    import numpy as np

    result, arrays = result_paths(tmp_path)
    np.savez(arrays, a0=np.array([{"x": 1}], dtype=object))
    result.write_text('{"ok": true, "results": {"v": {"__psdesign_ndarray__": "a0"}}}')
    with pytest.raises(CaseExchangeError):
        read_result(tmp_path)


# ----------------------------------------------------------------------------- not_converged


def test_untrusted_reason():
    assert untrusted_reason({"converged_x": True, "status": "ok", "k_x_m2": 1.0}) is None
    assert "converged_z=False" in untrusted_reason({"converged_x": True, "converged_z": False})
    assert "converged=False" in untrusted_reason({"converged": False})
    assert "status_x=entrance_bias" in untrusted_reason({"status_x": "entrance_bias"})
    assert "trusted=False" in untrusted_reason({"trusted": False})


def test_untrusted_reason_reads_the_columns_run_case_writes():
    """Product rule: a result that is not converged says so in its status. The transport
    outputs write ``diffusivity_<d>_converged`` / ``conductivity_<d>_converged``; before audit20
    only the ``converged_*`` prefix matched, so an unconverged Laplace solve was recorded
    ``ok``. ``k_<d>_status = "untrustworthy"`` keeps the case ok (the shipped voxel studies run
    at 7 voxels per fiber diameter, below the 8 of that flag) but is counted."""
    ok = {"k_z_m2": 1e-11, "k_z_status": "ok", "converged_z": True}
    assert untrusted_reason(ok) is None
    assert untrusted_reason({**ok, "diffusivity_z_converged": True}) is None
    got = untrusted_reason({**ok, "diffusivity_x_converged": False})
    assert "diffusivity_x_converged=False" in got
    got = untrusted_reason({**ok, "conductivity_y_converged": False})
    assert "conductivity_y_converged=False" in got
    assert "k_z_status=not_converged" in untrusted_reason({**ok, "k_z_status": "not_converged"})
    assert untrusted_reason({**ok, "k_z_status": "untrustworthy"}) is None
    assert untrusted_reason({"k_z_status": None}) is None  # a failed case has no K


def untrustworthy_case(spec, outputs, solver, workdir):
    out = fake_case(spec, outputs, solver, workdir)
    out["k_z_status"] = "untrustworthy" if spec["generator"]["porosity"] == 0.8 else "ok"
    return out


def test_untrustworthy_k_is_counted_in_one_line_and_exits_3(tmp_path, capsys):
    """Rule (psdesign/cli/exit_status.py, session 45): 3 when a result finished with complete
    outputs but its status is not ok. An ok case whose K the product rates ``untrustworthy``
    (k_z_status) made ``study run`` exit 0 with a warning, so ``psdesign study run ... &&``
    accepted it; now 3, one line counting it. ``--allow-not-converged`` accepts unconverged
    cases only (its name): the flagged K still exits 3. Fails on main's exit_status.py/study.py
    (0)."""
    from psdesign.cli.study import main

    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7, 0.8]')
    args = ["study", "run", str(p), "-o", str(tmp_path / "out"), "--quiet", "--no-report"]
    assert main([*args, "--case-fn", "test_study_safety:untrustworthy_case"]) == 3
    err = capsys.readouterr().err
    assert "psdesign: 1 ok case(s) have a value whose own status is not ok (k_z_status: " in err
    assert len(err.strip().splitlines()) == 1
    flag = [*args, "--case-fn", "test_study_safety:untrustworthy_case", "--allow-not-converged"]
    assert main(flag) == 3  # resumed: both cases recorded, nothing re-run
    df = pd.read_csv(tmp_path / "out" / "results.csv")
    assert df["status"].tolist() == ["ok", "ok"]
    assert df["k_z_status"].tolist() == ["ok", "untrustworthy"]


def warning_case(spec, outputs, solver, workdir):
    import warnings

    warnings.warn("K_z: only 6.0 voxels across\n the fiber", UserWarning, stacklevel=1)
    return fake_case(spec, outputs, solver, workdir)


def test_worker_warnings_are_one_line(tmp_path, capfd):
    """Product rule: one line per message, never Python's two-line warning with the source
    file and the code line (main: a pool worker printed ``.../x.py:12: UserWarning: ...`` and
    ``  warnings.warn(...)``)."""
    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7]')
    df = run_study(
        p, tmp_path / "out", workers=1, case_fn=warning_case, progress=False, report=False
    )
    assert df["status"].tolist() == ["ok"]
    err = capfd.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    cid = df["case_id"].iloc[0]
    assert lines == [f"psdesign: warning: case {cid}: K_z: only 6.0 voxels across the fiber"], err


def test_a_timed_case_names_itself_in_its_warnings(tmp_path):
    """--timeout runs each case in a child process whose stderr is the case's case.log: its
    warnings were written there as ``psdesign: warning: K_z: ...`` without the case id (session
    42 saw it; every other route prefixes it, show_case_warnings). Old code: the line had no
    ``case <id>:``."""
    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7]')
    df = run_study(
        p,
        tmp_path / "out",
        workers=0,
        case_fn=warning_case,
        progress=False,
        report=False,
        timeout_s=120,
    )
    assert df["status"].tolist() == ["ok"]
    cid = df["case_id"].iloc[0]
    (log,) = (tmp_path / "out").rglob("case.log")
    lines = [ln for ln in log.read_text().splitlines() if "warning" in ln]
    assert lines == [f"psdesign: warning: case {cid}: K_z: only 6.0 voxels across the fiber"]


def resolution_case(spec, outputs, solver, workdir):
    """The voxel route's ResolutionWarning, raised by each of two directions' solves."""
    import warnings

    from psdesign.flow.voxel import ResolutionWarning

    msg = "voxel grid has 7.0 voxels across the thinnest fiber"
    warnings.warn(msg, ResolutionWarning, stacklevel=1)  # the k_x solve
    warnings.warn(msg, ResolutionWarning, stacklevel=1)  # the k_z solve (another line)
    return fake_case(spec, outputs, solver, workdir)


@pytest.mark.parametrize("workers", [0, 1])
def test_a_study_names_the_case_of_each_warning_once(tmp_path, capfd, workers):
    """Session 42's walkthrough (benchmarks/RESULTS.md): a study printed "voxel grid has 7.0
    voxels ..." once per case without saying which case; now one line per case with its id
    (two solves of one case raising it: still one line)."""
    import warnings

    from psdesign.errors import show_warning_one_line

    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    with warnings.catch_warnings():
        warnings.showwarning = show_warning_one_line  # as the psdesign command installs it
        df = run_study(
            p,
            tmp_path / "out",
            workers=workers,
            case_fn=resolution_case,
            progress=False,
            report=False,
        )
    err = capfd.readouterr().err
    lines = sorted(ln for ln in err.splitlines() if "voxel grid has" in ln)
    assert lines == sorted(
        f"psdesign: warning: case {cid}: voxel grid has 7.0 voxels across the thinnest fiber"
        for cid in df["case_id"]
    ), err


def under_resolved_case(spec, outputs, solver, workdir):
    """A real voxel solve through psdesign's route with 6 voxels across the fibre: the
    ResolutionWarning is raised inside psdesign (at psdesign/flow/permeability.py's line)."""
    from psdesign.flow.permeability import permeability
    from psdesign.geometry.fibers import make_fiber
    from psdesign.geometry.rve import RVE

    rve = RVE([12e-6] * 3, [make_fiber("cylinder", 0.5, direction=[0, 0, 1])])
    permeability(rve, rve.voxelize(1e-6), "x", {"viscosity": 1.8e-5}, "voxel", None, False)
    return fake_case(spec, outputs, solver, workdir)


def test_an_in_process_case_warning_points_at_the_callers_line(tmp_path):
    """Session 43 (s43-polish item 4): with workers=0 a case's warnings were re-shown at the
    line inside psdesign that raised them ("psdesign/flow/permeability.py:178:
    ResolutionWarning: case c0000-...: voxel grid has 6.0 voxels ..."), not the user's call, as
    the API's other calls do (test_api.py); now at this file's run_study line, with the case id,
    and again on a second run from the same line."""
    import warnings

    from psdesign.flow.voxel import ResolutionWarning

    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7]')
    for out in ("out1", "out2"):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")
            df = run_study(
                p,
                tmp_path / out,
                workers=0,
                case_fn=under_resolved_case,
                progress=False,
                report=False,
            )
        ours = [w for w in caught if issubclass(w.category, ResolutionWarning)]
        cid = df["case_id"].iloc[0]
        assert len(ours) == 1 and ours[0].filename == __file__
        assert str(ours[0].message).startswith(f"case {cid}: voxel grid has 6.0 voxels")


def unconverged_transport_case(spec, outputs, solver, workdir):
    out = fake_case(spec, outputs, solver, workdir)
    out["diffusivity_z_converged"] = spec["generator"]["porosity"] != 0.8
    return out


def test_unconverged_transport_output_is_not_recorded_ok(tmp_path):
    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7, 0.8]')
    df = run_study(
        p,
        tmp_path / "out",
        workers=0,
        case_fn=unconverged_transport_case,
        progress=False,
        report=False,
    )
    st = dict(zip(df["generator.porosity"], df["status"], strict=True))
    assert st == {0.7: "ok", 0.8: "not_converged"}
    err = df[df["status"] == "not_converged"]["error"].iloc[0]
    assert "diffusivity_z_converged=False" in err


def test_not_converged_status_resume_retry_and_exit_code(tmp_path, capsys):
    from psdesign.cli.study import main

    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "out"
    args = ["study", "run", str(p), "-o", str(out), "--quiet", "--no-report", "--case-fn"]
    # 3, not 1: the outputs are complete; 1 is a run that could not finish (exit_status)
    assert main([*args, "test_study_safety:unconverged_case"]) == 3
    assert "1 case(s) not_converged" in capsys.readouterr().err
    df = pd.read_csv(out / "results.csv")
    st = dict(zip(df["generator.porosity"], df["status"], strict=True))
    assert st == {0.7: "ok", 0.8: "not_converged"}
    assert "converged_z=False" in df[df["status"] == "not_converged"]["error"].iloc[0]
    calls = {d.name: (d / "calls.txt").read_text() for d in (out / "cases").iterdir() if d.is_dir()}
    # resume: not_converged counts as finished; --allow-not-converged exits 0
    assert main([*args, "test_study_safety:unconverged_case", "--allow-not-converged"]) == 0
    assert {
        d.name: (d / "calls.txt").read_text() for d in (out / "cases").iterdir() if d.is_dir()
    } == calls
    # --retry-not-converged re-runs only that case; a fixed solver gives ok and exit 0
    assert main([*args, "study_cases:fake_case", "--retry-not-converged"]) == 0
    df = pd.read_csv(out / "results.csv")
    assert (df["status"] == "ok").all()
    reran = [c for c, t in calls.items() if (out / "cases" / c / "calls.txt").read_text() != t]
    assert len(reran) == 1


def test_flagged_case_is_not_converged_and_shown_in_report(tmp_path):
    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7]')
    out = tmp_path / "out"
    df = run_study(p, out, workers=0, case_fn=flagged_case, progress=False, report=True)
    assert df["status"].tolist() == ["not_converged"]
    html = (out / "report.html").read_text()
    assert "not_converged" in html


# ----------------------------------------------------------------------------- Ctrl-C


def _start_runner(
    tmp_path: Path,
    timeout: float | None,
    workers: int = 2,
    params: str = '"generator.porosity" = [0.7, 0.75, 0.8, 0.85]',
    extra=(),
):
    flag = tmp_path / "FLAG"
    flag.write_text("slow")
    p = write_study(tmp_path, ONE, params)
    out = tmp_path / "out"
    code = (
        f"import sys; sys.path[:0] = [{str(TESTS_DIR)!r}, {str(HERE)!r}]\n"
        # the process the psdesign command runs (console: Ctrl-C ignored once main returned)
        "from psdesign.cli.main import console\n"
        f"sys.argv = ['psdesign', 'study', 'run', {str(p)!r}, '-o', {str(out)!r}, '--workers',"
        f" '{workers}', '--no-report', '--case-fn', 'test_study_safety:slow_unless_flag_case']"
        + (f" + ['--timeout', '{timeout}']" if timeout else "")
        + f" + {list(extra)!r}"
        + "\nconsole()\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code],
        start_new_session=True,  # its own process group, as a terminal gives a job
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    return proc, p, out, flag


def _wait_for_sleepers(proc, out: Path, n: int, limit_s: float = 60.0) -> None:
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        if len(list((out / "cases").glob("*/pid.txt"))) >= n:
            return
        assert proc.poll() is None, proc.stderr.read().decode()
        time.sleep(0.05)
    raise AssertionError("cases did not start")


def _kill_all(procs) -> None:
    """Kill what a stop test left alive (clean-up; the test's assertions come before)."""
    import psutil

    for k in procs:
        try:
            k.kill()
        except psutil.Error:
            pass


def _resumes(p, out, flag) -> None:
    """The stopped run left no lock and resumes: the cases finished before are kept, and the
    rest run (the flag that held them is removed)."""
    assert not (out / ".lock").exists()
    done_before = {f.name for f in (out / "cases").glob("*.json")}
    flag.unlink()
    df = run_study(p, out, workers=0, case_fn=slow_unless_flag_case, progress=False, report=False)
    assert len(df) == 4 and (df["status"] == "ok").all()
    assert done_before <= {f.name for f in (out / "cases").glob("*.json")}


@pytest.mark.parametrize(
    ("target", "times", "timeout"),
    [
        pytest.param("group", 2, None, id="group-twice"),
        pytest.param("group", 1, None, id="group-once", marks=pytest.mark.slow),
        pytest.param("runner", 2, None, id="runner-alone-twice", marks=pytest.mark.slow),
        pytest.param("group", 2, 120.0, id="group-twice-timeout-mode", marks=pytest.mark.slow),
        pytest.param("runner", 1, 120.0, id="runner-once-timeout-mode", marks=pytest.mark.slow),
    ],
)
def test_ctrl_c_stops_runner_and_workers_and_leaves_resumable_folder(
    tmp_path, target, times, timeout
):
    import psutil

    proc, p, out, flag = _start_runner(tmp_path, timeout)
    procs: list = []
    try:
        _wait_for_sleepers(proc, out, 2)
        procs = [psutil.Process(proc.pid), *psutil.Process(proc.pid).children(recursive=True)]
        assert len(procs) >= 3  # the runner, 2 workers (+ per-case children in timeout mode)
        for i in range(times):
            if target == "group":
                os.killpg(proc.pid, signal.SIGINT)
            else:
                os.kill(proc.pid, signal.SIGINT)
            if i + 1 < times:
                time.sleep(0.1)
        gone, alive = psutil.wait_procs(procs, timeout=5.0)  # the limit
        assert not alive, [a.pid for a in alive]
        err = proc.stderr.read().decode()
        (runner,) = [g for g in gone if g.pid == proc.pid]
        assert runner.returncode == 130, err
        assert "rerun the command to resume" in err and "Traceback" not in err
    finally:
        _kill_all(procs)
    _resumes(p, out, flag)


@pytest.mark.parametrize("target", ["runner", pytest.param("group", marks=pytest.mark.slow)])
def test_sigterm_stops_runner_and_workers_releases_lock_and_resumes(tmp_path, target):
    """``kill PID`` / ``timeout`` / a batch system's cancel send SIGTERM, to the runner or (Slurm's
    ``scancel``, ``kill -TERM -PGID``) to the whole process group, workers included. Rules: never
    a traceback, nothing half-written, the folder resumable. On main the runner died at once
    (exit -15, Python's multi-line resource_tracker warning) and left ``OUT/.lock`` behind,
    which a run from another host refuses until deleted by hand."""
    import psutil

    proc, p, out, flag = _start_runner(tmp_path, None)
    procs: list = []
    try:
        _wait_for_sleepers(proc, out, 2)
        procs = [psutil.Process(proc.pid), *psutil.Process(proc.pid).children(recursive=True)]
        assert len(procs) >= 3
        if target == "group":
            os.killpg(proc.pid, signal.SIGTERM)
        else:
            os.kill(proc.pid, signal.SIGTERM)
        gone, alive = psutil.wait_procs(procs, timeout=5.0)
        assert not alive, [a.pid for a in alive]
        err = proc.stderr.read().decode()
        (runner,) = [g for g in gone if g.pid == proc.pid]
        assert runner.returncode == 143, err
        assert "terminated" in err and "rerun the command to resume" in err
        assert "Traceback" not in err and "leaked" not in err
    finally:
        _kill_all(procs)
    _resumes(p, out, flag)


EIGHT = '"generator.porosity" = [0.7, 0.75, 0.8, 0.85]\n"generator.diameter" = [6e-6, 7e-6]'
"""8 cases for 2 workers: more than the pool's call queue holds (workers + 1), so the queue is
full when the run is stopped, the state in which the pool's stop used to hang."""


def _stop_once(
    tmp_path: Path, sig: int, group: bool, delay_s: float, params: str = EIGHT, extra=()
) -> tuple[int | None, str]:
    """Start an 8-case, 2-worker ``study run`` (slow cases), send ``sig`` ``delay_s`` after its
    "to run on" line (while the workers start or run), and return (exit status or None if it
    was still running 20 s later, stderr)."""
    import psutil

    tmp_path.mkdir()
    proc, _p, _out, _flag = _start_runner(tmp_path, None, params=params, extra=extra)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stderr), daemon=True)
    reader.start()
    deadline = time.monotonic() + 60.0
    while not any(b"to run on" in ln for ln in lines) and time.monotonic() < deadline:
        assert proc.poll() is None, b"".join(lines).decode()
        time.sleep(0.02)
    time.sleep(delay_s)
    procs = [psutil.Process(proc.pid), *psutil.Process(proc.pid).children(recursive=True)]
    (os.killpg if group else os.kill)(proc.pid, sig)
    try:
        status = proc.wait(timeout=20.0)  # the hang: "psdesign: error: interrupted", no exit
    except subprocess.TimeoutExpired:
        status = None
    _kill_all(procs)
    proc.wait()
    reader.join(5.0)
    return status, b"".join(lines).decode()


@pytest.mark.parametrize(
    ("sig", "group", "delays"),
    [
        pytest.param(signal.SIGINT, True, (0.0, 1.0), id="ctrl-c-group"),
        pytest.param(signal.SIGTERM, False, (0.5, 2.0), id="sigterm-runner"),
        pytest.param(
            signal.SIGINT,
            True,
            (0.1, 0.3, 0.5, 0.7, 1.5, 2.0, 3.0, 5.0),
            id="ctrl-c-more",
            marks=pytest.mark.slow,
        ),
        pytest.param(
            signal.SIGTERM, False, (1.0, 4.0), id="sigterm-runner-more", marks=pytest.mark.slow
        ),
        pytest.param(
            signal.SIGTERM, True, (0.3, 1.0, 3.0, 6.0), id="sigterm-group", marks=pytest.mark.slow
        ),
    ],
)
def test_a_stop_while_the_pool_queue_is_full_exits_with_one_line(tmp_path, sig, group, delays):
    """Ctrl-C or SIGTERM while 8 cases wait for 2 workers (starting or running) exits 130/143
    within 20 s with one line. On session 52's main the runner hung for ever after printing
    "psdesign: error: interrupted" (walk-study, session 53: 2 of 3 Ctrl-C, 2 of 9 SIGTERM):
    the clean-up reaped the pool's workers itself, so multiprocessing saw them alive for ever and
    its manager thread spun in shutdown_workers with the call queue full; and a Ctrl-C while a
    worker was still importing printed that worker's KeyboardInterrupt traceback."""
    want = 143 if sig == signal.SIGTERM else 130
    # two runs side by side (each its own folder and process group): a run's wall is mostly
    # waiting (its start-up, the delay, the stop), so one after another left the test's core idle
    with ThreadPoolExecutor(2) as pool:
        runs = list(
            pool.map(
                lambda i: _stop_once(tmp_path / f"r{i}", sig, group, delays[i]), range(len(delays))
            )
        )
    for delay, (status, err) in zip(delays, runs, strict=True):
        assert status == want, (delay, status, err)
        # multiprocessing's resource tracker's "1 leaked semaphore" warning (2 lines) counts:
        # session 53's CI saw it in ~1 stop of 25 at 0.0 s, too rare to fail here reliably;
        # test_an_interrupt_while_the_pool_is_made_leaks_no_semaphore guards its cause
        lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("[study]")]
        assert len(lines) == 1 and lines[0].startswith("psdesign: error: "), (delay, err)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("sig", "word"), [(signal.SIGTERM, "terminated"), (signal.SIGINT, "interr")]
)
def test_a_stopped_local_dask_run_prints_only_its_line(tmp_path, sig, word):
    """SIGTERM or Ctrl-C to the process group of a ``--scheduler local`` run: exit 143/130 and
    one line. The local cluster's nannies (threads of the runner) logged 1-4 "distributed.nanny
    - WARNING - Restarting worker" lines above it on SIGTERM (walk-study, session 53; 2 of 2
    stops on the old code), and on Ctrl-C each Dask worker logged "Async instruction for <Task
    cancelled ...>" (6 of 6): dask's logs are quiet while the runner stops and the workers
    ignore Ctrl-C. Three stops, ~15 s each."""
    for i in range(3):
        status, err = _stop_once(
            tmp_path / f"r{i}",
            sig,
            True,
            2.0,
            params='"generator.porosity" = [0.7, 0.75, 0.8, 0.85]',
            extra=("--scheduler", "local"),
        )
        assert status == (143 if sig == signal.SIGTERM else 130), err
        lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("[study]")]
        lines = [ln for ln in lines if "Port 8787" not in ln]  # another dask on the machine
        assert len(lines) == 1 and lines[0].startswith(f"psdesign: error: {word}"), err


def test_an_error_in_the_runner_stops_the_pool_workers_at_once(tmp_path):
    """Review s53: the runner's clean-up after an error took the pool's workers from the
    executor after ``shutdown``, which forgets them, so it stopped none: the runner waited for
    the other worker's case (60 s here; the review's 40 s case gave exit 1 after 43.7 s) and
    the worker ran on after the study's lock was released. Truth: exit 1 with one line well
    before the sleeping case could end (3.6 s measured), and no case process is left."""
    import psutil

    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.75]')
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS_DIR.parent), str(TESTS_DIR)])}
    cmd = [sys.executable, "-m", "psdesign", "study", "run", str(p), "-o", str(tmp_path / "o")]
    cmd += ["--workers", "2", "--no-report", "--case-fn", "study_cases:record_breaking_case"]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1, proc.stderr
    assert time.monotonic() - t0 < 45.0, proc.stderr  # the other case sleeps 60 s
    # the sleeping case's worker (when it had started: under load a spawn can be slow, and be
    # stopped while it writes its pid) is gone
    texts = [f.read_text().strip() for f in (tmp_path / "o").rglob("pid.txt")]
    for pid in [int(t) for t in texts if t]:
        assert not psutil.pid_exists(pid) or psutil.Process(pid).status() == "zombie"


def test_interrupt_stops_only_processes_started_during_the_run():
    from psdesign.study.interrupt import stop_on_interrupt

    sleep = [sys.executable, "-c", "import time; time.sleep(60)"]
    before = subprocess.Popen(sleep)
    during = None
    handler = signal.getsignal(signal.SIGINT)  # whatever the caller had (other tests may set one)
    term_handler = signal.getsignal(signal.SIGTERM)
    try:
        with pytest.raises(KeyboardInterrupt), stop_on_interrupt():
            during = subprocess.Popen(sleep)
            raise KeyboardInterrupt
        during.wait(timeout=5)  # stopped (reaped by psutil: no exit status to check)
        assert before.poll() is None  # the caller's own child is left alone
        assert signal.getsignal(signal.SIGINT) is handler  # restored
        assert signal.getsignal(signal.SIGTERM) is term_handler
    finally:
        for proc in (before, during):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait()


# ----------------------------------------------------------------------------- Dask


class _JunkServer:
    """A plain TCP server on 127.0.0.1 that answers every connection with ``payload``."""

    def __init__(self, payload: bytes | None):
        self.payload = payload
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.conns: list = []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.payload is not None:
                try:
                    conn.sendall(self.payload)
                except OSError:
                    pass

    def close(self) -> None:
        self.sock.close()
        for c in self.conns:
            c.close()


@pytest.mark.parametrize(
    ("payload", "match"),
    [
        (b"\xff" * 64, "does not speak the Dask protocol"),  # claims a 16 EiB message
        (b"HTTP/1.1 400 Bad Request\r\n\r\n" * 4, "does not speak the Dask protocol"),
        (None, "sent no Dask handshake within 2 s"),
    ],
)
def test_non_dask_peer_gives_clean_error_fast(tmp_path, monkeypatch, payload, match):
    monkeypatch.setattr(runner_mod, "CONNECT_TIMEOUT_S", 2.0)
    srv = _JunkServer(payload)
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    t0 = time.monotonic()
    try:
        with pytest.raises(SchedulerError, match=match) as info:
            run_study(p, tmp_path / "out", scheduler=f"tcp://127.0.0.1:{srv.port}", progress=False)
    finally:
        srv.close()
    assert time.monotonic() - t0 < 10
    assert len(str(info.value).splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_plain_tcp_to_another_machine_warns_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner_mod, "CONNECT_TIMEOUT_S", 1.0)
    with pytest.raises(SchedulerError):
        runner_mod.connect_scheduler("tcp://192.0.2.1:8786", 1)  # TEST-NET-1: nobody there
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unencrypted" in err[0] and "tls://" in err[0]
    with pytest.raises(SchedulerError):
        runner_mod.connect_scheduler("tcp://127.0.0.1:9", 1)
    assert capsys.readouterr().err == ""  # loopback: no warning


def test_tls_options_are_checked(tmp_path):
    # bad options are bad input (StudyError, a SpecError), not a scheduler failure
    with pytest.raises(StudyError, match="^--tls-cert: required"):
        runner_mod.scheduler_security(tls_ca_file=str(tmp_path / "ca.pem"))
    with pytest.raises(StudyError, match="^--tls-ca-file: no such file"):
        runner_mod.scheduler_security(str(tmp_path / "a"), str(tmp_path / "b"), str(tmp_path / "c"))
    with pytest.raises(StudyError, match="tls:// needs --tls-ca-file"):
        runner_mod.connect_scheduler("tls://127.0.0.1:9", 1)
    assert runner_mod.scheduler_security() is None


def test_run_options_refuse_security_without_a_tls_scheduler(tmp_path):
    """The command line refuses ``--tls-*`` without a ``tls://`` scheduler; the API took
    ``RunOptions(security="zz")`` (and ``run_study(..., security=...)``) and ignored it, so a
    caller believed a run encrypted that was not (audit s45). Now refused on creation, one
    line naming the keyword, before the output folder exists. Fails on main's options.py."""
    from distributed.security import Security

    from psdesign.study.options import RunOptions

    for scheduler in (None, "local"):
        with pytest.raises(StudyError, match=r"^security: only with a scheduler tls://"):
            RunOptions(workers=1, scheduler=scheduler, security=Security())
    with pytest.raises(StudyError, match=r"^security: must be a distributed.security.Security"):
        RunOptions(scheduler="tls://127.0.0.1:8786", security="zz")
    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7, 0.8]')
    with pytest.raises(StudyError, match=r"^security: only with a scheduler tls://"):
        run_study(p, tmp_path / "out", workers=0, case_fn=fake_case, security=Security())
    assert not (tmp_path / "out").exists()
    # accepted where it is used (the TLS run itself: test_tls_scheduler_end_to_end, slow)
    opts = RunOptions(scheduler="tls://127.0.0.1:8786", security=Security())
    assert opts.security is not None and opts.scheduler == "tls://127.0.0.1:8786"


def _self_signed(tmp_path: Path) -> tuple[str, str]:
    """A CA-signed-by-itself certificate for 127.0.0.1 (cert + key in one PEM, and the key)."""
    import datetime as dt
    import ipaddress

    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "psdesign-test")])
    now = dt.datetime.now(dt.UTC)
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(days=1))
        .not_valid_after(now + dt.timedelta(days=2))
        .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
        .add_extension(
            x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]),
            critical=False,
        )
        .sign(key, hashes.SHA256())
    )
    cert_pem = tmp_path / "cert.pem"
    key_pem = tmp_path / "key.pem"
    cert_pem.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_pem.write_bytes(
        key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
    )
    return str(cert_pem), str(key_pem)


@pytest.mark.slow
def test_tls_scheduler_end_to_end(tmp_path, capsys):
    from distributed import LocalCluster
    from distributed.security import Security

    cert, key = _self_signed(tmp_path)
    sec = Security(
        tls_ca_file=cert,
        tls_scheduler_cert=cert,
        tls_scheduler_key=key,
        tls_worker_cert=cert,
        tls_worker_key=key,
        tls_client_cert=cert,
        tls_client_key=key,
        require_encryption=True,
    )
    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7, 0.8]')
    a = run_study(p, tmp_path / "a", workers=0, case_fn=fake_case, progress=False, report=False)
    with LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        protocol="tls",
        host="127.0.0.1",
        security=sec,
        dashboard_address=None,
    ) as cluster:
        addr = cluster.scheduler_address
        assert addr.startswith("tls://127.0.0.1:")
        with pytest.raises(StudyError, match="tls:// needs --tls-ca-file"):
            run_study(p, tmp_path / "b", scheduler=addr, case_fn=fake_case, progress=False)
        b = run_study(
            p,
            tmp_path / "b",
            scheduler=addr,
            case_fn=fake_case,
            progress=False,
            report=False,
            security=runner_mod.scheduler_security(cert, cert, key),
        )
    cols = ["case_id", "status", "k_x_m2", "k_z_m2"]
    pd.testing.assert_frame_equal(a[cols], b[cols])
    assert "warning" not in capsys.readouterr().err


def test_absurd_local_worker_count_and_nan_timeout_refused_before_work(tmp_path, capsys):
    """Rule: bad input exits 2 in one line naming the key and the range, before any work.
    main: ``--workers 100000`` was accepted (the pool is capped only at the number of cases: a
    1000-case study would start 1000 processes of up to GBs each), and ``timeout_s=nan`` passed
    the Python API's ``<= 0`` check."""
    from psdesign.cli.study import main
    from psdesign.study.runner import max_local_workers

    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "out"
    n = max_local_workers() + 1
    args = ["study", "run", str(p), "-o", str(out), "--quiet", "--case-fn", "study_cases:fake_case"]
    assert main([*args, "--workers", str(n)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"workers: at most {max_local_workers()} processes" in err and str(n) in err
    assert not out.exists()
    with pytest.raises(StudyError, match=r"^timeout_s: must be a number > 0"):
        run_study(p, out, workers=0, case_fn=fake_case, timeout_s=float("nan"))
    assert not out.exists()
    assert max_local_workers() >= 64


@pytest.mark.parametrize(
    ("cmd", "more"),
    [
        ("run", "; use --scheduler or --cluster for more"),
        ("optimize", "; use --scheduler for more"),  # it has no --cluster
        ("rev", ""),  # rev runs on this machine: no option gives it more
    ],
)
def test_too_many_workers_names_only_the_options_the_command_has(
    tmp_path, capsys, cmd, more
) -> None:
    """Session 46 review: the too-many-workers advice was chosen by the ``--`` prefix of
    ``--workers`` alone, so ``rev --workers 1000000`` was told to use --scheduler or --cluster
    (``rev`` has neither: cli/rev.py add_workers_argument(scheduler=False)) and ``study
    optimize`` (no --cluster) to use --cluster. The advice names what the command has."""
    from psdesign.cli.main import main
    from psdesign.study.runner import max_local_workers

    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "out"
    spec = TESTS_DIR.parent / "studies" / "examples" / "fig13_straight.toml"
    argv = {
        "run": ["study", "run", str(p), "-o", str(out)],
        "optimize": ["study", "optimize", str(p), "-o", str(out), "--target", "k_z_m2=1e-11"],
        "rev": ["rev", str(spec), "--sizes", "1e-4", "-o", str(out)],
    }[cmd]
    n = max_local_workers() + 1
    assert main([*argv, "--workers", str(n), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    head = f"psdesign: error: --workers: at most {max_local_workers()} processes on this machine"
    assert len(err) == 1 and err[0].startswith(head), err
    assert err[0].endswith(f"got {n}{more}"), err
    assert not out.exists()


@pytest.mark.parametrize("cmd", ["run", "optimize"])
@pytest.mark.parametrize(
    ("address", "line"),
    [
        ("bogus", "--scheduler: expected an address like tcp://HOST:PORT, tls://HOST:PORT "),
        ("tcp://bogus.invalid:8786", "--scheduler: the host of tcp://bogus.invalid:8786 does not "),
        ("ftp://host:1", "--scheduler: scheme ftp:// not supported; use tcp:// or tls://"),
    ],
)
def test_a_bad_scheduler_address_is_refused_before_dask_is_imported(
    tmp_path, cmd, address, line
) -> None:
    """Session 34 notes: ``--scheduler bogus`` took 5-10 s to refuse under load (13 s at load
    16): dask, pandas and the study runner were imported first. Now the address's form and
    its host (``.invalid`` never resolves: RFC 6761) are checked first, one line, exit 2; a
    fresh interpreter lists which heavy modules the refusal imported: none (no timing). A
    host that resolves but does not answer keeps the probe's 10 s wait (test_api:
    ``tcp://127.0.0.1:9``, "no Dask scheduler answers")."""
    p = write_study(tmp_path, ONE, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "out"
    argv = {
        "run": ["study", "run", str(p), "-o", str(out)],
        "optimize": ["study", "optimize", str(p), "-o", str(out), "--target", "k_z_m2=1e-11"],
    }[cmd] + ["--scheduler", address, "--quiet"]
    code = (
        "import sys\nfrom psdesign.cli.main import main\n"
        f"status = main({argv!r})\n"
        "heavy = [m for m in ('dask', 'distributed', 'pandas', 'numpy') if m in sys.modules]\n"
        "print(status, heavy)"
    )
    path = [str(TESTS_DIR.parent), os.environ.get("PYTHONPATH", "")]  # this checkout's psdesign
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(path)}
    run = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=env
    )
    assert run.stdout.strip() == "2 []", (run.stdout, run.stderr)
    err = run.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"psdesign: error: {line}"), err
    assert not out.exists()


def test_a_host_name_service_that_hangs_is_refused_after_its_timeout(monkeypatch) -> None:
    """``socket.getaddrinfo`` has no timeout: a name service that never answers is given
    ``timeout_s`` and the address refused, naming --scheduler (a stand-in lookup that blocks
    until the test ends)."""
    from psdesign.study import address

    release = threading.Event()
    monkeypatch.setattr(address.socket, "getaddrinfo", lambda *a, **k: release.wait(60))
    try:
        with pytest.raises(SchedulerError) as info:
            address.check_scheduler_address("tls://slow.example:8786", timeout_s=0.2)
    finally:
        release.set()
    assert str(info.value).startswith(
        "--scheduler: the host of tls://slow.example:8786 does not resolve (no answer from "
        "the name service within 0.2 s)"
    )


def test_a_scheduler_host_is_looked_up_once_per_run(tmp_path, monkeypatch, capsys) -> None:
    """Session 35 notes: ``study run --scheduler tcp://localhost:1`` (nothing listens there)
    looked localhost up five times: the CLI's check, RunOptions', connect_scheduler's, the
    loopback test and the probe's connection (up to 5 s each with a slow name service). The
    CLI's check now returns the address with its host's addresses (SchedulerAddress), which
    the later checks, the loopback test and the probe use: one lookup. Truth: a counting
    stand-in for ``socket.getaddrinfo``."""
    from psdesign.cli.main import main

    hosts: list[str] = []
    real = socket.getaddrinfo
    monkeypatch.setattr(
        socket, "getaddrinfo", lambda host, *a, **k: (hosts.append(host), real(host, *a, **k))[1]
    )
    p, out = write_study(tmp_path, FACTORIAL, FAC_PARAMS), tmp_path / "out"
    argv = ["study", "run", str(p), "--out", str(out), "--scheduler", "tcp://localhost:1"]
    assert main([*argv, "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no Dask scheduler answers at tcp://localhost:1" in err[0], err
    assert hosts == ["localhost"]
    assert not out.exists()
    # the API's entry (a plain str): RunOptions' two checks looked it up twice (session 36
    # review); the checked address it keeps needs no lookup in connect_scheduler later
    from psdesign.study.address import SchedulerAddress
    from psdesign.study.options import RunOptions

    hosts.clear()
    opts = RunOptions(scheduler="tcp://localhost:1", workers=1)
    assert hosts == ["localhost"] and isinstance(opts.scheduler, SchedulerAddress)


def test_stopping_the_workers_leaves_multiprocessing_s_resource_tracker():
    """Session 35's failure audit: Ctrl-C of a two-worker ``study run`` printed 3-5 tracebacks
    ``KeyError: '/mp-...'`` after its one line in 4 of 10 trials.  ``stop_children`` killed
    every child started during the run, multiprocessing's resource tracker too (it starts
    with the pool's first semaphore); a relaunched tracker then met the pool's releases of
    semaphores it never saw.  The tracker exits with this process by itself."""
    import multiprocessing
    import multiprocessing.resource_tracker as rt

    import psutil

    from psdesign.study.interrupt import _children_now, stop_children

    before = _children_now()
    ctx = multiprocessing.get_context("spawn")
    lock = ctx.Lock()  # a named semaphore: the tracker runs (started here or earlier)
    tracker = rt._resource_tracker._pid
    assert tracker is not None and psutil.pid_exists(tracker)
    worker = ctx.Process(target=time.sleep, args=(60,))
    worker.start()
    try:
        stop_children(grace_s=5.0, keep=before - {(tracker, psutil.Process(tracker).create_time())})
        assert not psutil.pid_exists(worker.pid)  # the worker was stopped (and reaped)
        assert psutil.pid_exists(tracker) and psutil.Process(tracker).status() != "zombie"
    finally:
        if psutil.pid_exists(worker.pid):
            worker.kill()
        del lock


def _pool_made_with_sigint_at_line(n: int, state: dict) -> None:
    """Make the runner's pool with SIGINT sent at the ``n``-th line of multiprocessing's code
    it runs (Python's handler raises KeyboardInterrupt at the next check, as on a Ctrl-C).
    ``state["at"]`` is ``n`` meanwhile; ``state["done"]`` becomes True when the pool's making
    ran fewer than ``n`` such lines (every line was tried)."""
    seen = [0]

    def tracer(frame, event, arg):  # noqa: ARG001 - sys.settrace's signature
        if event == "line" and "multiprocessing" in frame.f_code.co_filename:
            seen[0] += 1
            if seen[0] == n:
                os.kill(os.getpid(), signal.SIGINT)
        return tracer

    state["at"] = n
    pool = None
    sys.settrace(tracer)
    try:
        pool = runner_mod._new_pool(2)
    except KeyboardInterrupt:
        pass
    finally:
        sys.settrace(None)
    if pool is not None:
        pool.shutdown()
    state["done"] = seen[0] < n


def test_an_interrupt_while_the_pool_is_made_leaks_no_semaphore(monkeypatch):
    """Session 53's CI: a Ctrl-C as ``study run`` made its pool left multiprocessing's
    resource tracker printing "There appear to be 1 leaked semaphore objects to clean up at
    shutdown" (2 lines) under the runner's one line, in ~1 of 25 stops at 0.0 s: too rare for
    real stops to show it reliably (benchmarks/audit_interrupt_lines.py).  Here SIGINT is
    sent at each line of multiprocessing's code that making the pool runs, in turn: no named
    semaphore may stay registered with the tracker without its finalizer (the ones the
    tracker counts at exit).  SemLock.__init__ registers its name a few lines before its
    util.Finalize exists; on session 53's main 60 of the 425 lines leaked one (the tracker
    warned of 65 at exit); the pool is now made with the signals held."""
    import gc
    import multiprocessing.resource_tracker as rt
    import multiprocessing.synchronize as syn
    from multiprocessing import util

    state: dict = {"at": 0, "done": False}
    by_line: dict[int, list[str]] = {}
    gone: set[str] = set()
    real, real_un = rt._resource_tracker.register, rt._resource_tracker.unregister

    def register(name, rtype):
        real(name, rtype)
        by_line.setdefault(state["at"], []).append(name)

    def unregister(name, rtype):
        real_un(name, rtype)
        gone.add(name)

    monkeypatch.setattr(rt, "register", register)  # SemLock imports it at each call
    monkeypatch.setattr(rt, "unregister", unregister)
    previous_int, previous_trace = signal.getsignal(signal.SIGINT), sys.gettrace()
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        runner_mod._new_pool(2).shutdown()  # the tracker runs from here on, as in a run
        while not state["done"]:
            _pool_made_with_sigint_at_line(state["at"] + 1, state)
    finally:
        signal.signal(signal.SIGINT, previous_int)
        sys.settrace(previous_trace)
    gc.collect()
    live = {
        f._args[0]
        for f in list(util._finalizer_registry.values())
        if getattr(f, "_callback", None) is syn.SemLock._cleanup
    }
    leaked = {n: lost for n, v in by_line.items() if n and (lost := set(v) - gone - live)}
    for name in set().union(*leaked.values()):  # unlinked: the tracker has nothing to say
        with contextlib.suppress(OSError):
            syn.SemLock._cleanup(name)
    lines = state["at"] - 1
    assert lines > 100, lines  # the pool's making ran multiprocessing's code, line by line
    assert not leaked, f"{len(leaked)} of {lines} lines leaked a semaphore: {sorted(leaked)[:9]}"


def test_study_exit_status_tells_failed_cases_from_unconverged_ones():
    """exit_status: 1 when a case failed or timed out (the run could not give it), 3 when
    every case finished but some is not_converged (outputs complete), 0 when those are
    allowed; a failed case wins over an unconverged one. Before session 37 all three were 1."""
    import pandas as pd

    from psdesign.cli.study import study_exit_status

    def status(*s, allow=False):
        return study_exit_status(pd.DataFrame({"status": list(s)}), allow_not_converged=allow)

    assert status("ok", "ok") == 0
    assert status("ok", "not_converged") == 3
    assert status("ok", "not_converged", allow=True) == 0
    assert status("failed", "not_converged") == 1
    assert status("timeout", "ok", allow=True) == 1


def test_a_finished_case_that_is_not_to_be_trusted_exits_3_not_1():
    """Rule (psdesign/cli/exit_status.py, session 45): 1 is a run that could not finish
    (``failed``, ``timeout``), 3 a finished case with complete outputs whose status, or a value's
    own status, is not ok. On main, ``case_counts`` counted every case status but ``ok`` and
    ``not_converged`` as failed: a table with an ``untrustworthy`` case exited 1 ("could not
    finish"); an ok case with ``k_z_status = untrustworthy`` or ``diffusivity_z_status =
    blocked`` exited 0. Fails on main's exit_status.py and study.py (1, 1, 0, 0)."""
    import pandas as pd

    from psdesign.cli.study import study_exit_status

    def code(status, allow=False, **values):
        df = pd.DataFrame({"status": status, **values})
        return study_exit_status(df, allow_not_converged=allow)

    assert code(["ok", "untrustworthy"]) == 3  # a case_fn's own status word: finished
    assert code(["ok", "extrapolated"], True) == 3  # the flag accepts not_converged only
    assert code(["ok", "ok"], k_z_status=["ok", "untrustworthy"]) == 3
    assert code(["ok", "ok"], diffusivity_z_status=["blocked", "ok"]) == 3
    assert code(["ok", "ok"], True, pore_sizes_status=["ok", "untrustworthy"]) == 3
    assert code(["ok", "failed"], k_z_status=["ok", None]) == 1  # a failed case has no K
    assert code(["ok", "ok"], k_z_status=["ok", None]) == 0  # an unrated value is no flag
    assert code(["ok", "ok"], k_z_status=["ok", "ok"]) == 0


def test_a_users_report_in_a_copy_stays_theirs_after_study_fit_writes_the_marker(tmp_path, capsys):
    """Review F (session 52): in a marker-less copy (``cp -r out/* dest/``) with the user's
    own report.html, ``study fit`` wrote the first marker and listed report.html in it (every
    file an older psdesign's folder holds), so the next ``study report`` replaced it. The
    marker now lists only what the older-folder rule owns: the report is refused, kept."""
    from psdesign.cli.main import main
    from psdesign.io.outputs import read_marker

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=fake_case, progress=False)
    (out / ".psdesign-output.json").unlink()
    theirs = out / "report.html"
    theirs.write_text("MY OWN REPORT\n")
    assert main(["study", "fit", str(out)]) == 0
    assert "report.html" not in read_marker(out)["files"]
    capsys.readouterr()
    assert main(["study", "report", str(out)]) == 2
    assert theirs.read_text() == "MY OWN REPORT\n"


@pytest.mark.parametrize(("name", "argv"), [("report.html", "report"), ("surrogate.json", "fit")])
def test_a_copy_without_the_marker_keeps_a_users_report_and_surrogate(tmp_path, capsys, name, argv):
    """Review s52 (walk-report 3): ``cp -r out/* dest/`` drops the marker (a dotfile); a
    user's own report.html there was replaced by ``study report`` (the folder read as an
    older psdesign's, which owned every file). docs/study-files.md: a file the marker does not
    list is never replaced (exit 2, one line). psdesign's own report / surrogate in such a
    folder (what an older psdesign left) is still replaced."""
    from psdesign.cli.main import main

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=fake_case, progress=False)
    assert main(["study", "fit", str(out)]) == 0
    (out / ".psdesign-output.json").unlink()
    theirs = out / name
    psdesigns = theirs.read_bytes()
    theirs.write_text("MY OWN FILE\n")
    capsys.readouterr()
    assert main(["study", argv, str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{theirs} exists" in err[0] and "never replaced" in err[0], err
    assert theirs.read_text() == "MY OWN FILE\n"
    assert not (out / ".psdesign-output.json").exists()
    if name == "report.html":  # study run resuming the copy writes a report too
        run = ["study", "run", str(p), "-o", str(out), "--workers", "0", "--quiet"]
        assert main([*run, "--case-fn", "study_cases:fake_case"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{theirs} exists" in err[0], err
        assert theirs.read_text() == "MY OWN FILE\n"
    theirs.write_bytes(psdesigns)  # psdesign's own file: an older psdesign's folder
    assert main(["study", argv, str(out)]) == 0
    assert theirs.read_bytes() != b"MY OWN FILE\n"
