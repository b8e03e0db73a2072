"""The diffuse-domain wall in a 3-D staggered Stokes discretisation (issue 12 item 3, port step 1).

Usage::

    python benchmarks/diffuse3d.py tilted WALL PHI K,... [SHIFTS]
    python benchmarks/diffuse3d.py extruded WALL [PHI] [N,...] [NZ,...]
    python benchmarks/diffuse3d.py spheres WALL [C,...] [N,...] [SHIFTS]
    python benchmarks/diffuse3d.py cutface [C,...] [N,...] [SHIFTS]
    python benchmarks/diffuse3d.py iterations WALL C N
    python benchmarks/diffuse3d.py product WALL tilted|spheres PHI|C K|N [AXES] [TOL] [check]

``WALL`` is :func:`penalty_scatter.parse_wall`'s string; the wall that converges monotonically on
the 2-D arrays (wall22) is ``logistic,0.75,-0.08385500,-0.00674740,-0.09675771,-0.01476628,2.55``,
always with both nearest bodies' layers (``pair``: fluid fractions multiplied, drags added).

The model (:func:`assemble`; since dport23 the product's :mod:`solvers.voxel.diffuse_system`,
the public solve :func:`solvers.voxel.diffuse.solve_diffuse_stokes`): a periodic
``nx x ny x nz`` grid, ``u``, ``v``, ``w`` on the x, y, z faces, ``p`` on the cells, every face
an unknown (the solid too: the drag keeps no-slip).
Per velocity component ``c`` the viscous operator is ``sum_d D_d^T diag(eps) D_d`` (no
cross-component terms, as in the 2-D model), plus the drag ``D(s)`` on the diagonal; the
pressure force, the flux (``div(eps u) = 0``) and the body force are weighted by ``eps`` at the
face. ``eps`` of a viscous flux is sampled where that flux sits, midway between the two velocity
nodes it couples: for ``d = c`` (``u`` to ``u`` along x) that is a cell centre; for ``d != c``
it is the midpoint of a cell edge (``u`` to ``u`` along y: the edge along z at ``(i, j, k +
1/2)``). This is the 2-D model's choice (its corner points are the 3-D edges seen end-on), so an
extruded 2-D problem reproduces the 2-D model exactly, and it is where the flux's
finite-volume face is: the weight is the fluid fraction of the surface the stress acts on,
which in a staggered grid is centred on the edge. ``K = mean(eps u_f)`` per unit body force
(``mu`` = 1, voxel units).

* ``extruded``: cylinders along z (:class:`penalty_scatter._Diffuse` extruded over ``NZ``
  cells) against the 2-D model (``penalty_scatter.wall_along`` / ``wall_across``): the
  relative difference of K, along (force along z) and across (force along x), one shift.
* ``spheres``: a simple cubic array of spheres (one per ``n^3`` box), force along x, against
  Zick & Homsy (1982) (:data:`reference_values.ZICK_HOMSY_SIMPLE_CUBIC`); mean, sd, min, max
  of the true error over ``SHIFTS`` sub-voxel shifts (seed 11, 3-D), and per solid fraction
  the number of shifts whose ``|error|`` falls strictly with ``n``.
* ``cutface``: the same table for the product's cut-face solver
  (:func:`solvers.voxel_stokes.solve_voxel_stokes` with the exact distance, tol 1e-9).
* ``iterations``: MINRES iterations of the assembled diffuse system against the staircase
  (eps 0 / 1, drag 0 / 1e6) at one shift, with either pressure block of
  :func:`solvers.voxel.diffuse_system.preconditioner`.
* ``product``: the product's solver (:func:`solvers.voxel.diffuse.solve_diffuse_stokes`) on
  the tilted array (``K``: ``12 K`` voxels per spacing) or the spheres (``N`` voxels per box)
  through :meth:`solvers.voxel.diffuse.DiffuseGrid.sample`, per axis, with its cost
  (:func:`_product`).
* ``tilted``: a square cylinder array along ``(3, 4, 0)`` (:class:`Tilted`; ``12 k`` voxels per
  spacing), along and across, diffuse wall and cut-face solver, against the published values.

Solves: ``scipy.sparse.linalg.splu`` up to :data:`DIRECT_MAX` unknowns, above that MINRES with
a block-diagonal preconditioner (a smoothed-aggregation AMG V-cycle, pyamg, on each velocity
block; the inverse diagonal of ``S = B diag(A)^-1 B^T``, the product's sub-voxel pressure
scaling, on the pressure: 41 MINRES iterations where an AMG V-cycle on ``S`` needed 173, spheres
c 0.216 at 32^3), relative residual 1e-10.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "benchmarks"), str(ROOT)]

from arrays import L, radius_of  # noqa: E402
from penalty_scatter import _Diffuse, parse_wall, wall_across, wall_along  # noqa: E402
from reference_values import zick_homsy_k  # noqa: E402
from validation_tables import reference_k  # noqa: E402

from solvers.voxel.diffuse import DiffuseGrid  # noqa: E402
from solvers.voxel.diffuse_system import assemble as assemble_grid  # noqa: E402
from solvers.voxel.diffuse_system import preconditioner  # noqa: E402

#: Unknowns up to which the saddle system is factorised (splu); above, MINRES.
DIRECT_MAX = 5_000
#: 3-D sub-voxel shifts of the sphere centre (seed 11, as the 2-D tables' shifts).
SHIFTS3 = [tuple(v) for v in np.random.default_rng(11).random((16, 3)).round(3)]


def _points(shape, offset) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coordinates (voxels) of the points ``(i, j, k) + offset`` of the grid."""
    axes = [np.arange(m, dtype=float) + o for m, o in zip(shape, offset, strict=True)]
    return np.meshgrid(*axes, indexing="ij")


def _force(force) -> np.ndarray:
    """A force axis (0, 1, 2) or a 3-vector as a 3-vector."""
    return np.eye(3)[force] if np.ndim(force) == 0 else np.asarray(force, dtype=float)


def field_grid(shape, field) -> DiffuseGrid:
    """``field.eps(x, y, z)`` and ``field.drag(x, y, z)`` (raveled arrays) at the points of a
    :class:`solvers.voxel.diffuse.DiffuseGrid` (cell centres, faces, edges)."""

    def at(fn, offset):
        return fn(*_points(shape, offset)).reshape(shape)

    faces = [tuple(0.0 if a == c else 0.5 for a in range(3)) for c in range(3)]
    edges = [tuple(0.5 if a == e else 0.0 for a in range(3)) for e in range(3)]
    return DiffuseGrid(
        cell=at(field.eps, (0.5, 0.5, 0.5)),
        face=np.stack([at(field.eps, f) for f in faces]),
        edge=np.stack([at(field.eps, e) for e in edges]),
        drag=np.stack([at(field.drag, f) for f in faces]),
    )


def assemble(shape, field, force):
    """The saddle matrix ``[[A, -G], [-G^T, P]]``, its right-hand side, per face component
    ``(eps, A_c, G_c)`` and the live pressure cells: :func:`solvers.voxel.diffuse_system.
    assemble` of the field sampled by :func:`field_grid` (``field.eps(x, y, z)`` and
    ``field.drag(x, y, z)`` give the wall as raveled arrays)."""
    system = assemble_grid(field_grid(shape, field), _force(force))
    return system.matrix(), system.rhs, system.blocks, system.live


def solve(shape, field, force, method: str = "auto", pressure: str = "diag") -> tuple[float, int]:
    """``K = mean(eps u . f)`` (voxel units) under the body force ``f`` (an axis or a unit
    3-vector) and the MINRES iterations (0: direct); ``method``
    ``auto`` (direct up to :data:`DIRECT_MAX` unknowns), ``direct`` or ``minres`` (scipy's
    MINRES, ``rtol`` 1e-10, one run: port22's figures); ``pressure`` the preconditioner's
    pressure block (:func:`solvers.voxel.diffuse_system.preconditioner`)."""
    system = assemble_grid(field_grid(shape, field), _force(force))
    n = system.n
    if method == "direct" or (method == "auto" and 4 * n <= DIRECT_MAX):
        x = spla.splu(system.matrix().tocsc(), permc_spec="MMD_AT_PLUS_A").solve(system.rhs)
        its = 0
    else:
        count = [0]

        def tick(_):
            count[0] += 1

        x, info = spla.minres(
            system.operator(),
            system.rhs,
            M=preconditioner(system, pressure),
            rtol=1e-10,
            maxiter=20000,
            callback=tick,
        )
        if info != 0:
            raise RuntimeError(f"MINRES did not converge (info {info})")
        its = count[0]
    f = _force(force)
    blocks = system.blocks
    flux = sum(f[c] * np.mean(blocks[c][0] * x[c * n : (c + 1) * n]) for c in range(3))
    return float(flux), its


class Extruded:
    """A 2-D field (:class:`penalty_scatter._Diffuse`) extruded along z."""

    def __init__(self, field2d) -> None:
        self.f = field2d

    def eps(self, x, y, z):
        return np.broadcast_to(
            self.f.eps(x[:, :, 0], y[:, :, 0])[:, None], (x[:, :, 0].size, x.shape[2])
        ).ravel()

    def drag(self, x, y, z):
        return np.broadcast_to(
            self.f.drag(x[:, :, 0], y[:, :, 0])[:, None], (x[:, :, 0].size, x.shape[2])
        ).ravel()


class Spheres:
    """A simple cubic array of spheres, one per ``n^3`` box, centred at ``n / 2 + shift``,
    solid fraction ``c``; per point the two nearest spheres (of the 27 periodic images) each
    carry a wall (``pair``): signed distance ``r - a``, curvature ``kappa`` = the Laplacian of
    the distance ``2 / r``, grid anisotropy ``n_x^4 + n_y^4 + n_z^4`` of the normal."""

    def __init__(self, c: float, n: int, shift, wall) -> None:
        self.n, self.wall = n, wall
        self.radius = n * (3.0 * c / (4.0 * np.pi)) ** (1.0 / 3.0)
        self.centre = n / 2.0 + np.asarray(shift, dtype=float)

    def _walls(self, x, y, z):
        rel = [p - c for p, c in zip((x, y, z), self.centre, strict=True)]
        rel = [(d - self.n * np.round(d / self.n)).ravel() for d in rel]
        images = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])
        dx = rel[0][None] + self.n * images[:, 0, None]
        dy = rel[1][None] + self.n * images[:, 1, None]
        dz = rel[2][None] + self.n * images[:, 2, None]
        r = np.sqrt(dx * dx + dy * dy + dz * dz)
        out = []
        for k in np.argsort(r, axis=0)[:2]:
            pick = [np.take_along_axis(v, k[None], 0)[0] for v in (dx, dy, dz)]
            rk = np.maximum(np.take_along_axis(r, k[None], 0)[0], 1e-9)
            aniso = (pick[0] ** 4 + pick[1] ** 4 + pick[2] ** 4) / rk**4
            out.append((rk - self.radius, 2.0 / np.maximum(rk, 0.5), aniso))
        return out

    def eps(self, x, y, z):
        return np.prod([self.wall.eps(*w) for w in self._walls(x, y, z)], axis=0)

    def drag(self, x, y, z):
        return np.sum([self.wall.drag(s, a) for s, _, a in self._walls(x, y, z)], axis=0)

    def exact_k(self) -> float:
        """Zick & Homsy's K in voxels^2: ``F = 6 pi mu a K* U`` per sphere balances the mean
        pressure gradient over the box, so ``k = 2 a^2 / (9 c K*)``."""
        c = 4.0 / 3.0 * np.pi * self.radius**3 / self.n**3
        return 2.0 * self.radius**2 / (9.0 * c * zick_homsy_k(c))


class Tilted:
    """A square array of cylinders along ``(3, 4, 0) / 5`` in a periodic ``15 k x 20 k x 12 k``
    box: the box vectors project onto the plane across the axis as a square lattice of spacing
    ``12 k`` (``(15 k, 0, 0) . (4, -3, 0) / 5 = 12 k``, ``(0, 20 k, 0)`` gives ``-12 k``,
    ``(0, 0, 12 k)`` is across the axis), one cylinder per box. Per point the two nearest
    cylinders each carry a wall (``pair``); the curvature is ``1 / r``; the anisotropy is that
    of the 3-D normal ``(4 xi / 5, -3 xi / 5, eta) / r``, which lies in no grid plane."""

    AXIS = (0.6, 0.8, 0.0)

    def __init__(self, phi: float, k: int, shift, wall) -> None:
        self.s, self.wall = 12 * k, wall
        self.radius = radius_of(phi, "square", spacing=self.s)
        self.shift = np.asarray(shift, dtype=float)

    @staticmethod
    def shape(k: int) -> tuple[int, int, int]:
        return 15 * k, 20 * k, 12 * k

    def _walls(self, x, y, z):
        xi = (0.8 * x - 0.6 * y).ravel() - self.s / 2.0 - self.shift[0]
        eta = z.ravel() - self.s / 2.0 - self.shift[1]
        xi = xi - self.s * np.round(xi / self.s)
        eta = eta - self.s * np.round(eta / self.s)
        images = [(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)]
        dxi = np.stack([xi + self.s * i for i, _ in images])
        deta = np.stack([eta + self.s * j for _, j in images])
        r = np.hypot(dxi, deta)
        out = []
        for pick in np.argsort(r, axis=0)[:2]:
            a = np.take_along_axis(dxi, pick[None], 0)[0]
            b = np.take_along_axis(deta, pick[None], 0)[0]
            rk = np.maximum(np.hypot(a, b), 1e-9)
            aniso = ((0.8 * a) ** 4 + (0.6 * a) ** 4 + b**4) / rk**4
            out.append((rk - self.radius, 1.0 / np.maximum(rk, 0.5), aniso))
        return out

    eps = Spheres.eps
    drag = Spheres.drag


def tilted_error(phi: float, k: int, shift, wall, flow: str) -> tuple[float, int]:
    """True error of K of the tilted array (:class:`Tilted`), ``flow`` ``along`` (force along
    the axis) or ``across`` (force along z), against the published square-array value."""
    geo = Tilted(phi, k, shift, wall)
    kv, its = solve(Tilted.shape(k), geo, Tilted.AXIS if flow == "along" else 2)
    return kv * (L / geo.s) ** 2 / reference_k("square", flow, phi) - 1.0, its


def tilted_cutface(phi: float, k: int, shift) -> tuple[float, float, int]:
    """The cut-face solver's true errors on the tilted array, along and across (``K_along``
    from ``K_xx = K_along a_x^2 + K_across (1 - a_x^2)``), and its iterations (x and z)."""
    from solvers.voxel_stokes import solve_voxel_stokes

    shape = Tilted.shape(k)
    geo = Tilted(phi, k, shift, None)
    s = geo._walls(*_points(shape, (0.5, 0.5, 0.5)))[0][0].reshape(shape).astype(np.float32)
    kk, its = [], 0
    for axis in (0, 2):
        res = solve_voxel_stokes(s <= 0, 1.0, axis, distance=s, tol=1e-9)
        if not res.converged:
            raise RuntimeError("cut-face solve did not converge")
        kk.append(float(res.mean_velocity[axis] / res.pressure_gradient))
        its += int(res.iterations)
    across = kk[1]
    along = (kk[0] - across * (1.0 - 0.36)) / 0.36
    scale = (L / geo.s) ** 2
    return (
        along * scale / reference_k("square", "along", phi) - 1.0,
        across * scale / reference_k("square", "across", phi) - 1.0,
        its,
    )


def extruded_check(wall, phi: float, n: int, nz: int) -> tuple[float, float]:
    """Relative difference of K between the 3-D model on cylinders along z (``nz`` cells) and
    the 2-D model, along and across, at one shift."""
    shift = (0.13, 0.41)
    out = []
    for flow, axis, fn in (("along", 2, wall_along), ("across", 0, wall_across)):
        field = Extruded(_Diffuse(phi, n, shift, wall, "pair"))
        k3, _ = solve((n, n, nz), field, axis, "direct")
        k2 = (fn(phi, n, shift, wall, "pair") + 1.0) * reference_k("square", flow, phi)
        out.append(k3 * (L / n) ** 2 / k2 - 1.0)
    return out[0], out[1]


def cutface_k(c: float, n: int, shift) -> tuple[float, int]:
    """K (voxels^2) of the product's cut-face solver on the spheres, and its iterations."""
    from solvers.voxel_stokes import solve_voxel_stokes

    geo = Spheres(c, n, shift, None)
    x, y, z = _points((n, n, n), (0.5, 0.5, 0.5))
    s = geo._walls(x, y, z)[0][0].reshape(n, n, n)
    res = solve_voxel_stokes(s <= 0, 1.0, 0, distance=s.astype(np.float32), tol=1e-9)
    if not res.converged:
        raise RuntimeError("cut-face solve did not converge")
    return float(res.mean_velocity[0] / res.pressure_gradient), int(res.iterations)


def _table(fn, fracs, ns, shifts) -> None:
    """Per solid fraction and resolution mean, sd, min, max of the true error over the shifts;
    per solid fraction the number of shifts whose ``|error|`` falls strictly with ``n``."""
    for c in fracs:
        rows = []
        for n in ns:
            t0 = time.time()
            res = [fn(c, n, sh) for sh in shifts]
            e = np.array([r[0] for r in res])
            its = [r[1] for r in res]
            rows.append(e)
            sd = 100 * e.std(ddof=1) if len(e) > 1 else 0.0
            print(
                f"c {c} n {n}: mean {100 * e.mean():+.4f} %, sd {sd:.4f} %, min"
                f" {100 * e.min():+.4f}, max {100 * e.max():+.4f}; iterations {its};"
                f" {time.time() - t0:.1f} s",
                flush=True,
            )
        err = np.abs(np.array(rows))
        mono = int(np.all(np.diff(err, axis=0) < 0, axis=0).sum())
        print(f"c {c}: |error| strictly falling at {mono} / {len(shifts)} shifts", flush=True)


class Staircase(Spheres):
    """The same spheres as a staircase: ``eps`` 1 / 0 and drag 0 / 1e6 by the sign of the
    nearest sphere's distance at each point (the preconditioner's reference problem)."""

    def eps(self, x, y, z):
        return (self._walls(x, y, z)[0][0] > 0).astype(float)

    def drag(self, x, y, z):
        return np.where(self._walls(x, y, z)[0][0] > 0, 0.0, 1e6)


def _iterations(wall, c: float, n: int) -> int:
    """MINRES iterations and wall time, diffuse wall against staircase, one shift, with the
    AMG and the diagonal pressure block."""
    for pressure in ("amg", "diag"):
        for name, geo in (
            ("diffuse", Spheres(c, n, SHIFTS3[0], wall)),
            ("staircase", Staircase(c, n, SHIFTS3[0], wall)),
        ):
            t0 = time.time()
            kv, its = solve((n, n, n), geo, 0, "minres", pressure)
            print(
                f"{name} c {c} n {n} pressure block {pressure}: K {kv:.8e} voxel^2, {its} MINRES"
                f" iterations, {time.time() - t0:.1f} s",
                flush=True,
            )
    return 0


def _tilted(argv: list[str]) -> int:
    """``tilted WALL PHI K,...  SHIFTS``: the tilted array, diffuse wall along and across and
    the cut-face solver, per ``k`` (``12 k`` voxels per spacing) and shift; then per method
    and flow the mean and sd over the shifts and the number of shifts whose ``|error|`` falls
    strictly with ``k``."""
    wall, phi = parse_wall(argv[0]), float(argv[1])
    ks = [int(v) for v in argv[2].split(",")]
    shifts = [tuple(float(x) for x in v) for v in np.random.default_rng(11).random((8, 2)).round(3)]
    shifts = shifts[: int(argv[3]) if len(argv) > 3 else 2]
    errs = np.zeros((4, len(ks), len(shifts)))  # diffuse along, across, cut along, across
    for a, k in enumerate(ks):
        for b, sh in enumerate(shifts):
            t0 = time.time()
            cut = tilted_cutface(phi, k, sh)
            t1 = time.time()
            row = [tilted_error(phi, k, sh, wall, flow) for flow in ("along", "across")]
            errs[:, a, b] = row[0][0], row[1][0], cut[0], cut[1]
            print(
                f"phi {phi} {12 * k} voxels per spacing, shift {sh}: diffuse along"
                f" {100 * row[0][0]:+.4f} %, across {100 * row[1][0]:+.4f} % (MINRES"
                f" {row[0][1]}, {row[1][1]}; {time.time() - t1:.0f} s); cut-face along"
                f" {100 * cut[0]:+.4f} %, across {100 * cut[1]:+.4f} % ({cut[2]} iterations,"
                f" {t1 - t0:.0f} s)",
                flush=True,
            )
    names = ("diffuse along", "diffuse across", "cut-face along", "cut-face across")
    for name, e in zip(names, errs, strict=True):
        sd = e.std(axis=1, ddof=1) if len(shifts) > 1 else np.zeros(len(ks))
        mono = int(np.all(np.diff(np.abs(e), axis=0) < 0, axis=0).sum())
        print(
            f"{name}: mean {' / '.join(f'{100 * m:+.4f}' for m in e.mean(axis=1))} %, sd"
            f" {' / '.join(f'{100 * v:.4f}' for v in sd)} %; |error| strictly falling at"
            f" {mono} / {len(shifts)} shifts",
            flush=True,
        )
    return 0


def _product_geometry(wall, kind: str, size: float, n: int):
    """``(shape, walls, exact)``: the tilted array (``size`` phi, ``n`` = k) or the simple
    cubic spheres (``size`` c, ``n`` voxels per box), first seed-11 shift; ``exact(axis, K)``
    the true error of the axis' K where it has one (across the tilted array; the spheres)."""
    if kind == "tilted":
        shift = tuple(np.random.default_rng(11).random((8, 2)).round(3)[0])
        geo = Tilted(size, n, shift, wall)
        scale = (L / geo.s) ** 2

        def exact(axis, k):
            if axis != 2:
                return float("nan")
            return k * scale / reference_k("square", "across", size) - 1.0

        return Tilted.shape(n), geo, exact
    geo = Spheres(size, n, SHIFTS3[0], wall)
    return (n, n, n), geo, lambda axis, k: k / geo.exact_k() - 1.0


def _product(argv: list[str]) -> int:
    """``product WALL tilted|spheres PHI|C K|N [AXES] [TOL] [check]``: the product's solver
    (:func:`solvers.voxel.diffuse.solve_diffuse_stokes` on :meth:`DiffuseGrid.sample`) per axis:
    K (voxel^2), true error where known, MINRES iterations, true residual, times and the peak
    RSS; with all of x, y, z on the tilted array also K along the axis ``f^T K f``; ``check``
    runs :func:`solve` (this benchmark's scipy MINRES, ``rtol`` 1e-10) on the same field and
    prints the relative difference of K."""
    import resource

    from solvers.voxel.diffuse import diffuse_memory_bytes, solve_diffuse_stokes

    wall, kind, size, n = parse_wall(argv[0]), argv[1], float(argv[2]), int(argv[3])
    axes = [int(a) for a in (argv[4] if len(argv) > 4 else "0,1,2").split(",")]
    tol = float(argv[5]) if len(argv) > 5 else 1e-8
    shape, geo, exact = _product_geometry(wall, kind, size, n)
    cells = int(np.prod(shape))
    t0 = time.time()
    grid = DiffuseGrid.sample(shape, geo._walls, wall)
    print(
        f"{kind} {size} n {n}: grid {shape}, {cells} cells, sampled in {time.time() - t0:.1f} s;"
        f" model {diffuse_memory_bytes(shape) / 1e9:.3f} GB",
        flush=True,
    )
    kk = {}
    for axis in axes:
        res = solve_diffuse_stokes(grid, 1.0, axis, tol=tol)
        kk[axis] = res.mean_velocity
        print(
            f"axis {axis}: K {res.mean_velocity[axis]:.12e} voxel^2, true error"
            f" {100 * exact(axis, res.mean_velocity[axis]):+.4f} %, {res.iterations} MINRES"
            f" iterations, residual {res.residual:.2e}, converged {res.converged},"
            f" {res.wall_time_s:.1f} s, peak RSS {res.peak_memory_mb:.0f} MiB",
            flush=True,
        )
    if kind == "tilted" and set(axes) >= {0, 1}:
        along = 0.36 * kk[0][0] + 0.48 * (kk[0][1] + kk[1][0]) + 0.64 * kk[1][1]
        err = along * (L / geo.s) ** 2 / reference_k("square", "along", size) - 1.0
        print(f"along f^T K f {along:.12e} voxel^2, true error {100 * err:+.4f} %", flush=True)
        kk["along"] = along
    if "check" in argv[4:]:
        for axis, force in ((2, 2), ("along", Tilted.AXIS)):
            if axis in kk:
                ref, its = solve(shape, geo, force)
                got = kk[axis] if axis == "along" else kk[axis][axis]
                print(
                    f"{axis}: benchmark solve K {ref:.12e}, product / benchmark - 1 "
                    f"{got / ref - 1.0:+.2e} ({its} iterations)",
                    flush=True,
                )
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0
    print(f"total {time.time() - t0:.1f} s, peak RSS {peak / 1e9:.3f} GB", flush=True)
    return 0


def main(argv: list[str]) -> int:
    """Dispatch on the first argument (module docstring)."""
    names = ("extruded", "spheres", "cutface", "iterations", "tilted", "product")
    if not argv or argv[0] not in names:
        print("\n\n".join(__doc__.split("\n\n")[1:3]))
        return 2
    if argv[0] == "product":
        return _product(argv[1:])
    if argv[0] == "extruded":
        wall = parse_wall(argv[1])
        phi = float(argv[2]) if len(argv) > 2 else 0.3
        for n in [int(v) for v in (argv[3] if len(argv) > 3 else "24,32").split(",")]:
            for nz in [int(v) for v in (argv[4] if len(argv) > 4 else "1,2,4").split(",")]:
                along, across = extruded_check(wall, phi, n, nz)
                print(
                    f"phi {phi} n {n} nz {nz}: 3-D / 2-D - 1 along {along:+.3e}, across"
                    f" {across:+.3e}",
                    flush=True,
                )
        return 0
    if argv[0] == "tilted":
        return _tilted(argv[1:])
    if argv[0] == "iterations":
        return _iterations(parse_wall(argv[1]), float(argv[2]), int(argv[3]))
    k = 1 if argv[0] == "spheres" else 0
    fracs = [
        float(v) for v in (argv[1 + k] if len(argv) > 1 + k else "0.064,0.125,0.216").split(",")
    ]
    ns = [int(v) for v in (argv[2 + k] if len(argv) > 2 + k else "16,20,24,32").split(",")]
    shifts = SHIFTS3[: int(argv[3 + k]) if len(argv) > 3 + k else 4]
    if argv[0] == "spheres":
        wall = parse_wall(argv[1])

        def fn(c, n, sh):
            geo = Spheres(c, n, sh, wall)
            kv, its = solve((n, n, n), geo, 0)
            return kv / geo.exact_k() - 1.0, its
    else:

        def fn(c, n, sh):
            kv, its = cutface_k(c, n, sh)
            return kv / Spheres(c, n, sh, None).exact_k() - 1.0, its

    _table(fn, fracs, ns, shifts)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
