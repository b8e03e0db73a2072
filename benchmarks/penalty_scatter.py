"""A smooth penalised wall against the alignment scatter (issue 12 item 3), on 2-D models.

Usage::

    python benchmarks/penalty_scatter.py calibrate LAM
    python benchmarks/penalty_scatter.py along LAM LOGC A [N,N,...]
    python benchmarks/penalty_scatter.py across LAM LOGC A MODE [N,N,...]
    python benchmarks/penalty_scatter.py diffuse-calibrate LAM
    python benchmarks/penalty_scatter.py diffuse along|across LAM LOGC SE C [N,N,...] [SHIFTS]
    python benchmarks/penalty_scatter.py diffuse-closed LAM LOGC SE C CONCAVE
    python benchmarks/penalty_scatter.py wall-calibrate PROFILE LAM
    python benchmarks/penalty_scatter.py wall along|across WALL OVERLAP [PHI,...] [N,...] [SHIFTS]
    python benchmarks/penalty_scatter.py wall-closed WALL CONCAVE
    python benchmarks/penalty_scatter.py wall-stokes WALL
    python benchmarks/penalty_scatter.py wall-curvature WALL
    python benchmarks/penalty_scatter.py wall-radial
    python benchmarks/penalty_scatter.py wall-gap WALL
    python benchmarks/penalty_scatter.py wall-normals PROFILE LAM

The voxel solver's cut-face wall (:mod:`solvers.voxel.boundary`) makes K depend on where the
grid nodes sit next to the wall: 0.01-0.1 % scatter over sub-voxel shifts at 24-64 voxels per
spacing, the reason its convergence is not strictly monotone (``benchmarks/voxel_scatter.py``,
``docs/validation.md`` 'Alignment floor'). Here every cell of a periodic grid is a fluid unknown
and the wall is a smooth drag ``D(s) = exp(LOGC - s / LAM)`` (``s``: signed distance to the
wall in voxels, > 0 in the fluid; ``LAM`` voxels wide), with the body force
``f(s) = 1 - A z / (1 + z)``, ``z = exp(-s / LAM)`` (``A`` ~ 2: an odd extension of the
forcing into the solid). A smooth profile sampled on the grid barely depends on the shift.

* ``calibrate``: ``LOGC`` and ``A`` from plane Poiseuille flow between walls ``W`` = 160 and
  640 voxels apart (1-D, 16 shifts each): the first zeroes the wall's offset, the second the
  curvature term; prints the remaining error at W = 20-640.
* ``along``: flow along a square array (Sparrow & Loeffler), the scalar problem
  ``-Laplace(u) + D u = f``; mean and sd of the true error over 16 shifts (seed 11).
* ``across``: flow across it, a penalised MAC Stokes model; ``MODE`` ``plain`` (the pressure
  force and flux unweighted) or ``weighted`` (both weighted by ``f``, with ``A`` = 1 a weight
  from 1 to 0). 8 shifts.

* ``diffuse``: a diffuse-domain wall. A smooth fluid fraction ``eps(s) = 1 / (1 + exp(-(s - SE') /
  LAM))`` weights the viscous fluxes (at the points between two velocity nodes), the pressure
  force and the flux of every face (``div(eps u) = 0``: no flow through the smooth layer) and the
  body force, with the drag ``D(s)`` for no-slip; ``SE' = SE + C LAM^2 kappa`` shifts it by the
  wall's curvature (``kappa = 1 / r`` here, the Laplacian of the distance). ``K = mean(eps u)``.
  ``diffuse-calibrate``: ``LOGC`` and ``SE`` from plane Poiseuille flow as above (the curvature
  coefficient ``C`` is not calibrated there: 3 was read off the along table at 32 / 64 voxels).
  ``diffuse-closed``: the along model against closed forms, Poiseuille flow in a pipe (a concave
  wall) and axial flow in an annulus ``b = 3 a`` (a convex and a concave wall); ``CONCAVE`` 1
  applies the curvature shift on concave walls too, 0 on convex walls only.

* ``wall*``: the diffuse-domain wall made to converge monotonically (session 22; the profile is
  :class:`solvers.voxel.diffuse_wall.WallProfile`, imported here as ``Wall``). ``WALL`` is
  ``PROFILE,LAM,LOGC,SE[,LOGC_D,SE_D[,C]]``: ``PROFILE`` ``logistic`` (the ``diffuse`` wall) or
  ``erf`` (a Gaussian tail; the drag is ``exp(LOGC) (1 - step) / step`` for both, which is
  ``exp(LOGC - s / LAM)`` for the logistic step). ``LOGC``, ``SE`` hold for a wall along a grid
  axis, ``LOGC_D``, ``SE_D`` for a diagonal wall; both are interpolated linearly in the grid
  anisotropy ``a = n_x^4 + n_y^4`` of the wall normal ``n`` (the distance gradient; 1 on an axis,
  1/2 on a diagonal), because the discrete layer moves the wall by an angle-dependent amount
  (first order in h). ``C`` multiplies ``LAM^2`` times the Laplacian of the distance.

  ``wall-calibrate``: ``LOGC``, ``SE`` (axis) and ``LOGC_D``, ``SE_D`` (diagonal) from plane
  Poiseuille flow at W = 160 and 640 (:func:`oblique_channel_error`: the 2-D problem between
  oblique walls reduced exactly to 1-D), then the channel error at W = 6-160 for normals (1, 0),
  (4, 1), (2, 1), (3, 2), (1, 1). ``wall along|across``: the square-array tables (mean, sd,
  min, max over ``SHIFTS`` of the 16 seed-11 shifts, default 8; per solid fraction the number of
  shifts whose ``|error|`` falls strictly over the resolutions, and the largest ``|error|`` from
  40 voxels). ``OVERLAP``: ``nearest`` (the nearest cylinder's wall only, the ``diffuse`` model)
  or ``pair`` (the two nearest cylinders each have a wall: fluid fractions multiplied, drags
  added, which a narrow gap needs), ``drag`` / ``eps`` (the pair for that part only).
  ``wall-closed``: pipe and annulus (``diffuse-closed``) for this wall, the curvature shift on
  concave walls too if ``CONCAVE`` is 1. ``wall-stokes``: plane Poiseuille flow between oblique
  walls in the MAC Stokes model (the across model) against the scalar model.
  ``wall-curvature``: the ``C`` that zeroes the pipe (R = 20, 40, 80) and the annulus
  (a = 16, 32; both walls shifted), each from its errors at ``C`` = 0 and 3. ``wall-radial``:
  the same in the continuum limit (:func:`radial_curvature`, 1-D radial finite volumes that
  resolve the layer), where ``C`` is a property of the profile, not of the grid. ``wall-gap``:
  narrow plane channels (W = 5-40 voxels, 16 shifts) with the nearest wall's layer and with
  both walls' (``pair``). ``wall-normals``: 3-D normals (the 1-D reduction with
  ``k = p i + q j + r l``), each calibrated on its own against ``LOGC``, ``SE`` linear in
  ``a = n_x^4 + n_y^4 + n_z^4`` through the axis and face-diagonal values. ``wall-radial`` also
  runs a ball and a spherical shell (3-D), with ``kappa`` the Laplacian of the distance.

  The wall that converges monotonically on the square arrays (phi 0.1-0.5, along and across,
  24-96 voxels, every shift; ``benchmarks/RESULTS.md``, wall22): ``WALL`` =
  ``logistic,0.75,-0.08385500,-0.00674740,-0.09675771,-0.01476628,2.55`` with ``OVERLAP``
  ``pair``.

Direct sparse solves (scipy); seconds per row at these sizes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import fsolve

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "benchmarks"), str(ROOT)]

from arrays import L, radius_of  # noqa: E402
from validation_tables import reference_k  # noqa: E402
from voxel_scatter import OFFSETS, Cylinder  # noqa: E402

from solvers.voxel.diffuse_wall import WallProfile as Wall  # noqa: E402
from solvers.voxel.diffuse_wall import parse_wall  # noqa: E402, F401 - the benchmarks' import


def profiles(s: np.ndarray, lam: float, logc: float, a: float) -> tuple[np.ndarray, np.ndarray]:
    """Drag ``D(s)`` and forcing ``f(s)`` (module docstring)."""
    z = np.exp(np.minimum(-s / lam, 50.0))
    return np.minimum(np.exp(-s / lam + logc), 1e12), 1.0 - a * z / (1.0 + z)


def _periodic_diff(n: int) -> sp.csr_matrix:
    """``(D x)_i = x_i - x_{i-1}`` with periodic wrap (0 on one point: its own neighbour)."""
    if n == 1:
        return sp.csr_matrix((1, 1))
    e = np.ones(n)
    d = sp.diags([e, -e[:-1]], [0, -1]).tolil()
    d[0, n - 1] = -1.0
    return d.tocsr()


def _channel_distance(width: float, x0: float) -> np.ndarray:
    """Signed distance (> 0 in the fluid) at the points ``x0 + i`` of a periodic 1-D grid of
    ``width + 20`` voxels whose fluid is ``[0, width)``."""
    n = int(round(width + 20.0))
    x = np.mod(np.arange(n) + x0, float(n))
    return np.where(x < width, np.minimum(x, width - x), -np.minimum(x - width, n - x))


def channel_error(width: float, shift: float, lam: float, logc: float, a: float) -> float:
    """Relative flux error of plane Poiseuille flow between walls ``width`` voxels apart."""
    drag, f = profiles(_channel_distance(width, 0.5 + shift), lam, logc, a)
    d = _periodic_diff(len(drag))
    u = spla.spsolve((d.T @ d + sp.diags(drag)).tocsc(), f)
    return u.sum() / (width**3 / 12.0) - 1.0


def _mean_channel(error, width: float, p, m: int = 16) -> float:
    """Mean of ``error(width, shift, *p)`` over ``m`` sub-voxel shifts."""
    return float(np.mean([error(width, t, *p) for t in np.arange(m) / m]))


def _calibrate(error, lam: float, guess) -> tuple[float, float]:
    """The two wall parameters after ``lam`` zeroing ``error``'s mean at W = 160 and 640."""

    def g(p):
        return [1e4 * _mean_channel(error, w, (lam, *p)) for w in (160.0, 640.0)]

    first, second = fsolve(g, guess, xtol=1e-12)
    return float(first), float(second)


def calibrate(lam: float) -> tuple[float, float]:
    """``(LOGC, A)`` of the drag wall (:func:`channel_error`)."""
    return _calibrate(channel_error, lam, [0.29 - 1.43 * (lam - 0.5) / 0.5, 2.2])


def _saddle(au, av, gx, gy, pressure_diag, rhs_u) -> np.ndarray:
    """The x-face velocities of the 2-D MAC Stokes system ``[[Au, 0, -Gx], [0, Av, -Gy],
    [-Gx^T, -Gy^T, P]]`` (``gx``, ``gy``: the pressure difference per face) driven by the body
    force ``rhs_u`` on the x faces."""
    nn = len(rhs_u)
    mat = sp.bmat([[au, None, -gx], [None, av, -gy], [-gx.T, -gy.T, pressure_diag]]).tocsc()
    return spla.spsolve(mat, np.concatenate([rhs_u, np.zeros(2 * nn)]))[:nn]


def _laplacian(n: int) -> sp.csr_matrix:
    return _weighted_laplacian(n, np.ones(n * n), np.ones(n * n)).tocsr()


def along(phi: float, n: int, shift, lam: float, logc: float, a: float) -> float:
    """True error of K along a square array (scalar penalised problem)."""
    geo = Cylinder(n, radius_of(phi, "square", spacing=n), shift)
    xc, yc = np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5, indexing="ij")
    drag, f = profiles(geo(xc, yc), lam, logc, a)
    u = spla.spsolve((_laplacian(n) + sp.diags(drag.ravel())).tocsc(), f.ravel())
    return u.mean() * (L / n) ** 2 / reference_k("square", "along", phi) - 1.0


def across(phi: float, n: int, shift, lam: float, logc: float, a: float, mode: str) -> float:
    """True error of K across a square array (penalised MAC Stokes, body force along x)."""
    geo = Cylinder(n, radius_of(phi, "square", spacing=n), shift)
    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    du, fu = profiles(geo(i, j + 0.5), lam, logc, a)  # x faces
    dv, fv = profiles(geo(i + 0.5, j), lam, logc, a)  # y faces
    d, eye, nn = _periodic_diff(n), sp.identity(n), n * n
    wu, wv = (fu.ravel(), fv.ravel()) if mode == "weighted" else (np.ones(nn), np.ones(nn))
    gx, gy = sp.diags(wu) @ sp.kron(d, eye), sp.diags(wv) @ sp.kron(eye, d)
    lap = _laplacian(n)
    u = _saddle(
        lap + sp.diags(du.ravel()),
        lap + sp.diags(dv.ravel()),
        gx,
        gy,
        -1e-11 * sp.identity(nn),  # the pressure's constant mode
        fu.ravel(),
    )
    return u.mean() * (L / n) ** 2 / reference_k("square", "across", phi) - 1.0


def wall_channel_error(width: float, shift: float, wall: Wall, pair: bool = False) -> float:
    """Relative flux error of plane Poiseuille flow between walls ``width`` voxels apart;
    ``pair``: each wall has its own layer (fluid fractions multiplied, drags added) instead of
    the nearest wall's only."""

    def walls(x0):
        n = int(round(width + 20.0))
        x = np.mod(np.arange(n) + x0, float(n))
        x = np.where(x >= width + (n - width) / 2.0, x - n, x)  # the solid slab split in two
        return (x, width - x) if pair else (_channel_distance(width, x0),)

    cells, faces = walls(0.5 + shift), walls(shift)
    d = _periodic_diff(len(cells[0]))
    drag = np.sum([wall.drag(s) for s in cells], axis=0)
    mat = d.T @ sp.diags(np.prod([wall.eps(s) for s in faces], axis=0)) @ d + sp.diags(drag)
    eps = np.prod([wall.eps(s) for s in cells], axis=0)
    u = spla.spsolve(mat.tocsc(), eps)
    return (eps * u).sum() / (width**3 / 12.0) - 1.0


def oblique_channel_error(
    width: float, shift: float, wall: Wall, p: int = 1, q: int = 0, r: int = 0
) -> float:
    """Relative flux error of plane Poiseuille flow (the along model) between walls of normal
    ``(p, q, r) / |(p, q, r)|`` (integers >= 0, coprime; ``r`` = 0: a 2-D grid) ``width`` voxels
    apart.

    The discrete solution is constant along the walls, so it depends on ``k = p i + q j + r l``
    only: a 1-D problem whose node ``k`` couples to ``k +- p`` (x faces), ``k +- q`` (y faces)
    and ``k +- r`` (z faces). ``(1, 0)`` is :func:`wall_channel_error`."""
    steps = [c for c in (p, q, r) if c]
    norm = float(np.sqrt(p * p + q * q + r * r))
    m = int(round((width + 20.0) * norm))
    period = m / norm
    k = np.arange(m)

    def dist(t):
        t = np.mod(t, period)
        return np.where(t < width, np.minimum(t, width - t), -np.minimum(t - width, period - t))

    a = (p**4 + q**4 + r**4) / norm**4
    tc = (k + 0.5 * (p + q + r)) / norm + shift
    diag, rows, cols, vals = wall.drag(dist(tc), a), [], [], []
    for step in steps:  # equal components add their couplings twice, as on the grid
        for sign in (1, -1):
            weight = wall.eps(dist(tc + sign * step / (2.0 * norm)), 0.0, a)
            diag = diag + weight
            rows.append(k)
            cols.append((k + sign * step) % m)
            vals.append(-weight)
    mat = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), (m, m)
    )
    eps = wall.eps(dist(tc), 0.0, a)
    u = spla.spsolve((mat + sp.diags(diag)).tocsc(), eps)
    return (eps * u).mean() / (width**3 / 12.0 / period) - 1.0


def wall_calibrate(
    kind: str, lam: float, p: int = 1, q: int = 0, r: int = 0
) -> tuple[float, float]:
    """``(LOGC, SE)`` of a diffuse wall of normal ``(p, q, r)`` from plane Poiseuille flow at W =
    160 and 640 (:func:`oblique_channel_error`)."""

    def error(width, shift, lam_, logc, se):
        return oblique_channel_error(width, shift, Wall(kind, lam_, logc, se), p, q, r)

    return _calibrate(error, lam, [-0.5 if kind == "logistic" else 1.0, 0.0])


def diffuse_calibrate(lam: float) -> tuple[float, float]:
    """``(LOGC, SE)`` of the logistic diffuse wall."""
    return wall_calibrate("logistic", lam)


#: How two walls' layers combine in a narrow gap (:class:`_Diffuse`).
OVERLAPS = ("nearest", "pair", "drag", "eps")


class _Diffuse:
    """Drag and fluid fraction of one cylinder per cell, shifted by the curvature and
    interpolated in the normal's grid anisotropy (module docstring). ``overlap``: ``pair``, the
    two nearest cylinders each have their own wall, fluid fractions multiplied and drags added
    (two walls' layers overlap in a narrow gap); ``nearest``, the nearest cylinder only;
    ``drag`` / ``eps``, the pair for that part only."""

    def __init__(self, phi: float, n: int, shift, wall: Wall, overlap: str = "nearest") -> None:
        if overlap not in OVERLAPS:
            raise ValueError(f"overlap must be one of {OVERLAPS}, got {overlap}")
        self.radius = radius_of(phi, "square", spacing=n)
        self.geo = Cylinder(n, self.radius, shift)
        self.wall, self.overlap = wall, overlap

    def _walls(self, x, y):
        """Per wall (nearest cylinder, then the second nearest): signed distance, curvature
        (the Laplacian of the distance) and ``n_x^4 + n_y^4`` of the normal."""
        g = self.geo
        dx0 = x - g.cx - g.n * np.round((x - g.cx) / g.n)
        dy0 = y - g.cy - g.n * np.round((y - g.cy) / g.n)
        images = [(dx0 + g.n * i, dy0 + g.n * j) for i in (-1, 0, 1) for j in (-1, 0, 1)]
        r = np.stack([np.maximum(np.hypot(dx, dy), 1e-9) for dx, dy in images])
        order = np.argsort(r, axis=0)[:2]
        out = []
        for k in order:
            dx = np.take_along_axis(np.stack([im[0] for im in images]), k[None], 0)[0]
            dy = np.take_along_axis(np.stack([im[1] for im in images]), k[None], 0)[0]
            rk = np.maximum(np.hypot(dx, dy), 1e-9)
            out.append((rk - self.radius, 1.0 / np.maximum(rk, 0.5), (dx**4 + dy**4) / rk**4))
        return out

    def eps(self, x, y):
        walls = self._walls(x, y)[: 2 if self.overlap in ("pair", "eps") else 1]
        return np.prod([self.wall.eps(*w) for w in walls], axis=0).ravel()

    def drag(self, x, y):
        walls = self._walls(x, y)[: 2 if self.overlap in ("pair", "drag") else 1]
        return np.sum([self.wall.drag(s, a) for s, _, a in walls], axis=0).ravel()


def _weighted_laplacian(n, eps0, eps1):
    """``Dx^T eps0 Dx + Dy^T eps1 Dy`` (``eps``: at the points between two nodes)."""
    d, eye = _periodic_diff(n), sp.identity(n)
    dx, dy = sp.kron(d, eye), sp.kron(eye, d)
    return dx.T @ sp.diags(eps0) @ dx + dy.T @ sp.diags(eps1) @ dy


def wall_along(phi: float, n: int, shift, wall: Wall, overlap: str = "nearest") -> float:
    """True error of K along a square array, diffuse-domain wall (cell-centred unknowns)."""
    w = _Diffuse(phi, n, shift, wall, overlap)
    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    lap = _weighted_laplacian(n, w.eps(i, j + 0.5), w.eps(i + 0.5, j))
    eps = w.eps(i + 0.5, j + 0.5)
    u = spla.spsolve((lap + sp.diags(w.drag(i + 0.5, j + 0.5))).tocsc(), eps)
    return (eps * u).mean() * (L / n) ** 2 / reference_k("square", "along", phi) - 1.0


def _mac_flux(n: int, field, force: tuple[float, float] = (1.0, 0.0)) -> float:
    """Mean flux ``mean(eps u . force)`` of the diffuse-domain MAC Stokes model on a periodic
    ``n x n`` grid (u on x faces, v on y faces, p on cells) driven by the body force ``eps
    force``; ``field`` gives ``eps(x, y)`` and ``drag(x, y)``. Pressure cells with no weighted
    face are pinned."""
    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    au = _weighted_laplacian(n, field.eps(i - 0.5, j + 0.5), field.eps(i, j))  # u at (i, j + 1/2)
    av = _weighted_laplacian(n, field.eps(i, j), field.eps(i + 0.5, j - 0.5))  # v at (i + 1/2, j)
    eu, ev = field.eps(i, j + 0.5), field.eps(i + 0.5, j)
    d, eye, nn = _periodic_diff(n), sp.identity(n), n * n
    gx, gy = sp.diags(eu) @ sp.kron(d, eye), sp.diags(ev) @ sp.kron(eye, d)
    live = (abs(gx).T @ np.ones(nn) + abs(gy).T @ np.ones(nn)) > 1e-9
    keep = sp.diags(live * 1.0)
    au = au + sp.diags(field.drag(i, j + 0.5))
    av = av + sp.diags(field.drag(i + 0.5, j))
    pin = sp.diags(np.where(live, -1e-11, 1.0))  # -1e-11: the pressure's constant mode
    mat = sp.bmat(
        [[au, None, -gx @ keep], [None, av, -gy @ keep], [-keep @ gx.T, -keep @ gy.T, pin]]
    )
    rhs = np.concatenate([force[0] * eu, force[1] * ev, np.zeros(nn)])
    uv = spla.spsolve(mat.tocsc(), rhs)
    return float((eu * uv[:nn]).mean() * force[0] + (ev * uv[nn : 2 * nn]).mean() * force[1])


def wall_across(phi: float, n: int, shift, wall: Wall, overlap: str = "nearest") -> float:
    """True error of K across a square array, diffuse-domain MAC Stokes (:func:`_mac_flux`)."""
    flux = _mac_flux(n, _Diffuse(phi, n, shift, wall, overlap))
    return flux * (L / n) ** 2 / reference_k("square", "across", phi) - 1.0


class _Channel:
    """Fluid fraction and drag of plane walls of normal ``(p, q) / |(p, q)|``, ``width``
    voxels apart, period ``n / |(p, q)|`` on a periodic ``n x n`` grid."""

    def __init__(self, p: int, q: int, n: int, width: float, offset: float, wall: Wall) -> None:
        self.p, self.q, self.r = p, q, float(np.hypot(p, q))
        self.period, self.width, self.offset, self.wall = n / self.r, width, offset, wall
        self.aniso = (p**4 + q**4) / self.r**4

    def _s(self, x, y):
        t = np.mod((self.p * x + self.q * y) / self.r + self.offset, self.period)
        w, per = self.width, self.period
        return np.where(t < w, np.minimum(t, w - t), -np.minimum(t - w, per - t))

    def eps(self, x, y):
        return self.wall.eps(self._s(x, y), 0.0, self.aniso).ravel()

    def drag(self, x, y):
        return self.wall.drag(self._s(x, y), self.aniso).ravel()


def oblique_stokes_error(p: int, q: int, period: float, width: float, wall: Wall, offset=0.37):
    """Relative flux error of plane Poiseuille flow in the MAC Stokes model, walls of normal
    ``(p, q)``, the body force along the walls; the grid is ``round(period |(p, q)|)`` wide."""
    n = int(round(period * np.hypot(p, q)))
    r = np.hypot(p, q)
    flux = _mac_flux(n, _Channel(p, q, n, width, offset, wall), (q / r, -p / r))
    return flux / (width**3 / 12.0 / (n / r)) - 1.0


def diffuse_along(phi, n, shift, lam, logc, se, c) -> float:
    """:func:`wall_along` of the logistic wall."""
    return wall_along(phi, n, shift, Wall("logistic", lam, logc, se, c))


def diffuse_across(phi, n, shift, lam, logc, se, c) -> float:
    """:func:`wall_across` of the logistic wall."""
    return wall_across(phi, n, shift, Wall("logistic", lam, logc, se, c))


def closed_form_error(a: float, b: float, shift, wall: Wall, concave: float) -> float:
    """Relative flux error of axial flow in an annulus ``a < r < b`` (voxels; ``a`` = 0: a
    pipe), diffuse-domain along model."""
    n = int(2 * b + 12)
    cx, cy = n / 2 + shift[0], n / 2 + shift[1]

    def dist_kappa(x, y):
        """Signed distance, curvature and grid anisotropy ``n_x^4 + n_y^4`` of the normal."""
        r = np.maximum(np.hypot(x - cx, y - cy), 1e-9)
        inner, outer = (r - a if a > 0 else np.inf + 0 * r), b - r
        aniso = ((x - cx) ** 4 + (y - cy) ** 4) / r**4
        return np.minimum(inner, outer), np.where(inner < outer, 1.0 / r, -concave / r), aniso

    def eps(x, y):
        return wall.eps(*dist_kappa(x, y)).ravel()

    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    lap = _weighted_laplacian(n, eps(i, j + 0.5), eps(i + 0.5, j))
    e = eps(i + 0.5, j + 0.5)
    s, _, aniso = dist_kappa(i + 0.5, j + 0.5)
    u = spla.spsolve((lap + sp.diags(wall.drag(s, aniso).ravel())).tocsc(), e)
    exact = np.pi / 8 * (b**4 - a**4 - ((b * b - a * a) ** 2 / np.log(b / a) if a > 0 else 0.0))
    return (e * u).sum() / exact - 1.0


def _closed_tables(wall: Wall, concave: float) -> None:
    shifts = np.random.default_rng(3).random((4, 2))
    for label, radii in (
        ("pipe R", [(0, r) for r in (5, 10, 20, 40)]),
        ("annulus a", [(a, 3 * a) for a in (4, 8, 16, 32)]),
    ):
        for a, b in radii:
            e = [closed_form_error(a, b, sh, wall, concave) for sh in shifts]
            sd = 100 * np.std(e, ddof=1)
            print(f"{label} {a or b}: mean {100 * np.mean(e):+.4f} %, sd {sd:.4f} %", flush=True)


def _table(fn, ns, offsets, phis=(0.1, 0.3, 0.5)) -> None:
    """Mean, sd, min and max of ``fn(phi, n, offset)`` over the offsets; per solid fraction the
    number of offsets whose ``|error|`` falls strictly with ``n``, and the largest ``|error|``
    from 40 voxels on."""
    for phi in phis:
        rows = []
        for n in ns:
            e = np.array([fn(phi, n, o) for o in offsets])
            rows.append(e)
            print(
                f"phi {phi} n {n}: mean {100 * e.mean():+.4f} %, sd {100 * e.std(ddof=1):.4f} %,"
                f" min {100 * e.min():+.4f}, max {100 * e.max():+.4f}",
                flush=True,
            )
        err = np.abs(np.array(rows))  # (resolution, offset)
        mono = int(np.all(np.diff(err, axis=0) < 0, axis=0).sum())
        big = max((100 * err[i].max() for i, n in enumerate(ns) if n >= 40), default=float("nan"))
        print(
            f"phi {phi}: |error| strictly falling at {mono} / {len(offsets)} offsets;"
            f" max |error| from 40 voxels {big:.4f} %",
            flush=True,
        )


def _wall_calibration(kind: str, lam: float) -> None:
    axis, diag = wall_calibrate(kind, lam, 1, 0), wall_calibrate(kind, lam, 1, 1)
    wall = Wall(kind, lam, axis[0], axis[1], 0.0, diag[0], diag[1])
    print(f"WALL {kind},{lam},{axis[0]:.8f},{axis[1]:.8f},{diag[0]:.8f},{diag[1]:.8f}")
    for p, q in ((1, 0), (4, 1), (2, 1), (3, 2), (1, 1)):
        errs = [
            f"{w}: {100 * _mean_channel(oblique_channel_error, w, (wall, p, q)):+.5f}"
            for w in (6, 8, 12, 20, 40, 160)
        ]
        print(f"normal ({p}, {q}), channel error (%) at W = {', '.join(errs)}", flush=True)


def _radial_solve(r_lo, r_hi, dist_kappa, metric, wall: Wall, h: float) -> float:
    """``int eps u J dr`` of ``-(1/J)(J eps u')' + D u = eps`` on ``[r_lo, r_hi]`` (finite
    volumes of width ``h``, no flux through the ends; ``J = metric(r)``); the drag in units of
    ``1 / LAM^2`` (:func:`radial_curvature`)."""
    m = int(round((r_hi - r_lo) / h))
    rc, rf = r_lo + (np.arange(m) + 0.5) * h, r_lo + np.arange(m + 1) * h
    (s, k), (sf, kf) = dist_kappa(rc), dist_kappa(rf)
    ef = wall.eps(sf, kf) * metric(rf)
    ef[0] = ef[-1] = 0.0
    ec, jc = wall.eps(s, k), metric(rc)
    drag = np.minimum(np.exp(wall.logc - s / wall.lam) / wall.lam**2, 1e14)
    off = -ef[1:-1] / h**2
    mat = sp.diags([(ef[:-1] + ef[1:]) / h**2 + drag * jc, off, off], [0, 1, -1]).tocsc()
    return float(np.sum(ec * spla.spsolve(mat, ec * jc) * jc) * h)


def _radial_flux(lo, hi, dk, dim, wall, h=1.0 / 16) -> float:
    """:func:`_radial_solve` with the metric ``r^(dim - 1)`` and 12 ``LAM`` of solid beyond each
    wall (none below ``lo`` = 0 in 2-D and 3-D: the centre of a pipe or ball)."""
    start = lo - 12.0 if lo > 0 or dim == 1 else 0.0
    return _radial_solve(start, hi + 12.0, dk, lambda r: r ** (dim - 1), wall, h)


def _radial_cases(logc: float, se: float):
    """``(name, error(size, C), sizes)`` of the closed forms in radial coordinates (``LAM`` = 1):
    Poiseuille flow in a pipe and in an annulus ``b = 3 a`` (2-D, ``kappa`` = 1 / r), and
    ``-Laplace(u) = 1`` in a ball and a spherical shell ``b = 3 a`` (3-D, ``kappa`` = the
    Laplacian of the distance = 2 / r, the sum of the two principal curvatures)."""

    def hollow(radius, c, dim):
        def dk(r):
            return radius - r, -(dim - 1) / np.maximum(r, 1e-12)

        flux = _radial_flux(0.0, radius, dk, dim, Wall("logistic", 1.0, logc, se, c))
        exact = radius**4 / 16.0 if dim == 2 else radius**5 / 45.0
        return flux / exact - 1.0

    def shell(a, c, dim):
        b = 3.0 * a

        def dk(r):
            return np.minimum(r - a, b - r), (dim - 1) * np.where(r - a < b - r, 1.0, -1.0) / r

        if dim == 2:
            exact = (b**4 - a**4 - (b * b - a * a) ** 2 / np.log(b / a)) / 16.0
        else:  # u = -r^2 / 6 + A + B / r with u(a) = u(b) = 0
            big_b = -(a + b) * a * b / 6.0
            big_a = a * a / 6.0 - big_b / a
            exact = (
                -(b**5 - a**5) / 30.0 + big_a * (b**3 - a**3) / 3.0 + big_b * (b * b - a * a) / 2
            )
        flux = _radial_flux(a, b, dk, dim, Wall("logistic", 1.0, logc, se, c))
        return flux / exact - 1.0

    return (
        ("pipe R / LAM", lambda x, c: hollow(x, c, 2), (26.667, 53.333, 106.67, 400.0, 1600.0)),
        ("annulus a / LAM", lambda x, c: shell(x, c, 2), (21.333, 42.667, 400.0)),
        ("ball R / LAM", lambda x, c: hollow(x, c, 3), (53.333, 106.67, 400.0, 1600.0)),
        ("spherical shell a / LAM", lambda x, c: shell(x, c, 3), (42.667, 400.0)),
    )


def radial_curvature() -> None:
    """The continuum limit of the curvature coefficient ``C``: the logistic wall with ``LAM``
    = 1 resolved by 16 finite volumes per ``LAM`` in 1-D (plane channel: ``LOGC``, ``SE`` from
    W = 200 and 800; then :func:`_radial_cases`), no grid anisotropy; per size the ``C`` that
    zeroes the error (from ``C`` = 0 and 3)."""

    def channel(width, logc, se):
        def dk(r):
            return np.minimum(r, width - r), 0.0 * r

        flux = _radial_flux(0.0, width, dk, 1, Wall("logistic", 1.0, logc, se))
        return flux / (width**3 / 12.0) - 1.0

    logc, se = fsolve(
        lambda p: [1e4 * channel(w, *p) for w in (200.0, 800.0)], [0.0, -0.03], xtol=1e-12
    )
    print(f"continuum LAM 1: LOGC {logc:.6f}, SE {se:.6f}", flush=True)
    for name, error, sizes in _radial_cases(logc, se):
        for size in sizes:
            e0, e3 = error(size, 0.0), error(size, 3.0)
            print(
                f"{name} {size:g}: error {100 * e0:+.6f} % at C 0, {100 * e3:+.6f} % at C 3;"
                f" zero at C {3 * e0 / (e0 - e3):.4f}",
                flush=True,
            )


def _gap_table(wall: Wall) -> None:
    """Narrow plane channels: the nearest wall's layer against both walls' (``pair``)."""
    for width in (5, 6, 8, 10, 12, 16, 20, 40):
        row = []
        for pair in (False, True):
            e = [wall_channel_error(width, t, wall, pair) for t in np.arange(16) / 16]
            row.append(f"{100 * np.mean(e):+.4f} % (sd {100 * np.std(e, ddof=1):.4f})")
        print(f"W {width}: nearest {row[0]}, pair {row[1]}", flush=True)


def _curvature_fit(wall: Wall) -> None:
    """The ``C`` that zeroes the mean error of the pipe and of the annulus ``b = 3 a`` (both walls
    shifted), from the errors at ``C`` = 0 and 3 (the error is close to linear in ``C``)."""
    shifts = np.random.default_rng(3).random((4, 2))
    for a, b in ((0, 20), (0, 40), (0, 80), (16, 48), (32, 96)):
        e0, e3 = (
            np.mean([closed_form_error(a, b, sh, _with_c(wall, c), 1.0) for sh in shifts])
            for c in (0.0, 3.0)
        )
        name = f"pipe R {b}" if a == 0 else f"annulus a {a}"
        print(
            f"{name}: error {100 * e0:+.5f} % at C 0, {100 * e3:+.5f} % at C 3; zero at C"
            f" {3 * e0 / (e0 - e3):.3f}",
            flush=True,
        )


def _with_c(wall: Wall, c: float) -> Wall:
    return Wall(wall.kind, wall.lam, wall.logc, wall.se, c, wall.logc_d, wall.se_d)


def _stokes_table(wall: Wall) -> None:
    for p, q in ((1, 0), (2, 1), (1, 1)):
        for period in (30, 60):
            width = period - 12
            stokes = np.mean(
                [oblique_stokes_error(p, q, period, width, wall, o) for o in (0.13, 0.61)]
            )
            scalar = _mean_channel(oblique_channel_error, width, (wall, p, q))
            print(
                f"normal ({p}, {q}), W {width}: MAC Stokes {100 * stokes:+.4f} %,"
                f" scalar {100 * scalar:+.4f} %",
                flush=True,
            )


def _normals_check(kind: str, lam: float) -> None:
    """Per 3-D normal: ``LOGC`` and ``SE`` calibrated for it against the values linear in
    ``a = n_x^4 + n_y^4 + n_z^4`` through the (1, 0, 0) and (1, 1, 0) calibrations, and the
    interpolated wall's channel error."""
    axis, diag = wall_calibrate(kind, lam, 1, 0, 0), wall_calibrate(kind, lam, 1, 1, 0)
    wall = Wall(kind, lam, axis[0], axis[1], 0.0, diag[0], diag[1])
    for normal in ((1, 1, 1), (2, 1, 0), (2, 1, 1), (3, 2, 1), (2, 2, 1), (3, 1, 1)):
        a = sum(c**4 for c in normal) / sum(c * c for c in normal) ** 2
        logc, se = wall_calibrate(kind, lam, *normal)
        lin = wall._at(a)
        err = [100 * _mean_channel(oblique_channel_error, w, (wall, *normal)) for w in (40, 160)]
        print(
            f"normal {normal}, a {a:.4f}: LOGC {logc:.6f}, SE {se:.6f}; linear in a {lin[0]:.6f},"
            f" {lin[1]:.6f}; interpolated wall at W 40 / 160: {err[0]:+.5f} / {err[1]:+.5f} %",
            flush=True,
        )


def _wall_main(argv: list[str]) -> int:
    """The ``wall*`` subcommands (module docstring)."""
    if argv[0] == "wall-calibrate":
        _wall_calibration(argv[1], float(argv[2]))
        return 0
    if argv[0] == "wall-closed":
        _closed_tables(parse_wall(argv[1]), float(argv[2]))
        return 0
    if argv[0] == "wall-curvature":
        _curvature_fit(parse_wall(argv[1]))
        return 0
    if argv[0] == "wall-gap":
        _gap_table(parse_wall(argv[1]))
        return 0
    if argv[0] == "wall-normals":
        _normals_check(argv[1], float(argv[2]))
        return 0
    if argv[0] == "wall-radial":
        radial_curvature()
        return 0
    if argv[0] == "wall-stokes":
        _stokes_table(parse_wall(argv[1]))
        return 0
    fn = wall_along if argv[1] == "along" else wall_across
    wall, overlap = parse_wall(argv[2]), argv[3]
    phis = [float(v) for v in (argv[4] if len(argv) > 4 else "0.1,0.2,0.3,0.4,0.5").split(",")]
    ns = [int(v) for v in (argv[5] if len(argv) > 5 else "24,32,40,48,64,96").split(",")]
    m = int(argv[6]) if len(argv) > 6 else 8
    _table(lambda p, n, o: fn(p, n, o, wall, overlap), ns, OFFSETS["rand16"][:m], phis)
    return 0


def main(argv: list[str]) -> int:
    """Dispatch on the first argument (module docstring)."""
    if not argv or argv[0] not in (
        "calibrate",
        "along",
        "across",
        "diffuse-calibrate",
        "diffuse",
        "diffuse-closed",
        "wall-calibrate",
        "wall",
        "wall-closed",
        "wall-stokes",
        "wall-curvature",
        "wall-radial",
        "wall-gap",
        "wall-normals",
    ):
        print("\n\n".join(__doc__.split("\n\n")[1:3]))
        return 2
    if argv[0].startswith("wall"):
        return _wall_main(argv)
    if argv[0] == "diffuse-calibrate":
        lam = float(argv[1])
        logc, se = diffuse_calibrate(lam)
        print(f"LAM {lam}: LOGC {logc:.8f}, SE {se:.8f}")
        return 0
    if argv[0] == "diffuse-closed":
        lam, logc, se, c, concave = (float(v) for v in argv[1:6])
        _closed_tables(Wall("logistic", lam, logc, se, c), concave)
        return 0
    if argv[0] == "diffuse":
        fn = diffuse_along if argv[1] == "along" else diffuse_across
        lam, logc, se, c = (float(v) for v in argv[2:6])
        ns = [int(v) for v in (argv[6] if len(argv) > 6 else "24,32,40,48,64,96").split(",")]
        m = int(argv[7]) if len(argv) > 7 else 8
        _table(lambda p, n, o: fn(p, n, o, lam, logc, se, c), ns, OFFSETS["rand16"][:m])
        return 0
    lam = float(argv[1])
    if argv[0] == "calibrate":
        logc, a = calibrate(lam)
        errs = [
            f"W {w:.0f}: {100 * _mean_channel(channel_error, w, (lam, logc, a)):+.6f} %"
            for w in (20, 40, 80, 160, 320, 640)
        ]
        print(f"LAM {lam}: LOGC {logc:.8f}, A {a:.8f}; {', '.join(errs)}")
        return 0
    logc, a = float(argv[2]), float(argv[3])
    if argv[0] == "along":
        ns = [int(v) for v in (argv[4] if len(argv) > 4 else "16,24,32,40,48,64,96").split(",")]
        _table(lambda p, n, o: along(p, n, o, lam, logc, a), ns, OFFSETS["rand16"])
        return 0
    mode = argv[4]
    ns = [int(v) for v in (argv[5] if len(argv) > 5 else "24,32,40,48,64").split(",")]
    _table(lambda p, n, o: across(p, n, o, lam, logc, a, mode), ns, OFFSETS["rand16"][:8])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
