"""Statistics over replicates: one row per design point with mean, std, 95 % CI and n.

Replicates are the cases that share every design parameter and differ in the seed (a point
listed twice with the same seed is one realization: :func:`~psdesign.analysis.columns.
distinct_realizations`). The 95 %
confidence interval of the mean is Student's ``mean +- t_{0.975, n-1} s / sqrt(n)``; with one
replicate the spread is unknown and the interval is NaN (said, not hidden). The interval is
clipped to the output's physical range (:func:`physical_range`: K > 0, porosity and D_eff/D
in [0, 1], ...), both ways; the Student half-width ``t s / sqrt(n)`` is stored once, as its own
column ``X_ci95_half`` (:func:`ci95_half` reads it, or recomputes it for an older table).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from psdesign.analysis.columns import (
    ERROR_COLUMNS,
    distinct_realizations,
    ok_cases,
    output_columns,
    trusted,
)
from psdesign.analysis.ranges import RANGES
from psdesign.transport.study_outputs import UNIT_COLUMN


def t_quantile_975(dof: int) -> float:
    """Two-sided 95 % Student-t quantile for ``dof`` degrees of freedom (NaN for dof < 1)."""
    if dof < 1:
        return math.nan
    from scipy.stats import t

    return float(t.ppf(0.975, dof))


def physical_range(column: str) -> tuple[float | None, float | None]:
    """The physical range ``(floor, ceiling)`` of an output
    (:data:`psdesign.analysis.ranges.RANGES`), to which :func:`replicate_summary` clips the
    95 % CI: floor 0 for K, its tensor's diagonal, porosity, D_eff/D, conductivity, pore sizes,
    S_v; ceiling 1 for porosity and D_eff/D. None where an output has no such bound (an
    off-diagonal ``k_xy_m2`` may be negative; K has no ceiling). An error bar
    (:data:`~psdesign.analysis.columns.ERROR_COLUMNS`: ``porosity_error``, ``k_z_rel_error``...)
    is a magnitude: floor 0 (summary.csv had ``porosity_error_ci95_low = -0.000909``: walk-cli
    finding 5, session 52).

    >>> [physical_range(c) for c in ("k_z_m2", "k_xy_m2", "porosity", "diffusivity_z")]
    [(0.0, None), (None, None), (0.0, 1.0), (0.0, 1.0)]
    >>> physical_range("porosity_error"), physical_range("k_z_rel_error")
    ((0.0, None), (0.0, None))
    """
    if column in ERROR_COLUMNS:
        return 0.0, None
    rng = RANGES.get(column)
    if rng is None:
        return None, None
    low, high = rng[0], rng[2]
    return (
        low if math.isfinite(low) else None,
        high if math.isfinite(high) else None,
    )


def clip_to_range(column: str, low: float, high: float) -> tuple[float, float]:
    """The interval ``[low, high]`` of output ``column`` clipped to its :func:`physical_range`
    (NaN stays NaN).

    >>> clip_to_range("porosity", 0.97, 1.016)
    (0.97, 1.0)
    >>> clip_to_range("k_z_m2", -1e-12, 3e-12)
    (0.0, 3e-12)
    """
    floor, ceiling = physical_range(column)
    if floor is not None and low < floor:  # e.g. K > 0: never a negative bound
        low = floor
    if ceiling is not None and high > ceiling:  # e.g. porosity <= 1
        high = ceiling
    return low, high


def ci95_half(summary: pd.DataFrame, column: str) -> np.ndarray | None:
    """The Student 95 % half-width of output ``column``'s mean per row of a summary table
    (:func:`replicate_summary`), NaN with one replicate; None when the table has no interval.

    Reads ``X_ci95_half``; a table written before that column (session 40) gets it from
    ``X_std`` and ``X_n`` (``t_{0.975, n-1} X_std / sqrt(n)``), else from ``X_ci95_high -
    X_mean`` (its upper bound was never clipped then).

    >>> s = pd.DataFrame({"k_mean": [2.0], "k_std": [1.0], "k_n": [2], "k_ci95_high": [9.0]})
    >>> round(float(ci95_half(s, "k")[0]), 4)
    8.9846
    """
    if f"{column}_ci95_half" in summary:
        return summary[f"{column}_ci95_half"].to_numpy(dtype=float)
    if f"{column}_std" in summary and f"{column}_n" in summary:
        n = summary[f"{column}_n"].to_numpy(dtype=float)
        std = summary[f"{column}_std"].to_numpy(dtype=float)
        t = np.array([t_quantile_975(int(k) - 1) if k > 1 else math.nan for k in n])
        with np.errstate(invalid="ignore", divide="ignore"):
            return t * std / np.sqrt(n)
    if f"{column}_ci95_high" in summary and f"{column}_mean" in summary:
        high = summary[f"{column}_ci95_high"].to_numpy(dtype=float)
        return high - summary[f"{column}_mean"].to_numpy(dtype=float)
    return None


def replicate_summary(df: pd.DataFrame, params: list[str]) -> pd.DataFrame:
    """One row per design point of the ``ok`` cases of a results table.

    Parameters
    ----------
    df : DataFrame
        ``results.csv`` of a study.
    params : list of str
        The study's parameter columns (the design point).

    Returns
    -------
    DataFrame
        The parameter columns, ``n`` (cases) and for every numeric output ``X``: ``X_n`` (its
        finite values), ``X_mean``, ``X_std`` (sample, ddof 1), ``X_ci95_low``,
        ``X_ci95_high``, ``X_ci95_half`` (NaN with one finite value).

    Notes
    -----
    The interval is Student's, ``mean +- t_{0.975, n-1} s / sqrt(n)``, the CI of the
    arithmetic mean that ``X_mean`` reports, clipped to the output's physical range
    (:func:`physical_range`: K >= 0, porosity and D_eff/D in [0, 1], ...): with few seeds and
    a wide spread (a small RVE) ``mean - half`` can fall below 0, a negative permeability, and
    ``mean + half`` above 1, a porosity above 1 (session 40: 1.016 for a 30 um box, 2 seeds).
    The Student half-width itself is ``X_ci95_half``, unclipped: a reader of the error bar
    takes it from there (:func:`ci95_half`), not from ``X_ci95_high - X_mean``. (The CI of
    log K, exponentiated, would describe the geometric mean, not the ``X_mean`` beside it.)
    Other outputs (an off-diagonal ``k_xy_m2``) keep the symmetric interval.

    Examples
    --------
    >>> df = pd.DataFrame({"a": [1, 1, 2], "status": "ok", "k": [1.0, 3.0, 5.0]})
    >>> s = replicate_summary(df, ["a"])
    >>> s[["a", "n", "k_mean", "k_std"]].values.tolist()
    [[1.0, 2.0, 2.0, 1.4142135623730951], [2.0, 1.0, 5.0, nan]]
    """
    ok = ok_cases(df)
    ok = distinct_realizations(ok, params)
    outputs = output_columns(ok, params)
    keys = [p for p in params if p in ok.columns]
    rows = []
    groups = ok.groupby(keys, sort=False, dropna=False) if keys else [((), ok)]
    for key, g in groups:
        key = key if isinstance(key, tuple) else (key,)
        row: dict = dict(zip(keys, key, strict=True))
        row["n"] = len(g)
        for c in outputs:
            x = g[c].to_numpy(dtype=float)
            x = x[np.isfinite(x)]
            n = len(x)
            mean = float(x.mean()) if n else math.nan
            std = float(x.std(ddof=1)) if n > 1 else math.nan
            half = t_quantile_975(n - 1) * std / math.sqrt(n) if n > 1 else math.nan
            low, high = clip_to_range(c, mean - half, mean + half)
            row |= {
                f"{c}_n": n,
                f"{c}_mean": mean,
                f"{c}_std": std,
                f"{c}_ci95_low": low,
                f"{c}_ci95_high": high,
                f"{c}_ci95_half": half,
            }
        if UNIT_COLUMN in g:  # the conductivity's unit: a text column, carried per point
            row[UNIT_COLUMN] = "; ".join(sorted(set(g[UNIT_COLUMN].dropna().astype(str))))
        rows.append(row)
    return pd.DataFrame(rows)


def write_summary(out_dir: str | Path, df: pd.DataFrame, params: list[str]) -> pd.DataFrame:
    """Write ``OUT/summary.csv`` and ``OUT/summary.parquet`` atomically; returns the table.

    The statistics are over the trusted values (:func:`psdesign.analysis.columns.trusted`),
    as in the report; ``X_n`` counts them per output."""
    from psdesign.study.store import atomic_write_bytes

    out = Path(out_dir)
    summary = replicate_summary(trusted(df), params)
    atomic_write_bytes(out / "summary.csv", summary.to_csv(index=False).encode())
    try:
        import io

        buf = io.BytesIO()
        summary.to_parquet(buf, index=False)
        atomic_write_bytes(out / "summary.parquet", buf.getvalue())
    except (ImportError, ValueError):  # pyarrow missing or an object column it cannot store
        pass
    return summary
