"""Report sections that turn a study table into a design decision: outputs against each design
parameter with replicate 95 % CIs, anisotropy, main effects and two-factor interactions, the
surrogate's response surface with its uncertainty, and Sobol indices (interactive, Plotly).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from psdesign.analysis.columns import numeric_parameters
from psdesign.analysis.replicates import replicate_summary
from psdesign.report.interactive import figure_html

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


def _ok(df: pd.DataFrame) -> pd.DataFrame:
    return df[df["status"] == "ok"].copy() if "status" in df else df.copy()


def add_anisotropy(df: pd.DataFrame) -> pd.DataFrame:
    """Add ``anisotropy`` = mean in-plane K / through-plane K (K_x, K_y over K_z) per case."""
    inplane = [c for c in ("k_x_m2", "k_y_m2") if c in df]
    if "k_z_m2" not in df or not inplane:
        return df
    out = df.copy()
    out["anisotropy"] = out[inplane].mean(axis=1) / out["k_z_m2"]
    return out


def _err(summary: pd.DataFrame, c: str) -> np.ndarray | None:
    if f"{c}_ci95_high" not in summary:
        return None
    half = (summary[f"{c}_ci95_high"] - summary[f"{c}_ci95_low"]) / 2
    return half.to_numpy(dtype=float)


def _nan_none(a) -> list:
    return [None if (v is None or not math.isfinite(float(v))) else float(v) for v in a]


def parameter_plots(df: pd.DataFrame, params: list[str]) -> str:
    """Every output against each numeric design parameter, replicate means with 95 % CI bars."""
    import plotly.graph_objects as go

    ok = add_anisotropy(_ok(df))
    num = numeric_parameters(ok, params)
    if not num:
        return '<p class="note">No numeric design parameter to plot against.</p>'
    summary = replicate_summary(ok, params)
    kcols = [c for c in K_DIRECTIONS if f"{c}_mean" in summary]
    others = [
        c[:-5]
        for c in summary.columns
        if c.endswith("_mean") and c[:-5].startswith(OTHER_OUTPUT_PREFIXES)
    ]
    parts = []
    for p in num:
        order = np.argsort(summary[p].to_numpy(dtype=float), kind="stable")
        s = summary.iloc[order]
        # lines join the levels of a one-parameter or factorial design; scattered designs
        # (other parameters vary between neighbours) show markers only
        mode = "markers+lines" if len(num) == 1 or s[p].nunique() <= MAX_LEVELS else "markers"
        if kcols:
            fig = go.Figure()
            for c in kcols:
                e = _err(s, c)
                fig.add_trace(
                    go.Scatter(
                        x=s[p],
                        y=_nan_none(s[f"{c}_mean"]),
                        mode=mode,
                        name=K_DIRECTIONS[c],
                        error_y=None if e is None else {"type": "data", "array": _nan_none(e)},
                    )
                )
            fig.update_layout(
                title=f"K vs {p} (mean of replicates, 95 % CI)",
                height=360,
                xaxis_title=p,
                yaxis_title="K (m²)",
                yaxis_type="log",
                yaxis_exponentformat="e",
                margin={"l": 60, "r": 10, "t": 40, "b": 50},
            )
            parts.append(figure_html(fig, f"psd-k-{p}", k_axis="yaxis", k_label="K"))
        for c in others:
            e = _err(s, c)
            fig = go.Figure(
                go.Scatter(
                    x=s[p],
                    y=_nan_none(s[f"{c}_mean"]),
                    mode=mode,
                    name=c,
                    error_y=None if e is None else {"type": "data", "array": _nan_none(e)},
                )
            )
            fig.update_layout(
                title=f"{c} vs {p}",
                height=320,
                xaxis_title=p,
                yaxis_title=c,
                margin={"l": 60, "r": 10, "t": 40, "b": 50},
            )
            parts.append(figure_html(fig, f"psd-{c}-{p}"))
    return '<div class="psd-grid">' + "".join(f"<div>{x}</div>" for x in parts) + "</div>"


def _levels(x: pd.Series) -> pd.Series:
    """Levels of a parameter: its values, or quartile bins when it has many."""
    if x.nunique() <= MAX_LEVELS:
        return x
    bins = pd.qcut(x, 4, labels=False, duplicates="drop")
    return x.groupby(bins).transform("median")  # each bin named by its median value


def effect_plots(df: pd.DataFrame, params: list[str]) -> str:
    """Main effects (mean log10 K per level) and the two-factor interaction of the first two
    numeric parameters (lines of one parameter's levels over the other's)."""
    import plotly.graph_objects as go

    ok = _ok(df)
    num = [p for p in numeric_parameters(ok, params) if ok[p].nunique() > 1]
    kcols = [c for c in K_DIRECTIONS if c in ok and (ok[c] > 0).any()]
    if not num or not kcols:
        return '<p class="note">Main effects need a varying numeric parameter and K.</p>'
    y = np.log10(ok[kcols].where(ok[kcols] > 0))
    parts = []
    fig = go.Figure()
    for p in num:
        lv = _levels(ok[p].astype(float))
        for c in kcols:
            m = y[c].groupby(lv.to_numpy()).mean()
            # x as the level's rank scaled to [0, 1], so parameters share one axis
            xr = np.linspace(0, 1, len(m)) if len(m) > 1 else [0.5]
            fig.add_trace(
                go.Scatter(
                    x=list(xr),
                    y=m.to_list(),
                    mode="markers+lines",
                    name=f"{p}: {c}",
                    text=[f"{v:.4g}" for v in m.index],
                )
            )
    fig.update_layout(
        title="Main effects: mean log10 K per level (levels low to high)",
        height=380,
        xaxis_title="level (low -> high)",
        yaxis_title="log10 K (m²)",
        margin={"l": 60, "r": 10, "t": 40, "b": 50},
    )
    parts.append(figure_html(fig, "psd-main-effects"))
    if len(num) >= 2:
        a, b = num[0], num[1]
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
                    name=f"{b} = {lvl:.4g}",
                )
            )
        fig.update_layout(
            title=f"Interaction {a} x {b}: mean log10 {c}",
            height=380,
            xaxis_title=a,
            yaxis_title=f"log10 {c}",
            margin={"l": 60, "r": 10, "t": 40, "b": 50},
        )
        parts.append(figure_html(fig, "psd-interaction"))
    note = (
        '<p class="note">Parallel lines in the interaction plot mean the two parameters act '
        "independently on log K; crossing or fanning lines mean they interact.</p>"
    )
    return '<div class="psd-grid">' + "".join(f"<div>{x}</div>" for x in parts) + "</div>" + note


def surrogate_plots(df: pd.DataFrame, params: list[str], study: dict) -> str:
    """Sobol bars and the response surface of the two most important parameters (GP mean and
    its relative uncertainty), fitted here from the finished cases."""
    from psdesign.analysis.sensitivity import sobol_indices
    from psdesign.analysis.surrogate import fit_surrogate, parameter_bounds

    ok = _ok(df)
    num = [p for p in numeric_parameters(ok, params) if ok[p].nunique() > 1]
    kcols = [c for c in ("k_z_m2", "k_x_m2", "k_y_m2") if c in ok and (ok[c] > 0).sum() > 0]
    if len(ok) < MIN_CASES_SURROGATE or not num or not kcols:
        return (
            f'<p class="note">A surrogate needs at least {MIN_CASES_SURROGATE} finished '
            "cases, a varying numeric parameter and K.</p>"
        )
    c = kcols[0]
    s = fit_surrogate(ok, c, num, parameter_bounds(ok, num, study.get("parameters") or {}))
    parts = [
        f'<p class="note">Gaussian-process surrogate of {c} over {", ".join(num)} from '
        f"{len(s.y)} cases; cross-validated error {100 * s.cv_rel_error:.2g} %.</p>"
    ]
    order = num
    if len(num) >= 2:
        sob = sobol_indices(s, n=256)
        parts.append(figure_html(_sobol_figure(sob, c), "psd-sobol"))
        order = list(sob.sort_values("ST", ascending=False)["parameter"])
    if len(order) == 1:
        fig = _surface_1d(s, ok, num, order[0], c)
        parts.append(figure_html(fig, "psd-surface", k_axis="yaxis", k_label=c))
    else:
        parts.append(figure_html(_surface_2d(s, ok, num, order[:2], c), "psd-surface"))
    return (
        parts[0]
        + '<div class="psd-grid">'
        + "".join(f"<div>{x}</div>" for x in parts[1:])
        + "</div>"
    )


def _sobol_figure(sob: pd.DataFrame, c: str):
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
        title=f"Sobol indices of log10 {c} (95 % CI)",
        barmode="group",
        height=360,
        yaxis_range=[0, 1.05],
        margin={"l": 60, "r": 10, "t": 40, "b": 50},
    )
    return fig


def _axis_grid(s, num: list[str], name: str) -> np.ndarray:
    return np.linspace(s.low[num.index(name)], s.high[num.index(name)], 30)


def _at_mid_range(s, n: int) -> np.ndarray:
    """``n`` surrogate inputs, every parameter at the middle of its range."""
    return np.tile([(lo + hi) / 2 for lo, hi in zip(s.low, s.high, strict=True)], (n, 1))


def _surface_1d(s, ok: pd.DataFrame, num: list[str], a: str, c: str):
    """GP mean of K along the one parameter, +-2 std band, and the cases."""
    import plotly.graph_objects as go

    ga = _axis_grid(s, num, a)
    x = _at_mid_range(s, len(ga))
    x[:, num.index(a)] = ga
    m, sd = s.predict(x)
    fig = go.Figure(
        [
            go.Scatter(x=ga, y=m + 2 * sd, line={"width": 0}, showlegend=False),
            go.Scatter(
                x=ga,
                y=np.maximum(m - 2 * sd, m * 1e-3),
                fill="tonexty",
                line={"width": 0},
                name="+-2 std",
            ),
            go.Scatter(x=ga, y=m, name="GP mean"),
            go.Scatter(x=ok[a], y=ok[c], mode="markers", name="cases"),
        ]
    )
    fig.update_layout(
        title=f"Surrogate of {c} vs {a}",
        height=380,
        xaxis_title=a,
        yaxis_title="K (m²)",
        yaxis_type="log",
        yaxis_exponentformat="e",
    )
    return fig


def _surface_2d(s, ok: pd.DataFrame, num: list[str], pair: list[str], c: str):
    """Contours of log10 K (GP mean) and of std / mean over two parameters, the others at
    mid-range, with the cases marked."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    a, b = pair
    ga, gb = _axis_grid(s, num, a), _axis_grid(s, num, b)
    A, B = np.meshgrid(ga, gb)
    x = _at_mid_range(s, A.size)
    x[:, num.index(a)], x[:, num.index(b)] = A.ravel(), B.ravel()
    m, sd = s.predict(x)
    fig = make_subplots(
        rows=1,
        cols=2,
        subplot_titles=(f"log10 {c} (GP mean)", "relative uncertainty (std / mean)"),
    )
    bar = {"len": 0.9, "thickness": 12}
    fig.add_trace(
        go.Contour(x=ga, y=gb, z=np.log10(m).reshape(A.shape), colorbar={"x": 0.43, **bar}),
        1,
        1,
    )
    fig.add_trace(
        go.Contour(x=ga, y=gb, z=(sd / m).reshape(A.shape), colorscale="Greys", colorbar=bar),
        1,
        2,
    )
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
        title="Response surface (others at mid-range)",
        height=420,
        xaxis_title=a,
        yaxis_title=b,
        xaxis2_title=a,
    )
    return fig
