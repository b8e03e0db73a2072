"""Sensitivity summaries of study results: Spearman rank correlation, standardized regression
coefficients (SRC) and main-effect means."""

from __future__ import annotations

import numpy as np
import pandas as pd

from psdesign.analysis.columns import distinct_realizations, ok_cases
from psdesign.analysis.entangled import entangled

__all__ = ["main_effects", "response_columns", "sensitivity_table"]

K_COLUMNS = ("k_x_m2", "k_y_m2", "k_z_m2")


def response_columns(df: pd.DataFrame) -> dict[str, pd.Series]:
    """Responses analysed: ``porosity`` and ``log10(k_*_m2)`` for the computed directions."""
    out: dict[str, pd.Series] = {}
    if "porosity" in df and pd.to_numeric(df["porosity"], errors="coerce").notna().sum() > 1:
        out["porosity"] = pd.to_numeric(df["porosity"], errors="coerce")
    for c in K_COLUMNS:
        if c in df:
            k = pd.to_numeric(df[c], errors="coerce")
            k = k.where(k > 0)
            if k.notna().sum() > 1:
                out[f"log10 {c}"] = np.log10(k)
    return out


def _numeric(s: pd.Series) -> pd.Series | None:
    x = pd.to_numeric(s, errors="coerce")
    if x.notna().all() and x.nunique() > 1:
        return x.astype(float)
    return None


def sensitivity_table(df: pd.DataFrame, params: list[str]) -> pd.DataFrame:
    """Spearman rank correlation and SRC of each numeric parameter vs each response, over
    the distinct realizations (:func:`~psdesign.analysis.columns.distinct_realizations`: a
    design point listed twice with the same seed counts once).

    The SRC is the coefficient of the least-squares fit of the standardized response on all
    standardized numeric parameters (computed when there are more rows than parameters + 1).

    Returns
    -------
    pandas.DataFrame
        Columns ``parameter``, ``response``, ``spearman``, ``src``, ``n``.
    """
    from scipy.stats import spearmanr

    ok = ok_cases(df)
    ok = distinct_realizations(ok, params)  # a design point listed twice is one case
    responses = response_columns(ok)
    xs = {p: _numeric(ok[p]) for p in params if p in ok}
    xs = {p: x for p, x in xs.items() if x is not None}
    rows = []
    for rname, y in responses.items():
        mask = y.notna()
        for x in xs.values():
            mask &= x.notna()
        n = int(mask.sum())
        src: dict[str, float] = {}
        if xs and n > len(xs) + 1:
            X = np.column_stack([xs[p][mask].to_numpy() for p in xs])
            yv = y[mask].to_numpy(dtype=float)
            # a parameter constant over the rows with this response has no SRC (and would
            # put NaN into the least squares); nor have two that moved together (a csv design
            # with b = 2 a: least squares split the effect 0.50 / 0.50, whatever the truth)
            if yv.std() > 0 and (X.std(0) > 0).all() and not entangled(X, list(xs)):
                Xs = (X - X.mean(0)) / X.std(0)
                ys = (yv - yv.mean()) / yv.std()
                coef, *_ = np.linalg.lstsq(Xs, ys, rcond=None)
                src = dict(zip(xs, coef, strict=True))
        for p, x in xs.items():
            m = x.notna() & y.notna()
            rho = np.nan
            if m.sum() > 2 and y[m].nunique() > 1 and x[m].nunique() > 1:
                rho = float(spearmanr(x[m], y[m]).statistic)
            rows.append(
                {
                    "parameter": p,
                    "response": rname,
                    "spearman": rho,
                    "src": float(src.get(p, np.nan)),
                    "n": int(m.sum()),
                }
            )
    return pd.DataFrame(rows, columns=["parameter", "response", "spearman", "src", "n"])


def main_effects(df: pd.DataFrame, params: list[str]) -> pd.DataFrame:
    """Mean of each response at each level of each parameter (factorial designs), each
    distinct realization counted once.

    Returns
    -------
    pandas.DataFrame
        Columns ``parameter``, ``level`` and per response its mean (``mean log10 k_z_m2``)
        and the count of values behind it (``n log10 k_z_m2``, as summary.csv's ``k_z_m2_n``:
        a case whose K is not trusted has none; one ``n`` of cases read as the mean's count,
        review s52).
    """
    ok = ok_cases(df)
    ok = distinct_realizations(ok, params)  # a design point listed twice is one case
    responses = response_columns(ok)
    if not responses:
        return pd.DataFrame()
    frame = pd.DataFrame(responses)
    out = []
    for p in params:
        if p not in ok or ok[p].nunique() < 2:
            continue
        g = frame.groupby(ok[p].astype(str).to_numpy(), sort=False)
        means, counts = g.mean(), g.count()
        for level in means.index:
            row: dict = {"parameter": p, "level": level}
            for k, v in means.loc[level].items():
                row[f"mean {k}"], row[f"n {k}"] = float(v), int(counts.loc[level, k])
            out.append(row)
    return pd.DataFrame(out)
