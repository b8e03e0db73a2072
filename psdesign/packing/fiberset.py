"""Fiber sets as arrays of the Sec. 7.1 placement parameters, their centre-line pieces in a box,
and contacts between them (the geometry both intersection-removal methods work on).

A PS fiber is the periodic family of its lattice copies (one line per period^2 perpendicular to
its axis); its centre-line copies are clipped to the box, grown by the contact distance, so every
overlap inside the box is seen.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from psdesign.geometry.fibers import Fiber, make_fiber

_TO_X = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # rotation z -> x
_EZ = np.array([0.0, 0.0, 1.0])
#: Points per unit length (times f) used to resolve a bent medial axis.
BENT_SAMPLES_PER_WAVE = 8
#: A bent axis is cut into pieces no shorter than this fraction of its fiber's diameter (the
#: chord's sag, at most twice the bend amplitude, is added to the contact distance instead).
#: Binds only where a bend is shorter than 8 diameters (``f > 8 / D`` in periods), where
#: ``|u| f <= 10`` keeps the amplitude under 0.2 D; without it ``generator.f = 1000`` (its upper
#: end) cut each fiber copy of a 50 um box into 8000 pieces, and the contact search's pairs
#: within one diameter filled 22.7 GB until the kernel killed it (session 37 edge audit).
MIN_PIECE_DIAMETERS = 1.0 / 64.0


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
    least :data:`BENT_SAMPLES_PER_WAVE` pieces per bending period, none shorter than
    :data:`MIN_PIECE_DIAMETERS` diameters.
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


def pieces_for(st: FiberState, lo, hi, gap: float, piece: float) -> Pieces:
    """Centre-line pieces of every fiber copy that can touch the box ``[lo, hi]``."""
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
    per_wave = 1.0 / (BENT_SAMPLES_PER_WAVE * st.f[fid][bent])
    step[bent] = np.minimum(
        piece, np.maximum(per_wave, MIN_PIECE_DIAMETERS * st.diameter[fid][bent])
    )
    npieces = np.maximum(1, np.ceil(length / step).astype(np.int64))
    cid = np.repeat(np.arange(len(fid)), npieces)
    first = np.cumsum(npieces) - npieces
    k = np.arange(len(cid)) - first[cid]
    ds = (length / npieces)[cid]
    sa = s0[cid] + k * ds
    f_id = fid[cid]
    a = _axis_points(st, f_id, p[cid], sa)
    b = _axis_points(st, f_id, p[cid], sa + ds)
    amp = st.amplitude[f_id]
    # a chord and its arc both lie within the amplitude of the carrier line: sag <= 2 amp
    sag = np.minimum(amp * (2 * np.pi * st.f[f_id]) ** 2 * ds**2 / 8.0, 2.0 * amp)
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
