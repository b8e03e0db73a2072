"""The generalized PS model at one point, compiled: the one place its formula is written for
compiled code (paper Eq. 10; :class:`psdesign.geometry.model.GeneralizedPS` is its numpy form).

    psi(r) = sum_i mu_i cos(Phi_i),
    Phi_i  = 2 pi kappa_i (H_i . r + alpha_i)
             + sum_{k: term(k) = i} u_k cos(2 pi f_k (G_k . r + beta_k))

``m`` is the tuple ``(mu, kappa, H, alpha, minor_term, u, f, G, beta)`` of
:func:`psdesign.forcefield.kernels.model_arrays`. :func:`psi_point` fills the gradient ``g``
(``order >= 1``) and the Hessian ``hs`` (``order == 2``) in place; the rasterizer, the
force-field tables, tube sections and field evaluations all call it.
"""

from __future__ import annotations

import math

import numba
import numpy as np

import solvers.jit  # noqa: F401  (numba cache stamps cover the imported modules)

TWO_PI = 2.0 * np.pi


@numba.njit(cache=True, inline="always")
def term_phase(m, i, x0, x1, x2):  # pragma: no cover - compiled
    """``Phi_i`` of term ``i`` at one point (value only)."""
    mu, kappa, H, alpha, minor_term, u, f, G, beta = m
    ph = TWO_PI * kappa[i] * (H[i, 0] * x0 + H[i, 1] * x1 + H[i, 2] * x2 + alpha[i])
    for j in range(u.shape[0]):
        if minor_term[j] == i:
            ph += u[j] * math.cos(
                TWO_PI * f[j] * (G[j, 0] * x0 + G[j, 1] * x1 + G[j, 2] * x2 + beta[j])
            )
    return ph


@numba.njit(cache=True, inline="always")
def psi_value(m, x0, x1, x2):  # pragma: no cover - compiled
    """``psi`` at one point (value only)."""
    mu = m[0]
    val = 0.0
    for i in range(mu.shape[0]):
        val += mu[i] * math.cos(term_phase(m, i, x0, x1, x2))
    return val


@numba.njit(cache=True)
def psi_point(m, x0, x1, x2, g, hs, order):  # pragma: no cover - compiled
    """``psi`` at one point; fills ``g`` (order >= 1) and ``hs`` (order 2, 3x3)."""
    if order == 0:
        return psi_value(m, x0, x1, x2)
    mu, kappa, H, alpha, minor_term, u, f, G, beta = m
    val = 0.0
    g[0] = g[1] = g[2] = 0.0
    if order >= 2:
        for a in range(3):
            for b in range(3):
                hs[a, b] = 0.0
    for i in range(mu.shape[0]):
        kk = TWO_PI * kappa[i]
        ph = kk * (H[i, 0] * x0 + H[i, 1] * x1 + H[i, 2] * x2 + alpha[i])
        d0, d1, d2 = kk * H[i, 0], kk * H[i, 1], kk * H[i, 2]
        h00 = h01 = h02 = h11 = h12 = h22 = 0.0
        for j in range(u.shape[0]):
            if minor_term[j] != i:
                continue
            ff = TWO_PI * f[j]
            th = ff * (G[j, 0] * x0 + G[j, 1] * x1 + G[j, 2] * x2 + beta[j])
            ct = u[j] * math.cos(th)
            ph += ct
            st = u[j] * math.sin(th) * ff
            d0 -= st * G[j, 0]
            d1 -= st * G[j, 1]
            d2 -= st * G[j, 2]
            if order >= 2:
                c2 = ct * ff * ff
                h00 -= c2 * G[j, 0] * G[j, 0]
                h01 -= c2 * G[j, 0] * G[j, 1]
                h02 -= c2 * G[j, 0] * G[j, 2]
                h11 -= c2 * G[j, 1] * G[j, 1]
                h12 -= c2 * G[j, 1] * G[j, 2]
                h22 -= c2 * G[j, 2] * G[j, 2]
        c = mu[i] * math.cos(ph)
        s = mu[i] * math.sin(ph)
        val += c
        g[0] -= s * d0
        g[1] -= s * d1
        g[2] -= s * d2
        if order >= 2:
            hs[0, 0] -= c * d0 * d0 + s * h00
            hs[0, 1] -= c * d0 * d1 + s * h01
            hs[0, 2] -= c * d0 * d2 + s * h02
            hs[1, 1] -= c * d1 * d1 + s * h11
            hs[1, 2] -= c * d1 * d2 + s * h12
            hs[2, 2] -= c * d2 * d2 + s * h22
    if order >= 2:
        hs[1, 0] = hs[0, 1]
        hs[2, 0] = hs[0, 2]
        hs[2, 1] = hs[1, 2]
    return val
