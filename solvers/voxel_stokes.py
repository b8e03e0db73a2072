"""Stokes flow on a voxel grid (MAC finite volumes): fields and fluxes for Darcy's law.

The solver returns velocities, pressures, flow rates and the driving pressure gradient; the
permeability is formed by :mod:`psdesign.flow.voxel` through :mod:`psdesign.flow.darcy`.

Method and reasons
------------------
*Discretisation*: staggered-grid (MAC) finite volumes on the voxels.  Pressure lives at cell
centres, each velocity component on the cell faces normal to it.  The scheme is conservative and
has no spurious pressure modes (no stabilisation, unlike the Q1-Q1 FEM of PuMA).

*Walls* (:mod:`solvers.voxel.boundary`):

* ``staircase`` (a binary image): walls on the voxel faces; a face between two fluid cells is an
  unknown, the 7-point Laplacian uses the ghost value ``-u`` for a wall half a cell away and
  ``0`` for a node on a solid surface.  Second order for grid-aligned walls (plane Poiseuille
  with ``H`` fluid voxels: exactly ``K = phi (H^2/12 + h^2/6)``); for curved walls the staircase
  error is first order with a sign that oscillates with how the surface cuts the grid
  (Sangani & Acrivos arrays: +7.7 % at 32, -1.8 % at 64, +0.8 % at 128 cells per period).
* ``subvoxel`` (a signed distance is given): a face is an unknown when its centre lies in the
  fluid; the viscous term sees the wall at its true position (symmetric ghost-fluid diagonal
  ``1/theta``, Gibou et al. 2002) and the momentum and mass balances of the cut control volumes
  are weighted by their per-axis fluid fraction ``w_f`` (pressure force ``w_f dp``, flux
  ``w_f q_f``, body force ``w_f G``; the same weight on both off-diagonal blocks keeps the
  saddle-point matrix symmetric, the velocity blocks stay SPD).  Stored as the rounded uint8
  diagonal (the V-cycles' operator) plus the corrections of the cut faces only
  (:mod:`solvers.voxel.cutfaces`).  Plane Poiseuille with off-grid
  walls converges at second order; square/hexagonal arrays across and along are within 1 % at
  40 voxels per period for solid fractions 0.1-0.5 (``benchmarks/RESULTS.md``).  The pressure block
  of the preconditioner is the inverse diagonal of the weighted Schur complement (see
  ``PRESSURE_SCALING``), which keeps the iteration count near the staircase's (Toray-like
  40^3: 171 vs 133).

*Boundary conditions*: ``bc="periodic"`` (periodic on all faces, mean pressure gradient as a
body force: the homogenised K) or ``bc="permeameter"``: empty reservoirs before and after the
RVE along the flow (they join across the periodic face, so the body force applies the pressure
drop between the reservoir ends), lateral box faces as walls (``"slip"``: symmetry planes, zero
normal velocity and shear; ``"noslip"``), by editing only the operator coefficients on the box
faces (kernels, multigrid and MINRES unchanged).  ``rve_pressure_drop`` is the drop of the
fluid-face-averaged pressure between the RVE's own inlet and outlet planes (a diagnostic: it
keeps the entrance and exit losses); ``rve_energy_flux_profile`` (the mechanical energy flux per
unit flow rate on the RVE's face planes) gives the permeameter's windowed-dissipation drop, the
FEM route's definition (:func:`psdesign.flow.darcy.windowed_drop`).
Padding costs the reservoir volume (``1 + 2 aux_length`` times the RVE cells); mirroring the
lateral faces for slip walls would have cost 4x and a native pressure-Dirichlet inlet needs a
non-symmetric right-hand side path in every kernel.

*Solver* (chosen by measurement, see ``benchmarks/RESULTS.md``): preconditioned SYMMLQ
(MINRES before issue 16 session 7; the same Lanczos recurrence) on the symmetric saddle-point
system ``[[A, G], [G^T, 0]]`` with the block-diagonal preconditioner ``diag(V_u, V_v, V_w, I)``
(Elman, Silvester & Wathen, *Finite Elements and Fast Iterative Solvers*, ch. 4):

* ``A`` is, per velocity component, the scalar no-slip Laplacian; ``V_a`` is one symmetric
  V-cycle of a matrix-free aggregation multigrid (:mod:`solvers.voxel.multigrid`): Galerkin
  coarse operators of 2x2x2 box aggregates (semi-coarsening on axes of < 4 cells, odd sizes
  absorbed in the last aggregate), damped Jacobi, over-weighted coarse correction, sparse LU on
  the coarsest level.  Galerkin coarsening keeps the wall drag of the fine grid on every level
  however thin the fibres are, which is what broke the former re-discretised coupled (Vanka)
  multigrid on Toray-like grids (residual 1.2 after 80 cycles at 100^3).
* the pressure block (two-level since issue 16: *Pressure block* below) starts from the mass (the
  identity in the voxel units used internally): for MAC, ``G^T (-Laplacian)^-1 G`` is exactly
  the identity in a wall-free periodic box.
* the Krylov method is SYMMLQ (Paige & Saunders), moved to its CG point at the end of each run
  (:func:`_symmlq`; :data:`solvers.voxel.memory.KRYLOV`: MINRES, :func:`_minres`, on the same
  Lanczos recurrence, needs two directions instead of one); it runs in float32 (3 float32
  vectors of 4 fields and one direction, stored on the active unknowns only:
  :class:`solvers.voxel.lanczos.Packing`) inside an
  iterative refinement with a float64 residual ``b - K x``; the solution is float32 in the
  first refinement cycle and float32 plus an int16 extension (48 bits; int32 below ``tol`` 1e-7)
  from the second on (the Krylov run accumulates straight into it, :class:`solvers.voxel.
  lanczos.Solution`); each run reduces its preconditioned residual by up to
  ``INNER_RTOL_FLOOR`` and restarts on the new residual; the reported
  ``residual`` is always the true float64 ``||b - K x|| / ||b||``.  ``converged`` is True only
  when that reaches ``tol``; a cycle that does not halve the residual while the solution has
  the short int8 extension widens it first (:meth:`solvers.voxel.lanczos.Solution.widen`:
  int16 and float32 directions from then on); exhausting ``max_iter`` MINRES iterations, three
  refinement cycles without halving the residual, or loss of positivity of the preconditioner
  (round-off) stop the solve with ``converged=False`` and a ``message``.

Measured (Toray-like 48^3-200^3, PuMA and cylinder grids): 40-260 MINRES iterations for 1e-6;
with an exact velocity solve about two thirds of them remain (the inf-sup constant of the
fibrous geometry, not the multigrid, sets the count); adding a Darcy-type
``(G^T G)^-1`` pressure term (Cahouet-Chabard style) saved only 20 % of the iterations at 25 %
more work per iteration and was dropped.  Memory is O(N): about 84 bytes per voxel traced on a
periodic staircase Toray-like grid, at most 96 B counted (87.9 B traced on PuMA fibres_32, 95 %
of its unknowns active; at the default ``tol`` 1e-6,
:data:`solvers.voxel.memory.SHORT_SOLUTION_FROM`; 3 float32 4-field vectors; the 40-bit
solution and SYMMLQ's 24-bit later direction on the active unknowns only; uint8 diagonals, no stored
finest couplings, no fine multigrid work array), about 3 B more with sub-voxel walls (their
operator stored as the staircase's plus the cut faces, :mod:`solvers.voxel.cutfaces`: 85.4 B
traced on the Toray-like 64^3 grid; :mod:`solvers.voxel.memory`, checked before anything is
allocated); there is no assembled
matrix.  Threads
(:mod:`solvers.voxel.threads`): idle OpenMP threads sleep (``OMP_WAIT_POLICY=PASSIVE``);
grids and multigrid levels below :data:`solvers.voxel.threads.PARALLEL_MIN_CELLS` cells
(100 000; a parallel region costs up to ~15 ms start-up on a busy machine) run on one numba
thread, larger ones on all.

Kernel design (speed): every stencil kernel walks rows along the last axis through 1-D views
with branch-free bodies, so LLVM vectorises them (only the two periodic row ends use a wrapping
scalar stencil); this made the V-cycle 3x and the operator product 3x faster than the
point-wise version.  The solve is then memory-bandwidth bound (about 28 GB/s here, the same
with one or two threads), so MINRES passes are fused (see :func:`_minres`) and the last
smoothing sweep of each V-cycle writes straight into the output.

*Pressure block* (:mod:`solvers.voxel.schur`, :data:`COARSE_PRESSURE`): the inverse diagonal
of the Schur complement estimate ``G^T diag(A)^-1 G`` (1 in a wall-free box; a one-byte
logarithmic code, :func:`solvers.voxel.schur.schur_code`, the sub-voxel walls' weighted
too) plus a coarse Darcy correction ``R^T S_c^+ R`` on blocks of 4^3 cells
(:data:`solvers.voxel.schur.BLOCK`; 8^3 until session 10) with the Poisson permeability of each
block.  The pore-scale part alone leaves the long pressure waves,
whose Schur eigenvalues are ``K_P k^2``, and the MINRES count grew with the box side
(Toray-like at 1 um: 112 iterations at 48 um, 171 at 96, 206 at 100, 253 at 200, 456 at 400);
with both parts 94, 121, 151 and 176 at 48, 96, 100 and 200 um; either part alone does not
help (192 and 182 at 96 um).  Against the fine-grid ``(G^T G)^-1`` term above, the coarse
term costs one restriction pass over the pressure field and a V-cycle on N / 64 blocks
(``benchmarks/RESULTS.md``).  The 4^3 blocks took the count at 100 / 200 um from 153 / 187
(8^3) to 140 / 164 (session 10, "Issue 16 item 4, iteration growth").  Since session 11 the
coarse term has the weight 0.6 (:data:`solvers.voxel.schur.WEIGHT`) and the first refinement
cycle runs to 1e-5 (:data:`INNER_RTOL_FLOOR`): 140 / 157 / 222 / 307 iterations at 100 / 200 /
300 / 400 um before, 131 / 150 / 187 / 246 after (``benchmarks/RESULTS.md``, "Issue 16 item 4,
iteration growth (iter11)"; a local term for the blocks a fibre cuts into several fluid parts
was measured there and not kept).  Since session 14 each coarse transmissibility is at least
twice the interface's sum of ``w_f^2 / A_ff`` (:data:`solvers.voxel.schur.FACE_FLOOR`): the far
end of the spectrum was the coarse term over-correcting in small open pores of low smoothed
permeability; 104 / 139 / 164 / 182 -> 104 / 133 / 151 / 155 iterations at 100 / 200 / 300 /
400 um, 148 at 400 um with the knots of thin branches as thin cells too
(:data:`solvers.voxel.thin.JUNCTION`; ``benchmarks/RESULTS.md``, "Issue 16 item 4, the far end of
the spectrum (grow14)").

Driving force and averages
--------------------------
The flow is driven by a mean pressure gradient ``pressure_gradient`` (body force) along
``direction``.  ``mean_velocity`` is the superficial velocity (flux ``w_f q_f`` averaged over the
whole solved grid, solid and reservoirs included); ``flow_rate`` the flow through the grid
planes normal to the flow.  For ``bc="periodic"``, ``K[:, j] = mu <u> / G``.
"""

from __future__ import annotations

import math
import resource
import time
from collections import deque
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field

import numba
import numpy as np
from scipy import ndimage

from solvers import jit
from solvers.progress import PROGRESS_EVERY
from solvers.voxel import boundary as bd
from solvers.voxel import cutfaces as cf
from solvers.voxel import kernels as kr
from solvers.voxel import lanczos as lz
from solvers.voxel import memory as vmem
from solvers.voxel import multigrid as mg
from solvers.voxel import schur, thin
from solvers.voxel import threads as vthreads
from solvers.voxel.memory import reservoir_cells, solved_shape

__all__ = [
    "VoxelFlowResult",
    "NoFluidPathError",
    "VoxelStokesError",
    "check_percolates",
    "percolates",
    "reservoir_cells",
    "richardson_extrapolate",
    "solve_voxel_stokes",
    "solved_shape",
]

_AXES = {"x": 0, "y": 1, "z": 2, 0: 0, 1: 1, 2: 2}
_TREATMENTS = ("periodic", "mirror", "frame")
_BCS = ("periodic", "permeameter")
_SIDES = ("slip", "noslip")


class VoxelStokesError(ValueError):
    """Bad input to the voxel Stokes solver."""


class NoFluidPathError(VoxelStokesError):
    """The fluid does not percolate along the flow direction (:func:`check_percolates`)."""


@dataclass
class VoxelFlowResult:
    """Fields and fluxes of one voxel Stokes solve (no permeability: Darcy's law is applied by
    :mod:`psdesign.flow.voxel` through :mod:`psdesign.flow.darcy`).

    The flow is driven by a mean pressure gradient of magnitude ``pressure_gradient`` along
    ``direction`` (a body force on the periodic solved grid); all fields are linear in it.

    Attributes
    ----------
    mean_velocity : np.ndarray, shape (3,)
        Superficial mean velocity over the whole solved grid incl. solid and reservoirs (m/s).
    pressure_gradient : float
        Magnitude of the driving mean pressure gradient (Pa/m), along ``+direction``: the mean
        pressure falls along the flow.
    viscosity : float
        Dynamic viscosity used (Pa s).
    flow_rate : float
        Mean volumetric flow rate through the grid planes normal to ``direction`` (m^3/s).
    plane_flow_rates : np.ndarray
        Flow rate through every grid plane normal to ``direction`` (m^3/s).
    direction : int
        Axis of the driving pressure gradient (0, 1, 2).
    porosity : float
        Fluid fraction of the solved grid (cell centres in the fluid).
    converged, iterations, residual : bool, int, float
        True relative residual reached ``tol``; Krylov (SYMMLQ) iterations (each one operator
        product and three scalar V-cycles); final true relative residual ``||b - K x|| / ||b||``
        (voxel units, float64).
    n_cells : int
        Number of pressure cells (unknown mass balances).
    wall_time_s, peak_memory_mb : float
        Wall time of the solve incl. set-up (s); peak resident memory of the
        process (MiB: ``ru_maxrss`` / 1024; GNU time's "kbytes" are KiB too).
    velocity : np.ndarray or None
        ``(3, nx, ny, nz)`` float32 face velocities (m/s) on the solved grid, ``velocity[a][i, j,
        k]`` on the face between cells ``(i, j, k) - e_a`` and ``(i, j, k)``;
        ``None`` unless ``return_velocity=True``.
    pressure : np.ndarray or None
        ``(nx, ny, nz)`` float32 pressure at the cell centres (Pa) *without* the mean gradient
        (the total pressure is ``pressure - pressure_gradient * x_direction``), 0 off
        ``pressure_cells``; ``None`` unless ``return_pressure=True``.
    pressure_cells : np.ndarray or None
        ``(nx, ny, nz)`` bool: the cells that carry a pressure unknown and a mass balance (the
        cells with an active face, :func:`solvers.voxel.boundary.pressure_cells`; with sub-voxel
        walls these include cut cells whose centre lies in the solid, less the lone cells merged
        into a neighbour); ``None`` unless ``return_pressure=True``.
    history : list of float
        True relative residual before the first and after each refinement cycle.
    periodic_treatment : str
        Treatment applied before solving ('periodic' for the permeameter).
    flux_imbalance : float
        ``(max - min) / mean`` of ``plane_flow_rates`` (mass conservation; ~ ``residual``).
    message : str
        ``"converged"`` or why the iteration stopped.
    threads_used : int
        numba threads the solve's fine-grid kernels ran on (:func:`solvers.voxel.threads.
        thread_use`): 1 when the grid is small or when the parallel kernels were not compiled
        yet (run ``psdesign warmup``; :data:`solvers.jit.COMPILE_PARALLEL_ABOVE`).
    thread_note : str
        Why ``threads_used`` is fewer than numba's threads; ``""`` when it is not.
    serial_fallback : tuple of str
        Kernels that ran on one thread only because their parallel version was not compiled.
    bc : str
        ``"periodic"`` or ``"permeameter"``.
    wall_treatment : str
        ``"subvoxel"`` (a signed distance was given) or ``"staircase"``; ``"diffuse"`` from
        :func:`solvers.voxel.diffuse.solve_diffuse_stokes`.
    sides : str or None
        Lateral walls of the permeameter ('slip' | 'noslip'); None for periodic.
    rve_slice : tuple of int
        ``(start, stop)`` cell range of the RVE along ``direction`` in the solved grid.
    voxel_size : float
        Voxel edge (m).
    rve_pressure_drop : float
        Drop of the cross-section-averaged total pressure between the RVE's inlet and outlet
        planes (Pa; average over the fluid faces of each plane).  For ``bc="periodic"`` without
        treatment this is ``pressure_gradient * L``.
    rve_energy_flux_profile : np.ndarray or None
        Permeameter: the mechanical energy flux per unit flow rate ``E(s) / Q`` (Pa; pressure
        work minus viscous work through the plane, see ``_energy_flux_profile``) on each of the
        ``n + 1`` face planes of the RVE along ``direction``, relative to the inlet plane.  It
        falls by the dissipation; :func:`psdesign.flow.darcy.windowed_drop` forms from it the
        pressure drop without entrance and exit losses.  None for ``bc="periodic"``.
    rve_plane_pressure_profile : np.ndarray or None
        Permeameter: the mean total pressure over the active faces of the same planes (Pa,
        relative to the inlet plane; ``rve_pressure_drop`` is its end-to-end drop).  A second
        estimator of the same windowed drop with a different entrance residual (used for the
        error bar).  None for ``bc="periodic"``.
    rve_length, rve_area : float
        RVE length along ``direction`` (m) and full cross-section (m^2).
    applied_pressure_drop : float
        ``pressure_gradient`` times the solved grid length along ``direction`` (Pa): the drop
        between the reservoir ends for the permeameter.
    """

    mean_velocity: np.ndarray
    pressure_gradient: float
    viscosity: float
    flow_rate: float
    plane_flow_rates: np.ndarray
    direction: int
    porosity: float
    converged: bool
    iterations: int
    residual: float
    n_cells: int
    wall_time_s: float
    peak_memory_mb: float
    velocity: np.ndarray | None = None
    pressure: np.ndarray | None = None
    pressure_cells: np.ndarray | None = None
    history: list[float] = field(default_factory=list)
    periodic_treatment: str = "periodic"
    flux_imbalance: float = float("nan")
    message: str = ""
    threads_used: int = 1
    thread_note: str = ""
    serial_fallback: tuple[str, ...] = ()
    bc: str = "periodic"
    wall_treatment: str = "staircase"
    sides: str | None = None
    rve_slice: tuple[int, int] = (0, 0)
    voxel_size: float = float("nan")
    rve_pressure_drop: float = float("nan")
    rve_energy_flux_profile: np.ndarray | None = None
    rve_plane_pressure_profile: np.ndarray | None = None
    rve_length: float = float("nan")
    rve_area: float = float("nan")
    applied_pressure_drop: float = float("nan")


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


def _check_distance(distance: object, solid: np.ndarray) -> np.ndarray | None:
    if distance is None:
        return None
    if not isinstance(distance, np.ndarray) or distance.shape != solid.shape:
        raise VoxelStokesError(
            f"distance must be a float array of the grid's shape {solid.shape} (metres), got "
            f"{getattr(distance, 'shape', type(distance).__name__)}"
        )
    if not np.all(np.isfinite(distance)):
        raise VoxelStokesError("distance must be finite everywhere")
    if np.any((distance <= 0.0) != solid):
        raise VoxelStokesError(
            "distance must be <= 0 exactly on the solid voxels (distance <= 0 == solid)"
        )
    return distance


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


def check_percolates(solid: np.ndarray, direction: int, what: str) -> None:
    """Raise :class:`VoxelStokesError` unless the fluid of ``solid`` :func:`percolates` along
    ``direction``: without a fluid path a solver would return the leak through its walls, a
    tiny K that is no permeability.  ``what`` names the argument in the message."""
    if not percolates(solid, direction):
        raise NoFluidPathError(
            f"{what} has no percolating fluid path along direction {'xyz'[direction]!r} "
            "(periodic, face-connected fluid voxels)"
        )


def apply_treatment(
    solid: np.ndarray, d: int, treatment: str, phi: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
    """The solved grid of a periodic solve (and its distance ``phi``): the grid itself
    (``periodic``), with its mirror image along ``d`` (``mirror``) or a one-voxel solid frame
    on the high faces across ``d`` (``frame``)."""
    if treatment == "periodic":
        return solid, phi
    if treatment == "mirror":

        def cat(g: np.ndarray) -> np.ndarray:
            return np.concatenate([g, np.flip(g, axis=d)], axis=d)

        return cat(solid), (None if phi is None else cat(phi))
    pad = [(0, 0)] * 3
    for a in range(3):
        if a != d:
            pad[a] = (0, 1)
    grid = np.pad(solid, pad, constant_values=True)
    return grid, (None if phi is None else np.pad(phi, pad, constant_values=-0.5))


def _check_options(
    voxel_size: float, viscosity: float, tol: float, max_iter: int, treatment: str, bc: str
) -> None:
    if not (np.isfinite(voxel_size) and voxel_size > 0):
        raise VoxelStokesError(f"voxel_size must be a finite length > 0 m, got {voxel_size!r}")
    if not (np.isfinite(viscosity) and viscosity > 0):
        raise VoxelStokesError(f"viscosity must be > 0 Pa s, got {viscosity!r}")
    if not (0.0 < tol < 1.0):
        raise VoxelStokesError(f"tol must be in (0, 1), got {tol!r}")
    if int(max_iter) < 1:
        raise VoxelStokesError(f"max_iter must be >= 1, got {max_iter!r}")
    if treatment not in _TREATMENTS:
        raise VoxelStokesError(
            f"periodic_treatment must be one of {_TREATMENTS}, got {treatment!r}"
        )
    if bc not in _BCS:
        raise VoxelStokesError(f"bc must be one of {_BCS}, got {bc!r}")


def solve_voxel_stokes(
    solid: np.ndarray,
    voxel_size: float,
    direction: str | int,
    *,
    viscosity: float = 1.0,
    tol: float = 1e-6,
    max_iter: int = 2000,
    periodic_treatment: str = "periodic",
    return_velocity: bool = False,
    progress: Callable[[int, float], None] | None = None,
    distance: np.ndarray | None = None,
    bc: str = "periodic",
    aux_length: float = 0.2,
    sides: str = "slip",
    pressure_gradient: float = 1.0,
    return_pressure: bool = False,
) -> VoxelFlowResult:
    """Solve Stokes flow on a voxel grid driven along ``direction``; return fields and fluxes.

    (Fifteen parameters: independent knobs of the solver, like scipy's, keyword-only after three.)

    Parameters
    ----------
    solid : np.ndarray of bool, shape (nx, ny, nz)
        True = solid voxel (centre in the solid), indexed ``[x, y, z]``.
    voxel_size : float
        Voxel edge length in metres (> 0).
    direction : {'x', 'y', 'z', 0, 1, 2}
        Axis of the driving pressure gradient.
    viscosity : float
        Dynamic viscosity in Pa s (> 0); the fields scale with ``1 / viscosity``.
    tol : float
        True relative residual at which the iteration stops (0 < tol < 1).
    max_iter : int
        Maximum number of Krylov (SYMMLQ) iterations in total (>= 1).
    periodic_treatment : {'periodic', 'mirror', 'frame'}
        ``bc="periodic"`` only. ``'periodic'``: the grid is used as is (it must be periodic, or
        the seams act as extra geometry). ``'mirror'``: the grid is doubled along ``direction``
        by its mirror image. ``'frame'``: a one-voxel solid wall is added on the lateral faces.
    return_velocity : bool
        Return the face velocity field (float32, 3 x grid, m/s) in ``result.velocity``.
    progress : callable, optional
        ``progress(iterations, residual)`` every ``PROGRESS_EVERY`` Krylov iterations and after
        each refinement cycle.
    distance : np.ndarray, optional
        Signed distance to the solid surface at the voxel centres (metres, > 0 in the pore,
        ``distance <= 0`` exactly where ``solid``), e.g. :attr:`VoxelFields.distance`.  Turns on
        the sub-voxel wall treatment (:mod:`solvers.voxel.boundary`); without it the walls are
        the voxel faces (staircase).  Only the values within about one voxel of the surface
        matter.
    bc : {'periodic', 'permeameter'}
        ``'periodic'``: periodic on all faces, mean pressure gradient (homogenised K).
        ``'permeameter'``: empty reservoirs of ``aux_length`` times the RVE length (at least one
        voxel) before and after the RVE along ``direction``, lateral faces walls (``sides``).
        The reservoirs join across the periodic face of the padded grid, so a body force of
        ``pressure_gradient`` drives the flow with the drop ``pressure_gradient x (padded
        length)`` between the reservoir ends; ``rve_pressure_drop`` is measured on the RVE's own
        inlet and outlet planes.
    aux_length : float
        Reservoir length as a fraction of the RVE length (>= 0; permeameter).
    sides : {'slip', 'noslip'}
        Lateral walls of the permeameter: zero normal velocity and zero shear (symmetry planes),
        or no-slip.
    pressure_gradient : float
        Driving mean pressure gradient (Pa/m, > 0).
    return_pressure : bool
        Return the cell-centred pressure (Pa, float32) in ``result.pressure``.

    Returns
    -------
    VoxelFlowResult

    Raises
    ------
    VoxelStokesError (ValueError)
        Non-bool or non-3-D ``solid``, porosity 0 or 1, no percolating fluid path along
        ``direction``, a ``distance`` inconsistent with ``solid``, or any option out of range.
    """
    t0 = time.perf_counter()
    solid = _check_solid(solid)
    d = _check_direction(direction)
    _check_options(voxel_size, viscosity, tol, max_iter, periodic_treatment, bc)
    distance = _check_distance(distance, solid)
    _check_drive(solid, bc, periodic_treatment, sides, aux_length, pressure_gradient)
    treat = periodic_treatment
    cells = _check_memory(solid.shape, d, bc, treat, aux_length, distance is not None, tol)
    # the set-up's kernels: the solve's thread policy, on the cells of the grid they set up
    with _threads(cells), jit.kernel_log() as setup_log:
        setup = _setup_grid(solid, distance, voxel_size, d, bc, treat, aux_length, sides)
    vmem.release_free_heap()  # the set-up's freed temporaries (8 B per cell at 200^3)
    _percolation_and_porosity(setup, d)
    # the solve holds no grid-sized geometry of its own from here on (the operator keeps what
    # it needs): the caller's arrays are freed now if the caller holds no reference either
    del solid, distance
    vmem.release_free_heap()
    x, info = _solve_logged(setup["op"], d, tol, int(max_iter), progress, setup_log)
    units = (voxel_size, viscosity, pressure_gradient)
    return _result(x, info, setup, d, units, t0, (return_velocity, return_pressure))


def _check_drive(
    solid: np.ndarray, bc: str, treatment: str, sides: str, aux_length: float, g: float
) -> None:
    """Refuse the permeameter's options out of range, a pressure gradient ``g`` <= 0, and a
    solid without fluid (or, periodic, without solid)."""
    if bc == "permeameter":
        if sides not in _SIDES:
            raise VoxelStokesError(f"sides must be one of {_SIDES}, got {sides!r}")
        if not (np.isfinite(aux_length) and aux_length >= 0.0):
            raise VoxelStokesError(f"aux_length must be >= 0 (fraction of L), got {aux_length!r}")
    if not (np.isfinite(g) and g > 0):
        raise VoxelStokesError(f"pressure_gradient must be > 0 Pa/m, got {g!r}")
    phi0 = 1.0 - float(solid.mean())
    if phi0 <= 0.0 or (phi0 >= 1.0 and bc == "periodic" and treatment != "frame"):
        raise VoxelStokesError(
            f"solid has porosity {phi0:g}; it must be strictly between 0 and 1 "
            "(no fluid, or no solid: a solid-free periodic box has unbounded permeability)"
        )


def _percolation_and_porosity(setup: dict, d: int) -> None:
    """Refuse a solved grid without a fluid path along ``d``; store its porosity in ``setup``.
    The grid and its blocked mask leave ``setup`` (freed here unless the caller holds them)."""
    check_percolates(setup.pop("blocked"), d, "solid")
    grid = setup.pop("grid")
    setup["porosity"] = 1.0 - float(grid.mean())


def _solve_logged(
    op: _Stokes,
    d: int,
    tol: float,
    max_iter: int,
    progress: Callable[[int, float], None] | None,
    setup_log: jit.KernelLog,
) -> tuple[np.ndarray, dict]:
    """:func:`_solve_core` on the solve's threads; ``info`` gains the threads used and the
    kernels that ran serially (the set-up's ``setup_log`` and the solve's)."""
    with _threads(int(np.prod(op.shape[1:]))) as threads, jit.kernel_log() as log:
        x, info = _solve_core(op, d, tol, max_iter, progress)
    fallback, parallel = log.fallback | setup_log.fallback, log.parallel | setup_log.parallel
    info["threads"] = vthreads.thread_use(*threads, fallback, parallel)
    info["fallback"] = tuple(sorted(fallback))
    return x, info


def _setup_grid(
    solid: np.ndarray,
    distance: np.ndarray | None,
    h: float,
    d: int,
    bc: str,
    treatment: str,
    aux_length: float,
    sides: str,
) -> dict:
    """Solved grid (treatment or reservoirs), its distance field (voxels) and the operator."""
    phi = None if distance is None else np.asarray(distance, np.float64) / h
    n_d = solid.shape[d]
    walls: dict[int, str] = {}
    if bc == "permeameter":
        n_aux = reservoir_cells(n_d, aux_length)
        grid, phi = bd.pad_reservoirs(solid, phi, d, n_aux)
        walls = {b: sides for b in range(3) if b != d}
        rve = (n_aux, n_aux + n_d)
        pad = [(0, 1) if b != d else (0, 0) for b in range(3)]
        blocked = np.pad(grid, pad, constant_values=True)
    else:
        grid, phi = apply_treatment(solid, d, treatment, phi)
        rve = (0, n_d)
        blocked = grid
    op = _Stokes.build(grid, phi, walls, d, rve if bc == "permeameter" else None)
    return {
        "grid": grid,
        "blocked": blocked,
        "op": op,
        "rve": rve,
        "n_d": n_d,
        "wall_treatment": "staircase" if phi is None else "subvoxel",
        "bc": bc,
        "treatment": treatment,
        "sides": sides,
    }


def _plane_pressure(p: np.ndarray, act_d: np.ndarray, d: int, i: int) -> float:
    """Mean of the pressure over the active faces of face plane ``i`` normal to ``d`` (the two
    cells' mean on each face)."""
    n = p.shape[d]
    hi = np.take(p, i % n, axis=d)
    lo = np.take(p, (i - 1) % n, axis=d)
    act = np.take(act_d, i % n, axis=d)
    if not act.any():
        return float("nan")
    return float(0.5 * (hi[act] + lo[act]).mean())


def _energy_flux_profile(x: np.ndarray, flux: np.ndarray, d: int, i0: int, i1: int) -> np.ndarray:
    """Mechanical energy flux per unit flow rate, ``E(s) / Q``, on the face planes ``i0..i1``
    normal to ``d`` (voxel units, ``h = mu = G = 1``; relative to plane ``i0``).

    ``E(s) = int (P u_s - mu u . d_s u) dA`` with ``P`` the total pressure (the body-force
    gradient included: ``-1`` per cell): the pressure work ``sum q_f P_f`` (``q_f`` the face
    flux, ``P_f`` the mean of the two cells' pressures) minus the viscous work
    ``d_s int |u|^2 / 2 dA`` (central difference of the plane sums of ``u_d^2 / 2`` on the face
    planes, one-cell difference of those of the tangential components on the cell planes).
    ``E`` falls along the RVE by the dissipation; in the periodic interior ``E / Q`` is
    ``c - G s`` plus a periodic part.
    """
    n = x.shape[1 + d]
    sub = "ijk,ijk->" + "ijk"[d]  # plane sums of u_a^2 without a grid-sized temporary
    half_u2 = [0.5 * np.einsum(sub, x[a], x[a]) for a in range(3)]
    p = x[3]
    out = np.empty(i1 - i0 + 1)
    for k, i in enumerate(range(i0, i1 + 1)):
        q = np.take(flux, i % n, axis=d).astype(np.float64)
        p_face = 0.5 * (np.take(p, i % n, axis=d) + np.take(p, (i - 1) % n, axis=d))
        e = float((q * p_face).sum())
        for a in range(3):
            ke = half_u2[a]
            if a == d:
                e -= 0.5 * (ke[(i + 1) % n] - ke[(i - 1) % n])
            else:
                e -= ke[i % n] - ke[(i - 1) % n]
        out[k] = e / float(q.sum()) - (i - i0)
    return out - out[0]


def _face_flux(op: _Stokes, x: np.ndarray, a: int) -> np.ndarray:
    """``w_f q_f`` of component ``a`` (the staircase's weights are 1: ``x[a]`` itself)."""
    wa = op.weight(a)
    return x[a] if wa is None else x[a] * wa


def _result(
    x: np.ndarray,
    info: dict,
    setup: dict,
    d: int,
    units: tuple[float, float, float],
    t0: float,
    returns: tuple[bool, bool],
) -> VoxelFlowResult:
    """Scale the voxel-unit solution (h = mu = G = 1) to SI fields and fluxes: ``units`` is the
    voxel size, the viscosity and the pressure gradient; ``setup`` the solved grid's
    description (:func:`_setup_grid`) and ``returns`` which fields to return."""
    op = setup["op"]
    h, mu, g = units
    bc, treatment, sides = setup["bc"], setup["treatment"], setup["sides"]
    vel_scale = g * h * h / mu
    lat = tuple(b for b in range(3) if b != d)
    # the flux through a face is w_f q_f (cut-cell fluid fraction w_f; 1 for the staircase),
    # one component at a time (the dense sub-voxel weights are formed on demand)
    flux_d = _face_flux(op, x, d)
    mean_u = np.array([(flux_d if a == d else _face_flux(op, x, a)).mean() for a in range(3)])
    mean_u *= vel_scale
    planes = flux_d.sum(axis=lat) * vel_scale * h * h
    mean_q = float(planes.mean())
    imbalance = float((planes.max() - planes.min()) / mean_q) if mean_q > 0 else float("inf")
    i0, i1 = setup["rve"]
    n_d = setup["n_d"]
    p = x[3]
    dp_fluct = _plane_pressure(p, op.act[d], d, i0) - _plane_pressure(p, op.act[d], d, i1)
    profile = plane_p = None
    if bc == "permeameter":
        profile = _energy_flux_profile(x, flux_d, d, i0, i1) * (g * h)
        plane_p = np.array(
            [_plane_pressure(p, op.act[d], d, i) - (i - i0) for i in range(i0, i1 + 1)]
        )
        plane_p = (plane_p - plane_p[0]) * (g * h)
    shp = op.shape[1:]
    velocity = (x[:3] * vel_scale).astype(np.float32) if returns[0] else None
    pressure = (p * (g * h)).astype(np.float32) if returns[1] else None
    cells = (op.fluid != 0) if returns[1] else None  # the mask or the scale code
    del x, flux_d
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return VoxelFlowResult(
        mean_velocity=mean_u,
        pressure_gradient=g,
        viscosity=mu,
        flow_rate=mean_q,
        plane_flow_rates=planes,
        direction=d,
        porosity=setup["porosity"],
        converged=info["converged"],
        iterations=info["iterations"],
        residual=info["residual"],
        n_cells=int(np.count_nonzero(op.fluid)),
        wall_time_s=time.perf_counter() - t0,
        peak_memory_mb=peak,
        velocity=velocity,
        pressure=pressure,
        pressure_cells=cells,
        history=info["history"],
        periodic_treatment=treatment if bc == "periodic" else "periodic",
        flux_imbalance=imbalance,
        message=info["message"],
        threads_used=info["threads"][0],
        thread_note=info["threads"][1],
        serial_fallback=info["fallback"],
        bc=bc,
        wall_treatment=setup["wall_treatment"],
        sides=sides if bc == "permeameter" else None,
        rve_slice=(i0, i1),
        voxel_size=h,
        rve_pressure_drop=g * h * (n_d + dp_fluct) if bc == "permeameter" else g * n_d * h,
        rve_energy_flux_profile=profile,
        rve_plane_pressure_profile=plane_p,
        rve_length=n_d * h,
        rve_area=float(shp[lat[0]] * shp[lat[1]]) * h * h,
        applied_pressure_drop=g * shp[d] * h,
    )


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


def _check_memory(
    shape: tuple[int, ...],
    d: int,
    bc: str,
    treatment: str,
    aux_length: float,
    subvoxel: bool,
    tol: float = 1e-6,
) -> int:
    """Refuse, before any allocation, a solve whose estimated peak memory
    (:mod:`solvers.voxel.memory`) exceeds the memory available now; return the solved grid's
    cells."""
    cells = math.prod(solved_shape(shape, d, bc, treatment, aux_length))
    kind = "subvoxel" if subvoxel else "staircase"
    need = vmem.solver_bytes(cells, kind, tol, walls=bc == "permeameter")
    avail = vmem.available_bytes()
    if avail is not None and need > avail:
        raise VoxelStokesError(
            f"solid: the solved grid of {cells:.3g} cells needs about {need / 2**30:.3g} GiB "
            f"({need / cells:.0f} B per cell, {kind} walls); "
            f"{avail / 2**30:.3g} GiB are available: use a coarser voxel or a smaller RVE"
        )
    return cells


@contextmanager
def _threads(n_cells: int):
    """numba threads for a solve on ``n_cells`` cells (:func:`solvers.voxel.threads.
    solve_threads`); yields ``(threads, available)``.

    Inside the block the kernels whose parallel version is not compiled yet compile it (else
    run their serial twin) by one rule for the whole grid, :func:`solvers.jit.compile_rule`:
    ``n_cells`` against :data:`solvers.jit.COMPILE_PARALLEL_ABOVE`, not each kernel's first
    argument, which has 4 entries per cell for the 4-field vectors.  Per argument, a 120^3
    mirror solve (3.4 M cells) compiled five vector kernels on first use (58 s of its 95 s at
    load 3.5, 153 MB of its peak RSS) and still ran its operator kernels on one thread
    (``benchmarks/RESULTS.md``, session 44 mirror).  The rule, as numba's thread count, holds
    in the calling thread only: solves overlapping in threads of one process (a dask worker
    with ``--nthreads 2``, a user's thread pool) each keep their own."""
    old = numba.get_num_threads()
    numba.set_num_threads(n := vthreads.solve_threads(n_cells, old))
    try:
        with jit.compile_rule(n_cells):
            yield n, old
    finally:
        numba.set_num_threads(old)


PRESSURE_SCALING = True
"""Sub-voxel walls: scale the pressure block of the preconditioner by ``1 / max(SCHUR_FLOOR,
sum over the cell's faces f of w_f^2 / A_ff)``, the diagonal of the Schur complement
``W G^T diag(A)^-1 G W`` (1 in a wall-free box: six faces of weight 1 and diagonal 6).  The
diagonal ``A_ff`` carries the ghost-fluid stiffness ``1 / theta`` of the cut faces, so a cell
whose fluid faces sit against a wall gets the large scale it needs.  Measured, MINRES
iterations to 1e-6 (``benchmarks/RESULTS.md``): Toray-like 40^3 with the exact fibre
distance 566 -> 171 (staircase 133; K identical to 7 digits); the former estimate
``sum w_f^2 / 6`` (clamped at 0.05) had cut the square arrays from 93-184 to 60-76.  Stored
as the staircase's one-byte code (:func:`solvers.voxel.schur.schur_code`, 4.4 % steps), which
is the pressure-cell mask too (session 10: 4 B per cell less than the float32 scale and the
mask)."""

COARSE_PRESSURE = True
"""Add the coarse Darcy correction :class:`solvers.voxel.schur.CoarsePressure` to the pressure
block of the preconditioner (without it the MINRES iterations grow with the box side)."""

THIN_BLOCKS = True
"""Replace the pressure block's diagonal ``D`` by exact local solves on the thin pieces of the
fluid (dead-end tubes, slits: :class:`solvers.voxel.thin.ThinBlocks`), whose local pressure
modes are the smallest eigenvalues of the preconditioned system; since session 13 only the
pieces' slow modes (:data:`solvers.voxel.thin.LOW`; the exact solve of the whole piece cost the
cylinder arrays up to 23 % more iterations).  Toray-like at 1 um, 100 / 200 / 300 / 400 um: 131
/ 150 / 187 / 246 SYMMLQ iterations without, 113 / 141 / 166 / 182 with the whole pieces
(session 12), 104 / 139 / 164 / 182 with their slow modes (``benchmarks/RESULTS.md``, "Thin
pieces on array grids (thin13)")."""

SCHUR_FLOOR = 1e-4
"""Lower bound of the Schur diagonal estimate (the smallest possible value, a weight of 0.05 on
a face of diagonal 26, is 1e-4; 1e-3 and 1e-5 gave the same iteration count at 40^3)."""


def _share_coarse_work(mgs: list[mg.ScalarMG]) -> None:
    """Let the V-cycles of the three components (run one after the other) share the work
    arrays ``x, t, b`` of their coarse levels where the shapes agree (about 3.4 B per fine
    cell saved; the coarse operators stay per component)."""
    first = mgs[0].levels[1:]
    for other in mgs[1:]:
        for lev, lev0 in zip(other.levels[1:], first, strict=False):
            if lev.d.shape == lev0.d.shape:
                lev.x, lev.t, lev.b = lev0.x, lev0.t, lev0.b


class _Stokes:
    """Matrix-free MAC Stokes operator and block-diagonal preconditioner of one grid."""

    def __init__(
        self,
        cells: np.ndarray,
        ops: list[tuple[np.ndarray, np.ndarray]],
        acts: list[np.ndarray] | None,
        cut: cf.CutFaces | None = None,
        **mg_kw: object,
    ) -> None:
        self.fluid = np.ascontiguousarray(cells).view(np.uint8)
        # the active faces are the unknowns with a non-zero diagonal: not stored (3 B per cell)
        del acts
        self.cut = cut
        self.p_scale = None
        self.d = [o[0] for o in ops]
        code = None
        if cut is not None and PRESSURE_SCALING:
            # the Schur-diagonal scale as the staircase's one-byte code (4 B per cell less)
            inverse = self._face_inverses()
            code = schur.schur_code(self.d, SCHUR_FLOOR, inverse)  # frees each as it is summed
            del inverse
        self.c = [o[1] for o in ops]
        shp = cells.shape
        self.shape = (4, *shp)
        # the preconditioner's output vector: its pressure field is written last, so the
        # velocity V-cycles smooth between it and their own output field z[a]: no fine work
        # array of their own (8 B per cell saved)
        self.z = np.zeros(self.shape, np.float32)
        work = [self.z[3]]
        self._work = work
        self.mg = [mg.ScalarMG(o[0], o[1], work=work, **mg_kw) for o in ops]
        _share_coarse_work(self.mg)
        self.coarse_p = None
        faces = None
        if COARSE_PRESSURE:
            weights = None if cut is None else cf.WeightView(cut, self.d)
            cut_faces = None if cut is None else (lambda a: cut.scale_inverse(a, self.d[a]))
            self.coarse_p = schur.CoarsePressure(self.fluid, ops, self.mg, weights, faces=cut_faces)
            if cut is None and THIN_BLOCKS:
                # the staircase's 1 / A_ff, formed once for the scale code and the thin blocks
                # (each formed its own: 0.4 s of a one-thread 200^3 set-up's profile; 12 B per cell
                # while both use them, below the Krylov phase's peak)
                faces = self._face_inverses()
                code = schur.schur_code(self.d, SCHUR_FLOOR, list(faces))
            if code is not None:
                self.coarse_p.use_code(code)
            # the scale code (the staircase's formed now, its ~13 B per cell of temporaries
            self._mask_in_code()  # off the peak) is the pressure-cell mask too
        elif code is not None:
            self.p_scale = schur.CODE_TABLE[code]
        self.thin = self._thin_blocks(faces) if THIN_BLOCKS else None
        del faces
        del ops
        self._drop_couplings()

    def _face_inverses(self) -> list[np.ndarray]:
        """Each component's ``w_f^2 / A_ff`` (float32, 0 off the active faces; staircase:
        ``1 / A_ff``, :func:`solvers.voxel.schur.unit_inverse`)."""
        if self.cut is not None:
            return [self.cut.scale_inverse(a, da) for a, da in enumerate(self.d)]
        return [schur.unit_inverse(da) for da in self.d]

    def _thin_blocks(self, faces: list[np.ndarray] | None = None) -> thin.ThinBlocks | None:
        """The exact local pressure solves on the thin cells (:mod:`solvers.voxel.thin`), from
        the faces' ``w_f^2 / A_ff`` (:meth:`_face_inverses`, unless given); None without a
        pressure scale."""
        dinv = self.schur_scale()
        if dinv is None:
            return None
        if faces is None:
            faces = self._face_inverses()
        return thin.ThinBlocks(faces, self.fluid, dinv, SCHUR_FLOOR)

    def schur_scale(self) -> np.ndarray | None:
        """The pore-scale pressure block ``D^-1`` (float32, 0 off the pressure cells): the
        stored scale, or the decoded one-byte code (:func:`solvers.voxel.schur.schur_code`);
        None for the identity."""
        if self.p_scale is not None:
            return self.p_scale
        code = None if self.coarse_p is None else self.coarse_p.stored_code
        return None if code is None else schur.CODE_TABLE[code] * (self.fluid != 0)

    def weight(self, a: int) -> np.ndarray | None:
        """Dense face weights of component ``a`` (None for the staircase: all 1)."""
        return None if self.cut is None else self.cut.weight(a, self.d[a])

    def diagonal(self, a: int) -> np.ndarray:
        """Dense diagonal of component ``a`` of the operator the Krylov solve uses."""
        if self.cut is not None:
            return self.cut.diagonal(a, self.d[a])
        return self.d[a].astype(np.float64)

    def _mask_in_code(self) -> None:
        """Let the staircase's one-byte pressure scale code (:func:`solvers.voxel.schur.
        schur_code`) be the pressure-cell mask too: 0 off the pressure cells, where no fluid
        cell's code lies (a Schur diagonal below 4; at most 6 faces of ``1 / A_ff <= 1/4``,
        codes >= 23), so every kernel that reads the mask as ``!= 0`` reads the code instead
        and the mask (1 B per cell) is freed."""
        code = self.coarse_p.code(self.d, SCHUR_FLOOR)
        cells = self.fluid != 0
        if np.any(code[cells] == 0):  # not reached on a voxel grid (docstring): keep the mask
            return
        code[~cells] = 0
        del cells
        self.fluid = self.coarse_p.fluid = code

    def _drop_couplings(self) -> None:
        """Replace the finest couplings of each component by :func:`solvers.voxel.kernels.
        unit_couplings` where they are those of its active unknowns (periodic grids; the box
        walls of the permeameter cut some: kept there), after the set-up that needs them (the
        Galerkin levels, the coarse pressure term): 9 B per cell."""
        for a in range(3):
            act = self.d[a] > 0
            if all(np.array_equal(self.c[a][b], act & np.roll(act, 1, axis=b)) for b in range(3)):
                unit = kr.unit_couplings(act.shape[2])
                self.c[a] = unit
                self.mg[a].levels[0].c = unit

    @property
    def act(self) -> list[np.ndarray]:
        """Active faces (unknowns) of each velocity component: ``diag > 0`` (computed)."""
        return [da > 0 for da in self.d]

    @classmethod
    def build(
        cls,
        solid: np.ndarray,
        phi: np.ndarray | None = None,
        walls: dict[int, str] | None = None,
        d: int = 0,
        rve: tuple[int, int] | None = None,
        **mg_kw: object,
    ) -> _Stokes:
        """Operator of a solid mask, optionally with a signed distance ``phi`` (voxels; sub-voxel
        walls), box ``walls`` and the RVE planes ``rve`` along ``d`` (permeameter)."""
        if phi is None and not walls:
            fluid = ~solid
            ops = [mg.component_operator(fluid, a) for a in range(3)]
            acts = [o[0] > 0 for o in ops]
            return cls(fluid, ops, acts, **mg_kw)
        if phi is None:
            res = [bd.component_coefficients(a, fluid=~solid, walls=walls) for a in range(3)]
            acts = [r[2] for r in res]
            return cls(~solid, [(r[0], r[1]) for r in res], acts, **mg_kw)
        ops, coos = [], []
        for a in range(3):  # one component at a time, compressed at once (cutfaces.compress)
            face = bd.face_distance(phi, a)
            if rve is not None and a == d:
                bd.rve_plane_faces(face, phi, d, list(rve))
            diag, c, act, weight = bd.component_coefficients(a, phi_faces={a: face}, walls=walls)
            del face, act
            d8, coo = cf.compress(diag, weight)
            del diag, weight
            ops.append((d8, c))
            coos.append(coo)
        cells = cf.pressure_cells([o[0] for o in ops], coos)
        cut = cf.finish(coos, cells.shape)
        del coos
        return cls(cells, ops, None, cut=cut, **mg_kw)

    def lanczos(self, x: np.ndarray, s: float, c1: float, y: np.ndarray) -> float:
        """``y <- s K x - c1 y`` in place (``y`` unread if ``c1 == 0``; ``s = 1, c1 = 0`` is the
        product ``y = K x``); returns ``x . y``."""
        if self.cut is not None:
            return float(
                cf.stokes_lanczos_cut(*self.d, *self.c, self.fluid, *self.cut.arrays, x, s, c1, y)
            )
        return float(lz.stokes_lanczos(*self.d, *self.c, self.fluid, x, s, c1, y))

    def residual(self, x: np.ndarray, gdir: int, r: np.ndarray) -> tuple[float, float]:
        if self.cut is not None:
            rr, ff = cf.stokes_residual_cut(
                *self.d, *self.c, self.fluid, *self.cut.arrays, x, gdir, r
            )
        else:
            rr, ff = kr.stokes_residual(*self.d, *self.c, self.fluid, x, gdir, r)
        return float(np.sqrt(rr)), float(np.sqrt(ff))

    def precondition(self, r: np.ndarray, z: np.ndarray) -> float:
        """z = M^-1 r (three scalar V-cycles and the pressure scaling); returns ``r . z``
        (float64) from the same passes (the last smoothing sweep of each V-cycle and the pressure
        block), so MINRES needs no dot-product pass.  ``r`` must not be :attr:`z` (its pressure
        field is the V-cycles' work array), ``z`` may."""
        rz = sum(self.mg[a].apply(r[a], z[a]) for a in range(3))
        if self.coarse_p is not None:  # two-level pressure block (solvers.voxel.schur)
            rz += self.coarse_p.apply(r[3], z[3], self.d, SCHUR_FLOOR)
        elif self.p_scale is None:
            rz += kr.copy_dot(r[3], z[3])
        else:
            rz += kr.scale_dot(r[3], self.p_scale, z[3])
        if self.thin is not None:  # D^-1 -> L_P^-1 on the thin pieces (solvers.voxel.thin)
            rz += self.thin.apply(r[3], z[3])
        return rz


@dataclass
class MinresWork:
    """The work vectors of :func:`_minres` / :func:`_symmlq` besides the right-hand side: the
    preconditioned vector ``z`` (float32; :attr:`_Stokes.z`, whose pressure field the multigrid
    shares), the older Lanczos vector ``r1`` (float32) and the directions: MINRES' two
    unscaled ``u, u1`` (:class:`solvers.voxel.lanczos.Directions`, float32 or 16 bits per
    entry) or SYMMLQ's one ``w`` (float32, on the active unknowns ``packing`` only:
    :class:`solvers.voxel.lanczos.Packing`; :data:`solvers.voxel.memory.KRYLOV`)."""

    z: np.ndarray
    r1: np.ndarray
    u: lz.Directions | None
    u1: lz.Directions | None
    w: np.ndarray | None = None
    packing: lz.Packing | None = None
    wm: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))

    @classmethod
    def of(cls, op: _Stokes, krylov: str | None = None) -> MinresWork:
        """Work vectors for the operator ``op`` and the Krylov method ``krylov`` (default
        :data:`solvers.voxel.memory.KRYLOV`)."""
        shp = op.shape
        r1 = np.empty(shp, np.float32)
        if (krylov or vmem.KRYLOV) == "symmlq":
            pk = lz.Packing([*op.d, op.fluid])
            return cls(op.z, r1, None, None, np.zeros(pk.size, np.float32), pk)
        return cls(op.z, r1, lz.Directions(shp), lz.Directions(shp))

    def store_directions(self, bits: int) -> None:
        """Store MINRES' directions in ``bits`` (16 or 32) from now on, or SYMMLQ's in 24
        (``bits == 24``: the float32's upper two bytes in ``w`` (uint16) and the third in
        ``wm``, :func:`solvers.voxel.lanczos.symmlq_step`) or 32 (float32 ``w``, e.g. after
        :meth:`solvers.voxel.lanczos.Solution.widen`); new, zero directions, the old ones
        freed first, so the peak is that of the wider storage."""
        if self.w is not None:
            size = self.w.size
            if bits == 24 and self.wm.size == 0:
                self.w = None
                self.w, self.wm = np.zeros(size, np.uint16), np.zeros(size, np.uint8)
            elif bits == 32 and self.wm.size:
                self.w = self.wm = None
                self.w, self.wm = np.zeros(size, np.float32), np.zeros(0, np.uint8)
            return
        if self.u is None or self.u.q.itemsize * 8 == bits:
            return
        shp = self.u.q.shape
        self.u = self.u1 = None
        self.u, self.u1 = lz.Directions(shp, bits), lz.Directions(shp, bits)


def _solution_parts(x: lz.Solution | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(hi, lo, scale)`` of a :class:`solvers.voxel.lanczos.Solution`, or of a float array
    (an empty ``lo``) for the kernels that accumulate into the solution."""
    if isinstance(x, lz.Solution):
        return x.hi, x.lo, x.scale
    return x, np.zeros((0,) * x.ndim, np.int16), np.ones(x.shape[0])


def _lanczos_start(op: _Stokes, r2: np.ndarray, z: np.ndarray) -> tuple[float, str | None]:
    """``z <- M^-1 r2`` and ``beta1 = sqrt(r2 . z)``, the start of the preconditioned Lanczos
    recurrence shared by :func:`_minres` and :func:`_symmlq`; ``(0, why)`` when it cannot start
    (a zero right-hand side, or a preconditioner that lost positivity)."""
    beta1 = op.precondition(r2, z)
    if not beta1 > 0.0:
        return 0.0, "zero right-hand side" if beta1 == 0.0 else "preconditioner not positive"
    return float(np.sqrt(beta1)), None


def _lanczos_step(
    op: _Stokes,
    z: np.ndarray,
    r1: np.ndarray,
    r2: np.ndarray,
    beta: float,
    oldb: float,
    first: bool,
) -> tuple[float, float, np.ndarray, np.ndarray]:
    """One step of the preconditioned Lanczos recurrence (Paige & Saunders), in place: the older
    vector ``r1`` becomes ``s K z - (beta / oldb) r1 - (alfa / beta) r2`` with ``s = 1 / beta``
    and ``alfa = s^2 z . K z`` (the operator product overwrites ``r1``, ``c1 = 0`` on the first
    step). Returns ``(s, alfa, r1, r2)`` with the two vectors swapped: ``r2`` is the new one."""
    s = 1.0 / beta
    c1 = 0.0 if first else beta / oldb
    alfa = s * op.lanczos(z, s, c1, r1)
    lz.add_scaled(r1, -alfa / beta, r2)
    return s, alfa, r2, r1


def _minres(
    op: _Stokes,
    b: np.ndarray,
    x: lz.Solution | np.ndarray,
    work: MinresWork,
    rtol: float,
    maxit: int,
    report: Callable[[int, float], None] | None = None,
) -> tuple[int, str]:
    """Preconditioned MINRES (Paige & Saunders; as scipy.sparse.linalg.minres) for K e = b,
    accumulated into ``x`` (``x += e``; a :class:`solvers.voxel.lanczos.Solution` or a float
    array, so no separate correction vector is stored).

    Works in the precision of ``b`` (float32 here); ``b`` is overwritten.  ``work`` holds the
    other vectors (:class:`MinresWork`).  Stops when the preconditioned residual norm estimate
    has dropped by ``rtol``.  Returns (iterations, status).

    Five 4-field vectors besides ``x`` (:mod:`solvers.voxel.lanczos`): the Lanczos vector
    ``v = z / beta`` is never stored (the scale is carried into the kernels); the operator
    product overwrites the older Lanczos vector in place (``r1 <- s K z - c1 r1``, returning
    ``z . r1``, so ``alpha`` needs no extra sweep); the directions ``w = u / gamma`` are stored
    unscaled and updated before the next preconditioned vector is formed (``gamma`` is not known
    yet), and each direction's solution update ``x += phi w`` is fused into the next direction
    update (the last one is flushed on return).  The directions feed only ``x``, never the
    Lanczos recurrence, so they are stored in 16 bits (row-scaled int16): the recurrence, and
    with it the iteration count of a MINRES run, is that of float32 storage.
    ``report(itn, phibar / beta1)`` is called every ``PROGRESS_EVERY`` iterations if given.
    """
    z, r1, u, u1 = work.z, work.r1, work.u, work.u1
    xh, xl, xs = _solution_parts(x)
    u.clear()
    u1.clear()
    r2 = b
    beta1, failed = _lanczos_start(op, r2, z)
    if failed:
        return 0, failed
    oldb, beta, dbar, epsln, phibar, cs, sn = 0.0, beta1, 0.0, 0.0, beta1, -1.0, 0.0
    su = su1 = phi = 0.0  # scales of the stored directions (w = su u), pending x += phi w
    for itn in range(1, maxit + 1):
        s, alfa, r1, r2 = _lanczos_step(op, z, r1, r2, beta, oldb, itn == 1)
        oldeps = epsln
        delta = cs * dbar + sn * alfa
        gbar = sn * dbar - cs * alfa
        lz.minres_direction(
            z, s, u1.q, u1.e, oldeps * su1, u.q, u.e, delta * su, xh, xl, xs, phi * su
        )
        u, u1 = u1, u
        su1 = su
        oldb = beta
        beta = op.precondition(r2, z)
        if beta < 0.0:
            return itn, "preconditioner not positive"
        beta = np.sqrt(beta)
        epsln = sn * beta
        dbar = -cs * beta
        gamma = max(np.hypot(gbar, beta), 1e-300)
        cs = gbar / gamma
        sn = beta / gamma
        phi = cs * phibar
        phibar = sn * phibar
        su = 1.0 / gamma
        if report is not None and itn % PROGRESS_EVERY == 0:
            report(itn, phibar / beta1)
        if phibar <= rtol * beta1 or beta == 0.0:
            lz.add_direction(xh, xl, xs, phi * su, u.q, u.e)
            return itn, "ok" if phibar <= rtol * beta1 else "exact"
    lz.add_direction(xh, xl, xs, phi * su, u.q, u.e)
    return maxit, "max_iter"


def _symmlq(
    op: _Stokes,
    b: np.ndarray,
    x: lz.Solution,
    work: MinresWork,
    rtol: float,
    maxit: int,
    report: Callable[[int, float], None] | None = None,
) -> tuple[int, str]:
    """Preconditioned SYMMLQ (Paige & Saunders 1975) for K e = b, accumulated into ``x`` and
    moved to the CG point on return: :func:`_minres`' arguments and result, one direction.

    The Lanczos recurrence and its kernels are :func:`_minres`' (the same vectors ``z, r1`` and
    ``b``); the LQ factorisation of the Lanczos matrix uses the same plane rotations as MINRES'
    QR, but its iterate ``x_L = W z`` needs only one stored direction ``w-bar`` (float32,
    ``work.w``): rotation ``k - 1`` of ``(w-bar, v_k)`` gives the finished direction
    ``cs w-bar + sn v_k``, added to ``x`` with the weight ``zeta``, and the next ``w-bar = sn
    w-bar - cs v_k`` (:func:`solvers.voxel.lanczos.symmlq_step`, one pass while ``z`` still
    holds ``v_k``).  The CG point ``x_L + zeta-bar w-bar`` (``zeta-bar = rhs1 / gamma-bar``)
    has the preconditioned residual norm ``phibar / |c|``, MINRES' ``phibar = beta1 prod(sn)
    sn_k`` over the cosine ``c = gamma-bar / gamma`` of the next rotation; the run stops when
    ``phibar <= rtol beta1`` and ``phibar / |c| <= CG_SLACK rtol beta1`` and moves ``x`` there
    (at ``maxit``, only if that is below the LQ point's residual ``hypot(rhs1, rhs2)``, Paige &
    Saunders' rule).  ``x`` and ``w-bar`` are packed (:class:`solvers.voxel.lanczos.Packing`,
    ``work.packing``).  ``report(itn, phibar / beta1)`` (MINRES' estimate: monotone) every
    ``PROGRESS_EVERY`` iterations.
    """
    z, r1, w, wm = work.z, work.r1, work.w, work.wm
    masks = (*work.packing.masks, work.packing.start)
    xh, xl, xs = x.hi, x.lo, x.scale
    r2 = b
    beta1, failed = _lanczos_start(op, r2, z)
    if failed:
        return 0, failed
    w.fill(0)
    wm.fill(0)
    oldb, beta, gbar, dbar, rhs1, rhs2, snprod = 0.0, beta1, 0.0, 0.0, beta1, 0.0, 1.0
    for itn in range(1, maxit + 1):
        s, alfa, r1, r2 = _lanczos_step(op, z, r1, r2, beta, oldb, itn == 1)
        if itn == 1:  # w-bar_1 = v_1
            lz.symmlq_step(z, s, w, wm, -1.0, 0.0, xh, xl, xs, 0.0, *masks)
            cs, sn, zeta, delta, gbar = -1.0, 0.0, 0.0, 0.0, alfa
        else:  # rotation itn - 1: (gamma-bar, beta_itn) -> (gamma, 0)
            gamma = max(np.hypot(gbar, beta), 1e-300)
            cs, sn, zeta = gbar / gamma, beta / gamma, rhs1 / gamma
            lz.symmlq_step(z, s, w, wm, cs, sn, xh, xl, xs, zeta, *masks)
            delta = cs * dbar + sn * alfa
            gbar = sn * dbar - cs * alfa
            snprod *= sn
        oldb = beta
        beta = op.precondition(r2, z)
        if beta < 0.0:
            return itn, "preconditioner not positive"
        beta = np.sqrt(beta)
        if itn == 1:
            dbar = beta
        else:
            rhs1, rhs2 = rhs2 - delta * zeta, -sn * beta * zeta
            dbar = -cs * beta
        mr = snprod * beta1 * beta / max(np.hypot(gbar, beta), 1e-300)  # MINRES' phibar
        cg = snprod * beta1 * beta / abs(gbar) if gbar != 0.0 else np.inf
        if report is not None and itn % PROGRESS_EVERY == 0:
            report(itn, mr / beta1)
        done = (mr <= rtol * beta1 and cg <= CG_SLACK * rtol * beta1) or beta == 0.0
        if done or (itn == maxit and cg <= np.hypot(rhs1, rhs2)):
            zbar = rhs1 / gbar if gbar != 0.0 else 0.0
            lz.symmlq_step(z, 0.0, w, wm, 1.0, 0.0, xh, xl, xs, zbar, *masks)  # to the CG point
        if done:
            return itn, "exact" if beta == 0.0 else "ok"
    return maxit, "max_iter"


CG_SLACK = 2.0
""":func:`_symmlq` stops when MINRES' residual estimate is below ``rtol`` and that of the CG
point, where it moves, below ``CG_SLACK rtol`` (the refinement loop checks the true residual
after each run).  Measured, Toray-like at 1 um, tol 1e-6 (MINRES 151 / 175 iterations at
100^3 / 200^3): 1.0, 162 / 191 (the CG residual is about twice MINRES' and oscillates); 2.0,
153 / 179, final true residuals 4.3e-7 / 5.7e-7 (``benchmarks/RESULTS.md``)."""


def krylov_run(
    op: _Stokes,
    b: np.ndarray,
    x: lz.Solution | np.ndarray,
    work: MinresWork,
    rtol: float,
    maxit: int,
    report: Callable[[int, float], None] | None = None,
) -> tuple[int, str]:
    """:func:`_symmlq` or :func:`_minres`, the method ``work`` was made for
    (:meth:`MinresWork.of`: SYMMLQ's work holds its one direction ``w``)."""
    run = _symmlq if work.w is not None else _minres
    return run(op, b, x, work, rtol, maxit, report)


INNER_RTOL_FLOOR = 1e-5
"""Smallest relative reduction asked of one float32 Krylov run: the first refinement cycle runs
to it, down to about the float32 floor of its solution (true residual ~1e-4 after it; 1e-6 goes
past the floor: 3e-5 only).  1e-5 since session 11 (1e-4 before): the first cycle costs about
20 iterations per decade at 400^3 against 50 in the later ones, which restart on a rough
residual; Toray-like at 1 um, 100 / 200 / 300 um, with :data:`solvers.voxel.schur.WEIGHT`
0.6: 140 / 157 / 222 / 307 iterations before, 131 / 150 / 187 / 246 after
(``benchmarks/RESULTS.md``, "Issue 16 item 4, iteration growth (iter11)")."""


def _true_residual(op: _Stokes, x: lz.Solution, d: int, r: np.ndarray, work: MinresWork) -> float:
    """``r <- b - K x`` for the solution ``hi + lo * scale`` (float64 arithmetic on ``hi``; the
    small ``K (lo * scale)`` is formed in float32 in the free work vectors ``z, r1`` and
    subtracted); returns ``||r||`` (``||b||`` is the first residual's: :func:`_force_residual`)."""
    rn = op.residual(x.hi_value(work.z), d, r)[0]
    if x.extended:  # the Lanczos kernel with c1 = 0 is the product K x
        op.lanczos(x.lo_value(work.z), 1.0, 0.0, work.r1)
        rn = float(np.sqrt(lz.subtract_sq(r, work.r1)))
    return rn


def _force_residual(op: _Stokes, gdir: int, r: np.ndarray) -> tuple[float, float]:
    """``r <- b``, the residual ``b - K x`` at ``x = 0`` that starts :func:`_solve_core`, and
    ``(||b||, ||b||)``, without :func:`_true_residual`'s operator pass at zero (0.13 s of one
    thread at 200^3, 0.3-0.39 s where it first touches ``r``; ``benchmarks/RESULTS.md``,
    session 49): the bits of
    :meth:`_Stokes.residual` there.

    ``b`` is the body force: 1 on the active faces of ``gdir`` (the staircase's ``diag != 0``),
    the cut faces' weight on the sub-voxel grid (:meth:`_Stokes.weight`), 0 on the other
    components and on the pressure: ``+0.0`` from the staircase kernel (fastmath), ``-0.0``
    from the sub-voxel one (exact: the negated zero divergence).  Its norm is summed as the
    kernels sum it: plane by plane, each in its cells' order (``np.cumsum``: sequential), the
    planes in index order (:func:`_sequential_sum`); on the staircase a count of ones, exact in
    any order."""
    r.fill(0.0)
    w = op.weight(gdir)
    if w is None:
        np.not_equal(op.d[gdir], 0, out=r[gdir])
        ff = float(np.count_nonzero(op.d[gdir]))
    else:
        np.copyto(r[gdir], w)
        del w
        part = [_sequential_sum(np.square(p.ravel(), dtype=np.float64)) for p in r[gdir]]
        ff = _sequential_sum(np.array(part))
        np.negative(r[3], out=r[3])
    bn = float(np.sqrt(ff))
    return bn, bn


def _sequential_sum(v: np.ndarray) -> float:
    """``v[0] + v[1] + ...`` one after the other from 0.0 (float64; ``np.cumsum`` adds in order,
    ``np.sum`` pairwise): the order of a kernel's running sum."""
    return float(np.cumsum(v)[-1]) if v.size else 0.0


def _later_bits(work: MinresWork, short: bool) -> int:
    """Storage bits of the directions from the second refinement cycle on: SYMMLQ's
    :data:`solvers.voxel.memory.LATER_SYMMLQ_BITS` where the solution's extension is int8
    (``short``: :meth:`solvers.voxel.lanczos.Solution.short`), else float32; MINRES'
    :data:`solvers.voxel.memory.LATER_DIRECTION_BITS`."""
    if work.w is None:
        return vmem.LATER_DIRECTION_BITS
    return vmem.LATER_SYMMLQ_BITS if short else 32


def _solve_core(
    op: _Stokes,
    d: int,
    tol: float,
    max_iter: int,
    progress: Callable[[int, float], None] | None = None,
) -> tuple[np.ndarray, dict]:
    """Iterative refinement: float64 residual, float32 preconditioned SYMMLQ (or MINRES:
    :data:`solvers.voxel.memory.KRYLOV`), the solution in
    48 bits per entry (:class:`solvers.voxel.lanczos.Solution`: float32 in the first cycle, plus
    an int16 extension from the second); returns the solution as float64."""
    shp = op.shape
    r = np.empty(shp, np.float32)
    # x = 0: r = b, formed before the Krylov vectors exist (the sub-voxel force's dense
    # weight, 4 B per cell, stays below the solve's peak)
    rn, bn = _force_residual(op, d, r)
    work = MinresWork.of(op)
    x = lz.Solution(shp, work.packing)
    rel = rn / bn
    history = [rel]
    total = 0
    message = "converged"
    stalls = 0
    while rel > tol:
        if total >= max_iter:
            message = f"max_iter={max_iter} Krylov iterations reached"
            break
        if total > 0:
            if not x.extended:  # the directions narrow where the solution widens (memory)
                work.store_directions(_later_bits(work, x.short(tol)))
            x.extend(tol)  # the float32 round-off of x would stop the next cycle near 1e-6
        rtol = min(0.5, max(INNER_RTOL_FLOOR, 0.3 * tol / rel))
        report = None
        if progress is not None:
            done, scale = total, rel

            def report(itn: int, ratio: float, done: int = done, scale: float = scale) -> None:
                progress(done + itn, scale * ratio)

        vmem.release_free_heap()
        its, status = krylov_run(op, r, x, work, rtol, max_iter - total, report)
        total += its
        rn = _true_residual(op, x, d, r, work)
        new = rn / bn
        history.append(new)
        if progress is not None:
            progress(total, new)
        if status == "preconditioner not positive":
            rel = new
            message = "preconditioner lost positivity (round-off); stopped"
            break
        stalls = stalls + 1 if not new < 0.5 * rel else 0
        rel = new
        if stalls and rel > tol and x.short(tol):
            # the int8 extension's floor: go on with int16 (and, at the next cycle's
            # store_directions, float32 directions)
            x.widen()
            stalls = 0
            rn = _true_residual(op, x, d, r, work)  # of the folded solution
            rel = rn / bn
            history.append(rel)
        if not np.isfinite(rel) or stalls >= 3:
            message = "stalled: the residual stopped decreasing"
            break
    del work, r
    return x.value(), {
        "converged": bool(rel <= tol),
        "iterations": total,
        "residual": float(rel),
        "history": history,
        "message": message if rel > tol else "converged",
    }
