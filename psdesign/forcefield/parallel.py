"""Evaluate an objective in forked worker processes.

* :class:`WorkerPool` (used by :meth:`.cases.ForceFieldProblem.solve`): asynchronous
  speculative polling (:func:`.pattern.pattern_search` with ``evaluator``); every worker
  takes the next poll point as soon as it is free, the caller only dispatches.
* :func:`batch_map` (:func:`.pattern.pattern_search` with ``batch``): groups of points
  evaluated at once, the first in the calling process; each group waits for its slowest
  point.

Workers are forked from the caller, so the objective (a closure over the problem) needs
no pickling; only points and values cross the pipes. Values do not depend on which
process computes them, so results are the same for any number of workers. Workers run
their compiled kernels and BLAS single-threaded.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from multiprocessing import connection as mp_connection

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


def _worker_loop(fun: Callable[[np.ndarray], float], conn) -> None:  # pragma: no cover
    """Body of a :class:`WorkerPool` process: evaluate ``(tag, x)`` messages until None."""
    _init_worker()
    while True:
        try:
            msg = conn.recv()
        except (EOFError, KeyboardInterrupt):
            return
        if msg is None:
            return
        tag, x = msg
        try:
            out: tuple = (tag, float(fun(x)), None)
        except Exception as exc:  # noqa: BLE001 - sent back and re-raised by the caller
            out = (tag, float("nan"), exc)
        conn.send(out)


class WorkerPool:
    """``workers`` forked processes that evaluate ``fun`` one point at a time.

    The caller submits ``(tag, x)`` to a free worker and collects ``(tag, value)`` as the
    workers finish, in any order; it does not evaluate itself (it waits in
    :func:`multiprocessing.connection.wait`), so every core works on a point and no
    worker waits for another (used by :func:`.pattern.pattern_search` with
    ``evaluator``). ``fun`` is inherited through ``fork``: only tags, points and values
    cross the pipes. An exception raised by ``fun`` in a worker is re-raised by
    :meth:`collect`.
    """

    def __init__(self, fun: Callable[[np.ndarray], float], workers: int) -> None:
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        if "fork" not in mp.get_all_start_methods():  # pragma: no cover
            raise RuntimeError("WorkerPool needs the 'fork' start method")
        ctx = mp.get_context("fork")
        self._procs = []
        self._idle = []
        self._busy: dict = {}
        for _ in range(workers):
            parent, child = ctx.Pipe()
            proc = ctx.Process(target=_worker_loop, args=(fun, child), daemon=True)
            proc.start()
            child.close()
            self._procs.append(proc)
            self._idle.append(parent)

    @property
    def capacity(self) -> int:
        return len(self._procs)

    def free(self) -> int:
        """Workers without a point."""
        return len(self._idle)

    def submit(self, tag, x: np.ndarray) -> None:
        """Hand ``x`` to a free worker (raises if none is free)."""
        if not self._idle:
            raise RuntimeError("no free worker")
        conn = self._idle.pop(0)
        conn.send((tag, np.asarray(x, float)))
        self._busy[conn] = tag

    def collect(self, block: bool = True) -> list[tuple]:
        """``(tag, value)`` of the finished points (waits for one if ``block``)."""
        if not self._busy:
            return []
        ready = mp_connection.wait(list(self._busy), timeout=None if block else 0.0)
        out = []
        for conn in ready:
            try:
                tag, val, exc = conn.recv()
            except EOFError:
                raise RuntimeError("a force-field worker process died") from None
            del self._busy[conn]
            self._idle.append(conn)
            if exc is not None:
                raise exc
            out.append((tag, val))
        return out

    def close(self) -> None:
        """Stop the workers (points still running are abandoned)."""
        for conn in self._idle:
            try:
                conn.send(None)
            except OSError:  # pragma: no cover
                pass
        if self._busy:  # abandoned points: do not wait for them
            for proc in self._procs:
                proc.terminate()
        for proc in self._procs:
            proc.join(timeout=5)
            if proc.is_alive():  # pragma: no cover
                proc.terminate()
                proc.join()
        for conn in [*self._idle, *self._busy]:
            conn.close()
        self._idle, self._busy, self._procs = [], {}, []

    def __enter__(self) -> WorkerPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
