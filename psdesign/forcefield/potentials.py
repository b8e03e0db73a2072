"""The empirical force-field potentials of paper Sec. 6, with accurate quadrature.

For fibers with fields ``phi_j`` (solid where ``phi_j <= 0``) in a domain box:

* pair-wise volume interaction ``I_ij^(V) = - int_{phi_ij <= 0} phi_ij dV`` with
  ``phi_ij = max(phi_i, phi_j)`` (Eq. 8 for one pair), the depth-weighted overlap;
* surface interaction ``I_j^(S) = oint_{phi_j = 0} phi_(U j) dA`` with
  ``phi_(U j) = min_{k != j} phi_k`` (union of the other fibers, Eq. 7);
* surface potential ``S_j``: as printed, ``oint_{phi_j = 0} K dA`` (Gaussian curvature);
  alternatives: the area ``oint dA`` or the bending energy ``oint H^2 dA`` (mean
  curvature ``H``);
* total ``U = w1 sum_{i<j} I_ij^(V) + w2 sum_j I_j^(S) + w3 sum_j S_j``.

Quadrature. Volume integrals use the trapezoidal rule on a node grid of step ``<= h``
restricted to the overlap of the two fibers' bounding boxes (the integrand is Lipschitz
and vanishes on the boundary of the overlap, so the error is O(h^2)). Surface integrals
use a marching-cubes triangulation (scikit-image) of ``phi_j = 0`` on a node grid over the
fiber's bounding box and the vertex rule (the exact integral of the piecewise-linear
interpolant: every vertex carries a third of its triangles' areas); the integrand is
evaluated analytically at the vertex projected onto the surface by one Newton step
(fields of the other fibers) or at the vertex (curvatures from the analytic gradient
and Hessian). Both rules
converge at second order; see ``tests/test_forcefield.py`` and ``docs/forcefield.md``.

Surfaces are cut by the domain box (the paper integrates over the RVE), so for fibers
crossing the box ``S_j`` is not the topological ``2 pi chi`` of a closed surface: by
Gauss-Bonnet it equals ``2 pi chi - oint_{cut} k_g ds``, a boundary term.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
from skimage import measure

import solvers.jit  # noqa: F401  (numba cache stamps cover the imported modules)
from psdesign.forcefield.fields import ImplicitField, PSField, packed_tables
from psdesign.forcefield.kernels import deepest_point, lens_candidates, lens_minima, pair_max_grid
from psdesign.forcefield.memo import FiberMemo, domain_key, fiber_key
from psdesign.schema.forcefield import SURFACE_TERMS


@dataclass(frozen=True)
class SurfaceSample:
    """Quadrature of one fiber's surface inside the domain.

    Attributes
    ----------
    points : ndarray (m, 3)
        Mesh vertices projected onto ``phi = 0`` (one Newton step).
    weights : ndarray (m,)
        Vertex areas (a third of the incident triangle areas).
    gradient, hessian : ndarray (m, 3) and (m, 3, 3)
        Field derivatives at the (unprojected) vertices.
    verts, faces : ndarray
        The triangle mesh (for pictures).
    """

    points: np.ndarray
    weights: np.ndarray
    gradient: np.ndarray
    hessian: np.ndarray
    verts: np.ndarray = field(repr=False)
    faces: np.ndarray = field(repr=False)

    @property
    def area(self) -> float:
        return float(self.weights.sum())


def _check_domain(domain: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = (np.asarray(b, float).reshape(3) for b in domain)
    if not np.all(np.isfinite(lo)) or not np.all(hi > lo):
        raise ValueError(f"domain must be a box (lo, hi) with hi > lo, got {lo}, {hi}")
    return lo, hi


def _check_h(h: float) -> float:
    if not (np.isfinite(h) and 0 < h < 1):
        raise ValueError(f"h (grid step) must lie in (0, 1), got {h}")
    return float(h)


def node_axes(lo: np.ndarray, hi: np.ndarray, h: float) -> tuple[np.ndarray, ...]:
    """Node coordinates of a grid over [lo, hi] with step <= h (box faces are nodes)."""
    n = np.maximum(np.ceil((hi - lo) / h - 1e-9).astype(int), 1)
    return tuple(np.linspace(lo[a], hi[a], n[a] + 1) for a in range(3))


def _clip_box(fld: ImplicitField, lo: np.ndarray, hi: np.ndarray):
    blo = np.maximum(fld.bounds[0], lo)
    bhi = np.minimum(fld.bounds[1], hi)
    return blo, bhi


def surface_sample(
    fld: ImplicitField,
    domain: tuple[np.ndarray, np.ndarray],
    h: float,
    curvature: bool = True,
) -> SurfaceSample:
    """Triangulate ``phi = 0`` inside the domain and build its quadrature.

    ``curvature=False`` skips the Hessian (``hessian`` is then all zeros).

    Raises
    ------
    ValueError
        If the solid touches a face of the field's bounding box that is not a domain face
        (the bounds are too tight and the surface would be clipped).
    """
    lo, hi = _check_domain(domain)
    h = _check_h(h)
    blo, bhi = _clip_box(fld, lo, hi)
    empty = SurfaceSample(
        np.zeros((0, 3)),
        np.zeros(0),
        np.zeros((0, 3)),
        np.zeros((0, 3, 3)),
        np.zeros((0, 3)),
        np.zeros((0, 3), int),
    )
    if np.any(bhi <= blo):
        return empty
    axes = node_axes(blo, bhi, h)
    vals = fld.grid_values(axes)
    _check_not_clipped(vals, blo, bhi, lo, hi)
    if vals.min() >= 0.0 or vals.max() <= 0.0:
        return empty
    spacing = tuple(float(a[1] - a[0]) for a in axes)
    verts, faces, _, _ = measure.marching_cubes(vals, level=0.0, spacing=spacing)
    verts += blo
    tri = verts[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    # vertex rule: the integral of the piecewise-linear interpolant over the triangles
    w = np.bincount(faces.ravel(), weights=np.repeat(area / 3.0, 3), minlength=len(verts))
    keep = w > 0
    p = verts[keep]
    v, g, hs = fld.derivatives(p, hessian=curvature)
    # one Newton step onto phi = 0 (MC vertices are O(h^2) off the surface); the
    # derivatives are kept from the vertex (curvature error O(h^2), like the rule)
    g2 = np.einsum("ij,ij->i", g, g)
    p = p - (v / np.where(g2 > 0, g2, 1.0))[:, None] * g
    if hs is None:
        hs = np.zeros((len(p), 3, 3))
    return SurfaceSample(
        points=p, weights=w[keep], gradient=g, hessian=hs, verts=verts, faces=faces
    )


def _check_not_clipped(vals, blo, bhi, lo, hi) -> None:
    faces = [
        (vals[0], blo[0] > lo[0]),
        (vals[-1], bhi[0] < hi[0]),
        (vals[:, 0], blo[1] > lo[1]),
        (vals[:, -1], bhi[1] < hi[1]),
        (vals[:, :, 0], blo[2] > lo[2]),
        (vals[:, :, -1], bhi[2] < hi[2]),
    ]
    for face, interior in faces:
        if interior and face.min() <= 0.0:
            raise ValueError(
                "a fiber's solid reaches the edge of its bounds box; "
                "enlarge the field's bounds (tube radius)"
            )


@numba.njit(cache=True)
def _curvatures(g, hs):  # pragma: no cover
    n = g.shape[0]
    K = np.empty(n)
    Hm = np.empty(n)
    for p in range(n):
        a = hs[p]
        # adjugate of the symmetric Hessian
        c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
        c11 = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
        c22 = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        c01 = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
        c02 = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
        c12 = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
        x, y, z = g[p, 0], g[p, 1], g[p, 2]
        g2 = x * x + y * y + z * z
        num = (
            c00 * x * x
            + c11 * y * y
            + c22 * z * z
            + 2.0 * (c01 * x * y + c02 * x * z + c12 * y * z)
        )
        K[p] = num / (g2 * g2)
        ghg = (
            a[0, 0] * x * x
            + a[1, 1] * y * y
            + a[2, 2] * z * z
            + 2.0 * (a[0, 1] * x * y + a[0, 2] * x * z + a[1, 2] * y * z)
        )
        tr = a[0, 0] + a[1, 1] + a[2, 2]
        Hm[p] = (g2 * tr - ghg) / (2.0 * g2**1.5)
    return K, Hm


def gaussian_curvature(gradient: np.ndarray, hessian: np.ndarray) -> np.ndarray:
    """Gaussian curvature of the level set: ``K = g^T adj(Hs) g / |g|^4``."""
    return _curvatures(
        np.ascontiguousarray(gradient, dtype=float), np.ascontiguousarray(hessian, dtype=float)
    )[0]


def mean_curvature(gradient: np.ndarray, hessian: np.ndarray) -> np.ndarray:
    """Mean curvature ``(|g|^2 tr Hs - g^T Hs g) / (2 |g|^3)`` (1/R on a sphere)."""
    return _curvatures(
        np.ascontiguousarray(gradient, dtype=float), np.ascontiguousarray(hessian, dtype=float)
    )[1]


def _wsum(w: np.ndarray, g: np.ndarray) -> float:
    """``sum w * g`` without BLAS (a threaded BLAS dot stalls on a loaded machine)."""
    return float(np.einsum("i,i->", w, g))


def surface_term(sample: SurfaceSample, kind: str) -> float:
    """``S_j`` of one fiber: ``gaussian`` (paper), ``area`` or ``bending`` (int H^2 dA)."""
    if kind == "gaussian":
        return _wsum(sample.weights, gaussian_curvature(sample.gradient, sample.hessian))
    if kind == "area":
        return sample.area
    if kind == "bending":
        return _wsum(sample.weights, mean_curvature(sample.gradient, sample.hessian) ** 2)
    raise ValueError(f"surface_term must be one of {', '.join(SURFACE_TERMS)}; got {kind!r}")


def volume_interaction(
    fi: ImplicitField,
    fj: ImplicitField,
    domain: tuple[np.ndarray, np.ndarray],
    h: float,
    lens_guard: bool = True,
) -> float:
    """``I_ij^(V) = -int_{max(phi_i, phi_j) <= 0} max(phi_i, phi_j) dV`` (>= 0).

    Trapezoidal rule on a node grid of step ``<= h``. With ``lens_guard`` every local
    minimum of ``max(phi_i, phi_j)`` on the grid that lies within one grid slope of zero
    is polished to the exact deepest point of the overlap (Newton on
    ``grad phi_i + lam grad phi_j = 0, phi_i = phi_j``); if that point is inside both
    fibers, the integral over a box of half-size ``2 h`` centred on it is recomputed on a
    grid of step ``h / 4`` whose centre node is the deepest point. A thin overlap lens that
    falls between the coarse nodes is therefore detected (its value is then accurate to
    about a factor 2: the local box may truncate a wide, thin lens).

    Two :class:`PSField` s use the compiled kernels of :mod:`.kernels`; other fields the
    generic numpy path (same rule).
    """
    lo, hi = _check_domain(domain)
    h = _check_h(h)
    blo = np.maximum.reduce([fi.bounds[0], fj.bounds[0], lo])
    bhi = np.minimum.reduce([fi.bounds[1], fj.bounds[1], hi])
    if np.any(bhi <= blo):
        return 0.0
    axes = node_axes(blo, bhi, h)
    w = _trapezoid_weights(axes)
    m, total, slope = _pair_grid(fi, fj, axes, w)
    if not lens_guard:
        return total
    done: list[np.ndarray] = []
    for x in _lens_candidates(m, axes, slope=slope):
        p = _deepest_point(fi, fj, x, 4 * h)
        if p is None or not (np.all(p >= blo) and np.all(p <= bhi)):
            continue
        if any(np.max(np.abs(p - q)) < 4 * h for q in done):  # boxes must not overlap
            continue
        done.append(p)
        if max(fi.values(p[None])[0], fj.values(p[None])[0]) >= 0:
            continue
        total += _local_correction(fi, fj, p, axes, m, w, h)
    return max(total, 0.0)


def _trapezoid_weights(axes) -> list[np.ndarray]:
    w = [np.full(len(a), a[1] - a[0]) for a in axes]
    for wa in w:
        wa[0] *= 0.5
        wa[-1] *= 0.5
    return w


def _pair_grid(
    fi: ImplicitField, fj: ImplicitField, axes, w
) -> tuple[np.ndarray, float, float | None]:
    """``m = max(phi_i, phi_j)`` on the grid, ``int max(-m, 0) dV`` (weights ``w``) and the
    largest neighbour difference of ``m`` (None: not computed)."""
    if isinstance(fi, PSField) and isinstance(fj, PSField):
        fa, ma = packed_tables(fi.model, axes, fi.groups, fi.arrays)
        fb, mb = packed_tables(fj.model, axes, fj.groups, fj.arrays)
        m, total, slope = pair_max_grid(
            fa, ma, fi.isovalue, fi.scale, fb, mb, fj.isovalue, fj.scale, *w
        )
        return m, float(total), float(slope)
    m = np.maximum(fi.grid_values(axes), fj.grid_values(axes))
    depth = np.maximum(-m, 0.0)
    total = float(np.einsum("ijk,i,j,k->", depth, *w)) if depth.any() else 0.0
    return m, total, None


def _lens_candidates(
    m: np.ndarray, axes, max_n: int = 4, slope: float | None = None
) -> list[np.ndarray]:
    """Grid nodes that are local minima of m and within one grid slope of zero
    (the ``max_n`` deepest); ``slope`` is the largest neighbour difference if known."""
    m = np.ascontiguousarray(m)
    vals, idx = lens_candidates(m) if slope is None else lens_minima(m, slope)
    if len(vals) == 0:
        return []
    sel = idx[np.argsort(vals, kind="stable")[:max_n]]
    return [np.array([axes[a][s[a]] for a in range(3)]) for s in sel]


def _deepest_point(
    fi: ImplicitField, fj: ImplicitField, x0: np.ndarray, reach: float
) -> np.ndarray | None:
    """Minimax point of (phi_i, phi_j) within ``reach`` of x0, or None if Newton fails."""
    if isinstance(fi, PSField) and isinstance(fj, PSField):
        x, ok = deepest_point(
            fi.arrays,
            fi.isovalue,
            fi.scale,
            fj.arrays,
            fj.isovalue,
            fj.scale,
            np.asarray(x0, float).copy(),
            float(reach),
        )
        return x if ok else None
    x = np.asarray(x0, float).copy()
    _, gi, _ = fi.derivatives(x[None], hessian=False)
    _, gj, _ = fj.derivatives(x[None], hessian=False)
    lam = float(np.linalg.norm(gi) / max(np.linalg.norm(gj), 1e-30))
    for _ in range(30):
        vi, gi, hi_ = (a[0] for a in fi.derivatives(x[None]))
        vj, gj, hj = (a[0] for a in fj.derivatives(x[None]))
        F = np.concatenate([gi + lam * gj, [vi - vj]])
        J = np.zeros((4, 4))
        J[:3, :3] = hi_ + lam * hj
        J[:3, 3] = gj
        J[3, :3] = gi - gj
        try:
            step = np.linalg.solve(J, -F)
        except np.linalg.LinAlgError:
            return None
        x += step[:3]
        lam += step[3]
        if np.max(np.abs(step)) < 1e-12:
            break
    if not (lam > 0 and np.all(np.isfinite(x))) or np.linalg.norm(x - x0) > reach:
        return None
    return x


def _local_correction(fi, fj, p, axes, m, w, h) -> float:
    """Fine-minus-coarse integral over the box p +- 2h (fine step h/4, centre node p)."""
    half = 2.0 * h
    fine = np.linspace(-half, half, 17)
    fax = tuple(p[a] + fine for a in range(3))
    lo = np.array([a[0] for a in axes])
    hi = np.array([a[-1] for a in axes])
    fax = tuple(f[(f >= lo[a]) & (f <= hi[a])] for a, f in enumerate(fax))
    if min(len(f) for f in fax) < 2:
        return 0.0
    step = fine[1] - fine[0]
    wf = [np.full(len(f), step) for f in fax]
    for wa in wf:
        wa[0] *= 0.5
        wa[-1] *= 0.5
    _, fine_int, _ = _pair_grid(fi, fj, fax, wf)
    box_lo = np.array([f[0] for f in fax])
    box_hi = np.array([f[-1] for f in fax])
    sel = [np.flatnonzero((a > box_lo[k]) & (a < box_hi[k])) for k, a in enumerate(axes)]
    if min(len(s) for s in sel) == 0:
        coarse = 0.0
    else:
        sub = np.maximum(-m[np.ix_(*sel)], 0.0)
        coarse = float(np.einsum("ijk,i,j,k->", sub, *(w[k][s] for k, s in enumerate(sel))))
    return fine_int - coarse


def overlap_volume(
    fi: ImplicitField, fj: ImplicitField, domain: tuple[np.ndarray, np.ndarray], h: float
) -> float:
    """Volume of ``{phi_i <= 0} cap {phi_j <= 0}`` (trapezoid rule on the indicator, O(h))."""
    lo, hi = _check_domain(domain)
    h = _check_h(h)
    blo = np.maximum.reduce([fi.bounds[0], fj.bounds[0], lo])
    bhi = np.minimum.reduce([fi.bounds[1], fj.bounds[1], hi])
    if np.any(bhi <= blo):
        return 0.0
    axes = node_axes(blo, bhi, h)
    inside = (np.maximum(fi.grid_values(axes), fj.grid_values(axes)) <= 0).astype(float)
    w = [np.full(len(a), a[1] - a[0]) for a in axes]
    for wa in w:
        wa[0] *= 0.5
        wa[-1] *= 0.5
    return float(np.einsum("ijk,i,j,k->", inside, *w))


def surface_interaction(sample: SurfaceSample, others: list[ImplicitField]) -> float:
    """``I_j^(S) = oint phi_(U j) dA`` over one fiber's surface sample."""
    if not others or len(sample.weights) == 0:
        return 0.0
    union = np.min([o.values(sample.points) for o in others], axis=0)
    return _wsum(sample.weights, union)


@dataclass(frozen=True)
class Potentials:
    """The force-field energy and its parts.

    Attributes
    ----------
    U : float
        ``w1 * volume + w2 * surface_interaction + w3 * surface``.
    volume, surface_interaction, surface : float
        ``sum_{i<j} I_ij^(V)``, ``sum_j I_j^(S)``, ``sum_j S_j``.
    area : float
        Total fiber surface area in the domain (always reported).
    per_fiber_surface : tuple of float
        ``S_j`` per fiber.
    """

    U: float
    volume: float
    surface_interaction: float
    surface: float
    area: float
    per_fiber_surface: tuple[float, ...]

    def to_dict(self) -> dict:
        return {
            "U": self.U,
            "volume_interaction": self.volume,
            "surface_interaction": self.surface_interaction,
            "surface": self.surface,
            "area": self.area,
            "per_fiber_surface": list(self.per_fiber_surface),
        }


#: Factor of a bar from a FINER reference (``reference="finer"``): Roache's safety factor
#: F_s = 3 on the working value's two-grid estimate ``|U(h) - U(h/2)| r^p / (r^p - 1)`` with
#: ``r = 2, p = 2`` (that value's own error is ~1/4 of ``h``'s), i.e. ``3 * 4/3 = 4``.
FINER_SAFETY = 4.0


def quadrature_error(
    fine: Potentials, coarse: Potentials, weights, reference: str = "coarser"
) -> dict:
    """Error bar of each term of ``fine`` from one evaluation at a coarser quadrature.

    Each term's bar is ``|fine - coarse|`` (no Richardson division: for a second-order rule
    that is 3x the fine value's leading-order error, for a spectral one far more); ``U``'s bar
    is ``sum_k w_k`` times its terms' bars (triangle inequality). Checked against closed forms
    and a 4x finer quadrature in ``tests/unit/test_forcefield.py`` (docs/forcefield.md).

    Parameters
    ----------
    fine, coarse : Potentials
        The same fibers at the working quadrature and at the coarser one (``h -> 2 h``,
        ``n_s, n_theta`` halved: ``ForceFieldProblem.potential_error`` in ``cases.py``).
    weights : (w1, w2, w3)
    reference : {"coarser", "finer"}
        ``"finer"``: ``coarse`` is instead a FINER evaluation (``h -> h/2``; the field relax
        route, ``contact.field_potential_error``) and ``fine`` the value reported; each bar is
        then ``FINER_SAFETY * |fine - coarse|`` (Roache's F_s = 3 on the two-grid estimate).

    Returns
    -------
    dict
        The keys of :meth:`Potentials.to_dict`, each the bar of that value (>= 0).
    """
    if reference not in ("coarser", "finer"):
        raise ValueError(f"reference must be 'coarser' or 'finer', got {reference!r}")
    s = FINER_SAFETY if reference == "finer" else 1.0
    w = check_weights(weights)
    a, b = fine.to_dict(), coarse.to_dict()
    err = {
        k: s * abs(a[k] - b[k]) for k in ("volume_interaction", "surface_interaction", "surface")
    }
    err["area"] = s * abs(fine.area - coarse.area)
    err["per_fiber_surface"] = [
        s * abs(x - y)
        for x, y in zip(fine.per_fiber_surface, coarse.per_fiber_surface, strict=True)
    ]
    terms = (err["volume_interaction"], err["surface_interaction"], err["surface"])
    return {"U": float(np.dot(w, terms)), **err}


def check_weights(weights) -> np.ndarray:
    """Validate the weights (w1, w2, w3): finite, >= 0, not all zero."""
    w = np.asarray(weights, float)
    if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w > 0):
        raise ValueError(
            f"weights must be three finite non-negative numbers, not all zero; got {weights}"
        )
    return w


def total_potential(
    fields: list[ImplicitField],
    domain: tuple[np.ndarray, np.ndarray],
    h: float,
    weights=(1e10, 1.0, 1.0),
    surface: str = "gaussian",
    n_s: int = 64,
    n_theta: int = 32,
    memo: FiberMemo | None = None,
) -> Potentials:
    """Evaluate ``U`` and its parts for a set of fiber fields.

    Surface integrals use the tube quadrature (:func:`psdesign.forcefield.tube.tube_sample`,
    ``n_s`` x ``n_theta`` nodes) for fields that carry ``tubes``, else
    marching cubes on a grid of step ``h``. For tubes the printed Gaussian-curvature term
    is evaluated exactly through Gauss-Bonnet from the two end curves
    (:func:`psdesign.forcefield.tube.gauss_bonnet_ends`).

    Parameters
    ----------
    fields : list of ImplicitField
    domain : (lo, hi)
        Integration box (normalized coordinates; the paper's RVE is the unit cube).
    h : float
        Grid step of the volume and marching-cubes grids.
    n_s, n_theta : int
        Tube quadrature nodes along and around each fiber.
    weights : (w1, w2, w3)
    surface : {"gaussian", "area", "bending"}
        The surface potential: Gaussian curvature (as printed), area, or bending energy.
    memo : FiberMemo, optional
        Reuse the surface quadrature and ``S_j`` of fibers seen before with the same
        content (:mod:`.memo`).
    """
    w = check_weights(weights)
    if surface not in SURFACE_TERMS:
        raise ValueError(f"surface must be one of {', '.join(SURFACE_TERMS)}; got {surface!r}")
    n = len(fields)
    vol = 0.0
    if w[0] > 0:
        for i in range(n):
            for j in range(i + 1, n):
                vol += volume_interaction(fields[i], fields[j], domain, h)
    from psdesign.forcefield.tube import fiber_gaussian_term, fiber_sample, shared_fiber_sample

    curv = surface == "bending"
    memo = FiberMemo() if memo is None else memo

    def own(f: ImplicitField) -> tuple[SurfaceSample, float]:
        """One fiber's surface quadrature and surface potential S_j."""
        tube_gauss = surface == "gaussian" and getattr(f, "tubes", ())
        ends = None
        if getattr(f, "shared", ()):
            s, ends = shared_fiber_sample(f, domain, n_s, n_theta, curv, bool(tube_gauss), memo)
        elif getattr(f, "tubes", ()):
            s = fiber_sample(f, domain, n_s, n_theta, curv)
        else:
            s = surface_sample(f, domain, h, surface != "area")
        return s, (
            fiber_gaussian_term(f, domain, s, ends=ends) if tube_gauss else surface_term(s, surface)
        )

    dkey = domain_key(domain)
    parts = [
        memo.get(fiber_key(f, dkey, h, n_s, n_theta, surface), lambda f=f: own(f)) for f in fields
    ]
    samples = [s for s, _ in parts]
    inter = (
        sum(surface_interaction(s, fields[:j] + fields[j + 1 :]) for j, s in enumerate(samples))
        if w[1] > 0
        else 0.0
    )
    per = tuple(float(v) for _, v in parts)
    surf = float(sum(per))
    area = float(sum(s.area for s in samples))
    U = float(w[0] * vol + w[1] * inter + w[2] * surf)
    return Potentials(
        U=U,
        volume=vol,
        surface_interaction=float(inter),
        surface=surf,
        area=area,
        per_fiber_surface=per,
    )
