"""The two nearest fibre walls at any points: what the diffuse-domain wall needs.

The voxel solver's diffuse wall (:mod:`solvers.voxel.diffuse`, issue 12 item 3) weights every
point of the grid by a fluid fraction and a drag that depend on the signed distance ``s`` to
the nearest wall, the curvature ``kappa`` (Laplacian of the distance) and the normal's grid
anisotropy ``n_x^4 + n_y^4 + n_z^4``; in narrow gaps the second-nearest wall counts too (the
``pair`` rule, ``benchmarks/RESULTS.md`` wall22). Unlike the cut-face wall, which reads the
distance within a voxel of the surface, the diffuse layer reaches several voxels into the fluid,
so ``s`` must be a true distance there, not the PS field's first-order estimate.

Straight fibres with a circular-like cross-section have one in closed form (:data:`SHAPES`):

* ``cylinder``: ``s = r - D / 2``, ``r`` the distance to the nearest axis copy;
* ``rod`` (paper Eq. 4, ``4 cos 2 pi x + 4 cos 2 pi y + 3 <= psi0`` about its axis): ``s = r -
  R(theta)``, ``R(theta)`` the radius of the cross-section's boundary in the point's direction
  (Newton on the closed form). The rod's cross-section departs from a circle by ``O((pi D)^2)``
  relative, so ``r - R(theta)`` is its distance to within that fraction of ``s``.

Both take ``kappa = 1 / r`` and the normal ``(a l_0 + b l_1) / r`` (``a``, ``b`` the point's
offsets from the axis along the fibre's lattice vectors). Every fibre's copies repeat one period
apart across its axis; the two nearest copies of each fibre are candidates, so a one-fibre
periodic array sees its neighbour copy as the second wall. Other shapes (bent, compressed,
woven, PS-model fibres) have no such distance: :func:`unsupported` says why.
"""

from __future__ import annotations

import numpy as np

from psdesign.geometry.fibers import Fiber, rod_isovalue
from psdesign.geometry.rve import RVE

#: Fibre shapes whose wall distance, curvature and normal are known in closed form.
SHAPES = ("cylinder", "rod")
#: Distance (voxels) reported for a wall not looked at (beyond ``reach``): farther than any
#: wall layer reaches, finite so that the profile evaluates it to plain fluid.
FAR = 1e9
#: Stands in (periods) for a wall's axis coordinate along its own fibre in its identity: no
#: point is that far, so fibres along different axes never share an identity.
_AXIS_TAG = 1e6
#: Newton steps for the rod's boundary radius (quadratic convergence from ``D / 2``: the
#: boundary departs from the circle by < 1 % of ``D`` for ``D`` < 0.3 periods).
_NEWTON_STEPS = 6
#: Smallest axis distance used for ``kappa`` (voxels): the axis itself is deep in the solid.
_MIN_AXIS_DISTANCE = 0.5
#: Points farther than this (voxels) outside a rod's ``D / 2`` circle take ``D / 2`` as its
#: boundary radius: beyond the diffuse layer (a few voxels) the wall's distance is not read.
_NEWTON_REACH_VOXELS = 16.0
#: Boundary radius of a rod or cylinder over its diameter, at most (the rod's cross-section is
#: within 1 % of its D / 2 circle for D < 0.3 periods; 0.6 also covers D up to 0.5).
_RADIUS_BOUND = 0.6


def unsupported(rve: RVE) -> str | None:
    """Why :class:`NearestWalls` cannot be put on ``rve`` (None when it can): a fibre of a shape
    outside :data:`SHAPES`, or a bent fibre.

    Parameters
    ----------
    rve : RVE
        The RVE.

    Returns
    -------
    str or None
        The reason, naming the fibre.
    """
    if not rve.fibers:
        return "the RVE has no fibers"
    for i, fb in enumerate(rve.fibers):
        if fb.shape not in SHAPES or fb.u != 0.0:
            return (
                f"fiber {i} has shape {fb.shape!r}: the diffuse wall needs straight "
                f"{' or '.join(SHAPES)} fibers (a closed-form wall distance)"
            )
    return None


def untiled_axis(fb: Fiber, box: np.ndarray) -> int | None:
    """The first axis ``i`` along which a shift by the box edge ``box[i]`` (periods) does not
    map ``fb``'s family of copies onto itself (None when every one does).

    The solver wraps the box; :class:`NearestWalls` sees the fibre's copies. The two agree when
    ``box[i] e_i`` is a whole lattice vector plus a shift along the axis: its components on
    both lattice vectors are integers. A square array of one cell along x and y passes at any
    depth; a hexagonal cell (``sqrt(3) L`` wide, period the largest edge) or two cells of a
    square array (period 2 L, width L) do not: there :class:`NearestWalls` tiles the box's
    content itself (:func:`box_shifts`).

    Parameters
    ----------
    fb : Fiber
        The fibre (normalized coordinates).
    box : ndarray (3,)
        Box edges in PS periods (``rve.size / rve.period``).

    Returns
    -------
    int or None
        0, 1 or 2 for x, y or z.
    """
    axes = _untiled_axes(fb, box)
    return axes[0] if axes else None


def along_box_axis(fb: Fiber) -> bool:
    """Is the fibre's axis one of the box axes (to 1e-9)?

    Parameters
    ----------
    fb : Fiber
        The fibre.

    Returns
    -------
    bool
    """
    return bool(np.max(np.abs(fb.direction)) > 1.0 - 1e-9)


def _rod_radius(fb: Fiber, a: np.ndarray, b: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Radius (periods) of the rod's boundary ``cos 2 pi x + cos 2 pi y = c0`` in the
    direction ``(a, b) / r`` of each point."""
    c0 = (3.0 - rod_isovalue(fb.diameter)) / 4.0
    rr = np.maximum(r, 1e-300)
    ca, cb = a / rr, b / rr
    rad = np.full(r.shape, fb.diameter / 2.0)
    for _ in range(_NEWTON_STEPS):
        g = np.cos(2 * np.pi * rad * ca) + np.cos(2 * np.pi * rad * cb) - c0
        dg = -2 * np.pi * (ca * np.sin(2 * np.pi * rad * ca) + cb * np.sin(2 * np.pi * rad * cb))
        rad = rad - g / np.where(np.abs(dg) > 1e-12, dg, -1e-12)
    return rad


def _copy_wall(fb: Fiber, a: np.ndarray, b: np.ndarray, to_voxels: float) -> tuple:
    """``(s, kappa, aniso)`` (voxels) of the copy of ``fb`` whose axis is at offsets ``(a, b)``
    (periods, along the fibre's lattice vectors) from the points."""
    r = np.hypot(a, b)
    if fb.shape == "cylinder":
        radius = fb.diameter / 2.0
    else:
        # the rod's boundary radius matters only within the diffuse layer: far points keep D/2
        radius = np.full(r.shape, fb.diameter / 2.0)
        near = r * to_voxels < fb.diameter / 2.0 * to_voxels + _NEWTON_REACH_VOXELS
        radius[near] = _rod_radius(fb, a[near], b[near], r[near])
    rr = np.maximum(r, 1e-300)
    nx, ny = a / rr, b / rr
    l0, l1 = fb.lattice
    aniso = sum((nx * l0[i] + ny * l1[i]) ** 4 for i in range(3))
    aniso = np.where(r > 0, aniso, 1.0)
    return (r - radius) * to_voxels, 1.0 / np.maximum(r * to_voxels, _MIN_AXIS_DISTANCE), aniso


def _copy_offsets(fb: Fiber, xi: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Offsets ``(a, b)`` (periods, along the fibre's lattice vectors) from the points ``xi``
    (N, 3) to the axes of the two nearest copies of ``fb``. The copies sit on a square lattice
    of one period across the axis, so with the offsets reduced to ``[-1/2, 1/2]`` the nearest
    copy is the one at ``(a, b)`` and the second the nearer of ``(a - sign a, b)`` and ``(a,
    b - sign b)``."""
    rel = xi - fb.center
    a = rel @ fb.lattice[0]
    b = rel @ fb.lattice[1]
    a -= np.round(a)
    b -= np.round(b)
    a2 = a - np.where(a >= 0, 1.0, -1.0)
    b2 = b - np.where(b >= 0, 1.0, -1.0)
    step_a = a2 * a2 + b * b <= a * a + b2 * b2
    return [(a, b), (np.where(step_a, a2, a), np.where(step_a, b, b2))]


class NearestWalls:
    """The two nearest walls of an RVE's fibres at points given in voxel coordinates.

    Parameters
    ----------
    rve : RVE
        Fibres of :data:`SHAPES` only (:func:`unsupported`).
    voxel : float
        Voxel edge (m); point ``(x, y, z)`` in voxels is ``(x, y, z) voxel`` in metres (the cell
        ``(i, j, k)`` spans ``[i, i + 1] voxel`` along x, as :class:`psdesign.geometry.rve.
        VoxelGrid`).

    Calling it with arrays ``x, y, z`` (voxels, any equal shape) returns
    ``[(s1, kappa1, aniso1), (s2, kappa2, aniso2)]``: the nearest and the second-nearest wall,
    ``s`` the signed distance in voxels (> 0 in the pore), ``kappa`` in 1 / voxel. With ``reach``
    (voxels) a wall farther than that from a point is not looked at: where fewer than two are
    within reach, the missing ones are ``(FAR, 0, 1)`` (a wall out of any reach; finite, as the
    solver requires). The walls are those of the geometry the periodic solver sees, the box's
    content tiled (:func:`box_shifts`: the fibres' own copies where they repeat with the box;
    a reach below the box edges).

    >>> from psdesign.geometry.fibers import make_fiber
    >>> rve = RVE([1e-4, 1e-4, 1e-5], [make_fiber("cylinder", 0.4, direction=[0, 0, 1])])
    >>> x, y, z = np.array([50.0]), np.array([95.0]), np.array([0.0])
    >>> (s, kappa, aniso), _ = NearestWalls(rve, 1e-6)(x, y, z)
    >>> round(float(s[0]), 9), round(float(kappa[0]), 9), float(aniso[0])
    (25.0, 0.022222222, 1.0)
    """

    def __init__(self, rve: RVE, voxel: float, reach: float | None = None) -> None:
        why = unsupported(rve)
        if why is not None:
            raise ValueError(why)
        self.rve, self.voxel = rve, float(voxel)
        self.reach = np.inf if reach is None else float(reach)
        self.box = np.asarray(rve.size, float) / float(rve.period)
        self.shifts, self.untiled = box_shifts(rve.fibers, self.box)

    def __call__(self, x, y, z) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        shape = np.broadcast(x, y, z).shape
        pts = np.stack([np.broadcast_to(c, shape).ravel() for c in (x, y, z)], axis=1)
        xi = pts * (self.voxel / float(self.rve.period))
        to_voxels = float(self.rve.period) / self.voxel
        n = len(xi)
        best = [
            (np.full(n, FAR), np.zeros(n), np.ones(n), np.full((n, 3), np.nan)),
            (np.full(n, FAR), np.zeros(n), np.ones(n), np.full((n, 3), np.nan)),
        ]
        for fb in self.rve.fibers:
            # a bound on the boundary radius: the rod's departs from D / 2 by O((pi D)^2)
            bound = fb.diameter * _RADIUS_BOUND
            limit = bound + self.reach / to_voxels if self.reach < np.inf else np.inf
            along = int(np.argmax(np.abs(fb.direction)))
            for k in self.shifts:
                for a, b in _copy_offsets(fb, xi + k):
                    # the copy's axis (a point on it, periods) as the point sees it: the shift
                    # undone; its coordinate along the fibre is any, so replaced by a tag of
                    # the axis (the identity: crossing fibres along x and z are two walls)
                    foot = xi - a[:, None] * fb.lattice[0] - b[:, None] * fb.lattice[1]
                    foot[:, along] = _AXIS_TAG * (along + 1)
                    keep = np.hypot(a, b) < limit
                    if self.untiled:  # only copies the box holds: the solver tiles the box
                        held = foot + k
                        for i in self.untiled:
                            if i != along:
                                keep &= (held[:, i] > -bound) & (held[:, i] < self.box[i] + bound)
                    idx = np.flatnonzero(keep)
                    if idx.size:
                        wall = _copy_wall(fb, a[idx], b[idx], to_voxels)
                        _insert(best, (*wall, foot[idx]), idx)
        return [tuple(v.reshape(shape) for v in w[:3]) for w in best]


def box_shifts(fibers, box: np.ndarray) -> tuple[list[np.ndarray], tuple[int, ...]]:
    """Shifts (periods) at which :class:`NearestWalls` looks at the fibres' copies, and the
    axes along which the box does not map the copies onto themselves (:func:`untiled_axis`).

    Where every fibre's copies repeat with the box, the copies are the walls (one shift, 0).
    Else the solver's geometry is the box's content tiled: the copies the box holds, seen from
    the point and from its images one box edge away along each untiled axis (enough within a
    reach shorter than the box edge). That needs every fibre along a box axis; with any other,
    the copies themselves are the walls (:func:`psdesign.flow.diffuse.unsupported` refuses such
    an RVE).

    Parameters
    ----------
    fibers : sequence of Fiber
        The RVE's fibres.
    box : ndarray (3,)
        Box edges in PS periods.

    Returns
    -------
    shifts : list of ndarray (3,)
        Shifts in periods (``[0, 0, 0]`` alone where the copies repeat with the box).
    untiled : tuple of int
        The axes the shifts run along.
    """
    untiled = sorted({i for fb in fibers for i in _untiled_axes(fb, box)})
    if not all(along_box_axis(fb) for fb in fibers):
        untiled = []  # the copies themselves: a tilted fibre's tiled content has no closed form
    steps = [(-1.0, 0.0, 1.0) if i in untiled else (0.0,) for i in range(3)]
    shifts = [
        np.array([u * box[0], v * box[1], w * box[2]])
        for u in steps[0]
        for v in steps[1]
        for w in steps[2]
    ]
    return shifts, tuple(untiled)


def _untiled_axes(fb: Fiber, box: np.ndarray) -> list[int]:
    """Every axis of :func:`untiled_axis`."""
    out = []
    for i in range(3):
        m = np.asarray(fb.lattice)[:, i] * box[i]
        if np.any(np.abs(m - np.round(m)) > 1e-9):
            out.append(i)
    return out


def _insert(best: list[tuple], wall: tuple, idx: np.ndarray) -> None:
    """Keep in ``best`` (nearest first, full arrays, updated in place) the two nearest of it and
    ``wall`` ``(s, kappa, aniso, axis)`` (given at the points ``idx``); a wall whose axis is
    already one of the two (the same cylinder reached from another fibre or image) is skipped."""
    old = [[v[idx] for v in w] for w in best]
    same = np.zeros(idx.size, bool)
    for w in old:
        same |= np.all(np.abs(wall[3] - w[3]) < 1e-9, axis=1)
    first = ~same & (wall[0] < old[0][0])
    second = ~same & ~first & (wall[0] < old[1][0])
    for k in range(4):
        f = first if k < 3 else first[:, None]
        g = second if k < 3 else second[:, None]
        best[0][k][idx] = np.where(f, wall[k], old[0][k])
        best[1][k][idx] = np.where(f, old[0][k], np.where(g, wall[k], old[1][k]))
