"""Finest-level coefficients of the MAC voxel Stokes operator: wall treatment and box walls.

Each velocity component ``a`` has a 7-point operator ``(diag, c)`` on the faces normal to ``a``
(layout of :mod:`solvers.voxel.kernels`).  A face is *active* (an unknown) or pinned to 0.  For
an active face every one of its six neighbour faces (same component) contributes

* 1 to the diagonal and a coupling 1 when the neighbour is active;
* ``1 / theta`` to the diagonal and no coupling when it is not: the no-slip wall lies at the
  fraction ``theta`` (0 < theta <= 1) of the spacing between the face and that neighbour, and
  the neighbour value is the linear ghost extrapolation through ``u = 0`` on the wall.

This is the symmetric ghost-fluid (Shortley-Weller type) discretisation of Gibou, Fedkiw, Cheng &
Kang, *J. Comput. Phys.* 176 (2002) 205-227: only the diagonal changes, so every component
operator stays symmetric positive definite (and so do the Galerkin multigrid levels and the
saddle-point system that MINRES solves); the solution is second-order accurate.

*Staircase* (binary image): a face is active when both of its cells are fluid; an inactive
neighbour has ``theta = 1`` (node on the solid surface), or ``theta = 1/2`` for a tangential
neighbour whose two cells are both solid (the wall on the voxel face half a cell away).  These
are small integers, stored as uint8 (identical to
:func:`solvers.voxel.multigrid.component_operator`).

*Sub-voxel* (signed distance ``phi`` at the cell centres, > 0 in the fluid, in voxels): the
distance at a face centre is the mean of its two cells; a face is active when that is > 0 (its
centre lies in the fluid) and ``theta = phi_f / (phi_f - phi_nb)`` from the face and the
neighbour distances (clipped below at ``THETA_MIN``).  Pressure cells are the cells with at least
one active face (a cut cell whose centre lies in the solid still carries the mass balance of its
fluid faces), except a cell with a single one, which is merged into its neighbour
(:func:`pressure_cells`).

Cut control volumes: the diagonal-only closure alone leaves an O(1) truncation error at the
near-wall faces (1-D: the discrete operator returns ``(1 + theta) / 2`` times the curvature).
Each active face therefore gets a weight ``w_f = min_b [1 + sum_s (theta_bs - 1) / 2]`` (the
fluid fraction of its control volume along the most cut axis ``b``, ``s`` over the wall sides),
used for the body force, the pressure force and the face's flux in the mass balance: the
saddle-point matrix ``[[A, W G], [G^T W, 0]]`` stays symmetric and a pressure balancing the body
force in a closed pocket still gives no flow.  With it plane Poiseuille between off-grid walls
is exact at the nodes (the K error, 1.6e-2 / 4.3e-3 / 1.1e-3 at 8 / 15 / 30 voxels across, is
the quadrature of the mean) and cylinder arrays converge from one side.

*Alignment scatter*: K depends on where the wall cuts the cells (a shift of the geometry by a
fraction of a voxel moves it), standard deviation over sub-voxel shifts 0.03-0.09 % at 32 voxels
per cylinder spacing, 0.01-0.03 % at 64 (square arrays; ``docs/validation.md``, 'Alignment
floor'). It is how the face-centred velocity nodes sample the wall: across the cylinders exact
wall fractions from the analytic distance, exact control-volume fractions or face apertures as
``w_f``, another ``THETA_MIN``, keeping or merging the lone cells, or the consistent
(non-symmetric) Shortley-Weller closure all leave it (or make it larger); along them (no pressure
cells) a ``THETA_MIN`` of 0.005-0.01 cuts it 3-5x at solid fraction 0.3, not at 0.1
(``benchmarks/voxel_scatter.py``; ``benchmarks/RESULTS.md``, "Issue 12 item 3, alignment scatter
(mono11, 2026-12-02)").

*Box walls* (``walls``: axes whose two box faces are walls instead of periodic seams): the face
on the box face is pinned (no penetration); a tangential component loses its neighbour across
the wall (``"slip"``: zero shear, contribution 0) or sees the wall half a cell away
(``"noslip"``: contribution 2).
"""

from __future__ import annotations

import numpy as np

THETA_MIN = 0.05
"""Smallest wall fraction used (a face within 5 % of a spacing of the wall): bounds the diagonal
at 20 and with it the stiffness of the near-wall faces; moving the wall by < 0.05 h at these few
faces changes K by far less than the discretisation error."""


def face_distance(phi: np.ndarray, a: int) -> np.ndarray:
    """Signed distance at the centres of the faces normal to ``a`` (mean of the two cells)."""
    return 0.5 * (phi + np.roll(phi, 1, axis=a))


def component_coefficients(
    a: int,
    fluid: np.ndarray | None = None,
    phi_faces: list[np.ndarray] | None = None,
    walls: dict[int, str] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Diagonal, couplings and activity of velocity component ``a``.

    Parameters
    ----------
    a : int
        Component (axis) 0, 1, 2.
    fluid : np.ndarray of bool, optional
        Fluid cells (staircase treatment); used when ``phi_faces`` is None.
    phi_faces : list of 3 np.ndarray, or dict, optional
        Signed distance (voxels, > 0 in the fluid) at the face centres of each component
        (sub-voxel treatment; see :func:`face_distance`); only ``phi_faces[a]`` is read, so a
        caller may form one component's faces at a time (``{a: faces_a}``).
    walls : dict {axis: 'slip' | 'noslip'}, optional
        Axes whose box faces are walls (not periodic).

    Returns
    -------
    diag : np.ndarray
        uint8 (staircase) or float32 (sub-voxel); 0 on inactive faces.
    c : np.ndarray, uint8, shape (3, nx, ny, nz)
        Couplings to the lower neighbour along each axis.
    act : np.ndarray of bool
        Active faces.
    weight : np.ndarray (float32) or None
        Cut-control-volume weights ``w_f`` (sub-voxel; 0 on inactive faces), None for the
        staircase.
    """
    walls = walls or {}
    if phi_faces is None:
        act = fluid & np.roll(fluid, 1, axis=a)
        solid = ~fluid
        both_solid = solid & np.roll(solid, 1, axis=a)
        phi = None
    else:
        phi = phi_faces[a]
        act = phi > 0.0
    for b in walls:
        if b == a:
            act = act.copy()
            idx = [slice(None)] * 3
            idx[a] = 0
            act[tuple(idx)] = False
    shape = act.shape
    diag = np.zeros(shape, np.float64)
    c = np.empty((3, *shape), dtype=np.uint8)
    weight = np.ones(shape, np.float64)
    for b in range(3):
        vol_b = np.ones(shape, np.float64)
        c[b] = act & np.roll(act, 1, axis=b)
        for s in (-1, 1):
            nb_act = np.roll(act, -s, axis=b)
            if phi is None:
                ghost = 1.0 + (np.roll(both_solid, -s, axis=b) if b != a else 0.0)
                contrib = np.where(nb_act, 1.0, ghost)
            else:
                contrib = _ghost_fluid(phi, np.roll(phi, -s, axis=b), nb_act, vol_b)
            if b in walls:
                # the neighbour across the box face (rows 0 for s = -1, n - 1 for s = +1)
                n = shape[b]
                rows = [slice(None)] * 3
                rows[b] = 0 if s < 0 else n - 1
                rows = tuple(rows)
                if b == a:
                    # normal component: the neighbour face lies on the wall (pinned, theta = 1);
                    # for s = -1 that is face 0 itself (pinned above), so row 1 sees it
                    rows1 = [slice(None)] * 3
                    rows1[b] = 1 % n if s < 0 else n - 1
                    contrib[tuple(rows1)] = 1.0
                else:
                    contrib[rows] = 0.0 if walls[b] == "slip" else 2.0
            diag += contrib
        np.minimum(weight, vol_b, out=weight)
        if b in walls:
            idx = [slice(None)] * 3
            idx[b] = 0
            c[b][tuple(idx)] = 0
    diag[~act] = 0.0
    if phi is None:
        return diag.astype(np.uint8), c, act, None
    weight[~act] = 0.0
    return diag.astype(np.float32), c, act, weight.astype(np.float32)


def _ghost_fluid(
    phi: np.ndarray, nb_phi: np.ndarray, nb_act: np.ndarray, vol_b: np.ndarray
) -> np.ndarray:
    """Sub-voxel contribution of one neighbour side to the diagonal: 1 where the neighbour
    ``nb_act`` is active, ``1 / theta`` (``theta = phi / (phi - min(nb_phi, 0))`` clipped to
    ``[THETA_MIN, 1]``) where it is not; adds the wall's ``(theta - 1) / 2`` to ``vol_b`` there.

    Element-wise the arithmetic of the plain expressions, in place in ``nb_phi`` (which it
    overwrites and returns) and one temporary: two float64 grids instead of seven (the set-up
    was the sub-voxel solve's peak).
    """
    theta = nb_phi
    np.minimum(theta, 0.0, out=theta)
    np.subtract(phi, theta, out=theta)
    with np.errstate(divide="ignore", invalid="ignore"):
        np.divide(phi, theta, out=theta)
    np.nan_to_num(theta, copy=False, nan=1.0, posinf=1.0)
    np.clip(theta, THETA_MIN, 1.0, out=theta)
    half = np.subtract(theta, 1.0)
    half *= 0.5
    half[nb_act] = 0.0
    vol_b += half
    del half
    np.divide(1.0, theta, out=theta)
    theta[nb_act] = 1.0
    return theta


def pressure_cells(acts: list[np.ndarray], weights: list[np.ndarray] | None = None) -> np.ndarray:
    """Cells with at least one active face (they carry a pressure and a mass balance).

    With the sub-voxel ``weights`` (modified in place), a cell left with a single weighted face
    is released: its mass balance ``w_f q_f = 0`` would pin that face, whose centre lies in the
    fluid, to zero velocity (a wall moved up to half a cell into the fluid). The cell drops out
    of the pressure cells and the face's weight becomes 0 (no pressure force, no flux in the
    neighbour's balance, no body force: the face is carried by its viscous couplings alone, a
    merge of the sliver into the neighbouring cell). Repeated until no such cell is left. Square
    array across at solid fraction 0.3, 24 / 32 / 40 / 48 / 64 / 96 voxels per spacing: -0.14 /
    -0.38 / -0.09 / -0.28 / -0.14 / -0.11 % before, -0.10 / -0.16 / -0.04 / -0.12 / -0.08 /
    -0.02 % after (``benchmarks/RESULTS.md``).
    """
    cells = np.zeros(acts[0].shape, dtype=bool)
    for a, act in enumerate(acts):
        cells |= act | np.roll(act, -1, axis=a)
    if weights is None:
        return cells
    while True:
        count = np.zeros(cells.shape, np.int8)
        for a, w in enumerate(weights):
            on = w > 0.0
            count += on.astype(np.int8) + np.roll(on, -1, axis=a).astype(np.int8)
        lone = cells & (count == 1)
        if not lone.any():
            return cells
        for a, w in enumerate(weights):
            w[(w > 0.0) & (lone | np.roll(lone, 1, axis=a))] = 0.0
        cells &= ~lone


def pad_reservoirs(
    solid: np.ndarray, distance: np.ndarray | None, d: int, n_aux: int
) -> tuple[np.ndarray, np.ndarray | None]:
    """Empty inlet/outlet reservoirs of ``n_aux`` cells on both ends of axis ``d``.

    The distance in the reservoir is that of the cut fibre ends: ``(j + 1/2)`` voxels in front of
    a solid face cell, ``sqrt(phi0^2 + (j + 1/2)^2)`` in front of a fluid one (``phi0`` its
    distance); ``j`` counts the layers from the RVE face.
    """
    pad = [(0, 0)] * 3
    pad[d] = (n_aux, n_aux)
    grid = np.pad(solid, pad, constant_values=False)
    if distance is None:
        return grid, None
    j = np.arange(n_aux) + 0.5
    shape_j = [1, 1, 1]
    shape_j[d] = n_aux
    j = j.reshape(shape_j)

    def layer(face: np.ndarray) -> np.ndarray:
        f = np.expand_dims(face, d)
        return np.where(f > 0.0, np.sqrt(np.maximum(f, 0.0) ** 2 + j**2), j)

    first = np.take(distance, 0, axis=d)
    last = np.take(distance, -1, axis=d)
    lo = np.flip(layer(first), axis=d)
    hi = layer(last)
    phi = np.concatenate([lo, distance, hi], axis=d)
    return grid, phi


def rve_plane_faces(phi_face: np.ndarray, phi: np.ndarray, d: int, planes: list[int]) -> None:
    """On the RVE's inlet/outlet planes (face indices ``planes`` along ``d``), a face in front of
    a solid RVE cell lies on the cut fibre end: give it that cell's (negative) distance (in
    place)."""
    n = phi.shape[d]
    for i, side in zip(planes, (0, -1), strict=True):
        cell = i if side == 0 else (i - 1) % n
        idx = [slice(None)] * 3
        idx[d] = i
        cidx = [slice(None)] * 3
        cidx[d] = cell
        face = phi_face[tuple(idx)]
        cval = phi[tuple(cidx)]
        phi_face[tuple(idx)] = np.where(cval <= 0.0, np.minimum(cval, face), face)
