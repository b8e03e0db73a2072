"""A running study case reports its stage (generate -> solve K_d -> preview) through a stage
file that the runner's watcher prints on stderr."""

from __future__ import annotations

import io
import time

from psdesign.study import case as case_module
from psdesign.study.stages import STAGE_FILE, StageWatcher, mark_stage, running_stages

SPEC = {
    "rve": {"size": [20e-6, 20e-6, 20e-6], "voxel": 2e-6},
    "fibers": [
        {"shape": "cylinder", "diameter": 8e-6, "center": [10e-6] * 3, "direction": [0, 0, 1]},
    ],
    "flow": {"solver": "voxel", "viscosity": 1.8e-5},
}


def test_run_case_marks_each_stage_in_order(tmp_path, monkeypatch):
    seen: list[str] = []
    monkeypatch.setattr(case_module, "mark_stage", lambda wd, text: seen.append(text))
    case_module.run_case(SPEC, ["porosity", "k_x", "k_z"], "voxel", tmp_path)
    assert seen[0] == "generating the RVE"
    assert seen[1].startswith("solving K_x (voxel") and seen[2].startswith("solving K_z (voxel")
    assert seen[-1] == "preview picture"


def test_watcher_prints_running_cases_until_done(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    mark_stage(a, "solving K_z (fem, bc permeameter)")
    mark_stage(b, "generating the RVE")
    stream = io.StringIO()
    with StageWatcher({"ca": a, "cb": b}, every_s=0.05, stream=stream) as watcher:
        time.sleep(0.3)
        watcher.done("cb")
        assert not (b / STAGE_FILE).exists()
        n_before = stream.getvalue().count("cb:")
        time.sleep(0.3)
    text = stream.getvalue()
    assert "[study] running ca: solving K_z (fem, bc permeameter) (" in text
    assert n_before >= 1 and text.count("cb:") == n_before  # nothing after done()
    assert running_stages({"cb": b}) == []
