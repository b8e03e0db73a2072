"""The report's first section: the study's answer at a glance, the highest and the lowest
trusted permeability of each direction and the design point that gave it, before the
details (session 45: the page opened on the run's metadata; the answer was 2-4 screens down)."""

from __future__ import annotations

import html
import math

import pandas as pd

from psdesign.analysis.columns import trusted
from psdesign.report.trust import no_ok_case

#: Under a table whose K (or log10 K) stays in m² whatever the unit selector picks (this one,
#: and the tables of :mod:`psdesign.report.html` that do not convert).
STAYS_M2_NOTE = (
    '<p class="note psd-stays-m2">This table stays in m² (the unit selector converts the '
    "Results table's K columns and the K figures).</p>"
)

__all__ = ["glance_section", "k_text"]

DIRECTION_NAMES = {"x": "in-plane", "y": "in-plane", "z": "through-plane"}


def k_text(k: float, rel: float) -> str:
    """A permeability with its relative error bar as the report prints it.

    >>> k_text(3.1929e-11, 0.0389)
    '3.193e-11 ± 3.9 %'
    >>> k_text(2e-12, float("nan"))
    '2e-12'
    """
    txt = "" if pd.isna(k) else f"{k:.4g}"
    if txt and not pd.isna(rel):
        txt += f" ± {100 * rel:.1f} %"
    return txt


def _where(row: pd.Series, params: list[str]) -> str:
    """The design point of a case: its parameter values, case id and seed."""
    point = ", ".join(f"{p}={row[p]:.4g}" if _is_num(row[p]) else f"{p}={row[p]}" for p in params)
    return f"{point} ({row.get('case_id', '')}, seed {row.get('seed', '')})"


def _is_num(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def glance_section(df: pd.DataFrame, params: list[str]) -> str:
    """HTML of the "At a glance" section: per direction, the highest and the lowest trusted K
    (:func:`psdesign.analysis.columns.trusted`: the case ok and the K's own status ok) with its
    error bar and design point, and how many cases gave a trusted K; without any K column, that
    no case is ok when none is (every case failed), else "".

    Parameters
    ----------
    df : pandas.DataFrame
        ``results.csv`` of the study.
    params : list of str
        The study's design parameters (columns of ``df``).

    Returns
    -------
    str
        The section's HTML (escaped), or "".
    """
    dirs = [d for d in "xyz" if f"k_{d}_m2" in df]
    if not dirs:  # a study of every case failed has no K column: its answer is that
        none_ok = no_ok_case(df)
        return none_ok and (
            f'<h2 id="psd-glance">At a glance</h2><p class="note">No result: '
            f"{html.escape(none_ok)} (each case's reason in the tables below).</p>"
        )
    t = trusted(df)
    params = [p for p in params if p in df]
    rows = []
    for d in dirs:
        k = pd.to_numeric(t[f"k_{d}_m2"], errors="coerce")
        rel = pd.to_numeric(t.get(f"k_{d}_rel_error", pd.Series(index=t.index)), errors="coerce")
        n = int(k.notna().sum())
        cells = [f"K_{d} (m²), {DIRECTION_NAMES[d]}"]
        for i in (k.idxmax(), k.idxmin()) if n else ():
            cells.append(f"{k_text(k[i], rel[i])} at {_where(t.loc[i], params)}")
        if not n:
            cells += ["no trusted K", ""]
        cells.append(f"{n} of {len(df)}")
        rows.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) + "</tr>")
    head = "".join(
        f"<th>{h}</th>" for h in ("permeability", "highest", "lowest", "cases with a trusted K")
    )
    return (
        '<h2 id="psd-glance">At a glance</h2><p class="note">The highest and the lowest '
        "permeability of each direction over the cases whose K is trusted (case and K status "
        "ok; any other is marked in the tables below), with its error bar and the design "
        "point that gave it.</p>"
        + STAYS_M2_NOTE
        + f'<table class="meta glance"><thead><tr>{head}</tr></thead><tbody>'
        + "".join(rows)
        + "</tbody></table>"
    )
