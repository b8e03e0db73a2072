"""Fully periodic Stokes flow on a voxel grid and the permeability tensor (Darcy's law).

Method and reasons
------------------
*Discretisation*: staggered-grid (MAC) finite volumes on the voxels.  Pressure lives at fluid
cell centres, each velocity component on the cell faces normal to it; a face between two fluid
cells is an unknown, a face touching a solid cell is zero (no penetration, no slip on the voxel
surface).  The viscous term is the 7-point Laplacian with the wall exactly on the voxel faces
(ghost value ``-u`` for a wall half a cell away, ``0`` for a node on a solid surface).  The scheme
is conservative, has no spurious pressure modes (no stabilisation needed, unlike the Q1-Q1 FEM of
PuMA), and needs only a voxel mask: walls coincide with voxel faces, so there is no geometric
ambiguity.

*Accuracy*: for walls aligned with the grid the scheme is second order; for plane Poiseuille flow
with ``H`` fluid voxels across, the discrete solution is exactly ``K = phi (H^2/12 + h^2/6)``
(relative error ``2 (h/H)^2``), and :func:`richardson_extrapolate` with order 2 removes it.  For
curved surfaces the voxel staircase dominates.  On random fibre RVEs the errors of many fibres
at random angles average out and K converges fast (Toray-like, 7 um fibres: +1.2 % at 7,
+0.15 % at 10.5 voxels per diameter, relative to 21 voxels), so refinement to about 8 voxels
per diameter gives 1 %.  For a single ordered array the staircase error is first order with a
sign that oscillates with how the surface cuts the grid (Sangani & Acrivos arrays: +7.7 % at
32, -1.8 % at 64, +0.8 % at 128 cells per period), so Richardson extrapolation is not reliable
there; refine instead.  Measured figures: ``benchmarks/RESULTS.md``.

*Solver* (chosen by measurement, see ``benchmarks/RESULTS.md``): preconditioned MINRES on
the symmetric saddle-point system ``[[A, G], [G^T, 0]]`` with the block-diagonal preconditioner
``diag(V_u, V_v, V_w, I)`` (Elman, Silvester & Wathen, *Finite Elements and Fast Iterative
Solvers*, ch. 4):

* ``A`` is, per velocity component, the scalar no-slip Laplacian; ``V_a`` is one symmetric
  V-cycle of a matrix-free aggregation multigrid (:mod:`solvers.voxel.multigrid`): Galerkin
  coarse operators of 2x2x2 box aggregates (semi-coarsening on axes of < 4 cells, odd sizes
  absorbed in the last aggregate), damped Jacobi, over-weighted coarse correction, sparse LU on
  the coarsest level.  Galerkin coarsening keeps the wall drag of the fine grid on every level
  however thin the fibres are, which is what broke the former re-discretised coupled (Vanka)
  multigrid on Toray-like grids (residual 1.2 after 80 cycles at 100^3).
* the pressure block uses the pressure mass matrix (``h^3/mu`` times the identity, i.e. the
  identity in the voxel units used internally): for MAC, ``G^T (-Laplacian)^-1 G`` is exactly
  the identity in a wall-free periodic box.
* MINRES runs in float32 (7 vectors of 4 fields) inside a float64 iterative refinement: the
  residual ``b - K x`` and the solution are float64, each MINRES run reduces its preconditioned
  residual by up to ``INNER_RTOL_FLOOR`` and restarts on the new residual; the reported
  ``residual`` is always the true float64 ``||b - K x|| / ||b||``.  ``converged`` is True only
  when that reaches ``tol``; exhausting ``max_iter`` MINRES iterations, three refinement cycles
  without halving the residual, or loss of positivity of the preconditioner (round-off) stop
  the solve with ``converged=False`` and a ``message``.

Measured (Toray-like 48^3-200^3, PuMA and cylinder grids): 40-260 MINRES iterations for 1e-6;
with an exact velocity solve about two thirds of them remain (the inf-sup constant of the
fibrous geometry, not the multigrid, sets the count); adding a Darcy-type
``(G^T G)^-1`` pressure term (Cahouet-Chabard style) saved only 20 % of the iterations at 25 %
more work per iteration and was dropped.  Memory is O(N): about 170 bytes per voxel (float64
solution, 7 float32 4-field vectors, uint8 stencils); there is no assembled matrix.  Kernels run
on one numba thread below ``PARALLEL_MIN_CELLS`` cells (100 000; a parallel region costs up to
~15 ms start-up on a busy machine) and on all numba threads above.

Kernel design (speed): every stencil kernel walks rows along the last axis through 1-D views
with branch-free bodies, so LLVM vectorises them (only the two periodic row ends use a wrapping
scalar stencil); this made the V-cycle 3x and the operator product 3x faster than the
point-wise version.  The solve is then memory-bandwidth bound (about 28 GB/s here, the same
with one or two threads), so MINRES passes are fused (see :func:`_minres`) and the last
smoothing sweep of each V-cycle writes straight into the output.

Driving force and averages
--------------------------
The flow is driven by a unit mean pressure gradient (body force ``G``) along ``direction`` in a
fully periodic box.  ``K_ij = mu <u_i> / G_j`` with ``<.>`` the average over the *whole* grid
including solid (superficial velocity).
"""

from __future__ import annotations

import resource
import time
from collections import deque
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field

import numba
import numpy as np
from scipy import ndimage

from solvers.voxel import kernels as kr
from solvers.voxel import multigrid as mg

__all__ = [
    "VoxelFlowResult",
    "VoxelStokesError",
    "percolates",
    "richardson_extrapolate",
    "solve_voxel_stokes",
    "voxel_permeability_tensor",
]

_AXES = {"x": 0, "y": 1, "z": 2, 0: 0, 1: 1, 2: 2}
_TREATMENTS = ("periodic", "mirror", "frame")


class VoxelStokesError(ValueError):
    """Bad input to the voxel Stokes solver."""


@dataclass
class VoxelFlowResult:
    """Result of one periodic voxel Stokes solve.

    Attributes
    ----------
    permeability : np.ndarray, shape (3,)
        Column ``K[:, direction]`` of the permeability tensor in m^2 (superficial velocity).
    direction : int
        Axis of the driving pressure gradient (0, 1, 2).
    porosity : float
        Fluid fraction of the solved grid (after the periodic treatment).
    converged : bool
        The true relative residual reached ``tol`` (see ``message`` otherwise).
    iterations : int
        MINRES iterations used (each costs one operator product and one preconditioner,
        i.e. three scalar multigrid V-cycles).
    residual : float
        Final true relative residual ``||b - K x|| / ||b||`` (momentum and continuity, voxel
        units, float64).
    n_cells : int
        Number of fluid cells.
    wall_time_s : float
        Wall time of the solve incl. set-up (s).
    peak_memory_mb : float
        Peak resident memory of the process so far (MB, from ``getrusage``).
    velocity : np.ndarray or None
        ``(3, nx, ny, nz)`` float32 face velocities (m/s) for a unit pressure gradient (1 Pa/m)
        and the
        given viscosity, on the solved grid; ``None`` unless ``return_velocity=True``.
    history : list of float
        True relative residual before the first and after each refinement cycle.
    periodic_treatment : str
        Treatment applied before solving.
    flux_imbalance : float
        ``(max - min) / mean`` of the volumetric flow rate through the grid planes normal to
        ``direction`` (mass-conservation check; ~ ``residual`` for a converged solve).
    message : str
        ``"converged"`` or why the iteration stopped.
    """

    permeability: np.ndarray
    direction: int
    porosity: float
    converged: bool
    iterations: int
    residual: float
    n_cells: int
    wall_time_s: float
    peak_memory_mb: float
    velocity: np.ndarray | None = None
    history: list[float] = field(default_factory=list)
    periodic_treatment: str = "periodic"
    flux_imbalance: float = float("nan")
    message: str = ""


def _check_solid(solid: object) -> np.ndarray:
    if not isinstance(solid, np.ndarray):
        raise VoxelStokesError(f"solid must be a numpy bool array, got {type(solid).__name__}")
    if solid.dtype != np.bool_:
        raise VoxelStokesError(f"solid must have dtype bool (True = solid), got {solid.dtype}")
    if solid.ndim != 3:
        raise VoxelStokesError(f"solid must be 3-D (nx, ny, nz), got ndim={solid.ndim}")
    if min(solid.shape) < 1:
        raise VoxelStokesError(f"solid must be non-empty, got shape {solid.shape}")
    return solid


def _check_direction(direction: object) -> int:
    key = direction.lower() if isinstance(direction, str) else direction
    if isinstance(key, bool) or key not in _AXES:
        raise VoxelStokesError(
            f"direction must be one of 'x', 'y', 'z', 0, 1, 2; got {direction!r}"
        )
    return _AXES[key]


def percolates(solid: np.ndarray, direction: int) -> bool:
    """True if the fluid (``~solid``, face-connected) winds around the periodic box along
    ``direction``.

    Labels the fluid without wrap, links the labels across the periodic boundaries with a lattice
    offset and looks for a loop of non-zero net offset along ``direction`` (a percolating path).
    """
    lab, nlab = ndimage.label(~solid)
    if nlab == 0:
        return False
    adj: list[list[tuple[int, tuple[int, int, int]]]] = [[] for _ in range(nlab + 1)]
    for a in range(3):
        last = np.take(lab, -1, axis=a).ravel()
        first = np.take(lab, 0, axis=a).ravel()
        ok = (last > 0) & (first > 0)
        pairs = np.unique(np.stack([last[ok], first[ok]], axis=1), axis=0)
        off = [0, 0, 0]
        off[a] = 1
        for s, t in pairs:
            adj[int(s)].append((int(t), (off[0], off[1], off[2])))
            adj[int(t)].append((int(s), (-off[0], -off[1], -off[2])))
    pot: dict[int, tuple[int, int, int]] = {}
    for start in range(1, nlab + 1):
        if start in pot or not adj[start]:
            continue
        pot[start] = (0, 0, 0)
        queue = deque([start])
        while queue:
            x = queue.popleft()
            px = pot[x]
            for y, off in adj[x]:
                py = (px[0] + off[0], px[1] + off[1], px[2] + off[2])
                if y not in pot:
                    pot[y] = py
                    queue.append(y)
                elif pot[y][direction] != py[direction]:
                    return True
    return False


def _apply_treatment(solid: np.ndarray, d: int, treatment: str) -> np.ndarray:
    if treatment == "periodic":
        return solid
    if treatment == "mirror":
        return np.concatenate([solid, np.flip(solid, axis=d)], axis=d)
    pad = [(0, 0)] * 3
    for a in range(3):
        if a != d:
            pad[a] = (0, 1)
    return np.pad(solid, pad, constant_values=True)


def solve_voxel_stokes(
    solid: np.ndarray,
    voxel_size: float,
    direction: str | int,
    viscosity: float = 1.0,
    tol: float = 1e-6,
    max_iter: int = 2000,
    periodic_treatment: str = "periodic",
    return_velocity: bool = False,
    progress: Callable[[int, float], None] | None = None,
) -> VoxelFlowResult:
    """Solve periodic Stokes flow driven by a mean pressure gradient along ``direction``.

    Parameters
    ----------
    solid : np.ndarray of bool, shape (nx, ny, nz)
        True = solid voxel, indexed ``[x, y, z]``.
    voxel_size : float
        Voxel edge length in metres (> 0).
    direction : {'x', 'y', 'z', 0, 1, 2}
        Axis of the driving pressure gradient.
    viscosity : float
        Dynamic viscosity in Pa s (> 0); K does not depend on it, the velocity field does.
    tol : float
        True relative residual at which the iteration stops (0 < tol < 1).
    max_iter : int
        Maximum number of MINRES iterations in total (>= 1).
    periodic_treatment : {'periodic', 'mirror', 'frame'}
        ``'periodic'``: the grid is used as is (it must be periodic, or the seams act as extra
        geometry). ``'mirror'``: the grid is doubled along ``direction`` by its mirror image, making
        it periodic along the flow; K is that of the symmetrised sample: the off-diagonal entries
        ``K[i, d]`` vanish by symmetry and ``K[d, d]`` is the series (harmonic-type) mean of the
        sample and its image, equal to the sample's for a statistically homogeneous sample.
        ``'frame'``: a one-voxel solid wall is added on the lateral faces (the two axes other than
        ``direction``); no flow crosses the lateral seams, the walls add drag (K is lowered by a
        wall-layer effect of relative order pore size / box width) and lateral flow is suppressed.
        In all cases ``<u>`` is averaged over the solved (treated) grid.
    return_velocity : bool
        Return the velocity field (float32, 3 x grid) in ``result.velocity``.
    progress : callable, optional
        ``progress(iterations, residual)`` is called every ``PROGRESS_EVERY`` MINRES iterations
        with the running estimate of the relative residual, and after each refinement cycle
        with the true one (for progress reports on long solves).

    Returns
    -------
    VoxelFlowResult

    Raises
    ------
    VoxelStokesError (ValueError)
        Non-bool or non-3-D ``solid``, porosity 0 or 1, no percolating fluid path along
        ``direction``, bad ``direction``, ``voxel_size``, ``viscosity``, ``tol``, ``max_iter`` or
        ``periodic_treatment``.
    """
    t0 = time.perf_counter()
    solid = _check_solid(solid)
    d = _check_direction(direction)
    if not (np.isfinite(voxel_size) and voxel_size > 0):
        raise VoxelStokesError(f"voxel_size must be a finite length > 0 m, got {voxel_size!r}")
    if not (np.isfinite(viscosity) and viscosity > 0):
        raise VoxelStokesError(f"viscosity must be > 0 Pa s, got {viscosity!r}")
    if not (0.0 < tol < 1.0):
        raise VoxelStokesError(f"tol must be in (0, 1), got {tol!r}")
    if int(max_iter) < 1:
        raise VoxelStokesError(f"max_iter must be >= 1, got {max_iter!r}")
    if periodic_treatment not in _TREATMENTS:
        raise VoxelStokesError(
            f"periodic_treatment must be one of {_TREATMENTS}, got {periodic_treatment!r}"
        )
    phi0 = 1.0 - float(solid.mean())
    if phi0 <= 0.0 or phi0 >= 1.0:
        raise VoxelStokesError(
            f"solid has porosity {phi0:g}; it must be strictly between 0 and 1 "
            "(no fluid, or no solid: a solid-free periodic box has unbounded permeability)"
        )
    grid = _apply_treatment(solid, d, periodic_treatment)
    if not percolates(grid, d):
        raise VoxelStokesError(
            f"solid has no percolating fluid path along direction {'xyz'[d]!r} "
            "(periodic, face-connected fluid voxels)"
        )
    with _threads(grid.size):
        x, info = _solve_core(grid, d, tol, int(max_iter), progress)
    h2 = voxel_size * voxel_size
    k_col = np.array([x[a].mean() * h2 for a in range(3)])
    flow = x[d].sum(axis=tuple(b for b in range(3) if b != d))
    mean_flow = float(flow.mean())
    imbalance = float((flow.max() - flow.min()) / mean_flow) if mean_flow > 0 else float("inf")
    velocity = None
    if return_velocity:
        velocity = (x[:3] * (h2 / viscosity)).astype(np.float32)
    del x
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return VoxelFlowResult(
        permeability=k_col,
        direction=d,
        porosity=1.0 - float(grid.mean()),
        converged=info["converged"],
        iterations=info["iterations"],
        residual=info["residual"],
        n_cells=int(np.count_nonzero(~grid)),
        wall_time_s=time.perf_counter() - t0,
        peak_memory_mb=peak,
        velocity=velocity,
        history=info["history"],
        periodic_treatment=periodic_treatment,
        flux_imbalance=imbalance,
        message=info["message"],
    )


def voxel_permeability_tensor(
    solid: np.ndarray, voxel_size: float, viscosity: float = 1.0, **kw: object
) -> tuple[np.ndarray, list[VoxelFlowResult]]:
    """Full 3x3 permeability tensor (m^2) from three solves; column j = flow driven along j.

    Extra keyword arguments go to :func:`solve_voxel_stokes`.  Returns ``(K, results)``.
    """
    results = [
        solve_voxel_stokes(solid, voxel_size, d, viscosity=viscosity, **kw) for d in range(3)
    ]
    k = np.stack([res.permeability for res in results], axis=1)
    return k, results


def richardson_extrapolate(
    k_coarse: float | np.ndarray,
    k_fine: float | np.ndarray,
    ratio: float = 2.0,
    order: float = 1.0,
) -> float | np.ndarray:
    """Richardson extrapolation ``K_fine + (K_fine - K_coarse) / (ratio**order - 1)``.

    Parameters
    ----------
    k_coarse, k_fine : float or array
        Permeabilities of the same geometry at voxel sizes ``h`` and ``h / ratio``.
    ratio : float
        Refinement ratio (> 1).
    order : float
        Convergence order: 1 for voxelised curved surfaces (staircase), 2 for grid-aligned walls.
    """
    if not ratio > 1.0:
        raise VoxelStokesError(f"ratio must be > 1, got {ratio!r}")
    if not order > 0.0:
        raise VoxelStokesError(f"order must be > 0, got {order!r}")
    kc = np.asarray(k_coarse, dtype=float)
    kf = np.asarray(k_fine, dtype=float)
    out = kf + (kf - kc) / (ratio**order - 1.0)
    return float(out) if out.ndim == 0 else out


# ---------------------------------------------------------------------------------------------
# solver core (voxel units: h = 1, mu = 1, unit body force)

PARALLEL_MIN_CELLS = 100_000
"""Grids with fewer cells run the numba kernels on one thread.  Measured on an idle 2-core
machine with the row-vectorised kernels, two threads are faster from 32^3 up (100^3: 9.5 s ->
5.4 s, 150^3: 32.9 s -> 18.3 s); on a machine whose cores are busy with other work the start-up
latency of a parallel region (~15 ms under load) can make one thread faster for small grids,
so the tiny grids of tests and screening stay on one thread."""


@contextmanager
def _threads(n_cells: int):
    old = numba.get_num_threads()
    numba.set_num_threads(old if n_cells >= PARALLEL_MIN_CELLS else 1)
    try:
        yield
    finally:
        numba.set_num_threads(old)


class _Stokes:
    """Matrix-free MAC Stokes operator and block-diagonal preconditioner of one grid."""

    def __init__(self, solid: np.ndarray, **mg_kw: object) -> None:
        fluid = ~solid
        self.fluid = fluid.view(np.uint8)
        ops = [mg.component_operator(fluid, a) for a in range(3)]
        self.d = [o[0] for o in ops]
        self.c = [o[1] for o in ops]
        shp = solid.shape
        work = [np.zeros(shp, np.float32), np.zeros(shp, np.float32)]
        self._work = work
        self.mg = [mg.ScalarMG(o[0], o[1], work=work, **mg_kw) for o in ops]
        self.shape = (4, *shp)

    def apply(
        self, x: np.ndarray, y: np.ndarray, r: np.ndarray | None = None
    ) -> tuple[float, float]:
        """y = K x; returns ``(x . y, x . r)`` from the same pass (``r`` defaults to ``x``)."""
        xy, xr = kr.stokes_apply(*self.d, *self.c, self.fluid, x, y, x if r is None else r)
        return float(xy), float(xr)

    def residual(self, x: np.ndarray, gdir: int, r: np.ndarray) -> tuple[float, float]:
        rr, ff = kr.stokes_residual(*self.d, *self.c, self.fluid, x, gdir, r)
        return float(np.sqrt(rr)), float(np.sqrt(ff))

    def precondition(self, r: np.ndarray, z: np.ndarray) -> None:
        for a in range(3):
            self.mg[a].apply(r[a], z[a])
        np.copyto(z[3], r[3])


def _minres(
    op: _Stokes,
    b: np.ndarray,
    e: np.ndarray,
    bufs: list[np.ndarray],
    rtol: float,
    maxit: int,
    report: Callable[[int, float], None] | None = None,
) -> tuple[int, str]:
    """Preconditioned MINRES (Paige & Saunders; as scipy.sparse.linalg.minres) for K e = b.

    Works in the precision of ``b`` (float32 here); ``b`` is overwritten.  Stops when the
    preconditioned residual norm estimate has dropped by ``rtol``.  Returns (iterations, status).

    Memory passes are fused: the Lanczos vector ``v = z / beta`` is never stored (the scale is
    carried into the kernels), the operator product returns ``z . Kz`` and ``z . r1`` in the
    same pass, so ``alpha = v . (K v - c1 r1)`` needs no extra sweep, and the new Lanczos
    residual is formed in one sweep.  ``report(itn, phibar / beta1)`` is called every
    ``PROGRESS_EVERY`` iterations if given.
    """
    z, t, wa, wb, r1 = bufs
    for arr in (e, wa, wb, r1):
        arr.fill(0.0)
    r2 = b
    op.precondition(r2, z)
    beta1 = kr.dot(r2, z)
    if not beta1 > 0.0:
        return 0, "zero right-hand side" if beta1 == 0.0 else "preconditioner not positive"
    beta1 = np.sqrt(beta1)
    oldb, beta, dbar, epsln, phibar, cs, sn = 0.0, beta1, 0.0, 0.0, beta1, -1.0, 0.0
    for itn in range(1, maxit + 1):
        s = 1.0 / beta
        c1 = beta / oldb if itn >= 2 else 0.0
        zt, zr1 = op.apply(z, t, r1)
        alfa = s * s * zt - s * c1 * zr1
        kr.lanczos_step(t, s, r1, c1, r2, alfa / beta, r1)
        r1, r2 = r2, r1
        op.precondition(r2, t)
        oldb = beta
        beta = kr.dot(r2, t)
        if beta < 0.0:
            return itn, "preconditioner not positive"
        beta = np.sqrt(beta)
        oldeps = epsln
        delta = cs * dbar + sn * alfa
        gbar = sn * dbar - cs * alfa
        epsln = sn * beta
        dbar = -cs * beta
        gamma = max(np.hypot(gbar, beta), 1e-300)
        cs = gbar / gamma
        sn = beta / gamma
        phi = cs * phibar
        phibar = sn * phibar
        kr.minres_update(z, s, wb, wa, e, oldeps, delta, 1.0 / gamma, phi)
        wa, wb = wb, wa
        z, t = t, z
        if report is not None and itn % PROGRESS_EVERY == 0:
            report(itn, phibar / beta1)
        if phibar <= rtol * beta1:
            return itn, "ok"
        if beta == 0.0:
            return itn, "exact"
    return maxit, "max_iter"


PROGRESS_EVERY = 25
"""MINRES iterations between two progress reports."""

INNER_RTOL_FLOOR = 1e-4
"""Smallest relative reduction asked of one float32 MINRES run (float32 round-off floor)."""


def _solve_core(
    solid: np.ndarray,
    d: int,
    tol: float,
    max_iter: int,
    progress: Callable[[int, float], None] | None = None,
) -> tuple[np.ndarray, dict]:
    """Iterative refinement: float64 residual and solution, float32 preconditioned MINRES."""
    op = _Stokes(solid)
    shp = op.shape
    x = np.zeros(shp)
    r = np.empty(shp, np.float32)
    e = np.empty(shp, np.float32)
    bufs = [np.empty(shp, np.float32) for _ in range(5)]
    rn, bn = op.residual(x, d, r)
    rel = rn / bn
    history = [rel]
    total = 0
    message = "converged"
    stalls = 0
    while rel > tol:
        if total >= max_iter:
            message = f"max_iter={max_iter} MINRES iterations reached"
            break
        rtol = min(0.5, max(INNER_RTOL_FLOOR, 0.3 * tol / rel))
        report = None
        if progress is not None:
            done, scale = total, rel

            def report(itn: int, ratio: float, done: int = done, scale: float = scale) -> None:
                progress(done + itn, scale * ratio)

        its, status = _minres(op, r, e, bufs, rtol, max_iter - total, report)
        total += its
        if status == "preconditioner not positive":
            message = "preconditioner lost positivity (round-off); stopped"
            break
        kr.add_into(x, e)
        rn, _ = op.residual(x, d, r)
        new = rn / bn
        history.append(new)
        if progress is not None:
            progress(total, new)
        stalls = stalls + 1 if not new < 0.5 * rel else 0
        rel = new
        if not np.isfinite(rel) or stalls >= 3:
            message = "stalled: the residual stopped decreasing"
            break
    return x, {
        "converged": bool(rel <= tol),
        "iterations": total,
        "residual": float(rel),
        "history": history,
        "message": message if rel > tol else "converged",
    }
