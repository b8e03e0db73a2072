"""Force-field relaxation of any implicit fiber set: woven yarns, compressed fibers (issue 17).

:mod:`psdesign.forcefield.relax` relaxes round rods and bent rods through their centre lines
(analytic crossing volumes). Woven (Eq. 19) and compressed (Eq. 17-18, Fig. 6) fibers have
no round cross-section, so here the Sec. 6 volume interaction is evaluated on their fields:
every fiber ``j`` has the normalized field ``phi_j`` (approximate signed distance, periods,
``<= 0`` in the solid) and a pair is in contact where ``max(phi_i, phi_j) < gap``. The energy
minimized by pattern search (as in the paper) is

    U = w1 * sum_{i<j} h^3 sum_grid relu(gap - max(phi_i, phi_j))^2
      + w3 * sum_j [ (du_j f_j)^2 + |t_j|^2 / D_j^2 ]

over, per fiber in contact, two shifts ``t_j`` in its lattice plane (through and across the
fabric for a woven fiber) and, for fibers with a bend term (woven, compressed-bent, bent-rod),
the change ``du_j`` of the minor moment (Eq. 16/19: the bend amplitude). The first term is the
depth-weighted overlap (Eq. 8) with a clearance ``gap``; the second keeps the change of shape
small ("the fibers have the minimum deformation"; Sec. 6 uses surface terms for the same
purpose). A fiber changes only by a rigid shift and a bend amplitude, so it stays one
continuous fiber. Variables that end on their bound are listed in ``at_bound`` and the result
is not called converged; a contact left after the search is reported (``min_gap_after < 0``).

Cost: the fields are evaluated only at grid nodes where two fibers could meet within the move
bounds (the contact zone, fixed at the start), and each poll of the compass search changes one
fiber, whose field alone is recomputed (one cached field per fiber and trial value).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from psdesign.forcefield.pattern import pattern_search, poll_bars
from psdesign.forcefield.potentials import Potentials, quadrature_error
from psdesign.forcefield.search_settings import RELAX_SEARCH, SearchSettings
from psdesign.geometry.fibers import ROUND_SHAPES, Fiber, with_minor_moment
from psdesign.geometry.rve import thinnest_fiber_diameter

#: Keys of :meth:`Potentials.to_dict` this route has (no surface area is computed here).
FIELD_TERMS = ("U", "volume_interaction", "surface_interaction", "surface")


@dataclass
class ContactRelaxResult:
    """Outcome of :func:`relax_contacts` (normalized lengths: one period = 1)."""

    fibers: list
    movable: np.ndarray
    names: list
    x: np.ndarray
    min_gap_before: float
    min_gap_after: float
    overlap_before: float
    overlap_after: float
    U_before: float
    U_after: float
    at_bound: list
    converged: bool
    message: str
    n_evals: int
    wall_time_s: float
    n_moved: int = 0  # movable fibers the search did move (a non-zero shift or bend change)
    limit_stop: bool = False  # the search stopped on max_iter / max_evals
    potentials: dict = field(default_factory=dict)  # FIELD_TERMS at the result
    potentials_error: dict = field(default_factory=dict)  # their quadrature bars
    U_before_error: float = 0.0
    poll_step: float = 0.0  # the last poll's mesh (PatternSearchResult.poll_step)
    lower: np.ndarray | None = None  # the variables' bounds
    upper: np.ndarray | None = None


def grid_points(lo: np.ndarray, hi: np.ndarray, h: float) -> np.ndarray:
    """Cell-centred grid of step about ``h`` over the box ``[lo, hi]``, shape (N, 3)."""
    axes = []
    for a, b in zip(lo, hi, strict=True):
        n = max(2, int(np.ceil((b - a) / h)))
        axes.append(a + (np.arange(n) + 0.5) * (b - a) / n)
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def can_bend(fb: Fiber) -> bool:
    """True if the fiber's model has a bend (minor) term whose moment can change."""
    return fb.model.n_minor > 0


def moved_fiber(fb: Fiber, t1: float, t2: float, du: float = 0.0) -> Fiber:
    """The fiber shifted by ``t1, t2`` along its two lattice vectors, bend moment ``u + du``.

    A bend change goes through :func:`psdesign.geometry.fibers.with_minor_moment`: the field
    scale and diameter are re-measured for the new moment as ``make_fiber`` measures them,
    so the search evaluates the field of the fiber ``relaxed.toml`` re-reads to (Session 41:
    keeping the old scale had a re-read woven cell 1.4 um from contact where 2.2 um was
    reported)."""
    t = t1 * fb.lattice[0] + t2 * fb.lattice[1]
    if du and can_bend(fb):
        fb = with_minor_moment(fb, float(fb.model.u[0]) + du)
    return replace(fb, model=fb.model.translated(t), center=np.asarray(fb.center) + t)


def min_pair_gap(fibers: list, points: np.ndarray) -> float:
    """``min_{i<j} min_x max(phi_i, phi_j)`` over the points: < 0 where two fibers overlap.

    Equal to the minimum of the second-smallest field (Eq. 8's intersection field).
    """
    if len(fibers) < 2:
        return float("inf")
    phi = np.array([fb.field(points) for fb in fibers])
    return float(np.partition(phi, 1, axis=0)[1].min())


def overlap_fraction(fibers: list, points: np.ndarray) -> float:
    """Fraction of the points inside two or more fibers (the voxel Omega on this grid)."""
    phi = np.array([fb.field(points) for fb in fibers])
    return float(np.mean((phi <= 0.0).sum(axis=0) >= 2))


def _reach(fb: Fiber, max_shift: float, u_max: float) -> float:
    """Largest distance a surface point of ``fb`` can move within the bounds."""
    bend = u_max / (2 * np.pi) if can_bend(fb) else 0.0
    return float(np.sqrt(2.0) * max_shift + bend)


class _Problem:
    """Contact zone, variables and cached per-fiber fields of one relaxation."""

    def __init__(self, fibers, points, h, gap, max_shift, u_max, weights, tie_bend=False):
        self.fibers, self.h, self.gap = list(fibers), float(h), float(gap)
        self.w1, self.w3 = float(weights[0]), float(weights[2])
        phi = np.array([fb.field(points) for fb in self.fibers])
        reach = np.array([_reach(fb, max_shift, u_max) for fb in self.fibers])
        n = len(self.fibers)
        contact = set()
        for i in range(n):
            for j in range(i + 1, n):
                if np.maximum(phi[i], phi[j]).min() < gap:
                    contact.update((i, j))
        self.movable = np.array(sorted(contact), dtype=np.int64)
        mov = set(self.movable.tolist())
        # pairs that can meet within the bounds, with their points (thr: Lipschitz ~1 fields)
        self.pairs, pts_of = [], {k: [] for k in range(n)}
        for i in range(n):
            for j in range(i + 1, n):
                if i not in mov and j not in mov:
                    continue
                thr = gap + 1.5 * (reach[i] * (i in mov) + reach[j] * (j in mov)) + 2 * h
                idx = np.flatnonzero((phi[i] < thr) & (phi[j] < thr))
                if len(idx):
                    self.pairs.append((i, j, idx))
                    pts_of[i].append(idx)
                    pts_of[j].append(idx)
        self.local = {}  # fiber -> the indices of the points its pairs use
        for k in range(n):
            if pts_of[k]:
                self.local[k] = np.unique(np.concatenate(pts_of[k]))
        self.points = points
        self.base_phi = {k: phi[k][ix] for k, ix in self.local.items()}
        self.slots = {}
        for i, j, idx in self.pairs:
            self.slots[(i, j)] = (
                np.searchsorted(self.local[i], idx),
                np.searchsorted(self.local[j], idx),
            )
        self.bends = np.array([can_bend(self.fibers[k]) for k in self.movable], bool)
        # tied: one change of |u| shared by every bending fiber (Sec. 6.2's "same absolute
        # value of minor moment u"), signed like each fiber's own u
        self.tied = bool(tie_bend and self.bends.any())
        self.sign = {
            int(k): (1.0 if self.fibers[k].u >= 0 else -1.0)
            for k, b in zip(self.movable, self.bends, strict=True)
            if b
        }
        self.cache: dict = {}
        lo, names = [], []
        for k, b in zip(self.movable, self.bends, strict=True):
            own = b and not self.tied
            lo += [-max_shift, -max_shift] + ([-u_max] if own else [])
            names += [f"t1[{k}]", f"t2[{k}]"] + ([f"u[{k}]"] if own else [])
        if self.tied:
            lo.append(-u_max)
            names.append("|u|")
        self.nvar = len(lo)
        self.lower = np.array(lo, float)
        self.upper = -self.lower
        self.names = names

    def split(self, x: np.ndarray) -> dict:
        """Per movable fiber, its ``(t1, t2, du)``."""
        out, p = {}, 0
        common = float(x[-1]) if self.tied else 0.0
        for k, b in zip(self.movable, self.bends, strict=True):
            if self.tied:
                du = self.sign[int(k)] * common if b else 0.0
                p_next = p + 2
            else:
                du = float(x[p + 2]) if b else 0.0
                p_next = p + (3 if b else 2)
            out[int(k)] = (float(x[p]), float(x[p + 1]), du)
            p = p_next
        return out

    def _phi(self, k: int, v: tuple) -> np.ndarray:
        if v == (0.0, 0.0, 0.0):
            return self.base_phi[k]
        key = (k, v)
        got = self.cache.get(key)
        if got is None:
            if len(self.cache) > 4096:
                self.cache.clear()
            got = moved_fiber(self.fibers[k], *v).field(self.points[self.local[k]])
            self.cache[key] = got
        return got

    def overlap_energy(self, parts: dict) -> float:
        total = 0.0
        zero = (0.0, 0.0, 0.0)
        for i, j, _ in self.pairs:
            si, sj = self.slots[(i, j)]
            a = self._phi(i, parts.get(i, zero))[si]
            b = self._phi(j, parts.get(j, zero))[sj]
            d = np.maximum(self.gap - np.maximum(a, b), 0.0)
            total += float(d @ d)
        return total * self.h**3

    def change_energy(self, parts: dict) -> float:
        s = 0.0
        for k, (t1, t2, du) in parts.items():
            fb = self.fibers[k]
            s += (du * fb.f) ** 2 + (t1 * t1 + t2 * t2) / fb.diameter**2
        return s

    def energy(self, x: np.ndarray) -> float:
        parts = self.split(x)
        return self.w1 * self.overlap_energy(parts) + self.w3 * self.change_energy(parts)

    def result_fibers(self, x: np.ndarray) -> list:
        parts = self.split(x)
        return [
            moved_fiber(fb, *parts[k]) if k in parts else fb for k, fb in enumerate(self.fibers)
        ]


def field_potentials(volume: float, surface: float, weights) -> Potentials:
    """This route's U and terms as :class:`Potentials` (no area: 0, not computed)."""
    w1, w3 = float(weights[0]), float(weights[2])
    return Potentials(w1 * volume + w3 * surface, volume, 0.0, surface, 0.0, ())


def refined_points(lo, hi, h: float, idx: np.ndarray, r: int = 2) -> tuple[np.ndarray, float]:
    """The ``r**3`` sub-cell centres of the cells ``idx`` of :func:`grid_points` ``(lo, hi, h)``.

    Returns the points, shape ``(len(idx) * r**3, 3)`` (each cell's children consecutive), and
    the volume of one sub-cell (the true cell volume over ``r**3``, not ``(h / r)**3``).
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    n = np.array([max(2, int(np.ceil((b - a) / h))) for a, b in zip(lo, hi, strict=True)])
    c = (hi - lo) / n
    centres = grid_points(lo, hi, h)[idx]
    k = (np.arange(r) + 0.5) / r - 0.5
    off = np.stack(np.meshgrid(k, k, k, indexing="ij"), -1).reshape(-1, 3) * c
    return (centres[:, None, :] + off[None]).reshape(-1, 3), float(np.prod(c)) / r**3


def overlap_energy_refined(prob: _Problem, fibers: list, lo, hi, r: int = 2) -> float:
    """The volume term of ``prob`` for ``fibers`` with every cell of its contact zone split
    into ``r**3`` (step ``h / r``): a grid the search never evaluated. Costs the involved
    fibers' fields at ``r**3`` times their contact-zone points."""
    m = r**3
    phi, vol = {}, 0.0
    for k, ix in prob.local.items():
        pts, vol = refined_points(lo, hi, prob.h, ix, r)
        phi[k] = fibers[k].field(pts).reshape(len(ix), m)
    total = 0.0
    for i, j, _ in prob.pairs:
        si, sj = prob.slots[(i, j)]
        d = np.maximum(prob.gap - np.maximum(phi[i][si], phi[j][sj]), 0.0)
        total += float(np.sum(d * d))
    return total * vol


def field_potential_error(prob: _Problem, x, fibers: list, lo, hi, weights) -> tuple[dict, dict]:
    """U and its terms at ``x`` and their quadrature bar from a FINER check grid.

    The volume term once more with every contact-zone cell split in 8 (step ``h / 2``), and
    :func:`psdesign.forcefield.potentials.quadrature_error` with ``reference="finer"``:
    ``FINER_SAFETY * |U(h) - U(h/2)|``. Not the paper cases' ``h -> 2 h`` rule: the search
    fits the volume term to its own grid, so at its optimum ``|U(h) - U(2h)|`` under-covers
    (benchmarks/RESULTS.md, Session 40). The change-of-shape term is closed form (bar 0).
    ``fibers``: the fibers at ``x``. Costs about 8 evaluations of the volume term.
    """
    parts = prob.split(x)
    surf = prob.change_energy(parts)
    at_h = field_potentials(prob.overlap_energy(parts), surf, weights)
    check = field_potentials(overlap_energy_refined(prob, fibers, lo, hi), surf, weights)
    err = quadrature_error(at_h, check, weights, reference="finer")
    full = at_h.to_dict()
    return {k: full[k] for k in FIELD_TERMS}, {k: err[k] for k in FIELD_TERMS}


def relax_contacts(
    fibers: list,
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    h: float = 0.02,
    gap: float | None = None,
    max_shift: float = 0.05,
    u_max: float = 0.2,
    weights=(1e10, 1.0, 1.0),
    search: SearchSettings = RELAX_SEARCH,
    tie_bend: bool = False,
) -> ContactRelaxResult:
    """Remove the contacts of an implicit fiber set by small shifts and bends (Sec. 6).

    (Ten parameters: the fibers and box, then independent knobs of the relaxation, keyword-only.)

    Parameters
    ----------
    fibers : list of Fiber
        Any shapes (woven, compressed, rods); normalized coordinates.
    lo, hi : ndarray (3,)
        The box (normalized); contacts are looked for inside it.
    h : float
        Grid step of the volume term (normalized).
    gap : float, optional
        Clearance asked for between fibers (normalized; default ``h``, so that no grid cell
        holds two fibers).
    max_shift : float
        Bound of each lattice-plane shift (normalized).
    u_max : float
        Bound of the change of the bend moment (fibers with a bend term).
    weights : (w1, w2, w3)
        Sec. 6 weights; w2 (surface interaction) is not used for fiber sets.
    search : SearchSettings
        Pattern-search limits (default: :data:`.search_settings.RELAX_SEARCH`).
    tie_bend : bool
        One change of ``|u|`` for every fiber with a bend term (each keeps its sign), as the
        paper ties its woven yarns (Sec. 6.2); default: a change per fiber.

    Returns
    -------
    ContactRelaxResult
    """
    t0 = time.perf_counter()
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    gap = float(h if gap is None else gap)
    pts = grid_points(lo, hi, h)
    gap0 = min_pair_gap(fibers, pts)
    om0 = overlap_fraction(fibers, pts)
    prob = _Problem(fibers, pts, h, gap, max_shift, u_max, weights, tie_bend)
    x0 = np.zeros(prob.nvar)
    if prob.nvar == 0:
        return ContactRelaxResult(
            list(fibers), prob.movable, [], x0, gap0, gap0, om0, om0, 0.0, 0.0, [], True,
            "no contacts", 0, time.perf_counter() - t0,
        )  # fmt: skip
    u0 = prob.energy(x0)
    from psdesign.progress import search_progress

    res = pattern_search(
        prob.energy, x0, prob.lower, prob.upper,
        search,
        callback=search_progress(f"relax ({len(prob.movable)} fibers, contacts on a grid)"),
    )  # fmt: skip
    from psdesign.forcefield.run import at_bounds

    on = at_bounds(prob.names, res.x, prob.lower, prob.upper)
    final = prob.result_fibers(res.x)
    gap1 = min_pair_gap(final, pts)
    pot, err = field_potential_error(prob, res.x, final, lo, hi, weights)
    start_err = field_potential_error(prob, x0, list(fibers), lo, hi, weights)[1]["U"]
    return ContactRelaxResult(
        fibers=final,
        movable=prob.movable,
        names=prob.names,
        x=res.x,
        min_gap_before=gap0,
        min_gap_after=gap1,
        overlap_before=om0,
        overlap_after=overlap_fraction(final, pts),
        U_before=u0,
        U_after=float(res.fun),
        at_bound=on,
        converged=bool(res.converged and not on and gap1 >= 0.0),
        message=res.message,
        n_evals=res.n_evals,
        wall_time_s=time.perf_counter() - t0,
        n_moved=sum(any(v != 0.0 for v in m) for m in prob.split(res.x).values()),
        limit_stop=not res.converged,
        potentials=pot,
        potentials_error=err,
        U_before_error=start_err,
        poll_step=res.poll_step,
        lower=prob.lower,
        upper=prob.upper,
    )


# ------------------------------------------------------------------ specs
#: Options of ``[forcefield.relax]`` used only by this route (metres).
FIELD_KEYS = {"grid", "gap", "tie_bend"}


def placement_angles(fb: Fiber) -> tuple[float, float]:
    """Sec. 7.1 angles ``(theta, omega)`` that place ``fb`` with its own roll.

    Raises
    ------
    ValueError
        If no ``(theta, omega)`` reproduces the fiber's frame (a roll about its axis that the
        spec keys cannot express).
    """
    from psdesign.geometry.fibers import placement_rotation

    if fb.theta is not None and fb.omega is not None:
        return float(fb.theta), float(fb.omega)
    d = np.asarray(fb.direction, float)
    theta = float(np.degrees(-np.arcsin(np.clip(d[2], -1.0, 1.0))))
    omega = float(np.degrees(np.arctan2(d[1], d[0])))
    R = np.column_stack([fb.lattice[0], fb.lattice[1], d])
    if fb.shape not in ("rod", "cylinder") and not np.allclose(
        placement_rotation(theta, omega), R, atol=1e-9
    ):
        raise ValueError(f"a {fb.shape} fiber turned about its own axis has no theta/omega")
    return theta, omega


def fiber_table_lines(fb: Fiber, period: float) -> list[str]:
    """The ``[[fibers]]`` TOML lines of one placed fiber (metres, degrees)."""
    theta, omega = placement_angles(fb)
    lines = ["[[fibers]]", f'shape = "{fb.shape}"']
    if fb.shape in ROUND_SHAPES:
        lines.append(f"diameter = {float(fb.diameter * period)!r}")
    lines.append(f"center = [{', '.join(repr(float(v * period)) for v in fb.center)}]")
    lines += [f"theta = {theta!r}", f"omega = {omega!r}"]
    if fb.shape == "bent-rod":
        lines += [f"u = {float(fb.u)!r}", f"f = {float(fb.f)!r}"]
    elif fb.model.n_minor:
        lines.append(f"u = {float(fb.model.u[0])!r}")
    if fb.shape not in ROUND_SHAPES and fb.isovalue != 0.0:
        lines.append(f"isovalue = {float(fb.isovalue)!r}")
    return lines


def relaxed_fibers_toml(spec: dict, fibers: list, period: float) -> str:
    """An explicit RVE spec (TOML text) of any relaxed fiber set, readable by every command."""
    rv = spec["rve"]
    lines = ["# Fibers relaxed by psdesign forcefield (paper Sec. 6).", "[rve]"]
    lines.append(f"size = [{', '.join(repr(float(v)) for v in rv['size'])}]")
    lines.append(f"voxel = {float(rv['voxel'])!r}")
    lines.append(f"period = {float(period)!r}")
    for i, fb in enumerate(fibers):
        try:
            lines += [""] + fiber_table_lines(fb, period)
        except ValueError as exc:
            from psdesign.errors import SpecError

            raise SpecError(f"fibers[{i}]", f"relaxed.toml cannot hold it: {exc}") from None
    return "\n".join(lines + flow_table_lines(spec)) + "\n"


def flow_table_lines(spec: dict) -> list[str]:
    """The spec's ``[flow]`` table as TOML lines for a relaxed spec (strings, booleans and
    numbers; nothing when the spec has none)."""
    if "flow" not in spec:
        return []
    lines = ["", "[flow]"]
    for k, v in spec["flow"].items():
        if isinstance(v, str):
            lines.append(f'{k} = "{v}"')
        elif isinstance(v, bool):
            lines.append(f"{k} = {'true' if v else 'false'}")
        elif isinstance(v, int | float):
            lines.append(f"{k} = {v!r}")
    return lines


def relax_rve_fields(rve, kw: dict, grid_m: float | None, gap_m: float | None):
    """Run :func:`relax_contacts` on every fiber of ``rve``; returns (relaxed RVE, result)."""
    from psdesign.geometry.rve import RVE

    period = float(rve.period)
    dmin = thinnest_fiber_diameter(rve)
    h = (grid_m if grid_m is not None else dmin / 5.0) / period
    gap = None if gap_m is None else gap_m / period
    lo, hi = rve.box_normalized
    res = relax_contacts(list(rve.fibers), lo, hi, h=h, gap=gap, **kw)
    return RVE(rve.size, res.fibers, period=period), res


def field_summary(res: ContactRelaxResult, period: float, kw: dict, h_m: float) -> dict:
    """The ``summary.json`` record of a field-route relaxation (lengths in metres)."""
    from psdesign.forcefield.relax import free_variable_bars
    from psdesign.forcefield.run import RELAX_UNITS, search_status

    status = search_status(res.limit_stop, res.at_bound, res.min_gap_after < 0.0)
    return {
        "case": "relax",
        "route": "fields",
        "n_fibers": len(res.fibers),
        "n_movable": int(len(res.movable)),
        "n_moved": res.n_moved,
        "min_gap_before_m": res.min_gap_before * period,
        "min_gap_after_m": res.min_gap_after * period,
        "overlap_fraction_before": res.overlap_before,
        "overlap_fraction_after": res.overlap_after,
        "U": res.U_after,
        "U_error": res.potentials_error.get("U", 0.0),
        "potentials": res.potentials,
        "potentials_error": res.potentials_error,
        "start": {"U": res.U_before, "U_error": res.U_before_error},
        "converged": res.converged,
        "status": status,
        "at_bound": res.at_bound,
        "variables": dict(zip(res.names, (float(v) for v in res.x), strict=True)),
        "message": res.message,
        "n_evals": res.n_evals,
        "wall_time_s": res.wall_time_s,
        # units of "variables": shifts in periods
        "variables_error": poll_bars(res.names, res.lower, res.upper, res.poll_step)
        if res.lower is not None
        else {},
        "grid_m": h_m,
        "free_variables": {
            "max_shift_m": kw["max_shift"] * period,
            "u_max": kw["u_max"],
            "tie_bend": bool(kw.get("tie_bend", False)),
        },
        "free_variables_error": free_variable_bars(res.poll_step, kw, period),
        "surface_term": "change of shape (bend moment and shift)",
        "units": RELAX_UNITS,
    }
