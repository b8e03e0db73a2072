"""Generalized pattern search (compass search) with bound constraints.

The paper (Sec. 6) minimizes the force-field energy with MATLAB's pattern search. This is
the same method family: poll the 2n coordinate directions on a mesh of size ``step``
(scaled to each variable's bound range), move to the first improving point
(opportunistic polling, last successful direction first), expand the mesh after a
success and contract it after a failed poll. Trial points outside the bounds are
projected onto them, so a bound can be reached exactly. Equality constraints are handled
by the caller through a parametrization (see :mod:`psdesign.forcefield.params`).

No maintained, dependency-light PyPI package offers this with the iteration control
used here (PyNomadBBO and pymoo exist but are large dependencies), hence this small
implementation, tested on quadratic and Rosenbrock functions with bounds.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from psdesign.forcefield.search_settings import SearchSettings


class Evaluator(Protocol):
    """Asynchronous evaluation of the objective (see :class:`.parallel.WorkerPool`)."""

    def free(self) -> int:
        """Number of points that can be submitted now."""

    def submit(self, tag: Hashable, x: np.ndarray) -> None:
        """Start evaluating ``x``; its value comes back from :meth:`collect` with ``tag``."""

    def collect(self, block: bool = True) -> list[tuple[Hashable, float]]:
        """Finished ``(tag, value)`` pairs (wait for at least one if ``block``)."""


@dataclass
class PatternSearchResult:
    """Outcome of :func:`pattern_search`.

    Attributes
    ----------
    x : ndarray
        Best point found.
    fun : float
        Objective at ``x``.
    n_iter, n_evals : int
        Polls performed and objective evaluations the search used (cache hits not
        counted): the evaluations of plain serial polling, for any ``batch`` or
        ``evaluator``.
    n_speculative : int
        Further evaluations made ahead by parallel polling and not used (finished ones;
        may vary from run to run with ``evaluator``).
    converged : bool
        True if the mesh size fell below ``min_step``; False if an iteration or
        evaluation limit stopped the run (``x`` is then the best point so far).
    message : str
    history : list of dict
        One entry per iteration: ``iter``, ``n_evals``, ``fun`` (best so far), ``step``.
    poll_step : float
        Mesh size (fraction of each variable's range) of the last poll: after a converged
        stop every compass neighbour at this distance was no better, so it is the optimum's
        uncertainty per variable (the final ``step`` is this times ``contract``, never
        polled). NaN when no poll was made.
    infeasible : list of int
        Variables (indices) with a compass neighbour of the last poll where the objective
        is +inf (an infeasible point: a broken fiber): the optimum sits against that
        wall as against a bound, a constrained stop.
    """

    x: np.ndarray
    fun: float
    n_iter: int
    n_evals: int
    converged: bool
    message: str
    history: list[dict] = field(default_factory=list)
    n_speculative: int = 0
    poll_step: float = float("nan")
    infeasible: list[int] = field(default_factory=list)


def poll_bars(names, lower, upper, poll_step: float) -> dict[str, float]:
    """The +- of each variable of a pattern search's optimum: the last poll's mesh
    (:attr:`PatternSearchResult.poll_step`, a fraction of each range) times the variable's
    range ``upper - lower``; no compass neighbour that far was better.

    >>> poll_bars(["a", "b"], [0.0, -1.0], [2.0, 1.0], 0.01)
    {'a': 0.02, 'b': 0.02}
    """
    return {n: float(poll_step * (b - a)) for n, a, b in zip(names, lower, upper, strict=True)}


def check_bounds(x0, lower, upper) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate a start point and bounds; returns float arrays."""
    x0 = np.atleast_1d(np.asarray(x0, float))
    lo = np.broadcast_to(np.asarray(lower, float), x0.shape).copy()
    hi = np.broadcast_to(np.asarray(upper, float), x0.shape).copy()
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError("bounds must be finite")
    bad = np.flatnonzero(lo > hi)
    if bad.size:
        i = int(bad[0])
        raise ValueError(
            f"bounds leave no feasible point: lower[{i}] = {lo[i]} > upper[{i}] = {hi[i]}"
        )
    out = np.flatnonzero((x0 < lo) | (x0 > hi) | ~np.isfinite(x0))
    if out.size:
        i = int(out[0])
        raise ValueError(f"x0[{i}] = {x0[i]} lies outside its bounds [{lo[i]}, {hi[i]}]")
    return x0, lo, hi


def pattern_search(
    fun: Callable[[np.ndarray], float],
    x0,
    lower,
    upper,
    settings: SearchSettings | None = None,
    *,
    callback: Callable[[dict], None] | None = None,
    batch: int = 1,
    map_fun: Callable[[list[np.ndarray]], list[float]] | None = None,
    evaluator: Evaluator | None = None,
) -> PatternSearchResult:
    """Minimize ``fun`` over the box ``lower <= x <= upper`` by compass pattern search.

    (Nine parameters: the problem, the search's settings, and the progress callback and the
    three ways of evaluating, keyword-only.)

    Parameters
    ----------
    fun : callable
        Objective ``fun(x) -> float``.
    x0 : array_like
        Start point (inside the bounds).
    lower, upper : array_like
        Bounds; a variable with ``lower == upper`` is held fixed.
    settings : SearchSettings, optional
        Mesh sizes, mesh factors, iteration and evaluation limits (default:
        ``SearchSettings()``).
    callback : callable, optional
        Called with each history entry.
    batch : int
        Trial points evaluated together (speculative parallel polling): the poll
        directions are taken in order in groups of ``batch`` points not yet in the cache,
        evaluated with ``map_fun``, and the first improving point in poll order is
        accepted. The iterates are those of ``batch = 1`` (plain opportunistic polling);
        the speculative points after a success are counted in ``n_speculative``.
    map_fun : callable, optional
        ``map_fun(list of x) -> list of fun(x)``, e.g. a process pool's map
        (default: serial).
    evaluator : Evaluator, optional
        Asynchronous speculative polling (e.g. :class:`.parallel.WorkerPool`; ``batch``
        and ``map_fun`` are then ignored): every free worker gets the next poll point
        in order that is neither cached nor running, and the points are examined in poll
        order as their values arrive; the first improving one is accepted. The iterates
        are again those of plain polling; no worker waits for another, and points still
        running after a success finish into the cache (``n_speculative``). ``fun`` is
        not called.
    """
    x0, lo, hi = check_bounds(x0, lower, upper)
    opt = SearchSettings() if settings is None else settings
    if batch < 1:
        raise ValueError(f"batch must be >= 1, got {batch}")
    if map_fun is None:

        def map_fun(xs: list[np.ndarray]) -> list[float]:
            return [fun(x) for x in xs]

    polls = _Poller(lo, hi, map_fun, evaluator, batch, opt.max_evals)
    width = hi - lo
    z = np.where(width > 0, (x0 - lo) / np.where(width > 0, width, 1.0), 0.0)
    fz = _start_value(polls, z)
    dirs = [(i, s) for i in np.flatnonzero(width > 0) for s in (1.0, -1.0)]
    history: list[dict] = []
    converged, message, it = not dirs, "no free variables" if not dirs else "", 0
    step, polled = opt.step, float("nan")
    while not converged:
        message = _limit_reached(it, polls.n_done, opt)
        if message:
            break
        it += 1
        trials = _compass_trials(z, dirs, step)
        hit, polled = polls.poll(trials, fz), step
        if hit is not None:
            k, z = trials[hit]
            fz = polls.cache[polls.key(z)]
            dirs.insert(0, dirs.pop(k))  # poll this direction first next time
        step = min(step * opt.expand, opt.max_step) if hit is not None else step * opt.contract
        entry = {"iter": it, "n_evals": len(polls.used), "fun": fz, "step": step}
        history.append(entry)
        if callback is not None:
            callback(entry)
        if step < opt.min_step:
            converged, message = True, f"mesh size below min_step={opt.min_step}"
    return PatternSearchResult(
        x=lo + z * width,
        fun=fz,
        n_iter=it,
        n_evals=len(polls.used),
        converged=converged,
        message=message,
        history=history,
        n_speculative=polls.n_done - len(polls.used),
        poll_step=polled,
        infeasible=_infeasible_neighbours(polls, z, dirs, polled),
    )


def _infeasible_neighbours(polls: _Poller, z: np.ndarray, dirs, step: float) -> list[int]:
    """Variables whose compass neighbour at ``step`` (the last poll's mesh) evaluated to +inf
    (cached values only: a poll cut short by a limit did not examine all)."""
    if not np.isfinite(step):
        return []
    trials = _compass_trials(z, dirs, step)
    out = {dirs[k][0] for k, t in trials if polls.cache.get(polls.key(t)) == np.inf}
    return sorted(int(i) for i in out)


def _start_value(polls: _Poller, z: np.ndarray) -> float:
    """The objective at the start point ``z`` (unit coordinates), evaluated through ``polls``."""
    if polls.poll([(0, z)], np.inf) is None and polls.key(z) not in polls.cache:
        raise RuntimeError("the start point could not be evaluated")  # pragma: no cover
    return polls.cache[polls.key(z)]


def _limit_reached(it: int, n_done: int, opt: SearchSettings) -> str:
    """The stop message when the iteration or evaluation limit is used up, else ``""``."""
    if it >= opt.max_iter:
        return f"stopped on the iteration limit (max_iter={opt.max_iter})"
    if opt.max_evals is not None and n_done >= opt.max_evals:
        return f"stopped on the evaluation limit (max_evals={opt.max_evals})"
    return ""


def _compass_trials(
    z: np.ndarray, dirs: list[tuple[int, float]], step: float
) -> list[tuple[int, np.ndarray]]:
    """The poll's trial points in direction order: ``z`` moved by ``step`` along each
    direction, projected onto the unit box; a move the bound cancels is left out."""
    trials = []
    for k, (i, s) in enumerate(dirs):
        trial = z.copy()
        trial[i] = np.clip(trial[i] + s * step, 0.0, 1.0)
        if trial[i] != z[i]:
            trials.append((k, trial))
    return trials


class _Poller:
    """Evaluations of one pattern search in unit coordinates: the value cache, the points the
    search examined (``used``), those with the evaluator (``running``), and the poll."""

    def __init__(self, lo, hi, map_fun, evaluator, batch: int, max_evals: int | None):
        self.lo, self.width = lo, hi - lo
        self.map_fun, self.evaluator = map_fun, evaluator
        self.batch, self.max_evals = batch, max_evals
        self.cache: dict[tuple, float] = {}
        self.used: set[tuple] = set()
        self.running: set[tuple] = set()
        self.n_done = 0  # evaluations performed

    @staticmethod
    def key(z: np.ndarray) -> tuple:
        return tuple(np.round(z, 12))

    def to_x(self, z: np.ndarray) -> np.ndarray:
        x = self.lo + z * self.width
        x[self.width == 0] = self.lo[self.width == 0]
        return x

    def store(self, k: tuple, v: float) -> None:
        v = float(v)
        self.cache[k] = v if np.isfinite(v) else np.inf
        self.n_done += 1

    def evaluate(self, zs: list[np.ndarray]) -> None:
        """Evaluate the points not yet cached (in one ``map_fun`` call)."""
        key = self.key
        new = list({key(z): z for z in zs if key(z) not in self.cache}.items())
        if new:
            values = self.map_fun([self.to_x(z) for _, z in new])
            for (k, _), v in zip(new, values, strict=True):
                self.store(k, v)

    def collect(self, block: bool) -> None:
        for k, v in self.evaluator.collect(block):
            self.running.discard(k)
            self.store(k, v)

    def room(self) -> float:
        if self.max_evals is None:
            return np.inf
        return self.max_evals - self.n_done - len(self.running)

    def poll(self, trials: list[tuple[int, np.ndarray]], fz: float) -> int | None:
        """Examine ``trials`` in order; index of the first one below ``fz`` (None: none, or
        the evaluation limit stopped the poll)."""
        pos, nxt = 0, 0
        while pos < len(trials):
            k_pos = self.key(trials[pos][1])
            if k_pos in self.cache:
                self.used.add(k_pos)
                if self.cache[k_pos] < fz:
                    return pos
                pos += 1
                continue
            if self.evaluator is None:
                if not self._evaluate_group(trials, pos):  # evaluation limit reached
                    return None
                continue
            nxt = self._submit(trials, max(nxt, pos))
            if k_pos not in self.running and not self.running:  # evaluation limit reached
                return None
            self.collect(block=True)
        return None

    def _evaluate_group(self, trials, pos: int) -> bool:
        """Evaluate the next ``batch`` uncached trials from ``pos`` on, in poll order; False
        when the evaluation limit leaves no room."""
        key, cache = self.key, self.cache
        end, fresh = pos, set()
        lim = min(self.batch, self.room())
        while end < len(trials) and (len(fresh) < lim or key(trials[end][1]) in cache):
            if key(trials[end][1]) not in cache:
                fresh.add(key(trials[end][1]))
            end += 1
        if not fresh:
            return False
        self.evaluate([t for _, t in trials[pos:end]])
        return True

    def _submit(self, trials, nxt: int) -> int:
        """Give every free worker the next trial in order that is neither cached nor
        running; the index of the next trial to submit."""
        while self.evaluator.free() > 0 and nxt < len(trials) and self.room() > 0:
            k = self.key(trials[nxt][1])
            if k not in self.cache and k not in self.running:
                self.evaluator.submit(k, self.to_x(trials[nxt][1]))
                self.running.add(k)
            nxt += 1
        return nxt
