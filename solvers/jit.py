"""``parallel_kernel``: a numba ``parallel=True`` kernel with a serial twin for one-thread runs.

Compiling a ``parallel=True`` kernel costs 2-3 times the CPU time of the same function compiled
serially (the parfor passes and the gufunc wrapper; measured on the voxel Stokes kernels:
``jacobi`` 4.5 s vs 1.9 s, ``stokes_residual_w`` 11.4 s vs 4.3 s), and on one thread the
parallel version buys nothing.  Small grids run on one thread
(:data:`solvers.voxel.threads.PARALLEL_MIN_CELLS`), so a cold start on a small case compiles only
the serial twins.  Both are compiled lazily on first use (only the specializations a solve
needs) and cached on disk (``cache=True``); :mod:`psdesign.warmup` fills that cache ahead of
time.  ``prange`` is a plain ``range`` in the serial twin, so both give the same results up to
the order of floating-point reductions.
"""

from __future__ import annotations

import functools
import types
from collections.abc import Callable

import numba as nb

__all__ = ["COMPILE_PARALLEL_ABOVE", "TwinKernel", "parallel_kernel", "parallel_pending"]

COMPILE_PARALLEL_ABOVE = 10_000_000
"""First-argument size (about grid cells) from which a parallel kernel that is not in the cache
is compiled on first use: on 2 cores two threads save about 40 % of a solve (100^3: 9.5 s ->
5.4 s), which pays for the extra ~1-2 min of compiling only from a few hundred voxels per
side. Smaller grids run the serial twin until ``psdesign warmup`` has compiled the parallel
kernels."""

_PENDING: set[str] = set()


def parallel_pending() -> tuple[str, ...]:
    """Kernels that ran on one thread in this process because their parallel version was not
    compiled yet (empty once ``psdesign warmup`` has run)."""
    return tuple(sorted(_PENDING))


class TwinKernel:
    """A parallel and a serial numba dispatcher of one Python function.

    Calling it runs :attr:`serial` when numba runs on one thread
    (``numba.get_num_threads() == 1``) or when the first argument has fewer than
    ``serial_below`` elements.  Otherwise it runs :attr:`parallel` if that is already compiled
    for these argument types (in this process or in the on-disk cache, e.g. by
    ``psdesign warmup``) or if the first argument has at least :data:`COMPILE_PARALLEL_ABOVE`
    elements (a solve long enough to pay for compiling it); else the serial twin (one thread),
    and :func:`parallel_pending` says so.  Call it from Python only (a jitted function cannot
    call it; jitted helpers stay plain ``numba.njit`` functions).
    """

    def __init__(self, fn: Callable, serial_below: int = 0, **opts: object) -> None:
        self.py_func = fn
        self.serial_below = int(serial_below)
        self.parallel = nb.njit(parallel=True, **opts)(fn)
        # a copy of the function under its own qualified name: numba names its cache files
        # after ``__qualname__`` and does not key them on the ``parallel`` flag
        twin = types.FunctionType(
            fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__, fn.__closure__
        )
        twin.__qualname__ = f"{fn.__qualname__}__serial"
        twin.__doc__ = fn.__doc__
        twin.__module__ = fn.__module__
        self.serial = nb.njit(**opts)(twin)
        self._ready: dict[tuple, bool] = {}
        functools.update_wrapper(self, fn)

    def __call__(self, *args):
        size = getattr(args[0], "size", 0)
        if nb.get_num_threads() == 1 or (self.serial_below and size < self.serial_below):
            return self.serial(*args)
        if size >= COMPILE_PARALLEL_ABOVE or self._parallel_ready(args):
            return self.parallel(*args)
        _PENDING.add(self.py_func.__qualname__)
        return self.serial(*args)

    def _parallel_ready(self, args: tuple) -> bool:
        """True if :attr:`parallel` is compiled for the types of ``args`` (loads it from the
        on-disk cache if it is there; never compiles)."""
        key = tuple(
            (a.dtype.str, a.ndim, a.flags.c_contiguous) if hasattr(a, "dtype") else type(a)
            for a in args
        )
        ready = self._ready.get(key)
        if ready is None:
            d = self.parallel
            sig = tuple(d.typeof_pyval(a) for a in args)
            ready = sig in d.overloads
            if not ready:
                try:  # numba's own lookup (Dispatcher.compile tries it before compiling)
                    ready = d._cache.load_overload(sig, d.targetctx) is not None
                except Exception:
                    ready = False
                if ready:
                    d.compile(sig)  # loads it from the cache
            self._ready[key] = ready
        return ready

    def __repr__(self) -> str:
        return f"<TwinKernel {self.py_func.__module__}.{self.py_func.__qualname__}>"


def parallel_kernel(serial_below: int = 0, **opts: object) -> Callable[[Callable], TwinKernel]:
    """Decorator: ``@parallel_kernel(cache=True, fastmath=True)`` in place of
    ``@numba.njit(parallel=True, cache=True, fastmath=True)`` (see :class:`TwinKernel`);
    ``serial_below``: first-argument size below which the serial twin runs."""

    def wrap(fn: Callable) -> TwinKernel:
        return TwinKernel(fn, serial_below=serial_below, **opts)

    return wrap
