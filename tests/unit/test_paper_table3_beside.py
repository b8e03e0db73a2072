"""``benchmarks/paper_table3.py summary FEM --beside VOXEL``: the FEM permeameter K beside the
voxel periodic K of the same seeds (docs/paper-reproduction.md section 2.1), on hand-made runs
whose means, Student-t intervals and ratios are known in closed form, and the doc's table
against the shipped runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import load_benchmark

ROOT = Path(__file__).resolve().parents[2]
SPEC = "studies/table3/straight.toml"


@pytest.fixture(scope="module")
def t3():
    return load_benchmark("paper_table3")


def _fem(seed: int, k: float) -> dict:
    return {
        "spec": SPEC, "method": "ga", "seed": seed, "solver": "fem", "bc": "permeameter",
        "k_x_m2": k, "k_x_faces_m2": 2 * k, "k_x_applied_m2": 3 * k, "k_x_converged": True,
        "k_x_rel_error": 0.1 * seed, "k_x_status": "ok",
    }  # fmt: skip


def _voxel(seed: int, k: float, method: str = "ga") -> dict:
    return {"spec": SPEC, "method": method, "seed": seed, "solver": "voxel", "bc": "periodic",
            "k_x_m2": k}  # fmt: skip


def _write(path: Path, rows: list[dict]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return path


def test_beside_gives_the_closed_form_means_intervals_and_ratios(t3, tmp_path):
    """Seeds 1, 2 at 1e-11 and 2e-11: mean 1.5e-11, 95 % half-width t(0.975, 1 dof) s / sqrt 2
    = 12.706 * 0.5e-11 = 6.35e-11 (t table, e.g. NIST/SEMATECH e-Handbook 1.3.6.7.2); Table
    III's straight in-plane 1.21e-11 makes the mean +24 %. Voxel K half of the FEM's: every
    ratio 2.000. A `fast` voxel run of seed 1 (another placement) must not be paired."""
    fem = _write(tmp_path / "f.jsonl", [_fem(1, 1e-11), _fem(2, 2e-11)])
    vox = [_voxel(1, 0.5e-11), _voxel(2, 1e-11), _voxel(1, 9e-11, method="fast")]
    row = t3.beside(fem, _write(tmp_path / "v.jsonl", vox)).splitlines()[2]
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[:3] == ["straight", "x", "2 (1, 2)"]
    assert cells[3] == "1.500e-11 +- 6.35e-11 (+24 %)"
    assert cells[4] == "7.500e-12 +- 3.18e-11 (-38 %)"
    assert cells[5] == "2.000 (2.000, 2.000)"
    assert cells[6] == "3.000e-11 +- 1.27e-10 (+148 %)"  # faces reading, 2x
    assert cells[7] == "4.500e-11 +- 1.91e-10 (+272 %)"  # applied reading, 3x
    assert cells[8:] == ["10.0-20.0 %, ok", "1.21e-11"]


def test_paper_doc_2_1_table_is_the_summary_of_the_shipped_runs(t3):
    """The section 2.1 table is the script's output on the shipped runs, not typed by hand."""
    doc = (ROOT / "docs" / "paper-reproduction.md").read_text()
    section = doc.split("### 2.1 ")[1].split("### 2.2 ")[0]
    table = t3.beside(
        ROOT / "benchmarks" / "paper_table3_fem_runs_s52.jsonl",
        ROOT / "benchmarks" / "paper_table3_voxel_runs_s52.jsonl",
    )
    for line in table.splitlines():
        assert line in section, line
