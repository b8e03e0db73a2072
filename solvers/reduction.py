"""The final sum of a parallel kernel's per-plane (per-row, per-chunk) partial sums.

A ``part.sum()`` inside a ``parallel=True`` kernel is a numba parfor reduction: numba fuses it
into the ``prange`` loop before it and lets each thread sum the partials of the iterations it
ran.  The order of the additions then depends on the threading layer and the thread count:
with OpenMP on two threads a float64 sum of 2 000+ partials differed from the serial twin's in
the last bit on every call, with TBB (picked when ``libtbb`` is installed) it can differ from
call to call.  A solve's reported true residual differed by one ulp between one and two
threads (``benchmarks/RESULTS.md``, session 35 reproducibility audit; session 36 lead).
:func:`ordered_sum` is a plain function called after the loop: one order, whatever ran the loop.
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(fastmath=False, nogil=True, error_model="numpy")
def ordered_sum(part: np.ndarray) -> float:
    """``part[0] + part[1] + ...`` in index order, in float64 (no fast-math: LLVM may not
    reassociate the additions into vector lanes).

    Examples
    --------
    >>> import numpy as np
    >>> ordered_sum(np.array([1e16, 1.0, -1e16, 1.0]))
    1.0
    """
    s = 0.0
    for i in range(part.shape[0]):
        s += part[i]
    return s


@nb.njit(fastmath=False, nogil=True, error_model="numpy")
def ordered_column_sums(part: np.ndarray) -> np.ndarray:
    """``part[0] + part[1] + ...`` of a 2-D array's rows (the sums over axis 0), row by row in
    index order, in float64.

    Examples
    --------
    >>> import numpy as np
    >>> ordered_column_sums(np.array([[1e16, 2.0], [1.0, 3.0], [-1e16, 4.0], [1.0, 5.0]]))
    array([ 1., 14.])
    """
    out = np.zeros(part.shape[1])
    for i in range(part.shape[0]):
        for j in range(part.shape[1]):
            out[j] += part[i, j]
    return out
