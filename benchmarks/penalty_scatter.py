"""A smooth penalised wall against the alignment scatter (issue 12 item 3), on 2-D models.

Usage::

    python benchmarks/penalty_scatter.py calibrate LAM
    python benchmarks/penalty_scatter.py along LAM LOGC A [N,N,...]
    python benchmarks/penalty_scatter.py across LAM LOGC A MODE [N,N,...]
    python benchmarks/penalty_scatter.py diffuse-calibrate LAM
    python benchmarks/penalty_scatter.py diffuse along|across LAM LOGC SE C [N,N,...] [SHIFTS]
    python benchmarks/penalty_scatter.py diffuse-closed LAM LOGC SE C CONCAVE

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


def profiles(s: np.ndarray, lam: float, logc: float, a: float) -> tuple[np.ndarray, np.ndarray]:
    """Drag ``D(s)`` and forcing ``f(s)`` (module docstring)."""
    z = np.exp(np.minimum(-s / lam, 50.0))
    return np.minimum(np.exp(-s / lam + logc), 1e12), 1.0 - a * z / (1.0 + z)


def _periodic_diff(n: int) -> sp.csr_matrix:
    """``(D x)_i = x_i - x_{i-1}`` with periodic wrap."""
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


def fluid_fraction(s: np.ndarray, lam: float, se: float) -> np.ndarray:
    """The diffuse-domain fluid fraction ``eps(s)`` (module docstring)."""
    return 1.0 / (1.0 + np.exp(np.minimum(-(s - se) / lam, 60.0)))


def diffuse_channel_error(width: float, shift: float, lam: float, logc: float, se: float) -> float:
    """Relative flux error of plane Poiseuille flow, diffuse-domain wall."""
    s, s_mid = _channel_distance(width, 0.5 + shift), _channel_distance(width, shift)
    d = _periodic_diff(len(s))
    drag = np.minimum(np.exp(-s / lam + logc), 1e12)
    mat = d.T @ sp.diags(fluid_fraction(s_mid, lam, se)) @ d + sp.diags(drag)
    eps = fluid_fraction(s, lam, se)
    u = spla.spsolve(mat.tocsc(), eps)
    return (eps * u).sum() / (width**3 / 12.0) - 1.0


def diffuse_calibrate(lam: float) -> tuple[float, float]:
    """``(LOGC, SE)`` of the diffuse wall (:func:`diffuse_channel_error`)."""
    return _calibrate(diffuse_channel_error, lam, [-0.5, 0.0])


class _Diffuse:
    """Drag and curvature-shifted fluid fraction of one cylinder (module docstring)."""

    def __init__(self, phi, n, shift, lam, logc, se, c):
        self.radius = radius_of(phi, "square", spacing=n)
        self.geo = Cylinder(n, self.radius, shift)
        self.lam, self.logc, self.se, self.c = lam, logc, se, c

    def eps(self, x, y):
        s = self.geo(x, y)
        kappa = 1.0 / np.maximum(s + self.radius, 0.5)  # the Laplacian of the 2-D distance
        return fluid_fraction(s, self.lam, self.se + self.c * self.lam**2 * kappa).ravel()

    def drag(self, x, y):
        return np.minimum(np.exp(-self.geo(x, y) / self.lam + self.logc), 1e12).ravel()


def _weighted_laplacian(n, eps0, eps1):
    """``Dx^T eps0 Dx + Dy^T eps1 Dy`` (``eps``: at the points between two nodes)."""
    d, eye = _periodic_diff(n), sp.identity(n)
    dx, dy = sp.kron(d, eye), sp.kron(eye, d)
    return dx.T @ sp.diags(eps0) @ dx + dy.T @ sp.diags(eps1) @ dy


def diffuse_along(phi, n, shift, lam, logc, se, c) -> float:
    """True error of K along a square array, diffuse-domain wall (cell-centred unknowns)."""
    w = _Diffuse(phi, n, shift, lam, logc, se, c)
    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    lap = _weighted_laplacian(n, w.eps(i, j + 0.5), w.eps(i + 0.5, j))
    eps = w.eps(i + 0.5, j + 0.5)
    u = spla.spsolve((lap + sp.diags(w.drag(i + 0.5, j + 0.5))).tocsc(), eps)
    return (eps * u).mean() * (L / n) ** 2 / reference_k("square", "along", phi) - 1.0


def diffuse_across(phi, n, shift, lam, logc, se, c) -> float:
    """True error of K across a square array, diffuse-domain MAC Stokes (pressure cells with
    no weighted face are pinned)."""
    w = _Diffuse(phi, n, shift, lam, logc, se, c)
    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    au = _weighted_laplacian(n, w.eps(i - 0.5, j + 0.5), w.eps(i, j))  # u at (i, j + 1/2)
    av = _weighted_laplacian(n, w.eps(i, j), w.eps(i + 0.5, j - 0.5))  # v at (i + 1/2, j)
    eu, ev = w.eps(i, j + 0.5), w.eps(i + 0.5, j)
    d, eye, nn = _periodic_diff(n), sp.identity(n), n * n
    gx, gy = sp.diags(eu) @ sp.kron(d, eye), sp.diags(ev) @ sp.kron(eye, d)
    live = (abs(gx).T @ np.ones(nn) + abs(gy).T @ np.ones(nn)) > 1e-9
    keep = sp.diags(live * 1.0)
    u = _saddle(
        au + sp.diags(w.drag(i, j + 0.5)),
        av + sp.diags(w.drag(i + 0.5, j)),
        gx @ keep,
        gy @ keep,
        sp.diags(np.where(live, -1e-11, 1.0)),
        eu,
    )
    return (eu * u).mean() * (L / n) ** 2 / reference_k("square", "across", phi) - 1.0


def closed_form_error(a: float, b: float, shift, lam, logc, se, c, concave: float) -> float:
    """Relative flux error of axial flow in an annulus ``a < r < b`` (voxels; ``a`` = 0: a
    pipe), diffuse-domain along model."""
    n = int(2 * b + 12)
    cx, cy = n / 2 + shift[0], n / 2 + shift[1]

    def dist_kappa(x, y):
        r = np.maximum(np.hypot(x - cx, y - cy), 1e-9)
        inner, outer = (r - a if a > 0 else np.inf + 0 * r), b - r
        return np.minimum(inner, outer), np.where(inner < outer, 1.0 / r, -concave / r)

    def eps(x, y):
        s, k = dist_kappa(x, y)
        return fluid_fraction(s, lam, se + c * lam**2 * k).ravel()

    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    lap = _weighted_laplacian(n, eps(i, j + 0.5), eps(i + 0.5, j))
    e = eps(i + 0.5, j + 0.5)
    drag = np.minimum(np.exp(-dist_kappa(i + 0.5, j + 0.5)[0] / lam + logc), 1e12).ravel()
    u = spla.spsolve((lap + sp.diags(drag)).tocsc(), e)
    exact = np.pi / 8 * (b**4 - a**4 - ((b * b - a * a) ** 2 / np.log(b / a) if a > 0 else 0.0))
    return (e * u).sum() / exact - 1.0


def _closed_tables(lam, logc, se, c, concave) -> None:
    shifts = np.random.default_rng(3).random((4, 2))
    for label, radii in (
        ("pipe R", [(0, r) for r in (5, 10, 20, 40)]),
        ("annulus a", [(a, 3 * a) for a in (4, 8, 16, 32)]),
    ):
        for a, b in radii:
            e = [closed_form_error(a, b, sh, lam, logc, se, c, concave) for sh in shifts]
            sd = 100 * np.std(e, ddof=1)
            print(f"{label} {a or b}: mean {100 * np.mean(e):+.4f} %, sd {sd:.4f} %", flush=True)


def _table(fn, ns, offsets) -> None:
    for phi in (0.1, 0.3, 0.5):
        for n in ns:
            e = np.array([fn(phi, n, o) for o in offsets])
            print(
                f"phi {phi} n {n}: mean {100 * e.mean():+.4f} %, sd {100 * e.std(ddof=1):.4f} %,"
                f" min {100 * e.min():+.4f}, max {100 * e.max():+.4f}",
                flush=True,
            )


def main(argv: list[str]) -> int:
    """Dispatch on the first argument (module docstring)."""
    if not argv or argv[0] not in (
        "calibrate",
        "along",
        "across",
        "diffuse-calibrate",
        "diffuse",
        "diffuse-closed",
    ):
        print(__doc__.split("\n\n")[1])
        return 2
    if argv[0] == "diffuse-calibrate":
        lam = float(argv[1])
        logc, se = diffuse_calibrate(lam)
        print(f"LAM {lam}: LOGC {logc:.8f}, SE {se:.8f}")
        return 0
    if argv[0] == "diffuse-closed":
        _closed_tables(*(float(v) for v in argv[1:6]))
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
