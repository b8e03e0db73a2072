"""Statistics over replicates: one row per design point with mean, std, 95 % CI and n.

Replicates are the cases that share every design parameter and differ in the seed (a point
listed twice with the same seed is one realization: :func:`~psdesign.analysis.columns.
distinct_realizations`). The 95 %
confidence interval of the mean is Student's ``mean +- t_{0.975, n-1} s / sqrt(n)``; with one
replicate the spread is unknown and the interval is NaN (said, not hidden). A permeability
(positive) and every output with a physical lower bound has its lower bound clipped there
(:func:`physical_floor`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from psdesign.analysis.columns import distinct_realizations, output_columns, trusted
from psdesign.analysis.ranges import RANGES


def t_quantile_975(dof: int) -> float:
    """Two-sided 95 % Student-t quantile for ``dof`` degrees of freedom (NaN for dof < 1)."""
    if dof < 1:
        return math.nan
    from scipy.stats import t

    return float(t.ppf(0.975, dof))


def physical_floor(column: str) -> float | None:
    """The physical lower bound of an output (:data:`psdesign.analysis.ranges.RANGES`: 0 for
    K, its tensor's diagonal, porosity, D_eff/D, conductivity, pore sizes, S_v), where
    :func:`replicate_summary` clips the 95 % CI's lower bound; None for an output without one
    (an off-diagonal ``k_xy_m2`` may be negative).

    >>> [physical_floor(c) for c in ("k_z_m2", "k_xx_m2", "k_xy_m2", "porosity", "k_z_status")]
    [0.0, 0.0, None, 0.0, None]
    """
    rng = RANGES.get(column)
    return None if rng is None else rng[0]


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
        ``X_ci95_high``.

    Notes
    -----
    The interval is Student's, ``mean +- t_{0.975, n-1} s / sqrt(n)``, the CI of the
    arithmetic mean that ``X_mean`` reports. Where the output has a physical lower bound
    (:func:`physical_floor`: 0 for a permeability ``k_<d>_m2``, porosity, D_eff/D, ...) the
    lower bound is clipped there: with few seeds and a wide spread (a small RVE) ``mean -
    half`` can fall below 0, a negative permeability. The upper bound is kept, so
    ``X_ci95_high - X_mean`` is still the Student half-width. (The CI of log K,
    exponentiated, would describe the geometric mean, not the ``X_mean`` beside it.) Other
    outputs (an off-diagonal ``k_xy_m2``) keep the symmetric interval.

    Examples
    --------
    >>> df = pd.DataFrame({"a": [1, 1, 2], "status": "ok", "k": [1.0, 3.0, 5.0]})
    >>> s = replicate_summary(df, ["a"])
    >>> s[["a", "n", "k_mean", "k_std"]].values.tolist()
    [[1.0, 2.0, 2.0, 1.4142135623730951], [2.0, 1.0, 5.0, nan]]
    """
    ok = df[df["status"] == "ok"] if "status" in df.columns else df
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
            low = mean - half
            floor = physical_floor(c)
            if floor is not None and low < floor:  # e.g. K > 0: never a negative bound
                low = floor
            row |= {
                f"{c}_n": n,
                f"{c}_mean": mean,
                f"{c}_std": std,
                f"{c}_ci95_low": low,
                f"{c}_ci95_high": mean + half,
            }
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
