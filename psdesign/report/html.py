"""Build the self-contained HTML report of a study output folder (``OUT/report.html``).

Everything is inline: CSS in a ``<style>`` block, figures and previews as base64 ``data:``
URIs.  The file loads no external resource and opens offline.
"""

from __future__ import annotations

import base64
import html
import io
import math
import mimetypes
import platform
import re
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from psdesign.analysis.columns import (
    ABS_ERROR_COLUMNS,
    LOWER_BAR_COLUMN,
    RATED_BY,
    STATUS_COLUMNS,
    UPPER_BARS,
    case_status,
    column_numbers,
    error_bar,
    flagged_values,
    is_design_parameter,
    k_not_ok,
    own_status,
    rel_error_below,
    trusted,
    value_status,
)
from psdesign.errors import SpecError
from psdesign.report.decision import (
    effect_plots,
    fit_alert,
    parameter_plots,
    report_fit,
    surrogate_plots,
)
from psdesign.report.glance import STAYS_M2_NOTE, glance_section, k_text
from psdesign.report.interactive import CSS as INTERACTIVE_CSS
from psdesign.report.interactive import gallery_html, head_scripts, unit_selector
from psdesign.report.outcome import missed_target_alert, optimize_section
from psdesign.report.png import figure_png
from psdesign.report.references import (
    KOZENY_CONSTANT,
    TS_ALPHA_IN_PLANE,
    TS_ALPHA_THROUGH_PLANE,
    TS_EPS_P,
    kozeny_carman,
    tomadakis_sotirchos,
)
from psdesign.report.sensitivity import main_effects, sensitivity_table
from psdesign.report.transport import log_ticks, transport_figure
from psdesign.report.trust import (
    AT_UNTRUSTED_X,
    NOT_OK_MARKERS,
    draw_not_ok,
    failed_count,
    point_status,
    status_style,
)
from psdesign.report.units import output_label
from psdesign.transport.effective import BLOCKED

__all__ = ["ReportAlert", "ReportError", "build_html", "write_report", "write_report_alerts"]

FLUX_IMBALANCE_FLAG = 1e-2
SENS_BLANK_NOTE = (
    '<p class="note">A blank Spearman or SRC cell is not defined: fewer than 3 cases (SRC: more '
    "cases than parameters + 1), the parameter or the response is constant over them, or (SRC) "
    "two parameters moved together over them (correlation above 0.99: their effects cannot be "
    "told apart).</p>"
)
MAX_TABLE_ROWS = 2000
DIRECTIONS = {"k_x_m2": "x (in-plane)", "k_y_m2": "y (in-plane)", "k_z_m2": "z (through-plane)"}

CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:2em;
color:#222;max-width:1400px}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;font-size:.82em;margin:.5em 0}
th,td{border:1px solid #ddd;padding:.2em .5em;text-align:right;white-space:nowrap}
th{background:#f3f3f3;position:sticky;top:0}
tr.flag td{background:#ffe3e3}tr.warn td{background:#fff4d6}
.scroll{max-height:32em;overflow:auto;border:1px solid #eee}
.ktable th,.ktable td{white-space:normal;text-align:left;max-width:26em}
.ktable .kbc{color:#555;font-size:.9em}.ktable .kst{color:#a00}
.meta td,.meta th{text-align:left}.meta td{white-space:normal;overflow-wrap:break-word}
figure{display:inline-block;margin:.5em;vertical-align:top}
figcaption{font-size:.8em;color:#555;max-width:320px}
.note{color:#555;font-size:.9em}
.alert{background:#ffe3e3;border-left:4px solid #c00;padding:.4em .8em;max-width:1100px}
"""


class ReportError(SpecError):
    """The folder holds no study results to report on: bad input (``study report`` exits 2),
    so a :class:`~psdesign.errors.SpecError` naming ``out_dir`` (a plain ``ValueError`` until
    session 54; README: ``except psdesign.SpecError`` catches any bad input).

    Parameters
    ----------
    message : str
        The reader's one line (``"out_dir: no results.csv in ..."``): the key before its first
        ``": "`` (``out_dir`` when there is none), as :class:`~psdesign.errors.StudyError`.
    """

    def __init__(self, message: str) -> None:
        key, sep, rest = message.partition(": ")
        if not sep or " " in key:
            key, rest = "out_dir", message
        super().__init__(key, rest)


def _esc(x) -> str:
    return html.escape("" if x is None else str(x))


def _png(fig) -> str:
    """``fig`` as a PNG ``data:`` URI (:func:`~psdesign.report.png.figure_png`: drawn once)."""
    return "data:image/png;base64," + base64.b64encode(figure_png(fig)).decode()


def _img_file(path: Path) -> str | None:
    try:
        data = path.read_bytes()
    except OSError:
        return None
    mime = mimetypes.guess_type(path.name)[0] or "image/png"
    return f"data:{mime};base64," + base64.b64encode(data).decode()


#: JPEG quality of the previews in the report: a shaded render at full size (480 x 400 px,
#: shown 300 px wide) keeps its look at 4.3 KB per 10 kpx, against 7.6 KB as PNG (12 previews:
#: 0.65 MB -> 0.31 MB; session 43). The files in cases/ stay PNG.
PREVIEW_JPEG_QUALITY = 90


def _preview_uri(path: Path) -> str | None:
    """A case's preview picture as a JPEG ``data:`` URI at its own size (``None``: no file);
    a file Pillow cannot read goes in as it is (:func:`_img_file`)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            rgb = Image.new("RGB", im.size, "white")  # a transparent pixel shows white
            src = im.convert("RGBA")
            rgb.paste(src, mask=src.getchannel("A"))
    except (UnidentifiedImageError, ValueError):
        return _img_file(path)
    except OSError:
        return None
    buf = io.BytesIO()
    rgb.save(buf, "JPEG", quality=PREVIEW_JPEG_QUALITY, optimize=True)
    return "data:image/jpeg;base64," + base64.b64encode(buf.getvalue()).decode()


def _fmt(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if isinstance(v, float | np.floating):
        return f"{v:.4g}"
    return str(v)


#: The columns the unit selector converts: a permeability in m² (``k_z_m2``, a tensor's
#: ``k_xz_m2``). Any other name ending in ``_m2`` stays: the main effects' "mean log10
#: k_z_m2" (-11.33) became -1.148e+13 in darcy (review s52, walk-report 1).
K_VALUE_COLUMN = re.compile(r"k_[xyz]{1,2}_m2")
#: Any K column name, converted or not (a mean of log10 K too): the "stays in m²" note's test.
_K_NAME = re.compile(rf"\b{K_VALUE_COLUMN.pattern}\b|^K_[xyz]{{1,2}}\b.*m²")


def _converts(col: str) -> bool:
    """Whether the unit selector converts column ``col`` (:data:`K_VALUE_COLUMN`).

    >>> _converts("k_z_m2"), _converts("k_xy_m2"), _converts("mean log10 k_z_m2")
    (True, True, False)
    """
    return K_VALUE_COLUMN.fullmatch(str(col)) is not None


def _head(col: str) -> str:
    """A table header; a converted K column names the unit the selector picked (the
    ``psd-kunit`` span report.js rewrites): ``k_z (m²)``."""
    if _converts(col):
        return f'<th title="{_esc(col)}">{_esc(col[:-3])} (<span class="psd-kunit">m²</span>)</th>'
    return f"<th>{_esc(col)}</th>"


def _cell(col: str, v) -> str:
    """A table cell; a K column (:func:`_converts`) carries the value in m² for the selector."""
    if _converts(col) and isinstance(v, float | int | np.floating) and math.isfinite(v):
        return f'<td data-m2="{float(v)!r}">{_esc(_fmt(v))}</td>'
    return f"<td>{_esc(_fmt(v))}</td>"


def _table(
    df: pd.DataFrame,
    row_class: list[str] | None = None,
    max_rows: int = MAX_TABLE_ROWS,
    raw: tuple[str, ...] = (),
    table_class: str = "sortable",
):
    """A scrolling, sortable table of ``df``; the columns of ``raw`` hold HTML already
    escaped (:func:`_k_cell`), the others values (:func:`_cell`). A table with a K (or log10
    K) column the unit selector does not convert says it stays in m² (:data:`STAYS_M2_NOTE`)."""
    cols = list(df.columns)
    head = "".join(_head(c) for c in cols)
    body = []
    for i, (_, row) in enumerate(df.head(max_rows).iterrows()):
        cls = f' class="{row_class[i]}"' if row_class and row_class[i] else ""
        cells = (f"<td>{row[c]}</td>" if c in raw else _cell(c, row[c]) for c in cols)
        body.append(f"<tr{cls}>" + "".join(cells) + "</tr>")
    more = ""
    if len(df) > max_rows:
        more = f'<p class="note">{len(df) - max_rows} more rows in results.csv</p>'
    # a K column (k_z_m2, "mean log10 k_z_m2") that does not convert; not any "_m2" name (a
    # varied transport.bulk_diffusivity_m2_s is no K: review F, session 52)
    if any(_K_NAME.search(str(c)) and not _converts(c) for c in cols):
        more += STAYS_M2_NOTE
    return (
        f'<div class="scroll"><table class="{table_class}"><thead><tr>{head}</tr></thead><tbody>'
        + "".join(body)
        + "</tbody></table></div>"
        + more
    )


def _load(out: Path) -> tuple[pd.DataFrame, dict, dict]:
    from psdesign.report.image_source import HEADER_KEY
    from psdesign.study.readback import read_json_object, read_results

    try:  # the reader's check of results.csv (missing, empty, not CSV) is the one check
        df = read_results(out)
    except ValueError as exc:
        raise ReportError(str(exc)) from None
    study = {}
    if (out / "study.json").is_file():
        doc = read_json_object(out / "study.json")
        study = doc.get("study", {})
        if HEADER_KEY in doc:  # the image's header as the run read it (image_source)
            study = {**study, HEADER_KEY: doc[HEADER_KEY]}
    runs = {}
    if (out / "run.json").is_file():
        runs = read_json_object(out / "run.json")
    return df, study, runs


def _fiber_radius(df: pd.DataFrame, study: dict) -> tuple[pd.Series | None, float | None]:
    """Per-row fiber radius if the diameter is a study parameter (``generator.diameter``, or
    ``fibers.<i>.diameter`` of an explicit fiber: the median of the row's fiber diameters),
    else the base value.

    >>> df = pd.DataFrame({"fibers.0.diameter": [6e-6, 1e-5]})
    >>> base = {"base": {"fibers": [{"diameter": 8e-6}]}}
    >>> r, r0 = _fiber_radius(df, base)
    >>> r.tolist(), round(r0, 12)
    ([3e-06, 5e-06], 4e-06)
    """
    if "generator.diameter" in df:
        d = pd.to_numeric(df["generator.diameter"], errors="coerce")
        return d / 2.0, float(np.nanmedian(d)) / 2.0 if d.notna().any() else None
    d = (study.get("base") or {}).get("generator", {}).get("diameter")
    fibers = (study.get("base") or {}).get("fibers") or []
    ds = [f.get("diameter") if isinstance(f, dict) else None for f in fibers]
    varied = {
        int(m.group(1)): c
        for c in df.columns
        if (m := re.fullmatch(r"fibers\.(\d+)\.diameter", str(c))) and int(m.group(1)) < len(ds)
    }
    if d is None and varied:  # an explicit fiber's diameter is a parameter (session 40)
        rows = np.array([[np.nan if v is None else float(v) for v in ds]] * len(df))
        for i, c in varied.items():
            rows[:, i] = pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float)
        per_row = pd.Series(np.nanmedian(rows, axis=1), index=df.index) / 2.0
        return per_row, float(np.nanmedian(per_row)) if per_row.notna().any() else None
    if d is None:
        ds = [float(v) for v in ds if v]
        d = float(np.median(ds)) if ds else None
    return None, (float(d) / 2.0 if d else None)


def _porosity(df: pd.DataFrame) -> tuple[str | None, pd.Series | None]:
    """The porosity column a porosity-K figure draws on its x axis (the measured one, else the
    generator's target) and its values; ``(None, None)`` without one."""
    for c in ("porosity", "generator.porosity"):
        if c in df:
            p = pd.to_numeric(df[c], errors="coerce")
            if p.notna().any():
                return c, p
    return None, None


def _k_error(df: pd.DataFrame, c: str, k: pd.Series) -> np.ndarray | None:
    """Absolute error bar of K from its relative one (``k_x_rel_error``), or None."""
    rel = df.get(f"{c[:3]}_rel_error")
    if rel is None:
        return None
    e = (pd.to_numeric(rel, errors="coerce") * k).to_numpy(dtype=float)
    return e if np.isfinite(e).any() else None


def _perm_figure(df: pd.DataFrame, study: dict) -> tuple[str | None, str]:
    """Porosity vs K with error bars and the reference curves; a point that is not ok, its K
    (the case not converged, or this direction untrustworthy) or its porosity (a bar above
    20 %: :func:`~psdesign.report.trust.point_status`), drawn with an open marker per status
    (:func:`~psdesign.report.trust.draw_not_ok`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    eps_col, eps_all = _porosity(df)
    kcols = [c for c in DIRECTIONS if c in df and pd.to_numeric(df[c], errors="coerce").gt(0).any()]
    if eps_all is None or not kcols:
        return None, "No porosity/permeability results to plot."
    r_all, r0 = _fiber_radius(df, study)
    normalize = r_all is not None and r_all.nunique() > 1
    fig, ax = plt.subplots(figsize=(7, 4.8))
    ax.set_yscale("log")  # before draw_not_ok, which draws no K <= 0 on a log axis
    markers = {"k_x_m2": "o", "k_y_m2": "s", "k_z_m2": "^"}
    colors = {"k_x_m2": "C0", "k_y_m2": "C2", "k_z_m2": "C1"}
    n_bad = n_x = 0
    for c in kcols:
        k = pd.to_numeric(df[c], errors="coerce")
        scale = r_all**2 if normalize else 1.0
        y, err = k / scale, _k_error(df, c, k / scale)
        # filled: the K and its porosity both trusted (a point is as trusted as its worst)
        good = (point_status(df, c, eps_col) == "ok").to_numpy() & (k > 0).to_numpy()
        if good.any():
            ax.errorbar(
                eps_all[good],
                y[good],
                yerr=None if err is None else err[good],
                fmt=markers[c],
                ms=6,
                color=colors[c],
                capsize=2,
                alpha=0.8,
                label=f"{DIRECTIONS[c]} (this study)",
            )
        bad, at_bad_x = draw_not_ok(
            ax, df, c, (eps_all, y, err), markers[c], DIRECTIONS[c], eps_col
        )
        n_bad, n_x = n_bad + bad, n_x + at_bad_x
    notes = [_reference_curves(ax, eps_all, r0, normalize)]
    if n_bad:
        notes.append(
            f"{n_bad} K value(s) that are not ok ({NOT_OK_MARKERS}) are left out of the fits "
            "and sensitivity."
        )
    if n_x:
        notes.append(AT_UNTRUSTED_X.format(n=n_x, values="K", x="porosity"))
    n_failed = failed_count(df)
    if n_failed:
        notes.append(f"{n_failed} failed or timed-out case(s) have no K and are not plotted.")
    ax.set_xlabel("porosity (-)")
    ax.set_ylabel("K / r² (-)" if normalize else "permeability K (m²)")
    # labels of a known width (report.png.FIG_MARGINS_IN), over the data and reference curves
    log_ticks(ax.yaxis, [v for line in ax.lines for v in line.get_ydata()])
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return _png(fig), " ".join(n for n in notes if n)


def _reference_curves(ax, eps: pd.Series, r0: float | None, normalize: bool) -> str:
    """Tomadakis-Sotirchos and Kozeny-Carman curves over the porosity range; the caption."""
    if not r0:
        return "No fiber diameter in the spec: reference curves omitted."
    lo = max(TS_EPS_P + 0.02, float(np.nanmin(eps)) - 0.05)
    hi = min(0.98, float(np.nanmax(eps)) + 0.05)
    e = np.linspace(lo, hi, 200)
    rr = 1.0 if normalize else r0
    ax.plot(
        e,
        tomadakis_sotirchos(e, rr, TS_ALPHA_THROUGH_PLANE),
        "k-",
        label=f"Tomadakis-Sotirchos 1993 [1], through-plane (alpha={TS_ALPHA_THROUGH_PLANE})",
    )
    ax.plot(
        e,
        tomadakis_sotirchos(e, rr, TS_ALPHA_IN_PLANE),
        "k--",
        label=f"Tomadakis-Sotirchos 1993 [1], in-plane (alpha={TS_ALPHA_IN_PLANE})",
    )
    # each label cites its entry of the References list (_references): session 45 found the
    # legend naming the models without a source
    ax.plot(
        e, kozeny_carman(e, rr), "k:", label=f"Kozeny-Carman 1937 [2] (k_K={KOZENY_CONSTANT:g})"
    )
    if normalize:
        return "Diameter varies: permeability shown as K / r^2."
    return f"Reference curves for fiber radius r = {r0:.3g} m."


def _convergence(df: pd.DataFrame) -> tuple[str, str | None, int]:
    """The solver-convergence table (each case flagged when :func:`_convergence_flags`), the
    flux-imbalance figure's PNG (None without an imbalance) and the number flagged."""
    stat_cols = [
        c
        for c in df.columns
        if c.startswith(("iterations_", "flux_imbalance_", "converged_", "residual_"))
    ]
    cols = ["case_id", "status", *stat_cols, "error"]
    cols = [c for c in cols if c in df]
    flags = _convergence_flags(df, stat_cols)
    table = _table(df[cols], ["flag" if f else "" for f in flags])
    fig_uri = None
    fcols = [
        c
        for c in stat_cols
        if c.startswith("flux_imbalance_")
        and pd.to_numeric(df[c], errors="coerce").abs().gt(0).any()
    ]
    if fcols:
        fig_uri = _png(_convergence_figure(df, fcols))
    return table, fig_uri, int(flags.sum())


def _convergence_flags(df: pd.DataFrame, stat_cols: list[str]) -> np.ndarray:
    """Each case flagged in the convergence table: its status not ok, a K not ok by its own
    status (:func:`~psdesign.analysis.columns.k_not_ok`, what the red box counts; an in-memory
    "" own status is unset, not a flag, since review s46), a direction not converged or an
    |flux imbalance| above :data:`FLUX_IMBALANCE_FLAG`. Column by column: a one-value Series
    through ``pd.to_numeric`` per cell cost ~0.1 ms (session 48)."""
    flag = (case_status(df) != "ok").to_numpy(copy=True)
    flag |= pd.concat([k_not_ok(df, f"k_{d}_m2") for d in "xyz"], axis=1).any(axis=1).to_numpy()
    for c in stat_cols:
        if c.startswith("converged_"):
            flag |= df[c].astype(str).str.lower().isin(("false", "0", "0.0")).to_numpy()
        if c.startswith("flux_imbalance_"):
            flag |= np.abs(column_numbers(df, c)) > FLUX_IMBALANCE_FLAG
    return flag


def _convergence_figure(df: pd.DataFrame, fcols: list[str]):
    """|flux imbalance| of each case and direction against its case id (the table's first
    column): a shape per direction, filled where its K is ok, open in its status's colour
    (:func:`~psdesign.report.trust.status_style`) where it is not."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.4))
    x = np.arange(len(df))
    for i, c in enumerate(fcols):
        v = pd.to_numeric(df[c], errors="coerce").abs()
        v = v.where(v > 0).to_numpy()
        k_col = f"k_{c.rsplit('_', 1)[-1]}_m2"
        st = value_status(df, k_col).to_numpy()
        ok = st == "ok"
        shape = "os^"[i % 3]  # a shape per direction, a colour per status (as _perm_figure)
        ax.semilogy(x[ok], v[ok], shape, ms=4, color=f"C{i}", label=f"{c}: ok")
        for status in sorted(set(st[~ok])):
            m = st == status
            if not np.isfinite(v[m]).any():  # a failed case has no imbalance to draw
                continue
            color = status_style(status)[2]
            ax.semilogy(x[m], v[m], shape, ms=7, mfc="none", mec=color, label=f"{c}: {status}")
    ax.axhline(FLUX_IMBALANCE_FLAG, color="r", lw=0.8, ls="--", label="flag threshold")
    ids = df["case_id"].astype(str).str.split("-").str[0] if "case_id" in df else x
    step = max(1, len(df) // 30)  # at most ~30 readable labels
    ax.set_xticks(x[::step], list(ids)[::step], rotation=90, fontsize=7)
    ax.set_xlabel("case id")
    ax.set_ylabel("|flux imbalance| (relative)")
    log_ticks(ax.yaxis, [v for line in ax.lines for v in line.get_ydata()])  # the flag's line too
    ax.legend(fontsize=7)
    return fig


def status_mark(status: str) -> tuple[str, bool]:
    """``(word, flagged)`` of a value's own ``status`` in the report's K and values tables, by
    the one rule (:mod:`psdesign.status`): the word written beside the value, "" for a
    trusted one (:data:`~psdesign.status.TRUSTED`: ``converged`` and ``at_bound`` read as
    ``ok``, as :func:`psdesign.analysis.columns.value_status` reads them), and whether its row
    is highlighted: where the status does not pass (:func:`~psdesign.status.passes`), the rule
    of the red box and the exit (``not_applicable`` is written, not highlighted). Until
    session 52 the K table wrote every word but ``ok`` and the values table highlighted
    ``not_applicable``.

    >>> status_mark("ok"), status_mark("at_bound"), status_mark("not_applicable")
    (('', False), ('', False), ('not_applicable', False))
    >>> status_mark("untrustworthy")
    ('untrustworthy', True)
    """
    from psdesign.status import TRUSTED, passes

    return ("" if status in TRUSTED else status), not passes(status)


def _k_cell(k: float, e: float, bc: str, status: str) -> str:
    """One K table cell: the value with its error bar, then (each on its own line) the
    boundary condition when the column's header does not carry it and the status when it is
    not ok, escaped HTML."""
    txt = k_text(k, e)
    parts = [_esc(txt)] if txt else []
    if bc:
        parts.append(f'<span class="kbc">{_esc(bc)}</span>')
    if status and status != "ok":
        parts.append(f'<span class="kst">{_esc(status)}</span>')
    return "<br>".join(parts)


def _k_table(df: pd.DataFrame, solver: str | None = None) -> str:
    """K per direction with its error bar, status (an ``untrustworthy`` one with its reason)
    and boundary-condition model; ``solver``: the study's (``fem``: no voxel-count reason).

    One column per direction, its unit (and the bc, when every case has the same) in the
    header, the bar, bc and a status that is not ok in the cell, wrapped: with a column each
    for status and bc, two directions' reasons made the table 1601 px wide in a 1319 px box
    at a 1400 px window (session 43, benchmarks/RESULTS.md)."""
    rows = []
    dirs = [d for d in "xyz" if f"k_{d}_m2" in df]
    if not any(f"k_{d}_rel_error" in df for d in dirs):
        return ""
    if not dirs:
        return ""
    one_bc = {}
    for d in dirs:
        bcs = df[f"bc_{d}"].dropna().astype(str).unique() if f"bc_{d}" in df else []
        one_bc[d] = bcs[0] if len(bcs) == 1 else None
    heads = {d: f"K_{d} (m²)" + (f", bc {one_bc[d]}" if one_bc[d] else "") for d in dirs}
    classes = []
    cases = case_status(df).tolist()  # a missing one is "unknown", not ok (review s45)
    # each K's own status as the red box reads it (own_status: "" unset, an old table's K
    # without a status by its bar; review s46)
    own = {d: own_status(df, f"k_{d}_m2").tolist() for d in dirs}
    # each column parsed once, cells read by position: a one-value Series through
    # pd.to_numeric per cell and a Series looked up by label per cell cost 2.6 s of CPU of a
    # 2000-row table's 14 s report (session 48)
    num = {c: column_numbers(df, c) for d in dirs for c in (f"k_{d}_m2", f"k_{d}_rel_error")}
    for i, row in enumerate(df.to_dict("records")):
        out = {"case_id": row.get("case_id", ""), "case status": cases[i]}
        flag = cases[i] != "ok"
        for d in dirs:
            k, e = num[f"k_{d}_m2"][i], num[f"k_{d}_rel_error"][i]
            st = own[d][i]
            word, bad = status_mark(st)
            status = word if word or cases[i] == "ok" else cases[i]  # its own word first
            if st == "untrustworthy":  # the reason where the reader looks (session 42)
                status = f"untrustworthy: {untrusted_k_reason(row, d, solver)}"
            bc = row.get(f"bc_{d}", "")
            bc = "" if one_bc[d] or pd.isna(bc) else str(bc)
            out[heads[d]] = _k_cell(k, e, bc, status)
            flag |= bad  # what k_not_ok (the red box) flags
        rows.append(out)
        classes.append("flag" if flag else "")
    note = (
        '<p class="note">Error bar: two-grid discretization estimate (a second solve at about '
        "twice the step) with a resolution floor, plus the solver residual "
        "(docs/permeability.md). Highlighted: a case or a direction whose status is not "
        "trusted (failed, not_converged, untrustworthy); a status other than ok (or a "
        "trusted converged / at_bound) is written under the K.</p>"
    )
    table = _table(
        pd.DataFrame(rows), classes, raw=tuple(heads.values()), table_class="sortable ktable"
    )
    return "<h3>Permeability with error bars</h3>" + note + table


def untrusted_k_reason(row: pd.Series | dict, d: str, solver: str | None = "voxel") -> str:
    """Why the K of ``row`` along ``d`` is ``untrustworthy``, in a few words, from the row's
    numbers by :func:`psdesign.flow.error.untrustworthy_reasons`, the rule of ``status_of``:
    its error bar above :data:`~psdesign.flow.error.UNTRUSTWORTHY_REL_ERROR`, fewer than
    :data:`~psdesign.flow.error.MIN_CELLS_PER_DIAMETER` voxels per fiber diameter (per thin
    width where the row's ``resolution_measure_<d>`` says so; only the voxel route is rated on
    it: a FEM K is untrustworthy by its bar alone), else a phase lost on the second
    resolution's grid (its line in ``warnings_<d>``).

    Parameters
    ----------
    row : pandas.Series or dict
        A row of ``results.csv``.
    d : str
        The direction, ``"x"``, ``"y"`` or ``"z"``.
    solver : str or None
        The study's solver (``"fem"``: its K is not rated on voxels per diameter).

    Returns
    -------
    str
        E.g. ``"4.1 voxels per fiber diameter, need 8"``.

    Examples
    --------
    >>> row = pd.Series({"k_z_rel_error": 0.115, "cells_per_diameter_z": 7.0})
    >>> untrusted_k_reason(row, "z")
    '7.0 voxels per fiber diameter, need 8'
    >>> untrusted_k_reason(pd.Series({"k_z_rel_error": 0.31}), "z")
    'error bar 31.0 % > 20 %'
    >>> untrusted_k_reason(pd.Series({**row, "resolution_measure_z": "fiber thin width"}), "z")
    '7.0 voxels per fiber thin width, need 8'
    """
    from psdesign.flow.error import untrustworthy_reasons
    from psdesign.geometry.rve import DIAMETER_MEASURE

    # a cell at a time (_scalar: a one-value Series through pd.to_numeric cost ~0.1 ms)
    e, cpd = _scalar(row.get(f"k_{d}_rel_error")), _scalar(row.get(f"cells_per_diameter_{d}"))
    rated_cpd = cpd if solver != "fem" and math.isfinite(cpd) else None
    measure = row.get(f"resolution_measure_{d}")
    measure = measure if isinstance(measure, str) and measure else DIAMETER_MEASURE
    why = untrustworthy_reasons(e, rated_cpd, measure=measure)
    return "; ".join(why) or f"a phase lost on the coarser grid (warnings_{d})"


#: The values other than K that :func:`_values_table` lists with their bars, in this order.
RATED_VALUES = tuple(c for c in STATUS_COLUMNS if not c.startswith("k_"))


#: Values printed with their absolute error (a fraction of the box: a relative bar says
#: nothing for a zero Omega and 2000 % for a small one), as ``porosity_text`` prints them.
ABSOLUTE_BARS = ("porosity", "intersection_volume_fraction")


def _scalar(x) -> float:
    """One cell as a float, NaN where it is not a number (a one-value Series through
    ``pd.to_numeric`` cost ~0.1 ms a cell: ~2.4 s of a 2000-row values table, session 47).
    NaN, not :func:`~psdesign.analysis.columns.cell_number`'s None: its callers hand it on as
    a float (``math.isfinite``, ``pd.isna``, ``untrustworthy_reasons``' error bar)."""
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


#: Values that share one absolute bar and are rated together by it over one of them
#: (:data:`~psdesign.analysis.columns.RATED_BY`: d10, d50 and d90 by ``pore_diameter_error_m``
#: over d50): printed with that bar (one-sided, ``+bar/-0``: :data:`~psdesign.analysis.columns.
#: UPPER_BARS`), the one they are rated over with the fraction that rates them (until session
#: 47 each was printed ± its own fraction, d10's 30 % beside an ok status that d50's 15 % gave).
SHARED_BARS = (*RATED_BY, *dict.fromkeys(RATED_BY.values()))


def _absolute_bar_text(value, error, column: str, below=None) -> tuple[str, bool]:
    """``("0.8000 ± 4.0e-04", True)`` for the porosity, ``("1e-05 ± 2.0e-04", True)`` or
    ``("0 ± 0", True)`` for Omega (an exact zero printed as such), ``("1.234e-05
    +3.0e-06/-0", True)`` for a pore diameter (its bar one-sided, the truth above, ``below``
    it where a face does not repeat, :data:`~psdesign.analysis.columns.LOWER_BAR_COLUMN`:
    :func:`~psdesign.transport.pores.diameter_bar_text`; until session 48 ``± 3.0e-06``); the
    value alone and False without a bar, ``""`` without a value."""
    v, e = _scalar(value), _scalar(error)
    if pd.isna(v):
        return "", False
    digits = ".3g" if column == "intersection_volume_fraction" else ".4g"
    txt = f"{v:.4f}" if column == "porosity" else "0" if v == 0 else f"{v:{digits}}"
    if pd.isna(e):
        return txt, False
    if column in UPPER_BARS:
        from psdesign.transport.pores import diameter_bar_text

        low = _scalar(below)
        return f"{txt} {diameter_bar_text(e, 0.0 if pd.isna(low) else low)}", True
    return txt + " ± " + ("0" if e == 0 else f"{e:.1e}"), True


def _values_table(df: pd.DataFrame, study: dict | None = None) -> str:
    """Porosity and the transport values of each case with their error bars and statuses
    (:func:`psdesign.analysis.columns.error_bar`): the porosity and Omega ``+-`` their
    absolute bars (:func:`_absolute_bar_text`), the others ``+-`` a relative one, and
    ``[status]`` where it is not trusted (:data:`psdesign.status.TRUSTED`) nor
    unrated, under headings with their units (:func:`psdesign.report.units.output_label`); ""
    when the study has none of them with a bar."""
    cols = [
        c for c in RATED_VALUES if c in df and pd.to_numeric(df[c], errors="coerce").notna().any()
    ]
    rows, classes, any_bar = [], [], False
    cases = case_status(df)
    for i, r in df.iterrows():
        row = r.to_dict()
        out, flag = {"case_id": row.get("case_id", ""), "case status": cases[i]}, cases[i] != "ok"
        for c in cols:
            rel, st = error_bar(row, c)
            txt, has_bar = _value_cell(row, c, rel)
            if not txt and st == BLOCKED:  # a tortuosity: porosity / 0 (the JSON's null)
                txt = "undefined"
            any_bar |= has_bar
            if txt and st != "unrated":
                word, bad = status_mark(st)
                txt += f" [{word}]" if word else ""
                flag |= bad
            out[output_label(c, study)] = txt
        rows.append(out)
        classes.append("flag" if flag else "")
    if not any_bar:
        return ""
    omega = "intersection_volume_fraction" in cols
    transport = len(cols) > 1 + omega
    pores = [c for c in SHARED_BARS if c in cols]
    note = (
        '<p class="note">Porosity ± its absolute error (the voxel count against two partial-volume '
        "quadratures, docs/geometry.md)"
        + (
            "; the overlap Omega (intersection_volume_fraction, a fraction of the box) ± its "
            "absolute error (the same count on the grid and on every second voxel, and the "
            "rounding of its boundary; "
            + _status_words("intersection_volume_fraction_status")
            + ", docs/geometry.md)"
            if omega
            else ""
        )
        + ("; transport values ± their relative error bar (docs/transport.md)" if transport else "")
        + (_shared_bar_note() if pores else "")
        + (
            "; each with its status where it is not ok (highlighted where it is not trusted)"
            if len(cols) > 1
            else ""
        )
        + ".</p>"
    )
    title = "Porosity and " + ("transport values" if transport else "overlap") if omega else ""
    title = "Porosity and transport values" if transport else title or "Porosity"
    return f"<h3>{title} with error bars</h3>" + note + _table(pd.DataFrame(rows), classes)


def _value_cell(row: dict, c: str, rel: float | None) -> tuple[str, bool]:
    """The values table's cell of ``row[c]`` without its status, and whether it has a bar:
    ``+-`` the absolute bar (:data:`ABSOLUTE_BARS`, :data:`SHARED_BARS`; the value the others
    are rated over with the fraction that rates them all: the larger of ``rel`` and its lower
    side, :func:`~psdesign.analysis.columns.rel_error_below`), else ``+-`` the relative
    bar ``rel`` (:func:`~psdesign.analysis.columns.error_bar`'s).

    >>> row = {"pore_d10_m": 1e-5, "pore_d50_m": 2e-5, "pore_diameter_error_m": 3e-6}
    >>> _value_cell(row, "pore_d10_m", 0.3), _value_cell(row, "pore_d50_m", 0.15)
    (('1e-05 +3.0e-06/-0', True), ('2e-05 +3.0e-06/-0 (15.0 %)', True))
    >>> walled = {**row, "pore_diameter_error_below_m": 8e-6}
    >>> _value_cell(walled, "pore_d10_m", 0.4)[0], _value_cell(walled, "pore_d50_m", 0.15)[0]
    ('1e-05 +3.0e-06/-8.0e-06', '2e-05 +3.0e-06/-8.0e-06 (40.0 %)')
    >>> _value_cell({"diffusivity_z": 0.4}, "diffusivity_z", 0.05)
    ('0.4 ± 5.0 %', True)
    """
    v = _scalar(row.get(c))
    if c in ABSOLUTE_BARS or c in SHARED_BARS:
        txt, has_bar = _absolute_bar_text(
            v, row.get(ABS_ERROR_COLUMNS[c]), c, row.get(LOWER_BAR_COLUMN)
        )
        if has_bar and c in RATED_BY.values() and rel is not None:
            # the fraction that rates d10, d50 and d90: the larger side over d50 (the
            # product's rel_error), not the upper one alone (12.4 % beside an
            # untrustworthy the 55 % lower side gave: session 54 review)
            txt += f" ({100 * max(rel, rel_error_below(row, c)):.1f} %)"
        return txt, has_bar or rel is not None
    txt = "" if pd.isna(v) else f"{v:.4g}"
    return txt + ("" if rel is None else f" ± {100 * rel:.1f} %"), rel is not None


def _status_words(status_column: str) -> str:
    """The words of ``status_column``'s rating as every command prints them
    (:func:`psdesign.status.flagged_words`: one copy of them)."""
    from psdesign.status import flagged_words

    return flagged_words(status_column)


def _shared_bar_note() -> str:
    """The values table's words on the pore diameters' one bar (:data:`SHARED_BARS`) and the
    rating it enters (:func:`psdesign.status.flagged_words`)."""
    return (
        "; pore diameters d10, d50 and d90 with their one absolute bar (pore_diameter_error_m): "
        "the scan measures low, so each true diameter lies between the value and the value + "
        "the bar (+bar/-0), and where a face of the box does not repeat down to the value - "
        "pore_diameter_error_below_m (+bar/-below); rated together by the larger side over d50 "
        "(the % beside d50; "
        f"{_status_words('pore_sizes_status')}, docs/transport.md)"
    )


def _field_pictures(df: pd.DataFrame, out: Path, params: list[str]) -> str:
    """The flow-field pictures of the cases that wrote one (``[study] fields = true``)."""
    if "fields_png" not in df:
        return ""
    items = []
    for _, row in df.iterrows():
        p = row.get("fields_png")
        if not isinstance(p, str) or not p:
            continue
        uri = _img_file(Path(p) if Path(p).is_absolute() else out / p)
        if uri is not None:
            cap = ", ".join(f"{k}={_fmt(row[k])}" for k in params if k in row)
            items.append((uri, f"{row['case_id']}: {cap} seed={row.get('seed')}"))
    if not items:
        return ""
    note = (
        '<p class="note">Mid-plane slice of each case\'s first permeability solve: |velocity| '
        "with streamlines, and pressure. The VTU/VTI files for ParaView are in the case's "
        "<code>fields/</code> folder (fields.json lists the arrays and units).</p>"
    )
    # its own id: the page script finds a gallery by id (a second "psd-thumbs" never loaded)
    return "<h2>Flow fields</h2>" + note + gallery_html(items, "psd-fields", width=640)


def _previews(df: pd.DataFrame, out: Path, params: list[str], image: bool = False) -> str:
    """Every case's preview picture, paged (images are decoded only when their page shows),
    captioned with its design point. The title ``generate`` puts on its own preview
    (:func:`~psdesign.report.preview.preview_title`: the porosity and Omega with their bars
    and statuses, the fibre count; ``image``: an image's RVE, no Omega) is drawn on a picture
    since session 48; since session 49 its row says so (``preview_title``, written with the
    picture by ``psdesign.study.case``) and the caption does not repeat it. A folder written
    before session 49 (no ``preview_title``; its pictures with the title drawn, or before
    session 48 without) keeps the title in its caption."""
    from psdesign.report.preview import preview_title

    if "preview_png" not in df:
        return '<p class="note">The case function wrote no preview pictures.</p>'
    items = []
    for _, row in df.iterrows():
        p = row.get("preview_png")
        if not isinstance(p, str) or not p:
            continue
        path = Path(p) if Path(p).is_absolute() else out / p
        uri = _preview_uri(path)
        if uri is None:
            continue
        cap = ", ".join(f"{k}={_fmt(row[k])}" for k in params if k in row)
        drawn = row.get("preview_title")  # the title on the picture: not repeated
        title = "" if isinstance(drawn, str) else preview_title(row, image=image)
        caption = f"{row['case_id']}: {cap} seed={row.get('seed')}"
        items.append((uri, f"{caption}; {title}" if title else caption))
    if not items:
        return '<p class="note">No preview pictures found.</p>'
    return gallery_html(items)


def _versions() -> dict:
    import importlib.metadata as md

    out = {"python": sys.version.split()[0]}
    for name in ("psdesign", "numpy", "scipy", "pandas", "matplotlib", "dask", "distributed"):
        try:
            out[name] = md.version(name)
        except md.PackageNotFoundError:
            pass
    return out


def _safe(section, *args) -> str:
    """A report section, or a note saying why it is missing (a report is never lost to one)."""
    try:
        return section(*args)
    except Exception as exc:  # noqa: BLE001 - e.g. too few cases for a fit
        return f'<p class="note">Section not available: {_esc(type(exc).__name__)}: {_esc(exc)}</p>'


def _fit_or_none(df: pd.DataFrame, params: list[str], study: dict):
    """:func:`report_fit`, or ``None`` when it cannot fit (its section then says why)."""
    try:
        return report_fit(df, params, study)
    except Exception:  # noqa: BLE001 - the section's _safe note names the error
        return None


def build_html(out_dir: str | Path) -> str:
    """Return the report HTML for a study output folder (see :func:`write_report`)."""
    return render_report(out_dir)[0]


class ReportAlert(NamedTuple):
    """One thing a report shows not trusted besides its cases' statuses: what (``what``, the
    red box's words) and what to do (``todo``); ``study report`` prints
    ``psdesign: <what>: <todo>`` for each and exits 3 when there is one."""

    what: str
    todo: str = "read the report's red box"


def render_report(out_dir: str | Path) -> tuple[str, list[ReportAlert]]:
    """The report HTML of a study output folder and what its red boxes add to the cases'
    count: an unfinished study (fewer cases than study.json plans), a missed ``study
    optimize`` target and an untrustworthy surrogate it draws (``study report`` exits 3
    exactly when a box is there: the cases or these alerts)."""
    out = Path(out_dir)
    df, study, runs = _load(out)
    params = list((study.get("parameters") or {}).keys()) or [
        c for c in df.columns if is_design_parameter(c)
    ]
    fit = _fit_or_none(df, params, study)
    boxed = [a for a in (missed_target_alert(out), fit_alert(fit)) if a]
    incomplete, unfinished = _unfinished(out, df)
    name = study.get("name", out.name)
    meta = _meta_table(df, study, runs, params, name, out)

    perm_uri, perm_note = _perm_figure(df, study)
    perm_html = f'<img src="{perm_uri}" alt="porosity vs permeability">' if perm_uri else ""
    diff_png, diff_note = transport_figure(df)
    diff_html = (
        f'<h2>Porosity vs diffusivity</h2><img src="data:image/png;base64,{diff_png}" '
        f'alt="porosity vs relative diffusivity"><p class="note">{_esc(diff_note)}</p>'
        if diff_png
        else ""
    )

    sens = sensitivity_table(trusted(df), params)
    sens_html = (
        _table(sens) + SENS_BLANK_NOTE
        if len(sens)
        else '<p class="note">Not enough varying numeric parameters or results.</p>'
    )
    me_html = ""
    if study.get("design") == "full-factorial":
        me = main_effects(trusted(df), params)
        if len(me):
            me_html = "<h3>Main effects (mean response per level)</h3>" + _table(me)

    image = bool((study.get("base") or {}).get("image"))  # an image's RVE: no Omega
    conv_table, conv_uri, n_flag = _convergence(df)
    conv_fig = f'<img src="{conv_uri}" alt="flux imbalance">' if conv_uri else ""

    row_cls = ["" if s == "ok" else "flag" for s in case_status(df)]
    results_html = _table(df, row_cls)
    k_html = _k_table(df, study.get("solver"))

    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>psdesign study report: {_esc(name)}</title>
<style>{CSS}{INTERACTIVE_CSS}</style>
{head_scripts()}</head><body>
<h1>Study report: {_esc(name)}</h1>
{incomplete}{_status_banner(df, boxed)}{_safe(glance_section, df, params)}
<h2>Study</h2><table class="meta">{meta}</table>
{_safe(optimize_section, out)}
{unit_selector()}
<h2>Porosity vs permeability</h2>{perm_html}<p class="note">{_esc(perm_note)} Directions:
x, y in-plane, z through-plane (fibers lie mostly in the x-y plane).</p>{k_html}
{diff_html}{_values_table(df, study)}
<h2>Outputs vs design parameters</h2>
<p class="note">Means over replicates (seeds); bar: the Student-t 95 % half-width of the mean
(summary.csv's X_ci95_half; none for one seed) plus the cases' mean numerical error bar
(a pore diameter's upward only: the scan measures low, the truth lies above it);
anisotropy = mean in-plane K / through-plane K.</p>
{_safe(parameter_plots, df, params, study)}
<h2>Main effects and interactions</h2>{_safe(effect_plots, df, params, study)}
<h2>Surrogate model and global sensitivity</h2>{_safe(surrogate_plots, df, params, study, fit)}
<h2>Sensitivity</h2>
<p class="note">Spearman rank correlation and standardized regression coefficient (SRC, linear
least squares on standardized variables) of each numeric parameter against porosity and
log10 K, over cases with status ok.</p>{sens_html}{me_html}
<h2>Sample RVEs</h2>{_previews(df, out, params, image)}
{_field_pictures(df, out, params)}
<h2>Solver convergence</h2>
<p class="note">{n_flag} flagged case(s) (highlighted): status not ok, a direction not converged
or not trustworthy (k_*_status), or |flux imbalance| &gt; {FLUX_IMBALANCE_FLAG:g}.</p>
{conv_fig}{conv_table}
<h2>Results</h2>{results_html}
<h2>References</h2>{_references()}
</body></html>
"""
    return page, unfinished + [ReportAlert(a) for a in boxed]


def _unfinished(out: Path, df: pd.DataFrame) -> tuple[str, list[ReportAlert]]:
    """The red box at the top and its alert when ``study.json`` lists cases ``results.csv``
    has no row for (an interrupted run: :func:`psdesign.study.readback.cases_not_run`); ``""``
    and none for a finished study, whose report stays byte-identical. The one place that
    decides "unfinished" (until session 53 ``study report`` counted again on its own)."""
    from psdesign.study.readback import cases_not_run, resume_command

    missing, n_design = cases_not_run(out, df)
    if not missing:
        return "", []
    command = resume_command(out)
    banner = (
        f'<p class="alert" id="psd-incomplete-alert"><b>Incomplete study:</b> this report '
        f"shows {n_design - missing} of the {n_design} cases in study.json; {missing} were "
        f"not run. Rerun <code>psdesign {command}</code> with the same arguments "
        "and folder to resume, then report again.</p>"
    )
    what = f"the report shows {n_design - missing} of {n_design} case(s); {missing} not run"
    return banner, [ReportAlert(what, f"rerun {command} to resume")]


def _status_banner(df: pd.DataFrame, alerts: list[str] | tuple[str, ...] = ()) -> str:
    """A red box at the top when any case or any rated value (K, porosity, D_eff/D, ...) is not
    ok: how many, and where they show. It reads what ``study report``'s exit reads
    (:func:`psdesign.cli.exit_status.case_masks`: :func:`~psdesign.analysis.columns.case_status`
    and :func:`~psdesign.analysis.columns.flagged_values`), so it is there exactly when that
    exits 3 (until session 46 a table without a ``status`` column showed "N unknown" here and
    a status column without its value was counted by the exit only). ``alerts``
    (:func:`render_report`): what else the report shows not trusted, a line each (session 52)."""
    status = case_status(df)
    counts = status[status != "ok"].value_counts().to_dict()
    # one count per status column: the tortuosity shares the diffusivity's, d10-d90 one column
    bad = {st: int(m.sum()) for st, m in flagged_values(df).items()}
    untrusted = sum(bad.values())
    more = "".join(f"<br><b>Not trusted:</b> {_esc(a)}." for a in alerts)
    if not counts and not untrusted:
        return more and f'<p class="alert" id="psd-status-alert">{more[4:]}</p>'
    parts = [f"{v} {_esc(k)}" for k, v in sorted(counts.items())]
    if untrusted:
        cols = ", ".join(bad)
        parts.append(f"{untrusted} value(s) of ok cases not ok ({_esc(cols)})")
    return (
        f'<p class="alert" id="psd-status-alert"><b>Not ok:</b> {", ".join(parts)} of '
        f"{len(df)} cases. They are left out of the means, fits and sensitivity, drawn as "
        "open markers named by status in the plots (when they have a value) and highlighted "
        "in the tables below; the reason is in the <code>error</code> column (cases), beside "
        "each untrustworthy K's status in the Permeability table (more in the Results table's "
        "<code>warnings_x</code> / <code>_y</code> / <code>_z</code> columns), in the "
        "<code>diffusivity_z_warnings</code>-like columns (transport values) or beside the "
        "porosity's bar in the Porosity table (porosity_status: "
        # the rating's words as every command prints them (session 48: "above 20 %" was
        # written out here beside STATUS_WORDS' copy)
        f"{_esc(_status_words('porosity_status'))}).{more}</p>"
    )


def _design_text(study: dict, out: Path) -> str | None:
    """The Study table's design: a folder ``study optimize`` made (its marker's command) ran
    its own search, whatever the spec's design (review s52: it read ``csv``, the form of each
    round, for a spec saying latin-hypercube)."""
    from psdesign.analysis.optimize import OPTIMIZE_COMMAND
    from psdesign.io.outputs import read_marker

    if (read_marker(out) or {}).get("command") == OPTIMIZE_COMMAND:
        return (
            "study optimize search: a Latin-hypercube start, then the points its surrogate "
            "chose (optimize.json)"
        )
    return study.get("design")


def _meta_table(
    df: pd.DataFrame, study: dict, runs: dict, params: list[str], name: str, out: Path
) -> str:
    """The study's description, the image it solved (an image-based study,
    :func:`psdesign.report.image_source.image_rows`), status counts, runs, machine and
    versions as table rows."""
    from psdesign.report.image_source import HEADER_KEY, image_rows

    counts = case_status(df).value_counts().to_dict()
    run_list = runs.get("runs", [])
    last = run_list[-1] if run_list else {}
    machine = last.get("machine", {"host": platform.node(), "platform": platform.platform()})
    total_case_time = pd.to_numeric(
        df.get("wall_time_s", pd.Series(dtype=float)), errors="coerce"
    ).sum()

    meta_rows = [
        ("study", name),
        ("description", study.get("description", "")),
        ("design", _design_text(study, out)),
        *image_rows(study, out, study.get(HEADER_KEY)),
        ("cases", len(df)),
        ("status", ", ".join(f"{k}: {v}" for k, v in sorted(counts.items()))),
        ("outputs", ", ".join(study.get("outputs", []))),
        ("solver", study.get("solver")),
        ("seeds", study.get("seeds")),
        ("parameters", ", ".join(params)),
        ("runs", len(run_list)),
        (
            "last run",
            f"{last.get('started_at', '')} .. {last.get('finished_at', '')}, "
            f"{last.get('workers', '')} worker(s), scheduler {last.get('scheduler')}",
        ),
        ("wall time of runs (s)", ", ".join(f"{r.get('wall_time_s', 0):.1f}" for r in run_list)),
        ("sum of case wall times (s)", f"{total_case_time:.1f}"),
        ("case function", last.get("case_fn", "")),
        ("machine", ", ".join(f"{k}={v}" for k, v in machine.items())),
        ("versions", ", ".join(f"{k} {v}" for k, v in _versions().items())),
        # no clock time of writing: the same study folder gives a byte-identical report
    ]
    return "".join(f"<tr><th>{_esc(k)}</th><td>{_esc(v)}</td></tr>" for k, v in meta_rows)


def _references() -> str:
    """The published models and data the report's curves and lines come from."""
    return (
        "<ol>"
        "<li>Tomadakis-Sotirchos: M. M. Tomadakis, S. V. Sotirchos, Ordinary and transition "
        "regime diffusion in random fiber structures, AIChE J. 39 (1993) 397-412; "
        "permeability model as in M. M. Tomadakis, "
        "T. J. Robertson, J. Compos. Mater. 39 (2005) 163-188. 2-D random fibers: "
        f"eps_p = {TS_EPS_P}, alpha = {TS_ALPHA_IN_PLANE} (in-plane), "
        f"{TS_ALPHA_THROUGH_PLANE} (through-plane). "
        "K = r^2 eps (eps-eps_p)^(alpha+2) / (8 ln^2(eps) (1-eps_p)^alpha "
        "((alpha+1) eps - eps_p)^2). Applied to carbon-paper GDLs by J. T. Gostick et al., "
        "J. Power Sources 162 (2006) 228-238.</li>"
        "<li>Kozeny-Carman: P. C. Carman, Fluid flow through granular beds, Trans. Inst. Chem. "
        "Eng. 15 (1937) 150-166. "
        f"K = r^2 eps^3 / (4 k_K (1-eps)^2), k_K = {KOZENY_CONSTANT:g}.</li>"
        "</ol>"
    )


def write_report(out_dir: str | Path) -> Path:
    """Write ``OUT/report.html``: one self-contained file that opens offline.

    Sections: study metadata (machine, timing, versions), porosity vs permeability with
    Tomadakis-Sotirchos and Kozeny-Carman reference curves, sensitivity (Spearman, SRC,
    main effects for factorial designs), preview pictures, solver convergence, the results
    table and references.

    Parameters
    ----------
    out_dir : str or Path
        A study output folder (holds ``results.csv``, ``study.json``, ``run.json``).

    Returns
    -------
    Path
        The report file.

    Raises
    ------
    ReportError
        If the folder holds no readable ``results.csv``
        (:func:`psdesign.study.readback.read_results`' one line).
    psdesign.io.outputs.OutputError
        If ``report.html`` exists and psdesign did not write it (it is never replaced).
    """
    return write_report_alerts(out_dir)[0]


def write_report_alerts(out_dir: str | Path) -> tuple[Path, list[ReportAlert]]:
    """:func:`write_report`, also returning what its red boxes add to the cases' count
    (:func:`render_report`: an unfinished study, a missed target, an untrustworthy surrogate;
    ``study report`` prints them and exits by them)."""
    from psdesign.io.outputs import check_folder_name, claim_output_dir
    from psdesign.study.store import atomic_write_bytes, check_study_files

    check_folder_name(out_dir, "out_dir")
    out = Path(out_dir)
    check_study_files(out, ["report.html"], "study report")
    text, alerts = render_report(out)
    claim_output_dir(check_study_files(out, ["report.html"], "study report"), ["report.html"])
    path = out / "report.html"
    atomic_write_bytes(path, text.encode("utf-8"))
    return path, alerts
