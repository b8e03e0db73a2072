"""Periodic-surface (PS) models as plain data (paper Eq. 1 and Eq. 10).

A generalized PS model is

    psi(r) = sum_l sum_m mu_lm cos( 2 pi kappa_l (p_m . r)
                                    + sum_s sum_t u_lmst cos(2 pi f_lms (q_lmt . r)) )

with homogeneous location vector ``r = [x, y, z, 1]``, major basis vectors
``p_m = [H_m, alpha_m]`` and minor basis vectors ``q_lmt = [G_lmt, beta_lmt]``.
The printed Eq. (10) drops the carrier term ``2 pi kappa_l (p_m . r)``; it is
restored here (compare Eq. 11 and Eq. 16).

The model is stored *flattened*: every (l, m) pair is one **major term** with its
own moment ``mu``, scale ``kappa``, direction ``H`` and phase ``alpha``; every
(l, m, s, t) combination is one **minor term** attached to a major term with its
own minor moment ``u``, minor scale ``f``, direction ``G`` and phase ``beta``.
:meth:`GeneralizedPS.from_lmst` builds this from the paper's indexed arrays, so
any L, M, S, T is representable. Eq. (1) is the special case with no minor terms.

Coordinates are the paper's normalized ones (the unit cube is one period); the
RVE maps metres to them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

TWO_PI = 2.0 * np.pi
#: Points evaluated per chunk; bounds the temporary (chunk x n_terms) arrays.
DEFAULT_CHUNK = 65536


def _as_points(points: np.ndarray) -> np.ndarray:
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
    return pts


@dataclass(frozen=True)
class GeneralizedPS:
    """A generalized periodic-surface model (paper Eq. 10 with carrier term).

    Parameters
    ----------
    mu : ndarray, shape (n,)
        Major moments, one per major term.
    kappa : ndarray, shape (n,)
        Major scales.
    H : ndarray, shape (n, 3)
        Direction part of the major basis vectors.
    alpha : ndarray, shape (n,)
        Phase of the major basis vectors.
    minor_term : ndarray of int, shape (k,)
        Index of the major term each minor term belongs to.
    u : ndarray, shape (k,)
        Minor moments.
    f : ndarray, shape (k,)
        Minor scales.
    G : ndarray, shape (k, 3)
        Direction part of the minor basis vectors.
    beta : ndarray, shape (k,)
        Phase of the minor basis vectors.
    """

    mu: np.ndarray
    kappa: np.ndarray
    H: np.ndarray
    alpha: np.ndarray
    minor_term: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    u: np.ndarray = field(default_factory=lambda: np.zeros(0))
    f: np.ndarray = field(default_factory=lambda: np.zeros(0))
    G: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    beta: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        def arr(name: str, shape_tail: tuple[int, ...], dtype=float) -> np.ndarray:
            a = np.array(getattr(self, name), dtype=dtype).reshape((-1,) + shape_tail)
            if dtype is float and not np.all(np.isfinite(a)):
                raise ValueError(f"{name} must be finite")
            object.__setattr__(self, name, a)
            return a

        n = len(arr("mu", ()))
        for name, tail in (("kappa", ()), ("H", (3,)), ("alpha", ())):
            if len(arr(name, tail)) != n:
                raise ValueError(f"{name} must have one entry per major term ({n})")
        k = len(arr("minor_term", (), int))
        for name, tail in (("u", ()), ("f", ()), ("G", (3,)), ("beta", ())):
            if len(arr(name, tail)) != k:
                raise ValueError(f"{name} must have one entry per minor term ({k})")
        if k and (self.minor_term.min() < 0 or self.minor_term.max() >= n):
            raise ValueError("minor_term indices must refer to existing major terms")

    # ------------------------------------------------------------------ build
    @classmethod
    def from_lmst(
        cls,
        mu: np.ndarray,
        kappa: np.ndarray,
        P: np.ndarray,
        u: np.ndarray | None = None,
        f: np.ndarray | None = None,
        Q: np.ndarray | None = None,
    ) -> GeneralizedPS:
        """Build from the paper's indexed arrays.

        Parameters
        ----------
        mu : ndarray, shape (L, M)
            Major moments ``mu_lm``.
        kappa : ndarray, shape (L,)
            Major scales ``kappa_l``.
        P : ndarray, shape (M, 4)
            Major basis vectors ``p_m = [a, b, c, alpha]``.
        u : ndarray, shape (L, M, S, T), optional
            Minor moments ``u_lmst``.
        f : ndarray, shape (L, M, S), optional
            Minor scales ``f_lms``.
        Q : ndarray, shape (L, M, T, 4), optional
            Minor basis vectors ``q_lmt = [e, f, g, beta]``.
        """
        mu = np.asarray(mu, float)
        kappa = np.asarray(kappa, float)
        P = np.asarray(P, float)
        L, M = mu.shape
        li, mi = np.meshgrid(np.arange(L), np.arange(M), indexing="ij")
        li, mi = li.ravel(), mi.ravel()
        kw: dict[str, np.ndarray] = {}
        if u is not None:
            u = np.asarray(u, float)
            f = np.asarray(f, float)
            Q = np.asarray(Q, float)
            S, T = u.shape[2], u.shape[3]
            lm, s, t = np.meshgrid(np.arange(L * M), np.arange(S), np.arange(T), indexing="ij")
            lm, s, t = lm.ravel(), s.ravel(), t.ravel()
            l_idx, m_idx = li[lm], mi[lm]
            uu = u[l_idx, m_idx, s, t]
            keep = uu != 0.0
            kw = dict(
                minor_term=lm[keep],
                u=uu[keep],
                f=f[l_idx, m_idx, s][keep],
                G=Q[l_idx, m_idx, t, :3][keep],
                beta=Q[l_idx, m_idx, t, 3][keep],
            )
        return cls(mu=mu[li, mi], kappa=kappa[li], H=P[mi, :3], alpha=P[mi, 3], **kw)

    # ------------------------------------------------------------ properties
    @property
    def n_terms(self) -> int:
        """Number of major terms (flattened (l, m) pairs)."""
        return len(self.mu)

    @property
    def n_minor(self) -> int:
        """Number of minor terms (flattened (l, m, s, t) combinations)."""
        return len(self.u)

    def _minor_matrix(self) -> np.ndarray:
        """Incidence matrix (k, n): minor term j belongs to major term i."""
        inc = np.zeros((self.n_minor, self.n_terms))
        inc[np.arange(self.n_minor), self.minor_term] = 1.0
        return inc

    def is_periodic(self, tol: float = 1e-12) -> bool:
        """True if the model is periodic with period 1 along x, y and z.

        Sufficient condition: every ``kappa * H`` and every ``f * G`` has integer
        components (the phases then change by multiples of 2 pi under unit shifts).
        """
        kh = self.kappa[:, None] * self.H
        fg = self.f[:, None] * self.G
        both = np.concatenate([kh.ravel(), fg.ravel()])
        return bool(np.all(np.abs(both - np.round(both)) <= tol))

    # ------------------------------------------------------------ evaluation
    def _phases(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        major = TWO_PI * self.kappa * (pts @ self.H.T + self.alpha)
        minor_arg = TWO_PI * self.f * (pts @ self.G.T + self.beta)
        if self.n_minor:
            major = major + (np.cos(minor_arg) * self.u) @ self._minor_matrix()
        return major, minor_arg

    def evaluate(self, points: np.ndarray, chunk: int = DEFAULT_CHUNK) -> np.ndarray:
        """Evaluate psi at points.

        Parameters
        ----------
        points : ndarray, shape (N, 3)
            Normalized coordinates.
        chunk : int
            Points per block; memory stays O(chunk * n_terms).

        Returns
        -------
        ndarray, shape (N,)
        """
        pts = _as_points(points)
        out = np.empty(len(pts))
        for a in range(0, len(pts), chunk):
            major, _ = self._phases(pts[a : a + chunk])
            out[a : a + chunk] = np.cos(major) @ self.mu
        return out

    def gradient(self, points: np.ndarray, chunk: int = DEFAULT_CHUNK) -> np.ndarray:
        """Analytic gradient of psi at points, shape (N, 3)."""
        pts = _as_points(points)
        out = np.empty((len(pts), 3))
        inc = self._minor_matrix()
        for a in range(0, len(pts), chunk):
            p = pts[a : a + chunk]
            major, minor_arg = self._phases(p)
            w = -self.mu * np.sin(major)  # (c, n)
            g = w @ (TWO_PI * self.kappa[:, None] * self.H)
            if self.n_minor:
                # d/dr of u cos(2 pi f (G.r + beta)) = -u sin(.) 2 pi f G
                wm = (w @ inc.T) * (-self.u * np.sin(minor_arg))  # (c, k)
                g += wm @ (TWO_PI * self.f[:, None] * self.G)
            out[a : a + chunk] = g
        return out

    def evaluate_grid(
        self, axes: tuple[np.ndarray, np.ndarray, np.ndarray], chunk: int = DEFAULT_CHUNK
    ) -> np.ndarray:
        """Evaluate on the tensor grid ``axes[0] x axes[1] x axes[2]`` (ij indexing)."""
        x, y, z = (np.asarray(a, float) for a in axes)
        out = np.empty((len(x), len(y), len(z)))
        yz = np.stack(np.meshgrid(y, z, indexing="ij"), -1).reshape(-1, 2)
        for i, xi in enumerate(x):
            pts = np.column_stack([np.full(len(yz), xi), yz])
            out[i] = self.evaluate(pts, chunk).reshape(len(y), len(z))
        return out

    # -------------------------------------------------------- transformation
    def rotated(self, R: np.ndarray) -> GeneralizedPS:
        """Model rotated by the 3x3 rotation matrix ``R`` (Eq. 11-12).

        ``rotated(R).evaluate(r) == evaluate(R^T r)``: the direction parts of all
        basis vectors are rotated, phases are unchanged.
        """
        R = np.asarray(R, float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-10):
            raise ValueError("R must be a 3x3 orthogonal matrix")
        return self._replace(H=self.H @ R.T, G=self.G @ R.T)

    def translated(self, t: np.ndarray) -> GeneralizedPS:
        """Model translated by ``t`` (Sec. 4.2): ``translated(t).evaluate(r) == evaluate(r - t)``.

        The phase of every basis vector changes by ``-(H . t)`` (resp. ``-(G . t)``).
        """
        t = np.asarray(t, float).reshape(3)
        return self._replace(alpha=self.alpha - self.H @ t, beta=self.beta - self.G @ t)

    def _replace(self, **changes: np.ndarray) -> GeneralizedPS:
        data = {k: getattr(self, k) for k in self.__dataclass_fields__}
        data.update(changes)
        return GeneralizedPS(**data)

    # ------------------------------------------------------------------- io
    def to_dict(self) -> dict:
        """JSON-ready dict of all parameters."""
        return {
            "major": [
                {"mu": float(m), "kappa": float(k), "H": [float(v) for v in h], "alpha": float(a)}
                for m, k, h, a in zip(self.mu, self.kappa, self.H, self.alpha, strict=True)
            ],
            "minor": [
                {
                    "term": int(i),
                    "u": float(u),
                    "f": float(f),
                    "G": [float(v) for v in g],
                    "beta": float(b),
                }
                for i, u, f, g, b in zip(
                    self.minor_term, self.u, self.f, self.G, self.beta, strict=True
                )
            ],
        }

    @classmethod
    def from_dict(cls, data: dict) -> GeneralizedPS:
        """Inverse of :meth:`to_dict`."""
        major, minor = data["major"], data.get("minor", [])
        return cls(
            mu=[t["mu"] for t in major],
            kappa=[t["kappa"] for t in major],
            H=[t["H"] for t in major],
            alpha=[t["alpha"] for t in major],
            minor_term=[t["term"] for t in minor],
            u=[t["u"] for t in minor],
            f=[t["f"] for t in minor],
            G=[t["G"] for t in minor] or np.zeros((0, 3)),
            beta=[t["beta"] for t in minor],
        )


def rotation_matrix(
    theta_deg: float = 0.0, omega_deg: float = 0.0, phi_deg: float = 0.0
) -> np.ndarray:
    """Rotation about x by phi, then y by theta, then z by omega: ``Rz @ Ry @ Rx``.

    This is the order of Sec. 7.1 ("rotated about the y-axis by theta and the
    z-axis by omega"): a fiber starting along x ends along
    ``(cos theta cos omega, cos theta sin omega, -sin theta)``. (The matrix printed in
    Sec. 4.1 composes the same elementary rotations as ``Rx @ Ry @ Rz``.)
    """
    th, om, ph = np.radians([theta_deg, omega_deg, phi_deg])
    c, s = np.cos, np.sin
    Rx = np.array([[1, 0, 0], [0, c(ph), -s(ph)], [0, s(ph), c(ph)]])
    Ry = np.array([[c(th), 0, s(th)], [0, 1, 0], [-s(th), 0, c(th)]])
    Rz = np.array([[c(om), -s(om), 0], [s(om), c(om), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Proper rotation matrix taking unit vector ``a`` to unit vector ``b`` (Rodrigues)."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(a @ b)
    if np.linalg.norm(v) < 1e-14:
        if c > 0:
            return np.eye(3)
        # 180 degrees: rotate about any axis perpendicular to a
        perp = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
        perp /= np.linalg.norm(perp)
        return 2.0 * np.outer(perp, perp) - np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx * (1.0 / (1.0 + c))
