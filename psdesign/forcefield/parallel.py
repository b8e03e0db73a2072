"""Evaluate an objective at several points at once: the calling process plus forked workers.

Used for speculative parallel polling (:func:`.pattern.pattern_search` with ``batch``):
the first point of a batch is evaluated in the calling process, the others in worker
processes forked from it (so the objective, a closure over the problem, needs no
pickling; only points and values cross the pipe). Values do not depend on which process
computes them, so results are the same for any number of workers. Workers run their
compiled kernels and BLAS single-threaded.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np

_FUN: Callable[[np.ndarray], float] | None = None


def _init_worker() -> None:
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:  # pragma: no cover
        pass


def _call(x: np.ndarray) -> float:
    assert _FUN is not None
    return float(_FUN(x))


@contextmanager
def batch_map(
    fun: Callable[[np.ndarray], float], workers: int
) -> Iterator[Callable[[list[np.ndarray]], list[float]]]:
    """Context giving ``map(list of x) -> list of fun(x)`` over ``workers`` processes.

    ``workers = 1`` (or a platform without ``fork``) maps serially in this process.
    """
    global _FUN
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if workers == 1 or "fork" not in mp.get_all_start_methods():
        yield lambda xs: [float(fun(x)) for x in xs]
        return
    _FUN = fun
    ctx = mp.get_context("fork")
    pool = ctx.Pool(workers - 1, initializer=_init_worker)
    try:
        def mapper(xs: list[np.ndarray]) -> list[float]:
            if len(xs) == 1:
                return [float(fun(xs[0]))]
            pending = pool.map_async(_call, xs[1:], chunksize=1)
            first = float(fun(xs[0]))
            return [first, *pending.get()]

        yield mapper
    finally:
        pool.terminate()
        pool.join()
        _FUN = None

