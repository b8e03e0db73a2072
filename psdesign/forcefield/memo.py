"""Memo of per-fiber surface work across force-field evaluations.

A pattern-search poll changes one free variable; fibers whose model does not depend on
it (e.g. fibers 1-3 of the six-fiber case when t_x or t_y of fibers 4-6 moves) come out
of the build with the same content. Their surface quadrature and surface potential are
then taken from this memo, keyed by the fiber's full content (model arrays, isovalue,
scale, bounds, tubes) and the quadrature settings, so a hit returns exactly what a
recomputation would.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable
from typing import Any

import numpy as np

from psdesign.forcefield.fields import PSField


def fiber_key(fld: Any, *settings: Any) -> tuple | None:
    """Content key of a :class:`PSField` plus ``settings``; None for other fields."""
    if not isinstance(fld, PSField):
        return None
    parts: list[Any] = [a.tobytes() for a in fld.arrays]
    parts += [
        float(fld.isovalue),
        float(fld.scale),
        fld.bounds[0].tobytes(),
        fld.bounds[1].tobytes(),
    ]
    parts += [(t.point.tobytes(), t.axis, float(t.radius)) for t in fld.tubes]
    parts += [(st.key(), st.rotation.tobytes(), st.offset.tobytes()) for st in fld.shared]
    return (*parts, *settings)


class FiberMemo:
    """Least-recently-used memo of at most ``size`` per-fiber results."""

    def __init__(self, size: int = 64) -> None:
        if size < 1:
            raise ValueError(f"size must be >= 1, got {size}")
        self.size = size
        self._data: OrderedDict[tuple, Any] = OrderedDict()
        self.hits = 0
        self.misses = 0

    def get(self, key: tuple | None, compute: Callable[[], Any]) -> Any:
        """``compute()``, or its memoized result for ``key`` (None: never memoized)."""
        if key is None:
            return compute()
        if key in self._data:
            self._data.move_to_end(key)
            self.hits += 1
            return self._data[key]
        self.misses += 1
        val = compute()
        self._data[key] = val
        if len(self._data) > self.size:
            self._data.popitem(last=False)
        return val


def domain_key(domain: tuple[np.ndarray, np.ndarray]) -> bytes:
    """Hashable form of a domain box."""
    return np.asarray(domain, float).tobytes()
