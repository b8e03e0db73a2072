"""Report sections that turn a study table into a design decision: outputs against each design
parameter with replicate 95 % CIs and numerical error bars, anisotropy, main effects and
two-factor interactions, the surrogate's response surface with its uncertainty, and Sobol
indices (interactive, Plotly).
"""

from __future__ import annotations

import html
import math
from typing import NamedTuple

import numpy as np
import pandas as pd

from psdesign.analysis.columns import (
    ABS_ERROR_COLUMNS,
    ERROR_COLUMNS,
    LOWER_BAR_COLUMN,
    REL_ERROR_COLUMNS,
    UPPER_BARS,
    column_numbers,
    distinct_realizations,
    numeric_parameters,
    trusted,
    value_status,
    varying_categories,
)
from psdesign.analysis.replicates import ci95_half, replicate_summary
from psdesign.report.interactive import figure_html, number_axis
from psdesign.report.trust import (
    failed_count,
    no_ok_case,
    not_ok_status,
    status_style,
)
from psdesign.report.units import output_label, parameter_label, parameter_unit

K_DIRECTIONS = {"k_x_m2": "x (in-plane)", "k_y_m2": "y (in-plane)", "k_z_m2": "z (through-plane)"}
#: Other outputs plotted against the parameters when present.
OTHER_OUTPUT_PREFIXES = (
    "porosity",
    "diffusivity_",
    "tortuosity_",
    "conductivity_",
    "pore_d",
    "specific_surface",
    "anisotropy",
)
#: Fewest finished cases to fit a surrogate in the report.
MIN_CASES_SURROGATE = 6
#: Levels above which a parameter is binned (quartiles) for main-effect plots.
MAX_LEVELS = 6
#: Most combinations of the other parameters drawn as separate lines in a parameter plot.
MAX_LINE_GROUPS = 4
DASHES = ("solid", "dash", "dot", "dashdot")
#: Horizontal gap (fraction of the width) between the response surface's two panels: room
#: for the first panel's colour bar and the second panel's tick labels.
SURFACE_GAP = 0.3


def param_axis(p: str, log: bool = False) -> dict:
    """Plotly axis settings of a design parameter: title with its unit, the ticks of
    :func:`~psdesign.report.interactive.number_axis` (SI-prefixed with the unit, ``6μm``, or
    plain / exponent numbers for a dimensionless one), and a log axis for a ``loguniform``
    one (``log``; on a linear axis a 1e-7 to 1e-3 m range put 3/4 of its cases in the first
    1 % of the width)."""
    axis = {"title": {"text": parameter_label(p)}, **number_axis(parameter_unit(p))}
    return axis | ({"type": "log"} if log else {})


def _value(p: str, v) -> str:
    if isinstance(v, str):  # a categorical level (flow.wall_treatment = "diffuse")
        return v
    unit = parameter_unit(p)
    return f"{float(v):.4g}" + (f" {unit}" if unit and unit != "-" else "")


def _line_groups(s: pd.DataFrame, p: str, params: list[str]) -> tuple[list, str]:
    """Rows of ``s`` split by the levels of the other parameters, and the plot mode.

    Points are joined by lines only within one combination of the other parameters, numeric or
    not (a line across different diameters, or across two wall models, would draw a zig-zag
    that is no trend); scattered designs and many combinations give markers only.
    """
    others = [q for q in params if q != p and q in s.columns]
    if not others:
        return [("", s)], "markers+lines" if s[p].nunique() > 1 else "markers"
    groups = list(s.groupby(others, sort=True))
    if len(groups) > MAX_LINE_GROUPS or all(len(g) < 2 for _, g in groups):
        return [("", s)], "markers"
    out = []
    for key, g in groups:
        key = key if isinstance(key, tuple) else (key,)
        out.append(
            (", ".join(f"{q} = {_value(q, v)}" for q, v in zip(others, key, strict=True)), g)
        )
    return out, "markers+lines"


_ok = trusted


def add_anisotropy(df: pd.DataFrame) -> pd.DataFrame:
    """Add ``anisotropy`` = mean in-plane K / through-plane K (K_x, K_y over K_z) per case, and
    ``anisotropy_status``: the worst (:func:`~psdesign.transport.effective.worst_status`) of
    the statuses of the K it divides (:func:`~psdesign.analysis.columns.value_status`), a ratio
    being no better than its parts.

    >>> df = pd.DataFrame({"status": ["ok", "ok"], "k_x_m2": [4.0, 4.0], "k_z_m2": [2.0, 1.0],
    ...                    "k_z_status": ["ok", "untrustworthy"]})
    >>> add_anisotropy(df)[["anisotropy", "anisotropy_status"]].values.tolist()
    [[2.0, 'ok'], [4.0, 'untrustworthy']]
    """
    from psdesign.transport.effective import worst_status

    inplane = [c for c in ("k_x_m2", "k_y_m2") if c in df]
    if "k_z_m2" not in df or not inplane:
        return df
    out = df.copy()
    out["anisotropy"] = out[inplane].mean(axis=1) / out["k_z_m2"]
    st = pd.concat([value_status(df, c) for c in [*inplane, "k_z_m2"]], axis=1)
    out["anisotropy_status"] = [worst_status(list(r)) for r in st.itertuples(index=False)]
    return out


def _err(summary: pd.DataFrame, c: str) -> np.ndarray | None:
    """Half-width of the bar on each design point's mean of output ``c``: the 95 % CI of the
    replicate mean (0 with one replicate) plus the mean of the cases' own numerical error bars
    (:data:`~psdesign.analysis.columns.REL_ERROR_COLUMNS`, ``ABS_ERROR_COLUMNS``), added: a
    discretization error is not averaged away by more seeds. None when ``c`` has neither.

    The CI's half-width is the table's ``X_ci95_half`` (:func:`~psdesign.analysis.replicates.
    ci95_half`), not ``X_ci95_high - X_mean``: the interval is clipped to the physical range
    (a porosity's upper bound at 1).

    >>> s = pd.DataFrame({"k_z_m2_mean": [2.0], "k_z_m2_ci95_half": [0.5],
    ...                   "k_z_rel_error_mean": [0.1]})
    >>> _err(s, "k_z_m2").tolist()
    [0.7]
    """
    num = _numerical_half_width(summary, c)
    half = ci95_half(summary, c)
    if half is None:
        return num
    if num is None:
        return half
    return np.nan_to_num(half, nan=0.0) + num


def _numerical_half_width(table: pd.DataFrame, c: str, suffix: str = "_mean") -> np.ndarray | None:
    """The numerical error bar (absolute) of output ``c`` per row of ``table``: a summary's
    mean bar per design point, or with ``suffix=""`` each case's own bar in a results table
    (:data:`~psdesign.analysis.columns.REL_ERROR_COLUMNS` x the value, else
    :data:`~psdesign.analysis.columns.ABS_ERROR_COLUMNS`); None when ``c`` has neither.

    >>> t = pd.DataFrame({"porosity": [0.8], "porosity_error": [0.01]})
    >>> _numerical_half_width(t, "porosity", suffix="").tolist()
    [0.01]
    """

    def col(name: str) -> np.ndarray:
        return pd.to_numeric(table[f"{name}{suffix}"], errors="coerce").to_numpy(dtype=float)

    if f"{REL_ERROR_COLUMNS.get(c)}{suffix}" in table:
        return col(REL_ERROR_COLUMNS[c]) * np.abs(col(c))
    if f"{ABS_ERROR_COLUMNS.get(c)}{suffix}" in table:
        return col(ABS_ERROR_COLUMNS[c])
    return None


def _nan_none(a) -> list:
    return [None if (v is None or not math.isfinite(float(v))) else float(v) for v in a]


def _error_y(c: str, up: np.ndarray | None, down: np.ndarray | None) -> dict | None:
    """Plotly's ``error_y`` of output ``c``: ``up`` both ways, or for a value whose numerical
    bar is one-sided (:data:`~psdesign.analysis.columns.UPPER_BARS`: a pore diameter's scan
    measures low, the truth lies above) ``up`` above and ``down`` (the part of the bar that
    is not the numerical one: the replicates' CI, 0 for one case) below; None without ``up``.

    >>> _error_y("pore_d50_m", np.array([3.0]), np.array([1.0]))["arrayminus"]
    [1.0]
    >>> "arrayminus" in _error_y("k_z_m2", np.array([3.0]), np.array([1.0]))
    False
    """
    if up is None:
        return None
    bar = {"type": "data", "array": _nan_none(up)}
    if c in UPPER_BARS and down is not None:
        bar |= {"symmetric": False, "arrayminus": _nan_none(down)}
    return bar


def _below_part(table: pd.DataFrame, c: str, suffix: str = "_mean") -> np.ndarray:
    """The lower side of a pore diameter's own bar per row of ``table`` (a summary's mean,
    with ``suffix=""`` each case's): :data:`~psdesign.analysis.columns.LOWER_BAR_COLUMN`, 0
    where it is absent or NaN (every face repeats) or ``c`` has no one-sided bar.

    >>> t = pd.DataFrame({"pore_d50_m": [2e-5, 2e-5], "pore_diameter_error_below_m": [3e-6, None]})
    >>> _below_part(t, "pore_d50_m", suffix="").tolist(), _below_part(t, "k_z_m2", "").tolist()
    ([3e-06, 0.0], [0.0, 0.0])
    """
    name = f"{LOWER_BAR_COLUMN}{suffix}"
    if c not in UPPER_BARS or name not in table:
        return np.zeros(len(table))
    return np.nan_to_num(column_numbers(table, name), nan=0.0)


def _ci_part(summary: pd.DataFrame, c: str) -> np.ndarray:
    """The replicates' 95 % CI half-width of each design point's mean of ``c`` (0 without
    one): the part of :func:`_err` below a one-sided value's mean."""
    half = ci95_half(summary, c)
    return np.zeros(len(summary)) if half is None else np.nan_to_num(half, nan=0.0)


def parameter_plots(df: pd.DataFrame, params: list[str], study: dict | None = None) -> str:
    """Every output against each numeric design parameter: replicate means, bars of the 95 % CI
    plus the numerical error bar (:func:`_err`); ``loguniform`` parameters of ``study`` on a
    log axis."""
    import plotly.graph_objects as go

    from psdesign.analysis.surrogate import log_parameters

    logs = log_parameters((study or {}).get("parameters") or {})

    ok = add_anisotropy(_ok(df))
    num = numeric_parameters(ok, params)
    held = _held_note([p for p in num if ok[p].nunique() == 1], ok)
    num = [p for p in num if ok[p].nunique() > 1]  # one x value is no trend: no frame of it
    if not num:
        return (
            _nothing_ok(df)
            or held
            or '<p class="note">No numeric design parameter to plot against.</p>'
        )
    summary = replicate_summary(ok, params)
    # outputs with at least one trusted value (an all-NaN output would draw an empty frame)
    has = [c[:-5] for c in summary.columns if c.endswith("_mean") and summary[c].notna().any()]
    # each output's not-ok rows once (not once per parameter: on a 2000-row table without
    # status columns each took a rating of every row, session 47); K on its log axis
    k_bad = {c: not_ok_status(df, c) for c in K_DIRECTIONS}
    # a direction is drawn when it has a trusted mean or a case's value that is not ok
    kcols = [c for c in K_DIRECTIONS if c in has or any(m.any() for m in k_bad[c].values())]
    every = add_anisotropy(df)  # every case, for the values that are not ok
    others, bad = _other_outputs(every, has)
    # notes above the grid: a note in a grid cell pushed the frames aside
    if any(c in df for c in K_DIRECTIONS) and not any(c in has for c in K_DIRECTIONS):
        held += NO_TRUSTED_K
    n_failed = failed_count(df)
    if kcols and n_failed:
        held += f'<p class="note">{n_failed} failed or timed-out case(s) have no K: not drawn.</p>'
    parts = []
    for p in num:
        order = np.argsort(summary[p].to_numpy(dtype=float), kind="stable")
        groups, mode = _line_groups(summary.iloc[order], p, params)
        if kcols:
            fig = go.Figure()
            for i, c in enumerate(kcols):
                for j, (label, g) in enumerate(groups):
                    if c in has:
                        fig.add_trace(_mean_trace(g, p, c, mode, K_DIRECTIONS[c], label, i, j))
                # never in a mean or a line: each case's own value, marked by its status
                color = COLORS[i % len(COLORS)]
                fig.add_traces(_not_ok_traces(df, p, c, K_DIRECTIONS[c], color, k_bad[c]))
            fig.update_layout(
                title=f"K vs {p} (mean of replicates; bar: 95 % CI + numerical error)",
                height=360,
                xaxis=param_axis(p, p in logs),
                yaxis_title="K (m²)",
                yaxis_type="log",
                margin={"l": 60, "r": 10, "t": 40, "b": 50},
            )
            parts.append(figure_html(fig, f"psd-k-{p}", k_axis="yaxis", k_label="K"))
        for c in others:
            fig = _other_figure(every, groups, mode, p, c, bad[c], c in has)
            fig.update_layout(xaxis=param_axis(p, p in logs), yaxis_title=output_label(c, study))
            parts.append(figure_html(fig, f"psd-{c}-{p}"))
    grid = '<div class="psd-grid">' + "".join(f"<div>{x}</div>" for x in parts) + "</div>"
    return held + grid


def _other_outputs(
    every: pd.DataFrame, has: list[str]
) -> tuple[list[str], dict[str, dict[str, pd.Series]]]:
    """The outputs other than K drawn against the parameters: those with a trusted mean
    (``has``), then those whose every value is not ok (drawn as the K frames draw them; until
    session 45 such an output had no frame and an untrusted value no marker); and each one's
    not-ok rows on a linear axis (:func:`~psdesign.report.trust.not_ok_status`). An error
    column is the bar of its value (drawn on it, :func:`_err`), not an output."""
    outputs = [
        c for c in dict.fromkeys([*has, *every.columns])
        if c.startswith(OTHER_OUTPUT_PREFIXES) and c not in ERROR_COLUMNS
    ]  # fmt: skip
    bad = {c: not_ok_status(every, c, False) for c in outputs}
    return [c for c in outputs if c in has or bad[c]], bad


def _other_figure(
    every: pd.DataFrame, groups: list, mode: str, p: str, c: str, masks: dict, trusted: bool
):
    """The frame of output ``c`` against ``p`` (linear axis): the lines of trusted replicate
    means (``groups`` of the summary, when ``trusted``) and every case's value that is not ok
    by its status (``masks``, :func:`_not_ok_traces`, a ``blocked`` 0 included), never in a
    line."""
    import plotly.graph_objects as go

    lines = [_mean_trace(g, p, c, mode, c, label, 0, j) for j, (label, g) in enumerate(groups)]
    bad = _not_ok_traces(every, p, c, c, COLORS[0], masks)
    fig = go.Figure((lines if trusted else []) + bad)
    fig.update_layout(
        title=f"{c} vs {p}" + _one_sided_note(every, c),
        height=320,
        showlegend=len(groups) > 1 or bool(bad),
        margin={"l": 60, "r": 10, "t": 40, "b": 50},
    )
    return fig


def _one_sided_note(every: pd.DataFrame, c: str) -> str:
    """The title's word on a pore diameter's bar: ``+bar/-0`` where every case's box repeats,
    ``+bar/-below`` where some case's lower side is not 0 (a face that does not repeat,
    :data:`~psdesign.analysis.columns.LOWER_BAR_COLUMN`; session 54 review)."""
    if c not in UPPER_BARS:
        return ""
    if _below_part(every, c, suffix="").any():
        return " (bar +bar/-below: a face does not repeat)"
    return " (bar one-sided: +bar/-0)"


def _nothing_ok(df: pd.DataFrame) -> str:
    """The note of a section over the ok cases when there is none (:func:`~psdesign.report.
    trust.no_ok_case`), or ``""``."""
    none_ok = no_ok_case(df)
    if not none_ok:
        return ""
    return (
        f'<p class="note">Not plotted against the design parameters, {html.escape(none_ok)} '
        "(the red box at the top; each case's values and reason in the tables below).</p>"
    )


def _held_note(held: list[str], ok: pd.DataFrame) -> str:
    """A note naming the parameters that had one value in every plotted case (not plotted
    against), or ``""``."""
    if not held:
        return ""
    vals = ", ".join(f"{p} = {_value(p, ok[p].iloc[0])}" for p in held)
    return (
        f'<p class="note">Not plotted against (one value in every case with a trusted '
        f"output): {html.escape(vals)}.</p>"
    )


NO_TRUSTED_K = (
    '<p class="note">No trusted K: every K value is not ok (see the red box at the top); each '
    "is drawn as an open marker named by its status, no line.</p>"
)
COLORS = ("#636efa", "#ef553b", "#00cc96", "#ab63fa")


def _mean_trace(g: pd.DataFrame, p: str, c: str, mode: str, name: str, group: str, i, j):
    """One line of replicate means of output ``c`` against ``p``, bars of :func:`_err`; colour by
    output (``i``), dash by the other parameters' combination (``j``)."""
    import plotly.graph_objects as go

    e = _err(g, c)
    y = _nan_none(g[f"{c}_mean"])
    label = f"{name}, {group}" if group else name
    if all(v is None for v in y):  # a legend entry of an empty line said nothing (session 45)
        label += ": no trusted value"
    return go.Scatter(
        x=g[p],
        y=y,
        mode=mode,
        name=label,
        line={"color": COLORS[i % len(COLORS)], "dash": DASHES[j % len(DASHES)]},
        error_y=_error_y(c, e, _ci_part(g, c) + _below_part(g, c)),
    )


def _not_ok_traces(
    df: pd.DataFrame, p: str, c: str, name: str, color: str, masks: dict[str, pd.Series]
) -> list:
    """One marker-only trace per status that is not ``ok`` of output ``c`` against ``p``, the
    rows of ``masks`` (:func:`~psdesign.report.trust.not_ok_status` of ``df`` and ``c``; a 0
    is drawn unless the axis is ``log``): each case's value with its own numerical error bar
    (:func:`_numerical_half_width`), an open symbol per status
    (:func:`~psdesign.report.trust.status_style`) in the output's colour, named
    ``"<name>: <status> (not in the lines)"``."""
    import plotly.graph_objects as go

    out = []
    for status, m in masks.items():
        rows = df[m & pd.to_numeric(df[p], errors="coerce").notna()]
        if rows.empty:
            continue
        k = pd.to_numeric(rows[c], errors="coerce")
        e = _numerical_half_width(rows, c, suffix="")
        symbol = status_style(status)[0]
        out.append(
            go.Scatter(
                x=rows[p],
                y=_nan_none(k),
                mode="markers",
                name=f"{name}: {status} (not in the lines)",
                marker={"symbol": symbol, "size": 10, "color": color, "line": {"width": 2}},
                error_y=_error_y(c, e, _below_part(rows, c, suffix="")),  # a case's own bar
                text=list(rows["case_id"]) if "case_id" in rows else None,
            )
        )
    return out


def _levels(x: pd.Series) -> pd.Series:
    """Levels of a parameter: its values, or quartile bins when it has many."""
    if x.nunique() <= MAX_LEVELS:
        return x
    bins = pd.qcut(x, 4, labels=False, duplicates="drop")
    return x.groupby(bins).transform("median")  # each bin named by its median value


def _main_effects_figure(ok: pd.DataFrame, y: pd.DataFrame, kcols, num, logs):
    """Mean log10 K per level: a panel per parameter over its levels in its own unit (a
    ``loguniform`` one of ``logs`` on a log axis), log10 K shared. Until session 52 one axis
    held every parameter's level rank, 0..1 ("level (low -> high)"; review s52)."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    # plotly refuses a spacing above 1 / (cols - 1): 18 panels at 0.06 lost the section
    gap = min(0.06, 0.5 / max(len(num) - 1, 1))  # (review F, session 52)
    fig = make_subplots(rows=1, cols=len(num), shared_yaxes=True, horizontal_spacing=gap)
    for i, p in enumerate(num, start=1):
        lv = _levels(ok[p].astype(float))
        for c in kcols:
            m = y[c].groupby(lv.to_numpy()).mean()
            fig.add_trace(
                go.Scatter(
                    x=[float(v) for v in m.index],
                    y=m.to_list(),
                    mode="markers+lines",
                    name=f"{p}: {c}",
                    text=[_value(p, v) for v in m.index],
                ),
                1,
                i,
            )
        fig.update_xaxes(param_axis(p, p in logs), row=1, col=i)
    fig.update_yaxes(title_text="log10 K (m²)", row=1, col=1)
    fig.update_layout(
        title="Main effects: mean log10 K per level",
        height=380,
        margin={"l": 60, "r": 10, "t": 40, "b": 50},
    )
    return fig


def effect_plots(df: pd.DataFrame, params: list[str], study: dict | None = None) -> str:
    """Main effects (mean log10 K per level, each distinct realization counted once) and the
    two-factor interaction of the first two numeric parameters (lines of one parameter's
    levels over the other's; a ``loguniform`` one of ``study`` on a log axis)."""

    from psdesign.analysis.entangled import entangled, tied_to_axes
    from psdesign.analysis.surrogate import log_parameters

    ok = distinct_realizations(_ok(df), params)  # a design point listed twice is one case
    num = [p for p in numeric_parameters(ok, params) if ok[p].nunique() > 1]
    kcols = [c for c in K_DIRECTIONS if c in ok and (ok[c] > 0).any()]
    if not num or not kcols:
        return (
            _nothing_ok(df)
            or '<p class="note">Main effects need a varying numeric parameter and K.</p>'
        )
    y = np.log10(ok[kcols].where(ok[kcols] > 0))
    logs = log_parameters((study or {}).get("parameters") or {})
    parts = [figure_html(_main_effects_figure(ok, y, kcols, num, logs), "psd-main-effects")]
    # the groups over every varied parameter (a and b linked through c = 3 a = 3 b are one line
    # too); a third parameter that moved with one of the two moved with it in the cases shown
    tangled = entangled(ok[num].to_numpy(dtype=float), num, num[:2]) if len(num) >= 2 else ""
    if len(num) >= 2 and not tangled:
        fig = _interaction_figure(ok, y, kcols, num[0], num[1], num[0] in logs)
        parts.append(figure_html(fig, "psd-interaction"))
    note = (
        '<p class="note">Parallel lines in the interaction plot mean the two parameters act '
        "independently on log K; crossing or fanning lines mean they interact.</p>"
        if len(parts) > 1
        else ""
    )
    if tangled:  # one line of points, no lines of levels: no interaction to read
        note = f'<p class="note">Interaction not shown: {html.escape(tangled)}.</p>'
    elif len(parts) > 1:  # c = 3 a: the lines over a's levels are over c's as well
        ties = tied_to_axes(ok[num].to_numpy(dtype=float), num, num[:2])
        for p, (anchor, _, _) in ties.items():
            if anchor in num[:2]:
                note += (
                    f'<p class="note">Interaction: {html.escape(p)} moved with '
                    f"{html.escape(anchor)} in every case: the levels of {html.escape(anchor)} "
                    f"are those of {html.escape(p)} too.</p>"
                )
    return '<div class="psd-grid">' + "".join(f"<div>{x}</div>" for x in parts) + "</div>" + note


def _interaction_figure(ok: pd.DataFrame, y: pd.DataFrame, kcols: list[str], a, b, log_a: bool):
    """Lines of mean log10 K over ``a``'s levels, one per level of ``b``."""
    import plotly.graph_objects as go

    la, lb = _levels(ok[a].astype(float)), _levels(ok[b].astype(float))
    c = "k_z_m2" if "k_z_m2" in kcols else kcols[0]
    fig = go.Figure()
    tab = y[c].groupby([la.to_numpy(), lb.to_numpy()]).mean().unstack()
    for lvl in tab.columns:
        fig.add_trace(
            go.Scatter(
                x=list(tab.index),
                y=tab[lvl].to_list(),
                mode="markers+lines",
                name=f"{b} = {_value(b, lvl)}",
            )
        )
    fig.update_layout(
        title=f"Interaction {a} x {b}: mean log10 {c}",
        height=380,
        xaxis=param_axis(a, log_a),
        yaxis_title=f"log10 {c} (K in m²)",
        margin={"l": 60, "r": 10, "t": 40, "b": 50},
    )
    return fig


class ReportFit(NamedTuple):
    """The surrogate the report draws (:func:`report_fit`): the fit, the K column it models,
    the cases it was fitted to and its numeric inputs."""

    surrogate: object
    column: str
    ok: pd.DataFrame
    num: list[str]


def report_fit(df: pd.DataFrame, params: list[str], study: dict) -> ReportFit | None:
    """The Gaussian-process surrogate the report draws, fitted from the cases whose K is
    trusted, or ``None`` when it draws none (fewer than :data:`MIN_CASES_SURROGATE` such
    cases, no varying numeric parameter, or a varying non-numeric one:
    :func:`~psdesign.analysis.columns.varying_categories`). One fit for the section and the red
    box."""
    from psdesign.analysis.surrogate import fit_surrogate, parameter_bounds

    ok = _ok(df)
    c = _report_column(ok)
    if c is not None:
        ok = ok[ok[c] > 0]
    num = [p for p in numeric_parameters(ok, params) if ok[p].nunique() > 1]
    if len(ok) < MIN_CASES_SURROGATE or not num or c is None or varying_categories(ok, params):
        # a varying category: a fit over the numeric inputs mixes its levels (`study fit` rates
        # it untrustworthy); the report draws none and says why (review s53: a red box and
        # exit 3 on every study of a wall model or fibre kind, e.g. studies/voxel_walls.toml)
        return None
    bounds = parameter_bounds(ok, num, study.get("parameters") or {})
    s = fit_surrogate(ok, c, num, bounds, others=params)
    return ReportFit(s, c, ok, num)


def _report_column(ok: pd.DataFrame) -> str | None:
    """The K with the most trusted values (z first on a tie), or None: fit, range and markers
    are those cases only (a case whose K is not ok must not look like a data point)."""
    kcols = [c for c in ("k_z_m2", "k_x_m2", "k_y_m2") if c in ok and (ok[c] > 0).sum() > 0]
    return max(kcols, key=lambda k: (int((ok[k] > 0).sum()), k == "k_z_m2")) if kcols else None


def _no_surrogate_note(df: pd.DataFrame, params: list[str]) -> str:
    """Why the report draws no surrogate (:func:`report_fit` gave None)."""
    from psdesign.analysis.surrogate import MIN_FIT_CASES

    ok = _ok(df)
    c = _report_column(ok)
    cats = varying_categories(ok[ok[c] > 0] if c is not None else ok, params)
    if cats:
        names = html.escape(", ".join(cats))
        return (
            f'<p class="note">No surrogate drawn: the cases differ in {names}, which is not '
            "numeric, so a surrogate over the numeric parameters would mix its levels "
            "(<code>psdesign study fit</code> rates such a fit untrustworthy); compare the "
            "levels in the plots above, or run a study per level.</p>"
        )
    return (  # "a surrogate needs 6" read as a rule of study fit, which fits from 3
        f'<p class="note">The report fits its surrogate from at least {MIN_CASES_SURROGATE} '
        "finished cases with a trusted K and a varying numeric parameter; <code>psdesign "
        f"study fit</code> fits from {MIN_FIT_CASES} (its cross-validated error says how far "
        "to trust it).</p>"
    )


def fit_alert(fit: ReportFit | None) -> str:
    """The red box's line for a surrogate the report draws that is not trusted (its rating,
    the one `study fit` prints), or ``""`` (review s52: `study fit` exited 3 on a fit the
    report drew under a green page and an exit of 0)."""
    from psdesign.analysis.prediction import fit_status

    if fit is None:
        return ""
    status, why = fit_status(fit.surrogate)
    if status == "ok":
        return ""
    return f"the surrogate of {fit.column} the report draws is {status} ({'; '.join(why)})"


def surrogate_plots(
    df: pd.DataFrame, params: list[str], study: dict, fit: ReportFit | None = None
) -> str:
    """Sobol bars and the response surface of the two most important parameters (GP mean and
    its relative uncertainty), fitted here from the finished cases (or ``fit``, the same
    :func:`report_fit` made by the caller); no surface over two
    parameters that moved together (a note says why: :func:`~psdesign.analysis.sensitivity.
    entangled_inputs`, the rule that gives them no Sobol index); a third parameter that moved
    with one of the two follows it on the surface as in the cases (:func:`~psdesign.analysis.
    sensitivity.tied_inputs`), never held at mid-range apart from it."""
    from psdesign.analysis.entangled import tied_note
    from psdesign.analysis.prediction import fit_status
    from psdesign.analysis.sensitivity import (
        entangled_inputs,
        few_levels,
        no_indices_reason,
        sobol_indices,
        tied_inputs,
    )

    fit = fit or report_fit(df, params, study)
    if fit is None:
        return _no_surrogate_note(df, params)
    s, c, ok, num = fit
    # the status `study fit` prints (psdesign.analysis.prediction.fit_status), not a second rule
    status, why = fit_status(s)
    weak = ""
    if status != "ok":
        weak = (
            f" <b>[{status}] {html.escape('; '.join(why))}: the surface and the Sobol indices are "
            "not reliable; more cases (or fewer parameters) are needed.</b>"
        )
    parts = [
        f'<p class="note">Gaussian-process surrogate of {c} over {", ".join(num)} from '
        f"{len(s.y)} cases; cross-validated error {100 * s.cv_rel_error:.3g} %"
        f"{s.level_error_text()} [{status}].{weak}</p>"
    ]
    order = num
    why = no_indices_reason(s) if len(num) >= 2 else ""
    if why:  # the rule `study sensitivity` follows: no bars of noise or of entangled inputs
        parts[0] += f'<p class="note">Sobol indices not shown: {html.escape(why)}.</p>'
    elif len(num) >= 2:
        sob = sobol_indices(s, n=256)
        parts.append(figure_html(_sobol_figure(sob, c, s.log_output), "psd-sobol"))
        if few_levels(s):  # the words of `study sensitivity`: what to run
            parts[0] += f'<p class="note">Sobol indices: {html.escape(few_levels(s))}.</p>'
        order = list(sob.sort_values("ST", ascending=False)["parameter"])
    tangled = entangled_inputs(s, num, order[:2]) if len(order) >= 2 else ""
    if not tangled:  # a surface is drawn: what its band is
        parts[0] += f'<p class="note">{html.escape(surface_band_note(s))}.</p>'
    if len(order) == 1:
        fig = _surface_1d(s, ok, num, order[0], c)  # its y axis: "K (m²)"
        parts.append(figure_html(fig, "psd-surface", k_axis="yaxis", k_label="K"))
    elif tangled:  # the sensitivity rule: a surface over a pair the cases never separated
        parts.append(f'<p class="note">Response surface not shown: {html.escape(tangled)}.</p>')
    else:
        ties = tied_inputs(s, num, order[:2])
        parts.append(figure_html(_surface_2d(s, ok, num, order[:2], c, ties), "psd-surface"))
        if ties:  # c = 3 a held at mid-range while a moves: designs the cases never had
            parts[0] += f'<p class="note">Response surface: {html.escape(tied_note(ties))}</p>'
    return (
        parts[0]
        + '<div class="psd-grid">'
        + "".join(f"<div>{x}</div>" for x in parts[1:])
        + "</div>"
    )


def _sobol_figure(sob: pd.DataFrame, c: str, log_output: bool = True):
    """Grouped bars of the first-order and total Sobol indices with their 95 % intervals."""
    import plotly.graph_objects as go

    bars = [
        go.Bar(
            x=sob["parameter"],
            y=sob[col],
            name=name,
            error_y={"type": "data", "array": sob[f"{col}_conf"]},
        )
        for col, name in (("S1", "first order S1"), ("ST", "total ST"))
    ]
    fig = go.Figure(bars)
    fig.update_layout(
        # the surrogate models log10 K only when K spans more than a factor 3
        title=f"Sobol indices of {'log10 ' if log_output else ''}{c} (95 % CI)",
        barmode="group",
        height=360,
        yaxis_range=[0, 1.05],
        yaxis_title="Sobol index (-)",
        margin={"l": 60, "r": 10, "t": 40, "b": 50},
    )
    return fig


def _axis_grid(s, num: list[str], name: str) -> np.ndarray:
    """30 values over a parameter's range: evenly on its design scale (log-spaced for a
    ``loguniform`` one, as its cases were drawn and its surrogate input is scaled), by the
    surrogate's own mapping (:func:`~psdesign.analysis.surrogate.from_unit`)."""
    from psdesign.analysis.surrogate import from_unit

    i = num.index(name)
    return from_unit(np.linspace(0.0, 1.0, 30), s.low[i], s.high[i], s.log_params[i])


def _at_mid_range(s, n: int) -> np.ndarray:
    """``n`` surrogate inputs, every parameter at the middle of its range on its design
    scale (the geometric middle for a ``loguniform`` one).

    >>> from types import SimpleNamespace as S
    >>> _at_mid_range(S(low=[1.0, 1e-6], high=[3.0, 1e-4], log_params=[False, True]), 1)
    array([[2.e+00, 1.e-05]])
    """
    from psdesign.analysis.surrogate import from_unit

    mids = from_unit(np.full(len(s.low), 0.5), s.low, s.high, s.log_params)
    return np.tile(mids, (n, 1))


def _tie(s, num: list[str], x: np.ndarray, ties: dict) -> np.ndarray:
    """``x`` (surrogate inputs) with each parameter of ``ties`` (``{name: (anchor, slope,
    intercept)}`` in scaled inputs) set from its anchor's value, within its range.

    >>> from types import SimpleNamespace as S
    >>> s = S(low=[0.0, 0.0], high=[1.0, 3.0], log_params=[False, False])
    >>> _tie(s, ["a", "c"], np.array([[0.2, 1.5], [0.9, 1.5]]), {"c": ("a", 1.0, 0.0)})
    array([[0.2, 0.6],
           [0.9, 2.7]])
    """
    from psdesign.analysis.surrogate import from_unit, to_unit

    u = to_unit(x, s.low, s.high, s.log_params)
    for p, (anchor, slope, icpt) in ties.items():
        u[:, num.index(p)] = np.clip(icpt + slope * u[:, num.index(anchor)], 0.0, 1.0)
    return from_unit(u, s.low, s.high, s.log_params)


def surface_band_note(s) -> str:
    """The caption of the response surface's band: what its bar is (the bar ``study predict``
    prints, :func:`~psdesign.analysis.prediction.prediction_bar`) and the fit's hold-out figure
    it is never below (inside the box: :func:`~psdesign.analysis.prediction.bar_error`)."""
    from psdesign.analysis.prediction import bar_error

    rel, words = bar_error(s)
    held = f"the fit's {words}, {100 * rel:.3g} %" if rel == rel else "no hold-out error"
    return (
        "Response surface: its band (and relative uncertainty) is the bar study predict "
        f"prints, the GP std never below {held} (the GP std alone is overconfident between "
        "a grid's levels; before session 43 the band was +-2 GP std)"
    )


def _surface_1d(s, ok: pd.DataFrame, num: list[str], a: str, c: str):
    """GP mean of K along the one parameter, a +-2 bar band (:func:`~psdesign.analysis.
    prediction.prediction_bar`: the GP std, never below the fit's hold-out error), the cases."""
    import plotly.graph_objects as go

    from psdesign.analysis.prediction import prediction_bar

    ga = _axis_grid(s, num, a)
    x = _at_mid_range(s, len(ga))
    x[:, num.index(a)] = ga
    m, sd = s.predict(x)
    bar = prediction_bar(s, m, sd)
    fig = go.Figure(
        [
            go.Scatter(x=ga, y=m + 2 * bar, line={"width": 0}, showlegend=False),
            go.Scatter(
                x=ga,
                y=np.maximum(m - 2 * bar, m * 1e-3),
                fill="tonexty",
                line={"width": 0},
                name="+-2 bar (GP std, >= hold-out error)",
            ),
            go.Scatter(x=ga, y=m, name="GP mean"),
            go.Scatter(x=ok[a], y=ok[c], mode="markers", name="cases"),
        ]
    )
    fig.update_layout(
        title=f"Surrogate of {c} vs {a}",
        height=380,
        xaxis=param_axis(a, s.log_params[num.index(a)]),
        yaxis_title="K (m²)",
        yaxis_type="log",
    )
    return fig


#: Steps of the surface's relative uncertainty (a fraction): 0.01 %, below the colour bar's
#: 0.1 % ticks. A field whose spread is within one step is one number, not a map: contoured
#: raw, a constant 0.1998 bar drew stray lines from 1e-16 noise and one colour-bar tick
#: "0.1998213424444766073" (review s52, walk-report 4).
REL_UNCERTAINTY_STEP = 1e-4


def _uncertainty_panel(fig, ga, gb, rel: np.ndarray, bar: dict, floor: bool) -> bool:
    """Draw the right panel of :func:`_surface_2d`: contours of ``rel`` (bar / mean, rounded
    to :data:`REL_UNCERTAINTY_STEP`, ticks in %); a field within one step of constant is a
    note in the panel instead, naming the hold-out floor when ``floor`` (every bar is it).
    Returns whether it was constant."""
    import plotly.graph_objects as go

    z = np.round(rel, round(-np.log10(REL_UNCERTAINTY_STEP)))  # to the step, as decimals
    if np.ptp(z) <= REL_UNCERTAINTY_STEP:
        why = "<br>(the fit's estimated error between design points)" if floor else ""
        pct = 100 * float(np.median(rel))
        fig.add_annotation(
            text=f"bar = {pct:.1f} % of the mean everywhere in the box{why}",
            xref="paper",  # the right panel's middle (its axes hold the cases alone)
            yref="paper",
            x=sum(fig.layout.xaxis2.domain) / 2,
            xanchor="center",
            y=0.5,
            showarrow=False,
            bgcolor="white",
        )
        return True
    right_bar = {"x": 1.01, "title": {"text": "bar /<br>mean"}, "tickformat": ".1%"}
    fig.add_trace(
        go.Contour(x=ga, y=gb, z=z, colorscale="Greys", colorbar={**right_bar, **bar}), 1, 2
    )
    return False


def _surface_2d(
    s, ok: pd.DataFrame, num: list[str], pair: list[str], c: str, ties: dict | None = None
):
    """Contours of log10 K (GP mean) and of bar / mean over two parameters (the bar of
    :func:`~psdesign.analysis.prediction.prediction_bar`: the GP std, never below the fit's
    hold-out error), the others at mid-range, with the cases marked; a parameter of ``ties``
    (:func:`~psdesign.analysis.sensitivity.tied_inputs`) follows its anchor as in the cases."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    from psdesign.analysis.prediction import holdout_bar, prediction_bar

    a, b = pair
    log_a, log_b = s.log_params[num.index(a)], s.log_params[num.index(b)]
    ga, gb = _axis_grid(s, num, a), _axis_grid(s, num, b)
    A, B = np.meshgrid(ga, gb)
    x = _at_mid_range(s, A.size)
    x[:, num.index(a)], x[:, num.index(b)] = A.ravel(), B.ravel()
    m, sd = s.predict(_tie(s, num, x, ties or {}))
    err = prediction_bar(s, m, sd)
    fig = make_subplots(
        rows=1,
        cols=2,
        subplot_titles=(f"log10 {c} (GP mean)", "relative uncertainty (bar / mean)"),
        horizontal_spacing=SURFACE_GAP,
    )
    # each colour bar right of its own panel: the first one in the gap between the panels
    bar = {"len": 0.9, "thickness": 10, "xanchor": "left", "xpad": 4}
    left_bar = {"x": (1 - SURFACE_GAP) / 2 + 0.01, "title": {"text": "log10 K<br>(m²)"}}
    fig.add_trace(
        go.Contour(x=ga, y=gb, z=np.log10(m).reshape(A.shape), colorbar={**left_bar, **bar}),
        1,
        1,
    )
    floor = bool(np.all(err <= holdout_bar(s, m)))  # the GP std nowhere above the floor
    _uncertainty_panel(fig, ga, gb, (err / m).reshape(A.shape), bar, floor)
    for col in (1, 2):
        fig.add_trace(
            go.Scatter(
                x=ok[a],
                y=ok[b],
                mode="markers",
                showlegend=False,
                marker={"color": "red", "size": 6},
            ),
            1,
            col,
        )
    fig.update_layout(
        title={"text": "Response surface (others at mid-range)", "y": 0.97, "x": 0.02},
        title_font_size=14,
        height=440,
        margin={"l": 70, "r": 60, "t": 90, "b": 60},
        xaxis=param_axis(a, log_a),
        yaxis=param_axis(b, log_b),
        xaxis2=param_axis(a, log_a),
        yaxis2={k: v for k, v in param_axis(b, log_b).items() if k != "title"},
    )
    return fig
