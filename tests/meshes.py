"""Small structured tetrahedral meshes with tagged boundaries, for validation and benchmarks.

Tag names follow the mesher's convention: ``inlet``/``outlet`` on the two box faces normal to
the flow axis, ``side_x0``, ``side_x1``, ... on the other box faces, ``wall`` on everything
else (e.g. cylinder surfaces).
"""

from __future__ import annotations

from itertools import permutations

import numpy as np

from solvers.fem.boundary import boundary_triangles

AXES = "xyz"


def kuhn_tets(shape: tuple[int, int, int]) -> np.ndarray:
    """Conforming 6-tetrahedra (Kuhn) split of a structured grid of ``shape`` vertices.

    Vertex (i, j, k) has index ``np.ravel_multi_index((i, j, k), shape)``.
    """
    ni, nj, nk = shape
    i, j, k = np.meshgrid(np.arange(ni - 1), np.arange(nj - 1), np.arange(nk - 1), indexing="ij")
    base = np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1)
    out = []
    for perm in permutations(range(3)):
        corners = [np.zeros(3, int)]
        for a in perm:
            nxt = corners[-1].copy()
            nxt[a] = 1
            corners.append(nxt)
        ids = [np.ravel_multi_index(tuple((base + c).T), shape) for c in corners]
        out.append(np.stack(ids, axis=1))
    return np.concatenate(out)


def orient_positive(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Swap two vertices of negatively oriented tetrahedra."""
    a, b, c, d = (points[tets[:, i]] for i in range(4))
    vol = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)
    tets = tets.copy()
    neg = vol < 0
    tets[neg, 0], tets[neg, 1] = tets[neg, 1].copy(), tets[neg, 0].copy()
    return tets


def merge_points(points: np.ndarray, tets: np.ndarray, decimals: int = 9):
    """Merge coincident points (after rounding to ``decimals`` relative to the extent)."""
    scale = np.ptp(points, axis=0).max()
    key = np.round(points / scale, decimals)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return points[first], inv.ravel()[tets]


def tag_box_boundary(
    points: np.ndarray,
    tets: np.ndarray,
    lo,
    hi,
    flow_axis: int,
    rel_tol: float = 1e-7,
) -> dict[str, np.ndarray]:
    """Tag boundary triangles by the box face they lie on; all others are ``wall``.

    Parameters
    ----------
    lo, hi : sequences of 3 floats
        Box corners.
    flow_axis : int
        0, 1 or 2: faces normal to it become ``inlet`` (at lo) and ``outlet`` (at hi).
    """
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    tris = boundary_triangles(tets)
    tol = rel_tol * (hi - lo).max()
    taken = np.zeros(len(tris), dtype=bool)
    tags: dict[str, np.ndarray] = {}
    for ax in range(3):
        for side, val in ((0, lo[ax]), (1, hi[ax])):
            on = np.all(np.abs(points[tris][:, :, ax] - val) < tol, axis=1)
            if ax == flow_axis:
                name = "inlet" if side == 0 else "outlet"
            else:
                name = f"side_{AXES[ax]}{side}"
            tags[name] = tris[on & ~taken]
            taken |= on
    tags["wall"] = tris[~taken]
    return tags


def box_mesh(lo, hi, n) -> tuple[np.ndarray, np.ndarray]:
    """Structured Kuhn tet mesh of the box [lo, hi] with n = (nx, ny, nz) cells per axis."""
    axes = [np.linspace(lo[a], hi[a], n[a] + 1) for a in range(3)]
    g = np.meshgrid(*axes, indexing="ij")
    pts = np.stack([c.ravel() for c in g], axis=1)
    tets = kuhn_tets(tuple(int(k) + 1 for k in n))
    return pts, orient_positive(pts, tets)


def quarter_cell_2d(half: float, radius: float, n_theta: int, n_r: int) -> np.ndarray:
    """Points (n_r+1, 2 n_theta+1, 2) of the square [0, half]^2 minus a quarter disc at 0.

    Radial lines join the circle (uniform in angle) to the square sides (uniform in length).
    """
    if not 0 < radius < half:
        raise ValueError(f"radius must lie in (0, half={half}), got {radius}")
    j = np.arange(2 * n_theta + 1)
    theta = 0.5 * np.pi * j / (2 * n_theta)
    inner = radius * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    s = j / n_theta
    outer = np.where(
        (j <= n_theta)[:, None],
        np.stack([np.full_like(s, half), half * s], axis=1),
        np.stack([half * (2 - s), np.full_like(s, half)], axis=1),
    )
    t = (np.arange(n_r + 1) / n_r)[:, None, None]
    return inner[None] + t * (outer - inner)[None]


def _extrude(p2d: np.ndarray, z: np.ndarray):
    ni, nj, _ = p2d.shape
    nk = len(z)
    pts = np.empty((ni, nj, nk, 3))
    pts[..., :2] = p2d[:, :, None, :]
    pts[..., 2] = z[None, None, :]
    pts = pts.reshape(-1, 3)
    tets = kuhn_tets((ni, nj, nk))
    return pts, orient_positive(pts, tets)


def cylinder_parallel_cell(
    spacing: float, radius: float, length: float, n_theta: int, n_r: int, n_z: int = 1
):
    """Quarter unit cell of a square array of cylinders along z (flow along the cylinders).

    Domain [0, s/2]^2 x [0, length] minus the quarter cylinder of radius ``radius`` on the z
    axis; the four lateral faces are symmetry planes of the periodic array (tag them slip).

    Returns
    -------
    points, tets, tags
    """
    p2d = quarter_cell_2d(spacing / 2, radius, n_theta, n_r)
    pts, tets = _extrude(p2d, np.linspace(0, length, n_z + 1))
    tags = tag_box_boundary(pts, tets, (0, 0, 0), (spacing / 2, spacing / 2, length), 2)
    return pts, tets, tags


def cylinder_transverse_row(
    spacing: float,
    radius: float,
    n_cells: int,
    n_theta: int,
    n_r: int,
    depth: float | None = None,
    n_z: int = 1,
):
    """Row of ``n_cells`` half unit cells of a square cylinder array, flow along x.

    Cylinders along z at (x, y) = ((i + 1/2) s, 0), domain [0, n s] x [0, s/2] x [0, depth]
    minus the half cylinders. The y and z faces are symmetry planes of the periodic array
    (tag them slip); x = 0 is the inlet, x = n s the outlet. ``n_z`` element layers in z
    (default depth: one radial element size per layer).
    """
    h = spacing / 2
    depth = n_z * h / n_r if depth is None else depth
    q = quarter_cell_2d(h, radius, n_theta, n_r)
    right_pts, right_tets = _extrude(q, np.linspace(0.0, depth, n_z + 1))
    left_pts = right_pts * np.array([-1.0, 1.0, 1.0])
    pts = np.concatenate([left_pts, right_pts])
    tets = np.concatenate([right_tets, right_tets + len(right_pts)])
    cells_p = [pts + np.array([(2 * i + 1) * h, 0.0, 0.0]) for i in range(n_cells)]
    cells_t = [tets + i * len(pts) for i in range(n_cells)]
    pts, tets = merge_points(np.concatenate(cells_p), np.concatenate(cells_t))
    tets = orient_positive(pts, tets)
    tags = tag_box_boundary(pts, tets, (0, 0, 0), (n_cells * spacing, h, depth), 0)
    return pts, tets, tags


def snap_to_box(points: np.ndarray, lo, hi, rel_tol: float = 2e-3) -> np.ndarray:
    """Copy of ``points`` with coordinates within ``rel_tol * extent`` of a box plane set onto it.

    fTetWild (pytetwild) keeps the surface only within an envelope (default 1e-3 of the bounding
    box diagonal), so its box faces are not exactly planar; snapping restores flat faces for
    tagging and for slip conditions.
    """
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    tol = rel_tol * float((hi - lo).max())
    out = points.copy()
    for ax in range(3):
        for val in (lo[ax], hi[ax]):
            near = np.abs(out[:, ax] - val) < tol
            out[near, ax] = val
    return out
