"""Why a voxel solve found no fluid path along the flow, and the one line that says so.

The voxel solvers refuse a grid without a fluid path (:func:`solvers.voxel_stokes.
check_percolates`): the solve would return the leak through the walls, a tiny K that is no
permeability. Who closed the path decides what the user must change, so for an RVE with an
analytic surface the refusal looks at the signed distance ``d`` sampled at the voxel centres,
with the one test of a path (:func:`psdesign.geometry.throat.percolates`):

* **the diffuse wall closed a gap the grid has open** (``d > 0`` has a path, the cells with
  fluid fraction ``eps >= 1/2`` have none): each wall's layer (logistic, width 0.75 voxel,
  moved into the pore by the curvature term, :mod:`solvers.voxel.diffuse_wall`) and the pair
  rule (fractions multiplied) hold ``eps`` under 1/2 across a gap under about 2 voxels. Square
  arrays across (session 39, ``benchmarks/diffuse_closing_gap.py``): the layer closed every
  gap up to 1.96 voxels it closed and left open every one from 1.70 up; solid fraction 0.7 is
  closed up to 24 voxels per spacing (gap ``L (1 - 2 sqrt(0.7 / pi))`` = 1.34 voxels), where
  the sub-voxel wall solves it. The line names ``rve.voxel`` with the gap's width (the
  percolation radius of the half-gap field ``(s1 + s2) / 2`` of the two nearest walls,
  :func:`psdesign.flow.diffuse.half_gap`: within 0.1 voxel of the exact gaps of those arrays)
  and the voxel that puts :data:`DIFFUSE_GAP` voxels across it, and the sub-voxel wall;
* **the grid closed a gap narrower than about a voxel** (``d > 0`` has no path,
  ``d > -`` :data:`OPEN_MOVE` voxel has): the RVE may be open; ``rve.voxel`` is named;
* **the RVE has no path** (``d > -`` :data:`OPEN_MOVE` voxel has none): the distance is
  1-Lipschitz and a point is at most ``sqrt(3) / 2`` voxel from its voxel's centre, so every
  voxel a continuous pore path crosses has ``d > -sqrt(3) / 2`` voxel and those voxels join
  face to face: no path among them means none in the RVE, at any voxel size. The line says so
  and names the fibres, not the voxel.

A segmented image has no surface but its voxels: its pore space is what it is (``image``).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

#: How far (voxels) the walls move back for the test of an RVE without a path: the largest
#: distance of a point from its voxel's centre, ``sqrt(3) / 2`` (module docstring).
OPEN_MOVE = math.sqrt(3.0) / 2.0
#: Voxels across the narrowest gap that the line of a gap closed by the diffuse wall asks for:
#: above the widest gap the layer closed on square arrays (1.96 voxels, session 39), with the
#: gap's reading error (0.1 voxel) to spare.
DIFFUSE_GAP = 2.5
#: Tolerance (voxels) of the percolation radius's bisection here.
R_TOL = 0.05


def no_path_message(
    name: str,
    h: float,
    distance: np.ndarray | None,
    axis: int,
    wall: str,
    rve=None,
    grid: str = "periodic",
) -> str:
    """The one line of a voxel solve refused for want of a fluid path along ``name``.

    Parameters
    ----------
    name : str
        The flow direction, ``"x"``, ``"y"`` or ``"z"``.
    h : float
        Voxel edge (m).
    distance : ndarray or None
        Signed distance (m, > 0 in the pore) of the RVE's analytic surface at the voxel centres;
        None for a segmented image.
    axis : int
        The flow's axis.
    wall : str
        ``flow.wall_treatment`` as solved (``"subvoxel"``, ``"staircase"``, ``"diffuse"``).
    rve : RVE, optional
        The RVE; with ``wall = "diffuse"`` its walls measure the gap the layers closed.
    grid : str
        The refused grid, whose path test the line describes (:func:`path_test`):
        ``"permeameter"`` (``bc``), else the periodic bc's ``periodic_treatment``
        (``"periodic"``, ``"mirror"``, ``"frame"``). On every grid an RVE's line names the
        fibers when its walls moved back by :data:`OPEN_MOVE` voxel leave no path on that grid
        (:func:`solved_pore`; the permeameter's with one copy between its reservoirs and side
        walls: one copy closed closes any stack of them, since a path across the stack crosses
        each copy from its inlet face to its outlet face), else ``rve.voxel``; on the periodic
        grid the diffuse wall's closing is told apart too.

    Returns
    -------
    str
        The line, starting with the key to change (module docstring).

    >>> d = np.full((6, 6, 6), 2e-6); d[3] = -0.4e-6  # a sheet across x, 0.4 voxel thick
    >>> no_path_message("x", 1e-6, d, 0, "subvoxel")[:52]
    'rve.voxel: no fluid path along x on the 1e-06 m grid'
    >>> d[3] = -2e-6  # two voxels thick: closed at any voxel size
    >>> no_path_message("x", 1e-6, d, 0, "subvoxel")[:42]
    'fibers: the pore space has no path along x'
    >>> no_path_message("x", 1e-6, d, 0, "subvoxel", grid="permeameter")[:42]
    'fibers: the pore space has no path along x'
    """
    from psdesign.geometry.throat import percolates

    if distance is None:
        return _image_line(name, grid)
    d = np.asarray(distance) / float(h)
    if grid == "periodic" and wall == "diffuse" and rve is not None and percolates(d > 0, axis):
        return _diffuse_closed(name, h, rve, d.shape, axis)
    # the walls moved back on the solved grid (until session 45 the permeameter, mirror and
    # frame routes named rve.voxel here, and each route asked it its own way)
    if not percolates(solved_pore(d > -OPEN_MOVE, axis, grid), axis):
        return _fibers_line(name, h)
    if grid != "periodic":
        return (
            f"rve.voxel: no fluid path along {name} on the {h:.3g} m grid "
            f"({path_test(name, grid, 'fluid')}): a gap under about a voxel closes on the grid "
            "(allowed: a voxel small "
            f"enough to open the pore path; none if the pore space has no path along {name})"
        )
    return (
        f"rve.voxel: no fluid path along {name} on the {h:.3g} m grid (face-connected, "
        "periodic fluid voxels): a gap under about a voxel closes on the grid, which the RVE's "
        f"surface may leave open (it has a path once the walls move back by {OPEN_MOVE:.2f} "
        "voxel) (allowed: a voxel small enough to open the pore path, a few voxels across "
        "its narrowest gap)"
    )


#: How each grid's path test looks for a path (:func:`path_test`; ``{what}``: pore or fluid,
#: ``{name}``: the flow's axis).
PATH_TESTS = {
    "periodic": "face-connected, periodic {what} voxels",
    "permeameter": "face-connected {what} voxels between the reservoirs, inside the side walls",
    "mirror": "face-connected, periodic {what} voxels of the grid and its mirror along {name}",
    "frame": "face-connected {what} voxels inside a solid frame across {name}, periodic",
}


def path_test(name: str, grid: str, what: str = "pore") -> str:
    """How the path along ``name`` was looked for on ``grid`` (:func:`no_path_message`): the
    words of the refusal, true for each route (until session 44 an image's line said
    "periodic pore voxels" also for a permeameter, whose side walls close the wrap).

    >>> path_test("z", "permeameter")
    'face-connected pore voxels between the reservoirs, inside the side walls'
    """
    return PATH_TESTS[grid].format(what=what, name=name)


def _image_line(name: str, grid: str) -> str:
    """The line of a segmented image whose pore voxels have no path along ``name`` on
    ``grid`` (:func:`path_test`)."""
    return (
        f"image: the pore space has no path along {name} ({path_test(name, grid)}), so there "
        f"is no permeability along {name} (allowed: an image whose pore space joins the faces "
        "normal to the flow)"
    )


def _fibers_line(name: str, h: float) -> str:
    """The line of an RVE whose surface closes every path along ``name`` (module docstring)."""
    return (
        f"fibers: the pore space has no path along {name}: the fibers' surfaces close it "
        f"(none on the {h:.3g} m grid even with the walls moved back by "
        f"{OPEN_MOVE:.2f} voxel, farther than a voxel centre is from any point of its voxel), "
        f"so there is no permeability along {name} at any voxel size (allowed: fibers that "
        f"leave a pore path along {name})"
    )


def closed_pore_space(
    name: str,
    h: float,
    distance: np.ndarray | None,
    solid: np.ndarray | None,
    axis: int,
    periodic: bool,
) -> str | None:
    """The line of a pore space that has no path along ``name`` whatever the grid or mesh:
    an image's pore voxels (``distance`` None) or an RVE whose walls, moved back by
    :data:`OPEN_MOVE` voxel, still close it (module docstring); None when it may have one.

    The mesher refuses a pore space without an inlet-outlet path on the field it meshes (gaps
    closed, :func:`psdesign.meshing.surface.check_voxel_connectivity`); this tells the user
    when the image or the fibers are at fault, with the voxel route's line
    (:func:`no_path_message`), not the mesh's resolution.

    Parameters
    ----------
    name : str
        The flow direction, ``"x"``, ``"y"`` or ``"z"``.
    h : float
        Voxel edge (m).
    distance : ndarray or None
        Signed distance (m, > 0 in the pore) at the voxel centres; None for a segmented image.
    solid : ndarray of bool or None
        The voxels' solid mask (read for an image only: None with a ``distance``).
    axis : int
        The flow's axis.
    periodic : bool
        A periodic mesh (a path must wind around the box); else the permeameter's fluid
        zones before and after the RVE join its faces' pores (a path may enter and leave
        anywhere on them) and its side walls close the box across the flow (a path that
        winds around them in the periodic box is none).

    Returns
    -------
    str or None

    >>> solid = np.zeros((6, 4, 4), bool); solid[3] = True  # a plate across x
    >>> closed_pore_space("x", 1e-6, None, solid, 0, False)[:44]
    'image: the pore space has no path along x (f'
    >>> closed_pore_space("y", 1e-6, None, solid, 1, True) is None
    True
    """
    from psdesign.geometry.throat import percolates

    grid = "periodic" if periodic else "permeameter"
    pore = ~np.asarray(solid, bool) if distance is None else np.asarray(distance) / h > -OPEN_MOVE
    if percolates(solved_pore(pore, axis, grid), axis):
        return None
    return _image_line(name, grid) if distance is None else _fibers_line(name, h)


def solved_pore(pore: np.ndarray, axis: int, grid: str) -> np.ndarray:
    """The pore mask of the grid a voxel solve along ``axis`` solves, for the one test of a
    path (:func:`psdesign.geometry.throat.percolates`): the question of every route here and
    of :func:`psdesign.flow.voxel.refuse_without_path` (until session 45 asked three ways).

    Parameters
    ----------
    pore : ndarray of bool
        The pore voxels of one RVE (or of the permeameter's stack of copies).
    axis : int
        The flow's axis.
    grid : str
        ``"permeameter"``: with its reservoirs and side walls (:func:`permeameter_pore`); else
        the periodic bc's ``periodic_treatment``, the solver's own grid
        (:func:`solvers.voxel_stokes.apply_treatment`): ``"periodic"`` (``pore`` itself),
        ``"mirror"`` (with its mirror image along ``axis``), ``"frame"`` (a solid frame on the
        high faces across ``axis``).

    Returns
    -------
    ndarray of bool

    >>> pore = np.ones((4, 3, 2), bool)
    >>> [solved_pore(pore, 0, g).shape for g in ("periodic", "mirror", "frame", "permeameter")]
    [(4, 3, 2), (8, 3, 2), (4, 4, 3), (6, 4, 3)]
    """
    if grid == "permeameter":
        return permeameter_pore(pore, axis)
    if grid == "periodic":  # apply_treatment's grid itself: no two inversions of the mask
        return pore
    from solvers.voxel_stokes import apply_treatment

    return ~apply_treatment(~pore, axis, grid)[0]


def permeameter_pore(pore: np.ndarray, axis: int) -> np.ndarray:
    """The pore mask of a permeameter's grid for the periodic path test
    (:func:`solvers.voxel_stokes.percolates`): one fluid layer each side along ``axis`` (the
    reservoirs, joined across the wrap; their depth does not change the path) and one solid
    layer across it (the side walls, so that no path winds around them: the voxel
    permeameter's grid, ``solvers.voxel_stokes._setup_grid``'s ``blocked``).

    >>> permeameter_pore(np.ones((4, 3, 2), bool), 0).shape
    (6, 4, 3)
    """
    pad = [(1, 1) if a == axis else (0, 0) for a in range(3)]
    pore = np.pad(pore, pad, constant_values=True)
    walls = [(0, 0) if a == axis else (0, 1) for a in range(3)]
    return np.pad(pore, walls, constant_values=False)


@contextmanager
def says_closed_pore_space(fields, direction: str, periodic: bool) -> Iterator[None]:
    """Run a mesher: its refusal for want of a pore path (``PoreTopologyError``) says the
    image or the fibers are at fault where they are (:func:`closed_pore_space` of
    ``fields``, a :class:`psdesign.geometry.rve.VoxelFields`), else is left as it is."""
    from psdesign.meshing.errors import PoreTopologyError

    def line() -> str | None:
        axis = "xyz".index(direction)
        distance = fields.distance if fields.analytic_distance else None
        h = float(fields.grid.spacing[0])
        said = closed_pore_space(direction, h, distance, fields.solid, axis, periodic)
        if said is None and periodic and distance is None:  # a path only through the wrap?
            walled = closed_pore_space(direction, h, None, fields.solid, axis, periodic=False)
            said = None if walled is None else _wrap_only_line(direction)
        return said

    # an image is tested before the mesher starts (one percolation of its voxels), so the
    # refusal is the only line: the mesher's progress line came first until session 44
    if not fields.analytic_distance and (said := line()) is not None:
        raise PoreTopologyError(said)
    try:
        yield
    except PoreTopologyError as exc:
        said = line() if fields.analytic_distance else None
        if said is None:
            raise
        raise PoreTopologyError(said) from exc


def _wrap_only_line(name: str) -> str:
    """The line of an image whose only pore path along ``name`` winds through the box's side
    faces (a periodic path, none inside the side walls: :func:`closed_pore_space` of both):
    the periodic mesher keeps the pieces that join the two faces normal to the flow inside
    the box, so it refused such an image as ``rve.voxel`` (a key an image has not), though
    the voxel route solves it. Meshing it anyway (session 44, reverted as ee22dc1) gave a FEM
    K 3-5x the voxel route's, marked ok.

    >>> _wrap_only_line("z")[:50]
    "image: the pore space's only path along z winds th"
    """
    return (
        f"image: the pore space's only path along {name} winds through the box's side faces "
        "(periodic pore voxels; none inside them), which the FEM's mesh does not carry "
        "(allowed: --solver voxel, whose periodic grid solves it, or an image whose pore space "
        "joins the faces normal to the flow inside the box)"
    )


def _diffuse_closed(name: str, h: float, rve, shape, axis: int) -> str:
    """The line of a gap the grid has open and the diffuse wall's layers close: the narrowest
    gap a path must pass, twice the percolation radius of the half-gap field
    (:func:`psdesign.flow.diffuse.half_gap`, to :data:`R_TOL`, or to a tenth, a hundredth of
    it where the radius is under two tolerances: a gap of 0.03 voxel read as 0.1 asked for a
    voxel under which it stayed closed), and the voxel that puts :data:`DIFFUSE_GAP` voxels
    across it."""
    from psdesign.flow.diffuse import half_gap
    from psdesign.geometry.throat import percolation_radius
    from psdesign.schema.budget import round_down

    field = half_gap(rve, shape, h)
    tol = R_TOL
    radius = percolation_radius(field, axis, tol)
    while radius < 2.0 * tol and tol > 1e-3:  # a gap of a few tolerances: bisect finer
        tol /= 10.0
        radius = percolation_radius(field, axis, tol)
    gap = max(2.0 * radius, 2.0 * tol)  # the bisection's resolution
    return (
        f"rve.voxel: the diffuse wall closes the pore path along {name} on the {h:.3g} m grid, "
        f"which has it open: its narrowest gap is {gap:.3g} voxels ({gap * h:.3g} m) and the "
        "two walls' layers leave no cell with fluid fraction >= 1/2 across a gap under about 2 "
        f"voxels (allowed: rve.voxel <= {round_down(gap * h / DIFFUSE_GAP):.3g} m, "
        f"{DIFFUSE_GAP:g} voxels across the gap, or flow.wall_treatment = 'subvoxel', which "
        "keeps it open)"
    )
