"""The voxel route with the diffuse-domain wall (``flow.wall_treatment = "diffuse"``).

The cut-face wall of the default voxel solve converges at second order on average but keeps a
first-order scatter with how the surface cuts the grid, so K does not fall monotonically with
the voxel size (issue 12 item 3; ``benchmarks/RESULTS.md`` wall22, port22). The diffuse wall
replaces the sharp wall by a fluid fraction and a drag that vary smoothly over a few voxels
across the surface, calibrated on closed-form flows (:mod:`solvers.voxel.diffuse_wall`): on
cylinder arrays it converges strictly monotonically at every sub-voxel shift. It needs the true
distance to the two nearest walls several voxels into the pore, which straight ``cylinder`` and
``rod`` fibres have in closed form (:mod:`psdesign.geometry.walls`); other fibres, images and the
permeameter boundary condition are refused (:func:`unsupported`). The solve is assembled
(:func:`solvers.voxel.diffuse.solve_diffuse_stokes`), far more memory per voxel than the
default solver's: a reference for small RVEs and arrays, not the production path.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from psdesign.flow.darcy import periodic_gradient
from psdesign.geometry.rve import RVE, VoxelFields
from psdesign.geometry.walls import NearestWalls, along_box_axis, untiled_axis
from psdesign.geometry.walls import unsupported as unsupported_geometry
from psdesign.schema.flow import DIFFUSE_FLOW_TOL


def unsupported(rve: RVE | None, fields: VoxelFields, bc: str, treatment: str) -> str | None:
    """Why the diffuse wall cannot be used here (None when it can).

    Parameters
    ----------
    rve : RVE or None
        The RVE (None: an image).
    fields : VoxelFields
        Its voxel fields (``analytic_distance``, ``count``).
    bc, treatment : str
        ``flow.bc`` and ``flow.periodic_treatment`` as the route resolved them.

    Returns
    -------
    str or None
        The reason (without the key; the caller names ``flow.wall_treatment``).
    """
    if rve is None or not fields.analytic_distance:
        return "'diffuse' needs an analytic surface; an image has none (use 'staircase')"
    if bc != "periodic":
        return f"'diffuse' solves bc = 'periodic' only, not {bc!r}"
    if treatment != "periodic":
        return f"'diffuse' solves periodic_treatment = 'periodic' only, not {treatment!r}"
    why = unsupported_geometry(rve)
    if why is not None:
        return why
    i = untileable(rve.fibers, rve.size / float(rve.period))
    if i is not None:
        return f"fiber {i} {UNTILEABLE}"
    overlap = int(np.count_nonzero(fields.count >= 2))
    if overlap:
        # the pair rule puts a layer on both walls of a gap; a wall buried in another fibre
        # would still get one (K 20 % low on a fibre listed twice, review23)
        return (
            f"fibers overlap ({overlap} voxels inside two fibers): the wall model describes "
            "walls facing each other across the pore, not one fiber inside another"
        )
    return None


def untileable(fibers, box: np.ndarray) -> int | None:
    """The first fibre whose walls in the box's tiled content are not known in closed form
    (None when every fibre's are): some fibre's copies do not repeat with the box
    (:func:`psdesign.geometry.walls.untiled_axis`) and this fibre is not along a box axis. The
    one rule, checked on a spec's explicit fibres when it is loaded and on the built RVE
    (:data:`UNTILEABLE` says why).

    Parameters
    ----------
    fibers : sequence of Fiber
        The fibres (normalized coordinates).
    box : ndarray (3,)
        Box edges in PS periods.

    Returns
    -------
    int or None
        The fibre's index.
    """
    if all(untiled_axis(fb, box) is None for fb in fibers):
        return None
    return next((i for i, fb in enumerate(fibers) if not along_box_axis(fb)), None)


#: Why a fibre :func:`untileable` names is refused.
UNTILEABLE = (
    "is not along a box axis, in a box whose edges are not whole periods of every fiber's "
    "copies: the wall distances of the box's tiled content are known for fibers along the box "
    "axes only"
)


def solve_diffuse(
    rve: RVE,
    fields: VoxelFields,
    direction: str,
    flow: dict,
    voxel: float,
    progress: Callable[[int, float], None] | None = None,
):
    """One periodic solve with the diffuse wall along ``direction``.

    Parameters
    ----------
    rve : RVE
        The RVE (:func:`unsupported` returned None for it).
    fields : VoxelFields
        Its voxel fields at ``voxel``.
    direction : str
        ``"x"``, ``"y"`` or ``"z"``.
    flow : dict
        The ``[flow]`` table (``viscosity``; ``tol`` when set).
    voxel : float
        Voxel edge (m).
    progress : callable, optional
        ``progress(iteration, residual)``.

    Returns
    -------
    solvers.voxel_stokes.VoxelFlowResult
        The solve (K is formed by the caller, :mod:`psdesign.flow.darcy`).

    Raises
    ------
    ValueError
        The walls disagree with the voxel grid (:func:`_check_solid`).
    """
    from solvers.voxel.diffuse import DiffuseGrid, solve_diffuse_stokes
    from solvers.voxel.diffuse_wall import REACH_VOXELS

    # walls beyond the layer's reach change no weight: not looked at (the sampling's cost)
    walls = NearestWalls(rve, voxel, reach=REACH_VOXELS + 1.0)
    _check_solid(walls, fields)
    grid = DiffuseGrid.sample(fields.grid.shape, walls)
    kw = {"tol": float(flow.get("tol") or DIFFUSE_FLOW_TOL)}
    ax = "xyz".index(direction)
    return solve_diffuse_stokes(
        grid,
        voxel,
        direction,
        viscosity=float(flow["viscosity"]),
        pressure_gradient=periodic_gradient(flow, fields.grid.shape[ax] * voxel),
        progress=progress,
        **kw,
    )


def _check_solid(walls: NearestWalls, fields: VoxelFields) -> None:
    """The walls enclose the voxel grid's solid: the sign of the nearest wall's distance at
    every cell centre is the grid's (cells within 1e-6 voxel of a wall excepted). It fails where
    the box's content does not tile into whole fibres (a fibre cut by a face along which the
    copies do not repeat): the solver would see a geometry the walls do not describe."""
    nx, ny, nz = fields.grid.shape
    yz = np.meshgrid(np.arange(ny) + 0.5, np.arange(nz) + 0.5, indexing="ij")
    for i in range(nx):
        (s, _, _), _ = walls(np.full(yz[0].shape, i + 0.5), *yz)
        wrong = ((s < 0) != fields.solid[i]) & (np.abs(s) > 1e-6)
        if wrong.any():
            j, k = np.argwhere(wrong)[0]
            raise ValueError(
                f"flow.wall_treatment: 'diffuse' walls disagree with the voxel grid at cell "
                f"({i}, {j}, {k}) ({int(wrong.sum())} cells of plane x = {i}): the box's content "
                "does not tile into whole fibers across a face (use 'subvoxel')"
            )


def half_gap(rve: RVE, shape: tuple[int, int, int], voxel: float) -> np.ndarray:
    """Half the local gap between the two nearest walls, ``(s1 + s2) / 2`` (voxels), at every
    pore voxel centre; 0 in the solid. Between two walls it reads the gap's width wherever the
    centre sits across it (a wall distance reads half of it only on the midline), so the
    percolation radius of this field (:func:`psdesign.geometry.throat.percolation_radius`) is
    half the narrowest gap a path must pass, to within how the centres sample it along the
    walls (square arrays across: 0-0.02 voxel wide, session 39). Walls beyond the diffuse
    layer's reach read as far away (the gap is then no narrow one).

    Parameters
    ----------
    rve : RVE
        The RVE (:func:`unsupported` returned None for it).
    shape : (nx, ny, nz)
        Its voxel grid at ``voxel``.
    voxel : float
        Voxel edge (m).

    Returns
    -------
    ndarray (nx, ny, nz)
    """
    from solvers.voxel.diffuse_wall import REACH_VOXELS

    walls = NearestWalls(rve, voxel, reach=REACH_VOXELS + 1.0)
    nx, ny, nz = shape
    yz = np.meshgrid(np.arange(ny) + 0.5, np.arange(nz) + 0.5, indexing="ij")
    out = np.zeros((nx, ny, nz))
    for i in range(nx):
        (s1, _, _), (s2, _, _) = walls(np.full(yz[0].shape, i + 0.5), *yz)
        out[i] = np.where(s1 > 0, 0.5 * (s1 + s2), 0.0)
    return out
