"""How the report's figures draw a value that is not trusted (its status:
:func:`psdesign.analysis.columns.value_status`, one definition since session 46): one marker
style per status, shared by the static (matplotlib) and interactive (Plotly) figures so that
``not_converged`` and ``untrustworthy`` never look alike.

Session 45 found the K-vs-parameter frames dropping every untrusted case (an engineer saw a
line end without being told why) and the porosity-K and convergence figures drawing every
not-ok value with one red open marker.
"""

from __future__ import annotations

import pandas as pd

from psdesign.analysis.columns import case_status, value_status

__all__ = [
    "NOT_OK_MARKERS",
    "STATUS_STYLES",
    "draw_not_ok",
    "failed_count",
    "no_ok_case",
    "not_ok_status",
    "status_style",
]

#: How a caption names the not-ok markers of :func:`draw_not_ok`.
NOT_OK_MARKERS = "open markers, one colour per status, named in the legend"

#: Marker of each status that is not ``ok``: (Plotly open symbol, matplotlib marker, colour).
#: Any other status (``blocked``, ``error``, ...) takes :data:`OTHER_STYLE`.
STATUS_STYLES = {
    "not_converged": ("x-thin-open", "x", "#d62728"),
    # purple, not orange: the static figures' z direction is matplotlib's C1 orange
    "untrustworthy": ("diamond-open", "D", "#9467bd"),
}
OTHER_STYLE = ("square-open", "s", "#7f7f7f")


def status_style(status: str) -> tuple[str, str, str]:
    """(Plotly symbol, matplotlib marker, colour) of a not-ok ``status``."""
    return STATUS_STYLES.get(status, OTHER_STYLE)


def not_ok_status(df: pd.DataFrame, column: str, log: bool = True) -> dict[str, pd.Series]:
    """``{status: row mask}`` of the rows whose value in ``column`` is a finite number a figure
    can draw (positive on a ``log`` axis, else >= 0: a ``blocked`` D_eff/D is 0) and whose
    :func:`~psdesign.analysis.columns.value_status` is not ``ok``, statuses in sorted order (a
    failed case has no value: :func:`failed_count`).

    >>> df = pd.DataFrame({"status": ["ok", "ok", "ok"], "diffusivity_z": [0.5, 0.0, 0.3],
    ...                    "diffusivity_z_status": ["ok", "blocked", "untrustworthy"]})
    >>> {s: m.tolist() for s, m in not_ok_status(df, "diffusivity_z", log=False).items()}
    {'blocked': [False, True, False], 'untrustworthy': [False, False, True]}
    >>> list(not_ok_status(df, "diffusivity_z"))  # a log axis cannot draw the 0
    ['untrustworthy']
    """
    st = value_status(df, column)
    v = pd.to_numeric(df[column], errors="coerce") if column in df else None
    if v is None:
        return {}
    has = (v.gt(0) if log else v.ge(0)) & v.lt(float("inf"))
    return {s: has & (st == s) for s in sorted(set(st[has & (st != "ok")]))}


def failed_count(df: pd.DataFrame) -> int:
    """Cases the run could not give (``failed`` or ``timeout``,
    :data:`psdesign.cli.exit_status.NOT_FINISHED`): no value to draw (review s45: a timed-out
    case was not counted).

    >>> failed_count(pd.DataFrame({"status": ["ok", "timeout", "failed", "not_converged"]}))
    2
    """
    from psdesign.cli.exit_status import NOT_FINISHED

    return int(case_status(df).isin(NOT_FINISHED).sum())


def no_ok_case(df: pd.DataFrame) -> str:
    """How a study none of whose cases is ``ok`` is told (``"no case is ok: 12 failed of 12"``),
    or ``""`` when one is or the table is empty: with no ok case the sections over the ok cases
    said "No numeric design parameter to plot against" of a study varying two (session 45).

    >>> no_ok_case(pd.DataFrame({"status": ["failed", "not_converged", "failed"]}))
    'no case is ok: 2 failed, 1 not_converged of 3'
    >>> no_ok_case(pd.DataFrame({"status": ["failed", "ok"]}))
    ''
    """
    status = case_status(df)  # a table without a status column: every case ok
    if not len(df) or (status == "ok").any():
        return ""
    counts = status.value_counts().sort_index()
    return f"no case is ok: {', '.join(f'{n} {s}' for s, n in counts.items())} of {len(df)}"


def draw_not_ok(ax, df: pd.DataFrame, column: str, x, y, err, marker: str, name: str) -> int:
    """Draw on matplotlib ``ax`` the rows of ``df`` whose value in ``column`` is not ``ok``
    (:func:`not_ok_status`; a 0 too unless ``ax``'s y axis is already log: a ``blocked``
    D_eff/D on a linear one, left out until session 45): at (``x``, ``y``) (arrays over the
    rows) with bars ``err`` (or None), open ``marker`` in the status's colour, labelled
    ``"<name>: <status> (not in fits)"``; returns how many points were drawn."""
    import numpy as np

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = 0
    for status, m in not_ok_status(df, column, ax.get_yscale() == "log").items():
        rows = m.to_numpy() & np.isfinite(x) & np.isfinite(y)
        if not rows.any():
            continue
        color = status_style(status)[2]
        ax.errorbar(x[rows], y[rows], yerr=None if err is None else np.asarray(err)[rows],
                    fmt=marker, ms=9, mfc="none", mec=color, ecolor=color, color=color,
                    capsize=2, label=f"{name}: {status} (not in fits)")  # fmt: skip
        n += int(rows.sum())
    return n
