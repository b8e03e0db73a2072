"""``solvers.jit.SerialHelpers``: the serial twin of a kernel calls plain-``@njit`` leaf helpers,
the parallel kernel inlines them (numba ``inline="always"``), from one definition of each.

Truth: which dispatcher numba compiled (a plain helper gets its own signature when a caller
is compiled against it; an ``inline="always"`` helper never does) and the sums, computed by
hand."""

from __future__ import annotations

import numba as nb
import numpy as np

from solvers.jit import SerialHelpers, TwinKernel, parallel_kernel

_H = SerialHelpers(fastmath=False)


@_H.leaf
def _twice(v):
    return 2.0 * v


@_H.leaf
def _plus_one(v):
    return _twice(v) + 1.0  # a leaf calling a leaf


@_H.inline
def _row_sum(a, i):
    s = 0.0
    for k in range(a.shape[1]):
        s += _plus_one(a[i, k])
    return s


@_H.slab(cache=False)
def _slab(a, i):
    return _row_sum(a, i)


@parallel_kernel(helpers=_H)
def _kernel(a):
    out = np.zeros(a.shape[0])
    for i in nb.prange(a.shape[0]):
        out[i] = _slab(a, np.int64(i)) + _row_sum(a, i)
    return out.sum()


_H2 = SerialHelpers()


@_H2.leaf
def _inc(v):
    return v + 1.0


@parallel_kernel(helpers=_H2)
def _kernel2(a):
    out = np.zeros(a.shape[0])
    for i in nb.prange(a.shape[0]):
        out[i] = _inc(a[i])
    return out.sum()


_H3 = SerialHelpers()


@_H3.leaf
def _sq(v):
    return v * v


@_H3.shared(cache=False)
def _body(a, i):
    return _sq(a[i]) + 1.0


@parallel_kernel(helpers=_H3)
def _kernel3(a):
    out = np.zeros(a.shape[0])
    for i in nb.prange(a.shape[0]):
        out[i] = _body(a, np.int64(i))
    return out.sum()


_H.seal(globals())
_H2.seal(globals())
_H3.seal(globals())


def _a() -> np.ndarray:
    return np.arange(12.0).reshape(3, 4)


def test_serial_twin_compiles_the_plain_leaves_and_the_serial_slab():
    a = _a()
    # sum over 12 entries of 2 v + 1, twice: 2 (2 * 66 + 12) = 288
    assert isinstance(_kernel, TwinKernel)
    assert _kernel.serial(a) == 288.0
    twice, plus_one, slab = _H.ns["_twice"], _H.ns["_plus_one"], _H.ns["_slab"]
    assert twice.signatures and plus_one.signatures  # compiled as functions of their own
    assert slab.py_func.__qualname__ == "_slab__serial" and slab.signatures
    assert not _slab.signatures  # the module's slab is the parallel kernel's
    assert _kernel.serial.py_func.__globals__ is _H.ns


def test_parallel_kernel_inlines_every_helper():
    a = np.arange(5.0)
    assert _kernel2.parallel(a) == 15.0  # (0 + 1 + ... + 4) + 5 ones
    assert not _H2.ns["_inc"].signatures  # the parallel kernel never compiled the plain leaf
    assert _kernel2.serial(a) == 15.0
    assert _H2.ns["_inc"].signatures


def test_imported_helpers_map_to_their_serial_variants():
    other = SerialHelpers()
    other.seal({"_twice": _twice, "_row_sum": _row_sum, "x": [1], "n": 3})
    assert other.ns["_twice"] is _H.ns["_twice"]
    assert other.ns["_row_sum"] is _H.ns["_row_sum"]
    assert other.ns["x"] == [1] and other.ns["n"] == 3  # unhashable and plain values kept


def test_shared_body_is_a_function_for_the_parallel_kernel_and_inline_in_the_serial_twin():
    a = np.arange(4.0)
    # sum of v^2 + 1 over 0..3: 14 + 4 = 18
    assert _kernel3.serial(a) == 18.0
    assert not _body.signatures  # the serial twin inlined the body: no call, no compile
    assert _H3.ns["_sq"].signatures  # ... whose leaf is the plain one
    assert _kernel3.parallel(a) == 18.0
    assert _body.py_func.__qualname__ == "_body__serial" and _body.signatures
    assert _body.py_func.__globals__ is _H3.ns  # compiled over the serial helpers
    assert _H3.ns["_body"] is not _body  # the serial twin's name: the inline copy
    assert not _H3.ns["_body"].signatures  # ... inlined, never compiled as a function
