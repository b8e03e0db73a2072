"""Numba kernels that rasterize one fiber copy's narrow band into the voxel fields.

Slices along the dominant axis of the fiber never share voxels, so the slice loop
runs in parallel without races.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from psdesign.geometry.ps_kernel import psi_value
from solvers.jit import parallel_kernel

SERIAL_BELOW = 100_000
"""Grids of fewer voxels rasterize on one thread (the serial twin: half the compile time of
the parallel kernel, and a parallel region buys little on a grid this small)."""


@parallel_kernel(cache=True, serial_below=SERIAL_BELOW)
def rasterize_copy(
    distance,
    count,
    mark,
    mark_id,
    h,
    p,
    d,
    k,
    o0,
    o1,
    win0,
    win1,
    radius,
    margin,
    cylinder,
    cyl_center,
    lat0,
    lat1,
    cyl_radius,
    iso,
    grad,
    mu,
    kappa,
    H,
    alpha,
    minor_term,
    u,
    f,
    G,
    beta,
):
    """Update ``distance`` (min, clipped at ``margin``) and ``count`` for one fiber copy.

    Parameters are normalized (one period = 1). ``k`` is the dominant axis of the
    axis direction ``d``; ``o0, o1`` the other two; ``win0, win1`` the half-window in
    voxels. ``mark`` (uint16) records the last fiber that counted a voxel, so copies
    of one fiber that share voxels count them once.
    """
    nk = distance.shape[k]
    n0 = distance.shape[o0]
    n1 = distance.shape[o1]
    r2 = radius * radius
    model = (mu, kappa, H, alpha, minor_term, u, f, G, beta)
    for ik in prange(nk):
        xk = (ik + 0.5) * h[k]
        s = (xk - p[k]) / d[k]
        c = np.empty(3)
        for a in range(3):
            c[a] = p[a] + s * d[a]
        c0 = int(np.floor(c[o0] / h[o0]))
        c1 = int(np.floor(c[o1] / h[o1]))
        idx = np.empty(3, np.int64)
        x = np.empty(3)
        for i0 in range(max(c0 - win0, 0), min(c0 + win0 + 1, n0)):
            for i1 in range(max(c1 - win1, 0), min(c1 + win1 + 1, n1)):
                idx[k] = ik
                idx[o0] = i0
                idx[o1] = i1
                for a in range(3):
                    x[a] = (idx[a] + 0.5) * h[a]
                # distance to this copy's axis
                rel0 = x[0] - p[0]
                rel1 = x[1] - p[1]
                rel2 = x[2] - p[2]
                along = rel0 * d[0] + rel1 * d[1] + rel2 * d[2]
                q0 = rel0 - along * d[0]
                q1 = rel1 - along * d[1]
                q2 = rel2 - along * d[2]
                if q0 * q0 + q1 * q1 + q2 * q2 > r2:
                    continue
                if cylinder:
                    e0 = x[0] - cyl_center[0]
                    e1 = x[1] - cyl_center[1]
                    e2 = x[2] - cyl_center[2]
                    a_ = e0 * lat0[0] + e1 * lat0[1] + e2 * lat0[2]
                    b_ = e0 * lat1[0] + e1 * lat1[1] + e2 * lat1[2]
                    a_ -= np.round(a_)
                    b_ -= np.round(b_)
                    val = np.sqrt(a_ * a_ + b_ * b_) - cyl_radius
                else:
                    val = (psi_value(model, x[0], x[1], x[2]) - iso) / grad
                clipped = min(val, margin)
                i, j, l_ = idx[0], idx[1], idx[2]
                if clipped < distance[i, j, l_]:
                    distance[i, j, l_] = clipped
                if val <= 0.0 and mark[i, j, l_] != mark_id:
                    mark[i, j, l_] = mark_id
                    if count[i, j, l_] < 255:
                        count[i, j, l_] += 1
