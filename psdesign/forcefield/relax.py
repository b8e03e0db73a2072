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

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from psdesign.errors import SpecError
from psdesign.forcefield.pattern import pattern_search
from psdesign.packing.fiberset import FiberState, carrier_lengths, find_contacts
from psdesign.packing.genetic import analytic_omega

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


def bending_area(st: FiberState, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Area added by bending, per fiber: ``pi D L (u f)^2 / 4`` (L: carrier length in box)."""
    return np.pi * st.diameter * carrier_lengths(st, lo, hi) * (st.u * st.f) ** 2 / 4.0


def relax_fibers(
    st: FiberState,
    lo: np.ndarray,
    hi: np.ndarray,
    max_shift: float = 0.05,
    u_max: float = 0.3,
    f_straight: float = 1.0,
    weights=(1e10, 1.0, 1.0),
    max_iter: int = 200,
    max_evals: int = 4000,
    min_step: float = 1e-3,
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
    """
    t0 = time.perf_counter()
    st = st.copy()
    st.f = np.where(st.u == 0.0, f_straight, st.f)
    c = find_contacts(st, lo, hi, 0.0)
    involved = np.unique(np.r_[c.i, c.j]) if len(c) else np.zeros(0, int)
    movable = np.array([k for k in involved if not st.fixed[k]], dtype=np.int64)
    w1, _, w3 = (float(v) for v in weights)
    base_center, base_u = st.center.copy(), st.u.copy()
    frames = st.frames.copy()

    def apply(x: np.ndarray) -> FiberState:
        s = st.copy()
        if len(movable):
            x = x.reshape(len(movable), 3)
            l1, l2 = frames[movable, 1], frames[movable, 2]
            s.center[movable] = base_center[movable] + x[:, :1] * l1 + x[:, 1:2] * l2
            s.u[movable] = base_u[movable] + x[:, 2]
        s.shape = ["bent-rod" if u != 0.0 else sh for u, sh in zip(s.u, s.shape, strict=True)]
        return s

    def energy(x: np.ndarray) -> float:
        s = apply(x)
        return w1 * analytic_omega(s, lo, hi) + w3 * float(bending_area(s, lo, hi).sum())

    x0 = np.zeros(3 * len(movable))
    lower = np.tile([-max_shift, -max_shift, -u_max], len(movable))
    upper = -lower
    omega0 = analytic_omega(st, lo, hi)
    if len(movable) == 0:
        return RelaxResult(st, movable, omega0, omega0, 0.0, 0.0, [], True, "no contacts", 0, 0.0)
    res = pattern_search(
        energy, x0, lower, upper, step=0.25, min_step=min_step, max_iter=max_iter,
        max_evals=max_evals,
    )  # fmt: skip
    from psdesign.forcefield.run import at_bounds

    names = [f"{v}[{k}]" for k in movable for v in ("t1", "t2", "u")]
    on = at_bounds(names, res.x, lower, upper)
    final = apply(res.x)
    return RelaxResult(
        state=final,
        movable=movable,
        omega_before=omega0,
        omega_after=analytic_omega(final, lo, hi),
        U_before=energy(x0),
        U_after=float(res.fun),
        at_bound=on,
        converged=bool(res.converged and not on),
        message=res.message,
        n_evals=res.n_evals,
        wall_time_s=time.perf_counter() - t0,
    )


def _num(tab: dict, key: str, default: float, lo: float, hi: float) -> float:
    v = tab.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int | float) or not lo <= v <= hi:
        raise SpecError(f"forcefield.relax.{key}", f"must be a number in [{lo}, {hi}], got {v!r}")
    return float(v)


def _search_options(options: dict, dmin: float, period: float) -> dict:
    """The pattern-search keys of ``[forcefield.relax]`` both relax routes share (move bounds in
    box units, penalty weights, iteration and evaluation limits), each checked against its range
    (:class:`SpecError` naming the key)."""
    w = options.get("weights", [1e10, 1.0, 1.0])
    if not (isinstance(w, list) and len(w) == 3 and all(isinstance(v, int | float) for v in w)):
        raise SpecError("forcefield.relax.weights", f"must be three numbers, got {w!r}")
    return dict(
        max_shift=_num(options, "max_shift", 0.5 * dmin, 0.0, 0.5 * period) / period,
        u_max=_num(options, "u_max", 0.3, 0.0, 3.0),
        weights=tuple(float(v) for v in w),
        max_iter=int(_num(options, "max_iter", 200, 1, 100000)),
        max_evals=int(_num(options, "max_evals", 4000, 1, 1e7)),
        min_step=_num(options, "min_step", 1e-3, 1e-8, 0.1),
    )


def relax_spec(spec: dict, options: dict, out_dir: str | Path) -> dict:
    """Relax the fiber set of a validated RVE spec; write relaxed.toml, rve.json, summary.

    ``options`` is the ``[forcefield.relax]`` table (all optional): ``max_shift`` (metres,
    default 0.5 of the thinnest fiber), ``u_max`` (default 0.3, the paper's bent range),
    ``f`` (waves per period given to straight fibers, default 1), ``weights``,
    ``max_iter``, ``max_evals``, ``min_step``.
    """
    from psdesign.io.atomic import staged_directory, write_json
    from psdesign.packing.build import build_rve, rve_document
    from psdesign.packing.fiberset import FiberState as FS

    allowed = RELAX_KEYS | FIELD_ONLY_KEYS
    bad = sorted(set(options) - allowed)
    if bad:
        raise SpecError(f"forcefield.relax.{bad[0]}", f"unknown key; allowed: {sorted(allowed)}")
    built = build_rve(spec)
    rve = built.rve
    if any(fb.shape not in ("rod", "bent-rod") for fb in rve.fibers):
        return relax_spec_fields(spec, rve, options, out_dir)
    field_only = sorted(set(options) & FIELD_ONLY_KEYS)
    if field_only:
        raise SpecError(
            f"forcefield.relax.{field_only[0]}",
            "only used for woven / compressed fibers (rods are relaxed by their centre lines)",
        )
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
    summary = {
        "case": "relax",
        "n_fibers": len(st),
        "n_moved": int(len(res.movable)),
        "omega_analytic_before": res.omega_before,
        "omega_analytic_after": res.omega_after,
        "U": res.U_after,
        "start": {"U": res.U_before},
        "converged": res.converged,
        "status": "at_bound"
        if res.at_bound
        else ("converged" if res.converged else "not_converged"),
        "at_bound": res.at_bound,
        "message": res.message,
        "n_evals": res.n_evals,
        "wall_time_s": res.wall_time_s,
        "free_variables": {"max_shift_m": kw["max_shift"] * period, "u_max": kw["u_max"]},
        "surface_term": "bending area",
    }
    with staged_directory(out_dir) as tmp:
        write_json(tmp / "rve.json", {**rve_document(relaxed), "forcefield": summary})
        (tmp / "relaxed.toml").write_text(relaxed_spec_toml(spec, others, res.state, period))
        write_json(tmp / "summary.json", summary)
    return summary


def relax_spec_fields(spec: dict, rve, options: dict, out_dir: str | Path) -> dict:
    """The field route of :func:`relax_spec`: any fiber shapes (woven yarns, compressed
    fibers), contacts measured on the fibers' fields (:mod:`psdesign.forcefield.contact`).

    ``options`` as :func:`relax_spec` (``f`` unused) plus ``grid`` (step of the volume term,
    metres, default a fifth of the thinnest fiber), ``gap`` (clearance asked for, metres,
    default the grid step) and ``tie_bend`` (one change of ``|u|`` shared by every fiber
    with a bend term, as Sec. 6.2 ties its woven yarns; default false).
    """
    from psdesign.forcefield.contact import field_summary, relax_rve_fields, relaxed_fibers_toml
    from psdesign.io.atomic import staged_directory, write_json
    from psdesign.packing.build import rve_document

    period = float(rve.period)
    dmin = min(float(fb.diameter) for fb in rve.fibers) * period
    kw = _search_options(options, dmin, period)
    tie = options.get("tie_bend", False)
    if not isinstance(tie, bool):
        raise SpecError("forcefield.relax.tie_bend", f"must be true or false, got {tie!r}")
    kw["tie_bend"] = tie
    grid = _num(options, "grid", dmin / 5.0, 1e-3 * dmin, dmin) if "grid" in options else None
    gap = _num(options, "gap", 0.0, 0.0, dmin) if "gap" in options else None
    relaxed, res = relax_rve_fields(rve, kw, grid, gap)
    h_m = grid if grid is not None else dmin / 5.0
    summary = field_summary(res, period, kw, h_m)
    text = relaxed_fibers_toml(spec, relaxed.fibers, period)  # before writing: may refuse
    with staged_directory(out_dir) as tmp:
        write_json(tmp / "rve.json", {**rve_document(relaxed), "forcefield": summary})
        (tmp / "relaxed.toml").write_text(text)
        write_json(tmp / "summary.json", summary)
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
