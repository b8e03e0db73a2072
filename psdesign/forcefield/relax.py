"""The Sec. 6 force field as a tool: relax any spec's fiber set (issue 17).

Every rod / bent-rod fiber of an RVE spec (explicit ``[[fibers]]`` or drawn by
``[generator]``) may bend (minor moment ``u``, Eq. 16) and move a little in its lattice plane
to remove contacts; the total potential of Sec. 6 is minimized by pattern search (as the
paper). For fiber sets the terms are evaluated from the centre lines:

* volume interaction ``sum_ij I_ij``: the analytic crossing volume of every overlapping pair of
  fiber copies (:func:`psdesign.packing.genetic.analytic_omega`, the GA's objective), as a
  fraction of the box;
* surface term ``S_j``: the area added by bending, ``pi D L (u f)^2 / 4`` (the arc length of
  the bent medial axis to second order in the slope ``u f``), the physical reading of "the
  fibers have the minimum surface area"; the printed Gaussian-curvature integral is zero for
  every bent rod (a sheared tube) and cannot be used here;
* moves are kept small by their bounds (``max_shift``, ``u_max``); a variable that ends on its
  bound is listed in ``at_bound`` and the result is not called converged.

The surface interaction term (no dangling fibers) is not used: fibers of a random set need not
touch. The relaxed fibers are written as an explicit RVE spec that ``psdesign permeability``,
``mesh`` and ``generate`` read like any other.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from psdesign.errors import SpecError, short
from psdesign.forcefield.pattern import pattern_search, poll_bars
from psdesign.forcefield.potentials import Potentials, quadrature_error
from psdesign.forcefield.search_settings import RELAX_SEARCH, SearchSettings
from psdesign.geometry.rve import thinnest_fiber_diameter
from psdesign.packing.fiberset import (
    FiberState,
    build_pieces,
    carrier_lengths,
    find_contacts,
    segment_distance,
)
from psdesign.packing.genetic import GL_NODES, analytic_omega, contact_volumes, crossing_volume
from psdesign.packing.overlap_status import analytic_omega_keys

RELAX_KEYS = {"max_shift", "u_max", "f", "weights", "max_iter", "max_evals", "min_step"}
#: Keys of the field route (woven / compressed fibers, :mod:`psdesign.forcefield.contact`).
FIELD_ONLY_KEYS = {"grid", "gap", "tie_bend"}


@dataclass
class RelaxResult:
    """Outcome of :func:`relax_fibers` (normalized lengths)."""

    state: FiberState
    movable: np.ndarray
    omega_before: float
    omega_after: float
    U_before: float
    U_after: float
    at_bound: list
    converged: bool
    message: str
    n_evals: int
    wall_time_s: float
    names: list = field(default_factory=list)
    x: np.ndarray | None = None
    n_contacts_before: int = 0
    n_contacts_after: int = 0
    n_moved: int = 0  # movable fibers the search did move (a non-zero shift or bend change)
    limit_stop: bool = False  # the search stopped on max_iter / max_evals
    poll_step: float = float("nan")  # the last poll's mesh (PatternSearchResult.poll_step)
    lower: np.ndarray | None = None  # the variables' bounds
    upper: np.ndarray | None = None


def overlapping_pairs(st: FiberState, c) -> int:
    """Fiber pairs among the contacts ``c`` (:func:`find_contacts`) with a positive crossing
    volume: the pairs the analytic Omega counts.

    :func:`find_contacts` also keeps a pair of bent fibers whose axes' chords come within the
    chords' sag of touching, which may not touch: two rods 10 um into each other relaxed to
    Omega 0 (voxel Omega of relaxed.toml 0, finer chords no contact) with 1 contact counted
    (walk-paper, session 53).
    """
    if len(c) == 0:
        return 0
    on = contact_volumes(st, c, GL_NODES) > 0.0
    i, j = c.i[on], c.j[on]
    return len(np.unique(np.c_[np.minimum(i, j), np.maximum(i, j)], axis=0))


def bending_area(st: FiberState, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Area added by bending, per fiber: ``pi D L (u f)^2 / 4`` (L: carrier length in box)."""
    return np.pi * st.diameter * carrier_lengths(st, lo, hi) * (st.u * st.f) ** 2 / 4.0


def rod_potentials(st: FiberState, lo, hi, weights, n_gl: int = GL_NODES) -> Potentials:
    """The relax route's U and its terms on the whole fiber set, as :class:`Potentials`.

    ``volume`` is the analytic crossing-volume fraction (:func:`analytic_omega`, ``n_gl``
    Gauss-Legendre nodes per crossing), ``surface`` the bending area (closed form),
    ``surface_interaction`` 0 (not used for fiber sets); ``area`` is the fibers' lateral area
    in the box, ``pi D L`` plus the bending area (normalized units).
    """
    w = np.asarray(weights, float)
    bend = bending_area(st, lo, hi)
    omega = analytic_omega(st, lo, hi, n_gl=n_gl)
    area = float(np.sum(np.pi * st.diameter * carrier_lengths(st, lo, hi)) + bend.sum())
    return Potentials(
        U=float(w[0] * omega + w[2] * float(bend.sum())),
        volume=omega,
        surface_interaction=0.0,
        surface=float(bend.sum()),
        area=area,
        per_fiber_surface=tuple(float(v) for v in bend),
    )


def rod_potential_error(st: FiberState, lo, hi, weights) -> tuple[Potentials, dict]:
    """:func:`rod_potentials` and its quadrature bar: one coarser evaluation (``n_gl`` halved),
    ``|fine - coarse|`` per term by :func:`psdesign.forcefield.potentials.quadrature_error`
    (the paper cases' rule). Only the crossing volume has a quadrature; the bending area is
    closed form (bar 0). Costs one :func:`analytic_omega` of the set."""
    fine = rod_potentials(st, lo, hi, weights)
    coarse = rod_potentials(st, lo, hi, weights, n_gl=GL_NODES // 2)
    return fine, quadrature_error(fine, coarse, weights)


class _RodEnergy:
    """``w1 Omega + w3 sum_j S_j`` of :func:`relax_fibers`, evaluated incrementally.

    Each poll of the compass search changes one variable, so one fiber: only that fiber's
    pairs and its bending area change. The pairs a fiber can form within the move bounds are
    found once (its *neighbours*: every fiber whose centre line comes within ``(D_i + D_j)/2
    + reach`` of it) and the centre-line pieces of every fiber are kept; a trial cuts the
    changed fiber's axis alone and measures it against its neighbours' pieces (the contacts
    of :func:`find_contacts` restricted to its pairs), and the energy is the reference energy
    plus the change. The reference (a whole-set evaluation at the start) moves to each point
    evaluated with more than one fiber changed, one fiber at a time. For fibers of one
    diameter (their axes are then cut alike) it equals the whole-set evaluation for straight
    rods; for bent rods it differs only where two pieces of a bent axis share the closest
    point (a tie that :func:`find_contacts` breaks by its search order and this class by the
    axis parameter), so that the running energy is a function of the state alone (tests in
    ``tests/unit/test_forcefield_rods.py``). The result is re-measured on the whole set.
    """

    def __init__(self, st, movable, lo, hi, reach: float, w1: float, w3: float):
        self.base, self.movable, self.lo, self.hi = st, np.asarray(movable), lo, hi
        self.w1, self.w3 = w1, w3
        self.vol = float(np.prod(hi - lo))
        self.frames = st.frames.copy()
        self.state = st.copy()
        c = find_contacts(st, lo, hi, 0.0, reach=reach)
        near: dict[int, set] = {int(k): set() for k in movable}
        for i, j in zip(c.i.tolist(), c.j.tolist(), strict=True):
            if i in near:
                near[i].add(j)
            if j in near:
                near[j].add(i)
        self.near = {k: np.array(sorted(v), dtype=np.int64) for k, v in near.items()}
        self.x = np.zeros(3 * len(movable))
        self.pair: dict[tuple[int, int], float] = {}
        # the cut of find_contacts(st, lo, hi, 0.0): margin D_max / 2, pieces of 2 D_max
        self.dmax = float(st.diameter.max())
        self.piece = max(2.0 * self.dmax, 0.02)
        used = set(self.near) | {int(j) for v in self.near.values() for j in v}
        self.pc = {j: self._pieces(st, j) for j in sorted(used)}
        self.area = bending_area(self.state, lo, hi)
        for k in self.near:
            self._commit(k, *self._row(k, self.state))
        self.E = w1 * analytic_omega(st, lo, hi) + w3 * float(self.area.sum())
        self._trial: dict = {}

    def _place(self, s: FiberState, k: int, v: np.ndarray) -> None:
        """Fiber ``k`` of ``s`` at its variables ``v = (t1, t2, du)``."""
        l1, l2 = self.frames[k, 1], self.frames[k, 2]
        s.center[k] = self.base.center[k] + v[0] * l1 + v[1] * l2
        s.u[k] = self.base.u[k] + v[2]
        s.shape[k] = "bent-rod" if s.u[k] != 0.0 else self.base.shape[k]

    def _pieces(self, s: FiberState, k: int) -> tuple:
        """Centre-line pieces of fiber ``k`` alone, cut as :func:`find_contacts` cuts them."""
        pc = build_pieces(s.subset([k]), self.lo, self.hi, 0.5 * self.dmax, self.piece)
        return pc.a, pc.b, pc.sag, pc.copy, pc.s_mid

    def _row(self, k: int, s: FiberState) -> tuple[dict, float]:
        """Crossing volumes of fiber ``k`` with each neighbour, and its bending area.

        The contacts of :func:`find_contacts` restricted to the pairs with ``k``: every piece
        of ``k`` against every piece of its neighbours, one contact (the closest piece pair)
        per pair of copies.
        """
        one = s.subset([k])
        area = float(bending_area(one, self.lo, self.hi)[0])
        a, b, sag, cp, sm = self._pieces(s, k)
        nb = self.near[k]
        row = dict.fromkeys(nb.tolist(), 0.0)
        if len(nb) == 0 or len(a) == 0:
            return row, area
        got = [self.pc[j] for j in nb.tolist()]
        A = np.concatenate([g[0] for g in got])
        B = np.concatenate([g[1] for g in got])
        SAG = np.concatenate([g[2] for g in got])
        # copy key of the neighbour pieces: (neighbour position, its copy) as one integer
        CP = np.concatenate([m * 4096 + g[3] for m, g in enumerate(got)])
        OWN = np.concatenate([np.full(len(g[0]), m) for m, g in enumerate(got)])
        SM = np.concatenate([g[4] for g in got])
        # candidate piece pairs: midpoints closer than both half lengths + the largest limit
        ma, mb = 0.5 * (a + b), 0.5 * (A + B)
        ha = 0.5 * np.linalg.norm(b - a, axis=1)
        hb = 0.5 * np.linalg.norm(B - A, axis=1)
        d2 = ((ma[:, None, :] - mb[None, :, :]) ** 2).sum(-1)
        cut = ha[:, None] + hb[None, :] + self.dmax + sag[:, None] + SAG[None, :]
        ia, ib = np.nonzero(d2 < cut * cut)
        if len(ia) == 0:
            return row, area
        dist, _, _ = segment_distance(a[ia], b[ia], A[ib], B[ib])
        dj = s.diameter[nb][OWN[ib]]
        limit = 0.5 * (s.diameter[k] + dj) + sag[ia] + SAG[ib]
        hit = np.flatnonzero(dist < limit)
        if len(hit) == 0:
            return row, area
        key = cp[ia[hit]] * (1 << 40) + CP[ib[hit]]
        # two pieces sharing the closest point (a vertex of a bent axis) tie; take the one
        # first along the axis of the lower-numbered fiber, then of the other: a pair's
        # volume is then the same from either fiber's row (a function of the state alone)
        low = k < nb[OWN[ib[hit]]]
        s_a, s_b = sm[ia[hit]], SM[ib[hit]]
        order = np.lexsort(
            (
                np.where(low, s_b, s_a),
                np.where(low, s_a, s_b),
                np.round((dist - limit)[hit], 12),
                key,
            )
        )
        first = np.r_[True, key[order][1:] != key[order][:-1]]
        sel = hit[order[first]]
        ua = b[ia[sel]] - a[ia[sel]]
        ub = B[ib[sel]] - A[ib[sel]]
        ua /= np.linalg.norm(ua, axis=1)[:, None]
        ub /= np.linalg.norm(ub, axis=1)[:, None]
        sin_a = np.linalg.norm(np.cross(ua, ub), axis=1)
        rk = np.full(len(sel), 0.5 * s.diameter[k])
        v = crossing_volume(dist[sel], rk, 0.5 * dj[sel], sin_a)
        for m, vol in zip(OWN[ib[sel]].tolist(), v.tolist(), strict=True):
            row[int(nb[m])] += vol
        return row, area

    def _delta(self, k: int, row: dict, area: float) -> float:
        old = sum(self.pair.get((min(k, j), max(k, j)), 0.0) for j in row)
        return self.w1 * (sum(row.values()) - old) / self.vol + self.w3 * (area - self.area[k])

    def _commit(self, k: int, row: dict, area: float) -> None:
        for j, v in row.items():
            self.pair[(min(k, j), max(k, j))] = v
        self.area[k] = area
        self.pc[k] = self._pieces(self.state, k)

    def energy(self, x: np.ndarray) -> float:
        x3, r3 = x.reshape(-1, 3), self.x.reshape(-1, 3)
        changed = np.flatnonzero(np.any(x3 != r3, axis=1)).tolist()
        # a fiber whose trial row is at hand moves the reference first (the accepted poll)
        changed.sort(key=lambda q: (q, x3[q].tobytes()) not in self._trial)
        while len(changed) > 1:  # move the reference, one fiber at a time
            p = changed.pop(0)
            k = int(self.movable[p])
            self._place(self.state, k, x3[p])
            got = self._trial.get((p, x3[p].tobytes()))
            row, area = got if got is not None else self._row(k, self.state)
            self.E += self._delta(k, row, area)
            self._commit(k, row, area)
            self.x[3 * p : 3 * p + 3] = x3[p]
            self._trial = {}
        if not changed:
            return self.E
        p = changed[0]
        k = int(self.movable[p])
        s = self.state
        keep = (s.center[k].copy(), s.u[k], s.shape[k])
        self._place(s, k, x3[p])
        row, area = self._row(k, s)
        s.center[k], s.u[k], s.shape[k] = keep
        if len(self._trial) > 256:
            self._trial = {}
        self._trial[(p, x3[p].tobytes())] = (row, area)
        return self.E + self._delta(k, row, area)

    def state_at(self, x: np.ndarray) -> FiberState:
        """The fiber set at the variables ``x``."""
        s = self.base.copy()
        for p, k in enumerate(self.movable.tolist()):
            self._place(s, k, x[3 * p : 3 * p + 3])
        return s


def relax_fibers(
    st: FiberState,
    lo: np.ndarray,
    hi: np.ndarray,
    max_shift: float = 0.05,
    u_max: float = 0.3,
    f_straight: float = 1.0,
    weights=(1e10, 1.0, 1.0),
    search: SearchSettings = RELAX_SEARCH,
) -> RelaxResult:
    """Minimize ``w1 Omega + w3 sum_j S_j`` over shifts and bends of the fibers in contact.

    Parameters
    ----------
    st : FiberState
        The fibers (fixed ones are obstacles only).
    lo, hi : ndarray (3,)
        The box (normalized).
    max_shift : float
        Bound of each lattice-plane shift component (normalized).
    u_max : float
        Bound of the minor moment: ``u`` of each fiber in ``u0 +- u_max``.
    f_straight : float
        Minor scale given to straight fibers when they bend (waves per period).
    weights : (w1, w2, w3)
        Sec. 6 weights; w2 (surface interaction) is not used for fiber sets.
    search : SearchSettings
        Pattern-search limits (default: :data:`.search_settings.RELAX_SEARCH`).
    """
    t0 = time.perf_counter()
    st = st_start(st, f_straight)
    c = find_contacts(st, lo, hi, 0.0)
    involved = np.unique(np.r_[c.i, c.j]) if len(c) else np.zeros(0, int)
    movable = np.array([k for k in involved if not st.fixed[k]], dtype=np.int64)
    w1, _, w3 = (float(v) for v in weights)
    omega0 = analytic_omega(st, lo, hi)
    if len(movable) == 0:
        return RelaxResult(st, movable, omega0, omega0, 0.0, 0.0, [], True, "no contacts", 0, 0.0)
    n_before = overlapping_pairs(st, c)
    reach = 2.0 * (np.sqrt(2.0) * max_shift + u_max / (2.0 * np.pi))
    model = _RodEnergy(st, movable, lo, hi, reach, w1, w3)
    x0 = np.zeros(3 * len(movable))
    lower = np.tile([-max_shift, -max_shift, -u_max], len(movable))
    upper = -lower
    u0 = model.energy(x0)
    from psdesign.progress import search_progress

    res = pattern_search(
        model.energy, x0, lower, upper,
        search, callback=search_progress(f"relax ({len(movable)} fibers)"),
    )  # fmt: skip
    from psdesign.forcefield.run import at_bounds

    names = [f"{v}[{k}]" for k in movable for v in ("t1", "t2", "u")]
    on = at_bounds(names, res.x, lower, upper)
    final = model.state_at(res.x)
    omega1 = analytic_omega(final, lo, hi)  # the whole set, not the running sum
    n_after = overlapping_pairs(final, find_contacts(final, lo, hi, 0.0))
    return RelaxResult(
        state=final,
        movable=movable,
        omega_before=omega0,
        omega_after=omega1,
        U_before=u0,
        U_after=w1 * omega1 + w3 * float(bending_area(final, lo, hi).sum()),
        at_bound=on,
        converged=bool(res.converged and not on and omega1 == 0.0),
        message=res.message,
        n_evals=res.n_evals,
        wall_time_s=time.perf_counter() - t0,
        names=names,
        x=res.x,
        n_contacts_before=n_before,
        n_contacts_after=n_after,
        n_moved=int(np.any(res.x.reshape(-1, 3) != 0.0, axis=1).sum()),
        limit_stop=not res.converged,
        poll_step=res.poll_step,
        lower=lower,
        upper=upper,
    )


def _num(tab: dict, key: str, default: float, lo: float, hi: float, integer: bool = False) -> float:
    """``tab[key]`` (or ``default``), a number in ``[lo, hi]`` (an integer if ``integer``);
    :class:`SpecError` naming ``forcefield.relax.<key>`` otherwise."""
    v = tab.get(key, default)
    kind = "an integer" if integer else "a number"
    ok = not isinstance(v, bool) and isinstance(v, int if integer else int | float)
    if not ok or not lo <= v <= hi:
        raise SpecError(
            f"forcefield.relax.{key}", f"must be {kind} in [{lo:g}, {hi:g}], got {short(v)}"
        )
    return float(v)


def _weights(options: dict) -> tuple[float, float, float]:
    """``weights``: three finite numbers >= 0, not all zero (as the paper cases' weights; a
    negative weight would reward overlap)."""
    w = options.get("weights", [1e10, 1.0, 1.0])
    ok = isinstance(w, list) and len(w) == 3
    ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in w)
    ok = ok and all(math.isfinite(v) and v >= 0 for v in w) and any(v > 0 for v in w)
    if not ok:
        raise SpecError(
            "forcefield.relax.weights",
            f"must be three finite numbers >= 0, not all zero, got {short(w)}",
        )
    return tuple(float(v) for v in w)


def _search_options(options: dict, dmin: float, period: float) -> dict:
    """The pattern-search keys of ``[forcefield.relax]`` both relax routes share (move bounds in
    box units, penalty weights, iteration and evaluation limits), each checked against its range
    (:class:`SpecError` naming the key)."""
    d = RELAX_SEARCH
    return dict(
        max_shift=_num(options, "max_shift", 0.5 * dmin, 0.0, 0.5 * period) / period,
        u_max=_num(options, "u_max", 0.3, 0.0, 3.0),
        weights=_weights(options),
        # the defaults are RELAX_SEARCH's, the one place they are set (session 42 review)
        search=SearchSettings(
            max_iter=int(_num(options, "max_iter", d.max_iter, 1, 100000, integer=True)),
            max_evals=int(_num(options, "max_evals", d.max_evals, 1, 10**7, integer=True)),
            min_step=_num(options, "min_step", d.min_step, 1e-8, 0.1),
        ),
    )


def check_relax_table(options: object, period: float) -> None:
    """Check a ``[forcefield.relax]`` table before any work (the RVE is not built yet).

    Every key's type and range is checked here but the bounds that need the fibers (``grid``
    and ``gap`` at most the thinnest diameter), which :func:`relax_spec` checks after building.

    Parameters
    ----------
    options
        The table as read from the spec.
    period
        Metres per PS period of the spec's RVE (``rve.period``, else the largest edge).

    Raises
    ------
    SpecError
        One line naming ``forcefield.relax.<key>`` and its allowed range.
    """
    if not isinstance(options, dict):
        raise SpecError("forcefield.relax", "must be a table")
    allowed = RELAX_KEYS | FIELD_ONLY_KEYS
    bad = sorted(set(options) - allowed)
    if bad:
        raise SpecError(f"forcefield.relax.{bad[0]}", f"unknown key; allowed: {sorted(allowed)}")
    _search_options(options, 0.0, period)
    _num(options, "f", 1.0, 1e-3, 100.0)
    if not isinstance(options.get("tie_bend", False), bool):
        raise SpecError(
            "forcefield.relax.tie_bend", f"must be true or false, got {short(options['tie_bend'])}"
        )
    for key in ("grid", "gap"):
        if key in options:
            _num(options, key, 0.0, 0.0 if key == "gap" else 1e-300, period)


def check_relax_route(spec: dict, options: dict) -> None:
    """What the fibers of a validated spec decide, refused before the RVE is built (a
    generator's placement can take minutes): no fibers at all (an ``[image]``), and the
    field-route keys (``grid``, ``gap``, ``tie_bend``) when every fiber is a rod or bent rod
    (explicit ``rod`` / ``bent-rod``, or a ``[generator]``'s), whose centre lines are relaxed.

    Raises
    ------
    SpecError
        Naming ``fibers`` or ``forcefield.relax.<key>``.
    """
    shapes = {fb["shape"] for fb in spec.get("fibers", [])}
    if "generator" in spec:
        shapes.add("rod")  # straight -> rod, bent -> bent-rod: both relaxed as centre lines
    if not shapes:
        raise SpecError("fibers", "the force field relaxes fibers; this spec has none")
    field_only = sorted(set(options) & FIELD_ONLY_KEYS)
    if field_only and shapes <= {"rod", "bent-rod"}:
        raise SpecError(
            f"forcefield.relax.{field_only[0]}",
            "only used for woven / compressed fibers (rods are relaxed by their centre lines)",
        )


def rod_status(res: RelaxResult) -> str:
    """``not_converged`` (a limit stopped the search), ``contact_left`` (stopped with an
    overlap left, also on a bound: session 52), ``at_bound`` (a free variable on its bound,
    no overlap left) or ``converged`` (:func:`psdesign.forcefield.run.search_status`)."""
    from psdesign.forcefield.run import search_status

    return search_status(res.limit_stop, res.at_bound, res.omega_after > 0.0)


def relax_spec(spec: dict, options: dict, out_dir: str | Path) -> dict:
    """Relax the fiber set of a validated RVE spec; write relaxed.toml, rve.json, summary.

    ``options`` is the ``[forcefield.relax]`` table (all optional): ``max_shift`` (metres,
    default 0.5 of the thinnest fiber), ``u_max`` (default 0.3, the paper's bent range),
    ``f`` (waves per period given to straight fibers, default 1), ``weights``,
    ``max_iter``, ``max_evals``, ``min_step``.
    """
    from psdesign.forcefield.run import OUTPUT_FILES, RELAX_UNITS
    from psdesign.io.atomic import staged_directory, write_json
    from psdesign.io.timings import write_record
    from psdesign.packing.build import build_rve, rve_document
    from psdesign.packing.fiberset import FiberState as FS

    allowed = RELAX_KEYS | FIELD_ONLY_KEYS
    bad = sorted(set(options) - allowed)
    if bad:
        raise SpecError(f"forcefield.relax.{bad[0]}", f"unknown key; allowed: {sorted(allowed)}")
    check_relax_route(spec, options)
    built = build_rve(spec)
    rve = built.rve
    if any(fb.shape not in ("rod", "bent-rod") for fb in rve.fibers):
        return relax_spec_fields(spec, rve, options, out_dir)
    fibers = [fb for fb in rve.fibers if fb.shape in ("rod", "bent-rod")]
    if not fibers:
        raise SpecError("fibers", "the force field relaxes rod and bent-rod fibers; none found")
    st = FS.from_fibers(fibers, fixed=False)
    d = st.direction
    given = np.array([fb.theta is not None for fb in fibers])
    # fibers given by a direction: Sec. 7.1 angles of the same axis (rods are round)
    st.theta = np.where(given, st.theta, np.degrees(-np.arcsin(np.clip(d[:, 2], -1, 1))))
    st.omega = np.where(given, st.omega, np.degrees(np.arctan2(d[:, 1], d[:, 0])))
    st.refresh_frames(~given & (st.u == 0.0))
    period = rve.period
    lo, hi = rve.box_normalized
    dmin = float(st.diameter.min()) * period
    kw = _search_options(options, dmin, period)
    kw["f_straight"] = _num(options, "f", 1.0, 1e-3, 100.0)
    res = relax_fibers(st, lo, hi, **kw)
    others = [fb for fb in rve.fibers if fb.shape not in ("rod", "bent-rod")]
    from psdesign.geometry.rve import RVE

    relaxed = RVE(rve.size, others + res.state.to_fibers(), period=period)
    w = kw["weights"]
    pot, err = rod_potential_error(res.state, lo, hi, w)  # one extra analytic_omega each
    start = st_start(st, kw["f_straight"])
    start_err = rod_potential_error(start, lo, hi, w)[1]["U"]
    # +- the last poll's mesh times each range: no compass neighbour that far was better
    poll = res.poll_step if len(res.movable) else 0.0
    summary = {
        "case": "relax",
        "n_fibers": len(st),
        "n_movable": int(len(res.movable)),
        "n_moved": res.n_moved,
        # the objective's Omega with its bar and status (the values are res.omega_before /
        # res.omega_after, the same sums)
        **analytic_omega_keys({"before": start, "after": res.state}, lo, hi),
        "U": res.U_after,
        "U_error": err["U"],
        "potentials": pot.to_dict(),
        "potentials_error": err,
        "start": {"U": res.U_before, "U_error": start_err},
        "n_contacts_before": res.n_contacts_before,
        "n_contacts_after": res.n_contacts_after,
        "converged": res.converged,
        "status": rod_status(res),
        "at_bound": res.at_bound,
        "variables": dict(zip(res.names, (float(v) for v in res.x), strict=True))
        if res.x is not None
        else {},
        "message": res.message,
        "n_evals": res.n_evals,
        "wall_time_s": res.wall_time_s,
        # in the units of "variables" (shifts in periods, u dimensionless)
        "variables_error": poll_bars(res.names, res.lower, res.upper, poll)
        if res.x is not None and res.lower is not None
        else {},
        "free_variables": {"max_shift_m": kw["max_shift"] * period, "u_max": kw["u_max"]},
        "free_variables_error": free_variable_bars(poll, kw, period),
        "surface_term": "bending area",
        "units": RELAX_UNITS,
    }
    with staged_directory(out_dir, replaces=OUTPUT_FILES) as tmp:
        kept = write_record(tmp, "summary.json", summary)  # the wall time beside it
        write_json(tmp / "rve.json", {**rve_document(relaxed), "forcefield": kept})
        (tmp / "relaxed.toml").write_text(relaxed_spec_toml(spec, others, res.state, period))
    return summary


def free_variable_bars(poll_step: float, kw: dict, period: float) -> dict[str, float]:
    """The +- of a relaxation's shift (m) and bend moment: the last poll's mesh times their
    ranges ``[-max_shift, max_shift]`` (periods) and ``[-u_max, u_max]``
    (:func:`psdesign.forcefield.pattern.poll_bars`); both relax routes."""
    s, u = kw["max_shift"] * period, kw["u_max"]
    return poll_bars(("shift_m", "u"), (-s, -u), (s, u), poll_step)


def st_start(st: FiberState, f_straight: float) -> FiberState:
    """The fibers as :func:`relax_fibers` starts from them (straight ones given ``f``)."""
    out = st.copy()
    out.f = np.where(out.u == 0.0, f_straight, out.f)
    return out


def relax_spec_fields(spec: dict, rve, options: dict, out_dir: str | Path) -> dict:
    """The field route of :func:`relax_spec`: any fiber shapes (woven yarns, compressed
    fibers), contacts measured on the fibers' fields (:mod:`psdesign.forcefield.contact`).

    ``options`` as :func:`relax_spec` (``f`` unused) plus ``grid`` (step of the volume term,
    metres, default a fifth of the thinnest fiber), ``gap`` (clearance asked for, metres,
    default the grid step) and ``tie_bend`` (one change of ``|u|`` shared by every fiber
    with a bend term, as Sec. 6.2 ties its woven yarns; default false).
    """
    from psdesign.forcefield.contact import field_summary, relax_rve_fields, relaxed_fibers_toml
    from psdesign.forcefield.run import OUTPUT_FILES
    from psdesign.io.atomic import staged_directory, write_json
    from psdesign.io.timings import write_record
    from psdesign.packing.build import rve_document

    period = float(rve.period)
    dmin = thinnest_fiber_diameter(rve)
    kw = _search_options(options, dmin, period)
    tie = options.get("tie_bend", False)
    if not isinstance(tie, bool):
        raise SpecError("forcefield.relax.tie_bend", f"must be true or false, got {short(tie)}")
    kw["tie_bend"] = tie
    grid = _num(options, "grid", dmin / 5.0, 1e-3 * dmin, dmin) if "grid" in options else None
    gap = _num(options, "gap", 0.0, 0.0, dmin) if "gap" in options else None
    relaxed, res = relax_rve_fields(rve, kw, grid, gap)
    h_m = grid if grid is not None else dmin / 5.0
    summary = field_summary(res, period, kw, h_m)
    text = relaxed_fibers_toml(spec, relaxed.fibers, period)  # before writing: may refuse
    with staged_directory(out_dir, replaces=OUTPUT_FILES) as tmp:
        kept = write_record(tmp, "summary.json", summary)  # the wall time beside it
        write_json(tmp / "rve.json", {**rve_document(relaxed), "forcefield": kept})
        (tmp / "relaxed.toml").write_text(text)
    return summary


def relaxed_spec_toml(spec: dict, others: list, st: FiberState, period: float) -> str:
    """An explicit RVE spec (TOML text) of the relaxed fibers, readable by every command."""
    if others:
        raise SpecError("fibers", "relaxed.toml can hold rod and bent-rod fibers only")
    rv = spec["rve"]
    lines = ["# Fibers relaxed by psdesign forcefield (paper Sec. 6).", "[rve]"]
    lines.append(f"size = [{', '.join(repr(float(v)) for v in rv['size'])}]")
    lines.append(f"voxel = {float(rv['voxel'])!r}")
    lines.append(f"period = {float(period)!r}")
    for i in range(len(st)):
        bent = st.u[i] != 0.0
        lines += ["", "[[fibers]]", f'shape = "{"bent-rod" if bent else st.shape[i]}"']
        lines.append(f"diameter = {float(st.diameter[i] * period)!r}")
        lines.append(f"center = [{', '.join(repr(float(v * period)) for v in st.center[i])}]")
        lines.append(f"theta = {float(st.theta[i])!r}")
        lines.append(f"omega = {float(st.omega[i])!r}")
        if bent:
            lines += [f"u = {float(st.u[i])!r}", f"f = {float(st.f[i])!r}"]
    from psdesign.forcefield.contact import flow_table_lines

    return "\n".join(lines + flow_table_lines(spec)) + "\n"
