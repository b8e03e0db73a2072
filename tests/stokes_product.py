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


class DenseStokes:
    """The voxel solver's Stokes matrix from dense float coefficients (the diagonals and face
    weights of :mod:`solvers.voxel.boundary`, as stored before the cut faces), for a solve by
    :func:`solvers.voxel_stokes._solve_core` as a reference.

    ``K x`` and the float64 residual ``f - K x`` are :func:`stokes_product` (numpy); the
    preconditioner is that of ``pre``, the solver's own operator of the same grid (any SPD
    preconditioner leaves the solution unchanged; its active unknowns and pressure cells must
    be these coefficients', which ``pre.d`` and ``pre.fluid`` give the Krylov work vectors).
    """

    def __init__(
        self, diags: list[np.ndarray], weights: list[np.ndarray], cells: np.ndarray, pre
    ) -> None:
        self._diags = [np.asarray(d, np.float64) for d in diags]
        self._weights = [np.asarray(w, np.float64) for w in weights]
        self.fluid = np.asarray(cells, np.uint8)
        same = all(np.array_equal(a > 0, b > 0) for a, b in zip(self._diags, pre.d, strict=True))
        if not (same and np.array_equal(self.fluid != 0, pre.fluid != 0)):
            raise ValueError("pre has other unknowns than the dense coefficients")
        self.pre = pre
        self.d, self.z, self.shape = pre.d, pre.z, pre.shape

    def diagonal(self, a: int) -> np.ndarray:
        return self._diags[a]

    def weight(self, a: int) -> np.ndarray:
        return self._weights[a]

    def lanczos(self, x: np.ndarray, s: float, c1: float, y: np.ndarray) -> float:
        """``y <- s K x - c1 y`` (``y`` unread if ``c1 == 0``); returns ``x . y``."""
        kx = s * stokes_product(self, x)
        y[...] = kx if c1 == 0.0 else kx - c1 * y.astype(np.float64)
        return float(np.dot(x.ravel().astype(np.float64), y.ravel().astype(np.float64)))

    def residual(self, x: np.ndarray, gdir: int, r: np.ndarray) -> tuple[float, float]:
        """``r <- f - K x`` (``f`` the weight on the faces of ``gdir``); ``(||r||, ||f||)``."""
        f = np.zeros(x.shape)
        f[gdir] = self._weights[gdir] * (self._diags[gdir] > 0)
        res = f - stokes_product(self, x)
        r[...] = res
        return float(np.linalg.norm(res)), float(np.linalg.norm(f))

    def precondition(self, r: np.ndarray, z: np.ndarray) -> float:
        return self.pre.precondition(r, z)
