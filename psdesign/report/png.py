"""The report's matplotlib figures as PNG: drawn once, at fixed margins that hold labels of a
known size."""

from __future__ import annotations

import io

#: Margins of the report's matplotlib figures (inches: left, right, bottom, top), fixed: each
#: PNG is drawn once. ``bbox_inches="tight"`` drew every figure twice to find its margins (and
#: the convergence figure's ``tight_layout`` measured it a third time): about half the CPU of
#: the PNGs, session 48 (benchmarks/RESULTS.md). They hold every label because the labels'
#: sizes are known: log axes tick ``2e-11`` or ``3.2e-11`` (:func:`~psdesign.report.transport.
#: log_tick_text`, at most 7 characters), the porosity ``0.80``, and x tick labels written at 90
#: degrees (the convergence figure's case ids) set the bottom one by their measured length
#: (:func:`_bottom_margin`).
FIG_MARGINS_IN = (0.95, 0.25, 0.55, 0.15)
#: Of a bottom margin: the x axis' label and its pad, and the ticks with theirs (inches).
XLABEL_IN, TICKS_IN = 0.3, 0.1
#: Of a top margin: the space between a figure's title and its plots (inches).
TITLE_PAD_IN = 0.15


def _text_size(fig, text) -> tuple[float, float]:
    """Width and height (inches) of the matplotlib ``text`` as ``fig`` would draw it, measured
    by its renderer, not drawn."""
    renderer = fig.canvas.get_renderer()
    w, h, _ = renderer.get_text_width_height_descent(
        text.get_text(), text.get_fontproperties(), False
    )
    return w / fig.dpi, h / fig.dpi


def _bottom_margin(fig) -> float:
    """The bottom margin (inches) that holds ``fig``'s x axis: :data:`FIG_MARGINS_IN`'s, or
    with tick labels at 90 degrees the longest one's length (measured, not drawn) plus the
    ticks and the axis' label."""
    labels = [t for ax in fig.axes for t in ax.get_xticklabels()]
    rotated = [t for t in labels if t.get_rotation() == 90 and t.get_text()]
    if not rotated:
        return FIG_MARGINS_IN[2]
    return XLABEL_IN + TICKS_IN + max(_text_size(fig, t)[0] for t in rotated)


def _title_height(fig) -> float:
    """The height (inches) of ``fig``'s title (``suptitle``) with its pad, measured, not
    drawn; 0 without one."""
    title = fig._suptitle  # matplotlib's own attribute: None until suptitle() is called
    if title is None or not title.get_text():
        return 0.0
    return TITLE_PAD_IN + _text_size(fig, title)[1]


def _columns(fig) -> int:
    """How many columns of axes ``fig``'s grid has (1 for a figure of one plot)."""
    specs = [ax.get_subplotspec() for ax in fig.axes]
    return max((s.get_gridspec().ncols for s in specs if s is not None), default=1)


def figure_png(fig) -> bytes:
    """``fig`` as PNG bytes at the margins :data:`FIG_MARGINS_IN`, drawn once, and closed: the
    one encoder of the report's matplotlib figures (the K, convergence and diffusivity ones,
    and ``psdesign pores --plot``'s; the diffusivity figure saved with
    ``bbox_inches="tight"``, drawn twice, until session 48's review, the pores one until
    session 49). A title (``suptitle``) adds its measured height to the top margin, and
    panels side by side are the left margin apart (it holds a y axis' label and ticks): the
    picture's size is the figure's, whatever its data."""
    import matplotlib.pyplot as plt

    left, right, fixed, top = FIG_MARGINS_IN
    bottom = _bottom_margin(fig)
    top += _title_height(fig)
    w, h = fig.get_size_inches()
    if bottom > fixed:  # long labels lengthen the picture, never shorten the plot
        h += bottom - fixed
        fig.set_size_inches(w, h)
    n = _columns(fig)
    # subplots_adjust's wspace is a fraction of the mean axes width
    width = (w - left - right - (n - 1) * left) / n
    fig.subplots_adjust(
        left=left / w,
        right=1 - right / w,
        bottom=bottom / h,
        top=1 - top / h,
        wspace=left / width if n > 1 else None,
    )
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()
