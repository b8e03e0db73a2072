"""Intersection removal for random fiber sets (paper Sec. 7.1, Eq. 8-9).

Both methods work on a :class:`FiberState` (arrays of the Sec. 7.1 placement parameters,
normalized lengths, one PS period = 1). A PS fiber is the periodic family of its lattice
copies (one line per period^2 perpendicular to its axis); its centre-line copies are
clipped to the box, grown by the contact distance, so every overlap inside the box is seen.

``fast`` (:func:`place_sequential`)
    Fibers are placed one after the other. A fiber stays where it was drawn if its centre
    lines clear every placed fiber by ``(D_i + D_j) / 2 + gap``; otherwise it moves by the
    smallest shift in its lattice plane that clears them. Those shifts form a torus (a
    shift by a lattice vector maps the fiber onto itself), and projected along the fiber
    axis every placed centre-line piece forbids an exact capsule of shifts; the capsules
    are rasterized on a grid of the torus (numba), so one fiber costs O(pieces), not a
    search. Bent fibers use capsules dilated by the sway of their axis, and may also move
    their bend phase. A fiber that fits nowhere tries a few re-orientations and then
    ejects the fewest placed fibers blocking a position (they are re-queued). Because the
    rod cross-section of Eq. (4) lies inside the circle of the nominal diameter (and a
    bent rod's slices are shifted rod sections), this separation guarantees that no
    voxel centre is inside two fibers: Omega on the voxel grid is exactly 0.

``ga`` (:func:`genetic`)
    The paper's genetic algorithm over the adjustment ranges of Sec. 7.1 (theta and omega
    +-1 deg, translations +-0.1 of the RVE edge, u in [0.1, 0.3] and f in [1, 10] for bent
    fibers). The objective is Omega: either an analytic estimate from the centre lines
    (pairwise crossing volume ``int w_i(z) w_j(z) dz / sin(alpha)`` of two cylinders at
    axis distance d and angle alpha), or the voxel count of Eq. (8) on a coarse grid
    (``objective="voxel"``, as the paper).
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field, replace

import numba
import numpy as np
from scipy.spatial import cKDTree

from psdesign.geometry.fibers import Fiber, make_fiber

_TO_X = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # rotation z -> x
_EZ = np.array([0.0, 0.0, 1.0])
#: Points per unit length (times f) used to resolve a bent medial axis.
BENT_SAMPLES_PER_WAVE = 8


# ------------------------------------------------------------------------ state
@dataclass
class FiberState:
    """Sec. 7.1 parameters of a fiber set (normalized lengths, angles in degrees).

    Attributes
    ----------
    diameter : ndarray (n,)
    center : ndarray (n, 3)
    theta, omega : ndarray (n,)
        Rotation about y, then about z (degrees) of a fiber that starts along x.
    u, f : ndarray (n,)
        Bend moment and scale (u = 0: straight rod).
    fixed : ndarray of bool (n,)
        Fibers that the optimizers must not move (explicit fibers).
    frames : ndarray (n, 3, 3), optional
        Rows (direction, lattice1 = bend direction, lattice2). Recomputed from theta and
        omega for movable fibers; kept as given for fixed ones.
    phase : ndarray (n,)
        Bend phase offset of the medial axis (0 for generated fibers).
    shape : list of str
        Fiber shape names (``rod``, ``bent-rod`` or ``cylinder``).
    """

    diameter: np.ndarray
    center: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    u: np.ndarray
    f: np.ndarray
    fixed: np.ndarray
    frames: np.ndarray | None = None
    phase: np.ndarray | None = None
    shape: list = field(default_factory=list)

    def __post_init__(self) -> None:
        n = len(self.diameter)
        self.diameter = np.asarray(self.diameter, float).reshape(n)
        self.center = np.asarray(self.center, float).reshape(n, 3)
        for k in ("theta", "omega", "u", "f"):
            setattr(self, k, np.asarray(getattr(self, k), float).reshape(n))
        self.fixed = np.asarray(self.fixed, bool).reshape(n)
        if self.phase is None:
            self.phase = np.zeros(n)
        if not self.shape:
            self.shape = ["bent-rod" if u != 0 else "rod" for u in self.u]
        if self.frames is None:
            self.frames = np.zeros((n, 3, 3))
            self.refresh_frames(np.ones(n, bool))

    def __len__(self) -> int:
        return len(self.diameter)

    def copy(self) -> FiberState:
        return replace(
            self,
            diameter=self.diameter.copy(),
            center=self.center.copy(),
            theta=self.theta.copy(),
            omega=self.omega.copy(),
            u=self.u.copy(),
            f=self.f.copy(),
            fixed=self.fixed.copy(),
            frames=self.frames.copy(),
            phase=self.phase.copy(),
            shape=list(self.shape),
        )

    def refresh_frames(self, mask: np.ndarray | None = None) -> None:
        """Recompute (direction, lattice1, lattice2) from theta, omega (movable fibers)."""
        mask = ~self.fixed if mask is None else mask
        if not np.any(mask):
            return
        th, om = np.radians(self.theta[mask]), np.radians(self.omega[mask])
        ct, st, co, so = np.cos(th), np.sin(th), np.cos(om), np.sin(om)
        z, o = np.zeros_like(th), np.ones_like(th)
        ry = np.stack(
            [np.stack([ct, z, st], -1), np.stack([z, o, z], -1), np.stack([-st, z, ct], -1)], -2
        )
        rz = np.stack(
            [np.stack([co, -so, z], -1), np.stack([so, co, z], -1), np.stack([z, z, o], -1)], -2
        )
        m = rz @ ry @ _TO_X  # placement rotation of a canonical (z-axis) fiber
        self.frames[mask] = np.swapaxes(m, 1, 2)[:, [2, 0, 1], :]  # rows: M z, M x, M y

    @property
    def direction(self) -> np.ndarray:
        return self.frames[:, 0]

    @property
    def amplitude(self) -> np.ndarray:
        """Largest medial-axis offset from the carrier axis, ``|u| / (2 pi)``."""
        return np.abs(self.u) / (2.0 * np.pi)

    def wrap_centers(self, mid: np.ndarray) -> None:
        """Move each centre by whole lattice vectors towards ``mid`` (geometry unchanged)."""
        rel = self.center - mid
        for k in (1, 2):
            lat = self.frames[:, k]
            self.center -= np.round(np.einsum("ij,ij->i", rel, lat))[:, None] * lat
            rel = self.center - mid

    # ------------------------------------------------------------ conversion
    @classmethod
    def from_fibers(cls, fibers: list[Fiber], fixed: bool = True) -> FiberState:
        """State of existing fibers (rod, cylinder or bent-rod shapes)."""
        n = len(fibers)
        frames = np.array([[fb.direction, fb.lattice[0], fb.lattice[1]] for fb in fibers])
        return cls(
            diameter=np.array([fb.diameter for fb in fibers]),
            center=np.array([fb.center for fb in fibers]).reshape(n, 3),
            theta=np.array([fb.theta or 0.0 for fb in fibers]),
            omega=np.array([fb.omega or 0.0 for fb in fibers]),
            u=np.array([fb.u if fb.shape != "cylinder" else 0.0 for fb in fibers]),
            f=np.array([fb.f for fb in fibers]),
            fixed=np.full(n, fixed),
            frames=frames.reshape(n, 3, 3),
            phase=np.array([fb.extra.get("phase", 0.0) for fb in fibers]),
            shape=[fb.shape for fb in fibers],
        )

    def to_fibers(self) -> list[Fiber]:
        """Placed :class:`Fiber` objects (movable fibers via :func:`make_fiber`)."""
        out = []
        for i in range(len(self)):
            out.append(
                make_fiber(
                    self.shape[i],
                    float(self.diameter[i]),
                    center=self.center[i],
                    theta=float(self.theta[i]),
                    omega=float(self.omega[i]),
                    u=float(self.u[i]),
                    f=float(self.f[i]),
                )
            )
        return out

    @staticmethod
    def concat(a: FiberState, b: FiberState) -> FiberState:
        return FiberState(
            diameter=np.r_[a.diameter, b.diameter],
            center=np.r_[a.center, b.center],
            theta=np.r_[a.theta, b.theta],
            omega=np.r_[a.omega, b.omega],
            u=np.r_[a.u, b.u],
            f=np.r_[a.f, b.f],
            fixed=np.r_[a.fixed, b.fixed],
            frames=np.concatenate([a.frames, b.frames]),
            phase=np.r_[a.phase, b.phase],
            shape=list(a.shape) + list(b.shape),
        )

    def subset(self, idx) -> FiberState:
        idx = np.asarray(idx)
        return FiberState(
            diameter=self.diameter[idx],
            center=self.center[idx],
            theta=self.theta[idx],
            omega=self.omega[idx],
            u=self.u[idx],
            f=self.f[idx],
            fixed=self.fixed[idx],
            frames=self.frames[idx],
            phase=self.phase[idx],
            shape=[self.shape[i] for i in np.arange(len(self))[idx]],
        )


# --------------------------------------------------------------------- geometry
@dataclass
class Pieces:
    """Short straight pieces of the medial axes of all fiber copies in a box."""

    a: np.ndarray  # (m, 3) start points
    b: np.ndarray  # (m, 3) end points
    fiber: np.ndarray  # (m,) fiber index
    copy: np.ndarray  # (m,) global copy index
    sag: np.ndarray  # (m,) chord error bound of the piece (bent fibers)
    s_mid: np.ndarray  # (m,) axis parameter of the piece middle
    copy_len: np.ndarray  # (n_copies,) carrier-axis length of each copy in the box
    copy_fiber: np.ndarray  # (n_copies,)


def _clip_lines(p: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray):
    """Vectorized slab clip of lines p + s d to boxes [lo, hi] (per row). Returns s0, s1."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (lo - p) / d
        b = (hi - p) / d
    par = np.abs(d) < 1e-14
    inside = (p >= lo) & (p <= hi)
    smin = np.where(par, np.where(inside, -np.inf, np.inf), np.minimum(a, b))
    smax = np.where(par, np.where(inside, np.inf, -np.inf), np.maximum(a, b))
    return smin.max(axis=1), smax.min(axis=1)


def copies_in_box(st: FiberState, lo: np.ndarray, hi: np.ndarray, margin: np.ndarray | float):
    """Axis copies of every fiber whose carrier line passes within the grown box.

    Returns
    -------
    fiber : (k,) fiber index, p : (k, 3) point on the copy's carrier axis (its s = 0 is
    the fiber's centre plane), s0, s1 : (k,) clipped parameter interval.
    """
    n = len(st)
    margin = np.broadcast_to(np.asarray(margin, float), (n,))
    mid = 0.5 * (lo + hi)
    c = st.center.copy()
    d, l1, l2 = st.frames[:, 0], st.frames[:, 1], st.frames[:, 2]
    rel = c - mid
    c -= np.round(np.einsum("ij,ij->i", rel, l1))[:, None] * l1
    c -= np.round(np.einsum("ij,ij->i", c - mid, l2))[:, None] * l2
    reach = int(np.ceil(np.linalg.norm(hi - lo) / 2 + margin.max() + 1.0))
    jk = np.arange(-reach, reach + 1)
    J, K = (g.ravel() for g in np.meshgrid(jk, jk, indexing="ij"))
    fid = np.repeat(np.arange(n), len(J))
    Jr, Kr = np.tile(J, n), np.tile(K, n)
    p = c[fid] + Jr[:, None] * l1[fid] + Kr[:, None] * l2[fid]
    # shift to the copy's point in the fiber's centre plane (s measured from the centre)
    p = p - np.einsum("ij,ij->i", p - st.center[fid], d[fid])[:, None] * d[fid]
    m = margin[fid][:, None]
    s0, s1 = _clip_lines(p, d[fid], lo - m, hi + m)
    ok = s1 > s0
    return fid[ok], p[ok], s0[ok], s1[ok]


def _axis_points(st: FiberState, fid: np.ndarray, p: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Medial-axis points at parameter s of copies with base points p (bent offset included)."""
    d, wave = st.frames[fid, 0], st.frames[fid, 1]
    x = p + s[:, None] * d
    u = st.u[fid]
    bent = u != 0.0
    if np.any(bent):
        disp = -u * np.cos(2 * np.pi * st.f[fid] * (s + 0.5) + st.phase[fid]) / (2 * np.pi)
        x = x + np.where(bent, disp, 0.0)[:, None] * wave
    return x


def build_pieces(
    st: FiberState, lo: np.ndarray, hi: np.ndarray, margin: float, piece: float
) -> Pieces:
    """Cut every copy's medial axis (inside the box grown by ``margin``) into pieces.

    Straight copies are cut into pieces no longer than ``piece``; bent ones also into at
    least :data:`BENT_SAMPLES_PER_WAVE` pieces per bending period.
    """
    fid, p, s0, s1 = copies_in_box(st, lo, hi, margin + st.amplitude)
    return _cut(st, fid, p, s0, s1, piece)


def segment_distance(p1, q1, p2, q2):
    """Closest points of segment pairs [p1, q1], [p2, q2] (vectorized; Ericson 2005, 5.1.9).

    Returns
    -------
    dist : (m,), c1 : (m, 3), c2 : (m, 3)
    """
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("ij,ij->i", d1, d1)
    e = np.einsum("ij,ij->i", d2, d2)
    f = np.einsum("ij,ij->i", d2, r)
    c = np.einsum("ij,ij->i", d1, r)
    b = np.einsum("ij,ij->i", d1, d2)
    a = np.maximum(a, 1e-300)
    e = np.maximum(e, 1e-300)
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > 1e-14 * a * e, np.clip((b * f - c * e) / denom, 0.0, 1.0), 0.0)
    t = (b * s + f) / e
    lo_t, hi_t = t < 0.0, t > 1.0
    s = np.where(lo_t, np.clip(-c / a, 0.0, 1.0), np.where(hi_t, np.clip((b - c) / a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    c1 = p1 + s[:, None] * d1
    c2 = p2 + t[:, None] * d2
    return np.linalg.norm(c1 - c2, axis=1), c1, c2


@dataclass
class Contacts:
    """Closest approach of every pair of fiber copies closer than their limit."""

    i: np.ndarray  # fiber index of the first copy
    j: np.ndarray  # fiber index of the second copy
    dist: np.ndarray  # centre-line distance
    limit: np.ndarray  # required distance (D_i + D_j)/2 + gap (+ chord error)
    pi: np.ndarray  # closest point on copy of i
    pj: np.ndarray  # closest point on copy of j
    di: np.ndarray  # local axis direction of i at the contact
    dj: np.ndarray

    def __len__(self) -> int:
        return len(self.i)


def find_contacts(
    st: FiberState,
    lo: np.ndarray,
    hi: np.ndarray,
    gap: float = 0.0,
    reach: float = 0.0,
    piece: float | None = None,
) -> Contacts:
    """Pairs of fiber copies whose medial axes come closer than ``(D_i+D_j)/2 + gap + reach``.

    ``limit`` excludes ``reach`` (callers use it to collect near pairs). One contact (the
    closest piece pair) is kept per pair of copies. Copies are clipped to the box grown by
    the contact distance, so every overlap inside the box is seen.
    """
    dmax = float(st.diameter.max()) if len(st) else 0.0
    cut = dmax + max(gap, 0.0) + reach
    if piece is None:
        piece = max(2.0 * cut, 0.02)
    pc = build_pieces(st, lo, hi, 0.5 * dmax + max(gap, 0.0), piece)
    empty = Contacts(*(np.zeros(0, int),) * 2, *(np.zeros(0),) * 2, *(np.zeros((0, 3)),) * 4)
    if len(pc.fiber) < 2:
        return empty
    mid = 0.5 * (pc.a + pc.b)
    half = 0.5 * np.linalg.norm(pc.b - pc.a, axis=1)
    tree = cKDTree(mid)
    pairs = tree.query_pairs(
        2.0 * half.max() + cut + 2 * pc.sag.max() + 1e-12, output_type="ndarray"
    )
    if len(pairs) == 0:
        return empty
    pa, pb = pairs[:, 0], pairs[:, 1]
    keep = pc.fiber[pa] != pc.fiber[pb]
    pa, pb = pa[keep], pb[keep]
    dist, ca, cb = segment_distance(pc.a[pa], pc.b[pa], pc.a[pb], pc.b[pb])
    fi, fj = pc.fiber[pa], pc.fiber[pb]
    limit = 0.5 * (st.diameter[fi] + st.diameter[fj]) + gap + pc.sag[pa] + pc.sag[pb]
    near = dist < limit + reach
    pa, pb, dist, ca, cb, limit = pa[near], pb[near], dist[near], ca[near], cb[near], limit[near]
    if len(pa) == 0:
        return empty
    # one contact per pair of copies: the closest piece pair
    ca_, cb_ = pc.copy[pa], pc.copy[pb]
    swap = ca_ > cb_
    key = np.where(swap, cb_, ca_) * (len(pc.copy_len) + 1) + np.where(swap, ca_, cb_)
    order = np.lexsort((dist - limit, key))
    first = np.r_[True, key[order][1:] != key[order][:-1]]
    sel = order[first]
    pa, pb = pa[sel], pb[sel]
    ua = pc.b[pa] - pc.a[pa]
    ub = pc.b[pb] - pc.a[pb]
    ua /= np.linalg.norm(ua, axis=1)[:, None]
    ub /= np.linalg.norm(ub, axis=1)[:, None]
    return Contacts(
        i=pc.fiber[pa],
        j=pc.fiber[pb],
        dist=dist[sel],
        limit=limit[sel],
        pi=ca[sel],
        pj=cb[sel],
        di=ua,
        dj=ub,
    )


def clearance(st: FiberState, lo: np.ndarray, hi: np.ndarray) -> float:
    """Smallest ``|x_i - x_j| - (D_i + D_j) / 2`` over fiber pairs in the box (normalized).

    Only pairs closer than ``max D`` are examined; returns ``inf`` if there are none.
    """
    c = find_contacts(st, lo, hi, gap=0.0, reach=float(st.diameter.max()))
    if len(c) == 0:
        return float("inf")
    return float(np.min(c.dist - 0.5 * (st.diameter[c.i] + st.diameter[c.j])))


def carrier_lengths(st: FiberState, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Length of each fiber's carrier axis (all copies) inside the box [lo, hi]."""
    fid, _, s0, s1 = copies_in_box(st, lo, hi, 0.0)
    return np.bincount(fid, weights=s1 - s0, minlength=len(st))


def orientation_tensor(st: FiberState, weights: np.ndarray | None = None) -> np.ndarray:
    """Second-order orientation tensor ``<d d^T>`` (weighted mean over fibers)."""
    d = st.direction
    w = np.ones(len(st)) if weights is None else np.asarray(weights, float)
    if w.sum() <= 0:
        return np.zeros((3, 3))
    return np.einsum("i,ij,ik->jk", w, d, d) / w.sum()


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


def torus_offsets(step: float) -> np.ndarray:
    """Lattice-plane shifts (t1, t2) in [-1/2, 1/2)^2 on a grid, nearest to 0 first."""
    k = max(2, int(np.ceil(1.0 / step)))
    g = (np.arange(k) - k // 2) / k
    T = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    return T[np.argsort(np.hypot(T[:, 0], T[:, 1]), kind="stable")]


def _pieces_for(st: FiberState, lo, hi, gap: float, piece: float) -> Pieces:
    # each fiber is clipped to the box grown by its own radius + gap: any overlap point
    # inside the box is within that distance of both axes
    margin = 0.5 * st.diameter + max(gap, 0.0)
    amp = st.amplitude
    fid, p, s0, s1 = copies_in_box(st, lo, hi, margin + amp)
    return _cut(st, fid, p, s0, s1, piece)


def _cut(st: FiberState, fid, p, s0, s1, piece: float) -> Pieces:
    length = s1 - s0
    step = np.full(len(fid), piece)
    bent = st.u[fid] != 0.0
    step[bent] = np.minimum(piece, 1.0 / (BENT_SAMPLES_PER_WAVE * st.f[fid][bent]))
    npieces = np.maximum(1, np.ceil(length / step).astype(np.int64))
    cid = np.repeat(np.arange(len(fid)), npieces)
    first = np.cumsum(npieces) - npieces
    k = np.arange(len(cid)) - first[cid]
    ds = (length / npieces)[cid]
    sa = s0[cid] + k * ds
    f_id = fid[cid]
    a = _axis_points(st, f_id, p[cid], sa)
    b = _axis_points(st, f_id, p[cid], sa + ds)
    sag = st.amplitude[f_id] * (2 * np.pi * st.f[f_id]) ** 2 * ds**2 / 8.0
    return Pieces(
        a=a,
        b=b,
        fiber=f_id,
        copy=cid,
        sag=sag,
        s_mid=sa + 0.5 * ds,
        copy_len=length,
        copy_fiber=fid,
    )


@numba.njit(cache=True)
def _mark_capsules(free, A, B, lim):  # pragma: no cover - compiled
    """Clear the grid points (periodic, grid units) closer than lim[m] to segment A[m]B[m]."""
    k = free.shape[0]
    half = k // 2
    for m in range(A.shape[0]):
        ax, ay, bx, by, r = A[m, 0], A[m, 1], B[m, 0], B[m, 1], lim[m]
        ex, ey = bx - ax, by - ay
        L2 = max(ex * ex + ey * ey, 1e-30)
        i0 = int(np.floor(min(ax, bx) - r))
        i1 = int(np.ceil(max(ax, bx) + r))
        j0 = int(np.floor(min(ay, by) - r))
        j1 = int(np.ceil(max(ay, by) + r))
        for i in range(i0, i1 + 1):
            px = i - ax
            for j in range(j0, j1 + 1):
                py = j - ay
                t = (px * ex + py * ey) / L2
                t = min(1.0, max(0.0, t))
                dx = px - t * ex
                dy = py - t * ey
                if dx * dx + dy * dy < r * r:
                    free[(i + half) % k, (j + half) % k] = False


def _bent_capsules(trial: FiberState, old: Pieces, A, B, lim):
    """Capsules (projected plane) that hold every shift bringing a bent fiber within lim.

    The new axis sits at ``w(s) l1`` off its carrier (``w = -u cos(2 pi f (s + 1/2) + phase)
    / (2 pi)``). For an old piece spanning axial range [s_min, s_max] (measured along the
    new axis), a contact at new-axis parameter s needs ``(s - s_y)^2 + r^2 < lim^2``. The
    window ``[s_min - lim, s_max + lim]`` is cut into short sub-intervals; on each, the
    in-plane radius is at most ``sqrt(lim^2 - g^2)`` (g: axial gap to the piece) and w
    varies within [w_lo, w_hi], giving one capsule shifted by ``-(w_lo + w_hi)/2`` and
    grown by ``(w_hi - w_lo)/2``. The union over-covers the exact forbidden set (safe).
    """
    c, d = trial.center[0], trial.frames[0, 0]
    u, f, ph = float(trial.u[0]), float(trial.f[0]), float(trial.phase[0])
    sa, sb = (old.a - c) @ d, (old.b - c) @ d
    smin, smax = np.minimum(sa, sb), np.maximum(sa, sb)
    width = min(0.5 * float(lim.min()), 1.0 / (12.0 * f))
    m = np.maximum(1, np.ceil((smax - smin + 2 * lim) / width).astype(np.int64))
    rep = np.repeat(np.arange(len(m)), m)
    j = np.arange(len(rep)) - (np.cumsum(m) - m)[rep]
    h = ((smax - smin + 2 * lim) / m)[rep]
    s0 = smin[rep] - lim[rep] + j * h
    s1 = s0 + h
    g = np.maximum(0.0, np.maximum(s0 - smax[rep], smin[rep] - s1))
    r = np.sqrt(np.clip(lim[rep] ** 2 - g**2, 0.0, None))
    tp = 2 * np.pi
    th0 = tp * f * (s0 + 0.5) + ph
    th1 = tp * f * (s1 + 0.5) + ph
    has_max = np.floor(th1 / tp) >= np.ceil(th0 / tp)
    has_min = np.floor((th1 - np.pi) / tp) >= np.ceil((th0 - np.pi) / tp)
    cmax = np.where(has_max, 1.0, np.maximum(np.cos(th0), np.cos(th1)))
    cmin = np.where(has_min, -1.0, np.minimum(np.cos(th0), np.cos(th1)))
    w1, w2 = -u * cmax / tp, -u * cmin / tp
    wlo, whi = np.minimum(w1, w2), np.maximum(w1, w2)
    keep = g < lim[rep]
    shift = np.zeros((len(rep), 2))
    shift[:, 0] = 0.5 * (wlo + whi)
    A2 = (A[rep] - shift)[keep]
    B2 = (B[rep] - shift)[keep]
    return A2, B2, (r + 0.5 * (whi - wlo))[keep], old.fiber[rep][keep]


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
    gap: float = 0.0,
    step: float | None = None,
    max_rotation_deg: float = 0.0,
    orientation_tries: int = 0,
    seed: int = 0,
    on_reject: str = "skip",
    area: np.ndarray | None = None,
    stop_solid: float | None = None,
    max_consecutive_rejects: int | None = None,
    max_shift_z: float | None = None,
    max_ejections: int = 6,
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
    gap : float
        Minimum surface gap (normalized); negative allows a contact overlap of ``-gap``.
    step : float, optional
        Grid step of the shift search (default: min diameter / 4).
    on_reject : {"skip", "raise"}
        What to do with a fiber that fits nowhere: leave it out, or stop and return the
        fibers placed so far (``rejected`` then lists the first failure).
    area, stop_solid : optional
        Cross-section area of each fiber (normalized); placement stops once the placed
        solid ``sum(area_i * carrier length_i in box) / box volume`` reaches ``stop_solid``.
    max_consecutive_rejects : int, optional
        Stop after this many fibers in a row found no place (the packing is jammed).
    max_ejections : int
        A fiber that fits nowhere may eject the placed fibers blocking its least blocked
        position; they go back to the front of the queue. Each fiber can be ejected at
        most this often (0 disables ejection).
    max_shift_z : float, optional
        Largest allowed z component of a shift (normalized), to keep a drawn through-plane
        position distribution (e.g. beta z translations, Fig. 17); in-plane moves stay
        free. Default: the whole lattice torus.
    """
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    n = len(st)
    if n == 0:
        return PlacementResult(
            st.copy(), np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3)), np.zeros(0), 0, 0.0
        )
    dmin_all = float(st.diameter.min())
    step = dmin_all / 4.0 if step is None else step
    T = torus_offsets(step)
    k_grid = max(2, int(np.ceil(1.0 / step)))
    tidx = (np.round(T * k_grid).astype(np.int64) + k_grid // 2) % k_grid
    cut = float(st.diameter.max()) + max(gap, 0.0)
    piece = max(0.5 * cut, 0.005)
    out = st.copy()
    old: Pieces | None = None
    tested = 0
    box_volume = float(np.prod(hi - lo))
    placed: list[int] = []
    rejected: list[int] = []
    contrib: dict[int, float] = {}
    ejected = np.zeros(n, np.int64)
    streak = 0
    stopped = False

    def add_old(idx) -> None:
        nonlocal old
        idx = np.atleast_1d(idx)
        pc = _pieces_for(out.subset(idx), lo, hi, gap, piece)
        pc.fiber = idx[pc.fiber]
        if area is not None:
            lengths = carrier_lengths(out.subset(idx), lo, hi)
            for k, v in zip(idx, area[idx] * lengths / box_volume, strict=True):
                contrib[int(k)] = float(v)
        old = pc if old is None else _concat_pieces(old, pc)

    def remove_old(idx: np.ndarray) -> None:
        nonlocal old
        keep = ~np.isin(old.fiber, idx)
        old = Pieces(
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
            contrib.pop(int(k), None)
            placed.remove(int(k))

    def accept(i: int, c_new: np.ndarray, trial: FiberState) -> None:
        out.center[i] = c_new
        out.theta[i], out.omega[i] = trial.theta[0], trial.omega[0]
        out.frames[i] = trial.frames[0]
        placed.append(i)
        add_old(i)

    fixed_idx = np.flatnonzero(st.fixed)
    if len(fixed_idx):
        placed.extend(int(k) for k in fixed_idx)
        add_old(fixed_idx)
    queue = deque(int(k) for k in np.flatnonzero(~st.fixed))
    while queue:
        if stop_solid is not None and sum(contrib.values()) >= stop_solid:
            stopped = True
            break
        if max_consecutive_rejects is not None and streak >= max_consecutive_rejects:
            break
        i = queue.popleft()
        found = None
        base = st.subset([i])
        # tries: the drawn orientation (bent fibers also with their bend phase moved by
        # quarter wavelengths along the axis), then random re-orientations
        tries = [(0.0, 0.0, 0.0)]
        if base.u[0] != 0.0:
            tries += [(0.0, 0.0, q / base.f[0]) for q in (0.25, 0.5, 0.75)]
        if max_rotation_deg > 0:
            tries += [
                (
                    rng.uniform(-max_rotation_deg, max_rotation_deg),
                    rng.uniform(-max_rotation_deg, max_rotation_deg),
                    0.0,
                )
                for _ in range(orientation_tries)
            ]
        for dth, dom, ds in tries:
            trial = base.copy()
            if dth or dom:
                trial.theta += dth
                trial.omega += dom
                trial.refresh_frames()
            trial.center[0] += ds * trial.frames[0, 0]
            l1, l2 = trial.frames[0, 1], trial.frames[0, 2]
            tested += len(T)
            free = _free_shift_raster(trial, old, out.diameter, gap, k_grid)
            ok = free[tidx[:, 0], tidx[:, 1]]
            if max_shift_z is not None:
                ok &= np.abs(T[:, 0] * l1[2] + T[:, 1] * l2[2]) <= max_shift_z + 1e-12
            if np.any(ok):
                k = int(np.argmax(ok))
                found = (trial.center[0] + T[k, 0] * l1 + T[k, 1] * l2, trial)
                break
        if found is None and max_ejections > 0:
            # eject the fewest placed fibers that block a position; they are re-queued
            c_new, blockers = _least_blocked(
                base, old, out.diameter, st.fixed, gap, T, max_shift_z, k_grid, tidx
            )
            if c_new is not None and np.all(ejected[blockers] < max_ejections):
                ejected[blockers] += 1
                remove_old(blockers)
                queue.extendleft(int(b) for b in blockers[::-1])
                found = (c_new, base)
        if found is None:
            rejected.append(i)
            streak += 1
            if on_reject == "raise":
                break
            continue
        streak = 0
        accept(i, *found)
    keep = np.array(placed, dtype=np.int64)
    final = out.subset(keep)
    shift = final.center - st.center[keep]
    cosang = np.abs(np.einsum("ij,ij->i", final.direction, st.direction[keep]))
    return PlacementResult(
        state=final,
        placed=keep,
        rejected=np.array(rejected, dtype=np.int64),
        shift=shift,
        rotation_deg=np.degrees(np.arccos(np.clip(cosang, 0.0, 1.0))),
        candidates_tested=tested,
        wall_time_s=time.perf_counter() - t0,
        solid=sum(contrib.values()),
        reached_stop=stopped or (stop_solid is not None and sum(contrib.values()) >= stop_solid),
        n_ejections=int(ejected.sum()),
    )


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
    max_shift_z: float | None,
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
    if max_shift_z is not None:
        far = np.abs(T[:, 0] * l1[2] + T[:, 1] * l2[2]) > max_shift_z + 1e-12
        cnt = np.where(far, np.iinfo(np.int64).max, cnt)
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


# ------------------------------------------------------------------- objectives
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)


def crossing_volume(dist, ri, rj, sin_alpha, max_len: float = 1.0) -> np.ndarray:
    """Intersection volume of two cylinders crossing at angle alpha, axes ``dist`` apart.

    ``V = int w_i(z) w_j(z) dz / sin(alpha)`` with chord widths ``w = 2 sqrt(r^2 - z^2)``
    (exact for infinite cylinders; 16 r^3 / 3 for the Steinmetz solid). Near-parallel
    pairs are capped by an overlap length ``max_len``.
    """
    dist, ri, rj = (np.asarray(v, float) for v in (dist, ri, rj))
    za = np.maximum(-ri, dist - rj)
    zb = np.minimum(ri, dist + rj)
    ok = zb > za
    half = 0.5 * (zb - za)
    mid = 0.5 * (zb + za)
    z = mid[:, None] + half[:, None] * _GL_X[None, :]
    wi = 2 * np.sqrt(np.clip(ri[:, None] ** 2 - z**2, 0, None))
    wj = 2 * np.sqrt(np.clip(rj[:, None] ** 2 - (z - dist[:, None]) ** 2, 0, None))
    integral = half * np.sum(_GL_W * wi * wj, axis=1)
    width = np.minimum(2 * ri, 2 * rj)
    s = np.maximum(np.abs(sin_alpha), width / max_len)
    return np.where(ok, integral / s, 0.0)


def analytic_omega(st: FiberState, lo: np.ndarray, hi: np.ndarray) -> float:
    """Estimated intersection volume fraction of the box from the centre lines."""
    c = find_contacts(st, lo, hi, 0.0)
    if len(c) == 0:
        return 0.0
    sin_a = np.linalg.norm(np.cross(c.di, c.dj), axis=1)
    v = crossing_volume(c.dist, 0.5 * st.diameter[c.i], 0.5 * st.diameter[c.j], sin_a)
    return float(v.sum() / np.prod(hi - lo))


# --------------------------------------------------------------------- the GA
@dataclass
class GAResult:
    """Outcome of :func:`genetic`."""

    state: FiberState
    objective_initial: float
    objective_final: float
    generations: int
    evaluations: int
    wall_time_s: float
    history: list = field(default_factory=list)


def genetic(
    st: FiberState,
    lo: np.ndarray,
    hi: np.ndarray,
    size_norm: np.ndarray,
    angle_range_deg: float = 1.0,
    shift_range: float = 0.1,
    u_range: tuple[float, float] = (0.1, 0.3),
    f_range: tuple[float, float] = (1.0, 10.0),
    population: int = 24,
    generations: int = 40,
    mutation_sigma: float = 0.15,
    objective: str = "analytic",
    voxel: float | None = None,
    seed: int = 0,
    time_limit_s: float | None = None,
) -> GAResult:
    """Real-coded genetic algorithm over the Sec. 7.1 adjustments (paper Eq. 9).

    Genes per movable fiber: theta and omega adjustments in ``+-angle_range_deg``,
    translation adjustments in ``+-shift_range`` of the RVE edge, and for bent fibers the
    absolute ``u`` and ``f`` in their ranges. Tournament selection, uniform crossover
    per fiber, Gaussian mutation, elitism; the unchanged state is in the first generation.

    Parameters
    ----------
    objective : {"analytic", "voxel"}
        Omega from :func:`analytic_omega`, or the voxel count of Eq. (8) on a grid of
        step ``voxel`` (normalized).
    """
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    mov = np.flatnonzero(~st.fixed)
    bent = st.u[mov] != 0.0
    nm = len(mov)
    G = 7  # theta, omega, tx, ty, tz, u, f  (u, f genes unused for straight fibers)

    def decode(g: np.ndarray) -> FiberState:
        s = st.copy()
        g = g.reshape(nm, G)
        s.theta[mov] = st.theta[mov] + angle_range_deg * g[:, 0]
        s.omega[mov] = st.omega[mov] + angle_range_deg * g[:, 1]
        s.center[mov] = st.center[mov] + shift_range * g[:, 2:5] * size_norm
        if np.any(bent):
            b = mov[bent]
            s.u[b] = u_range[0] + (u_range[1] - u_range[0]) * 0.5 * (g[bent, 5] + 1)
            s.f[b] = f_range[0] + (f_range[1] - f_range[0]) * 0.5 * (g[bent, 6] + 1)
        s.refresh_frames()
        return s

    if objective == "voxel":
        from psdesign.geometry.rve import RVE

        if voxel is None:
            raise ValueError("voxel objective needs a voxel step")

        def cost(g: np.ndarray) -> float:
            s = decode(g)
            rve = RVE(hi - lo, s.to_fibers(), period=1.0)
            return rve.voxelize(voxel).intersection_volume_fraction
    elif objective == "analytic":

        def cost(g: np.ndarray) -> float:
            return analytic_omega(decode(g), lo, hi)
    else:
        raise ValueError(f"objective must be 'analytic' or 'voxel', got {objective!r}")

    g0 = np.zeros((nm, G))
    if np.any(bent):  # encode the drawn u, f as the starting genes
        b = mov[bent]
        g0[bent, 5] = np.clip(2 * (st.u[b] - u_range[0]) / (u_range[1] - u_range[0]) - 1, -1, 1)
        g0[bent, 6] = np.clip(2 * (st.f[b] - f_range[0]) / (f_range[1] - f_range[0]) - 1, -1, 1)
    g0 = g0.ravel()
    pop = np.clip(g0 + rng.normal(0, 0.5, (population, nm * G)), -1, 1)
    pop[0] = g0
    fit = np.array([cost(g) for g in pop])
    evals = population
    f_init = float(fit[0])
    history = [float(fit.min())]
    gen = 0
    for _ in range(generations):
        if fit.min() <= 0.0:
            break
        if time_limit_s is not None and time.perf_counter() - t0 > time_limit_s:
            break
        elite = np.argsort(fit)[:2]
        children = [pop[e].copy() for e in elite]
        while len(children) < population:
            a, b = (min(rng.integers(0, population, 2), key=lambda k: fit[k]) for _ in range(2))
            mask = np.repeat(rng.random(nm) < 0.5, G)
            child = np.where(mask, pop[a], pop[b])
            mut = rng.random(child.size) < max(1.0 / nm, 0.02)
            child = np.clip(child + mut * rng.normal(0, mutation_sigma, child.size), -1, 1)
            children.append(child)
        pop = np.array(children)
        fit = np.r_[fit[elite], [cost(g) for g in pop[2:]]]
        evals += population - 2
        gen += 1
        history.append(float(fit.min()))
    best = int(np.argmin(fit))
    return GAResult(
        state=decode(pop[best]),
        objective_initial=f_init,
        objective_final=float(fit[best]),
        generations=gen,
        evaluations=evals,
        wall_time_s=time.perf_counter() - t0,
        history=history,
    )
