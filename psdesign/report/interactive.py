"""Interactive pieces of the report: Plotly figures (plotly.js inlined once, offline), a
sortable table, paged thumbnails, the K-unit selector, and a JavaScript error trap that the
browser test reads (``#psd-js-errors`` stays empty, ``body[data-psd-ready]`` is set on load)."""

from __future__ import annotations

import functools
import html
import json
from pathlib import Path

from psdesign.report.units import K_UNIT_LABELS, K_UNITS

ASSETS = Path(__file__).resolve().parent / "assets"

#: Width of every figure (px); fixed so that figures render the same in every browser.
FIGURE_WIDTH = 640
#: Top margin (px) of a titled figure: the tool bar above, the title below it.
TITLE_MARGIN = 64
#: Thumbnails per page of the gallery.
THUMBS_PER_PAGE = 24


CSS = """
.psd-grid{display:grid;grid-template-columns:repeat(auto-fill,650px);gap:.5em}
table.sortable th{cursor:pointer}table.sortable th[data-order=asc]::after{content:" \\25B2"}
table.sortable th[data-order=desc]::after{content:" \\25BC"}
.scroll{max-width:100%;overflow:auto}
#psd-js-errors{color:#b00;white-space:pre}
"""


@functools.cache
def plotly_gz() -> str:
    """plotly.js gzip-compressed (``mtime = 0``: the same bytes on every run, so the same study
    writes the same report) as base64: 1.96 MB for the 4.82 MB script of plotly 7.1, which
    was 82 % of a 12-case report (5.9 MB, session 43).

    Computed once per process: it depends only on the installed plotly, and level-9 gzip of
    4.82 MB is 0.22-0.24 s of CPU, which every report a process writes paid again (session 47).
    """
    import base64
    import gzip

    from plotly.offline import get_plotlyjs

    packed = gzip.compress(get_plotlyjs().encode("utf-8"), compresslevel=9, mtime=0)
    return base64.b64encode(packed).decode("ascii")


def head_scripts() -> str:
    """``<script>`` blocks for the ``<head>``: plotly.js (inline, gzip + base64, unpacked by
    the browser: ``assets/plotly_loader.js``), the inflater the loader runs where the browser
    has no ``DecompressionStream`` (``assets/fflate_gunzip.min.js``, inert text until then)
    and the report's helpers."""
    units = (
        f"window.PSD_UNITS = {json.dumps(K_UNITS)};\n"
        f"window.PSD_UNIT_LABELS = {json.dumps(K_UNIT_LABELS)};\n"
    )
    helpers = (ASSETS / "report.js").read_text()
    inflater = (ASSETS / "fflate_gunzip.min.js").read_text()
    loader = (ASSETS / "plotly_loader.js").read_text()
    return (
        f'<script type="application/gzip;base64" id="psd-plotly-gz">{plotly_gz()}</script>\n'
        f'<script type="text/psd-inflate" id="psd-inflate">{inflater}</script>\n'
        f"<script>{units}{helpers}</script>\n<script>{loader}</script>"
    )


def unit_selector() -> str:
    """The K-unit drop-down (affects every K table cell and K figure)."""
    opts = "".join(
        f'<option value="{k}">{html.escape(v)}</option>' for k, v in K_UNIT_LABELS.items()
    )
    return (
        '<p>Permeability unit: <select id="psd-unit">' + opts + "</select> "
        '<span class="note">(files stay in m²)</span></p><div id="psd-js-errors"></div>'
    )


def number_axis(unit: str = "") -> dict:
    """Tick settings of a numeric Plotly axis or colour bar (the one definition of the report).

    With a unit (``"m"``) the ticks carry it with an SI prefix (``6µm``); without one (``""``,
    dimensionless ``"-"``, ``"deg"``) they are plain or exponent numbers (``0.0065``,
    ``6.5e-4``). Plotly's default (``exponentformat = "B"``) printed a porosity error of
    6.5e-4 as ``650µ``, a prefix that reads as a unit.
    """
    if unit and unit not in ("-", "deg"):
        return {"exponentformat": "SI", "ticksuffix": unit}
    return {"exponentformat": "e"}


def _plain_numbers(fig) -> None:
    """Give every axis and colour bar of ``fig`` whose tick format is unset
    :func:`number_axis`'s plain-or-exponent numbers, and every log axis whole numbers at its
    minor ticks."""
    for axis in [*fig.select_xaxes(), *fig.select_yaxes()]:
        if axis.exponentformat is None:
            axis.update(number_axis())
        # plotly 5.24 has no minorloglabels (pyproject allows >= 5.18: AttributeError there)
        if axis.type == "log" and getattr(axis, "minorloglabels", "") is None:
            # a K axis within a decade ticked "3", "2", "1e-11", "9", "8": digits that read
            # as values (session 45); every tick a whole number: "3e-11"
            axis.minorloglabels = "complete"
    for trace in fig.data:
        bar = getattr(trace, "colorbar", None)
        if bar is not None and bar.exponentformat is None:
            bar.update(number_axis())


def figure_html(fig, div_id: str, k_axis: str | None = None, k_label: str = "K") -> str:
    """A Plotly figure as a ``<div>`` (no plotly.js; :func:`head_scripts` loads it once).

    Axes and colour bars without a unit tick plain or exponent numbers (:func:`number_axis`).
    With ``k_axis`` (``"yaxis"``), the figure's y data are K in m^2 and follow the unit selector.
    """
    _plain_numbers(fig)
    fig.update_layout(autosize=False, width=FIGURE_WIDTH)
    _title_below_modebar(fig)
    div = fig.to_html(
        full_html=False,
        include_plotlyjs=False,
        div_id=div_id,
        config={"displaylogo": False},
    )
    # run by assets/plotly_loader.js once plotly.js is unpacked, not while the page parses
    assert div.count("<script>") == 1, "one figure script per figure"
    div = div.replace("<script>", '<script type="text/psd-plot">')
    if not k_axis:
        return div
    ys, errs = [], []
    for tr in fig.data:
        ys.append([None if v is None else float(v) for v in (tr.y if tr.y is not None else [])])
        e = getattr(tr, "error_y", None)
        arr = getattr(e, "array", None) if e is not None else None
        errs.append(None if arr is None else [None if v is None else float(v) for v in arr])
    reg = {
        "id": div_id,
        "traces": list(range(len(fig.data))),
        "y": ys,
        "err": errs if any(e is not None for e in errs) else None,
        "axis": k_axis,
        "label": k_label,
    }
    return div + (
        "<script>(window.PSD_KFIGS = window.PSD_KFIGS || []).push("
        + json.dumps(reg, allow_nan=False).replace("NaN", "null")
        + ");</script>"
    )


def _title_below_modebar(fig) -> None:
    """Put the title just above the plot area, below Plotly's tool bar (which sits in the
    figure's top right corner and otherwise covers the end of a long title)."""
    title = fig.layout.title
    if not (title and title.text) or fig.layout.annotations:
        return  # subplot titles are annotations at the same height: their figure sets margins
    top = fig.layout.margin.t if fig.layout.margin.t is not None else 80
    fig.update_layout(
        title={"yref": "paper", "y": 1.0, "yanchor": "bottom", "pad": {"b": 10}},
        title_font_size=14,
        margin_t=max(top, TITLE_MARGIN),
    )


def gallery_html(
    items: list[tuple[str, str]], gallery_id: str = "psd-thumbs", width: int = 300
) -> str:
    """Paged thumbnails ``width`` px wide; ``items`` are ``(data_uri, caption)``. Images load
    when shown; ``gallery_id`` must be unique in the page."""
    figs = "".join(
        f'<figure><img data-src="{uri}" alt="{html.escape(cap)}" width="{width}">'
        f"<figcaption>{html.escape(cap)}</figcaption></figure>"
        for uri, cap in items
    )
    nav = (
        f"<p><button onclick=\"psdPage('{gallery_id}', parseInt(document.getElementById("
        f"'{gallery_id}').getAttribute('data-page')) - 1)\">previous</button> "
        f'<span id="{gallery_id}-label"></span> '
        f"<button onclick=\"psdPage('{gallery_id}', parseInt(document.getElementById("
        f"'{gallery_id}').getAttribute('data-page')) + 1)\">next</button></p>"
    )
    return (
        f'{nav}<div class="psd-gallery" id="{gallery_id}" data-per-page="{THUMBS_PER_PAGE}"'
        f' data-page="0">{figs}</div>'
    )
