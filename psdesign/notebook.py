"""HTML tables for results shown in a notebook (``_repr_html_``): one row per quantity with
its unit, and a status that stands out when it is not ok."""

from __future__ import annotations

import html

__all__ = ["result_html"]

#: The badge of a status: ``ok`` green; ``unrated`` (nothing measured yet: a Material not
#: voxelized) neutral grey, so that red marks only a result not to trust (the same red for
#: both until session 54 took the alarm's weight); every other word red.
_STATUS_STYLE = {
    "ok": "color:#060;font-weight:bold",
    "unrated": "color:#555;border:1px solid #999;padding:0 .4em",
}
_ALARM_STYLE = "color:#fff;background:#c00;font-weight:bold;padding:0 .4em"


def result_html(title: str, rows: list[tuple[str, str]], status: str, notes: list[str]) -> str:
    """A small HTML table: ``title``, the ``(label, value)`` rows (labels carry the units),
    the ``status`` (:data:`_STATUS_STYLE`: red unless ``"ok"`` or ``"unrated"``) and ``notes``
    (warnings) under it.

    ``title``, ``status`` and ``notes`` are escaped here; the rows are HTML as given (units
    use ``<sup>``, errors ``&plusmn;``): the caller escapes any user-given string in them
    (``html.escape``: a file name, a ``from_dict`` field)."""
    body = "".join(
        f'<tr><th style="text-align:left">{label}</th><td style="text-align:left">{value}</td></tr>'
        for label, value in rows
    )
    style = _STATUS_STYLE.get(status, _ALARM_STYLE)
    body += (
        '<tr><th style="text-align:left">status</th>'
        f'<td style="text-align:left"><span style="{style}">{html.escape(status)}</span></td></tr>'
    )
    warn = "".join(f"<li>{html.escape(str(n))}</li>" for n in notes if n)
    return (
        f"<div><b>{html.escape(title)}</b><table>{body}</table>"
        + (f"<ul>{warn}</ul>" if warn else "")
        + "</div>"
    )


def plus_minus(rel_error: float | None) -> str:
    """``&plusmn; 2.3 %`` or ``n/a``."""
    if rel_error is None:
        return "n/a"
    return f"&plusmn; {100 * rel_error:.2g} %"


def porosity_html(porosity: float, error: float | None) -> str:
    """The porosity row's value as the other rows write theirs: ``0.8497 &plusmn; 3.1e-03``
    (:func:`~psdesign.geometry.porosity.porosity_text` with ``&plusmn;`` for ``+-``; the
    notebook showed ``+-`` beside every other row's ``±``, review s52).

    >>> porosity_html(0.84972, 0.0031)
    '0.8497 &plusmn; 3.1e-03'
    """
    from psdesign.geometry.porosity import porosity_text

    return porosity_text(porosity, error).replace(" +- ", " &plusmn; ")
