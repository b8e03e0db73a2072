"""Steady conduction / diffusion ``div(sigma grad T) = 0`` on a voxel grid: fields and fluxes.

Knows nothing of fibres: a voxel array of non-negative cell conductivities in, the potential
and the fluxes out (the effective property is formed by the caller, e.g.
:mod:`psdesign.transport`).

Discretisation
--------------
Cell-centred, flux-conservative finite volumes in voxel units (``h = 1``).  The conductance of
the face between two cells is the harmonic mean ``2 s1 s2 / (s1 + s2)`` of their conductivities
(series resistance of two half cells; 0 when either is 0, so a zero-conductivity phase is an
insulating wall with zero normal flux on the voxel faces: the pore-diffusion case).  The scheme
is exact for layered media normal to an axis and for straight channels along it.

Boundary conditions along the driving axis ``a``:

* ``"periodic"``: periodic on every face, unit mean gradient: ``T = phi - x_a`` with ``phi``
  periodic.  The mean flux vector over the whole box is column ``a`` of the effective tensor
  (three solves give the full tensor).
* ``"fixed"`` (alias ``"permeameter"``): ``T = 1`` on the inlet face ``x_a = 0`` and ``T = 0`` on
  the outlet face ``x_a = n_a`` (half-cell conductance ``2 s`` to the face), zero flux through
  the four lateral faces (insulated sides, like a through-plane cell).

Solver
------
Conjugate gradients in float64 on the symmetric positive (semi-)definite matrix-free 7-point
operator, preconditioned by one symmetric V-cycle of the aggregation multigrid of the voxel
Stokes solver (:class:`solvers.voxel.multigrid.ScalarMG`, Galerkin coarse operators, float32).
Conducting clusters that carry no flux are dropped first (``"fixed"``: clusters not touching
both the inlet and the outlet face; they are at a constant potential and make the operator
singular).  With periodic faces the operator keeps one constant null vector per cluster; the
right-hand side is consistent (a discrete divergence) and the preconditioner is built on the
operator plus a tiny diagonal shift (``1e-6`` of the largest diagonal), which CG tolerates.

A blocked direction (no conducting path from inlet to outlet) returns zero fluxes,
``blocked=True`` and a message; never NaN.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from solvers.progress import PROGRESS_EVERY
from solvers.transport import kernels as tk

BCS = ("periodic", "fixed", "permeameter")
#: Relative shift of the preconditioner's diagonal for the (singular) periodic operator.
PERIODIC_SHIFT = 1e-6
#: A periodic solve whose mean flux is below this fraction of the arithmetic-mean face
#: conductance (the Wiener upper bound) is reported as blocked.
BLOCKED_FRACTION = 1e-7


@dataclass
class LaplaceResult:
    """Fields and fluxes of one solve (voxel units, conductivities as given).

    Attributes
    ----------
    potential : ndarray float64 (nx, ny, nz)
        ``"periodic"``: the periodic part ``phi`` (``T = phi - x_a``); ``"fixed"``: ``T``.
        Zero in insulating cells and in dropped clusters.
    axis : int
        Driving axis.
    bc : str
        ``"periodic"`` or ``"fixed"``.
    gradient : float
        Magnitude of the applied mean potential gradient (1 periodic, ``1 / n_a`` fixed).
    mean_flux : ndarray (3,)
        Flux density averaged over the whole box (superficial), per axis.
    plane_flux : ndarray
        Total flux through each plane normal to ``axis`` (``n_a`` face planes periodic,
        ``n_a + 1`` fixed: inlet face first, outlet face last).
    flux_imbalance : float
        ``(max - min) / mean`` of ``plane_flux`` (0 for an exact solve).
    converged, residual, iterations :
        CG reached ``tol``; final true scaled residual ``||D^-1 (b - A x)|| / ||D^-1 b||``;
        CG iterations.
    blocked : bool
        No conducting path along ``axis``; fluxes are zero.
    message : str
    n_active : int
        Unknowns kept.
    wall_time_s : float
    """

    potential: np.ndarray
    axis: int
    bc: str
    gradient: float
    mean_flux: np.ndarray
    plane_flux: np.ndarray
    flux_imbalance: float
    converged: bool
    residual: float
    iterations: int
    blocked: bool = False
    message: str = ""
    n_active: int = 0
    wall_time_s: float = 0.0
    history: list[float] = field(default_factory=list)


def _spanning(cond: np.ndarray, axis: int) -> np.ndarray:
    """Mask of conducting cells in 6-connected clusters touching both faces normal to axis."""
    lab, n = ndimage.label(cond)
    if n == 0:
        return np.zeros(cond.shape, bool)
    first = np.unique(np.take(lab, 0, axis=axis))
    last = np.unique(np.take(lab, -1, axis=axis))
    keep = np.intersect1d(first[first > 0], last[last > 0])
    if keep.size == 0:
        return np.zeros(cond.shape, bool)
    lut = np.zeros(n + 1, bool)
    lut[keep] = True
    return lut[lab]


def _fluxes(t, c, sigma, axis, fixed):
    """Plane fluxes along ``axis`` and the mean flux density vector."""
    n = t.size
    planes, tot = tk.face_fluxes(t, c[0], c[1], c[2], axis, 0.0 if fixed else 1.0)
    mean = tot / n
    if fixed:
        lo = np.take(sigma, 0, axis=axis) * (1.0 - np.take(t, 0, axis=axis))
        hi = np.take(sigma, -1, axis=axis) * np.take(t, -1, axis=axis)
        planes = np.concatenate([[2.0 * lo.sum()], planes[1:], [2.0 * hi.sum()]])
        mean[axis] = planes.mean() / (n / t.shape[axis])
    return planes, mean


def _imbalance(planes: np.ndarray) -> float:
    m = float(np.mean(planes))
    return float((planes.max() - planes.min()) / abs(m)) if m != 0 else 0.0


def _blocked(shape, axis, bc, grad, t0, msg) -> LaplaceResult:
    n_planes = shape[axis] + (1 if bc == "fixed" else 0)
    return LaplaceResult(
        potential=np.zeros(shape),
        axis=axis,
        bc=bc,
        gradient=grad,
        mean_flux=np.zeros(3),
        plane_flux=np.zeros(n_planes),
        flux_imbalance=0.0,
        converged=True,
        residual=0.0,
        iterations=0,
        blocked=True,
        message=msg,
        wall_time_s=time.perf_counter() - t0,
    )


def _check_input(conductivity: np.ndarray, axis: int, bc: str) -> np.ndarray:
    sigma = np.asarray(conductivity, dtype=np.float64)
    if sigma.ndim != 3:
        raise ValueError(f"conductivity must be a 3-D voxel array, got shape {sigma.shape}")
    if not np.all(np.isfinite(sigma)) or np.any(sigma < 0):
        raise ValueError("conductivity must be finite and >= 0 in every voxel")
    if axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0, 1 or 2, got {axis!r}")
    if bc not in BCS:
        raise ValueError(f"bc must be one of {', '.join(BCS)}, got {bc!r}")
    return sigma


def solve_laplace(
    conductivity: np.ndarray,
    axis: int,
    bc: str = "periodic",
    tol: float = 1e-8,
    max_iter: int = 1000,
    progress: Callable[[int, float], None] | None = None,
) -> LaplaceResult:
    """Solve steady conduction driven along ``axis`` (see the module docstring).

    Parameters
    ----------
    conductivity : ndarray (nx, ny, nz)
        Cell conductivities, >= 0 (0 = insulating / solid for diffusion); any units, the
        fluxes come out in the same units (times potential per voxel).
    axis : {0, 1, 2}
    bc : {"periodic", "fixed", "permeameter"}
    tol : float
        Relative Jacobi-scaled residual ``||D^-1 (b - A x)|| / ||D^-1 b||`` to reach (the
        scaling weighs the low-conductivity cells as much as the high ones, so the fluxes
        through a weak phase converge too at contrasts of 1e6).
    max_iter : int
        CG iteration cap (``converged=False`` past it).
    progress : callable, optional
        ``progress(iteration, relative_residual)`` every ``PROGRESS_EVERY`` iterations
        (:mod:`solvers.progress`: every one; the caller throttles what it prints).

    Returns
    -------
    LaplaceResult
    """
    t0 = time.perf_counter()
    sigma = _check_input(conductivity, axis, bc)
    bc = "fixed" if bc == "permeameter" else bc
    fixed = bc == "fixed"
    shape = sigma.shape
    grad = 1.0 / shape[axis] if fixed else 1.0
    scale = float(sigma.max()) if sigma.size else 0.0
    if scale <= 0:
        return _blocked(shape, axis, bc, grad, t0, "no conducting voxel: flux is zero")
    sigma = (sigma / scale).astype(np.float32)
    if fixed:
        span = _spanning(sigma > 0, axis)
        if not span.any():
            return _blocked(
                shape,
                axis,
                bc,
                grad,
                t0,
                f"blocked: no conducting path from inlet to outlet along {'xyz'[axis]}; flux is "
                "zero",
            )
        sigma[~span] = 0.0
    c = np.empty((3, *shape), np.float32)
    d = np.empty(shape)
    rhs = np.empty(shape)
    tk.coefficients(sigma, axis, fixed, c[0], c[1], c[2], d, rhs)
    if not fixed:
        plane_max = c[axis].max(axis=tuple(b for b in range(3) if b != axis))
        if plane_max.min() == 0:
            return _blocked(
                shape,
                axis,
                bc,
                grad,
                t0,
                f"blocked: a plane normal to {'xyz'[axis]} has no conducting face; flux is zero",
            )
    x, its, res, conv, hist = _pcg(d, c, rhs, fixed, tol, max_iter, progress)
    planes, mean = _fluxes(x, c, sigma, axis, fixed)
    mean *= scale
    planes = planes * scale
    msg = "" if conv else f"CG stopped at {its} iterations, residual {res:.2e} > tol {tol:.1e}"
    wiener = float(np.mean(c[axis], dtype=np.float64)) * scale
    if not fixed and mean[axis] <= BLOCKED_FRACTION * wiener:
        return _blocked(
            shape,
            axis,
            bc,
            grad,
            t0,
            f"blocked: no periodic conducting path along {'xyz'[axis]}; flux is zero",
        )
    return LaplaceResult(
        potential=x,
        axis=axis,
        bc=bc,
        gradient=grad,
        mean_flux=mean,
        plane_flux=planes,
        flux_imbalance=_imbalance(planes),
        converged=conv,
        residual=res,
        iterations=its,
        message=msg,
        n_active=int(np.count_nonzero(d)),
        wall_time_s=time.perf_counter() - t0,
        history=hist,
    )


def _pcg(d, c, rhs, fixed, tol, max_iter, progress):
    """Multigrid-preconditioned CG from zero; returns x, iterations, residual, flag, history."""
    from solvers.voxel.multigrid import ScalarMG

    d32 = d.astype(np.float32)
    low = d32 < d  # round up: the float32 preconditioner stays diagonally dominant
    d32[low] = np.nextafter(d32[low], np.float32(np.inf))
    if not fixed:
        d32 += np.float32(PERIODIC_SHIFT * float(d.max())) * (d32 > 0)
    mg = ScalarMG(d32, c)
    del d32, low
    cx, cy, cz = c
    act = d > 0
    bnorm = float(np.linalg.norm(rhs[act] / d[act]))
    x = np.zeros_like(rhs)
    if bnorm == 0:
        return x, 0, 0.0, True, []
    r = rhs.copy()
    r32 = r.astype(np.float32)
    z32 = np.zeros_like(r32)
    q = np.empty_like(r)
    mg.apply(r32, z32)
    rz = tk.dot_z32(r, z32)
    p = z32.astype(np.float64)
    hist: list[float] = [1.0]
    res = 1.0
    its = 0
    while its < max_iter:
        pq = tk.apply_dot(d, cx, cy, cz, p, q)
        if not pq > 0:
            break
        alpha = rz / pq
        rr = tk.update_xr(x, r, p, q, alpha, r32, d)
        its += 1
        res = float(np.sqrt(rr)) / bnorm
        hist.append(res)
        if progress is not None and its % PROGRESS_EVERY == 0:
            progress(its, res)
        if res <= tol:
            break
        mg.apply(r32, z32)
        rz_new = tk.dot_z32(r, z32)
        tk.update_p32(p, z32, rz_new / rz)
        rz = rz_new
    tk.apply_dot(d, cx, cy, cz, x, q)  # true residual
    q -= rhs
    true = float(np.linalg.norm(q[act] / d[act])) / bnorm
    return x, its, true, bool(true <= tol * 10 and res <= tol), hist
