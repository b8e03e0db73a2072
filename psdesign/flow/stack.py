"""Stacked permeameter: copies of a periodic RVE along the flow (``flow.permeameter_copies``).

The permeameter's windowed-dissipation drop (:mod:`psdesign.flow.darcy`) is exactly ``G L`` when
the sample between the reservoirs holds two or more periods of the structure along the flow: the
window is then a flat top of whole periods with smooth ramps (a box of whole periods convolved
with a bump), which annihilates the periodic part of the dissipation and is zero near the faces.
A one-period RVE (a random RVE, generated periodic) has no such window (the sin^2 window it falls
back to weights its middle layers; measured: K 36 % below the periodic K on five 8 um fibres in a
40 um cube). Stacking ``m = 2`` copies of a geometry that is periodic along the flow makes the
sample two periods long, so the windowed drop is ``G m L`` again and the entrance and exit layers
fall outside the window.

The stack is built on the voxel grid (distance field and fiber counts tiled along the axis), which
both routes use: the voxel solver directly, the tet mesher through the distance field. The
reservoirs keep their length (``aux_length`` times one copy's length).

Rule of ``"auto"`` (:func:`plan_copies`): 2 when the geometry is periodic along the flow axis (its
end planes differ by at most :data:`SEAM_TOL_LENGTH` of its length there: a property of the
geometry, the same on every grid) and one copy holds fewer than two periods of it; 1 when one copy
already holds two or more (arrays of two or more cells: nothing to gain); 1 with a warning when the
geometry is not periodic along the axis (the permeameter K is then the sample's, entrance layers
included).

Then the sample length (:func:`next_auto_copies`, applied by :func:`psdesign.flow.permeability.
permeability`): while the solve's window term (``error_estimate.window``, the entrance/exit
residual of the windowed drop, :func:`psdesign.flow.error.window_of`) is above
:data:`AUTO_WINDOW` (the product's ``WINDOW_WARN``, 1 %) on a geometry periodic along the flow,
``"auto"`` solves again with one copy more, up to :data:`AUTO_MAX_COPIES` (only a stack of a
one-period RVE: an array already holds whole periods), and only while the
longer stack fits the memory budget (:func:`psdesign.schema.budget.restack_bytes`; up front
both the budget and ``flow.max_memory_gb`` count the copies explicit fibers or an image plan,
:func:`spec_auto_copies`; where only the built RVE tells, the budget counts the first solve's
:data:`AUTO_COPIES`, the cap one copy and the planned copies before the stack is meshed or
solved, :func:`psdesign.schema.budget.check_planned_stack`); where it stops above the threshold the
result warns and names ``flow.permeameter_copies``. The error bar's second resolution is solved
with the final copies. Measured (``docs/permeability.md``, "Two copies are not always enough"):
three_rods (porosity 0.91, 20 um rods in a 100 um cube) has window terms of 10.0 / 1.9 / 0.4 %
(FEM) and 5.5 / 1.2 / 0.3 % (voxel) with 2 / 3 / 4 copies, so ``"auto"`` takes 4 on both routes;
the dense random RVEs of the shipped studies stay at 2 where their term is below 1 %. The
attempts are in the result's ``permeameter_auto`` (copies, K and window term of each solve).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from psdesign.errors import SpecError
from psdesign.flow.error import WINDOW_WARN
from psdesign.geometry.rve import RVE, VoxelFields, VoxelGrid
from psdesign.schema.flow import AUTO_PERMEAMETER_COPIES, MAX_PERMEAMETER_COPIES

#: Largest ``flow.permeameter_copies`` (the cost grows linearly with the copies).
MAX_COPIES = MAX_PERMEAMETER_COPIES
#: Copies ``"auto"`` takes for a periodic one-period RVE.
AUTO_COPIES = AUTO_PERMEAMETER_COPIES
#: Most copies ``"auto"`` stacks when the window term asks for a longer sample (the three_rods
#: stack is within 0.4 % of its window limit at 4, ``docs/permeability.md``).
AUTO_MAX_COPIES = 4
#: ``"auto"`` adds a copy while the window term is above this (the term that draws the warning).
AUTO_WINDOW = WINDOW_WARN
#: Sub-periods looked for within one copy (a structure of period ``L / k``, ``k`` up to this).
MAX_SUB_PERIODS = 8
#: Points sampled to compare the analytic field at ``s`` and ``s + L / k`` (seeded).
SAMPLE_POINTS = 4000
SAMPLE_SEED = 12345
#: End planes whose analytic fields differ near the surface by at most this fraction of the RVE's
#: length along the axis are periodic enough to stack. A length of the geometry, not a fraction of
#: the voxel, so the plan (and K) does not change with ``rve.voxel`` (until session 19 the
#: tolerance was half a voxel: rev_toray's 60 um RVE, end planes 0.46 um apart, was two copies at
#: 1 um and one at 0.9 um and finer, and its K moved by 10 %). Why relative to the length: the
#: seam acts like a slab of the gap's thickness cut out of every period, and K moves with the
#: fraction cut. Measured (``benchmarks/seam_gap.py``, voxel route, periodic, in-plane
#: Toray-like RVEs with a slab cut out): K falls by 1.2-1.9 % per 1 % of the length cut, on 60,
#: 50 and 100 um cubes alike (``benchmarks/RESULTS.md``, seam19). At 2 % the stack is at most
#: about 4 % low (less where not every fiber reaches the largest gap), below the bars of these
#: RVEs and far from the one copy it replaces (10 % high on rev_toray, -36 to +88 % on the RVEs
#: of ``docs/permeability.md``). A tilted PS fiber is periodic along z only to
#: ``L (1 - cos(theta))`` (its copies are one period apart across its own axis): 0.33 um at 6 deg
#: in 60 um; measured by the field near the surface, rev_toray's 60 um RVE differs by 0.47 um
#: (0.78 % of L), the quickstart's 50 um RVE by 0.24 um (0.48 %).
SEAM_TOL_LENGTH = 0.02
#: Sub-periods (``field(s) = field(s + L / k)``) need a much closer match: a false "two periods"
#: would skip the stack; arrays match to rounding.
SUB_PERIOD_TOL_LENGTH = 1e-4
#: Points within this fraction of the thinnest fiber diameter of the surface (on either side) are
#: compared (two voxels at the product's 8 voxels per diameter).
NEAR_SURFACE_DIAMETERS = 0.25
#: Reference length of an RVE whose fibers carry no diameter: this many voxels.
FALLBACK_DIAMETER_VOXELS = 8.0


@dataclass(frozen=True)
class StackPlan:
    """How many copies the permeameter stacks, and why.

    Attributes
    ----------
    copies : int
        Copies of the RVE along the flow axis (1 = the RVE alone).
    periodic : bool
        The geometry is periodic along the flow axis (end planes match).
    periods : int
        Periods of the structure within one copy (1: none shorter than the RVE was found).
    check : str
        ``"analytic"`` (the RVE's union field) or ``"voxel"`` (the grid: images).
    note : str or None
        Warning text (``"auto"`` on a geometry that is not periodic along the axis).
    seam_gap_fraction : float
        The end planes' mismatch as a fraction of the RVE's length (:attr:`EndPlanes.
        gap_fraction`) where copies meet at a seam (``copies >= 2``), else 0: the error bar's
        seam term (:func:`psdesign.flow.error.seam_rel_error`).
    """

    copies: int
    periodic: bool
    periods: int
    check: str
    note: str | None = None
    seam_gap_fraction: float = 0.0

    def as_dict(self) -> dict:
        """JSON keys of a permeameter result."""
        return {
            "permeameter_copies": self.copies,
            "geometry_periodic_along_flow": self.periodic,
            "periods_per_copy": self.periods,
            "periodicity_check": self.check,
            "seam_gap_fraction": self.seam_gap_fraction,
        }


@dataclass(frozen=True)
class SolidMask:
    """An image's solid mask before its voxel fields are built: what the voxel seam test
    reads (:func:`end_planes`, :func:`_voxel_periods`; the built fields' ``solid`` is this
    mask, :func:`psdesign.image.fields.signed_distance`)."""

    solid: np.ndarray
    analytic_distance = False


def _has_analytic(rve: RVE | None, fields: VoxelFields | SolidMask | float) -> bool:
    """The RVE has an analytic surface (fibers; ``fields`` a voxel size: the RVE alone, before
    its voxel fields are built, :func:`spec_auto_copies`)."""
    analytic = isinstance(fields, float) or bool(fields.analytic_distance)
    return rve is not None and bool(rve.fibers) and analytic


def _reference_diameter(rve: RVE, fields: VoxelFields | float, axis: int) -> float:
    """The length (m) that sets which points are near the surface
    (:data:`NEAR_SURFACE_DIAMETERS`): the thinnest fiber diameter
    (:func:`psdesign.meshing.options.thinnest_fiber_diameter`), else
    :data:`FALLBACK_DIAMETER_VOXELS` voxels along ``axis`` (``fields``' grid, or a voxel size
    in metres)."""
    from psdesign.meshing.options import thinnest_fiber_diameter

    d = thinnest_fiber_diameter(rve)
    if d:
        return float(d)
    voxel = fields if isinstance(fields, float) else float(fields.grid.spacing[axis])
    return FALLBACK_DIAMETER_VOXELS * voxel


def _surface_gap(a: np.ndarray, b: np.ndarray, d: float) -> float:
    """Largest ``|a - b|`` (m) over the points near the surface in either field (within
    :data:`NEAR_SURFACE_DIAMETERS` of ``d``)."""
    near = np.minimum(np.abs(a), np.abs(b)) <= NEAR_SURFACE_DIAMETERS * d
    diff = np.abs(a - b)
    return float(diff[near].max()) if near.any() else float(diff.max())


@dataclass(frozen=True)
class EndPlanes:
    """Do the two end planes of the RVE along an axis match (the geometry is periodic along it)?

    Attributes
    ----------
    axis : str
        ``"x"``, ``"y"`` or ``"z"``.
    periodic : bool
        The end planes match (:data:`SEAM_TOL_LENGTH` near the surface, or the voxel seam
        test).
    check : str
        ``"analytic"`` or ``"voxel"`` (:func:`periodicity`).
    detail : str
        The measurement, for messages.
    gap_fraction : float
        The largest difference of the fiber surfaces on the two planes as a fraction of the RVE's
        length along the axis (analytic check; 0 for the voxel check, whose seam is at most as
        rough as any layer inside).
    """

    axis: str
    periodic: bool
    check: str
    detail: str
    gap_fraction: float = 0.0


def _analytic_points(rve: RVE) -> np.ndarray:
    size = np.asarray(rve.size, float)
    return np.random.default_rng(SAMPLE_SEED).uniform(0.0, 1.0, (SAMPLE_POINTS, 3)) * size


def end_planes(rve: RVE | None, fields: VoxelFields | SolidMask | float, axis: int) -> EndPlanes:
    """Compare the geometry on the two end planes along ``axis``: the analytic union field near
    the surface where the RVE has one (largest difference against :data:`SEAM_TOL_LENGTH`
    of the RVE's length along the axis: a length of the geometry, so the answer does not depend
    on the grid), else the voxel layers (the seam against the worst step between neighbouring
    layers, :func:`_voxel_periods`)."""
    name = "xyz"[axis]
    if _has_analytic(rve, fields):
        d = _reference_diameter(rve, fields, axis)
        length = float(rve.size[axis])
        p = _analytic_points(rve)
        lo, hi = p.copy(), p.copy()
        lo[:, axis], hi[:, axis] = 0.0, length
        gap = _surface_gap(rve.union_field(lo), rve.union_field(hi), d)
        detail = (
            f"the fiber surfaces at {name} = 0 and {name} = L differ by up to "
            f"{gap:.3g} m, {100 * gap / length:.3g} % of L = {length:.3g} m, "
            f"allowed {100 * SEAM_TOL_LENGTH:g} %"
        )
        return EndPlanes(name, gap <= SEAM_TOL_LENGTH * length, "analytic", detail, gap / length)
    solid = fields.solid
    n = solid.shape[axis]
    steps = [np.mean(np.take(solid, i, axis) != np.take(solid, i + 1, axis)) for i in range(n - 1)]
    seam = float(np.mean(np.take(solid, 0, axis) != np.take(solid, n - 1, axis)))
    worst = float(max(steps)) if steps else 0.0
    detail = (
        f"the first and last voxel layers along {name} differ on {100 * seam:.2f} % of their "
        f"voxels, neighbouring layers inside on at most {100 * worst:.2f} %"
    )
    return EndPlanes(name, n >= 2 and seam <= worst, "voxel", detail)


def unmatched_faces(rve: RVE | None, fields: VoxelFields) -> str:
    """``"faces normal to x, y do not match (<measurements>)"`` for the axes whose end planes
    differ (:func:`end_planes`), for messages; ``""`` when the geometry is periodic on all three.
    """
    bad = [m for ax in range(3) if not (m := end_planes(rve, fields, ax)).periodic]
    if not bad:
        return ""
    axes, details = ", ".join(m.axis for m in bad), "; ".join(m.detail for m in bad)
    return f"faces normal to {axes} do not match ({details})"


def _analytic_periods(rve: RVE, fields: VoxelFields | float, axis: int) -> int:
    """The largest ``k`` with ``field(s) = field(s + L / k)`` along ``axis`` (1 if none), from
    the RVE's analytic union field."""
    d = _reference_diameter(rve, fields, axis)
    length = float(rve.size[axis])
    p = _analytic_points(rve)
    base = rve.union_field(p)
    found = 1
    for k in range(2, MAX_SUB_PERIODS + 1):
        q = p.copy()
        q[:, axis] = (p[:, axis] + length / k) % length
        if _surface_gap(rve.union_field(q), base, d) <= SUB_PERIOD_TOL_LENGTH * length:
            found = k
    return found


def _voxel_periods(fields: VoxelFields | SolidMask, axis: int) -> int:
    """The same from the grid: sub-periods by rolling the solid by ``n / k`` layers (``k``
    dividing ``n``; an image's distance is not periodic)."""
    solid = fields.solid
    n = solid.shape[axis]
    found = 1
    for k in range(2, MAX_SUB_PERIODS + 1):
        if n % k == 0 and np.array_equal(np.roll(solid, n // k, axis=axis), solid):
            found = k
    return found


def periodicity(
    rve: RVE | None, fields: VoxelFields | SolidMask | float, axis: int
) -> tuple[bool, int, str, float]:
    """``(periodic, periods_per_copy, check, gap_fraction)`` of the geometry along ``axis``:
    whether the end planes match (:func:`end_planes`: the analytic union field near the surface
    where the RVE has one, :data:`SEAM_TOL_LENGTH`, else the voxel layers, the seam against the
    worst step between neighbouring layers inside), the sub-periods within one copy
    (:func:`_analytic_periods`, :func:`_voxel_periods`; 1 when not periodic), ``"analytic"`` or
    ``"voxel"``, and the end planes' mismatch as a fraction of the length
    (:attr:`EndPlanes.gap_fraction`). ``fields`` a voxel size (m): the RVE's analytic field
    alone, before its voxel fields are built (:func:`spec_auto_copies`)."""
    ends = end_planes(rve, fields, axis)
    return ends.periodic, _periods(rve, fields, ends), ends.check, ends.gap_fraction


def _periods(rve: RVE | None, fields: VoxelFields | SolidMask | float, ends: EndPlanes) -> int:
    """The sub-periods within one copy along ``ends``' axis by the test that judged its end
    planes (1 when they differ): :func:`periodicity`'s, for a caller that needs ``ends`` too."""
    if not ends.periodic:
        return 1
    axis = "xyz".index(ends.axis)
    if ends.check == "analytic":
        return _analytic_periods(rve, fields, axis)
    return _voxel_periods(fields, axis)


def parse_copies(value: object) -> int | str:
    """``flow.permeameter_copies`` as ``"auto"`` or an int in ``[1, MAX_COPIES]``."""
    if value is None or value == "auto":
        return "auto"
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise SpecError(
            "flow.permeameter_copies", f"must be 'auto' or an integer in [1, {MAX_COPIES}]"
        )
    if not 1 <= int(value) <= MAX_COPIES:
        raise SpecError(
            "flow.permeameter_copies",
            f"must be 'auto' or an integer in [1, {MAX_COPIES}], got {value!r}",
        )
    return int(value)


def plan_copies(flow: dict, rve: RVE | None, fields: VoxelFields, axis: int) -> StackPlan:
    """The permeameter's copies along ``axis`` from ``flow["permeameter_copies"]`` (module doc).

    Raises
    ------
    SpecError
        An explicit count of 2 or more on a geometry that is not periodic along the axis (the
        copies would meet at a seam of mismatched fibres).
    """
    want = parse_copies(flow.get("permeameter_copies"))
    # the end planes once: the analytic test samples 4000 points of the union field (~50 ms on
    # 119 fibres), and a solve plans two or more times (review s51: it ran three times here)
    ends = end_planes(rve, fields, axis)
    periodic, check, gap = ends.periodic, ends.check, ends.gap_fraction
    periods = _periods(rve, fields, ends)
    name = "xyz"[axis]
    if want == "auto":
        if periodic:
            copies = auto_copies(periodic, periods)
            note = voxel_stack_note(ends) if copies >= 2 else None
            return StackPlan(copies, True, periods, check, note, gap if copies >= 2 else 0.0)
        note = (
            f"K_{name}: the geometry is not periodic along {name} (its end planes differ: "
            f"{ends.detail}), so the permeameter cannot stack copies: "
            "K is this sample's, its entrance layers included (flow.permeameter_copies = 1); "
            "compare bc = 'periodic'"
        )
        return StackPlan(1, False, periods, check, note)
    if want >= 2 and not periodic:
        raise SpecError(
            "flow.permeameter_copies",
            f"{want} copies need a geometry periodic along {name} (its end planes differ: "
            f"{ends.detail}); allowed here: 1 or 'auto'",
        )
    note = voxel_stack_note(ends) if want >= 2 else None
    return StackPlan(want, periodic, periods, check, note, gap if want >= 2 else 0.0)


def voxel_stack_note(ends: EndPlanes) -> str | None:
    """Why a stack of copies on the voxel test (an image: no fibre surfaces) may hold seams
    the analytic test of the same fibres refuses; None on the analytic test (``ends``: the
    :func:`end_planes` of the stacking axis).

    The two tests of :func:`end_planes` must differ: the analytic one compares the fibres'
    surfaces on the two end planes (the fibres continue past the box), to
    :data:`SEAM_TOL_LENGTH` of L. An image ends at its first and last voxel layers, which in a
    periodic sample are neighbours across the seam, so its test can ask only whether the seam
    step is as rough as a step inside; at a few voxels per fibre a fibre cut at an end plane
    is. Session 50's walk: 13 fibres across 80 um in z, 76.5 % of L apart on the end planes,
    stacked in 3 copies as their TIFF (seam 7.3 % of the voxels, steps inside up to 16 %).
    """
    if ends.check != "voxel":
        return None
    return (
        f"K_{ends.axis}: copies stacked on the voxel test of the end planes ({ends.detail}): "
        "without fibre surfaces (an image) a seam as rough as a step between layers inside "
        "passes, and so can fibres cut at the end planes (an RVE of fibres is judged by its "
        f"fibre surfaces on the two planes, to {100 * SEAM_TOL_LENGTH:g} % of L); if the sample "
        f"is not periodic along {ends.axis}, set flow.permeameter_copies = 1"
    )


def auto_copies(periodic: bool, periods: int) -> int:
    """The copies ``"auto"`` stacks first (module doc): :data:`AUTO_COPIES` on a geometry
    periodic along the flow with fewer than two periods in one copy, else 1.

    >>> auto_copies(True, 1), auto_copies(True, 2), auto_copies(False, 1)
    (2, 1, 1)
    """
    return AUTO_COPIES if periodic and periods < 2 else 1


def spec_auto_copies(rve: RVE | None, axes: Iterable[int], voxel: float | SolidMask) -> int:
    """The most copies ``"auto"`` plans along ``axes`` (0, 1, 2) for an RVE of explicit fibers,
    known before its voxel fields are built: :func:`auto_copies` of :func:`periodicity` on the
    RVE's analytic field, the test :func:`plan_copies` applies to the built RVE (the same
    fibers, so the same answer); ``voxel`` (m) sets the near-surface band only for fibers
    without a diameter. An image (``rve`` None, ``voxel`` its :class:`SolidMask`): the voxel
    seam test on its mask. What the up-front memory checks count
    (:func:`psdesign.schema.plan.planned_flow`).

    >>> from psdesign.geometry.fibers import make_fiber
    >>> rod = make_fiber("rod", 0.2, theta=0.0, omega=0.0)  # along x, one period per box
    >>> rve = RVE(np.full(3, 20e-6), [rod], period=20e-6)
    >>> spec_auto_copies(rve, [0], 1e-6), spec_auto_copies(rve, [2], 1e-6)
    (1, 2)
    """
    fields = voxel if isinstance(voxel, SolidMask) else float(voxel)
    return max(auto_copies(*periodicity(rve, fields, a)[:2]) for a in axes)


def next_auto_copies(requested: object, result: dict, window: float) -> tuple[int | None, str]:
    """The copies of the next solve of an ``"auto"`` permeameter after ``result`` (module doc),
    and why: ``(copies + 1, "window")`` while ``window`` (its window term) is above
    :data:`AUTO_WINDOW`, else ``(None, why)`` with why ``"fixed"`` (an explicit count, or not a
    permeameter), ``"not periodic"`` (the geometry cannot be stacked), ``"converged"`` (the
    window term is at most the threshold), ``"periods"`` (one copy already holds two or more
    periods: an array, or cylinders along the flow, whose window is exact; measured: cylinders
    along the flow reach a window term of 2-3 % through its a-priori reach part alone while a
    second copy moves K by < 0.03 %, ``benchmarks/RESULTS.md``) or ``"max"``
    (:data:`AUTO_MAX_COPIES` reached).
    ``requested`` is ``flow["permeameter_copies"]`` as the user gave it.

    >>> r = {"bc": "permeameter", "geometry_periodic_along_flow": True, "permeameter_copies": 2}
    >>> next_auto_copies("auto", r, 0.10), next_auto_copies("auto", r, 0.004)
    ((3, 'window'), (None, 'converged'))
    >>> next_auto_copies(2, r, 0.10), next_auto_copies(None, {**r, "permeameter_copies": 4}, 0.1)
    ((None, 'fixed'), (None, 'max'))
    """
    if parse_copies(requested) != "auto" or result.get("bc") != "permeameter":
        return None, "fixed"
    if not result.get("geometry_periodic_along_flow"):
        return None, "not periodic"
    if int(result.get("periods_per_copy") or 1) >= 2:
        return None, "periods"
    if not window > AUTO_WINDOW:
        return None, "converged"
    copies = int(result.get("permeameter_copies") or 1)
    if copies >= AUTO_MAX_COPIES:
        return None, "max"
    return copies + 1, "window"


def stack_fields(fields: VoxelFields, axis: int, copies: int) -> VoxelFields:
    """``copies`` copies of the voxel fields along ``axis`` (same class, grid ``copies`` times as
    long). ``copies = 1`` returns ``fields`` itself."""
    if copies == 1:
        return fields
    reps = [1, 1, 1]
    reps[axis] = copies
    g = fields.grid
    size = np.asarray(g.size, float).copy()
    size[axis] *= copies
    shape = list(g.shape)
    shape[axis] *= copies
    grid = VoxelGrid(size=size, shape=tuple(shape), spacing=np.asarray(g.spacing, float).copy())
    return type(fields)(
        distance=np.tile(fields.distance, reps), count=np.tile(fields.count, reps), grid=grid
    )


def stacked_flow(flow: dict, copies: int) -> dict:
    """The ``[flow]`` table for the stack: the reservoirs keep one copy's ``aux_length``."""
    if copies == 1:
        return flow
    return {**flow, "aux_length": float(flow.get("aux_length", 0.2)) / copies}


def mirror_sides(fields: VoxelFields, axis: int) -> VoxelFields:
    """The voxel fields mirrored across their side faces (the faces normal to the two axes other
    than ``axis``; the grid is twice as wide in each): a slip wall is a mirror plane, so the
    periodic K along ``axis`` of this grid is the K of an endless column of the RVE with slip
    sides, the limit of the stacked permeameter (slip sides) as its copies grow. A diagnostic
    (``benchmarks/solver_agreement.py probe --bc mirrored``): the stack of a periodic RVE
    converges to it, e.g. three_rods at 1 um, voxel route, 6 copies within 0.03 %.

    >>> g = VoxelGrid(size=np.array([2.0, 1.0, 1.0]), shape=(2, 1, 1), spacing=np.ones(3))
    >>> f = VoxelFields(np.array([1.0, -1.0]).reshape(2, 1, 1), np.zeros((2, 1, 1), np.uint8), g)
    >>> m = mirror_sides(f, 2)
    >>> m.distance[:, 0, 0].tolist(), m.grid.shape
    ([1.0, -1.0, -1.0, 1.0], (4, 2, 1))
    """
    dist, count = fields.distance, fields.count
    size, shape = np.asarray(fields.grid.size, float).copy(), list(fields.grid.shape)
    for a in (a for a in range(3) if a != axis):
        dist = np.concatenate([dist, np.flip(dist, a)], axis=a)
        count = np.concatenate([count, np.flip(count, a)], axis=a)
        size[a], shape[a] = 2 * size[a], 2 * shape[a]
    spacing = np.asarray(fields.grid.spacing, float).copy()
    grid = VoxelGrid(size=size, shape=tuple(shape), spacing=spacing)
    return type(fields)(
        distance=np.ascontiguousarray(dist), count=np.ascontiguousarray(count), grid=grid
    )
