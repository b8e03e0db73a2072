"""Study rows carry the boundary-condition model, the error bar and the status of every K."""

from __future__ import annotations

import pandas as pd
import pytest

from psdesign.report.html import _k_table
from psdesign.study.case import run_case

SPEC = {
    "rve": {"size": [40e-6, 40e-6, 40e-6], "voxel": 2e-6},
    "fibers": [
        {
            "shape": "cylinder",
            "diameter": 10e-6,
            "center": [20e-6, 20e-6, 20e-6],
            "direction": [0, 0, 1],
        },
    ],
    "flow": {"solver": "voxel", "viscosity": 1.8e-5},
}


def test_run_case_row_has_bc_error_bar_status(tmp_path):
    row = run_case(SPEC, ["porosity", "k_x"], "voxel", tmp_path)
    assert row["bc_x"] == "periodic"
    assert 0 < row["k_x_rel_error"] < 10
    assert row["k_x_status"] in ("ok", "untrustworthy", "not_converged")
    assert row["cells_per_diameter_x"] == pytest.approx(5.0)  # 10 um / 2 um
    assert row["k_x_status"] == "untrustworthy"  # < 8 voxels across the fiber
    assert "across the thinnest fiber" in row["warnings_x"]
    # the solve's size is a count named so (it was size_x: read as the RVE edge in metres)
    assert "size_x" not in row and 0 < row["n_cells_x"] <= 20**3


def test_report_k_table_shows_bar_and_flags():
    df = pd.DataFrame(
        {
            "case_id": ["a", "b"],
            "k_z_m2": [1e-11, 2e-11],
            "k_z_rel_error": [0.031, 0.5],
            "k_z_status": ["ok", "untrustworthy"],
            "bc_z": ["periodic", "periodic"],
        }
    )
    html = _k_table(df)
    assert "1e-11 ± 3.1 %" in html and "2e-11 ± 50.0 %" in html
    assert html.count('class="flag"') == 1
    assert _k_table(df.drop(columns=["k_z_rel_error"])) == ""  # old tables: no section


def test_row_porosity_carries_its_error_and_status(tmp_path):
    """The porosity column has its error estimate (a 10 um cylinder along z: solid fraction
    pi 5^2 / 40^2 exactly) and the error bar rates it; before, the table rated nothing."""
    import math

    from psdesign.analysis.columns import error_bar

    row = run_case(SPEC, ["porosity"], "voxel", tmp_path)
    true = 1 - math.pi * 25 / 1600
    assert abs(row["porosity"] - true) <= row["porosity_error"] < 0.02
    rel, status = error_bar(row, "porosity")
    assert (rel, status) == (pytest.approx(row["porosity_error"] / row["porosity"]), "ok")
    assert row["porosity_status"] == "ok"  # the row says it (session 46), as generate prints it


def test_row_pore_values_are_rated_as_pores_rates_them():
    """A study row's pore sizes and S_v carry the status ``psdesign pores`` gives them: at
    2 um voxels the 10 um cylinder has 5 voxels across (< 8), so both are untrustworthy and
    ``trusted`` drops them (they were unrated and kept)."""
    from psdesign.analysis.columns import trusted
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec
    from psdesign.transport.study_outputs import transport_outputs

    spec = validate_spec(SPEC)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    row = transport_outputs(built.rve, fields, ["pore_d50_m", "specific_surface_m-1"], spec)
    assert row["pore_sizes_status"] == row["specific_surface_status"] == "untrustworthy"
    kept = trusted(pd.DataFrame([{"status": "ok", **row}]))
    assert kept["pore_d50_m"].isna().all() and kept["specific_surface_m-1"].isna().all()


def test_report_k_table_gives_the_reason_beside_untrustworthy(tmp_path):
    """Session 42's walkthrough (benchmarks/RESULTS.md): the K table said 'untrustworthy' at
    +-9-12 % without the reason, which sat far right in the Results table. A 10 um fiber on
    2 um voxels has 10 / 2 = 5.0 voxels per diameter (< 8, the voxel route's rule)."""
    row = run_case(SPEC, ["porosity", "k_x"], "voxel", tmp_path)
    assert row["k_x_status"] == "untrustworthy" and row["k_x_rel_error"] <= 0.2
    html = _k_table(pd.DataFrame([row]))  # solver unknown: rated as the voxel route
    assert "untrustworthy: 5.0 voxels per fiber diameter, need 8" in html
    bar = pd.DataFrame(
        {
            "case_id": ["b"],
            "k_z_m2": [2e-11],
            "k_z_rel_error": [0.5],
            "k_z_status": ["untrustworthy"],
        }
    )
    assert "untrustworthy: error bar 50.0 % &gt; 20 %" in _k_table(bar, "fem")
    bar["cells_per_diameter_z"] = 3.0  # a FEM K is rated on its bar alone: no voxel count
    assert "voxels per fiber" not in _k_table(bar, "fem")
    assert "; 3.0 voxels per fiber diameter, need 8" in _k_table(bar, "voxel")


def test_report_k_table_has_one_wrapped_column_per_direction():
    """Session 42 saw the K table scroll sideways at 1400 px with two flow directions: a
    column each for K, status and bc per direction (8 columns; the two untrustworthy reasons
    made it 1601 px in a 1319 px box, benchmarks/RESULTS.md session 43). Now one column per
    direction, the unit and a bc every case shares in its header, the bar, a bc that differs
    and a status that is not ok in the cell, and the table wraps (class ktable)."""
    import re

    df = pd.DataFrame(
        {
            "case_id": ["a", "b"],
            "status": ["ok", "ok"],
            "k_x_m2": [1e-11, 2e-11],
            "k_x_rel_error": [0.04, 0.04],
            "k_x_status": ["ok", "untrustworthy"],
            "cells_per_diameter_x": [9.0, 5.0],
            "bc_x": ["permeameter", "permeameter"],
            "k_z_m2": [3e-11, 4e-11],
            "k_z_rel_error": [0.04, 0.25],
            "k_z_status": ["ok", "untrustworthy"],
            "cells_per_diameter_z": [9.0, 5.0],
            "bc_z": ["periodic", "permeameter"],
        }
    )
    html = _k_table(df, "voxel")
    heads = re.findall(r"<th>(.*?)</th>", html)
    assert heads == ["case_id", "case status", "K_x (m²), bc permeameter", "K_z (m²)"]
    assert '<table class="sortable ktable">' in html
    rows = re.findall(r"<tr[^>]*>(.*?)</tr>", html.split("<tbody>")[1])
    cells = [re.findall(r"<td>(.*?)</td>", r) for r in rows]
    assert cells[0][2:] == ["1e-11 ± 4.0 %", '3e-11 ± 4.0 %<br><span class="kbc">periodic</span>']
    assert cells[1][2] == (
        '2e-11 ± 4.0 %<br><span class="kst">untrustworthy: 5.0 voxels per fiber diameter, '
        "need 8</span>"
    )
    assert cells[1][3].startswith('4e-11 ± 25.0 %<br><span class="kbc">permeameter</span><br>')
    from psdesign.report.html import CSS

    assert ".ktable th,.ktable td{white-space:normal" in CSS


@pytest.mark.parametrize(("y", "status"), [(13.3e-6, "ok"), (17.6e-6, "untrustworthy")])
def test_row_omega_carries_its_status_and_flags_the_case(tmp_path, y, status):
    """Study rows gave Omega (``intersection_volume_fraction``) a bar and no status (session
    45). Two perpendicular 8 um cylinders in a 20 um cell at 1 um voxels: a lens 4.7 um deep
    (resolved: the exact volume, Cavalieri's ``int 4 sqrt(r^2 - y^2) sqrt(r^2 - (y - s)^2) dy``,
    within the bar) and one 0.4 um deep that holds no voxel centre (``0 +- 0`` against the
    exact 2.45e-4 of the box). The status joins the table's rated values, so the second case
    is flagged (exit 3) and its Omega left out of the trusted table. Fails on main (no
    status column)."""
    from conftest import load_benchmark

    from psdesign.analysis.columns import trusted
    from psdesign.cli.exit_status import case_counts

    cyl = {"shape": "cylinder", "diameter": 8e-6}
    spec = {
        "rve": {"size": [20e-6] * 3, "voxel": 1e-6},
        "fibers": [
            cyl | {"center": [10e-6, 10e-6, 10e-6], "direction": [1, 0, 0]},
            cyl | {"center": [10e-6, y, 10e-6], "direction": [0, 0, 1]},
        ],
    }
    row = run_case(spec, ["porosity"], "voxel", tmp_path) | {"status": "ok"}
    crossing_lens = load_benchmark("porosity_error_coverage").crossing_lens
    exact = crossing_lens(4e-6, 4e-6, y - 10e-6) / (20e-6) ** 3
    miss = abs(row["intersection_volume_fraction"] - exact)
    assert (miss <= row["intersection_volume_fraction_error"]) == (status == "ok")
    assert row["intersection_volume_fraction_status"] == status
    df = pd.DataFrame([row])
    assert case_counts(df).flagged == (status != "ok")
    assert trusted(df)["intersection_volume_fraction"].isna().all() == (status != "ok")


GENERATED = {
    "rve": {"size": [40e-6] * 3, "voxel": 1e-6},
    "generator": {
        "kind": "straight",
        "porosity": 0.85,
        "diameter": 5e-6,
        "seed": 1,
        "porosity_tolerance": 0.02,
    },
    "intersections": {"method": "none"},
}


@pytest.fixture()
def status_calls(monkeypatch) -> list:
    """Every (fibers, grid shape) ``intersection_status`` is called on, wherever it is
    imported from."""
    import psdesign.packing.generators as generators
    import psdesign.packing.overlap_status as overlap_status

    real, calls = overlap_status.intersection_status, []

    def counted(rve, fields):
        calls.append((len(rve.fibers), fields.grid.shape))
        return real(rve, fields)

    monkeypatch.setattr(overlap_status, "intersection_status", counted)
    monkeypatch.setattr(generators, "intersection_status", counted)
    return calls


def test_a_generated_case_rates_omega_once_and_says_it_alike(tmp_path, capsys, status_calls):
    """Omega's status was computed twice on the same fibers and grid per generated case: by
    the generator (``omega_after_status``) and again by the row (study/case.py) and by
    summary.json (packing/build.summarize): 0.03 s on fig13, 0.2 s for 131 fibers (session
    46). Now once, reused by :meth:`psdesign.packing.build.BuiltRVE.intersection_status`:
    two calls per case (the drawn fibers', ``omega_before_status``, and the final ones'), the
    same word in the row, the generation report and generate's JSON line and summary.json.
    Fails on main's build.py / case.py (three calls)."""
    import json

    from psdesign.cli import main
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    row = run_case(GENERATED, ["porosity"], "voxel", tmp_path / "case")
    assert len(status_calls) == 2
    assert row["intersection_volume_fraction_status"] == row["omega_after_status"]
    spec = tmp_path / "gen.toml"
    spec.write_text(
        '[rve]\nsize = [40e-6, 40e-6, 40e-6]\nvoxel = 1e-6\n[generator]\nkind = "straight"\n'
        "porosity = 0.85\ndiameter = 5e-6\nseed = 1\nporosity_tolerance = 0.02\n"
        '[intersections]\nmethod = "none"\n'
    )
    status_calls.clear()
    code = main(["generate", str(spec), "-o", str(tmp_path / "out"), "--no-preview", "--quiet"])
    assert len(status_calls) == 2
    out = json.loads(capsys.readouterr().out)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    word = row["intersection_volume_fraction_status"]
    assert out["intersection_volume_fraction_status"] == word
    assert summary["intersection_volume_fraction_status"] == word
    assert summary["generation"]["omega_after_status"] == word
    assert code == (0 if word == "ok" and out["porosity_status"] == "ok" else 3)
    # fields on another grid are not the generator's: rated on their own
    built = build_rve(validate_spec(GENERATED))
    status_calls.clear()
    assert built.intersection_status(built.voxelize(2e-6)) in ("ok", "untrustworthy")
    assert status_calls == [(len(built.rve.fibers), (20, 20, 20))]


#: a study whose base [flow] names the voxel periodic bc's mirror treatment but no flow.solver
#: (the validated table's solver is then the default "fem"): the study's solver is the route
MIRROR_STUDY = """
[base.rve]
size = [40e-6, 40e-6, 40e-6]
voxel = 4e-6
[[base.fibers]]
shape = "cylinder"
diameter = 10e-6
center = [20e-6, 20e-6, 20e-6]
direction = [1, 0, 0]
[base.flow]
periodic_treatment = "mirror"
error_estimate = false
[study]
design = "full-factorial"
seeds = [1]
solver = "voxel"
outputs = ["k_z"]
[parameters]
"flow.viscosity" = [1.8e-5]
"""
#: the study's base as a spec (a 4 um grid, the fibre along x)
MIRROR_BASE = {
    "rve": {"size": [40e-6, 40e-6, 40e-6], "voxel": 4e-6},
    "fibers": [{**SPEC["fibers"][0], "direction": [1, 0, 0]}],
    "flow": {"periodic_treatment": "mirror", "error_estimate": False},
}


def test_a_study_of_solver_voxel_runs_a_base_mirror_treatment(tmp_path):
    """Review of session 49: a study with base ``[flow] periodic_treatment = "mirror"`` (no
    flow.solver) and ``solver = "voxel"`` failed every case (``flow.periodic_treatment:
    'mirror' applies to the voxel solver's periodic bc only, not to solver 'fem'``, exit 1):
    the route's check read the table's default solver, not the study's. It worked until
    b74d15a. The case runs again and its K is the truth of the treatment: a cylinder centred
    in the box is its own mirror image, so the mirrored solve is the periodic one's array
    (docs/permeability.md, periodic_treatment) and K agrees to the solver tolerance."""
    import warnings

    import psdesign
    from psdesign.flow.voxel import ResolutionWarning
    from psdesign.study import run_study

    study = tmp_path / "s.toml"
    study.write_text(MIRROR_STUDY)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResolutionWarning)  # 2.5 voxels across: the point
        df = run_study(study, tmp_path / "out", workers=0, progress=False, report=False)
        m = psdesign.build(MIRROR_BASE)
        flow = {**m.spec["flow"], "periodic_treatment": "periodic"}
        periodic = psdesign.permeability(m.rve, m.fields, "z", flow, "voxel", None, False)
    row = df.iloc[0]
    assert row["status"] == "ok", row["error"]
    assert row["converged_z"] and row["bc_z"] == "periodic"
    assert row["k_z_m2"] == pytest.approx(periodic["permeability_m2"], rel=1e-6)
