"""The voxel solver's Stokes product ``K x`` in plain numpy, for checking its numba kernels.

Written from the stencil description of :mod:`solvers.voxel.kernels` (its module docstring),
not from the kernels: each velocity component ``a`` has the 7-point operator
``(A q)_I = d_I q_I - sum_b (c_b[I] q[I - e_b] + c_b[I + e_b] q[I + e_b])`` with the couplings
of the active unknowns, ``c_b[I] = act[I] & act[I - e_b]``, plus the weighted pressure gradient
``w_I (p_I - p_{I - e_a})``; the continuity row of a fluid cell is the weighted divergence
``sum_a (w_a q_a)[I] - (w_a q_a)[I + e_a]``. Weights are 1 on the active faces of the staircase
and the cut-face fluid fractions with sub-voxel walls. Everything is periodic and float64.
"""

from __future__ import annotations

import numpy as np


def stokes_product(op, x: np.ndarray) -> np.ndarray:
    """``K x`` (float64, shape of ``x``) for a :class:`solvers.voxel_stokes._Stokes` ``op``."""
    y = np.zeros(x.shape)
    p = x[3].astype(np.float64)
    div = np.zeros(p.shape)
    for a in range(3):
        d = op.diagonal(a)
        act = d > 0
        q = x[a].astype(np.float64) * act
        aq = d * q
        for b in range(3):
            c_lo = act & np.roll(act, 1, axis=b)
            aq -= c_lo * np.roll(q, 1, axis=b)
            aq -= np.roll(c_lo, -1, axis=b) * np.roll(q, -1, axis=b)
        wa = op.weight(a)
        w = wa.astype(np.float64) if wa is not None else act.astype(np.float64)
        aq += w * (p - np.roll(p, 1, axis=a))
        y[a] = np.where(act, aq, 0.0)
        wq = w * q
        div += wq - np.roll(wq, -1, axis=a)
    y[3] = np.where(op.fluid > 0, div, 0.0)
    return y
