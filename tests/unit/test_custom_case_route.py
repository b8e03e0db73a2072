"""A study's up-front memory plan is the plan of psdesign's own route: a custom case function
(``run_study(case_fn=...)``, ``--case-fn``) builds and solves what it chooses, so its study is
held to the schema's keys and its voxel grid, not to a solve psdesign would run.

Truth: :func:`psdesign.schema.budget.grid_bytes` of the 100^3 grid of ``study_cases.BASE`` (1 um
voxels): 0.132 GB solved periodic (one copy), 0.414 GB as a 3-copy permeameter with 0.2 reservoirs;
``flow.max_memory_gb = 0.2`` (x 1.25 margin: 0.25 GB) lies between them.
"""

from __future__ import annotations

import pandas as pd
import pytest
from study_cases import BASE, fake_case, kc_truth

from psdesign.cli.main import main
from psdesign.schema import budget
from psdesign.schema.budget import grid_bytes
from psdesign.study import load_study
from psdesign.study.studyfile import StudyError

FLOW = '[base.flow]\nsolver = "voxel"\naux_length = 0.2\n'
PERMEAMETER = FLOW + 'bc = "permeameter"\npermeameter_copies = 3\nmax_memory_gb = 0.2\n'
STUDY = """
[study]
name = "custom"
design = "full-factorial"
seeds = [1]
outputs = ["porosity", "k_z"]

[parameters]
"generator.porosity" = [0.75, 0.85]
"""


def _study(tmp_path, study: str = STUDY):
    p = tmp_path / "s.toml"
    p.write_text(BASE.replace(FLOW, PERMEAMETER) + study)
    return p


def test_the_premise():
    assert PERMEAMETER in BASE.replace(FLOW, PERMEAMETER)
    assert (
        grid_bytes([100] * 3, "voxel")
        < 1.25 * 0.2e9
        < grid_bytes([100] * 3, "voxel", 3, {"aux": 0.2})
    )


def test_a_custom_case_function_is_not_refused_for_a_permeameter_it_does_not_build(
    tmp_path, capsys
):
    """Session 43 noticed, session 44 reproduced: the study of a case function that builds no
    permeameter (study_cases.fake_case: Kozeny-Carman) was refused at load, before its case
    function was known, for the 3-copy permeameter of its base spec ("base.flow.max_memory_gb:
    the voxel solve of the 100x100x100 grid (3 copies stacked) needs about 0.414 GB, over the
    cap of 0.2 GB"; a 400 um cube: "base.flow.permeameter_copies: 2 copies ... need about 17.5
    GiB"), exit 2, nothing run. psdesign's own case function is still refused there."""
    p = _study(tmp_path)
    argv = ["study", "run", str(p), "--workers", "0", "--quiet", "--no-report"]
    assert main([*argv, "-o", str(tmp_path / "own")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("psdesign: error: base.flow.max_memory_gb: "), err
    assert (
        "(3 copies stacked, counted along the least of x, y, z) needs about 0.414 GB" in err[0]
    ), err
    assert not (tmp_path / "own").exists()
    out = tmp_path / "custom"
    assert main([*argv, "-o", str(out), "--case-fn", "study_cases:fake_case"]) == 0
    df = pd.read_csv(out / "results.csv")
    assert df["status"].tolist() == ["ok", "ok"]
    want = [2 * kc_truth(e, 7e-6) for e in (0.75, 0.85)]  # fake_case: K_z = 2 KC, 1 % noise
    assert df["k_z_m2"].tolist() == pytest.approx(want, rel=0.03)


def test_load_study_plans_the_route_of_the_case_function_it_is_given(tmp_path):
    p = _study(tmp_path)
    with pytest.raises(StudyError, match="base.flow.max_memory_gb"):
        load_study(p)
    assert len(load_study(p, case_fn=fake_case).parameters) == 1
    assert len(load_study(p, case_fn="study_cases:fake_case").parameters) == 1
    with pytest.raises(StudyError, match="base.flow.max_memory_gb"):
        load_study(p, case_fn="psdesign.study.case:run_case")
    bad = p.read_text().replace("aux_length = 0.2", "aux_length = -1")
    p.write_text(bad)  # the keys are still the schema's
    with pytest.raises(StudyError, match="aux_length"):
        load_study(p, case_fn=fake_case)


def test_optimize_with_a_custom_case_function_plans_no_route(tmp_path, capsys):
    """`study optimize` loads its study with the case function it runs (the same refusal)."""
    study = STUDY.replace('"full-factorial"', '"latin-hypercube"\nn_samples = 4').replace(
        "[0.75, 0.85]", "{low = 0.8, high = 0.88}"
    )
    p = _study(tmp_path, study)
    target = 2.0 * kc_truth(0.84, 7e-6)
    argv = ["study", "optimize", str(p), "--budget", "8", "--workers", "0", "--quiet"]
    argv += ["--target", f"k_z_m2={target:.6e}+-10%"]
    assert main([*argv, "-o", str(tmp_path / "own")]) == 2
    assert "base.flow.max_memory_gb" in capsys.readouterr().err
    assert main([*argv, "-o", str(tmp_path / "opt"), "--case-fn", "study_cases:fake_case"]) == 0


def test_a_custom_case_functions_grid_refusal_names_no_solver_a_user_cannot_set(
    tmp_path, monkeypatch
):
    """Inside a custom case function's study the grid alone is checked (16 B per voxel of
    fields, budget.GEOMETRY_BYTES_PER_VOXEL): a 3000 um cube at 1 um, 2.7e10 voxels, 402 GiB.
    Its line read "16 B each with solver 'geometry'" (session 44 review2), a solver no spec
    can name; now it says what was counted, the voxel grid's own fields."""
    big = BASE.replace("size = [100e-6, 100e-6, 100e-6]", "size = [3000e-6, 3000e-6, 3000e-6]")
    p = tmp_path / "big.toml"
    p.write_text(big + STUDY)
    monkeypatch.setattr(budget, "machine_memory", lambda: 24.0 * 2**30)  # any machine
    with pytest.raises(StudyError) as ei:
        load_study(p, case_fn=fake_case)
    line = str(ei.value)
    assert "(2.7e+10 voxels, 16 B each for the voxel grid's own fields; no flow solve is" in line
    assert "solver" not in line, line
    assert f"needs about {2.7e10 * 16 / 2**30:.3g} GiB" in line
