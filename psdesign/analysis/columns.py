"""Which columns of a study table are design parameters, which are outputs."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

#: Columns that describe a case, not a result.
CASE_COLUMNS = ("case_id", "index", "seed", "status", "error")


def study_parameters(out_dir: str | Path) -> dict[str, dict]:
    """The ``parameters`` table of ``OUT/study.json`` (path -> kind, values, low, high, ...)."""
    path = Path(out_dir) / "study.json"
    if not path.is_file():
        raise FileNotFoundError(f"{out_dir}: no study.json; is this a study output folder?")
    doc = json.loads(path.read_text())
    study = doc.get("study", doc)
    return dict(study.get("parameters", {}))


def numeric_parameters(df: pd.DataFrame, params: list[str]) -> list[str]:
    """Parameters whose every value is a finite number (whole-table levels are left out)."""
    out = []
    for p in params:
        if p in df.columns and pd.api.types.is_numeric_dtype(df[p]) and df[p].notna().all():
            out.append(p)
    return out


def output_columns(df: pd.DataFrame, params: list[str]) -> list[str]:
    """Numeric result columns (K, porosity, errors, solver statistics; timings left out)."""
    from psdesign.study.store import is_timing_column

    skip = set(CASE_COLUMNS) | set(params)
    return [
        c
        for c in df.columns
        if c not in skip
        and not is_timing_column(c)
        and pd.api.types.is_numeric_dtype(df[c])
        and not pd.api.types.is_bool_dtype(df[c])
    ]
