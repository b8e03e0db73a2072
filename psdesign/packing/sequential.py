"""``fast`` intersection removal: sequential zero-overlap placement on the shift torus (Sec. 7.1).

Fibers are placed one after the other. A fiber stays where it was drawn if its centre lines clear
every placed fiber by ``(D_i + D_j) / 2 + gap``; otherwise it moves by the smallest shift in its
lattice plane that clears them. Those shifts form a torus (a shift by a lattice vector maps the
fiber onto itself), and projected along the fiber axis every placed centre-line piece forbids an
exact capsule of shifts; the capsules are rasterized on a grid of the torus (numba), so one fiber
costs O(pieces), not a search. Bent fibers use capsules dilated by the sway of their axis, and may
also move their bend phase. A fiber that fits nowhere tries a few re-orientations and then ejects
the fewest placed fibers blocking a position (they are re-queued). Because the rod cross-section
of Eq. (4) lies inside the circle of the nominal diameter (and a bent rod's slices are shifted rod
sections), this separation guarantees that no voxel centre is inside two fibers: Omega on the
voxel grid is exactly 0.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field

import numba
import numpy as np

import solvers.jit  # noqa: F401  (numba cache stamps cover the imported modules)
from psdesign.packing.fiberset import (
    MIN_PIECE_DIAMETERS,
    FiberState,
    Pieces,
    carrier_lengths,
    pieces_for,
)
from psdesign.packing.placement_settings import DEFAULT_STEP_DIAMETERS, PlacementSettings


# ------------------------------------------------------------------ fast method
@dataclass
class PlacementResult:
    """Outcome of :func:`place_sequential`.

    Attributes
    ----------
    state : FiberState
        The placed fibers (rejected ones removed).
    placed : ndarray of int
        Indices (into the input state) of the fibers kept, in order.
    rejected : ndarray of int
        Indices of fibers for which no free position was found.
    shift : ndarray (n_placed, 3)
        Translation applied to each kept fiber (normalized).
    rotation_deg : ndarray (n_placed,)
        Angle between the drawn and the final direction of each kept fiber.
    candidates_tested : int
    wall_time_s : float
    exceeded : ndarray of int
        Indices (into the input state) of the kept fibers that found no place within the
        move bounds (``max_shift``) and were moved further (nearest free shift).
    """

    state: FiberState
    placed: np.ndarray
    rejected: np.ndarray
    shift: np.ndarray
    rotation_deg: np.ndarray
    candidates_tested: int
    wall_time_s: float
    solid: float = 0.0
    reached_stop: bool = False
    n_ejections: int = 0
    exceeded: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


def torus_offsets(step: float) -> np.ndarray:
    """Lattice-plane shifts (t1, t2) in [-1/2, 1/2)^2 on a grid, nearest to 0 first."""
    k = max(2, int(np.ceil(1.0 / step)))
    g = (np.arange(k) - k // 2) / k
    T = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    return T[np.argsort(np.hypot(T[:, 0], T[:, 1]), kind="stable")]


@numba.njit(cache=True)
def _mark_capsules(free, A, B, lim):  # pragma: no cover - compiled
    """Clear the grid points (periodic, grid units) closer than lim[m] to segment A[m]B[m].

    A bent fiber's search brings ~20 000 capsules onto a 35 x 35 torus (each point under
    ~1 300 of them), so most of the work was re-testing cleared points: rows with no free
    point left are skipped, cleared points are not tested again, and the loop stops once
    nothing is free. The test itself is unchanged, so the result is the same bit for bit.
    """
    k = free.shape[0]
    half = k // 2
    row_free = np.zeros(k, np.int64)
    for ii in range(k):
        for jj in range(k):
            row_free[ii] += free[ii, jj]
    n_free = row_free.sum()
    for m in range(A.shape[0]):
        if n_free == 0:
            return
        ax, ay, bx, by, r = A[m, 0], A[m, 1], B[m, 0], B[m, 1], lim[m]
        ex, ey = bx - ax, by - ay
        L2 = max(ex * ex + ey * ey, 1e-30)
        i0 = int(np.floor(min(ax, bx) - r))
        i1 = int(np.ceil(max(ax, bx) + r))
        j0 = int(np.floor(min(ay, by) - r))
        j1 = int(np.ceil(max(ay, by) + r))
        for i in range(i0, i1 + 1):
            ii = (i + half) % k
            if row_free[ii] == 0:
                continue
            px = i - ax
            for j in range(j0, j1 + 1):
                jj = (j + half) % k
                if not free[ii, jj]:
                    continue
                py = j - ay
                t = (px * ex + py * ey) / L2
                t = min(1.0, max(0.0, t))
                dx = px - t * ex
                dy = py - t * ey
                if dx * dx + dy * dy < r * r:
                    free[ii, jj] = False
                    row_free[ii] -= 1
                    n_free -= 1


def _bent_capsules(trial: FiberState, old: Pieces, A, B, lim):
    """Capsules (projected plane) that hold every shift bringing a bent fiber within lim.

    The new axis sits at ``w(s) l1`` off its carrier (``w = -u cos(2 pi f (s + 1/2) + phase)
    / (2 pi)``). For an old piece spanning axial range [s_min, s_max] (measured along the
    new axis), a contact at new-axis parameter s needs ``(s - s_y)^2 + r^2 < lim^2``. The
    window ``[s_min - lim, s_max + lim]`` is cut into short sub-intervals; on each, the
    in-plane radius is at most ``sqrt(lim^2 - g^2)`` (g: axial gap to the piece) and w
    varies within [w_lo, w_hi], giving one capsule shifted by ``-(w_lo + w_hi)/2`` and
    grown by ``(w_hi - w_lo)/2``. The union over-covers the exact forbidden set (safe).

    A sub-interval is a twelfth of a bend, but no shorter than :data:`MIN_PIECE_DIAMETERS`
    of the fiber's diameter (as the pieces are): the floor binds only where ``f > 16 / (3 D)``
    (in periods), never for the generator's ``f <= 10`` at ``D < 0.5``; a longer sub-interval
    grows its capsule by at most the whole amplitude ``|u| / (2 pi) <= 10 / (2 pi f)`` (under
    0.3 D where the floor binds, 0.01 D at f = 1000 and D = 0.16). Without it that f cut each
    old piece's window into 3 947 capsules (132 now), 1.8 M per fiber, and a placement of 6
    fibers in a 50 um box ran past 300 s (session 37 edge audit, ``bent_fast_f_max``).
    """
    c, d = trial.center[0], trial.frames[0, 0]
    u, f, ph = float(trial.u[0]), float(trial.f[0]), float(trial.phase[0])
    sa, sb = (old.a - c) @ d, (old.b - c) @ d
    smin, smax = np.minimum(sa, sb), np.maximum(sa, sb)
    floor = MIN_PIECE_DIAMETERS * float(trial.diameter[0])
    width = min(0.5 * float(lim.min()), max(1.0 / (12.0 * f), floor))
    return _bent_capsule_rows(smin, smax, lim, A, B, old.fiber.astype(np.int64), u, f, ph, width)


@numba.njit(cache=True)
def _bent_capsule_rows(smin, smax, lim, A, B, fiber, u, f, ph, width):  # pragma: no cover
    """The sub-interval capsules of :func:`_bent_capsules`, one loop per old piece (a numpy
    version built ~20 arrays of ~20 000 rows per call: 40 % of a bent placement); every
    value is computed by the same operations in the same order, so bit for bit the same."""
    n = smin.shape[0]
    m = np.empty(n, np.int64)
    total = 0
    for p in range(n):
        m[p] = max(1, np.int64(np.ceil((smax[p] - smin[p] + 2 * lim[p]) / width)))
        total += m[p]
    A2 = np.empty((total, 2))
    B2 = np.empty((total, 2))
    R = np.empty(total)
    owner = np.empty(total, np.int64)
    tp = 2 * np.pi
    tpf = tp * f
    q = 0
    for p in range(n):
        h = (smax[p] - smin[p] + 2 * lim[p]) / m[p]
        for j in range(m[p]):
            s0 = smin[p] - lim[p] + j * h
            s1 = s0 + h
            g = max(0.0, max(s0 - smax[p], smin[p] - s1))
            if not g < lim[p]:
                continue
            r2 = lim[p] ** 2 - g**2
            r = np.sqrt(r2 if r2 > 0.0 else 0.0)
            th0 = tpf * (s0 + 0.5) + ph
            th1 = tpf * (s1 + 0.5) + ph
            c0, c1 = np.cos(th0), np.cos(th1)
            if np.floor(th1 / tp) >= np.ceil(th0 / tp):
                cmax = 1.0
            else:
                cmax = max(c0, c1)
            if np.floor((th1 - np.pi) / tp) >= np.ceil((th0 - np.pi) / tp):
                cmin = -1.0
            else:
                cmin = min(c0, c1)
            w1, w2 = -u * cmax / tp, -u * cmin / tp
            wlo, whi = min(w1, w2), max(w1, w2)
            shift = 0.5 * (wlo + whi)
            A2[q, 0], A2[q, 1] = A[p, 0] - shift, A[p, 1]
            B2[q, 0], B2[q, 1] = B[p, 0] - shift, B[p, 1]
            R[q] = r + 0.5 * (whi - wlo)
            owner[q] = fiber[p]
            q += 1
    return A2[:q], B2[:q], R[:q], owner[:q]


def _capsules(trial: FiberState, old: Pieces, old_d: np.ndarray, gap: float):
    """Forbidden-shift capsules (A, B, radius, owning fiber) in lattice coordinates."""
    c = trial.center[0]
    l1, l2 = trial.frames[0, 1], trial.frames[0, 2]
    A = np.column_stack([(old.a - c) @ l1, (old.a - c) @ l2])
    B = np.column_stack([(old.b - c) @ l1, (old.b - c) @ l2])
    lim = 0.5 * (trial.diameter[0] + old_d[old.fiber]) + gap + old.sag
    if float(trial.u[0]) != 0.0:
        return _bent_capsules(trial, old, A, B, lim)
    return A, B, lim, old.fiber


def _free_shift_raster(
    trial: FiberState, old: Pieces | None, old_d: np.ndarray, gap: float, k: int
) -> np.ndarray:
    """Boolean (k, k) grid of lattice-plane shifts of a straight fiber that clear ``old``.

    Grid cell (i, j) is the shift ``((i - k//2)/k) l1 + ((j - k//2)/k) l2``. A straight
    line is within ``limit`` of a segment iff, projected along the line direction onto
    the (l1, l2) plane, the shift lies within ``limit`` of the projected segment; so each
    old piece forbids a capsule, marked exactly at the grid points of a window around it
    (periodic in both lattice coordinates).
    """
    free = np.ones((k, k), bool)
    if old is None or len(old.fiber) == 0:
        return free
    A, B, lim, _ = _capsules(trial, old, old_d, gap)
    A, B, lim = A * k, B * k, lim * k  # grid units
    _mark_capsules(free, A, B, lim)
    return free


def place_sequential(
    st: FiberState,
    lo: np.ndarray,
    hi: np.ndarray,
    settings: PlacementSettings | None = None,
    *,
    seed: int = 0,
    area: np.ndarray | None = None,
    stop_solid: float | None = None,
) -> PlacementResult:
    """Intersection-free fibers by sequential minimal shifts on the lattice torus.

    Fibers are taken in order; fixed fibers are obstacles from the start. Each movable
    fiber is kept where it was drawn if it clears every fiber already placed by
    ``(D_i + D_j)/2 + gap``; otherwise it is translated by the smallest shift
    ``t1 l1 + t2 l2`` in its lattice plane (l1, l2: the unit lattice vectors of its
    periodic copies, so the shifts form a torus ``[-1/2, 1/2)^2`` and cover every distinct
    position) that clears them. The free shifts are found on a grid of the torus by
    projecting every placed centre-line piece along the new fiber's axis: a straight line
    is within ``limit`` of a segment iff the shift lies in the projected segment's capsule
    (bent fibers: dilated by the sway of their axis), so each piece marks an exact capsule
    of forbidden grid points; the free grid point nearest to the drawn position is taken.
    Bent fibers also try moving their bend phase by quarter wavelengths.
    Orientations are unchanged unless no shift works, in which case up to
    ``orientation_tries`` random re-orientations within ``+-max_rotation_deg`` are tried.

    Parameters
    ----------
    st : FiberState
        Drawn fibers (not modified).
    lo, hi : ndarray (3,)
        The box (normalized).
    settings : PlacementSettings, optional
        Gap, search grid, move bounds, re-orientations, ejections and stop rules (default:
        ``PlacementSettings()``).
    seed : int
        Seed of the random re-orientations (same seed, same result).
    area, stop_solid : optional
        Cross-section area of each fiber (normalized); placement stops once the placed
        solid ``sum(area_i * carrier length_i in box) / box volume`` reaches ``stop_solid``.
    """
    opts = PlacementSettings() if settings is None else settings
    t0 = time.perf_counter()
    if len(st) == 0:
        return PlacementResult(
            st.copy(), np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3)), np.zeros(0), 0, 0.0
        )
    placer = _Placer(st, lo, hi, opts, seed, area, stop_solid)
    placer.run()
    return placer.result(time.perf_counter() - t0)


class _Placer:
    """The state of one sequential placement: placed pieces, queue, budgets, counters."""

    def __init__(
        self,
        st: FiberState,
        lo,
        hi,
        opts: PlacementSettings,
        seed: int,
        area: np.ndarray | None,
        stop_solid: float | None,
    ):
        self.st, self.lo, self.hi, self.opts = st, lo, hi, opts
        self.area, self.stop_solid = area, stop_solid
        self.rng = np.random.default_rng(seed)
        n = len(st)
        step = DEFAULT_STEP_DIAMETERS * float(st.diameter.min()) if opts.step is None else opts.step
        self.T = torus_offsets(step)
        self.k_grid = max(2, int(np.ceil(1.0 / step)))
        self.tidx = (
            np.round(self.T * self.k_grid).astype(np.int64) + self.k_grid // 2
        ) % self.k_grid
        cut = float(st.diameter.max()) + max(opts.gap, 0.0)
        self.piece = max(0.5 * cut, 0.005)
        self.out = st.copy()
        self.old: Pieces | None = None
        self.tested = 0
        self.box_volume = float(np.prod(hi - lo))
        # along an edge shorter than one period the box holds only part of the lattice torus:
        # a shift that moves a fiber's centre out there can take it out of the box altogether
        short = (np.asarray(hi, float) - np.asarray(lo, float)) < 1.0 - 1e-9
        self.keep = (np.asarray(lo, float), np.asarray(hi, float), short) if short.any() else None
        self.placed: list[int] = []
        self.rejected: list[int] = []
        self.contrib: dict[int, float] = {}
        self.ejected = np.zeros(n, np.int64)
        self.ejected_in_bounds = np.zeros(n, np.int64)
        self.exceeded: set[int] = set()
        self.stopped = False

    def bounds(self, bounded: bool):
        return (self.opts.max_shift_z, self.opts.max_shift if bounded else None, self.keep)

    def add_old(self, idx) -> None:
        idx = np.atleast_1d(idx)
        pc = pieces_for(self.out.subset(idx), self.lo, self.hi, self.opts.gap, self.piece)
        pc.fiber = idx[pc.fiber]
        if self.area is not None:
            lengths = carrier_lengths(self.out.subset(idx), self.lo, self.hi)
            share = self.area[idx] * lengths / self.box_volume
            for k, v in zip(idx, share, strict=True):
                self.contrib[int(k)] = float(v)
        self.old = pc if self.old is None else _concat_pieces(self.old, pc)

    def remove_old(self, idx: np.ndarray) -> None:
        old = self.old
        keep = ~np.isin(old.fiber, idx)
        self.old = Pieces(
            a=old.a[keep],
            b=old.b[keep],
            fiber=old.fiber[keep],
            copy=old.copy[keep],
            sag=old.sag[keep],
            s_mid=old.s_mid[keep],
            copy_len=old.copy_len,
            copy_fiber=old.copy_fiber,
        )
        for k in idx:
            self.contrib.pop(int(k), None)
            self.placed.remove(int(k))

    def accept(self, i: int, c_new: np.ndarray, trial: FiberState) -> None:
        out = self.out
        out.center[i] = c_new
        out.theta[i], out.omega[i] = trial.theta[0], trial.omega[0]
        out.frames[i] = trial.frames[0]
        self.placed.append(i)
        self.add_old(i)

    def tries(self, base: FiberState, bounded: bool) -> list:
        """The drawn orientation (bent fibers also with their bend phase moved by quarter
        wavelengths along the axis), then random re-orientations within the pass's range."""
        tries0 = [(0.0, 0.0, 0.0)]
        if base.u[0] != 0.0:
            tries0 += [(0.0, 0.0, q / base.f[0]) for q in (0.25, 0.5, 0.75)]
        o = self.opts
        lim = o.max_rotation_deg if bounded else max(o.max_rotation_deg, o.exceed_rotation_deg)
        if lim <= 0:
            return tries0
        return tries0 + [
            (self.rng.uniform(-lim, lim), self.rng.uniform(-lim, lim), 0.0)
            for _ in range(o.orientation_tries)
        ]

    def place_one(self, i: int, queue: deque):
        """A position for fiber ``i`` (``(centre, trial)``) or None; may eject blockers."""
        o = self.opts
        base = self.st.subset([i])
        bounded_pass = o.exceed and (o.max_shift is not None or o.exceed_rotation_deg)
        passes = [True, False] if bounded_pass else [True]
        for bounded in passes:
            found, n_tried = _search(
                self.tries(base, bounded),
                base,
                self.old,
                self.out.diameter,
                o.gap,
                self.T,
                self.k_grid,
                self.tidx,
                self.bounds(bounded),
            )
            self.tested += len(self.T) * n_tried
            # eject the fewest placed fibers that block a position (they are re-queued);
            # ejections within the bounds have their own budget (half), so they never use up
            # the last pass's
            last = bounded == passes[-1]
            count = self.ejected if last else self.ejected_in_bounds
            budget = o.max_ejections if last else o.max_ejections // 2
            if found is None and budget > 0:
                c_new, blockers = _least_blocked(
                    base,
                    self.old,
                    self.out.diameter,
                    self.st.fixed,
                    o.gap,
                    self.T,
                    self.bounds(bounded),
                    self.k_grid,
                    self.tidx,
                )
                if c_new is not None and np.all(count[blockers] < budget):
                    count[blockers] += 1
                    self.remove_old(blockers)
                    queue.extendleft(int(b) for b in blockers[::-1])
                    found = (c_new, base)
            if found is not None:
                if not bounded:
                    self.exceeded.add(i)
                else:
                    self.exceeded.discard(i)
                return found
        return None

    def run(self) -> None:
        o, st = self.opts, self.st
        fixed_idx = np.flatnonzero(st.fixed)
        if len(fixed_idx):
            self.placed.extend(int(k) for k in fixed_idx)
            self.add_old(fixed_idx)
        queue = deque(int(k) for k in np.flatnonzero(~st.fixed))
        streak = 0
        report = _placement_progress(len(queue), self.stop_solid)
        track = report is not None or self.stop_solid is not None
        while queue:
            solid = sum(self.contrib.values()) if track else 0.0  # once for both uses
            if report is not None:
                report(len(self.placed) - len(fixed_idx), solid)
            if self.stop_solid is not None and solid >= self.stop_solid:
                self.stopped = True
                break
            if o.max_consecutive_rejects is not None and streak >= o.max_consecutive_rejects:
                break
            i = queue.popleft()
            found = self.place_one(i, queue)
            if found is None:
                self.rejected.append(i)
                streak += 1
                if o.on_reject == "raise":
                    break
                continue
            streak = 0
            self.accept(i, *found)

    def result(self, wall_time_s: float) -> PlacementResult:
        st, stop_solid = self.st, self.stop_solid
        keep = np.array(self.placed, dtype=np.int64)
        final = self.out.subset(keep)
        cosang = np.abs(np.einsum("ij,ij->i", final.direction, st.direction[keep]))
        solid = sum(self.contrib.values())
        placed = set(self.placed)
        return PlacementResult(
            state=final,
            placed=keep,
            rejected=np.array(self.rejected, dtype=np.int64),
            shift=final.center - st.center[keep],
            rotation_deg=np.degrees(np.arccos(np.clip(cosang, 0.0, 1.0))),
            candidates_tested=self.tested,
            wall_time_s=wall_time_s,
            solid=solid,
            reached_stop=self.stopped or (stop_solid is not None and solid >= stop_solid),
            n_ejections=int(self.ejected.sum() + self.ejected_in_bounds.sum()),
            exceeded=np.array(sorted(k for k in self.exceeded if k in placed), dtype=np.int64),
        )


def _placement_progress(n_fibers: int, stop_solid: float | None):
    """Throttled progress of a placement on the command's printer (None without one):
    ``psdesign: fiber placement: N placed, solid fraction S of GOAL, T s`` (``N of M placed``
    without a solid goal)."""
    from psdesign import progress

    if stop_solid is None:
        return progress.throttled(
            lambda s, n, solid: f"psdesign: fiber placement: {n} of {n_fibers} placed, {s:.0f} s"
        )
    return progress.throttled(
        lambda s, n, solid: (
            f"psdesign: fiber placement: {n} placed, solid fraction {solid:.3f} of "
            f"{stop_solid:.3f}, {s:.0f} s"
        )
    )


def _allowed(T: np.ndarray, l1: np.ndarray, l2: np.ndarray, limits, c0: np.ndarray) -> np.ndarray:
    """Shifts of ``T`` within the move bounds ``limits = (max_shift_z, max_shift, keep)``.

    ``keep = (lo, hi, short)`` (or None): along the box edges shorter than one period
    (``short``) the shifted centre ``c0 + t1 l1 + t2 l2`` must stay inside ``[lo, hi]`` (or
    no further out than the drawn centre ``c0``). There the box holds only part of the
    lattice torus, and the nearest free shift was often one that moved the fiber out of the
    box: it then counted as placed but added no solid (a 100 x 100 x 50 um box at porosity
    0.85 ran out of fibers with 17 of its first 40 outside).
    """
    max_z, max_len, keep = limits
    ok = np.ones(len(T), bool)
    if max_z is not None:
        ok &= np.abs(T[:, 0] * l1[2] + T[:, 1] * l2[2]) <= max_z + 1e-12
    if max_len is not None:
        ok &= np.hypot(T[:, 0], T[:, 1]) <= max_len + 1e-12
    if keep is not None:
        lo, hi, short = keep
        c = c0 + T[:, :1] * l1 + T[:, 1:] * l2
        inside = (c >= np.minimum(lo, c0) - 1e-12) & (c <= np.maximum(hi, c0) + 1e-12)
        ok &= np.all(inside | ~short, axis=1)
    return ok


def _search(tries, base: FiberState, old, old_d, gap, T, k_grid, tidx, limits):
    """First (orientation try, nearest allowed free shift) that clears ``old`` (or None), and
    the number of tries used."""
    for n_tried, (dth, dom, ds) in enumerate(tries, start=1):
        trial = base.copy()
        if dth or dom:
            trial.theta += dth
            trial.omega += dom
            trial.refresh_frames()
        trial.center[0] += ds * trial.frames[0, 0]
        l1, l2 = trial.frames[0, 1], trial.frames[0, 2]
        free = _free_shift_raster(trial, old, old_d, gap, k_grid)
        ok = free[tidx[:, 0], tidx[:, 1]] & _allowed(T, l1, l2, limits, base.center[0])
        if np.any(ok):
            k = int(np.argmax(ok))
            return (trial.center[0] + T[k, 0] * l1 + T[k, 1] * l2, trial), n_tried
    return None, len(tries)


def _concat_pieces(p: Pieces, q: Pieces) -> Pieces:
    return Pieces(
        a=np.r_[p.a, q.a],
        b=np.r_[p.b, q.b],
        fiber=np.r_[p.fiber, q.fiber],
        copy=np.r_[p.copy, q.copy],
        sag=np.r_[p.sag, q.sag],
        s_mid=np.r_[p.s_mid, q.s_mid],
        copy_len=p.copy_len,
        copy_fiber=p.copy_fiber,
    )


def _least_blocked(
    trial: FiberState,
    old: Pieces | None,
    old_d: np.ndarray,
    fixed: np.ndarray,
    gap: float,
    T: np.ndarray,
    limits,
    k: int,
    tidx,
):
    """Shift (nearest first) blocked by the fewest movable fibers, and those fibers.

    Returns ``(None, None)`` if every shift is blocked by a fixed fiber.
    """
    if old is None or len(old.fiber) == 0:
        return None, None
    c = trial.center[0]
    l1, l2 = trial.frames[0, 1], trial.frames[0, 2]
    A, B, lim, owner = _capsules(trial, old, old_d, gap)
    count = np.zeros((k, k), np.int64)
    stamp = np.full((k, k), -1, np.int64)
    weight = np.where(fixed[owner], 1 << 30, 1).astype(np.int64)
    _count_capsules(count, stamp, A * k, B * k, lim * k, owner.astype(np.int64), weight)
    cnt = count[tidx[:, 0], tidx[:, 1]]
    cnt = np.where(_allowed(T, l1, l2, limits, c), cnt, np.iinfo(np.int64).max)
    j = int(np.argmin(cnt))  # first minimum = nearest
    if cnt[j] >= 1 << 30:
        return None, None
    hit = _capsule_hits(T[j], A, B, lim)
    fibers = np.unique(owner[hit])
    if np.any(fixed[fibers]):
        return None, None
    return c + T[j, 0] * l1 + T[j, 1] * l2, fibers


@numba.njit(cache=True)
def _count_capsules(count, stamp, A, B, lim, owner, weight):  # pragma: no cover - compiled
    """Per grid point, the (weighted) number of distinct owners whose capsules contain it.

    Capsules of one owner must be contiguous; ``stamp`` remembers the last owner counted.
    """
    k = count.shape[0]
    half = k // 2
    for m in range(A.shape[0]):
        ax, ay, bx, by, r = A[m, 0], A[m, 1], B[m, 0], B[m, 1], lim[m]
        ex, ey = bx - ax, by - ay
        L2 = max(ex * ex + ey * ey, 1e-30)
        for i in range(int(np.floor(min(ax, bx) - r)), int(np.ceil(max(ax, bx) + r)) + 1):
            px = i - ax
            for j in range(int(np.floor(min(ay, by) - r)), int(np.ceil(max(ay, by) + r)) + 1):
                py = j - ay
                t = min(1.0, max(0.0, (px * ex + py * ey) / L2))
                dx = px - t * ex
                dy = py - t * ey
                if dx * dx + dy * dy < r * r:
                    ii = (i + half) % k
                    jj = (j + half) % k
                    if stamp[ii, jj] != owner[m]:
                        stamp[ii, jj] = owner[m]
                        count[ii, jj] += weight[m]


def _capsule_hits(t: np.ndarray, A, B, lim) -> np.ndarray:
    """Capsules (segments A-B grown by lim, periodic with period 1) that contain point t."""
    ab = B - A
    L2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30)
    # nearest periodic image of t to each capsule's midpoint
    mid = 0.5 * (A + B)
    tt = t + np.round(mid - t)
    p = tt - A
    s = np.clip(np.einsum("ij,ij->i", p, ab) / L2, 0.0, 1.0)
    d = p - s[:, None] * ab
    return np.einsum("ij,ij->i", d, d) < lim * lim
