"""Resume by content, and results tables rebuilt at a bounded rate (study runner)."""

from __future__ import annotations

import errno
import json
import os

import pandas as pd
import pytest
from study_cases import (
    FAC_PARAMS,
    FACTORIAL,
    disk_full_case,
    failing_case,
    fake_case,
    write_study,
)

from psdesign.study import is_timing_column, run_study
from psdesign.study import runner as runner_mod
from psdesign.study import store as store_mod
from psdesign.study.design import content_hash, expand_design, match_finished
from psdesign.study.progress import Progress
from psdesign.study.studyfile import load_study


def _calls(out, case_id: str) -> int:
    return len((out / "cases" / case_id / "calls.txt").read_text().split())


def _all_calls(out) -> int:
    """Runs of the case function over every working folder (a re-run under a new id too)."""
    return sum(len(f.read_text().split()) for f in (out / "cases").glob("*/calls.txt"))


def _content(df: pd.DataFrame) -> pd.DataFrame:
    """Rows keyed by case_id without the position and the timings (they legitimately move)."""
    keep = [c for c in df.columns if not is_timing_column(c) and c != "index"]
    return df[keep].set_index("case_id").sort_index()


def _stored_as(out) -> list[str]:
    """The id each case of the last run's design is stored under (study.json)."""
    return [c["stored_as"] for c in json.loads((out / "study.json").read_text())["cases"]]


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("seeds = [1, 2]", "seeds = [2]"),  # a seed dropped: every later case moves
        ('"generator.porosity" = [0.7, 0.8, 0.9]', '"generator.porosity" = [0.8, 0.9]'),
    ],
)
def test_dropping_a_seed_or_level_reruns_no_identical_case(tmp_path, old, new):
    """Ids were ``c<index>-<hash>`` matched whole: dropping a seed or level moved the later,
    identical cases to new indices and the resume re-ran them (calls.txt counted 2).  Now a
    finished record of the same content hash is reused, the table keeps design order."""
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    full = run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    text = p.read_text()
    assert old in text
    p.write_text(text.replace(old, new))
    df = run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    assert 0 < len(df) < len(full) and list(df["index"]) == list(range(len(df)))
    assert _all_calls(out) == len(full)  # nothing re-run
    stored = _stored_as(out)
    assert all(_calls(out, c) == 1 for c in stored)
    assert set(stored) <= set(full["case_id"]) and stored != list(df["case_id"])  # moved
    by_run = full.set_index("case_id").loc[stored].reset_index()
    pd.testing.assert_frame_equal(
        _content(df.assign(case_id=stored)), _content(by_run), check_like=True
    )
    design = json.loads((out / "study.json").read_text())["cases"]
    assert [c["case_id"] for c in design] == list(df["case_id"])
    assert pd.read_csv(out / "results.csv")["case_id"].tolist() == df["case_id"].tolist()
    # the level or seed back: only its cases run, the others keep their records
    p.write_text(text)
    again = run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    pd.testing.assert_frame_equal(_content(again), _content(full))
    assert _all_calls(out) == len(full)


def test_match_finished_keeps_exact_ids_and_pairs_duplicates_in_order(tmp_path):
    """Exact ids first; equal hashes go to the earliest finished record, one record per case."""
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    cases = expand_design(load_study(p))
    h = content_hash(cases[5].case_id)
    assert h is not None and content_hash("garbage") is None
    records = {cases[0].case_id, f"c0009-{h}", f"c0012-{h}"}
    got = match_finished(cases, records)
    assert got == {cases[0].case_id: cases[0].case_id, cases[5].case_id: f"c0009-{h}"}


def test_a_resumed_run_has_the_case_ids_of_a_fresh_run(tmp_path):
    """A resumed case kept the id (index) where it first ran, so dropping a level gave other
    ids than a fresh run of the same design.  Now the ids (tables, study.json) are the
    design's; the moved records and folders stay, untouched, under the id they ran with
    (study.json ``stored_as``), nothing is re-run, and a failed moved case retried is
    re-recorded under its own record, not beside it."""
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=failing_case, progress=False, report=False)
    before = {f.name: f.read_bytes() for f in (out / "cases").glob("*.json")}
    text = p.read_text()
    p.write_text(text.replace("[0.7, 0.8, 0.9]", "[0.8, 0.9]"))
    kw = {"workers": 0, "progress": False, "report": False}
    resumed = run_study(p, out, case_fn=failing_case, **kw)
    fresh = run_study(p, tmp_path / "fresh", case_fn=failing_case, **kw)
    assert list(resumed["case_id"]) == list(fresh["case_id"])
    assert pd.read_csv(out / "results.csv")["case_id"].tolist() == list(fresh["case_id"])
    drop = ["preview_png", "error"]  # paths into each folder; tracebacks name them
    pd.testing.assert_frame_equal(
        _content(resumed).drop(columns=drop), _content(fresh).drop(columns=drop)
    )
    assert {f.name: f.read_bytes() for f in (out / "cases").glob("*.json")} == before
    assert _all_calls(out) == len(before) - (resumed["status"] == "failed").sum()
    again = run_study(p, out, case_fn=fake_case, retry_failed=True, **kw)
    assert list(again["case_id"]) == list(fresh["case_id"]) and set(again["status"]) == {"ok"}
    assert sorted(f.name for f in (out / "cases").glob("*.json")) == sorted(before)


def _count_table_writes(monkeypatch) -> list[int]:
    writes: list[int] = []
    real = store_mod.CaseStore.write_tables

    def counting(self, records, param_names):
        records = list(records)
        writes.append(len(records))
        return real(self, records, param_names)

    monkeypatch.setattr(store_mod.CaseStore, "write_tables", counting)
    return writes


def test_tables_rebuilt_at_a_bounded_rate_and_complete_at_the_end(tmp_path, monkeypatch):
    """results.csv/.parquet were rebuilt after every case (12 cases: 13 rebuilds, quadratic in
    the number of cases); now within one interval the first case's and the final rebuild."""
    monkeypatch.setattr(runner_mod, "TABLE_INTERVAL_S", 3600.0, raising=False)
    writes = _count_table_writes(monkeypatch)
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    df = run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    assert writes == [1, 12]
    assert sorted(pd.read_csv(out / "results.csv")["case_id"]) == sorted(df["case_id"])
    assert len(pd.read_parquet(out / "results.parquet")) == 12


def test_interrupted_run_leaves_tables_with_every_finished_case(tmp_path, monkeypatch):
    """Ctrl-C after 5 cases: the tables hold exactly the 5 recorded cases (rebuilt at the first
    case and on the interrupt, instead of after every case)."""
    monkeypatch.setattr(runner_mod, "TABLE_INTERVAL_S", 3600.0, raising=False)
    writes = _count_table_writes(monkeypatch)
    real_update = Progress.update

    def interrupt_after_5(self, *a, **kw):
        real_update(self, *a, **kw)
        if self.done >= 5:
            raise KeyboardInterrupt

    monkeypatch.setattr(Progress, "update", interrupt_after_5)
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    recorded = sorted(f.stem for f in (out / "cases").glob("*.json"))
    assert len(recorded) == 5 and writes == [1, 5]
    assert sorted(pd.read_csv(out / "results.csv")["case_id"]) == recorded
    assert sorted(pd.read_parquet(out / "results.parquet")["case_id"]) == recorded
    assert not list(out.glob("*.tmp"))


def _disk_full_once(flag):
    """A case function whose first call for porosity 0.8 meets a full disk (as the preview
    picture did on a 40 kB tmpfs, audit s35), later calls succeed."""

    def case(spec, outputs, solver, workdir):
        if spec["generator"]["porosity"] == 0.8 and not flag.exists():
            flag.write_text("full once\n")
            raise OSError(errno.ENOSPC, "No space left on device")
        return fake_case(spec, outputs, solver, workdir)

    return case


def test_a_case_that_meets_a_full_disk_stops_the_run_and_runs_again_on_resume(tmp_path):
    """The old runner recorded the case as failed (the preview's ENOSPC even as ok, with a
    preview_error and no picture), so a resume after freeing space kept the failure: the table
    differed from an uninterrupted run's.  Now the run stops with a StorageError naming the
    full disk, nothing of that case is recorded, and the resume equals a clean run."""
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    case = _disk_full_once(tmp_path / "flag")
    with pytest.raises(store_mod.StorageError, match="disk is full") as info:
        run_study(p, out, workers=0, case_fn=case, progress=False, report=False)
    assert info.value.errno == errno.ENOSPC
    recorded = [json.loads(f.read_text()) for f in (out / "cases").glob("*.json")]
    assert all(r["status"] == "ok" for r in recorded)  # no failed record of the full disk
    assert all("disk_full" not in r for r in recorded)
    resumed = run_study(p, out, workers=0, case_fn=case, progress=False, report=False)
    clean = run_study(
        p, tmp_path / "clean", workers=0, case_fn=fake_case, progress=False, report=False
    )
    assert (resumed["status"] == "ok").all() and len(resumed) == 12
    # the full disk's traceback does not stay beside the case that then succeeded
    assert list((out / "cases").glob("*/error.txt")) == []
    pd.testing.assert_frame_equal(_content(resumed), _content(clean))


def test_disk_full_in_a_timed_case_child_stops_the_run_too(tmp_path):
    """With a timeout the case runs in a child process: its ENOSPC reaches the runner as the
    child's result, flagged, and stops the run the same way."""
    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.8]\n')
    out = tmp_path / "out"
    with pytest.raises(store_mod.StorageError, match="disk is full"):
        run_study(
            p, out, workers=0, case_fn=disk_full_case, progress=False, report=False, timeout_s=60
        )
    assert list((out / "cases").glob("*.json")) == []


def test_a_study_case_preview_carries_generates_title(tmp_path, monkeypatch):
    """Session 48 (re-read of session 47): a study case's preview.png had no title while
    generate's shows the porosity and Omega with their bars and statuses. One 4 um rod in a
    12 um box at 1 um voxels: the title is preview_title of the case's own row, and the row
    records it as ``preview_title`` (session 49)."""
    from psdesign.report import preview
    from psdesign.study.case import run_case

    titles = []
    real = preview.render_preview
    monkeypatch.setattr(
        preview, "render_preview", lambda *a, **k: titles.append(k.get("title")) or real(*a, **k)
    )
    spec = {
        "rve": {"size": [12e-6, 12e-6, 12e-6], "voxel": 1e-6},
        "fibers": [{"shape": "rod", "diameter": 4e-6, "center": [6e-6, 6e-6, 6e-6]}],
    }
    row = run_case(spec, ["porosity"], "voxel", tmp_path)
    (title,) = titles
    bar = f"{row['porosity']:.4f} +- {row['porosity_error']:.1e}"
    assert title.startswith(f"porosity {bar} [{row['porosity_status']}], Omega ")
    assert title.endswith(f"[{row['intersection_volume_fraction_status']}], 1 fibers")
    assert (tmp_path / "preview.png").stat().st_size > 0
    # what the picture shows, for the report's caption (session 49: it repeated the title)
    assert row["preview_title"] == title


def test_a_preview_on_a_full_disk_stops_the_case(tmp_path, monkeypatch):
    """psdesign.study.case: a picture never fails a case, but a full disk is not the picture's
    failure (the old code recorded ``preview_error`` and an ok case without its picture)."""
    from psdesign.report import preview
    from psdesign.study.case import run_case

    def full(_distance, _spacing, path, **_k):
        path.write_bytes(b"\x89PNG\r\n")  # the part written before the disk filled
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(preview, "render_preview", full)
    spec = {
        "rve": {"size": [12e-6, 12e-6, 12e-6], "voxel": 1e-6},
        "fibers": [{"shape": "rod", "diameter": 4e-6, "center": [6e-6, 6e-6, 6e-6]}],
    }
    with pytest.raises(OSError) as info:
        run_case(spec, ["porosity"], "voxel", tmp_path)
    assert info.value.errno == errno.ENOSPC
    # no truncated picture under its name (the old code drew straight into preview.png)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stage.txt"]


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="start times from Linux /proc")
def test_a_dead_writer_s_temp_is_removed_when_its_pid_was_reused(tmp_path) -> None:
    """Session 35 notes: ``remove_dead_temp`` trusted pids: the temp of a killed ``study fit``
    whose pid a live process now has (in a container each command may get the same small pid)
    stayed for good, and one carrying this process's own pid was never looked at. A temp last
    written before its pid's process started is a dead writer's: removed; a live writer's,
    written after its start, stays. Truth: the start times from psutil (its own reading,
    independent of psdesign's ``/proc`` parsing)."""
    import psutil

    target = tmp_path / "surrogate.json"
    init = psutil.Process(1).create_time()  # pid 1: alive for the whole test
    me = psutil.Process().create_time()
    old = tmp_path / ".psdesign-surrogate.json.1.tmp"
    old.write_text('{"version": 1, "mod')  # a half-written surrogate of an earlier pid 1
    os.utime(old, (init - 60, init - 60))
    mine = tmp_path / f".psdesign-surrogate.json.{os.getpid()}.tmp"
    mine.write_text("this process's write, under way")
    assert store_mod.remove_dead_temp(target) == [old]
    assert not old.exists() and mine.exists()
    old.write_text("pid 1's write, under way")  # written now: after pid 1 started
    assert store_mod.remove_dead_temp(target) == [] and old.exists() and mine.exists()
    os.utime(mine, (me - 60, me - 60))  # this pid's name, written before this process began
    assert store_mod.remove_dead_temp(target) == [mine] and old.exists()
