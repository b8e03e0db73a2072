"""Effective property of a voxel conductivity map from one Laplace solve, with an error
estimate (shared by diffusivity and conductivity).

``value = <J_a> / |grad T|`` (superficial mean flux over the box per unit applied gradient, in
the units of the conductivity map), and for periodic BC the whole column ``<J_b> / |grad T|``.
The error estimate (``rel_error``) is built as the permeability's
(:mod:`psdesign.flow.error`, ``docs/transport.md``)::

    rel_error = max(F_s |X_h - X_2h| / |X_h|,  C h S_f m) + flux_imbalance

* the two-grid term: with ``error_estimate = "resolution"``, a second solve on the grid
  coarsened by two (the signed distance averaged over 2x2x2 blocks, so the surface is
  re-sampled, not eroded; a segmented image, whose walls lie on voxel faces, gets each block's
  columns along the drive in series and in parallel instead, :func:`coarsen_conductivity`);
  the staircase error is first order, so ``X_h - X_2h`` estimates the error of ``X_h``, times
  Roache's safety factor ``F_s = 3`` for two grids
  (:func:`psdesign.flow.error.richardson_rel_error`);
* the staircase floor: the two grids can agree by chance (the staircase error of an ordered
  array changes sign with the resolution), so the bar is at least the change of the value when
  every wall moves by ``C h``, ``C h S_f m``: ``S_f`` is the voxel-face area per volume
  (:func:`face_surface`), ``m`` the relative sensitivity to the pore fraction of the parallel
  or series mean, whichever is smaller (:func:`staircase_floor`), ``C``
  :data:`STAIRCASE_FLOOR`; with ``error_estimate = "residual"`` (no second grid) the floor
  alone, doubled, as for the permeability;
* ``flux_imbalance`` between the planes (algebraic).

Each value is rated like a permeability (:func:`psdesign.flow.error.status_of`): ``status`` is
``"blocked"`` (no conducting path), ``"not_converged"``, ``"untrustworthy"`` (error bar above
:data:`psdesign.flow.error.UNTRUSTWORTHY_REL_ERROR`, fewer than
:data:`psdesign.flow.error.MIN_CELLS_PER_DIAMETER` voxels across the thinnest fiber, or a value
outside its Wiener bounds by more than its error bar: :func:`outside_wiener`; or, on an
analytic RVE, a conducting path that crosses a neck narrower than about a voxel:
:mod:`psdesign.transport.necks`) or ``"ok"``, with
one warning line per reason (:func:`rating`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from psdesign.flow import error as err
from psdesign.flow.darcy import checked_axis
from psdesign.flow.error import richardson_rel_error
from psdesign.geometry.rve import DIAMETER_MEASURE, VoxelFields, is_cubic

BC_NAMES = ("periodic", "permeameter")
#: ``C`` of the staircase floor ``C h S_f m``: on the calibration set (square
#: cylinder arrays at solid fractions 0.2, 0.4, 0.5, 16-96 voxels per spacing, insulating and
#: conducting cylinders at contrasts 10 and 1000, across and along: 108 cases against Rayleigh /
#: Perrins et al. 1979 and the parallel rule; ``benchmarks/RESULTS.md``, truth22) the largest
#: ``|error| / (h S_f m)`` is 0.51; the floor alone covers every case.
STAIRCASE_FLOOR = 0.55
#: Relative slack of the Wiener check (:func:`outside_wiener`) beyond the error bar: the
#: conductivity map is float32 (rounding 6e-8) and a straight-fibre value equals its bound (the
#: parallel mean) up to the CG tolerance; measured 4e-12 above it on the one-cylinder cell.
WIENER_ROUNDING = 1e-6


@dataclass
class Effective:
    """One effective-property solve (see module docstring)."""

    direction: str
    bc: str
    value: float
    column: list[float]
    converged: bool
    residual: float
    iterations: int
    flux_imbalance: float
    rel_error: float
    error_method: str
    blocked: bool
    message: str
    n_cells: int
    wall_time_s: float
    coarse_value: float | None = None
    extra: dict = field(default_factory=dict)
    neck: str | None = None


def wiener_bounds(s1: float, s2: float, f2: float) -> tuple[float, float]:
    """Harmonic (series) and arithmetic (parallel) means of two phases (conductivity ``s1`` at
    fraction ``1 - f2``, ``s2`` at ``f2``): ``(lower, upper)``, rigorous bounds of the effective
    value along any direction of any arrangement, with any of the two boundary conditions.

    >>> wiener_bounds(1.0, 0.0, 0.25)  # pores of a relative diffusivity: [0, porosity]
    (0.0, 0.75)
    """
    f1 = 1.0 - f2
    upper = f1 * s1 + f2 * s2
    lower = 0.0 if min(s1, s2) == 0 else 1.0 / (f1 / s1 + f2 / s2)
    return float(lower), float(upper)


def outside_wiener(
    name: str, value: float, rel_error: float, bounds: tuple[float, float]
) -> str | None:
    """The warning line of a value outside its Wiener bounds by more than its error bar
    (``value * rel_error``, plus :data:`WIENER_ROUNDING` of the upper bound), else None: the
    bounds bind every direction of every medium, so such a value is wrong, not imprecise.

    >>> outside_wiener("sigma_eff_x", 5.0, 0.1, (1.0, 4.0))[:45]
    'sigma_eff_x: 5 lies outside the Wiener bounds'
    >>> outside_wiener("sigma_eff_x", 4.3, 0.1, (1.0, 4.0)) is None  # within its bar
    True
    """
    lo, hi = bounds
    slack = abs(value) * rel_error + WIENER_ROUNDING * abs(hi)
    if not (value + slack < lo or value - slack > hi):
        return None
    return (
        f"{name}: {value:.4g} lies outside the Wiener bounds [{lo:.4g}, {hi:.4g}] (the series "
        f"and parallel means, which bind any direction) by more than its error bar "
        f"({100 * rel_error:.1f} %): the value is wrong"
    )


def rating(
    quantity: str,
    direction: str,
    blocked: bool,
    converged: bool,
    rel_error: float,
    cells_per_diameter: float | None,
    *,
    wiener: tuple[float, tuple[float, float]] | None = None,
    neck: str | None = None,
    measure: str = DIAMETER_MEASURE,
    conducting: str = "pore",
) -> tuple[str, list[str]]:
    """``(status, warnings)`` of one transport value named ``quantity`` (``"D_eff/D"``) along
    ``direction`` ("" for a value without one, e.g. the pore sizes; module docstring).

    (Ten parameters: the value's own numbers, then its optional checks, keyword-only.)

    ``wiener``: ``(value, (lower, upper))`` to check against its Wiener bounds
    (:func:`outside_wiener`; outside makes an ``ok`` value ``untrustworthy``). ``neck``: the
    warning of a conducting path through a neck narrower than about a voxel
    (:func:`psdesign.transport.necks.neck_warning`), which makes an ``ok`` value
    ``untrustworthy``. ``measure``: what ``cells_per_diameter`` counts voxels across
    (:func:`psdesign.geometry.rve.resolution_measure`: a woven yarn's thin width), named in
    the resolution warning as K's is. ``conducting``: the phase that conducts, ``"pore"`` or
    ``"solid"``, whose words the warning of a value blocked on the grid says
    (:func:`blocked_on_grid`).

    >>> rating("D_eff/D", "z", False, True, 0.31, 6.0)[0]
    'untrustworthy'
    >>> rating("D_eff/D", "z", False, True, 0.05, 12.0)
    ('ok', [])
    >>> rating("D_eff/D", "z", False, True, 0.05, 12.0, wiener=(0.9, (0.0, 0.8)))[0]
    'untrustworthy'
    >>> rating("D_eff/D", "z", False, True, 0.05, 7.0, measure="fiber thin width")[1][0][:48]
    'D_eff/D_z: only 7.0 voxels across the thinnest f'
    >>> rating("sigma_eff", "x", True, True, 0.0, 12.0, conducting="solid")[1][0][:62]
    'sigma_eff_x: blocked on the voxel grid, which breaks any conta'
    """
    name = f"{quantity}_{direction}" if direction else quantity
    if blocked:  # an image (no fiber diameter) is its own geometry: its block is exact
        on_grid = [blocked_on_grid(name, conducting)]
        return BLOCKED, [] if cells_per_diameter is None else on_grid
    warnings = err.resolution_warnings(
        cells_per_diameter, "voxel", direction, quantity, measure=measure
    )
    if not converged:
        warnings.append(f"{name}: solver did not converge")
    if not rel_error <= err.UNTRUSTWORTHY_REL_ERROR:
        warnings.append(
            f"{name}: estimated error {err.over_limit_percent(rel_error)} % exceeds "
            f"{100 * err.UNTRUSTWORTHY_REL_ERROR:g} %"
        )
    status = err.status_of(converged, rel_error, cells_per_diameter)
    outside = None if wiener is None else outside_wiener(name, wiener[0], rel_error, wiener[1])
    for reason in (outside, None if neck is None else f"{name}: {neck}"):
        if reason is not None:
            warnings.append(reason)
            status = "untrustworthy" if status == "ok" else status
    return status, warnings


def blocked_on_grid(name: str, conducting: str = "pore") -> str:
    """The warning of a value blocked on the voxel grid of an analytic RVE: the block may be
    the grid's, not the RVE's (a square array across at solid fraction 0.75 has a 0.46 um gap
    per 20 um, closed at 0.5 um voxels: D_eff/D = 0 there, blocked; session 37 edge audit).
    ``conducting``: the phase that conducts, ``"pore"`` or ``"solid"`` (a conductivity with
    an insulating fluid, whose path the grid breaks at a contact thinner than a voxel, not at
    a pore gap; until session 45 it got the pore's words).

    >>> blocked_on_grid("D_eff/D_x")[:40]
    'D_eff/D_x: blocked on the voxel grid, wh'
    >>> blocked_on_grid("sigma_eff_x", "solid")[:76]
    'sigma_eff_x: blocked on the voxel grid, which breaks any contact between the'
    """
    if conducting == "solid":
        return (
            f"{name}: blocked on the voxel grid, which breaks any contact between the fibers "
            "thinner than about a voxel: the fibers themselves may touch and conduct; refine "
            "rve.voxel to tell fibers that do not touch from an unresolved contact"
        )
    return (
        f"{name}: blocked on the voxel grid, which closes any gap of the fibers' surface "
        "narrower than about a voxel: the RVE itself may have a path; refine rve.voxel to tell "
        "a closed pore space from an unresolved gap"
    )


class Rated:
    """The ``status`` of a result dataclass with ``direction``, ``blocked``, ``converged``,
    ``rel_error`` and ``cells_per_diameter`` (:func:`rating`); ``QUANTITY`` names its value in
    the warning lines, :meth:`wiener` gives its value and Wiener bounds."""

    QUANTITY = "value"
    #: The fields the short repr shows before the ``status``: the value (its unit in its name
    #: or a unit field), the error bar, the convergence; every field stays an attribute and is
    #: in ``to_dict()`` (the generated repr listed all 22, a page in a notebook).
    REPR_FIELDS: tuple[str, ...] = ("direction", "rel_error", "converged", "bc")

    @property
    def status(self) -> str:
        """``"ok"``, ``"blocked"`` (no conducting path), ``"not_converged"`` or
        ``"untrustworthy"`` (error bar above 20 %, fewer than 8 voxels across the thinnest
        fiber, or the value outside its Wiener bounds by more than its error bar)."""
        return self._rating()[0]

    def wiener(self) -> tuple[float, tuple[float, float]] | None:
        """``(value, (lower, upper))`` for the Wiener check (:func:`outside_wiener`); None
        here (no check)."""
        return None

    def conducting(self) -> str:
        """The phase that conducts, ``"pore"`` here, whose words the warning of a value
        blocked on the grid says (:func:`blocked_on_grid`)."""
        return "pore"

    def __repr__(self) -> str:
        """:data:`REPR_FIELDS` and the ``status`` (a property, which the generated repr left
        out: a notebook's plain output showed the error bar but not the rating)."""
        shown = [f"{name}={getattr(self, name)!r}" for name in self.REPR_FIELDS]
        return f"{type(self).__name__}({', '.join(shown)}, status={self.status!r})"

    def rating_warnings(self) -> list[str]:
        """One warning line per reason the value is not ``ok`` (:func:`rating`)."""
        return self._rating()[1]

    def to_dict(self) -> dict:
        """Plain dict (JSON-ready), with its ``status``; ``resolution_measure`` only where it
        is a non-round fiber's thin width (round fibers keep their keys, as K's result)."""
        out = asdict(self)
        if out.get("resolution_measure") == DIAMETER_MEASURE:
            del out["resolution_measure"]
        out["solver"] = "voxel-laplace"
        out["status"] = self.status
        return out

    def _rating(self) -> tuple[str, list[str]]:
        return rating(
            self.QUANTITY,
            self.direction,
            self.blocked,
            self.converged,
            self.rel_error,
            self.cells_per_diameter,
            wiener=self.wiener(),
            neck=getattr(self, "unresolved_neck", None),
            measure=getattr(self, "resolution_measure", DIAMETER_MEASURE),
            conducting=self.conducting(),
        )


#: A transport value's status with no conducting path (its value 0, a tortuosity undefined).
BLOCKED = "blocked"
STATUS_ORDER = ("ok", "untrustworthy", "not_converged", BLOCKED)
"""Statuses from best to worst (:func:`worst_status`). The words the exit rule passes
(:func:`psdesign.status.passes`: ``ok``, a force-field search's ``converged`` and
``at_bound``, and ``not_applicable``) rank with ``ok``, and only they: the worst status passes
exactly when the exit is 0."""


def _rank(status: str | None) -> int:
    # A trusted word ranks with "ok" (until session 46 "converged" and "at_bound" ranked below
    # "blocked", as an unknown word: the worst of ["converged", "untrustworthy"] was
    # "converged"). A word outside both (``extrapolated``, ``contact_left``, a missing status)
    # ranks below every known one: nothing says it is better than ``blocked``, and the exit
    # rule (psdesign.status) treats it as not ok. ``.index`` raised ValueError on it.
    from psdesign.packing.overlap_status import NOT_APPLICABLE
    from psdesign.status import passes

    if status == NOT_APPLICABLE:  # no value (an image's Omega): never the worst of real ones
        return -1
    if passes(status):  # trusted, as the exit rule
        return 0
    return STATUS_ORDER.index(status) if status in STATUS_ORDER else len(STATUS_ORDER)


def worst_status(statuses: list[str | None]) -> str | None:
    """The worst of several values' statuses (:data:`STATUS_ORDER`), total over every word: a
    trusted one (:data:`psdesign.status.TRUSTED`) is as good as ``ok``, one outside
    both (or ``None``) is worse than ``blocked``; the first of the worst is returned.

    >>> worst_status(["ok", "untrustworthy", "ok"])
    'untrustworthy'
    >>> worst_status(["ok", "blocked", "extrapolated", "not_converged"])
    'extrapolated'
    >>> worst_status(["converged", "untrustworthy"]), worst_status(["at_bound", "ok"])
    ('untrustworthy', 'at_bound')
    >>> worst_status(["ok", "not_applicable"]), worst_status(["not_applicable", "ok"])
    ('ok', 'ok')
    """
    return max(statuses, key=_rank, default="ok")


def tensor_parts(columns: list) -> dict:
    """The homogenized tensor of three periodic solves, as ``--direction all`` reports it for
    every transport value: ``tensor`` (3x3, column ``a`` = the mean flux for a unit gradient
    along ``a``), ``symmetric`` (its symmetric part) and its ``eigenvalues`` (ascending).
    One definition for diffusivity and conductivity (``conductivity`` gave the tensor alone
    until session 53, though docs/transport.md promised all three).

    >>> tensor_parts([[2.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 3.0]])["symmetric"][0]
    [2.0, 0.1, 0.0]
    """
    tensor = np.column_stack([np.asarray(c, float) for c in columns])
    sym = 0.5 * (tensor + tensor.T)
    return {
        "tensor": tensor.tolist(),
        "symmetric": sym.tolist(),
        "eigenvalues": np.linalg.eigvalsh(sym).tolist(),
    }


def fields_from_solid(solid: np.ndarray, voxel: float) -> VoxelFields:
    """VoxelFields of a voxel image (True = solid) with cubic voxels of ``voxel`` metres; the
    distance field is a binary +-voxel/2 (no sub-voxel surface)."""
    from psdesign.image.fields import image_fields

    solid = np.asarray(solid, bool)
    h = float(voxel)
    return image_fields(solid, h, distance=np.where(solid, -0.5 * h, 0.5 * h).astype(np.float32))


def coarsen_solid(distance: np.ndarray) -> np.ndarray:
    """Solid mask on the grid coarsened by 2 (odd trailing layers dropped): the block-mean
    distance is <= 0."""
    n = [s - s % 2 for s in distance.shape]
    d = distance[: n[0], : n[1], : n[2]].astype(np.float64)
    d = d.reshape(n[0] // 2, 2, n[1] // 2, 2, n[2] // 2, 2).mean(axis=(1, 3, 5))
    return d <= 0.0


def coarsen_conductivity(sigma: np.ndarray, axis: int) -> np.ndarray:
    """Conductivity map of a segmented image on the grid coarsened by 2 (odd trailing layers
    dropped), for a drive along ``axis``: each 2x2x2 block's four columns of two voxels along
    the drive in series (harmonic mean), the columns in parallel (arithmetic mean), the lower
    of Cardwell & Parsons' (1945) bounds of a block's effective conductivity (no conduction
    across the drive inside the block).

    An image's walls lie on voxel faces; a wall through the middle of a block is a fraction of
    it here, where the sign of the block-mean distance (:func:`coarsen_solid`, right for a
    re-sampled analytic surface) ties at half and goes solid, thinning a pore at every wall on
    an odd voxel face. A straight channel along the drive keeps its area on the coarse grid at
    any offset (its columns are uniform) and a wall across the drive stays closed (its columns
    are in series); the plain block mean (both bounds' upper) bridged conducting inclusions
    (session 38, ``benchmarks/image_coarse_grid.py``).

    >>> s = np.zeros((4, 4, 4), np.float32); s[:, 1:3, 1:3] = 1  # a 2x2 channel off the blocks
    >>> float(coarsen_conductivity(s, 0)[0].sum() * 4)  # its area in a cross-section
    4.0
    >>> w = np.ones((4, 4, 4), np.float32); w[1] = 0  # a wall across x, one voxel thick
    >>> float(coarsen_conductivity(w, 0)[0].max())  # its coarse layer stays closed
    0.0
    """
    n = [s - s % 2 for s in sigma.shape]
    s = np.asarray(sigma[: n[0], : n[1], : n[2]], np.float64)
    # in units of the largest: a * b of two 1e-300 phases underflowed to 0 (session 53)
    scale = float(s.max()) if s.size and s.max() > 0 else 1.0
    s = (s / scale).reshape(n[0] // 2, 2, n[1] // 2, 2, n[2] // 2, 2)
    pair = 2 * axis + 1
    a, b = np.take(s, 0, axis=pair), np.take(s, 1, axis=pair)
    total = a + b
    series = np.divide(2.0 * a * b, total, out=np.zeros_like(total), where=total > 0)
    across = tuple(i if i < pair else i - 1 for i in (1, 3, 5) if i != pair)
    # the map's own precision: a float64 map (conductivity) keeps a phase under float32's range
    return (scale * series.mean(axis=across)).astype(np.result_type(sigma.dtype, np.float32))


def face_surface(solid: np.ndarray) -> float:
    """Voxel faces between the phases per voxel (periodic wrap): ``h S_f``, the staircase
    surface per volume in units of ``1 / h``."""
    faces = sum(int(np.count_nonzero(solid != np.roll(solid, 1, axis=a))) for a in range(3))
    return faces / max(solid.size, 1)


def staircase_floor(solid: np.ndarray, sigma_solid: float, sigma_fluid: float) -> float:
    """Relative error floor ``C h S_f m`` (module docstring): ``m`` is the relative change of
    the effective value per unit change of the pore fraction, taken as the smaller of the
    parallel (arithmetic) mean's ``|s_f - s_s| / s_arith`` (exact along straight fibres) and the
    series (harmonic) mean's ``s_harm |1 / s_f - 1 / s_s|`` (across layers; ``1 / (1 - eps)``
    for an insulating solid): the two bound how strongly a mean can react."""
    eps = 1.0 - float(np.count_nonzero(solid)) / max(solid.size, 1)
    arith = eps * sigma_fluid + (1.0 - eps) * sigma_solid
    if arith <= 0 or eps in (0.0, 1.0):
        return 0.0
    parallel = abs(sigma_fluid - sigma_solid) / arith
    if min(sigma_solid, sigma_fluid) <= 0:  # harmonic mean 0: its limit, 1 / fraction of the other
        series = 1.0 / (1.0 - eps) if sigma_solid <= 0 else 1.0 / eps
    else:
        harm = 1.0 / (eps / sigma_fluid + (1.0 - eps) / sigma_solid)
        series = harm * abs(1.0 / sigma_fluid - 1.0 / sigma_solid)
    return STAIRCASE_FLOOR * face_surface(solid) * min(parallel, series)


def porosity_term(fields: VoxelFields, sigma_solid: float, sigma_fluid: float) -> float:
    """Relative error of a value whose pore fraction is off by the voxel count's own bar
    (``fields.porosity_error``, :mod:`psdesign.geometry.porosity`), at the parallel mean's
    sensitivity ``|s_f - s_s| / s_arith`` (exact along straight fibres, where the value is the
    parallel mean of the counted fractions): near-touching cylinders at a few voxels per
    spacing count their corner pores wrong by more than the staircase floor allows (session 38,
    square array at solid fraction 0.77, 16 voxels, along: ``D_eff / D`` -18.5 % against a
    10.6 % bar). 0 for a segmented image (its count is exact)."""
    eps = float(fields.porosity)
    arith = eps * sigma_fluid + (1.0 - eps) * sigma_solid
    if arith <= 0:
        return 0.0
    return abs(sigma_fluid - sigma_solid) / arith * float(getattr(fields, "porosity_error", 0.0))


def check_bc(bc: str) -> str:
    """The bc name, or ValueError naming ``transport.bc``."""
    if bc not in BC_NAMES:
        raise ValueError(f"transport.bc: must be 'periodic' or 'permeameter', got {bc!r}")
    return bc


def _discretization(
    sigma_of: Callable[[np.ndarray], np.ndarray],
    fields: VoxelFields,
    ax: int,
    bc: str,
    kw: dict,
    value: float,
    transport: dict,
) -> tuple[float, str, float | None]:
    """Discretization part of the bar (module docstring): ``(relative error, method, X_2h)``."""
    from solvers.transport import solve_laplace

    sigma_s, sigma_f = (float(v) for v in sigma_of(np.array([True, False])))
    floor = staircase_floor(fields.solid, sigma_s, sigma_f)
    count = porosity_term(fields, sigma_s, sigma_f)
    if transport.get("error_estimate", "resolution") != "resolution":
        return max(2.0 * floor, count), "staircase floor (doubled) + flux imbalance", None
    if getattr(fields, "analytic_distance", True):  # re-sample the fibers' surface
        coarse = sigma_of(coarsen_solid(fields.distance))
    else:  # a segmented image: walls on voxel faces, a block's columns in series
        coarse = coarsen_conductivity(sigma_of(fields.solid), ax)
    if min(coarse.shape) < 4 or value <= 0:
        return max(2.0 * floor, count), "staircase floor (doubled) + flux imbalance", None
    rc = solve_laplace(coarse, ax, bc=bc, **kw)
    coarse_value = float(rc.mean_flux[ax] / rc.gradient)
    two_grid = richardson_rel_error(value, coarse_value, 2.0, 1)
    method = "max(two_grid F_s = 3, staircase floor, porosity count) + flux imbalance"
    return max(two_grid, floor, count), method, coarse_value


def _neck(sigma_of: Callable[[np.ndarray], np.ndarray], fields: VoxelFields, ax: int) -> str | None:
    """The narrow-neck warning of an analytic RVE's value (:mod:`psdesign.transport.necks`);
    None for a segmented image, which is its own geometry (its walls are the voxel faces)."""
    from psdesign.transport.necks import neck_warning

    if not getattr(fields, "analytic_distance", True):
        return None
    sigma_s, sigma_f = (float(v) for v in sigma_of(np.array([True, False])))
    h = float(fields.grid.spacing[0])
    return neck_warning(fields.distance, h, sigma_s, sigma_f, ax)


def solve_effective(
    sigma_of: Callable[[np.ndarray], np.ndarray],
    fields: VoxelFields,
    direction: str | int,
    transport: dict,
    progress: Callable[[int, float], None] | None = None,
    capture: Callable[..., None] | None = None,
) -> Effective:
    """Solve for the effective property along ``direction``.

    Parameters
    ----------
    sigma_of : callable
        Maps a solid mask to the voxel conductivity map (called on the fine and, for the
        resolution estimate, the coarse mask).
    fields : VoxelFields
        Cubic voxels.
    direction : "x", "y", "z" or 0..2
    transport : dict
        Validated ``[transport]`` table (``bc``, ``tol``, ``max_iter``, ``error_estimate``).
    progress : callable, optional
        ``progress(iteration, residual)`` passed to the solver.
    capture : callable, optional
        Called as ``capture(solution=LaplaceResult, conductivity=array, fields=fields)`` after
        the fine solve (the potential field for :mod:`psdesign.fields`).
    """
    from solvers.transport import solve_laplace

    t0 = time.perf_counter()
    name, ax = checked_axis(direction, "direction")
    spacing = fields.grid.spacing
    if not is_cubic(spacing):
        raise ValueError("transport needs cubic voxels; make rve.size a multiple of rve.voxel")
    bc = check_bc(transport.get("bc", "periodic"))
    kw = {
        "tol": float(transport.get("tol", 1e-8)),
        "max_iter": int(transport.get("max_iter", 2000)),
    }
    sigma = sigma_of(fields.solid)
    res = solve_laplace(sigma, ax, bc=bc, progress=progress, **kw)
    if capture is not None:
        capture(solution=res, conductivity=sigma, fields=fields)
    del sigma
    column = (res.mean_flux / res.gradient).tolist()
    value = float(column[ax])
    discretization, method, coarse_value, neck = 0.0, "flux_imbalance", None, None
    if not res.blocked:
        discretization, method, coarse_value = _discretization(
            sigma_of, fields, ax, bc, kw, value, transport
        )
        neck = _neck(sigma_of, fields, ax)
    rel_error = discretization + float(res.flux_imbalance)
    return Effective(
        direction=name,
        bc=bc,
        value=value,
        column=[float(c) for c in column],
        converged=bool(res.converged),
        residual=float(res.residual),
        iterations=int(res.iterations),
        flux_imbalance=float(res.flux_imbalance),
        rel_error=float(rel_error),
        error_method=method,
        blocked=bool(res.blocked),
        message=res.message,
        n_cells=int(np.prod(fields.grid.shape)),
        wall_time_s=time.perf_counter() - t0,
        coarse_value=coarse_value,
        neck=neck,
    )
