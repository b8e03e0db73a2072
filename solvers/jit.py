"""``parallel_kernel``: a numba ``parallel=True`` kernel with a serial twin for one-thread runs.

Compiling a ``parallel=True`` kernel costs 2-3 times the CPU time of the same function compiled
serially (the parfor passes and the gufunc wrapper; measured on the voxel Stokes kernels:
``jacobi`` 4.5 s vs 1.9 s, ``stokes_residual_w`` 11.4 s vs 4.3 s), and on one thread the
parallel version buys nothing.  Small grids run on one thread
(:data:`solvers.voxel_stokes.PARALLEL_MIN_CELLS`), so a cold start on a small case compiles only
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

__all__ = ["parallel_kernel", "TwinKernel"]


class TwinKernel:
    """A parallel and a serial numba dispatcher of one Python function.

    Calling it runs :attr:`serial` when numba runs on one thread
    (``numba.get_num_threads() == 1``) or when the first argument has fewer than
    ``serial_below`` elements, else :attr:`parallel`.  Call it from Python only (a jitted
    function cannot call it; jitted helpers stay plain ``numba.njit`` functions).
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
        functools.update_wrapper(self, fn)

    def __call__(self, *args):
        if nb.get_num_threads() == 1 or (
            self.serial_below and getattr(args[0], "size", 0) < self.serial_below
        ):
            return self.serial(*args)
        return self.parallel(*args)

    def __repr__(self) -> str:
        return f"<TwinKernel {self.py_func.__module__}.{self.py_func.__qualname__}>"


def parallel_kernel(serial_below: int = 0, **opts: object) -> Callable[[Callable], TwinKernel]:
    """Decorator: ``@parallel_kernel(cache=True, fastmath=True)`` in place of
    ``@numba.njit(parallel=True, cache=True, fastmath=True)`` (see :class:`TwinKernel`);
    ``serial_below``: first-argument size below which the serial twin runs."""

    def wrap(fn: Callable) -> TwinKernel:
        return TwinKernel(fn, serial_below=serial_below, **opts)

    return wrap
