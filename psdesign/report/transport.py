"""Report plots of the transport outputs (issue 13): pore sizes / intrusion and diffusivity vs
porosity with the Tomadakis-Sotirchos curves.

:func:`transport_figure` takes the study table and returns a base64 PNG (or None when the study
has no transport columns) for ``report/html.py`` to embed; :func:`pore_figure` writes the
``psdesign pores --plot`` picture.
"""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np

from psdesign.report.png import figure_png
from psdesign.report.trust import AT_UNTRUSTED_X, NOT_OK_MARKERS, draw_not_ok, point_status

#: Tomadakis & Sotirchos (1993), 2-D random fibre structures: eps_p, alpha in / through plane.
TS_2D = (0.11, 0.521, 0.785)


def log_tick_text(x: float) -> str:
    """A log axis' tick label: one digit (``2e-05``), two where matplotlib falls back to linear
    ticks inside a decade (``3.2e-05``, not ``3e-05`` beside ``3e-05``): at most 7 characters.

    >>> log_tick_text(2e-05), log_tick_text(3.2e-05), log_tick_text(3.25e-05)
    ('2e-05', '3.2e-05', '3.2e-05')
    """
    one = f"{x:.0e}"
    return one if abs(float(one) - x) <= 1e-9 * abs(x) else f"{x:.1e}"


def log_ticks(axis, values) -> None:
    """Label a log axis over ``values`` at 1, 2 and 5 per decade (``2e-05``) when they span up
    to two decades, else at the decades, and leave the other ticks bare: over less than a
    decade matplotlib labels every minor tick (``4x10^-6`` and ``3x10^-6`` overlapped on the
    intrusion curve of a 20 um box)."""
    from matplotlib import ticker

    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v) & (v > 0)]
    span = float(np.log10(v.max() / v.min())) if v.size else 0.0
    subs = (1.0, 2.0, 5.0) if span <= 2.0 else (1.0,)
    axis.set_major_locator(ticker.LogLocator(base=10.0, subs=subs))
    axis.set_major_formatter(ticker.FuncFormatter(lambda x, _: log_tick_text(x)))
    axis.set_minor_locator(ticker.LogLocator(base=10.0, subs=np.arange(1.0, 10.0)))
    axis.set_minor_formatter(ticker.NullFormatter())
    if v.size and span <= 2.0:
        _widen_to_two_ticks(axis, float(v.min()), float(v.max()))


def _widen_to_two_ticks(axis, lo: float, hi: float) -> None:
    """Widen ``axis``' view to the 1-2-5 values on either side of ``[lo, hi]`` when fewer than
    two lie within it: with one or no major tick in view matplotlib's LogLocator falls back
    to linear ticks, labelled ``9.4e-12`` seven times over K_z = 9.40e-12 and 9.45e-12 (or a
    one-case study; session 48 review). The view is centred on the data in log space (the
    geometric mean of ``lo`` and ``hi``), as far on either side as the farther of the two
    values: 9.4e-12 sat at 91 % of the height of [5e-12, 1e-11], by its top edge (session
    49). Only widens, and keeps an inverted axis inverted (``set_view_interval``);
    autoscaling is then off so a later artist does not undo it."""
    exps = np.arange(np.floor(np.log10(lo)) - 1, np.ceil(np.log10(hi)) + 2)
    steps = np.sort(np.outer(10.0**exps, (1.0, 2.0, 5.0)).ravel())
    # a relative slack: 5e-12 computed as 5 * 10**-12 may differ from a value in the last bit
    inside = steps[(steps >= lo * (1 - 1e-9)) & (steps <= hi * (1 + 1e-9))]
    if inside.size >= 2:
        return
    below, above = steps[steps < lo * (1 - 1e-9)][-1], steps[steps > hi * (1 + 1e-9)][0]
    centre = np.sqrt(lo * hi)
    half = max(centre / below, above / centre)  # a ratio: the half-width in log space
    # a hair beyond the 1-2-5 values, so the locator counts both as in view
    axis.set_view_interval(centre / half * (1 - 1e-6), centre * half * (1 + 1e-6))
    axis.axes.autoscale(enable=False, axis=axis.axis_name)


def pore_figure(pores: dict, path: str | Path) -> Path:
    """Pore size distribution (volume fraction per diameter) and intrusion curve, PNG.

    The d10 / d50 / d90 lines are named in a legend with their values, each with its error bar
    (``diameter_error_m`` above, ``diameter_error_below_m`` below: 0 when every face repeats,
    :func:`psdesign.transport.pores.walled`) shaded, the intrusion curve with walls past the
    faces that do not repeat dashed beside the open one (its lower bound), and the
    title gives the rating (``pore_sizes_status``, red when not ``ok``) as the printed line
    does: until session 42 the picture had three unnamed dashed lines, no bar and no status
    (an ``untrustworthy`` scan looked like an ``ok`` one).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from psdesign.transport.pores import diameter_bar_text

    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.4))
    d = np.asarray(pores["diameters_m"])  # metres, as every output
    a.bar(d, pores["volume_fraction"], width=0.8 * (d[1] - d[0]) if d.size > 1 else 1e-6)
    err = float(pores.get("diameter_error_m") or 0.0)
    below = float(pores.get("diameter_error_below_m") or 0.0)
    for q, ls in (("pore_d10_m", ":"), ("pore_d50_m", "--"), ("pore_d90_m", "-.")):
        a.axvline(pores[q], color="k", lw=0.8, ls=ls, label=f"{q[5:8]} {pores[q]:.3g} m")
        if err + below > 0:
            a.axvspan(pores[q] - below, pores[q] + err, color="k", alpha=0.12, lw=0)
    a.legend(fontsize=7, loc="upper left")
    status = str(pores.get("pore_sizes_status", pores.get("status", "")))
    if status:
        bar = f", each {diameter_bar_text(err, below)} m (shaded)" if err + below > 0 else ""
        fig.suptitle(
            f"pore sizes [{status}]{bar}",
            fontsize=9,
            color="k" if status == "ok" else "tab:red",
        )
    a.set_xlabel("local thickness diameter (m)")
    a.set_ylabel("pore volume fraction (-)")
    dia = np.asarray(pores["intrusion_diameter_m"], dtype=float)
    b.plot(dia, pores["intrusion_saturation"], "o-", label="open faces (the value)")
    if pores.get("intrusion_saturation_walled") is not None:
        b.plot(dia, pores["intrusion_saturation_walled"], "o--", ms=3, label="walled (lower bound)")
        b.legend(fontsize=7, loc="lower right")
    b.set_xscale("log")
    log_ticks(b.xaxis, dia)
    b.invert_xaxis()
    b.set_xlabel("accessible diameter (m)")
    b.set_ylabel("non-wetting saturation (-)")
    out = Path(path)
    out.write_bytes(figure_png(fig))
    return out


def transport_figure(df) -> tuple[str | None, str]:
    """Relative diffusivity vs porosity of a study table with the Tomadakis-Sotirchos curves;
    ``(base64 png or None, caption)``. Each value carries its error bar
    (``diffusivity_<d>_rel_error``); a point whose value or porosity is not ``ok`` (by its
    case or own status, :func:`~psdesign.report.trust.point_status`) is drawn with an open
    marker per status (:func:`~psdesign.report.trust.draw_not_ok`) and counted in the
    caption, as the report's K figure does."""
    import pandas as pd

    from psdesign.analysis.columns import REL_ERROR_COLUMNS

    cols = [c for c in ("diffusivity_x", "diffusivity_y", "diffusivity_z") if c in df.columns]
    if not cols or "porosity" not in df.columns:
        return None, ""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.6))
    eps = pd.to_numeric(df["porosity"], errors="coerce").to_numpy(dtype=float)
    n_bad = n_x = 0
    for i, c in enumerate(cols):
        y = pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float)
        rel = df.get(REL_ERROR_COLUMNS[c])
        err = None if rel is None else np.abs(pd.to_numeric(rel, errors="coerce").to_numpy() * y)
        has = np.isfinite(y) & np.isfinite(eps)
        good = has & (point_status(df, c, "porosity") == "ok").to_numpy()
        if good.any():
            ax.errorbar(eps[good], y[good], yerr=None if err is None else err[good],
                        fmt="os^"[i], capsize=2, color=f"C{i}", label=c)  # fmt: skip
        # linear axis: a blocked 0 too
        bad, at_bad_x = draw_not_ok(ax, df, c, (eps, y, err), "os^"[i], c, "porosity")
        n_bad, n_x = n_bad + bad, n_x + at_bad_x
    curve = np.linspace(0.12, 0.99, 100)
    ep, a_in, a_tp = TS_2D
    # black as the K figure's reference curves: the data keep the colours
    for alpha, name, ls in ((a_tp, "through-plane", "k-"), (a_in, "in-plane", "k--")):
        ax.plot(
            curve,
            curve * ((curve - ep) / (1 - ep)) ** alpha,
            ls,
            lw=1,
            label=f"Tomadakis-Sotirchos 1993 [1], {name}",
        )
    ax.set_xlabel("porosity (-)")
    ax.set_ylabel("D_eff / D_bulk (-)")
    ax.legend(fontsize=7)
    png = base64.b64encode(figure_png(fig)).decode()
    caption = (
        "Relative diffusivity against porosity, bars: each value's error bar; lines: Tomadakis & "
        "Sotirchos (1993) for random overlapping 2-D fibre structures (eps_p = 0.11, alpha = "
        "0.521 in-plane, 0.785 through-plane)."
    )
    if n_bad:
        caption += (
            f" {n_bad} value(s) that are not ok ({NOT_OK_MARKERS}) are left out of the fits and "
            "sensitivity."
        )
    if n_x:
        caption += " " + AT_UNTRUSTED_X.format(n=n_x, values="D_eff/D", x="porosity")
    return png, caption
