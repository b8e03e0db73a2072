"""Random straight and bent fiber RVEs at a target porosity (paper Sec. 7.1, Figs 13-18).

Entry point: :func:`build_fibers` turns a spec (``[rve]``, ``[generator]``,
``[intersections]`` tables, see ``/work/shared/design.md``) into fibers, an :class:`RVE`
and a report. Fibers follow Sec. 7.1: each starts along x through the cell centre, is
rotated about y by ``theta`` and about z by ``omega`` (degrees) and translated to
``(tx, ty, tz)`` (fractions of the RVE edges). Every parameter is drawn from a named
distribution (:mod:`psdesign.packing.distributions`); ``orientation = {anisotropy = b}`` replaces
theta/omega by the Schulz et al. (2007) density.

Porosity targeting: a fiber of normalized cross-section area ``A`` whose carrier axis
has length ``L`` inside the box adds ``A L / V`` solid (exact for a cylinder cut by the
box faces away from edges). Fibers are added (``fast``: placed without overlap) until the
predicted porosity reaches the target, then the porosity is MEASURED on the voxel grid
and corrected by adding or dropping fibers until it is within the tolerance; the
achieved value is reported. An unreachable target raises :class:`GenerationError`
with the closest porosity reached.
"""

from __future__ import annotations

import csv
import json
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from psdesign.errors import SpecError
from psdesign.geometry.fibers import ROUND_SHAPES, Fiber, rod_cross_section_area
from psdesign.geometry.rve import RVE, VoxelFields
from psdesign.packing.distributions import AnisotropicOrientation, Distribution
from psdesign.packing.ga_settings import GA_VOXEL_RVE_VOXELS, PAPER_MAX_SHIFT, GASettings
from psdesign.packing.genetic import ga_progress
from psdesign.packing.intersections import (
    FiberState,
    carrier_lengths,
    clearance,
    genetic,
    orientation_tensor,
    place_sequential,
)
from psdesign.packing.overlap_status import analytic_omega_keys, intersection_status
from psdesign.packing.placement_settings import FAST_SPEC_DEFAULTS, PlacementSettings
from psdesign.schema.document import MAX_CYLINDER_PACKING  # noqa: F401 (re-export)
from psdesign.schema.generator import DEFAULT_TOLERANCE, METHODS, IntersectionsTable  # noqa: F401
from psdesign.schema.generator import GeneratorTable as _GeneratorTable
from psdesign.schema.spec import validate_document

#: Keys of ``[generator]`` / ``[intersections]`` (derived from the schema).
_GEN_KEYS = set(_GeneratorTable.model_fields)
_INT_KEYS = set(IntersectionsTable.model_fields)


class GenerationError(SpecError):
    """The generator could not build a valid RVE (e.g. an unreachable porosity).

    A :class:`~psdesign.errors.SpecError` naming the key to change (``generator.porosity``,
    ``generator.n_fibers``, ``intersections.method``), as the CLI treats it (exit 2): until
    session 42 it was a bare ``ValueError``, and a script's ``except psdesign.SpecError``
    around ``psdesign.build`` (README: it "catches any bad input") let a porosity the seed
    cannot reach through as a traceback.

    Parameters
    ----------
    message : str
        ``"key: what happened"``; ``key`` becomes :attr:`key`.
    closest_porosity : float or None
        The porosity closest to the target that was reached (voxel measure).
    """

    def __init__(self, message: str, closest_porosity: float | None = None) -> None:
        self.closest_porosity = closest_porosity
        key, _, rest = message.partition(": ")
        super().__init__(key, rest)


#: The uniform (low, high) each ``[generator]`` distribution a spec leaves out is drawn from
#: (degrees; fractions of the edge; u and f of bent fibers): one definition, for
#: :func:`parse_generator` and docs/spec-keys.md (:func:`psdesign.schema.keys.code_defaults`).
DEFAULT_UNIFORM = {
    "theta": (-5.0, 5.0),
    "omega": (0.0, 180.0),
    **{k: (0.0, 1.0) for k in ("tx", "ty", "tz")},
    "u": (0.1, 0.3),
    "f": (1.0, 10.0),
}


@dataclass
class GenerationResult:
    """Fibers, the RVE holding them, the final voxel fields and a report dict."""

    fibers: list[Fiber]
    rve: RVE
    report: dict
    fields: VoxelFields | None = None


@dataclass
class GeneratorSpec:
    """Validated ``[generator]`` + ``[intersections]`` tables (lengths in metres)."""

    kind: str
    porosity: float | None
    n_fibers: int | None
    diameter: Distribution
    seed: int
    theta: Distribution | None
    omega: Distribution | None
    orientation: AnisotropicOrientation | None
    t: tuple[Distribution, Distribution, Distribution]
    u: Distribution | None
    f: Distribution | None
    tolerance: float
    max_fibers: int
    method: str
    min_gap: float
    options: dict = field(default_factory=dict)
    period: float = 1.0


# ------------------------------------------------------------------- validation
def parse_rve(spec: dict) -> tuple[np.ndarray, float, float]:
    """``[rve] size``, ``voxel`` and ``period`` (metres) of a spec, validated by the schema.

    One default and limit for the voxel (:class:`psdesign.schema.document.SpecDocument`):
    smallest edge / 100, at most a quarter of the smallest edge, within the memory budget.
    """
    doc = validate_document(spec)
    return np.asarray(doc.rve.size, float), float(doc.voxel), float(doc.period)


def parse_generator(spec: dict, size: np.ndarray, period: float | None = None) -> GeneratorSpec:
    """``[generator]`` and ``[intersections]`` as a :class:`GeneratorSpec`.

    The values are validated once, by the schema (:mod:`psdesign.schema.generator` and the
    cross-field checks of :class:`~psdesign.schema.document.SpecDocument`); this function only
    reads them. ``size`` is kept for compatibility (the spec's ``rve.size`` is used);
    ``period`` defaults to the spec's.

    Raises
    ------
    SpecError
        Any bad key or value (the message names the key and the allowed range).
    """
    if not isinstance(spec, dict) or not isinstance(spec.get("generator"), dict):
        raise SpecError("generator", "must be a table (allowed: [generator] kind, porosity, ...)")
    doc = validate_document(spec)
    g = doc.generator
    inter = doc.intersections or IntersectionsTable()
    period = float(doc.period) if period is None else float(period)

    def dist(name: str, default: Distribution | None = None) -> Distribution | None:
        value = getattr(g, name)
        if value is None:
            return None if default is None else Distribution(default.kind, default.params, name)
        return Distribution.from_model(f"generator.{name}", value)

    orientation = theta = omega = None
    if g.orientation is not None:
        orientation = AnisotropicOrientation(g.orientation.anisotropy)
    else:
        theta = dist("theta", Distribution.uniform(*DEFAULT_UNIFORM["theta"]))
        omega = dist("omega", Distribution.uniform(*DEFAULT_UNIFORM["omega"]))
    t = tuple(dist(k, Distribution.uniform(*DEFAULT_UNIFORM[k])) for k in ("tx", "ty", "tz"))
    u = f = None
    if g.kind == "bent":
        u = dist("u", Distribution.uniform(*DEFAULT_UNIFORM["u"]))
        f = dist("f", Distribution.uniform(*DEFAULT_UNIFORM["f"]))
    opts = {
        k: getattr(inter, k)
        for k in inter.model_fields_set
        if k not in ("method", "min_gap") and getattr(inter, k) is not None
    }
    return GeneratorSpec(
        kind=g.kind,
        porosity=g.porosity,
        n_fibers=g.n_fibers,
        diameter=dist("diameter"),
        seed=g.seed,
        theta=theta,
        omega=omega,
        orientation=orientation,
        t=t,
        u=u,
        f=f,
        tolerance=g.porosity_tolerance,
        max_fibers=g.max_fibers,
        method=inter.method,
        min_gap=inter.min_gap,
        options=opts,
        period=period,
    )


# ---------------------------------------------------------------------- drawing
def draw_fibers(gs: GeneratorSpec, seed: int, n: int, size: np.ndarray) -> FiberState:
    """Draw ``n`` fibers (normalized state) from the spec's distributions.

    Every parameter has its own random stream (spawned from ``seed``), so the first k
    fibers are the same whatever ``n`` is: the porosity search, ``n_fibers`` and every
    intersection method start from the same fibers for one seed.
    """
    period = gs.period
    r = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(9)]
    d = gs.diameter.sample(r[0], n) / period
    if gs.orientation is not None:
        theta, omega = gs.orientation.sample_angles(r[1], n)
    else:
        theta = gs.theta.sample(r[1], n)
        omega = gs.omega.sample(r[2], n)
    t = np.column_stack([dist.sample(r[3 + k], n) for k, dist in enumerate(gs.t)])
    center = t * (size / period)
    if gs.kind == "bent":
        u = gs.u.sample(r[6], n)
        f = gs.f.sample(r[7], n)
        u = np.where(u == 0.0, 1e-12, u)  # keep the bent-rod shape
    else:
        u, f = np.zeros(n), np.ones(n)
    return FiberState(
        diameter=d,
        center=center,
        theta=theta,
        omega=omega,
        u=u,
        f=f,
        fixed=np.zeros(n, bool),
        shape=["bent-rod" if gs.kind == "bent" else "rod"] * n,
    )


def _probe(gs: GeneratorSpec, size: np.ndarray) -> FiberState:
    """256 fibers drawn like the RVE's, from their own seed, to estimate a fiber count."""
    return draw_fibers(gs, gs.seed + 10_000, 256, size)


def _solid_per_fiber(probe: FiberState, lo: np.ndarray, hi: np.ndarray) -> float:
    """Expected solid volume fraction one drawn fiber adds (normalized): a first guess of a
    fiber count, which the porosity search then corrects on the voxel grid.

    A fiber adds ``A L / V`` (area ``A``, carrier length ``L`` in the box of volume ``V``).
    When every box edge is a whole number of periods this takes ``E[L] = V`` (the mean area):
    exact for fibers along a box axis; up to ~4 % more solid in a one-period box
    (:func:`whole_periods`). Along an edge shorter than a period the drawn centre lies in the
    box (``t`` in [0, 1] of the edge) and ``E[L] / V`` exceeds 1 (about 2 for in-plane fibers
    in a box half a period thick): there the probe's own lengths are used.
    """
    areas = _areas(probe)
    ext = np.asarray(hi, float) - np.asarray(lo, float)
    if whole_periods(ext):
        return float(np.mean(areas))
    return float(np.mean(areas * carrier_lengths(probe, lo, hi)) / np.prod(ext))


#: Fibers drawn to measure one fiber's expected carrier length in a one-period box
#: (:func:`_measured_solid_per_fiber`): an isotropic fiber's ``L / V`` scatters by 0.19 there,
#: so 20000 give ``E[L] / V`` to +-0.0013 (session 53: 0.8 s).
SOLID_PROBE_FIBERS = 20_000
#: Fibers whose copies are clipped at once (bounds the memory of the larger boxes' copies).
_PROBE_CHUNK = 2_000


def _measured_solid_per_fiber(gs: GeneratorSpec, size: np.ndarray) -> float:
    """Expected solid volume fraction one fiber of ``gs`` adds to a box of ``size`` (metres),
    ``E[A] E[L] / V``, measured: ``E[L]`` on fibers drawn as the RVE's (own seed, so
    deterministic), ``E[A]`` on the first 256 of them (:func:`_probe`).

    ``A`` and ``L`` are independent: the diameter, the orientation and the centre are drawn
    from separate streams (:func:`draw_fibers`). A fiber's copies sit on a unit lattice in its
    own cross-plane and its centre is uniform in the box, so ``E[L] / V`` is 1 only for fibers
    along a box axis or in boxes of many periods: at one period 1.044 (isotropic), 1.014 (the
    default theta / omega), 1.037 (omega 45 deg); at two and three periods 1.0025, 1.0005
    (isotropic; session 53, 20000 draws). ``L / V`` scatters as about ``0.2 / m^2`` in a box
    whose shortest edge is ``m`` periods (0.19 / 0.051 / 0.024 / 0.013 at 1-4, isotropic):
    :data:`SOLID_PROBE_FIBERS` ``/ m^2`` fibers (the copies clipped grow as ``m^2``) keep the
    one-period box's error, the time about constant.
    """
    size = np.asarray(size, float)
    hi = size / gs.period
    m = max(1.0, float(hi.min()))
    n = max(_PROBE_CHUNK, math.ceil(SOLID_PROBE_FIBERS / m**2))
    probe = draw_fibers(gs, gs.seed + 10_000, n, size)
    total = 0.0
    for start in range(0, n, _PROBE_CHUNK):
        part = probe.subset(np.arange(start, min(start + _PROBE_CHUNK, n)))
        total += float(carrier_lengths(part, np.zeros(3), hi).sum())
    return float(np.mean(_areas(_probe(gs, size)))) * total / n / float(np.prod(hi))


def whole_periods(ext: np.ndarray) -> bool:
    """Whether every box edge ``ext`` (in periods) is a whole number (>= 1) of periods: then a
    fiber's copies (one line per period^2 across its axis) fill the box, and its expected
    length in it is the box's volume over period^2 for fibers along a box axis; up to ~4 %
    more in a one-period box, 0.25 % at two periods (:func:`_measured_solid_per_fiber`)."""
    ext = np.asarray(ext, float)
    return bool(np.allclose(ext, np.round(ext), rtol=0.0, atol=1e-9) and np.all(ext >= 1 - 1e-9))


_N_FIBERS_HELP = "give generator.porosity instead of n_fibers to hold the material"


def n_fibers_at_edges(spec: dict, edges: list[float]) -> list[int]:
    """``generator.n_fibers`` of ``spec`` carried to cubes of edge ``edges`` (metres) at the
    same expected solid fraction, as ``psdesign rev`` grows an RVE at fixed statistics (the
    spec box's own probe measured once for all edges).

    The count is scaled by the measured solid one fiber adds in each box
    (:func:`_measured_solid_per_fiber`): ``n s_box / s_cube``. A fiber adds about ``E[A] / P^2``
    of solid (mean cross-section ``A``, period ``P``) to a box of whole periods: exact for
    fibers along a box axis; up to ~4 % more solid in a one-period box. So the count goes as
    ``edge^2`` for the default period (the cube's edge: every cube is one period, the same
    shape scaled; not as the volume, which doubled the solid per doubling of the edge) and
    stays near the spec's for a given ``rve.period`` (its copies fill the bigger box): 12
    isotropic fibers of 7 um in a one-period 30 um box are 12.5 in a 60 um one (until session
    53 they stayed 12, porosity 0.584 +- 0.002 vs 0.595 +- 0.001). The porosity does not stay
    exactly: fibers that may overlap (``intersections.method = "none"``) hide ``O(n s^2)`` of
    each other, ``s`` one fiber's solid.

    Raises
    ------
    SpecError
        ``generator.n_fibers``, when the spec's box or the cube is not a whole number of
        periods (one fiber's solid there scatters with its place), or when the nearest whole
        count moves the solid fraction by more than ``generator.porosity_tolerance``: a
        porosity target (``generator.porosity``) then.
    """
    size, _, period = parse_rve(spec)
    given = spec["rve"].get("period")
    gs = parse_generator(spec, size, period)
    per_fiber = None  # the spec box's, measured once when the first edge needs it
    counts = []
    for edge in map(float, edges):
        cube_period = float(given) if given is not None else edge
        if not (whole_periods(size / period) and whole_periods(np.full(3, edge / cube_period))):
            raise SpecError(
                "generator.n_fibers",
                f"held fixed only in boxes of whole periods (rve.period {period:g} m, box "
                f"{'x'.join(f'{s:g}' for s in size)} m, cube {edge:g} m, period {cube_period:g} "
                f"m): the solid per fiber there depends on the orientations; {_N_FIBERS_HELP}",
            )
        if per_fiber is None:
            per_fiber = _measured_solid_per_fiber(gs, size)
        cube = np.full(3, edge)
        per_fiber_cube = _measured_solid_per_fiber(replace(gs, period=cube_period), cube)
        exact = gs.n_fibers * per_fiber / per_fiber_cube
        n = max(1, round(exact))
        shift = abs(n - exact) * per_fiber_cube
        if shift > gs.tolerance:
            raise SpecError(
                "generator.n_fibers",
                f"{gs.n_fibers} fibers of the spec's box are {exact:.3g} in a {edge:g} m cube, "
                f"and {n} move its solid fraction by {shift:.3f}, over "
                f"generator.porosity_tolerance {gs.tolerance:g}: choose sizes where the count is "
                f"nearly whole, or {_N_FIBERS_HELP}",
            )
        counts.append(n)
    return counts


def _coarse_step(probe: FiberState, lo: np.ndarray, hi: np.ndarray, tol: float) -> str | None:
    """Why a porosity target was missed when one fiber moves the porosity by more than the
    tolerance band (2 x tol), or None: then most targets fall between two fiber counts (a 40 um
    cube of 7 um fibers: 0.024 per fiber against +-0.005)."""
    step = _solid_per_fiber(probe, lo, hi)
    if step <= 2.0 * tol:
        return None
    return (
        f"one fiber changes the porosity by about {step:.3f} in this box, more than the "
        f"+-{tol} band: enlarge the RVE, thin the fibers or widen generator.porosity_tolerance"
    )


def _areas(st: FiberState) -> np.ndarray:
    """Normalized cross-section area of each fiber (each distinct rod diameter integrated once:
    a quadrature costs ~8 ms)."""
    rods = {d: rod_cross_section_area(d) for d in set(st.diameter.tolist())}
    return np.array(
        [
            np.pi * d * d / 4 if s == "cylinder" else rods[d]
            for d, s in zip(st.diameter.tolist(), st.shape, strict=True)
        ]
    )


# ------------------------------------------------------------------- main entry
def build_fibers(spec: dict, explicit: list[Fiber] | tuple = ()) -> GenerationResult:
    """Build the fibers of an RVE spec (generator + intersection removal + porosity target).

    Parameters
    ----------
    spec : dict
        Parsed TOML with ``rve``, optionally ``generator`` and ``intersections`` tables.
    explicit : list of Fiber
        Explicit fibers (normalized to the RVE period); kept fixed, obstacles for the
        intersection removal, counted in the porosity.

    Returns
    -------
    GenerationResult
        ``report`` holds: method, seed, n_fibers, n_explicit, target_porosity, porosity,
        porosity_before, omega_before / omega_after (voxel fractions, Eq. 8),
        orientation_tensor_before / after, displacement_m and rotation_deg statistics,
        min_clearance_m, n_rejected, wall_time_s.

    Raises
    ------
    SpecError
        Bad keys or values (the message names the key and the allowed range).
    GenerationError
        Unreachable porosity or remaining overlap after ``fast``; reports the closest
        porosity reached.
    """
    t_start = time.perf_counter()
    size, voxel, period = parse_rve(spec)
    lo, hi = np.zeros(3), size / period
    explicit = list(explicit)
    if "generator" not in spec:
        return _explicit_only(size, voxel, period, explicit, t_start)
    gs = parse_generator(spec, size, period)
    rng = np.random.default_rng(gs.seed)
    supported = [fb for fb in explicit if fb.shape in ROUND_SHAPES]
    fixed = FiberState.from_fibers(supported, fixed=True) if supported else None
    others = [fb for fb in explicit if fb.shape not in ROUND_SHAPES]
    gap = gs.min_gap / period
    times: dict = {}

    def measure(st: FiberState) -> VoxelFields:
        t0 = time.perf_counter()
        vf = RVE(size, explicit + st.to_fibers(), period=period).voxelize(voxel)
        times["voxelize"] = times.get("voxelize", 0.0) + time.perf_counter() - t0
        return vf

    t0 = time.perf_counter()
    if gs.method == "fast":
        st, drawn, info = _fast(gs, rng, size, lo, hi, gap, fixed, measure)
    elif gs.method == "ga":
        st, drawn, info = _ga(gs, rng, size, lo, hi, voxel / period, measure)
    else:
        st, drawn, info = _none(gs, rng, size, lo, hi, measure)
    times["generate_and_remove"] = time.perf_counter() - t0 - times.get("voxelize", 0.0)
    vf = info.pop("fields")
    _check_reached(gs, vf, info, others)
    vf_before = measure(drawn)
    fibers = explicit + st.to_fibers()
    rve = RVE(size, fibers, period=period)
    both = FiberState.concat(fixed, st) if fixed is not None else st
    report = {
        "method": gs.method,
        "kind": gs.kind,
        "seed": gs.seed,
        "n_fibers": len(st),
        "n_explicit": len(explicit),
        "target_porosity": gs.porosity,
        "porosity": vf.porosity,
        "porosity_error": vf.porosity_error,
        "porosity_tolerance": gs.tolerance,
        "porosity_before": vf_before.porosity,
        "omega_before": vf_before.intersection_volume_fraction,
        "omega_before_error": vf_before.intersection_error,
        "omega_after": vf.intersection_volume_fraction,
        "omega_after_error": vf.intersection_error,
        "omega_before_status": intersection_status(
            RVE(size, explicit + drawn.to_fibers(), period=period), vf_before
        ),
        "omega_after_status": intersection_status(rve, vf),
        **_placement_stats(drawn, st, both, lo, hi, period),
        "min_gap_m": gs.min_gap,
        "voxel_m": voxel,
        "grid_shape": list(vf.grid.shape),
        **{k: v for k, v in info.items() if k not in ("closest", "why", "jammed")},
    }
    times["total"] = time.perf_counter() - t_start
    report["wall_time_s"] = {k: round(v, 3) for k, v in times.items()}
    return GenerationResult(fibers, rve, report, vf)


def _explicit_only(size, voxel: float, period: float, explicit: list, t_start: float):
    """The :class:`GenerationResult` of a spec without a ``[generator]``: its explicit fibers."""
    rve = RVE(size, explicit, period=period)
    vf = rve.voxelize(voxel)
    report = {
        "method": "none",
        "n_fibers": 0,
        "n_explicit": len(explicit),
        "porosity": vf.porosity,
        "porosity_error": vf.porosity_error,
        "omega_after": vf.intersection_volume_fraction,
        "omega_after_error": vf.intersection_error,
        "omega_after_status": intersection_status(rve, vf),
        "voxel_m": voxel,
        "wall_time_s": {"total": time.perf_counter() - t_start},
    }
    return GenerationResult(explicit, rve, report, vf)


def _jam_advice(gs: GeneratorSpec, closest: float, info: dict) -> str:
    """What to change when ``fast`` jammed short of its solid: a porosity above the one this
    seed reached (a hint, not a promise: where a packing jams depends on its target, session
    53's review saw 0.72 advised at 0.70 jam again at 0.739), thinner fibers, or overlaps
    allowed; '' for any other miss (its reason says what to do). Until session 53 the jam named
    no key or value (session 52 walk-geometry: a thin slab)."""
    if not info.get("jammed") or closest <= gs.porosity:
        return ""
    works = math.ceil(round(closest * 100.0, 6)) / 100.0
    return (
        f"; raise generator.porosity above {closest:.4f} (e.g. {works:.2f}: where a packing "
        "jams depends on its target), use thinner fibers, or intersections.method = 'none' "
        "(overlaps allowed)"
    )


def _check_reached(gs: GeneratorSpec, vf: VoxelFields, info: dict, others: list) -> None:
    """Raise :class:`GenerationError` when the porosity target was missed or ``fast`` left
    overlap on the voxel grid (the closest porosity reached in the message)."""
    achieved = vf.porosity
    omega_after = vf.intersection_volume_fraction
    if gs.porosity is not None and abs(achieved - gs.porosity) > gs.tolerance + 1e-12:
        closest = info.get("closest", achieved)
        raise GenerationError(
            f"generator.porosity: target {gs.porosity} not reached within +-{gs.tolerance} on "
            f"the voxel grid; closest porosity reached {closest:.4f} "
            f"({info.get('why', 'optimizer limit')}{_jam_advice(gs, closest, info)})",
            closest,
        )
    if gs.method == "fast" and omega_after > 0 and gs.min_gap >= 0:
        raise GenerationError(
            f"intersections.method: fast left Omega = {omega_after:.3g} on the voxel grid "
            f"(explicit fibers overlapping each other or unsupported explicit shapes "
            f"{sorted({fb.shape for fb in others})})",
            achieved,
        )


def _placement_stats(drawn, st, both, lo, hi, period: float) -> dict:
    """The report's overlap, orientation and motion statistics of the drawn state ``drawn``
    and the final ``st`` (``both``: with the fixed explicit fibers), lengths in metres."""
    disp = st.center - drawn.center
    d0, d1 = drawn.direction, st.direction
    disp_perp = disp - np.einsum("ij,ij->i", disp, d0)[:, None] * d0
    dist = np.linalg.norm(disp_perp, axis=1) * period
    rot = np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", d0, d1)), 0, 1)))
    return {
        # the centre lines' Omega (the GA's objective) with its bar and status
        **analytic_omega_keys({"before": drawn, "after": both}, lo, hi),
        "orientation_tensor_before": orientation_tensor(drawn).round(6).tolist(),
        "orientation_tensor_after": orientation_tensor(st).round(6).tolist(),
        "displacement_m": _stats(dist),
        "center_z_m": {
            "before": _stats_ms(drawn.center[:, 2] * period),
            "after": _stats_ms(st.center[:, 2] * period),
        },
        "rotation_deg": _stats(rot),
        "orientation_deg": {"before": _angle_stats(drawn), "after": _angle_stats(st)},
        "min_clearance_m": (clearance(both, lo, hi) * period) if len(both) > 1 else None,
    }


def _stats_ms(x: np.ndarray) -> dict:
    return {
        "mean": float(np.mean(x)) if len(x) else 0.0,
        "std": float(np.std(x)) if len(x) else 0.0,
    }


def _angle_stats(st: FiberState) -> dict:
    """Mean and std of the Sec. 7.1 angles of the fiber axes (theta from the axis' z
    component, omega in [0, 180) degrees)."""
    d = st.direction
    theta = np.degrees(-np.arcsin(np.clip(d[:, 2], -1.0, 1.0))) if len(d) else np.zeros(0)
    sign = np.where(d[:, 0] < 0, -1.0, 1.0) if len(d) else np.zeros(0)
    omega = np.degrees(np.arctan2(sign * d[:, 1], sign * d[:, 0])) % 180.0 if len(d) else theta
    theta = theta * sign
    return {
        "theta_mean": float(np.mean(theta)) if len(d) else 0.0,
        "theta_std": float(np.std(theta)) if len(d) else 0.0,
        "omega_mean": float(np.mean(omega)) if len(d) else 0.0,
        "omega_std": float(np.std(omega)) if len(d) else 0.0,
    }


def _stats(x: np.ndarray) -> dict:
    if len(x) == 0:
        return {"mean": 0.0, "rms": 0.0, "max": 0.0}
    return {
        "mean": float(np.mean(x)),
        "rms": float(np.sqrt(np.mean(x * x))),
        "max": float(np.max(x)),
    }


# ------------------------------------------------------------------- the methods
def _fast(gs, rng, size, lo, hi, gap, fixed, measure):
    """Sequential minimal-shift placement, with porosity targeting by measured correction."""
    opts = _fast_options(gs, gap)
    if gs.n_fibers is not None:
        return _fast_count(gs, size, lo, hi, fixed, measure, opts)
    return _fast_porosity(gs, size, lo, hi, fixed, measure, opts)


def _fast_options(gs, gap: float) -> PlacementSettings:
    """:func:`place_sequential`'s settings from ``[intersections]`` (normalized lengths)."""
    opts = FAST_SPEC_DEFAULTS | gs.options
    return PlacementSettings(
        gap=gap,
        step=opts.get("step", None) and opts["step"] / gs.period,
        max_rotation_deg=float(opts["max_rotation_deg"]),
        orientation_tries=int(opts["orientation_tries"]),
        max_ejections=int(opts["max_ejections"]),
        max_shift_z=(float(opts["max_shift_z"]) / gs.period if "max_shift_z" in opts else None),
        max_shift=float(opts.get("max_shift", PAPER_MAX_SHIFT * gs.period)) / gs.period,
        exceed=bool(opts["exceed_bounds"]),
        exceed_rotation_deg=float(opts["exceed_rotation_deg"]),
    )


def _fast_count(gs, size, lo, hi, fixed, measure, opts: PlacementSettings):
    """``generator.n_fibers`` fibers placed without intersections, or a GenerationError."""
    drawn = draw_fibers(gs, gs.seed, gs.n_fibers, size)
    full = FiberState.concat(fixed, drawn) if fixed is not None else drawn
    res = place_sequential(full, lo, hi, replace(opts, on_reject="raise"), seed=gs.seed)
    if len(res.rejected):
        vf = measure(res.state.subset(~res.state.fixed))
        raise GenerationError(
            f"generator.n_fibers: no intersection-free place for fiber "
            f"{int(res.rejected[0]) - (len(fixed) if fixed else 0)} of {gs.n_fibers} "
            f"(jammed at porosity {vf.porosity:.4f}); lower n_fibers, widen the "
            f"orientation range or allow intersections.max_rotation_deg",
            vf.porosity,
        )
    st = res.state.subset(~res.state.fixed)
    n_fx = len(fixed) if fixed is not None else 0
    drawn = drawn.subset(res.placed[res.placed >= n_fx] - n_fx)  # placement order
    vf = measure(st)
    return (
        st,
        drawn,
        {
            "n_rejected": 0,
            "fields": vf,
            "placement_time_s": round(res.wall_time_s, 3),
            "candidates_tested": res.candidates_tested,
            "n_ejections": res.n_ejections,
            "bounds": _bounds_report(opts, gs.period, [len(res.exceeded)]),
        },
    )


def _fast_porosity(gs, size, lo, hi, fixed, measure, opts: PlacementSettings):
    """Fibers placed until the measured porosity meets ``generator.porosity``.

    A generous pool is drawn once (reproducible) and placed until the predicted solid
    fraction reaches the goal; the goal is corrected by the measured minus predicted solid
    for up to six rounds, and the prefix closest to the target is kept.
    """
    t0 = time.perf_counter()
    target_solid = 1.0 - gs.porosity
    probe = _probe(gs, size)
    mean_area = float(np.mean(_areas(probe)))
    n_pool = min(gs.max_fibers, int(np.ceil(2.0 * target_solid / mean_area)) + 50)
    run = _PoolPlacement(gs, size, lo, hi, fixed, opts, n_pool)
    bias = 0.0
    best = None
    for _round in range(6):
        goal = target_solid - bias
        run.place_to(goal)
        st, predicted = run.keep_closest(goal)
        vf = measure(st)
        if best is None or abs(vf.porosity - gs.porosity) < abs(best[0] - gs.porosity):
            best = (vf.porosity, st, list(run.kept), vf)
        err = vf.porosity - gs.porosity
        if abs(err) <= gs.tolerance:
            break
        bias = (1.0 - vf.porosity) - predicted  # measured minus predicted solid
        if err > 0 and not run.jammed and run.used >= run.n_pool < gs.max_fibers:
            # rejections used up the pool before a jam was detected: draw more (the first
            # n_pool draws are unchanged, so the placed fibers stay valid)
            run.draw_more()
            continue
        if err > 0 and (run.jammed or run.used >= run.n_pool):
            break
    porosity, st, kept, vf = best
    why = run.why
    if not run.jammed and run.used < run.n_pool:
        why = _coarse_step(probe, lo, hi, gs.tolerance) or why
    drawn = run.pool.subset(np.array(kept, int))
    info = {
        "n_rejected": run.n_rejected,
        "n_ejections": run.n_ejections,
        "fields": vf,
        "closest": porosity,
        "why": why,
        "jammed": run.jammed,
        "placement_time_s": round(time.perf_counter() - t0, 3),
        "bounds": _bounds_report(opts, gs.period, run.exceeded_counts),
    }
    return st, drawn, info


class _PoolPlacement:
    """The rounds of ``fast`` porosity targeting on one drawn pool: the explicit fibers first,
    then the pool's fibers placed in order (``placed``; ``kept`` their pool indices, ``used``
    the pool fibers tried so far), and the counts the report gives."""

    def __init__(self, gs, size, lo, hi, fixed, opts: PlacementSettings, n_pool: int):
        self.gs, self.size, self.lo, self.hi = gs, size, lo, hi
        self.opts = replace(opts, max_consecutive_rejects=40)
        self.n_pool = n_pool
        self.pool = draw_fibers(gs, gs.seed, n_pool, size)
        self.areas = _areas(self.pool)
        self.box_volume = float(np.prod(hi - lo))
        self.n_fixed = len(fixed) if fixed is not None else 0
        self.fixed_solid = 0.0
        if fixed is not None:
            solid = np.sum(_areas(fixed) * carrier_lengths(fixed, lo, hi))
            self.fixed_solid = float(solid) / self.box_volume
        self.placed = fixed  # explicit fibers first, then placed pool fibers in order
        self.kept: list[int] = []  # pool index of each placed pool fiber
        self.used = 0
        self.n_rejected = 0
        self.n_ejections = 0
        self.exceeded_counts: list[int] = []
        self.why = "the measured porosity did not converge"
        self.jammed = False

    def place_to(self, goal: float) -> None:
        """Place further pool fibers until the predicted solid fraction reaches ``goal``
        (nothing when it already does, the pool is used up or the packing jammed)."""
        lo, hi, n_pool, used = self.lo, self.hi, self.n_pool, self.used
        if not (self.placed_solid() < goal and used < n_pool and not self.jammed):
            return
        rest = self.pool.subset(np.arange(used, n_pool))
        if self.placed is None:
            full, full_area, nb = rest, self.areas[used:], 0
        else:
            full = FiberState.concat(_as_fixed(self.placed), rest)
            full_area = np.r_[_areas(self.placed), self.areas[used:]]
            nb = len(self.placed)
        res = place_sequential(
            full, lo, hi, self.opts, seed=self.gs.seed, area=full_area, stop_solid=goal
        )
        new = [int(k) - nb for k in res.placed if k >= nb]
        seen = new + [int(k) - nb for k in res.rejected]
        self.kept += [used + k for k in new]
        self.used += (max(seen) + 1) if seen else 0
        self.n_rejected += len(res.rejected)
        self.n_ejections += res.n_ejections
        self.exceeded_counts.append(len(res.exceeded))
        self.placed = res.state
        self.placed.fixed[:] = np.arange(len(self.placed)) < self.n_fixed
        if not res.reached_stop:
            self.jammed = self.used < n_pool
            self.why = (
                "packing jammed: 40 fibers in a row found no free place"
                if self.jammed
                else "fiber pool exhausted (raise generator.max_fibers)"
            )

    def _kept_solid(self) -> np.ndarray:
        """Each kept pool fiber's solid volume (area x length in the box), the length where it
        was placed, not where it was drawn: in a box thinner than a period a shift changes a
        tilted fiber's length in the box (a 9 um slab of 7 um fibers: solid fraction 0.334
        drawn against 0.202 placed)."""
        placed, n_fixed = self.placed, self.n_fixed
        if placed is None or not self.kept:
            return np.zeros(0)
        lengths = carrier_lengths(placed.subset(np.arange(n_fixed, len(placed))), self.lo, self.hi)
        return self.areas[np.array(self.kept, int)] * lengths

    def placed_solid(self) -> float:
        """Predicted solid fraction of the explicit fibers and the pool fibers kept, counted as
        :meth:`keep_closest` counts them (:meth:`_kept_solid`). Until session 53 the kept fibers
        were counted where they were drawn, so a later round in a thin slab found its goal met,
        placed nothing, and the target was missed as "the measured porosity did not converge"."""
        return self.fixed_solid + float(np.sum(self._kept_solid())) / self.box_volume

    def keep_closest(self, goal: float) -> tuple[FiberState, float]:
        """Keep the prefix of placed fibers whose predicted solid fraction is closest to
        ``goal``; the kept pool fibers and their predicted solid fraction."""
        n_fixed, placed = self.n_fixed, self.placed
        cum = self.fixed_solid + np.r_[0.0, np.cumsum(self._kept_solid()) / self.box_volume]
        k = int(np.argmin(np.abs(cum - goal)))
        self.kept = self.kept[:k]
        if placed is not None:
            self.placed = placed = placed.subset(np.arange(n_fixed + k))
        st = (
            placed.subset(np.arange(n_fixed, len(placed)))
            if placed is not None
            else self.pool.subset(np.zeros(0, int))
        )
        return st, cum[k]

    def draw_more(self) -> None:
        """Double the pool (at most ``generator.max_fibers``); its first draws are unchanged."""
        gs = self.gs
        self.n_pool = min(gs.max_fibers, 2 * self.n_pool)
        self.pool = draw_fibers(gs, gs.seed, self.n_pool, self.size)
        self.areas = _areas(self.pool)


def _bounds_report(opts: PlacementSettings, period: float, exceeded: list[int]) -> dict:
    """Move bounds used by ``fast`` and how many placements had to exceed them."""
    n = int(sum(exceeded))
    return {
        "max_shift_m": opts.max_shift * period if opts.max_shift is not None else None,
        "max_shift_z_m": opts.max_shift_z * period if opts.max_shift_z is not None else None,
        "max_rotation_deg": opts.max_rotation_deg,
        "exceed_bounds": opts.exceed,
        "exceed_rotation_deg": opts.exceed_rotation_deg,
        **_bounds_status(n),
    }


def _bounds_status(n_exceeded: int) -> dict:
    """The ``n_exceeded`` / ``status`` pair of a placement's bounds report."""
    return {
        "n_exceeded": n_exceeded,
        "status": "within_bounds" if n_exceeded == 0 else "exceeded_bounds",
    }


def _as_fixed(st: FiberState) -> FiberState:
    s = st.copy()
    s.fixed[:] = True
    return s


def _ga(gs, rng, size, lo, hi, voxel_norm, measure):
    """The paper's GA; the fiber count is set by the no-overlap prediction and corrected."""
    opts = gs.options
    period = gs.period
    if gs.n_fibers is not None:
        n = gs.n_fibers
    else:
        probe = _probe(gs, size)
        n = max(1, int(round((1.0 - gs.porosity) / _solid_per_fiber(probe, lo, hi))))
    pool = draw_fibers(gs, gs.seed, min(gs.max_fibers, 4 * n + 50), size)
    d = GASettings()  # the defaults, set there only
    settings = GASettings(
        angle_range_deg=float(opts.get("angle_range_deg", d.angle_range_deg)),
        shift_range=float(opts.get("shift_range", d.shift_range)),
        population=int(opts.get("population", d.population)),
        generations=int(opts.get("generations", d.generations)),
        objective=opts.get("objective", d.objective),
        voxel=float(opts.get("ga_voxel", GA_VOXEL_RVE_VOXELS * voxel_norm * period)) / period,
        time_limit_s=opts.get("time_limit_s"),
    )
    best = None
    info: dict = {"ga": []}
    st = pool.subset(np.arange(n))
    rounds = [1]
    report = ga_progress(settings.generations, settings.objective, rounds)
    for _round in range(4):
        rounds[0] = _round + 1
        res = genetic(st, lo, hi, size / period, settings, seed=gs.seed + _round, report=report)
        vf = measure(res.state)
        info["ga"].append(
            {
                "n_fibers": len(st),
                "objective_initial": res.objective_initial,
                "objective_final": res.objective_final,
                "generations": res.generations,
                "evaluations": res.evaluations,
                "wall_time_s": res.wall_time_s,
                "porosity": vf.porosity,
            }
        )
        if (
            best is None
            or gs.porosity is None
            or abs(vf.porosity - gs.porosity) < abs(best[1].porosity - gs.porosity)
        ):
            best = (res.state, vf, len(st))
        if gs.porosity is None or abs(vf.porosity - gs.porosity) <= gs.tolerance:
            break
        # add/remove fibers by the measured deficit (solid per fiber from this round)
        per = (1.0 - vf.porosity) / max(len(st), 1)
        dn = int(round((vf.porosity - gs.porosity) / max(per, 1e-12)))
        dn = dn if dn != 0 else (1 if vf.porosity > gs.porosity else -1)
        m = int(np.clip(len(st) + dn, 1, len(pool.diameter)))
        st = (
            FiberState.concat(
                res.state.subset(np.arange(min(m, len(st)))), pool.subset(np.arange(len(st), m))
            )
            if m > len(st)
            else res.state.subset(np.arange(m))
        )
    state, vf, m = best
    drawn = pool.subset(np.arange(m))
    info.update(
        {
            "fields": vf,
            "closest": vf.porosity,
            "why": "GA rounds exhausted",
            "n_rejected": 0,
            "bounds": _ga_bounds_report(state, drawn, settings, size / period, period),
        }
    )
    return state, drawn, info


def _ga_bounds_report(
    state: FiberState, drawn: FiberState, settings: GASettings, size_norm: np.ndarray, period: float
) -> dict:
    """The GA's move ranges and how many fibers ended outside them, measured from the drawn
    state: each round restarts from the previous round's result, so the moves of the fibers
    kept over several rounds add up (paper Sec. 7.1 gives the ranges of one adjustment)."""
    shift = np.abs(state.center - drawn.center) / np.asarray(size_norm)
    turn = np.maximum(np.abs(state.theta - drawn.theta), np.abs(state.omega - drawn.omega))
    tol = 1e-9
    out = (shift.max(axis=1, initial=0.0) > settings.shift_range + tol) | (
        turn > settings.angle_range_deg + tol
    )
    return {
        "shift_range": settings.shift_range,
        "angle_range_deg": settings.angle_range_deg,
        "max_shift_m": float(np.max(np.abs(state.center - drawn.center), initial=0.0) * period),
        "max_turn_deg": float(np.max(turn, initial=0.0)),
        **_bounds_status(int(np.count_nonzero(out))),
    }


def _none(gs, rng, size, lo, hi, measure):
    """No intersection removal: overlapping fibers (Boolean model) to the target porosity."""
    if gs.n_fibers is not None:
        st = draw_fibers(gs, gs.seed, gs.n_fibers, size)
        return st, st, {"fields": measure(st), "n_rejected": 0}
    probe = _probe(gs, size)
    a = _solid_per_fiber(probe, lo, hi)
    # Boolean model: porosity = exp(-n a) for random lines of density n per unit area
    n = max(1, int(round(-np.log(gs.porosity) / a)))
    pool = draw_fibers(gs, gs.seed, min(gs.max_fibers, 3 * n + 50), size)
    best = None
    for _round in range(8):
        st = pool.subset(np.arange(n))
        vf = measure(st)
        if best is None or abs(vf.porosity - gs.porosity) < abs(best[1].porosity - gs.porosity):
            best = (st, vf)
        if abs(vf.porosity - gs.porosity) <= gs.tolerance:
            break
        dn = int(round((np.log(gs.porosity) - np.log(vf.porosity)) / -a))
        n = int(
            np.clip(
                n + (dn if dn else (1 if vf.porosity > gs.porosity else -1)), 1, len(pool.diameter)
            )
        )
    st, vf = best
    return (
        st,
        st,
        {
            "fields": vf,
            "closest": vf.porosity,
            "n_rejected": 0,
            "why": _coarse_step(probe, lo, hi, gs.tolerance) or "fiber count search exhausted",
        },
    )


# ---------------------------------------------------------------------- exports
def write_medial_axes(rve: RVE, out_dir: str | Path, n: int = 64) -> tuple[Path, Path]:
    """Write ``medial_axes.csv`` and ``medial_axes.json`` (polylines in metres).

    The CSV has one row per point: ``fiber, copy, point, x_m, y_m, z_m``; the JSON holds
    ``{"units": "m", "fibers": [{"fiber", "shape", "diameter_m", "copies": [[[x, y, z],
    ...], ...]}]}``. Each copy is one periodic copy of the fiber clipped to the box.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    lines = rve.medial_axes_m(n)
    csv_path, json_path = out / "medial_axes.csv", out / "medial_axes.json"
    with open(csv_path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["fiber", "copy", "point", "x_m", "y_m", "z_m"])
        for i, copies in enumerate(lines):
            for c, pts in enumerate(copies):
                for k, p in enumerate(pts):
                    w.writerow([i, c, k, *(f"{v:.9e}" for v in p)])
    data = {
        "units": "m",
        "size_m": rve.size.tolist(),
        "fibers": [
            {
                "fiber": i,
                "shape": fb.shape,
                "diameter_m": fb.diameter * rve.period,
                "copies": [pts.tolist() for pts in copies],
            }
            for i, (fb, copies) in enumerate(zip(rve.fibers, lines, strict=True))
        ],
    }
    json_path.write_text(json.dumps(data))
    return csv_path, json_path
