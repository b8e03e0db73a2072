"""Point location and evaluation of P2 / P1 fields on a tetrahedral mesh (vectorized)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


class PointLocator:
    """Find the tetrahedron containing each query point (KD-tree on centroids + barycentrics).

    Parameters
    ----------
    points : (n, 3) array
    tets : (m, 4) int array
    """

    def __init__(self, points: np.ndarray, tets: np.ndarray):
        self.points = points
        self.tets = tets
        self.tree = cKDTree(points[tets].mean(axis=1))

    def barycentric(self, x: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """Barycentric coordinates (k, 4) of points x (k, 3) in tetrahedra ``cells`` (k,)."""
        v = self.points[self.tets[cells]]  # (k, 4, 3)
        T = np.transpose(v[:, 1:] - v[:, :1], (0, 2, 1))  # (k, 3, 3)
        lam = np.linalg.solve(T, (x - v[:, 0])[:, :, None])[:, :, 0]
        return np.concatenate([1 - lam.sum(axis=1, keepdims=True), lam], axis=1)

    def locate(self, x: np.ndarray, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
        """Cell index (-1 if outside) and barycentric coordinates of each point."""
        k = len(x)
        cells = np.full(k, -1, dtype=np.int64)
        lam = np.zeros((k, 4))
        todo = np.arange(k)
        n_tets = len(self.tets)
        for n_cand in (8, 32, 128):
            if len(todo) == 0:
                break
            nc = min(n_cand, n_tets)
            _, cand = self.tree.query(x[todo], k=nc)
            cand = cand.reshape(len(todo), nc)
            for j in range(nc):
                sel = cells[todo] < 0
                if not sel.any():
                    break
                idx = todo[sel]
                c = cand[sel, j]
                lj = self.barycentric(x[idx], c)
                ok = lj.min(axis=1) >= -tol
                cells[idx[ok]] = c[ok]
                lam[idx[ok]] = lj[ok]
            todo = todo[cells[todo] < 0]
        return cells, lam


def p2_weights(
    t: np.ndarray, edges: np.ndarray, t2e: np.ndarray, cells: np.ndarray, lam: np.ndarray
) -> np.ndarray:
    """Values (10, k) of the 10 P2 basis functions, in skfem's element dof order.

    Rows 0-3: vertex functions ``l_i (2 l_i - 1)``; rows 4-9: edge functions ``4 l_a l_b`` for
    the element's edges ``t2e`` (endpoints matched to local vertices, order-independent).
    """
    w = np.empty((10, len(cells)))
    tc = t[:, cells]  # (4, k)
    for i in range(4):
        w[i] = lam[:, i] * (2 * lam[:, i] - 1)
    for e in range(6):
        ends = edges[:, t2e[e, cells]]  # (2, k)
        ia = np.argmax(tc == ends[0], axis=0)
        ib = np.argmax(tc == ends[1], axis=0)
        r = np.arange(len(cells))
        w[4 + e] = 4 * lam[r, ia] * lam[r, ib]
    return w
