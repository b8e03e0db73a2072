"""``benchmarks/solver_agreement.py seam`` rates a row as the product does.

The product (``psdesign.flow.permeability``, where ``status_of`` is called) rates the voxel route
untrustworthy below 8 voxels across the thinnest fibre, while the FEM's status follows its error
bar alone (its under-resolution line is a warning only). The ``seam`` subcommand, which added the
seam term to the bars of rows solved before it, re-rated every row with the cells-per-diameter
rule: the FEM rows of docs/solver-agreement.md it touched read 'untrustworthy' with bars of
1-8 % (e.g. table3 stacked, bar 3.0 %, 3.4 cells per diameter), where a solve of the same row
on the same code says 'ok' (session 37, s37-agree).
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest
from conftest import load_benchmark

ROOT = Path(__file__).resolve().parents[2]


def _script():
    return load_benchmark("solver_agreement")


def _row(solver: str, cpd: float, bar: float) -> dict:
    return {
        "date": "2026-12-02 06:58",  # before the seam term (SEAM_TERM_SINCE)
        "spec": "studies/x.toml",
        "bc": "periodic",
        "solver": solver,
        "k_m2": 5.65e-12,
        "rel_error": bar,
        "converged": True,
        "cells_per_diameter": cpd,
        "status": "ok",
    }


def test_seam_keeps_the_products_status_rule(tmp_path: Path, monkeypatch) -> None:
    """An FEM row at 3.4 cells per diameter with a 2.7 % bar stays 'ok' after the seam term
    (0.36 points for g / L = 0.19 %, as table3's RVE); a voxel row at 4.2 voxels per diameter is
    'untrustworthy' (the product's rule, ``psdesign.flow.error.status_of``: bar above 20 % or,
    for the voxel route, fewer than 8 cells per diameter)."""
    import psdesign.flow.stack as stack
    from psdesign.flow.error import SEAM_SLOPE

    mod = _script()
    rel = "studies/x.toml"
    rows = {(rel, "periodic", "fem"): _row("fem", 3.4, 0.027)}
    rows[(rel, "periodic", "voxel")] = _row("voxel", 4.2, 0.05)
    monkeypatch.setattr(mod, "CACHE", tmp_path)
    monkeypatch.setattr(mod, "_spec_rows", lambda: ({rel: {"spec": rel, "base": {}}}, rows))
    monkeypatch.setattr(mod, "_rebuild", lambda rel, info: (SimpleNamespace(rve=None), None))
    monkeypatch.setattr(mod, "_refresh_refusal", lambda *a: None)
    monkeypatch.setattr(stack, "periodicity", lambda *a: (True, None, None, 0.0019))
    mod.run_seam(SimpleNamespace(only=None, direction="z"))
    fem = json.loads((tmp_path / "x__z__periodic__fem.json").read_text())
    vox = json.loads((tmp_path / "x__z__periodic__voxel.json").read_text())
    assert fem["rel_error"] == pytest.approx(0.027 + SEAM_SLOPE * 0.0019, rel=1e-12)
    assert fem["status"] == "ok"
    assert vox["status"] == "untrustworthy"
