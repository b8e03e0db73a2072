"""High-order surface quadrature for tube-like fibers.

A fiber crossing the domain along a coordinate axis ``d`` is parametrized by the axial
coordinate ``s`` and the polar angle ``theta`` of a ray in the cross-section plane from
the section's field minimum ``c(s)``: ``X = c(s) + rho(s, theta) e(theta)``, with
``phi(X) = 0``. Because ``c(s) - c(s0)`` stays in the cross-section plane, the volume
Jacobian of ``(s, rho, theta)`` is ``rho`` and the area element is (coarea formula)

    dA = rho |grad phi| / |grad phi . e| ds dtheta .

The integral over ``theta`` uses the trapezoidal rule (spectrally accurate for the
periodic integrand), the integral over ``s`` Gauss-Legendre nodes on the domain's extent;
the box faces perpendicular to ``d`` cut the tube exactly. Roots ``rho`` are bracketed by
sampling the ray and refined by safeguarded Newton iterations using the analytic
gradient.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from psdesign.forcefield.fields import NoFiberError, PSField, SharedTube, Tube
from psdesign.forcefield.kernels import (
    BEYOND_RADIUS,
    NO_SOLID,
    NOT_CONVERGED,
    section_centres,
    section_roots,
)
from psdesign.forcefield.memo import FiberMemo
from psdesign.forcefield.potentials import SurfaceSample

_NEWTON_ITERS = 30


@lru_cache(maxsize=32)
def _gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.polynomial.legendre.leggauss(n)


def _centres(fld: PSField, base: np.ndarray, e1: np.ndarray, e2: np.ndarray) -> np.ndarray:
    """Minimum of the field in each cross-section plane (2-D Newton from ``base``)."""
    if isinstance(fld, PSField):
        return section_centres(
            fld.arrays,
            np.ascontiguousarray(base, dtype=float),
            np.asarray(e1, float),
            np.asarray(e2, float),
        )
    c = base.copy()
    P = np.stack([e1, e2])  # (2, 3)
    for _ in range(12):
        _, g, hs = fld.derivatives(c)
        g2 = g @ P.T  # (n, 2) plane gradient
        h2 = np.einsum("ia,nab,jb->nij", P, hs, P)
        det = h2[:, 0, 0] * h2[:, 1, 1] - h2[:, 0, 1] * h2[:, 1, 0]
        ok = det > 0
        step = np.zeros_like(g2)
        step[ok, 0] = (h2[ok, 1, 1] * g2[ok, 0] - h2[ok, 0, 1] * g2[ok, 1]) / det[ok]
        step[ok, 1] = (h2[ok, 0, 0] * g2[ok, 1] - h2[ok, 1, 0] * g2[ok, 0]) / det[ok]
        # gradient descent fallback where the plane Hessian is not positive definite
        step[~ok] = 1e-3 * g2[~ok] / np.maximum(np.linalg.norm(g2[~ok], axis=1), 1e-30)[:, None]
        c = c - step @ P
        if np.max(np.abs(step)) < 1e-12:
            break
    return c


def fiber_sample(
    fld: PSField,
    domain: tuple[np.ndarray, np.ndarray],
    n_s: int,
    n_theta: int,
    curvature: bool = True,
) -> SurfaceSample:
    """Tube quadrature over every copy (tube) of a fiber inside the domain."""
    if not fld.tubes:
        raise ValueError("fiber_sample needs a field with tube descriptions")
    for tube in fld.tubes:
        check_continuous(fld, domain, tube, max(128, 4 * n_s))
    parts = [tube_sample(fld, domain, n_s, n_theta, curvature, tube) for tube in fld.tubes]
    if len(parts) == 1:
        return parts[0]
    return SurfaceSample(
        points=np.concatenate([p.points for p in parts]),
        weights=np.concatenate([p.weights for p in parts]),
        gradient=np.concatenate([p.gradient for p in parts]),
        hessian=np.concatenate([p.hessian for p in parts]),
        verts=np.zeros((0, 3)),
        faces=np.zeros((0, 3), int),
    )


def _sections(fld: PSField, tube: Tube, s: np.ndarray, n_theta: int):
    """Surface points of the cross-sections at axial coordinates ``s``.

    Returns ``(C, E, rho, e)``: ray origins (section minima) and directions per node
    (section-major, ``n_theta`` angles each), root distances, and the angle directions.
    """
    e1, e2, d = tube.frame()
    a = tube.axis
    base = tube.point + np.outer(s - tube.point[a], d)
    c = _centres(fld, base, e1, e2)
    th = np.arange(n_theta) * (2 * np.pi / n_theta)
    e = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2  # (m, 3)
    C = np.repeat(c, n_theta, axis=0)
    E = np.tile(e, (len(s), 1))
    if isinstance(fld, PSField):
        rho, _, status = section_roots(
            fld.arrays,
            float(fld.isovalue),
            float(fld.scale),
            c,
            np.ascontiguousarray(e),
            float(tube.radius),
            _NEWTON_ITERS,
        )
        _raise_status(status)
        return C, E, rho, e
    vc = fld.values(c)
    if np.any(vc >= 0):
        _raise_status(NO_SOLID)
    npts = len(C)
    # bracket [0, radius]; start from the quadratic model of the field at the centre
    v_out = fld.values(C + tube.radius * E)
    if np.any(v_out <= 0):
        _raise_status(BEYOND_RADIUS)
    _, _, hc = fld.derivatives(c)
    curv = np.einsum("ma,nab,mb->nm", e, hc, e).ravel()  # e^T H e per (section, angle)
    vcr = np.repeat(vc, n_theta)
    rho = np.sqrt(-2.0 * vcr / np.where(curv > 0, curv, np.inf))
    rho = np.clip(
        np.where(np.isfinite(rho) & (rho > 0), rho, 0.5 * tube.radius),
        1e-6 * tube.radius,
        0.999 * tube.radius,
    )
    r_lo = np.zeros(npts)
    r_hi = np.full(npts, tube.radius)
    for _ in range(_NEWTON_ITERS):
        v, g, _ = fld.derivatives(C + rho[:, None] * E, hessian=False)
        dv = np.einsum("ij,ij->i", g, E)
        # keep the bracket; Newton step if it stays inside, else bisection
        inside = v <= 0
        r_lo = np.where(inside, rho, r_lo)
        r_hi = np.where(inside, r_hi, rho)
        newton = rho - v / np.where(dv != 0, dv, np.inf)
        ok = (newton > r_lo) & (newton < r_hi) & (dv > 0)
        rho_new = np.where(ok, newton, 0.5 * (r_lo + r_hi))
        done = np.max(np.abs(rho_new - rho)) < 1e-10
        rho = rho_new
        if done:
            break
    else:
        if np.max(np.abs(v)) > 1e-8 * max(1.0, float(np.abs(vc).max())):
            _raise_status(NOT_CONVERGED)
    return C, E, rho, e


def _raise_status(status: int) -> None:
    """Raise the error a :func:`.kernels.section_roots` status code stands for."""
    if status == NO_SOLID:
        raise NoFiberError(
            "a cross-section of the fiber has no solid (field minimum >= 0); "
            "the fiber breaks inside the domain"
        )
    if status == BEYOND_RADIUS:
        raise ValueError(
            "a fiber's surface lies farther than its tube radius from the axis; "
            "enlarge the tube radius"
        )
    if status == NOT_CONVERGED:
        raise ValueError("tube quadrature: surface root finding did not converge")


#: A fiber whose thinnest cross-section has a field depth below the isovalue (``-phi`` at the
#: section's minimum) under this fraction of its median section's depth counts as broken
#: (:class:`NoFiberError`, U = +inf). Near a section's minimum the field is a quadratic well,
#: so the section's area is proportional to that depth (area = 2 pi depth / sqrt(det H)):
#: 0.25 is a neck of about a quarter of the fiber's typical area, half its width. Without it
#: only a section with no solid at all was refused, and the six-fiber "area" optimum thinned
#: its woven fibers to a neck of depth 1.7e-5 of the median (area 0 on a 200^2 grid: pinched
#: lobes, walk-paper, session 53); the bending optimum's thinnest section keeps 0.81.
NECK_DEPTH_FRACTION = 0.25


def check_continuous(
    fld: PSField, domain: tuple[np.ndarray, np.ndarray], tube: Tube, n_check: int = 256
) -> None:
    """Raise :class:`NoFiberError` if the fiber pinches off, or nearly, along the domain.

    The section minimum of the field is found on ``n_check`` equally spaced sections
    (the quadrature nodes alone could straddle a break); a section without solid means
    the fiber breaks into pieces there, and a section shallower than
    :data:`NECK_DEPTH_FRACTION` of the median section's depth is a neck the fiber is
    refused for too. Necks thinner than the ``n_check`` sections resolve are not detected.
    """
    lo, hi = (np.asarray(b, float) for b in domain)
    a = tube.axis
    e1, e2, d = tube.frame()
    s = np.linspace(lo[a], hi[a], n_check)
    c = _centres(fld, tube.point + np.outer(s - tube.point[a], d), e1, e2)
    depth = -fld.values(c)
    if np.any(depth <= 0):
        raise NoFiberError("the fiber pinches off inside the domain (a cross-section has no solid)")
    if depth.min() < NECK_DEPTH_FRACTION * np.median(depth):
        raise NoFiberError(
            f"the fiber nearly pinches off inside the domain: its thinnest cross-section has "
            f"{depth.min() / np.median(depth):.3g} of its median section's depth (below "
            f"NECK_DEPTH_FRACTION = {NECK_DEPTH_FRACTION})"
        )


def tube_sample(
    fld: PSField,
    domain: tuple[np.ndarray, np.ndarray],
    n_s: int,
    n_theta: int,
    curvature: bool = True,
    tube: Tube | None = None,
) -> SurfaceSample:
    """Quadrature of the fiber surface ``phi = 0`` inside the domain.

    Parameters
    ----------
    fld : PSField
        The fiber field.
    domain : (lo, hi)
    n_s, n_theta : int
        Gauss-Legendre nodes along the axis and trapezoid nodes around it.
    curvature : bool
        Compute the Hessian (for curvature integrands).
    tube : Tube, optional
        The copy to integrate (default: the field's first tube).

    Raises
    ------
    ValueError
        If a ray does not leave the solid within the tube radius, or the field
        minimum of a section is not inside the solid.
    """
    tube = _pick_tube(fld, tube)
    lo, hi = (np.asarray(b, float) for b in domain)
    X, w, g, hs = _tube_nodes(fld, tube, lo[tube.axis], hi[tube.axis], n_s, n_theta, curvature)
    return _cut(X, w, g, hs, lo, hi)


def _tube_nodes(
    fld: PSField, tube: Tube, s_lo: float, s_hi: float, n_s: int, n_theta: int, curvature: bool
):
    """Nodes, weights, gradients and Hessians (None without ``curvature``) of the tube
    quadrature between the axial coordinates ``s_lo`` and ``s_hi`` (no lateral cut)."""
    if n_s < 2 or n_theta < 3:
        raise ValueError(f"need n_s >= 2 and n_theta >= 3, got {n_s}, {n_theta}")
    xg, wg = _gauss_legendre(n_s)
    s = s_lo + (xg + 1.0) * 0.5 * (s_hi - s_lo)
    ws = wg * 0.5 * (s_hi - s_lo)
    C, E, rho, _ = _sections(fld, tube, s, n_theta)
    X = C + rho[:, None] * E
    _, g, hs = fld.derivatives(X, hessian=curvature)
    gn = np.linalg.norm(g, axis=1)
    ge = np.abs(np.einsum("ij,ij->i", g, E))
    w = rho * gn / ge * np.repeat(ws, n_theta) * (2 * np.pi / n_theta)
    return X, w, g, hs


def _cut(X, w, g, hs, lo, hi) -> SurfaceSample:
    """Sample with the weights of nodes outside the domain's lateral faces set to zero."""
    # parts of a copy outside the domain's lateral faces do not count (first-order cut)
    outside = np.any((X < lo - 1e-12) | (X > hi + 1e-12), axis=1)
    w = w.copy()
    w[outside] = 0.0
    if hs is None:
        hs = np.zeros((len(X), 3, 3))
    return SurfaceSample(
        points=X,
        weights=w,
        gradient=g,
        hessian=hs,
        verts=np.zeros((0, 3)),
        faces=np.zeros((0, 3), int),
    )


def _local_domain(st: SharedTube, s_lo: float, s_hi: float):
    """A domain in the local frame with the world axial extent along the local axis (the
    other extents are not used by the tube routines)."""
    lo, hi = np.zeros(3), np.ones(3)
    lo[st.tube.axis], hi[st.tube.axis] = s_lo, s_hi
    return lo, hi


def _shared_part(
    st: SharedTube, s_lo: float, s_hi: float, n_s: int, n_theta: int, curvature: bool, gauss: bool
) -> tuple:
    """Local quadrature of a shared tube: ``(X, w, g, hs, int K dA or None)``."""
    dom = _local_domain(st, s_lo, s_hi)
    check_continuous(st.local, dom, st.tube, max(128, 4 * n_s))
    X, w, g, hs = _tube_nodes(st.local, st.tube, s_lo, s_hi, n_s, n_theta, curvature)
    gb = gauss_bonnet_ends(st.local, dom, 256, st.tube) if gauss else None
    return X, w, g, hs, gb


def shared_fiber_sample(
    fld: PSField,
    domain: tuple[np.ndarray, np.ndarray],
    n_s: int,
    n_theta: int,
    curvature: bool = True,
    gauss: bool = False,
    memo: FiberMemo | None = None,
) -> tuple[SurfaceSample, float | None]:
    """Tube quadrature of a fiber whose tubes are rigid copies (``fld.shared``).

    Each tube's nodes, weights and derivatives are computed in the local frame of its
    :class:`.fields.SharedTube` (once per local fiber, tube, axial extent and settings
    when ``memo`` is given: copies of one shape share the work) and mapped to the world
    frame; then the lateral cut of :func:`tube_sample` is applied. Returns the sample and,
    with ``gauss``, the Gauss-Bonnet end term ``sum int K dA`` over the tubes (see
    :func:`gauss_bonnet_ends`; the value does not change under a proper rigid motion).

    The result equals :func:`fiber_sample` (and :func:`gauss_bonnet_ends`) of ``fld`` up to
    round-off; the angle nodes are the local ones mapped by the rotation, the same node
    set when ``n_theta`` is a multiple of 4.
    """
    if not fld.shared:
        raise ValueError("shared_fiber_sample needs a field with shared tubes")
    lo, hi = (np.asarray(b, float) for b in domain)
    memo = FiberMemo(len(fld.shared)) if memo is None else memo
    Xs, ws, gs, hss, gb = [], [], [], [], 0.0
    for t, st in zip(fld.tubes, fld.shared, strict=True):
        a = t.axis
        s_lo, s_hi = float(lo[a]), float(hi[a])
        key = ("shared-tube", st.key(), s_lo, s_hi, n_s, n_theta, bool(curvature), bool(gauss))
        X, w, g, hs, ends = memo.get(
            key,
            lambda st=st, s_lo=s_lo, s_hi=s_hi: _shared_part(
                st, s_lo, s_hi, n_s, n_theta, curvature, gauss
            ),
        )
        Q = st.rotation
        Xs.append(X @ Q.T + st.offset)
        ws.append(w)
        gs.append(g @ Q.T)
        hss.append(None if hs is None else np.einsum("ik,nkl,jl->nij", Q, hs, Q))
        gb = gb + ends if gauss else None
    X = np.concatenate(Xs)
    hs = None if hss[0] is None else np.concatenate(hss)
    return _cut(X, np.concatenate(ws), np.concatenate(gs), hs, lo, hi), gb


def _pick_tube(fld: PSField, tube: Tube | None) -> Tube:
    if tube is not None:
        return tube
    if not fld.tubes:
        raise ValueError("tube quadrature needs a tube (or a field with tubes)")
    return fld.tubes[0]


def gauss_bonnet_ends(
    fld: PSField,
    domain: tuple[np.ndarray, np.ndarray],
    n_theta: int = 256,
    tube: Tube | None = None,
) -> float:
    """``int K dA`` over the tube inside the domain, from its two end curves.

    The tube between the domain faces perpendicular to its axis is a topological
    cylinder (Euler characteristic 0), so Gauss-Bonnet gives
    ``int K dA = - oint k_g ds`` over the two cut curves. With the section curve
    ``gamma(theta) = c + rho(theta) e(theta)`` (``theta`` counter-clockwise about the axis
    ``d``), unit normal ``N`` and tangent ``T``, ``k_g ds = gamma'' . (N x T) / |gamma'| dtheta``
    and ``int K dA = oint_far - oint_near`` of that form (the two ends are traversed in
    opposite senses relative to the surface). ``rho`` is differentiated
    spectrally (FFT). Exact for a surface of revolution: ``-2 pi [r' / sqrt(1 + r'^2)]``.
    """
    tube = _pick_tube(fld, tube)
    lo, hi = (np.asarray(b, float) for b in domain)
    a = tube.axis
    C, E, rho, e = _sections(fld, tube, np.array([lo[a], hi[a]]), n_theta)
    e1, e2, d = tube.frame()
    th = np.arange(n_theta) * (2 * np.pi / n_theta)
    ep = -np.sin(th)[:, None] * e1 + np.cos(th)[:, None] * e2  # de/dtheta
    k = np.fft.rfftfreq(n_theta, 1.0 / n_theta)
    total = 0.0
    for j, sign in ((0, -1.0), (1, 1.0)):
        r = rho[j * n_theta : (j + 1) * n_theta]
        rf = np.fft.rfft(r)
        if n_theta % 2 == 0:
            rf1 = 1j * k * rf
            rf1[-1] = 0.0
        else:
            rf1 = 1j * k * rf
        r1 = np.fft.irfft(rf1, n_theta)
        r2 = np.fft.irfft(-(k**2) * rf, n_theta)
        g1 = r1[:, None] * e + r[:, None] * ep
        g2 = (r2 - r)[:, None] * e + 2 * r1[:, None] * ep
        X = C[j * n_theta : (j + 1) * n_theta] + r[:, None] * e
        _, g, _ = fld.derivatives(X, hessian=False)
        N = g / np.linalg.norm(g, axis=1)[:, None]
        sp = np.linalg.norm(g1, axis=1)
        T = g1 / sp[:, None]
        kg = np.einsum("ij,ij->i", g2, np.cross(N, T)) / sp
        total += sign * kg.sum() * (2 * np.pi / n_theta)
    return float(total)


def fiber_gaussian_term(
    fld: PSField,
    domain: tuple[np.ndarray, np.ndarray],
    sample: SurfaceSample,
    n_theta_ends: int = 256,
    ends: float | None = None,
) -> float:
    """The printed ``S_j = int K dA`` of a tube fiber, via :func:`gauss_bonnet_ends`
    (``ends``: that sum over the tubes, if already known).

    Falls back to the area quadrature ``sample`` when a copy is cut by a domain face
    parallel to its axis (the cut would add boundary the end formula ignores). A sample
    built without Hessians (``curvature=False``, the usual case for this term) gets them
    evaluated at its nodes for the fallback.
    """
    lo, hi = (np.asarray(b, float) for b in domain)
    if np.any((sample.points < lo - 1e-12) | (sample.points > hi + 1e-12)):
        from psdesign.forcefield.potentials import _wsum, gaussian_curvature

        hs = sample.hessian
        if hs is None or not np.any(hs):
            _, _, hs = fld.derivatives(sample.points, hessian=True)
        kappa = gaussian_curvature(sample.gradient, hs)
        return _wsum(sample.weights, kappa)
    if ends is not None:
        return float(ends)
    return float(sum(gauss_bonnet_ends(fld, domain, n_theta_ends, t) for t in fld.tubes))
