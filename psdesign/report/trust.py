"""How the report's figures draw a value that is not trusted (its status:
:func:`psdesign.analysis.columns.value_status`, one definition since session 46, whose ``ok``
is the exit's trusted words since session 51): one marker style per status, shared by the
static (matplotlib) and interactive (Plotly) figures so that ``not_converged`` and
``untrustworthy`` never look alike.

Session 45 found the K-vs-parameter frames dropping every untrusted case (an engineer saw a
line end without being told why) and the porosity-K and convergence figures drawing every
not-ok value with one red open marker. Session 47: a point of a porosity figure is as trusted
as the least trusted of its two coordinates (:func:`point_status`).
"""

from __future__ import annotations

import pandas as pd

from psdesign.analysis.columns import case_status, value_status

__all__ = [
    "AT_UNTRUSTED_X",
    "NOT_OK_MARKERS",
    "STATUS_STYLES",
    "draw_not_ok",
    "failed_count",
    "no_ok_case",
    "not_ok_status",
    "point_status",
    "status_style",
]

#: How a caption names the not-ok markers of :func:`draw_not_ok`.
NOT_OK_MARKERS = "open markers, one colour per status, named in the legend"
#: How a caption counts the trusted values :func:`draw_not_ok` draws open at an x (the
#: porosity) that is not trusted (``.format(n=..., values="K", x="porosity")``).
AT_UNTRUSTED_X = (
    "{n} trusted {values} value(s) at a {x} that is not ok are drawn open too (legend "
    '"{x} <status>"): the {values} stays in the fits and sensitivity, the {x} does not.'
)

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


def point_status(df: pd.DataFrame, column: str, x_column: str | None = None) -> pd.Series:
    """The status of each row's point: the :func:`~psdesign.analysis.columns.value_status` of
    its value in ``column``, or with an ``x_column`` (the porosity of a porosity-K figure) the
    worst of its two coordinates' (:func:`~psdesign.transport.effective.worst_status`): a point
    is as trusted as the least trusted of them (session 47: a trusted K at a porosity with a
    27 % bar was drawn filled, at an x no one trusts).

    >>> df = pd.DataFrame({"porosity": [0.8, 0.09], "porosity_error": [4e-4, 0.025],
    ...                    "k_z_m2": [1e-11, 2e-11], "k_z_status": ["ok", "ok"]})
    >>> point_status(df, "k_z_m2").tolist(), point_status(df, "k_z_m2", "porosity").tolist()
    (['ok', 'ok'], ['ok', 'untrustworthy'])
    """
    st = value_status(df, column)
    if x_column is None:
        return st
    from psdesign.transport.effective import worst_status

    sx = value_status(df, x_column)
    both = (st != "ok") & (sx != "ok")  # the worst of two words only where both are not ok
    worst = [worst_status([a, b]) for a, b in zip(st[both], sx[both], strict=True)]
    out = st.where(st != "ok", sx).astype(object)
    out[both] = worst
    return out.astype(str)


def not_ok_status(
    df: pd.DataFrame, column: str, log: bool = True, x_column: str | None = None
) -> dict[str, pd.Series]:
    """``{status: row mask}`` of the rows whose value in ``column`` is a finite number a figure
    can draw (positive on a ``log`` axis, else >= 0: a ``blocked`` D_eff/D is 0) and whose
    status is not ``ok`` (:func:`point_status`: the value's
    :func:`~psdesign.analysis.columns.value_status`, with an ``x_column`` the worst of it and
    its x's), statuses in sorted order (a failed case has no value: :func:`failed_count`).

    >>> df = pd.DataFrame({"status": ["ok", "ok", "ok"], "diffusivity_z": [0.5, 0.0, 0.3],
    ...                    "diffusivity_z_status": ["ok", "blocked", "untrustworthy"]})
    >>> {s: m.tolist() for s, m in not_ok_status(df, "diffusivity_z", log=False).items()}
    {'blocked': [False, True, False], 'untrustworthy': [False, False, True]}
    >>> list(not_ok_status(df, "diffusivity_z"))  # a log axis cannot draw the 0
    ['untrustworthy']
    """
    v = pd.to_numeric(df[column], errors="coerce") if column in df else None
    if v is None:
        return {}
    st = point_status(df, column, x_column)
    has = (v.gt(0) if log else v.ge(0)) & v.lt(float("inf"))
    return {s: has & (st == s) for s in sorted(set(st[has & (st != "ok")]))}


def failed_count(df: pd.DataFrame) -> int:
    """Cases the run could not give (``failed`` or ``timeout``,
    :data:`psdesign.status.NOT_FINISHED`): no value to draw (review s45: a timed-out
    case was not counted).

    >>> failed_count(pd.DataFrame({"status": ["ok", "timeout", "failed", "not_converged"]}))
    2
    """
    from psdesign.status import NOT_FINISHED

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


def draw_not_ok(
    ax, df: pd.DataFrame, column: str, points: tuple, marker: str, name: str, x_column=None
) -> tuple[int, int]:
    """Draw on matplotlib ``ax`` the rows of ``df`` whose point is not ``ok``
    (:func:`not_ok_status`; a 0 too unless ``ax``'s y axis is already log: a ``blocked``
    D_eff/D on a linear one, left out until session 45) at ``points`` = (x, y, err) (arrays
    over the rows; err may be None), open ``marker`` in the status's colour. A row whose value
    in ``column`` is not ok is labelled ``"<name>: <status> (not in fits)"``; one whose value is
    trusted at an x that is not (:func:`point_status` of ``x_column``, the porosity),
    ``"<name>: porosity <status> (value in fits)"``, the same open marker (until session 47
    drawn filled, as a trusted point).
    Returns how many points of each kind were drawn: (value not ok, x alone not ok)."""
    import numpy as np

    x, y, err = points
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    value_bad = (value_status(df, column) != "ok").to_numpy()
    n = [0, 0]
    for status, m in not_ok_status(df, column, ax.get_yscale() == "log", x_column).items():
        color = status_style(status)[2]
        labels = (f"{status} (not in fits)", f"{x_column} {status} (value in fits)")
        for i, (which, label) in enumerate(zip((value_bad, ~value_bad), labels, strict=True)):
            rows = m.to_numpy() & which & np.isfinite(x) & np.isfinite(y)
            if not rows.any():
                continue
            ax.errorbar(x[rows], y[rows], yerr=None if err is None else np.asarray(err)[rows],
                        fmt=marker, ms=9, mfc="none", mec=color, ecolor=color, color=color,
                        capsize=2, label=f"{name}: {label}")  # fmt: skip
            n[i] += int(rows.sum())
    return n[0], n[1]
