"""The error bar and the rating of one surrogate prediction (``study predict``).

The GP's own standard deviation is overconfident between a grid's levels: on Kozeny-Carman
truth (3 porosities x 2 diameters, 2 seeds; 5 x 3 levels, 1 seed) it held the truth within two
standard deviations at only 21 % / 42 % of a 41 x 41 grid of the box (session 43). A
prediction's bar is therefore never smaller than what the fit measured by holding cases out,
and which figure depends on where the prediction is (session 44):

* inside the fitted box, of a fit its own rating trusts: the estimated error between the
  study's design points (:func:`~psdesign.analysis.surrogate.between_level_error`: the error
  at the levels plus the inner-level error scaled to the study's spacing);
* outside the box (``extrapolated``), or of a fit rated ``untrustworthy``: the largest
  hold-out error the fit measured (:func:`holdout_error`: the cross-validated error and, on a
  grid, the error with each inner level held out), the session-43 bar.

A prediction inside whose between-level error exceeds
:data:`~psdesign.flow.error.UNTRUSTWORTHY_REL_ERROR` is ``untrustworthy``.
"""

from __future__ import annotations

import math

import numpy as np

from psdesign.analysis.surrogate import Surrogate, holdout_figure


def holdout_error(s: Surrogate) -> tuple[float, str]:
    """The largest relative hold-out error the fit measured and its words, ``(nan, "")``
    without one (one design point).

    >>> from types import SimpleNamespace as S
    >>> holdout_error(S(cv_rel_error=0.0065, cv_level_rel_error=0.30))
    (0.3, 'error with each inner level held out')
    >>> holdout_error(S(cv_rel_error=0.02, cv_level_rel_error=float("nan")))
    (0.02, 'cross-validated error')
    """
    found = [holdout_figure(s, key) for key in ("cv_rel_error", "cv_level_rel_error")]
    found = [(v, words) for v, words in found if v == v]  # NaN: not measured
    return max(found) if found else (math.nan, "")


def bar_error(s: Surrogate, inside=True) -> tuple[float, str]:
    """The relative hold-out figure a prediction's bar is never below, and its words: the
    estimated error between the design points (``cv_between_rel_error``) for a prediction
    ``inside`` the fitted box of a fit rated ``ok``, else the largest measured hold-out error
    (:func:`holdout_error`: outside the box, an untrustworthy fit, or a surrogate.json
    written before session 44).

    >>> from types import SimpleNamespace as S
    >>> s = S(cv_rel_error=0.0065, cv_level_rel_error=0.30, cv_between_rel_error=0.082,
    ...       rating=lambda: ("ok", []))
    >>> bar_error(s), bar_error(s, inside=False)[0]
    ((0.082, "estimated error between the study's design points"), 0.3)
    """
    between = holdout_figure(s, "cv_between_rel_error")
    if inside and between[0] == between[0] and s.rating()[0] == "ok":
        return between
    return holdout_error(s)


def holdout_bar(s: Surrogate, mean, inside=True):
    """The fit's hold-out figure (:func:`bar_error`) at a prediction ``mean`` (a number or an
    array of them), in the output's unit (0 without one): relative to the value for a
    log-modelled output (its relative error is ``10**rmse - 1``), to the cases' mean ``|y|``
    otherwise (how :func:`~psdesign.analysis.surrogate.fit_surrogate` made it relative)."""
    rel, _ = bar_error(s, inside)
    if rel != rel:
        return 0.0 * np.abs(mean)
    scale = np.abs(mean) if s.log_output else float(np.mean(np.abs(np.asarray(s.y, float))))
    return rel * scale


def prediction_bar(s: Surrogate, mean, gp_std, inside=True):
    """The bar of a prediction (a number, or arrays of them): the GP std ``gp_std``, never
    below the fit's hold-out figure for where it is (:func:`holdout_bar`: between the design
    points ``inside`` the fitted box, the largest hold-out error outside it), the one rule of
    ``study predict``'s printed ``+-`` and the report's response surface (its band and its
    relative uncertainty; the GP std alone, session 43).

    >>> from types import SimpleNamespace as S
    >>> s = S(cv_rel_error=0.02, cv_level_rel_error=0.3, log_output=True, y=[1.0])
    >>> prediction_bar(s, np.array([2.0, 4.0]), np.array([1.0, 0.5])).tolist()
    [1.0, 1.2]
    """
    return np.maximum(gp_std, holdout_bar(s, mean, inside))


def holdout_reason(s: Surrogate) -> str:
    """Why a prediction of ``s`` inside its box is untrustworthy by the fit's estimated error
    between the design points (the inner-level error in a surrogate.json written before
    session 44), or ``""``: it exceeds :data:`~psdesign.flow.error.UNTRUSTWORTHY_REL_ERROR`
    (the cross-validated error is in the fit's own rating,
    :meth:`~psdesign.analysis.surrogate.Surrogate.rating`)."""
    from psdesign.flow.error import UNTRUSTWORTHY_REL_ERROR

    lv, words = holdout_figure(s, "cv_between_rel_error")
    if lv != lv:  # a surrogate.json written before session 44
        lv, words = holdout_figure(s, "cv_level_rel_error")
    if not lv > UNTRUSTWORTHY_REL_ERROR:  # NaN: no such figure
        return ""
    return (
        f"{s.output}: the fit's {words} is {100 * lv:.3g} %, above "
        f"{100 * UNTRUSTWORTHY_REL_ERROR:g} %: between the study's levels it may be off by "
        "that much; run more levels"
    )


def fit_status(s: Surrogate) -> tuple[str, list[str]]:
    """``(status, reasons)`` of a fit as every command and the report give it: its
    :meth:`~psdesign.analysis.surrogate.Surrogate.rating`, and ``untrustworthy`` also when
    its estimated error between the design points is too wide (:func:`holdout_reason`), as
    `study predict` rates each prediction inside the box. Until session 53 `study fit`,
    `study sensitivity` and the report said ``[ok]`` of a 3 x 3 grid with 10 % seed scatter
    whose every prediction `study predict` rated untrustworthy (27.3 % between the levels)."""
    status, why = s.rating()
    held = holdout_reason(s) if status == "ok" else ""
    return ("untrustworthy", [held]) if held else (status, why)


def bar_text(row: dict) -> str:
    """What a prediction's ``+-`` is, after the value: the GP std, or the fit's hold-out
    error where that is larger, then the cross-validated error.

    >>> bar_text({"std": 0.3, "gp_std": 0.1, "error_from": "error with each inner level "
    ...           "held out", "holdout_rel_error": 0.3, "cv_rel_error": 0.01})
    "the fit's error with each inner level held out, 30 %; GP std 0.1; cross-validated error 1 %"
    """
    cv = row["cv_rel_error"]
    cv = "no cross-validated error" if cv != cv else f"cross-validated error {100 * cv:.3g} %"
    if row["error_from"] == "GP std":
        return f"GP std; {cv}"
    head = f"the fit's {row['error_from']}, {100 * row['holdout_rel_error']:.3g} %"
    if row["error_from"] == "cross-validated error":
        return f"{head}; GP std {row['gp_std']:.2g}"
    return f"{head}; GP std {row['gp_std']:.2g}; {cv}"
