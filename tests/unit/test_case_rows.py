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
