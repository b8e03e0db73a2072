"""Global sensitivity of a surrogate: Sobol first-order and total indices (Saltelli sampling)
and Morris elementary effects, both with SALib.

The indices are those of the surrogate's mean over the parameter box (uniform in the scaled
inputs, i.e. log-uniform for log-scaled parameters). Confidence intervals are SALib's bootstrap
95 % intervals. A parameter that held one value in every fitted case
(:meth:`~psdesign.analysis.surrogate.Surrogate.fixed_inputs`) is held at that value and gets
no index: the cases say nothing about it (varied over its box, the GP's prior alone once made
such a parameter the "most influential" one, S1 0.59, of a study that never changed it).
No index at all is computed (:func:`no_indices_reason`) for an output that did not vary beyond
the fit's error (:meth:`~psdesign.analysis.surrogate.Surrogate.flat_output`: the indices would
be those of noise, S_T 0.92 of a constant), nor when parameters moved together over the
fitted cases (:mod:`psdesign.analysis.entangled`; a csv design with b = 2 a: the cases cannot
tell their effects apart, yet the GP split them 0.50 / 0.50 over a box the cases never filled).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from psdesign.analysis.entangled import entangled, tied_to_axes
from psdesign.analysis.surrogate import MIN_DESIGN_POINTS, Surrogate, from_unit, to_unit


def _varied(s: Surrogate) -> list[str]:
    """The parameters whose indices are computed (those not fixed in the fitted cases)."""
    fixed = s.fixed_inputs()
    return [p for p in s.params if p not in fixed]


def _unit_points(s: Surrogate) -> np.ndarray:
    """The distinct fitted design points, scaled to the unit box (log10 where log-scaled)."""
    return to_unit(np.unique(np.asarray(s.x, dtype=float), axis=0), s.low, s.high, s.log_params)


def entangled_inputs(s: Surrogate, names: list[str], axes: list[str] | None = None) -> str:
    """:func:`~psdesign.analysis.entangled.entangled` over the fitted design points (scaled
    inputs) of ``names``: the rule of :func:`no_indices_reason`, also the report's for its
    response surface over ``axes``."""
    u = _unit_points(s)
    return entangled(u[:, [s.params.index(p) for p in names]], names, axes)


def tied_inputs(s: Surrogate, names: list[str], axes: list[str]) -> dict[str, tuple]:
    """:func:`~psdesign.analysis.entangled.tied_to_axes` over the fitted design points of
    ``names``, in scaled inputs (the unit box of :func:`~psdesign.analysis.surrogate.to_unit`):
    how a figure over ``axes`` holds each parameter that moved with another."""
    u = _unit_points(s)
    return tied_to_axes(u[:, [s.params.index(p) for p in names]], names, axes)


def no_indices_reason(s: Surrogate) -> str:
    """Why no sensitivity index of ``s`` means anything: no parameter varied, two design
    points only (:meth:`Surrogate.too_few_points`), the output did not vary beyond the fit's
    error (:meth:`Surrogate.flat_output`), or a group of parameters moved together
    (:func:`~psdesign.analysis.entangled.entangled_groups`); ``""`` when they mean something."""
    names = _varied(s)
    if not names:
        held = ", ".join(f"{p} = {v:g}" for p, v in s.fixed_inputs().items())
        return f"no design parameter varied among the fitted cases ({held})"
    return s.too_few_points() or s.flat_output() or entangled_inputs(s, names)


def few_levels(s: Surrogate) -> str:
    """What to do when a varied parameter had fewer than ``MIN_DESIGN_POINTS`` (3) values
    among the fitted cases, or ``""``: the one line `study sensitivity` (text and JSON
    ``advice``) and the report give beside the indices.

    A 2 x 2 factorial passes :meth:`~psdesign.analysis.surrogate.Surrogate.too_few_points`
    (four design points) and gets indices, but along a two-level parameter the fit sees a
    straight line between two values: no curvature, no interaction it can check (on
    Kozeny-Carman truth its cross-validated error was 78.5 %, its error between the levels
    129 % RMS; session 43), and "untrustworthy" alone did not say what to run.
    """
    x = np.asarray(s.x, dtype=float).reshape(-1, len(s.params))
    few = [p for p in _varied(s) if len(np.unique(x[:, s.params.index(p)])) < MIN_DESIGN_POINTS]
    if not few:
        return ""
    them = "it" if len(few) == 1 else "them"
    return (
        f"{s.output}: {', '.join(few)} had 2 levels among the fitted cases, so the indices see "
        f"no curvature along {them}; run {MIN_DESIGN_POINTS} or more levels per parameter"
    )


def _problem(s: Surrogate) -> dict:
    why = no_indices_reason(s)
    if why:
        raise ValueError(f"{s.output}: no sensitivity indices: {why}")
    names = _varied(s)
    return {"num_vars": len(names), "names": names, "bounds": [[0.0, 1.0]] * len(names)}


def _unscale(s: Surrogate, u: np.ndarray) -> np.ndarray:
    """Surrogate inputs (all of ``s.params``) from unit samples of the varied parameters;
    the fixed ones at their value (a fitted case's, which every case shares)."""
    cols = [s.params.index(p) for p in _varied(s)]
    x = np.tile(np.asarray(s.x, dtype=float)[0], (len(u), 1))
    x[:, cols] = from_unit(u, *([v[i] for i in cols] for v in (s.low, s.high, s.log_params)))
    return x


def _model_output(s: Surrogate, x: np.ndarray) -> np.ndarray:
    m, _ = s.predict(x)
    return np.log10(m) if s.log_output else m


def sobol_indices(s: Surrogate, n: int = 1024, seed: int = 0) -> pd.DataFrame:
    """Sobol S1, ST and their 95 % confidence half-widths per parameter.

    ``n`` is the base sample size (a power of two); the surrogate is evaluated
    ``n * (2 d + 2)`` times. For log outputs the indices are of ``log10(output)``. The same
    ``seed`` gives the same indices and intervals (the sample and SALib's bootstrap).
    """
    from SALib.analyze import sobol
    from SALib.sample import sobol as sobol_sample

    prob = _problem(s)
    u = sobol_sample.sample(prob, n, calc_second_order=True, seed=seed)
    y = _model_output(s, _unscale(s, u))
    # SALib seeds its bootstrap only for a truthy seed (`if seed:`): seed 0 would leave the
    # confidence intervals to numpy's unseeded generator, different on every run
    r = sobol.analyze(prob, y, calc_second_order=True, seed=seed + 1)
    return pd.DataFrame(
        {
            "parameter": prob["names"],
            "S1": r["S1"],
            "S1_conf": r["S1_conf"],
            "ST": r["ST"],
            "ST_conf": r["ST_conf"],
        }
    )


def morris_screening(s: Surrogate, trajectories: int = 50, seed: int = 0) -> pd.DataFrame:
    """Morris mu* (mean |elementary effect|, in scaled-input units), its 95 % CI, and sigma."""
    from SALib.analyze import morris
    from SALib.sample import morris as morris_sample

    prob = _problem(s)
    u = morris_sample.sample(prob, trajectories, num_levels=4, seed=seed)
    y = _model_output(s, _unscale(s, u))
    r = morris.analyze(prob, u, y, num_levels=4, seed=seed)
    return pd.DataFrame(
        {
            "parameter": prob["names"],
            "mu_star": r["mu_star"],
            "mu_star_conf": r["mu_star_conf"],
            "sigma": r["sigma"],
        }
    )
