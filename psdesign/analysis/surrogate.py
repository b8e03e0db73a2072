"""Gaussian-process surrogates of study outputs over the design parameters (scikit-learn).

Inputs are scaled to [0, 1] by the parameter bounds (log10 first for log-uniform parameters);
strictly positive outputs spanning more than a factor of 3 (permeabilities) are modelled as
log10. The kernel is ``C * Matern(nu=2.5, one length scale per parameter) + White`` with
``normalize_y``; its fitted hyper-parameters and the training data are saved as JSON (portable,
no pickle), and :meth:`Surrogate.from_dict` rebuilds the same predictor by refitting with the
optimizer off. The cross-validated error (k-fold over design points, k = min(5, points);
replicates of a point share a fold; a design of two or more varying parameters without an
inner level shared by two points refits the kernel per fold; a one-parameter design of 3 or
more points keeps the full fit's, each inner point held out as a level) is stored with each
model.
"""

from __future__ import annotations

import json
import math
from collections.abc import Collection
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from psdesign.analysis.columns import (
    ERROR_COLUMNS,
    distinct_realizations,
    numeric_parameters,
    output_columns,
    study_parameters,
    trusted,
)

SURROGATE_FILE = "surrogate.json"
#: Bounds of the Matern kernel's length scales (inputs scaled to [0, 1]).
LENGTH_SCALE_BOUNDS = (1e-2, 1e2)
#: Distinct design points a fit needs before its cross-validated error says anything: with
#: two, each is predicted from the other alone (:meth:`Surrogate.too_few_points`).
MIN_DESIGN_POINTS = 3
#: Design points per varied parameter below which `study fit` and `study sensitivity` warn
#: (:meth:`Surrogate.sparse_design`).
MIN_POINTS_PER_PARAMETER = 4
#: Fewest finished cases with a trusted value :func:`fit_surrogate` fits from: the one number
#: of its refusal, `study optimize`'s "cannot fit" and the report's note (which spelled "3").
MIN_FIT_CASES = 3


#: The fit's hold-out figures (attributes of :class:`Surrogate`) and their words: the one
#: wording of `study fit`'s print (:meth:`Surrogate.level_error_text`), `study predict`'s
#: text and JSON (``error_from``, :mod:`psdesign.analysis.prediction`) and the report; until
#: session 45 `study fit` said "8.2 % estimated between the design points" of the figure
#: `study predict` called "estimated error between the study's design points".
HOLDOUT_WORDS = {
    "cv_rel_error": "cross-validated error",
    "cv_level_rel_error": "error with each inner level held out",
    "cv_between_rel_error": "estimated error between the study's design points",
}


def holdout_figure(s, key: str) -> tuple[float, str]:
    """``(relative error, words)`` of the hold-out figure ``key`` of :data:`HOLDOUT_WORDS`
    kept by ``s`` (a :class:`Surrogate`); NaN where not measured (or absent: a surrogate.json
    written before the figure existed).

    >>> from types import SimpleNamespace as S
    >>> holdout_figure(S(cv_rel_error=0.02), "cv_rel_error")
    (0.02, 'cross-validated error')
    """
    return float(getattr(s, key, math.nan)), HOLDOUT_WORDS[key]


def _box(low, high, log) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    lo, hi, lg = np.asarray(low, float), np.asarray(high, float), np.asarray(log, bool)
    lo = np.where(lg, np.log10(np.where(lg, lo, 1.0)), lo)
    hi = np.where(lg, np.log10(np.where(lg, hi, 1.0)), hi)
    return lo, np.where(hi > lo, hi - lo, 1.0), lg


def to_unit(x: np.ndarray, low, high, log) -> np.ndarray:
    """Map points (n, d) of the parameter box to [0, 1]^d (log10 first where ``log``)."""
    lo, span, lg = _box(low, high, log)
    x = np.asarray(x, dtype=float)
    return (np.where(lg, np.log10(np.where(lg, x, 1.0)), x) - lo) / span


def from_unit(u: np.ndarray, low, high, log) -> np.ndarray:
    """Inverse of :func:`to_unit`; a degenerate range (``low == high``) maps every ``u`` to
    ``low`` (never outside the range)."""
    lo, span, lg = _box(low, high, log)
    span = np.where(np.asarray(high, float) > np.asarray(low, float), span, 0.0)
    x = lo + np.asarray(u, dtype=float) * span
    # 10**x only where log: a linear parameter of 1000-5000 (an int) overflowed in the unused
    # branch and printed numpy's "overflow encountered in power" to the user
    return np.where(lg, 10.0 ** np.where(lg, x, 0.0), x)


@dataclass
class Surrogate:
    """A fitted GP for one output.

    Attributes
    ----------
    output : str
    params : list of str
        Design parameters, in input order.
    low, high : list of float
        Bounds used to scale each parameter to [0, 1].
    log_params : list of bool
        Parameter scaled in log10.
    log_output : bool
        The GP models ``log10(output)``.
    kernel : dict
        Fitted hyper-parameters: ``constant``, ``length_scale`` (list), ``noise``.
    x, y : list
        Training inputs (original units) and outputs (original units).
    cv_rmse : float
        k-fold cross-validated RMSE in the modelled space (log10 units for log outputs).
    cv_rel_error : float
        The same as a relative error of the output (``10**rmse - 1`` for log outputs, RMSE /
        mean |y| otherwise).
    cv_level_rel_error : float
        The relative error with each inner level of a grid parameter held out
        (:func:`inner_level_error`; NaN when no parameter's inner level is shared by two or
        more design points, e.g. a latin-hypercube design).
    cv_between_rel_error : float
        The estimated relative error between the study's design points, the bar of a
        prediction inside the box (:func:`between_level_error`; NaN in a surrogate.json
        written before session 44).
    pooled : list of str
        Design parameters that are no input of the fit (not numeric: a whole-table level such
        as ``generator = [{kind = "straight", ...}, {kind = "bent", ...}]``) and took more
        than one value among the fitted cases: the fit mixes their levels (:meth:`rating`).
    """

    output: str
    params: list[str]
    low: list[float]
    high: list[float]
    log_params: list[bool]
    log_output: bool
    kernel: dict
    x: list[list[float]]
    y: list[float]
    cv_rmse: float = math.nan
    cv_rel_error: float = math.nan
    cv_level_rel_error: float = math.nan
    cv_between_rel_error: float = math.nan
    pooled: list[str] = field(default_factory=list)
    _gp: object = field(default=None, repr=False, compare=False)

    def fixed_inputs(self) -> dict[str, float]:
        """Parameters that held one value in every fitted case, ``{name: value}``.

        The cases say nothing about how the output moves with them: no sensitivity index is
        computed for them (:mod:`psdesign.analysis.sensitivity`), and a prediction at another
        value is an extrapolation (:func:`outside_range`).
        """
        x = np.asarray(self.x, dtype=float).reshape(-1, len(self.params))
        return {p: float(x[0, i]) for i, p in enumerate(self.params) if np.ptp(x[:, i]) == 0}

    def too_few_points(self) -> str:
        """Why the fitted cases cannot rate the fit: two design points (``""`` otherwise).

        The cross-validation holds out the replicates of one design point and predicts them
        from the other alone, which no fit can: its error is the output's change between the
        two points, not noise. Before session 42 a two-level study (porosity 0.849 / 0.902
        over three seeds each) read "follows no trend between the cases" and, in `study
        sensitivity`, "varies no more than the fit's cross-validated error ... constant to
        within noise". One design point has its own word (NaN error, :meth:`rating`).
        """
        x = np.asarray(self.x, dtype=float).reshape(-1, len(self.params))
        n = len(np.unique(x, axis=0))
        if not 1 < n < MIN_DESIGN_POINTS:
            return ""
        return (
            f"only {n} design points among the fitted cases: the cross-validation predicts "
            "the one held out from the other alone, so its error is the output's change "
            f"between them, not the fit's; run {MIN_DESIGN_POINTS} or more levels"
        )

    def sparse_design(self) -> str:
        """A warning when the fitted cases hold fewer than :data:`MIN_POINTS_PER_PARAMETER`
        design points per varied parameter, or ``""``: a fit of 5 points over 3 parameters
        rated ``ok`` on an 11.3 % cross-validated error (24 % with each fold's kernel fitted
        again; session 53) says little between them."""
        x = np.asarray(self.x, dtype=float).reshape(-1, len(self.params))
        n, varied = len(np.unique(x, axis=0)), _varying(self)
        if varied == 0 or n >= MIN_POINTS_PER_PARAMETER * varied:
            return ""
        return (
            f"{self.output}: {n} design points for {varied} varied parameters (fewer than "
            f"{MIN_POINTS_PER_PARAMETER} per parameter): the fit and its cross-validated error "
            f"rest on few cases; run {MIN_POINTS_PER_PARAMETER * varied} or more"
        )

    def flat_output(self) -> str:
        """Why the fitted cases show no variation of the output to rank parameters by, or
        ``""``.

        The output held one value in every fitted case, or it varied no more than the fit's
        cross-validated error (RMSE >= the cases' standard deviation, in the modelled space:
        the fit predicts a design it has not seen no better than the cases' mean, Q^2 <= 0).
        Sensitivity indices of such a fit are those of its noise (:mod:`~psdesign.analysis.
        sensitivity` computes none).
        """
        y = self._target(np.asarray(self.y, dtype=float))
        if np.ptp(y) == 0:
            return f"{self.output} = {self.y[0]:g} in every fitted case"
        spread = float(np.std(y))
        if not self.cv_rmse < spread:
            space = "log10 " if self.log_output else ""
            return (
                f"{self.output} varies no more than the fit's cross-validated error "
                f"({space}std {spread:.3g} over the cases, RMSE {self.cv_rmse:.3g}): "
                "constant to within noise"
            )
        return ""

    def pooled_text(self) -> str:
        """Why a fit over cases that differ in a parameter it has no input for is not trusted
        (:attr:`pooled`), or ``""``.

        Its cases at one numeric point but another level (a straight and a bent generator)
        are read as scatter: a prediction is neither level's value. Until session 53 the fit
        kept the first level's cases only, rated ``ok`` (8 cases of 2 generators x 4
        ``flow.aux_length``: "GP over flow.aux_length from 4 cases", the straight values).
        """
        if not self.pooled:
            return ""
        return (
            f"{self.output}: the fitted cases differ in {', '.join(self.pooled)}, which is not "
            "numeric and no input of the fit: it mixes their levels (a prediction is none of "
            "theirs); run a study per level"
        )

    def level_error_text(self) -> str:
        """``", error with each inner level held out 30.2 %, estimated error between the
        study's design points 8.2 %"`` after the cross-validated error of a grid design's fit
        (:func:`inner_level_error`, :func:`between_level_error`: the figure `study predict`'s
        bar is never under inside the box, :func:`psdesign.analysis.prediction.holdout_bar`),
        ``""`` where there is none: `study fit`'s print and the report, in the words of
        :data:`HOLDOUT_WORDS` (`study predict`'s too).

        >>> from types import SimpleNamespace as S
        >>> s = S(cv_level_rel_error=0.302, cv_between_rel_error=0.082)
        >>> for part in Surrogate.level_error_text(s).split(", ")[1:]:
        ...     print(part)
        error with each inner level held out 30.2 %
        estimated error between the study's design points 8.2 %
        >>> Surrogate.level_error_text(S(cv_level_rel_error=float("nan")))
        ''
        """
        figures = (holdout_figure(self, k) for k in ("cv_level_rel_error", "cv_between_rel_error"))
        return "".join(f", {words} {100 * v:.3g} %" for v, words in figures if v == v)

    # -------------------------------------------------------------- transforms
    def _scale(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float).reshape(-1, len(self.params))
        return to_unit(x, self.low, self.high, self.log_params)

    def _target(self, y: np.ndarray) -> np.ndarray:
        y = np.asarray(y, dtype=float)
        return np.log10(y) if self.log_output else y

    # -------------------------------------------------------------- model
    def _regressor(self, fixed: bool, noise: float = 1e-4, restarts: int = 3):
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

        k = self.kernel
        kern = ConstantKernel(k.get("constant", 1.0), (1e-3, 1e3)) * Matern(
            length_scale=k.get("length_scale", [0.5] * len(self.params)),
            length_scale_bounds=LENGTH_SCALE_BOUNDS,
            nu=2.5,
        ) + WhiteKernel(k.get("noise", noise), (1e-8, 1e0))
        return GaussianProcessRegressor(
            kernel=kern,
            normalize_y=True,
            optimizer=None if fixed else "fmin_l_bfgs_b",
            n_restarts_optimizer=0 if fixed else restarts,
            random_state=0,
        )

    def _fit(self) -> None:
        import warnings

        from sklearn.exceptions import ConvergenceWarning

        fixed = bool(self.kernel)
        x, y = self._scale(np.asarray(self.x)), self._target(np.asarray(self.y))
        with warnings.catch_warnings():  # a hyper-parameter on its bound is fine here
            warnings.simplefilter("ignore", ConvergenceWarning)
            gp = self._regressor(fixed).fit(x, y)
            if not fixed:
                # from a start of little noise the restarts can all fall where a length
                # scale sits on its lower bound (each case interpolated, flat between them)
                # though a trend fits better (session 50: a porosity study, log likelihood
                # -2.614 there, -2.437 at length 1.0): one more start with a tenth of the
                # variance as noise, the likelier fit kept (its restarts would repeat the
                # first fit's: sklearn draws them from random_state=0 and the same bounds)
                alt = self._regressor(False, noise=0.1, restarts=0).fit(x, y)
                if alt.log_marginal_likelihood_value_ > gp.log_marginal_likelihood_value_:
                    gp = alt
        if not self.kernel:
            kp = gp.kernel_.get_params()
            self.kernel = {
                "constant": float(kp["k1__k1__constant_value"]),
                "length_scale": np.atleast_1d(kp["k1__k2__length_scale"]).astype(float).tolist(),
                "noise": float(kp["k2__noise_level"]),
            }
        self._gp = gp

    def rating(self) -> tuple[str, list[str]]:
        """``(status, warnings)`` of the fit: ``untrustworthy`` when its cross-validated error
        is above :data:`psdesign.flow.error.UNTRUSTWORTHY_REL_ERROR` (the rule every value of
        psdesign follows), a length scale sits on its lower bound (the fit then interpolates
        each case and is flat between them: predictions inside the range equal those far
        outside it), its cases pool the levels of a non-numeric parameter it has no input for
        (:attr:`pooled`, :meth:`pooled_text`: a prediction is none of theirs; since session
        53), there is no cross-validated error (one design point) or too few design points
        (:meth:`too_few_points`), else ``ok``."""
        from psdesign.flow.error import UNTRUSTWORTHY_REL_ERROR

        few = self.too_few_points()
        if few:
            return "untrustworthy", [f"{self.output}: {few}"]
        warnings = [self.pooled_text()] if self.pooled else []
        if math.isnan(self.cv_rel_error):
            warnings.append(
                f"{self.output}: no cross-validated error: every fitted case is at one design "
                "point (nothing to hold out); vary a parameter"
            )
        elif not self.cv_rel_error <= UNTRUSTWORTHY_REL_ERROR:
            warnings.append(
                f"{self.output}: cross-validated error {100 * self.cv_rel_error:.3g} % exceeds "
                f"{100 * UNTRUSTWORTHY_REL_ERROR:g} %"
            )
        low = LENGTH_SCALE_BOUNDS[0] * (1.0 + 1e-6)
        for name, ls in zip(self.params, self.kernel.get("length_scale", []), strict=False):
            if ls <= low:
                warnings.append(
                    f"{self.output}: the fit's length scale along {name} is on its lower bound "
                    f"({LENGTH_SCALE_BOUNDS[0]:g} of the range): it follows no trend between the "
                    "cases; run more cases"
                )
        return ("untrustworthy" if warnings else "ok"), warnings

    def predict_modelled(self, x: np.ndarray | list) -> tuple[np.ndarray, np.ndarray]:
        """Mean and standard deviation at points ``x`` in the modelled space (log10 for log
        outputs).

        An output that held one value ``y0`` in every case has its std scaled by ``|y0|``
        (1 for 0): scikit-learn's ``normalize_y`` divides by the cases' std and, that being 0,
        by 1, so the std came out in absolute units of the output (K = 1e-11 m^2 in every
        case was predicted ``1e-11 +- 1.1e-4`` m^2).
        """
        if self._gp is None:
            self._fit()
        m, s = self._gp.predict(self._scale(np.asarray(x, dtype=float)), return_std=True)
        y = self._target(np.asarray(self.y, dtype=float))
        if np.ptp(y) == 0:
            s = s * (abs(float(y[0])) or 1.0)
        return m, s

    def predict(self, x: np.ndarray | list) -> tuple[np.ndarray, np.ndarray]:
        """Mean and standard deviation at points ``x`` (n, n_params), original units.

        For log outputs the mean is ``10**m`` (the median) and the std is that of the
        log-normal, ``10**m * sqrt(exp(s^2 ln(10)^2) - 1)``.
        """
        m, s = self.predict_modelled(x)
        if not self.log_output:
            return m, s
        ln10 = math.log(10.0)
        return 10.0**m, 10.0**m * np.sqrt(np.expm1((s * ln10) ** 2))

    def to_dict(self) -> dict:
        d = asdict(self)
        d.pop("_gp")
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Surrogate:
        """The surrogate :meth:`to_dict` saved; a cross-validated error saved as ``null`` (JSON
        has no NaN: no error could be computed) reads back as NaN."""
        s = cls(**{k: v for k, v in d.items() if k != "_gp"})
        keys = ("cv_rmse", "cv_rel_error", "cv_level_rel_error", "cv_between_rel_error")
        for key in keys:
            if getattr(s, key) is None:
                setattr(s, key, math.nan)
        return s


def design_point_folds(x: np.ndarray, k_max: int = 5) -> tuple[np.ndarray, int]:
    """Cross-validation fold of each row of ``x`` (n, d), and the number of folds.

    Rows with the same design point (replicates that differ only in the seed) share a fold:
    a held-out case whose replicate stays in the training set is predicted from its own
    twin, and the error quoted is then the seed-to-seed scatter, not the error at a new
    design (a 2-seed study quoted 1 % where the real error at new points was 17 %). Points are
    numbered in order of first appearance and dealt round-robin into ``min(k_max, points)``
    folds (a one-seed study keeps its row-by-row folds).

    Examples
    --------
    >>> design_point_folds(np.array([[0.0], [0.0], [1.0], [1.0], [2.0]]), k_max=2)
    (array([0, 0, 1, 1, 0]), 2)
    """
    _, first, point = np.unique(x, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=int)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    k = min(k_max, len(first))
    return rank[np.ravel(point)] % max(k, 1), k


def _held_out_errors(s: Surrogate, test: np.ndarray, refit: bool = False) -> np.ndarray:
    """Errors (modelled space) at the rows ``test`` of a fit of the other rows, with ``s``'s
    hyper-parameters, or (``refit``) those optimized again from them on the other rows alone
    (:func:`_refit`; the cross-validation of a design without inner levels,
    :func:`_fold_errors`)."""
    x, y = np.asarray(s.x, float), np.asarray(s.y, float)
    sub = Surrogate(
        s.output,
        s.params,
        s.low,
        s.high,
        s.log_params,
        s.log_output,
        dict(s.kernel),
        x[~test].tolist(),
        y[~test].tolist(),
    )
    if refit:
        sub._gp = _refit(sub)
    m, _ = sub.predict(x[test])
    return s._target(m) - s._target(y[test])


def _refit(s: Surrogate):
    """The GP of ``s``'s cases with its kernel's hyper-parameters optimized again from
    ``s.kernel`` (one local search, no restarts: a held-out fold's fit)."""
    import warnings

    from sklearn.exceptions import ConvergenceWarning

    x, y = s._scale(np.asarray(s.x)), s._target(np.asarray(s.y))
    with warnings.catch_warnings():  # a hyper-parameter on its bound is fine here
        warnings.simplefilter("ignore", ConvergenceWarning)
        return s._regressor(False, restarts=0).fit(x, y)


def _rmse_and_rel(s: Surrogate, err: np.ndarray) -> tuple[float, float]:
    """RMSE of held-out errors and the same as a relative error of the output."""
    rmse = float(np.sqrt(np.mean(err**2)))
    scale = float(np.mean(np.abs(np.asarray(s.y, float))))
    if s.log_output:
        rel = 10.0**rmse - 1.0
    elif scale > 0:
        rel = rmse / scale
    else:  # 0 in every case (an off-diagonal K of a symmetric geometry): ZeroDivisionError
        rel = 0.0 if rmse == 0 else math.inf
    return rmse, float(rel)


def _fold_errors(s: Surrogate) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The design-point cross-validation, row by row: each case's held-out error (modelled
    space), whether its design point kept every one of its levels in the rest of the cases
    (a grid's point: predicted *at* the study's levels), and whether it lay inside the box of
    the rest (interpolated, not extrapolated); None with fewer than two folds."""
    x = np.asarray(s.x, float).reshape(-1, len(s.params))
    folds, k = design_point_folds(x)
    if k < 2:
        return None
    # No parameter with an inner level shared by two design points (_inner_level_columns: a
    # latin hypercube, a csv design of scattered values, a 2 x 2 or 2 x 2 x 2 grid): the
    # held-out cases had shaped the length scales that predicted them, so each fold's are
    # fitted again; on 6 points of Kozeny-Carman truth (design seed 3) the error read 1.59 %
    # where the refit gives 55.6 %, and 11.3 % for 24 % on 5 points over 3 parameters, the
    # truth 4-5 bars away (walk-design, session 53). With one (a grid of 3+ levels, a latin
    # hypercube whose discrete parameter repeats an inner value) the full fit's are kept:
    # inner_level_error holds out whole levels for the error between the points, and a refit
    # of 3 x 2 Kozeny-Carman levels less one read 59 % for a fit off by 3.3 % RMS. The rule
    # is by that estimate, not by the design's name: a 2 x 2 grid has none, and a design of
    # one varying parameter with 3 or more points has one (each inner point is a level held
    # out, scattered or not: review s53).
    refit = not _inner_level_columns(s)
    err = np.empty(len(s.y))
    kept, inside = np.zeros(len(s.y), bool), np.zeros(len(s.y), bool)
    for f in range(k):
        test = folds == f
        err[test] = _held_out_errors(s, test, refit)
        rest = x[~test]
        kept[test] = [all((rest[:, j] == v).any() for j, v in enumerate(r)) for r in x[test]]
        inside[test] = np.all((x[test] >= rest.min(0)) & (x[test] <= rest.max(0)), axis=1)
    return err, kept, inside


def inner_level_error(s: Surrogate) -> float:
    """Relative error of the fit with each inner level of a grid parameter held out, or NaN.

    In a grid (full-factorial) design the held-out design point of the cross-validation
    (:func:`_fold_errors`) keeps its levels in the training set through its neighbours along
    the other parameters, so that error is the error *at* the study's levels, never between
    them: on Kozeny-Carman truth (3 porosities x 2 diameters, 2 seeds) it read 0.65 % where
    the fit is off by 3.3 % (RMS, 6.1 % at most) between the levels. Holding out a whole inner
    level (every case at it; the end levels would be extrapolation) predicts across twice the
    levels' spacing: 30 % there, 2.1 % on 5 x 3 levels (true error between levels 0.55 % RMS,
    1.35 % at most): an upper estimate of the error between levels (session 43), scaled to the
    study's own spacing by :func:`between_level_error`. A 1-D design's inner levels are one
    design point each (held out one by one since session 44: 2.75 % on 5 porosities, where
    the cross-validation's 8.4 % is mostly the two end points, extrapolated when held out).
    NaN when no parameter has an inner level (a latin hypercube: no level is shared).
    """
    held = _inner_level_errors(s)
    return math.nan if held is None else _rmse_and_rel(s, np.concatenate([e for e, _ in held]))[1]


def _inner_level_errors(s: Surrogate) -> list[tuple[np.ndarray, float]] | None:
    """The held-out errors (modelled space) of :func:`inner_level_error`, one array per inner
    level held out, each with its spacing factor (:func:`_spacing_factor`); None without."""
    x = np.asarray(s.x, float).reshape(-1, len(s.params))
    points = np.unique(x, axis=0)
    unit = to_unit(points, s.low, s.high, s.log_params)  # the fit's own coordinates
    out: list[tuple[np.ndarray, float]] = []
    for j in _inner_level_columns(s):
        levels = np.unique(points[:, j])
        at = np.unique(unit[:, j])
        out += [
            (_held_out_errors(s, x[:, j] == v), _spacing_factor(at, i))
            for i, v in enumerate(levels[1:-1], start=1)
        ]
    return out or None


def _inner_level_columns(s: Surrogate) -> list[int]:
    """The parameters (columns of ``s.x``) with an inner level shared by two or more design
    points, or any inner level in a 1-D design: the grid's of :func:`inner_level_error`."""
    points = np.unique(np.asarray(s.x, float).reshape(-1, len(s.params)), axis=0)
    # a parameter held at one level (``levels = 1``) adds no dimension: 5 porosities x 1
    # diameter is a 1-D design (its inner levels one point each), as 5 porosities alone
    varying = _varying(s)
    out = []
    for j in range(points.shape[1]):
        levels, counts = np.unique(points[:, j], return_counts=True)
        if len(levels) >= 3 and (counts[1:-1].max() >= 2 or varying <= 1):
            out.append(j)
    return out


def _varying(s: Surrogate) -> int:
    """How many parameters take more than one value among the fitted cases."""
    x = np.asarray(s.x, float).reshape(-1, len(s.params))
    return int(sum(np.ptp(x[:, j]) > 0 for j in range(x.shape[1])))


def _spacing_factor(levels: np.ndarray, i: int) -> float:
    """How much smaller the error between the study's levels is than the error with inner
    level ``i`` of ``levels`` (sorted, the fit's coordinates) held out: an interpolant at
    least as good as a piecewise-linear one errs as the spacing squared (h^2 / 8 max|f''|),
    and the held-out level was predicted across ``levels[i + 1] - levels[i - 1]``, so
    ``(widest gap / that span)^2``, at most 1. Equal spacing: 1/4 (the span is twice the
    gap). The widest gap of the parameter, not the level's own: on uneven levels (porosity
    0.7, 0.72, 0.9) the level's gaps are not where the fit errs most, and 1/4 held the
    Kozeny-Carman truth within 2 bars at 61 % of the box (s44 review)."""
    gaps = np.diff(levels)
    return float(min(1.0, (gaps.max() / (levels[i + 1] - levels[i - 1])) ** 2))


def between_level_error(s: Surrogate, folds) -> float:
    """The estimated relative error of the fit between its design points (the bar of a
    prediction inside the box, :func:`~psdesign.analysis.prediction.prediction_bar`), or NaN.

    With inner levels (a grid, or a 1-D design): the cross-validated error of the design
    points that kept every level when held out (the error *at* the levels: the cases'
    scatter and the fit's misfit there; 0 in 1-D) plus the worst of the inner-level hold-out
    errors (:func:`inner_level_error`'s, measured across twice the spacing; their RMS held the
    truth at only 88-93 % of a 1-D sweep, the curvature being largest at an end), each scaled
    to the study's widest gap by :func:`_spacing_factor` (1/4 for equal spacing). Without (a
    latin hypercube): the cross-validated error of the points inside the box of the rest
    (the ends of each parameter's range are extrapolated when held out). Never below the
    cross-validated error, save in 1-D. ``folds`` is :func:`_fold_errors`' result.

    Why (session 44): the larger of the cross-validated and the inner-level error, the bar
    until then, quoted an error across twice the spacing (a grid's inner level held out) or
    at the ends of the range (a 1-D design's end points, extrapolated when held out) for a
    prediction between the study's levels: 30 % on 3 x 2 levels of Kozeny-Carman truth where
    the fit is off by 6.1 % at most, 8.4 % on 5 porosities for 1.8 %.

    Why never below the cross-validated error (session 45): a bar under the error the fit
    made at a held-out design point is not honest, and on a scattered design the box's
    corners and faces lie outside the points' hull, where the fit extrapolates as it did for
    the held-out end points. On 96 latin hypercubes (8-30 points, seeds 1-8; Kozeny-Carman,
    Gebart, linear truth) the inside-points figure alone held the truth within 2 bars at
    76-93 % of the box on 9 of them (3 since, at 90-94 %; `benchmarks/RESULTS.md`, session
    45). A 1-D design's box ends are design points, so its cross-validated error (the two
    end points, extrapolated when held out: 8.4 % on 5 porosities) says nothing of a
    prediction inside.
    """
    if folds is None:
        return math.nan
    err, kept, inside = folds
    held = _inner_level_errors(s)
    if held is not None:
        at = _rmse_and_rel(s, err[kept])[1] if kept.any() else 0.0
        worst = max(_rmse_and_rel(s, np.abs(e).max(keepdims=True))[1] * f for e, f in held)
        if _varying(s) == 1:  # the box's two ends are design points: nothing extrapolates
            return at + worst
        return max(at + worst, _rmse_and_rel(s, err)[1])
    found = _rmse_and_rel(s, err[inside])[1] if inside.any() else math.nan
    return max(found, _rmse_and_rel(s, err)[1]) if found == found else math.nan


def fit_surrogate(
    df: pd.DataFrame,
    output: str,
    params: list[str],
    bounds: dict,
    others: Collection[str] = (),
) -> Surrogate:
    """Fit one output of a results table; ``bounds[p] = (low, high, log)``. Only trusted
    values are fitted (:func:`psdesign.analysis.columns.trusted`: ``ok`` cases, a K whose own
    status is ``untrustworthy`` or ``not_converged`` left out). ``others``: the study's other
    design parameters (not inputs: a whole-table level); a case repeats another only when
    they match too, and those that vary are kept in :attr:`Surrogate.pooled`."""
    others = [p for p in others if p in df.columns and p not in params]
    ok = distinct_realizations(trusted(df), [*params, *others])
    ok = ok[ok[output].notna()]
    if len(ok) < MIN_FIT_CASES:
        raise ValueError(
            f"{output}: need at least {MIN_FIT_CASES} finished cases with a trusted value to "
            f"fit, got {len(ok)}"
        )
    y = ok[output].to_numpy(float)
    log_out = bool(np.all(y > 0) and y.max() / y.min() > 3.0)
    s = Surrogate(
        output=output,
        params=list(params),
        low=[float(bounds[p][0]) for p in params],
        high=[float(bounds[p][1]) for p in params],
        log_params=[bool(bounds[p][2]) for p in params],
        log_output=log_out,
        kernel={},
        x=ok[params].to_numpy(float).tolist(),
        y=y.tolist(),
        pooled=[p for p in others if ok[p].astype(str).nunique() > 1],
    )
    s._fit()
    folds = _fold_errors(s)
    s.cv_rmse, s.cv_rel_error = (
        (math.nan, math.nan) if folds is None else _rmse_and_rel(s, folds[0])
    )
    s.cv_level_rel_error = inner_level_error(s)
    s.cv_between_rel_error = between_level_error(s, folds)
    return s


def log_parameters(spec: dict[str, dict]) -> set[str]:
    """The ``loguniform`` parameters of a study's ``parameters`` table: drawn, fitted (scaled
    in log10) and plotted on a log scale.

    >>> sorted(log_parameters({"a": {"dist": "loguniform"}, "b": {"dist": "uniform"}, "c": {}}))
    ['a']
    """
    return {p for p, info in spec.items() if (info or {}).get("dist") == "loguniform"}


def parameter_bounds(df: pd.DataFrame, params: list[str], spec: dict[str, dict]) -> dict:
    out = {}
    logs = log_parameters(spec)
    for p in params:
        info = spec.get(p, {})
        lo, hi = info.get("low"), info.get("high")
        if lo is None or hi is None:
            lo, hi = float(df[p].min()), float(df[p].max())
        out[p] = (lo, hi, p in logs)
    return out


def _check_parameter_cells(df: pd.DataFrame, params: list[str]) -> None:
    """Refuse (one-line ``ValueError``) a numeric parameter column with empty cells.

    The runner writes every parameter of every case; a hole comes from an edited table, and
    :func:`~psdesign.analysis.columns.numeric_parameters` would quietly drop the whole
    parameter from the fit (a 2-parameter study fitted over 1, its error unexplained).
    """
    for p in params:
        if p in df.columns and pd.api.types.is_numeric_dtype(df[p]) and df[p].isna().any():
            rows = [int(i) + 2 for i in np.flatnonzero(df[p].isna())]  # + header, 1-based
            raise ValueError(
                f"results.csv: parameter {p} is empty on line(s) "
                f"{', '.join(map(str, rows[:5]))}{' ...' if len(rows) > 5 else ''}; every "
                "case needs a number (the runner writes one; was the table edited?)"
            )


def default_fit_outputs(columns: list[str]) -> list[str]:
    """The outputs ``study fit`` fits without ``--outputs``: porosity, K and the transport
    values, not their error bars (:data:`~psdesign.analysis.columns.ERROR_COLUMNS`; a transport
    study's ``diffusivity_z_rel_error`` was fitted as an output).

    >>> default_fit_outputs(["porosity", "porosity_error", "k_z_m2", "k_z_rel_error",
    ...                      "diffusivity_z", "diffusivity_z_rel_error", "n_fibers"])
    ['porosity', 'k_z_m2', 'diffusivity_z']
    """
    return [
        c
        for c in columns
        if c not in ERROR_COLUMNS
        and (
            c == "porosity"
            or c.endswith("_m2")
            or c.startswith(("diffusivity_", "tortuosity_", "conductivity_"))
        )
    ]


def fit_study(
    out_dir: str | Path,
    outputs: list[str] | None = None,
    skipped: dict[str, str] | None = None,
) -> dict[str, Surrogate]:
    """Fit a surrogate per output of ``OUT/results.csv`` and save ``OUT/surrogate.json``.

    Every output that can be fitted is: one that cannot (fewer than 3 trusted values) is left
    out and its reason (``"k_z_m2: need at least 3 ..."``) put in ``skipped[name]``; a
    ``ValueError`` naming every reason when no output can be fitted (nothing is written).

    A ``surrogate.json`` that psdesign did not write (the folder's marker does not list it) is
    never replaced: :class:`psdesign.io.outputs.OutputError` (a ``ValueError``) before the fit.
    """
    from psdesign.io.outputs import claim_output_dir
    from psdesign.study.readback import read_results
    from psdesign.study.store import atomic_write_json, check_study_files, remove_dead_temp

    out = Path(out_dir)
    check_study_files(out, [SURROGATE_FILE], "study fit")
    spec = study_parameters(out)
    df = read_results(out)
    if df.empty:  # interrupted before its first case: not "no numeric parameter" (session 52)
        raise ValueError(
            f"out_dir: the study in {out} has no finished case yet (results.csv has no rows); "
            "run or resume it with `psdesign study run` first"
        )
    _check_parameter_cells(df, list(spec))
    params = numeric_parameters(df, list(spec))
    if not params:  # a GP needs a number per case on an axis: a category is no axis
        raise ValueError(
            f"out_dir: the study in {out} has no numeric design parameter to fit over "
            f"({', '.join(spec) or 'none'}: not a number in every case); allowed: a study "
            "with a numeric parameter (e.g. generator.porosity)"
        )
    bounds = parameter_bounds(df, params, spec)
    allowed = output_columns(df, params)
    names = outputs or default_fit_outputs(allowed)
    # every name before any fit; a design parameter, the seed or a text column is no output
    for name in names:
        if name not in allowed:
            raise ValueError(
                f"--outputs: {name!r} is not a numeric output of results.csv; "
                f"allowed: {', '.join(allowed)}"
            )
    models, reasons = {}, {}
    for name in names:
        try:
            models[name] = fit_surrogate(df, name, params, bounds, others=list(spec))
        except ValueError as exc:
            reasons[name] = " ".join(str(exc).split())
    if skipped is not None:
        skipped.update(reasons)
    if not models:
        raise ValueError(
            f"out_dir: no output of {out} could be fitted ({'; '.join(reasons.values())})"
        )
    claim_output_dir(check_study_files(out, [SURROGATE_FILE], "study fit"), [SURROGATE_FILE])
    remove_dead_temp(out / SURROGATE_FILE)
    atomic_write_json(
        out / SURROGATE_FILE,
        {
            "version": 1,
            "table": table_fingerprint(df),
            "models": {k: m.to_dict() for k, m in models.items()},
        },
    )
    return models


def table_fingerprint(df: pd.DataFrame) -> dict:
    """What ``surrogate.json`` records of the ``results.csv`` it was fitted on: the number of
    rows and the sha256 of its sorted ``case_id,status`` lines.

    A ``study run`` that adds cases (a grown design), re-runs failed or not_converged ones or
    finishes an interrupted run changes the ids or a status, so :func:`load_study_surrogates`
    tells a fit of an older table (walk-cli finding 2, session 52: ``study predict`` used a
    6-case fit, CV 77.8 %, after the study grew to 12 cases, whose refit gives 19.4 %). Cases
    are never recomputed with their status unchanged, so the pairs name the fitted data
    without the timing columns a rewrite may change.

    >>> t = table_fingerprint(pd.DataFrame({"case_id": ["b", "a"], "status": ["ok", "failed"]}))
    >>> t["n_cases"], t["sha256"][:12]
    (2, '50dd8aabb456')
    """
    import hashlib

    from psdesign.analysis.columns import case_status

    # case_status: a values-only table (no status column) reads as every case ok, as the
    # report and exit read it (review C, session 52: df["status"] raised KeyError there)
    pairs = zip(df["case_id"], case_status(df), strict=True)
    lines = sorted(f"{c},{s}" for c, s in pairs)
    digest = hashlib.sha256("\n".join(lines).encode("utf-8")).hexdigest()
    return {"n_cases": len(lines), "sha256": digest}


def _check_table(out_dir: Path, doc: dict) -> None:
    """Refuse a ``surrogate.json`` fitted on another ``results.csv`` than the folder's now
    (:func:`table_fingerprint`); warn on one written before session 52, which has no
    fingerprint to check."""
    import warnings

    from psdesign.study.readback import read_results

    fitted = doc.get("table")
    if not isinstance(fitted, dict):
        warnings.warn(
            f"{out_dir / SURROGATE_FILE} predates the check against results.csv (session 52): "
            "if the study ran again since `psdesign study fit`, fit again",
            UserWarning,
            stacklevel=3,
        )
        return
    now = table_fingerprint(read_results(out_dir))
    if now["sha256"] != fitted.get("sha256"):
        raise ValueError(
            f"out_dir: {out_dir / SURROGATE_FILE} was fitted on an older results.csv "
            f"({fitted.get('n_cases')} case(s); now {now['n_cases']}, or their statuses "
            "changed); rerun `psdesign study fit`"
        )


def load_study_surrogates(out_dir: str | Path) -> dict[str, Surrogate]:
    """The surrogates saved by :func:`fit_study`.

    Raises
    ------
    FileNotFoundError
        No ``surrogate.json`` in ``out_dir``.
    ValueError
        One psdesign did not write, or fitted on an older ``results.csv`` than the folder's
        (:func:`table_fingerprint`; one written before session 52 has none: a warning).
    """
    path = Path(out_dir) / SURROGATE_FILE
    if not path.is_file():
        raise FileNotFoundError(
            f"out_dir: no {SURROGATE_FILE} in {out_dir}; run `psdesign study fit` first"
        )
    try:
        doc = json.loads(path.read_text())
        models = {k: Surrogate.from_dict(v) for k, v in doc["models"].items()}
    except (ValueError, TypeError, KeyError, AttributeError) as exc:  # also UnicodeDecodeError
        msg = " ".join(str(exc).split())
        raise ValueError(
            f"{path}: not a surrogate file psdesign wrote ({type(exc).__name__}: {msg}); "
            "run `psdesign study fit` again"
        ) from None
    _check_table(Path(out_dir), doc)
    return models


def parse_point(
    text: str, params: list[str], ints: Collection[str] = (), study: dict | None = None
) -> np.ndarray:
    """``"generator.porosity=0.82,generator.diameter=8e-6"`` -> values in ``params`` order.

    A parameter in ``ints`` (``type = "int"`` in the study) must be a whole number:

    >>> parse_point("n=12.0", ["n"], ints={"n"})
    array([12.])
    >>> parse_point("n=12.5", ["n"], ints={"n"})
    Traceback (most recent call last):
    ...
    ValueError: --at: n must be an integer (type = "int" in the study), got '12.5'

    and every value one the schema allows its key (:func:`psdesign.study.point.
    check_design_point`, set into ``study``'s base spec: ``study.json``'s ``study`` table,
    :func:`~psdesign.analysis.columns.study_table`); a value outside the study's box but
    allowed is predicted, flagged ``extrapolated`` (:func:`outside_range`):

    >>> parse_point("generator.porosity=5", ["generator.porosity"])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: --at: generator.porosity: must be < 1, got 5 (allowed: target in (0, 1): ...
    """
    values: dict[str, float] = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        key, sep, val = item.partition("=")
        if not sep:
            raise ValueError(f"--at: expected KEY=VALUE, got {item!r}")
        key = key.strip()
        if key not in params:
            raise ValueError(f"--at: unknown parameter {key!r}; allowed: {', '.join(params)}")
        if key in values:
            raise ValueError(f"--at: {key} given twice; give each parameter once")
        try:
            values[key] = float(val)
        except ValueError:
            raise ValueError(f"--at: {key} must be a number, got {val!r}") from None
        if not math.isfinite(values[key]):
            raise ValueError(f"--at: {key} must be a finite number, got {val.strip()!r}")
        if key in ints and not values[key].is_integer():
            raise ValueError(
                f'--at: {key} must be an integer (type = "int" in the study), got {val.strip()!r}'
            )
    missing = [p for p in params if p not in values]
    if missing:
        raise ValueError(f"--at: missing {', '.join(missing)}")
    from psdesign.errors import SpecError
    from psdesign.study.point import check_design_point

    try:  # porosity 5 was predicted, flagged extrapolated only (exit 3; session 45)
        check_design_point(values, study)
    except SpecError as exc:
        raise ValueError(f"--at: {exc}") from None
    return np.array([values[p] for p in params])


def wide_prediction(s: Surrogate, mean: float, std: float) -> str:
    """Why a prediction inside the fitted range is untrustworthy by its own error bar, or
    ``""``: the GP's std at the point exceeds
    :data:`psdesign.flow.error.UNTRUSTWORTHY_REL_ERROR` of the predicted value (the rule every
    value of psdesign follows). Inside the box the cases may still not pin a point down: two
    parameters that moved together leave the plane off their line unknown (a csv design with
    diameter = 1e-5 porosity predicted K 2.18e-11 +- 482 % at a corner, status ``ok``, where
    the truth is 7.7e-12).

    >>> from types import SimpleNamespace as S
    >>> wide_prediction(S(output="k"), 1.0, 0.1), wide_prediction(S(output="k"), 1.0, 4.8)[:33]
    ('', 'k: its error bar here is 480 % of')
    """
    from psdesign.flow.error import UNTRUSTWORTHY_REL_ERROR

    rel = std / abs(mean) if mean else math.inf
    if rel <= UNTRUSTWORTHY_REL_ERROR:
        return ""
    return (
        f"{s.output}: its error bar here is {100 * rel:.3g} % of the value (GP std), above "
        f"{100 * UNTRUSTWORTHY_REL_ERROR:g} %: the cases do not pin this point down"
    )


def outside_range(s: Surrogate, x: np.ndarray) -> list[str]:
    """The parameters of point ``x`` (``s.params`` order) outside what the surrogate was
    fitted on, as ``"name = v outside [low, high]"`` (the study's box), for a parameter held
    at one value in every fitted case (:meth:`Surrogate.fixed_inputs`; a ``levels = 1``
    parameter keeps its ``[low, high]`` bounds) ``"name = v, every fitted case had v0"``, and
    inside the box but beyond the fitted cases' values ``"name = v outside the fitted cases'
    [min, max]"`` (a small latin hypercube leaves the box's ends unsampled: its fit was off by
    4-5 bars there, rated ``ok`` until session 53); empty inside. A value within
    :data:`SAME_VALUE_REL` of a fitted one is that value: a grid's end levels are computed
    (log-spaced ``1e-5`` is stored as 9.999999999999997e-06), and ``--at ...=1e-5`` there is
    no extrapolation (session 53 flagged it so, its bar 20.5 % not 7.68 %, exit 3)."""
    fixed = s.fixed_inputs()
    cases = np.asarray(s.x, float).reshape(-1, len(s.params))
    out = []
    for j, (p, v) in enumerate(zip(s.params, np.asarray(x, float), strict=True)):
        lo, hi, cmin, cmax = s.low[j], s.high[j], cases[:, j].min(), cases[:, j].max()
        if not lo <= v <= hi:
            out.append(f"{p} = {v:g} outside [{lo:g}, {hi:g}]")
        elif p in fixed and not _same_value(v, fixed[p]):
            out.append(f"{p} = {v:g}, every fitted case had {fixed[p]:g}")
        elif (v < cmin and not _same_value(v, cmin)) or (v > cmax and not _same_value(v, cmax)):
            out.append(f"{p} = {v:g} outside the fitted cases' [{cmin:g}, {cmax:g}]")
    return out


#: Relative difference below which a point's parameter value is a fitted case's value
#: (:func:`outside_range`): float rounding of computed levels is ~1e-16, a real step >> 1e-9.
SAME_VALUE_REL = 1e-9


def _same_value(v: float, fitted: float) -> bool:
    """``v`` is the fitted value ``fitted`` to within :data:`SAME_VALUE_REL`."""
    return math.isclose(v, fitted, rel_tol=SAME_VALUE_REL, abs_tol=0.0)
