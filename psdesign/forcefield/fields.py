"""Implicit fiber fields for the force-field potentials (paper Sec. 6).

A field is a scalar function ``phi`` of normalized coordinates with the fiber solid where
``phi <= 0``. The potentials need it in four forms: values on a tensor grid (volume
integrals, marching cubes), values at scattered points, and the analytic gradient and
Hessian at scattered points (surface projection and curvatures).

:class:`PSField` wraps a :class:`~psdesign.geometry.model.GeneralizedPS` model and an isovalue,
``phi = scale * (psi - isovalue)``; its grid evaluation exploits that every PS term
depends only on the coordinates its basis vectors touch (a rod term ``cos(2 pi x)`` is a
1-D array broadcast over the grid), so a grid costs a few 2-D cosines plus 3-D additions.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import Protocol

import numba
import numpy as np

import solvers.jit  # noqa: F401  (numba cache stamps cover the imported modules)
from psdesign.forcefield.kernels import fill_tables, model_arrays
from psdesign.geometry.model import TWO_PI, GeneralizedPS
from psdesign.geometry.ps_kernel import psi_point, psi_value


class NoFiberError(ValueError):
    """The parameters give a fiber with no solid, or one that breaks inside the domain."""


class ImplicitField(Protocol):
    """What the potentials need from a fiber field (solid where ``phi <= 0``).

    Attributes
    ----------
    bounds : tuple of ndarray (3,)
        Axis-aligned box (lo, hi) that contains every solid point of the field that lies
        inside the integration domain.
    """

    bounds: tuple[np.ndarray, np.ndarray]

    def values(self, points: np.ndarray) -> np.ndarray: ...

    def grid_values(self, axes: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray: ...

    def derivatives(
        self, points: np.ndarray, hessian: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]: ...


@numba.njit(cache=True)
def _derivs_kernel(
    pts, mu, kappa, H, alpha, minor_term, u, f, G, beta, want_hess
):  # pragma: no cover
    m = (mu, kappa, H, alpha, minor_term, u, f, G, beta)
    npts = pts.shape[0]
    val = np.zeros(npts)
    grad = np.zeros((npts, 3))
    hess = np.zeros((npts, 3, 3)) if want_hess else np.zeros((0, 3, 3))
    g = np.zeros(3)
    hs = np.zeros((3, 3))
    order = 2 if want_hess else 1
    for p in range(npts):
        val[p] = psi_point(m, pts[p, 0], pts[p, 1], pts[p, 2], g, hs, order)
        grad[p] = g
        if want_hess:
            hess[p] = hs
    return val, grad, hess


@numba.njit(cache=True)
def _value_kernel(pts, mu, kappa, H, alpha, minor_term, u, f, G, beta):  # pragma: no cover
    m = (mu, kappa, H, alpha, minor_term, u, f, G, beta)
    val = np.zeros(pts.shape[0])
    for p in range(pts.shape[0]):
        val[p] = psi_value(m, pts[p, 0], pts[p, 1], pts[p, 2])
    return val


def ps_values(model: GeneralizedPS, points: np.ndarray) -> np.ndarray:
    """Values of a generalized PS model at points (compiled; same as ``model.evaluate``)."""
    pts = np.ascontiguousarray(np.asarray(points, float).reshape(-1, 3))
    return _value_kernel(pts, *model_arrays(model))


def ps_derivatives(
    model: GeneralizedPS, points: np.ndarray, hessian: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Value, analytic gradient and analytic Hessian of a generalized PS model (compiled).

    Same result as :func:`ps_derivatives_numpy` (see there for the formulas).
    """
    pts = np.ascontiguousarray(np.asarray(points, float).reshape(-1, 3))
    v, g, h = _derivs_kernel(pts, *model_arrays(model), bool(hessian))
    return v, g, (h if hessian else None)


def ps_derivatives_numpy(
    model: GeneralizedPS, points: np.ndarray, hessian: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Value, analytic gradient and analytic Hessian of a generalized PS model.

    With ``Phi_i = 2 pi kappa_i (H_i . r + alpha_i) + sum_k u_k cos(theta_k)`` and
    ``theta_k = 2 pi f_k (G_k . r + beta_k)`` (minor terms k of major term i)::

        grad Phi_i  = 2 pi kappa_i H_i - sum_k u_k sin(theta_k) 2 pi f_k G_k
        hess Phi_i  = - sum_k u_k cos(theta_k) (2 pi f_k)^2 G_k G_k^T
        psi         = sum_i mu_i cos(Phi_i)
        grad psi    = - sum_i mu_i sin(Phi_i) grad Phi_i
        hess psi    = - sum_i mu_i [cos(Phi_i) grad Phi_i grad Phi_i^T + sin(Phi_i) hess Phi_i]

    Parameters
    ----------
    model : GeneralizedPS
    points : ndarray, shape (N, 3)
    hessian : bool
        Compute the Hessian (else None is returned for it).

    Returns
    -------
    value : ndarray (N,)
    gradient : ndarray (N, 3)
    hessian : ndarray (N, 3, 3)
    """
    pts = np.asarray(points, float).reshape(-1, 3)
    npts, n = len(pts), model.n_terms
    kh = TWO_PI * model.kappa[:, None] * model.H  # (n, 3)
    phase = pts @ kh.T + TWO_PI * model.kappa * model.alpha  # (N, n)
    dphi = np.empty((n, npts, 3))
    dphi[:] = kh[:, None, :]
    hphi: dict[int, np.ndarray] = {}
    if model.n_minor:
        fg = TWO_PI * model.f[:, None] * model.G  # (k, 3)
        theta = pts @ fg.T + TWO_PI * model.f * model.beta  # (N, k)
        ct, st = np.cos(theta) * model.u, np.sin(theta) * model.u
        for k, i in enumerate(model.minor_term):  # loop over the (few) minor terms
            phase[:, i] += ct[:, k]
            dphi[i] -= st[:, k, None] * fg[k]
            if hessian:
                gg = -np.outer(fg[k], fg[k])
                hk = ct[:, k, None, None] * gg
                hphi[i] = hphi[i] + hk if i in hphi else hk
    c, s = np.cos(phase) * model.mu, np.sin(phase) * model.mu  # (N, n)
    value = c.sum(axis=1)
    grad = np.zeros((npts, 3))
    hess = np.zeros((npts, 3, 3)) if hessian else None
    for i in range(n):  # loop over the (few) major terms
        grad -= s[:, i, None] * dphi[i]
        if hessian:
            hess -= c[:, i, None, None] * (dphi[i][:, :, None] * dphi[i][:, None, :])
            if i in hphi:
                hess -= s[:, i, None, None] * hphi[i]
    return value, grad, hess


def ps_term_tables(
    model: GeneralizedPS, axes: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> list[np.ndarray]:
    """Per-term values ``mu_i cos(Phi_i)`` of a PS model on the grid ``x (ij) y (ij) z``.

    Each term is evaluated only on the coordinates its basis vectors depend on: the
    arrays have length 1 along the other axes (broadcast shapes). Terms that depend on
    the same axes are summed into one table.
    """
    coords = [
        np.asarray(a, float).reshape(s)
        for a, s in zip(axes, ((-1, 1, 1), (1, -1, 1), (1, 1, -1)), strict=True)
    ]
    tables: dict[tuple[int, ...], np.ndarray] = {}
    for i in range(model.n_terms):
        phase: np.ndarray | float = TWO_PI * model.kappa[i] * model.alpha[i]
        for a in range(3):
            if model.H[i, a] != 0.0:
                phase = phase + (TWO_PI * model.kappa[i] * model.H[i, a]) * coords[a]
        for k in np.flatnonzero(model.minor_term == i):
            theta: np.ndarray | float = TWO_PI * model.f[k] * model.beta[k]
            for a in range(3):
                if model.G[k, a] != 0.0:
                    theta = theta + (TWO_PI * model.f[k] * model.G[k, a]) * coords[a]
            phase = phase + model.u[k] * np.cos(theta)
        term = np.asarray(model.mu[i] * np.cos(phase), float).reshape(
            np.broadcast_shapes(np.shape(phase), (1, 1, 1))
        )
        key = term.shape
        tables[key] = tables[key] + term if key in tables else term
    return list(tables.values())


def ps_grid_values(
    model: GeneralizedPS, axes: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> np.ndarray:
    """Evaluate a generalized PS model on the tensor grid ``x (ij) y (ij) z``.

    Sums the broadcast term tables of :func:`ps_term_tables`, so the cost is dominated by
    additions on the 3-D grid.
    """
    out = np.zeros(tuple(len(a) for a in axes))
    for t in ps_term_tables(model, axes):
        out += t
    return out


def term_groups(model: GeneralizedPS) -> tuple[np.ndarray, np.ndarray]:
    """Major terms grouped by the axes they depend on (for :func:`packed_tables`).

    Returns ``(deps, group)``: per group a 0/1 row (depends on x, y, z), per major term
    its group index. A term depends on an axis if its own or one of its minor terms'
    direction has a non-zero component along it.
    """
    Hnz = tuple(tuple(bool(v) for v in row) for row in (model.H != 0.0))
    Gnz = tuple(tuple(bool(v) for v in row) for row in (model.G != 0.0))
    return _term_groups(Hnz, Gnz, tuple(int(i) for i in model.minor_term))


@lru_cache(maxsize=64)
def _term_groups(Hnz: tuple, Gnz: tuple, minor_term: tuple) -> tuple[np.ndarray, np.ndarray]:
    """:func:`term_groups` from the non-zero patterns (memoized; read-only arrays)."""
    keys: dict[tuple[bool, ...], int] = {}
    group = np.empty(len(Hnz), dtype=np.int64)
    for i, hrow in enumerate(Hnz):
        dep = list(hrow)
        for k, term in enumerate(minor_term):
            if term == i:
                dep = [a or b for a, b in zip(dep, Gnz[k], strict=True)]
        group[i] = keys.setdefault(tuple(dep), len(keys))
    deps = np.array(list(keys), dtype=np.int64).reshape(-1, 3)
    deps.flags.writeable = False
    group.flags.writeable = False
    return deps, group


def packed_tables(
    model: GeneralizedPS,
    axes: tuple[np.ndarray, np.ndarray, np.ndarray],
    groups: tuple[np.ndarray, np.ndarray] | None = None,
    arrays: tuple | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Separable term tables of a PS model on a tensor grid, packed for
    :func:`.kernels.pair_max_grid`.

    Returns ``(flat, meta)``: per group of :func:`term_groups` the sum of its terms
    ``mu_i cos(Phi_i)`` on the axes the group depends on (broadcast along the others),
    concatenated, and per table its offset and its strides along x, y, z (0 where the
    table does not depend on the axis). ``groups`` / ``arrays`` may pass precomputed
    :func:`term_groups` / :func:`.kernels.model_arrays`.
    """
    deps, group = term_groups(model) if groups is None else groups
    ax = [np.ascontiguousarray(a, dtype=float) for a in axes]
    n = [len(a) for a in ax]
    rows = []
    off = 0
    for dx, dy, dz in deps.tolist():
        sx, sy, sz = (n[0] if dx else 1), (n[1] if dy else 1), (n[2] if dz else 1)
        rows.append((off, sy * sz if dx else 0, sz if dy else 0, 1 if dz else 0))
        off += sx * sy * sz
    meta = np.array(rows, dtype=np.int64).reshape(-1, 4)
    flat = fill_tables(
        model_arrays(model) if arrays is None else arrays,
        group,
        deps,
        meta,
        ax[0],
        ax[1],
        ax[2],
        max(off, 1),
    )
    return flat, meta


@dataclass(frozen=True)
class Tube:
    """Carrier axis of a fiber crossing the domain along a coordinate axis.

    Every cross-section of the solid by a plane perpendicular to ``direction`` must be
    star-shaped about the section's minimum of the field and lie within ``radius`` of the
    carrier axis.

    Parameters
    ----------
    point : array_like (3,)
        A point on the carrier axis.
    axis : int
        0, 1 or 2: the coordinate axis the fiber runs along.
    radius : float
        Bound on the distance of solid points from the carrier axis.
    """

    point: np.ndarray
    axis: int
    radius: float

    def __post_init__(self) -> None:
        if self.axis not in (0, 1, 2):
            raise ValueError(f"axis must be 0, 1 or 2, got {self.axis}")
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"radius must be positive, got {self.radius}")
        object.__setattr__(self, "point", np.asarray(self.point, float).reshape(3))

    def frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Right-handed orthonormal frame (e1, e2, d) with d along the axis."""
        return self._frame

    @cached_property
    def _frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        d = np.eye(3)[self.axis]
        e1 = np.eye(3)[(self.axis + 1) % 3]
        e2 = np.cross(d, e1)
        for v in (d, e1, e2):
            v.flags.writeable = False
        return e1, e2, d


@dataclass(frozen=True, eq=False)
class SharedTube:
    """A tube of a fiber given as a rigid copy of a tube of a shared local fiber.

    The fiber near the tube is ``phi(r) = local.phi(Q^T (r - offset))``: a proper
    rotation ``Q`` (a signed permutation, so exact in floating point) that maps the
    local tube axis onto the world tube axis, and an ``offset`` with no component along
    that axis (the axial coordinate is the same in both frames). Fibers that are
    translated or rotated copies of one shape (the woven fibers) carry the same
    ``local`` field and tube, so their tube quadrature is computed once
    (:func:`.tube.shared_fiber_sample`).

    Parameters
    ----------
    local : PSField
        The shared fiber in local coordinates.
    tube : Tube
        Its tube in local coordinates.
    rotation : array_like (3, 3)
        ``Q``.
    offset : array_like (3,)
    """

    local: PSField
    tube: Tube
    rotation: np.ndarray
    offset: np.ndarray

    def __post_init__(self) -> None:
        Q = np.asarray(self.rotation, float).reshape(3, 3)
        off = np.asarray(self.offset, float).reshape(3)
        perm = np.all(np.isin(Q, (-1.0, 0.0, 1.0))) and np.all(np.abs(Q).sum(axis=0) == 1)
        if not (perm and np.all(np.abs(Q).sum(axis=1) == 1) and np.linalg.det(Q) > 0):
            raise ValueError("rotation must be a proper signed permutation matrix")
        object.__setattr__(self, "rotation", Q)
        object.__setattr__(self, "offset", off)

    def world_axis(self) -> int:
        """The world axis the tube runs along."""
        return int(np.flatnonzero(self.rotation[:, self.tube.axis])[0])

    def key(self) -> tuple:
        """Content key of the local fiber and tube (equal keys: same local quadrature)."""
        f, t = self.local, self.tube
        return (
            *[a.tobytes() for a in f.arrays],
            float(f.isovalue),
            float(f.scale),
            t.point.tobytes(),
            t.axis,
            float(t.radius),
        )


@dataclass(frozen=True)
class PSField:
    """Fiber field ``phi = scale * (psi - isovalue)`` of a generalized PS model.

    Parameters
    ----------
    model : GeneralizedPS
        Placed model (normalized coordinates).
    isovalue : float
        Solid where ``psi <= isovalue``.
    bounds : tuple of array_like (3,)
        Axis-aligned box containing the fiber's solid inside the domain (its "tube").
    scale : float
        Positive factor on the field (1 = the paper's raw PS values).
    tubes : tuple of Tube, optional
        Carrier axes of the fiber's copies that enter the domain; enables the high-order
        tube quadrature of the surface integrals (else marching cubes is used).
    shared : tuple of SharedTube, optional
        One per tube: the tube as a rigid copy of a shared local fiber (its quadrature is
        then computed in local coordinates and reused by every copy with the same local
        fiber and tube).
    """

    model: GeneralizedPS
    isovalue: float
    bounds: tuple[np.ndarray, np.ndarray]
    scale: float = 1.0
    tubes: tuple[Tube, ...] = ()
    shared: tuple[SharedTube, ...] = ()

    def __post_init__(self) -> None:
        lo, hi = (np.asarray(b, float).reshape(3) for b in self.bounds)
        if not np.all(hi > lo):
            raise ValueError(f"bounds must satisfy hi > lo, got {lo}, {hi}")
        if not (np.isfinite(self.scale) and self.scale > 0):
            raise ValueError(f"scale must be positive, got {self.scale}")
        object.__setattr__(self, "bounds", (lo, hi))
        object.__setattr__(self, "tubes", tuple(self.tubes))
        object.__setattr__(self, "shared", tuple(self.shared))
        if self.shared and len(self.shared) != len(self.tubes):
            raise ValueError("shared must give one SharedTube per tube")
        for t, st in zip(self.tubes, self.shared, strict=False):
            if (
                st.world_axis() != t.axis
                or st.rotation[t.axis, st.tube.axis] != 1.0
                or st.offset[t.axis] != 0.0
            ):
                raise ValueError(
                    "a shared tube must run along its tube's axis with no axial offset"
                )

    @cached_property
    def groups(self) -> tuple[np.ndarray, np.ndarray]:
        """:func:`term_groups` of the model."""
        return term_groups(self.model)

    @cached_property
    def arrays(self) -> tuple:
        """The model's arrays for the compiled kernels (:func:`.kernels.model_arrays`)."""
        return model_arrays(self.model)

    def values(self, points: np.ndarray) -> np.ndarray:
        pts = np.ascontiguousarray(np.asarray(points, float).reshape(-1, 3))
        return self.scale * (_value_kernel(pts, *self.arrays) - self.isovalue)

    def grid_values(self, axes: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
        return self.scale * (ps_grid_values(self.model, axes) - self.isovalue)

    def derivatives(
        self, points: np.ndarray, hessian: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        pts = np.ascontiguousarray(np.asarray(points, float).reshape(-1, 3))
        v, g, h = _derivs_kernel(pts, *self.arrays, bool(hessian))
        h = h if hessian else None
        return (
            self.scale * (v - self.isovalue),
            self.scale * g,
            None if h is None else self.scale * h,
        )
