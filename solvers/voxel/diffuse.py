"""Stokes flow on a voxel grid with the diffuse-domain wall: fields and fluxes for Darcy's law
(issue 12 item 3; the product path of ``benchmarks/diffuse3d.py``).

The wall is a smooth layer (:mod:`solvers.voxel.diffuse_wall`): a fluid fraction ``eps`` that
weights the viscous fluxes, the pressure force, the flux and the body force, and a drag that
keeps no-slip.  Sampled from the analytic geometry (the signed distance, its Laplacian and the
normal of the two nearest bodies at 7 points per cell, :meth:`DiffuseGrid.sample`), it makes K
converge monotonically where the cut-face wall (:func:`solvers.voxel_stokes.solve_voxel_stokes`,
the default) scatters with the sub-voxel position of the wall: square cylinder arrays in 2-D at
phi 0.1-0.5 along and across at every shift (``benchmarks/RESULTS.md``, wall22), spheres and a
cylinder array tilted to the grid in 3-D (port22).  The error is negative and second order
(-1.2 % at 24, -0.25 % at 40 voxels per spacing on the square array phi 0.3 along); on spheres it
is 3-6x the cut-face solver's (port22).

Cost, honestly: the system is assembled (scipy sparse) and solved by MINRES with pyamg V-cycles
(:mod:`solvers.voxel.diffuse_system`), periodic on all faces only: about 1.7-1.8 kB per cell
measured, :data:`BYTES_PER_CELL` = 2.1 kB counted (:func:`diffuse_memory_bytes`; 20x the
cut-face solver's 99 B), so 11 M cells (224^3) fit in 24 GB; 70-95 MINRES iterations to
``tol`` 1e-8, 0.24 s per iteration at 230 k cells on one core (about 1 us per cell and
iteration, 25x the cut-face solver's 336 ms at 200^3 of issue 16); ``benchmarks/RESULTS.md``,
dport23.  A solve that would not fit in the available memory is refused before anything is
allocated.
"""

from __future__ import annotations

import resource
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from solvers.voxel import memory as vmem
from solvers.voxel.diffuse_system import assemble, minres_solve
from solvers.voxel.diffuse_wall import DEFAULT_WALL, WallProfile, combine
from solvers.voxel_stokes import (
    VoxelFlowResult,
    VoxelStokesError,
    _check_direction,
    _check_options,
    check_percolates,
)

__all__ = ["BYTES_PER_CELL", "DiffuseGrid", "diffuse_memory_bytes", "solve_diffuse_stokes"]

SLAB_POINTS = 1 << 18
"""Points per call of the ``walls`` sampler (whole x planes, at least one)."""

_CELL = (0.5, 0.5, 0.5)


def _face_offset(c: int) -> tuple[float, float, float]:
    """Face ``c`` of cell ``(i, j, k)``: the centre minus ``e_c / 2``."""
    return tuple(0.0 if a == c else 0.5 for a in range(3))


def _edge_offset(e: int) -> tuple[float, float, float]:
    """The edge along ``e`` at the cell's lower corner: ``(i, j, k) + e_e / 2``."""
    return tuple(0.5 if a == e else 0.0 for a in range(3))


@dataclass(frozen=True)
class DiffuseGrid:
    """eps and drag of a diffuse wall at the points of a periodic grid (voxel units; cell
    ``(i, j, k)`` spans ``[i, i+1] x [j, j+1] x [k, k+1]``).

    Attributes
    ----------
    cell : np.ndarray, shape (nx, ny, nz)
        eps at the cell centres ``(i + 1/2, j + 1/2, k + 1/2)``.
    face : np.ndarray, shape (3, nx, ny, nz)
        eps at face ``c`` of cell ``(i, j, k)``: the centre minus ``e_c / 2`` (the product's
        ``velocity[c][i, j, k]`` convention: the face between cells ``(i, j, k) - e_c`` and
        ``(i, j, k)``).
    edge : np.ndarray, shape (3, nx, ny, nz)
        eps at the edge along axis ``e`` at the cell's lower corner: ``(i, j, k) + e_e / 2``.
    drag : np.ndarray, shape (3, nx, ny, nz)
        Drag at the faces (1 / voxel^2).
    """

    cell: np.ndarray
    face: np.ndarray
    edge: np.ndarray
    drag: np.ndarray

    @property
    def shape(self) -> tuple[int, int, int]:
        """The grid ``(nx, ny, nz)``."""
        return tuple(int(m) for m in self.cell.shape)

    @classmethod
    def sample(
        cls,
        shape: tuple[int, int, int],
        walls: Callable,
        profile: WallProfile = DEFAULT_WALL,
    ) -> DiffuseGrid:
        """Sample the wall of the geometry ``walls`` on a periodic grid of ``shape`` cells.

        Parameters
        ----------
        shape : (nx, ny, nz)
            Cells of the grid (each >= 1).
        walls : callable
            ``walls(x, y, z) -> sequence of one or two (s, kappa, aniso)`` (arrays like ``x``, or
            raveled): the nearest and the second-nearest wall at the points ``(x, y, z)`` (voxel
            coordinates, float64 arrays of one slab of whole x planes): signed distance (> 0 in
            the fluid), Laplacian of the distance (1 / voxel) and ``n_x^4 + n_y^4 + n_z^4`` of
            the unit normal.  Fluid points farther than
            :data:`solvers.voxel.diffuse_wall.REACH_VOXELS` from every wall may get any
            distance at least that large (eps 1 and drag 0 there to 1e-7); solid points need
            their true distance.  Evaluated slab by slab along x so that memory stays O(slab).
        profile : WallProfile
            The wall profile (default: the calibrated :data:`DEFAULT_WALL`).

        Raises
        ------
        VoxelStokesError
            A bad ``shape``, or ``walls`` returning no, more than two, mis-shaped or
            non-finite walls.
        """
        shape = _check_shape(shape)
        cell = np.empty(shape)
        face, edge, drag = (np.empty((3, *shape)) for _ in range(3))
        step = max(1, SLAB_POINTS // (shape[1] * shape[2]))
        for i0 in range(0, shape[0], step):
            sl = slice(i0, min(i0 + step, shape[0]))
            cell[sl] = _sample_slab(walls, profile, shape, sl, _CELL, False)[0]
            for a in range(3):
                face[a, sl], drag[a, sl] = _sample_slab(
                    walls, profile, shape, sl, _face_offset(a), True
                )
                edge[a, sl] = _sample_slab(walls, profile, shape, sl, _edge_offset(a), False)[0]
        return cls(cell, face, edge, drag)


def _check_shape(shape) -> tuple[int, int, int]:
    try:
        out = tuple(int(m) for m in shape)
    except (TypeError, ValueError):
        out = ()
    if len(out) != 3 or min(out) < 1 or tuple(shape) != out:
        raise VoxelStokesError(f"shape must be three whole cell counts >= 1, got {shape!r}")
    return out


def _sample_slab(walls, profile, shape, sl: slice, offset, with_drag: bool):
    """eps (and the drag) of the pair rule at the points ``(i, j, k) + offset`` of x planes
    ``sl``."""
    axes = [np.arange(sl.start, sl.stop, dtype=float) + offset[0]]
    axes += [np.arange(m, dtype=float) + o for m, o in zip(shape[1:], offset[1:], strict=True)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    got = walls(x, y, z)
    if not isinstance(got, list | tuple) or not 1 <= len(got) <= 2:
        raise VoxelStokesError(
            "walls must return one or two (s, kappa, aniso) tuples (nearest, second nearest)"
        )
    pts = []
    for w in got:
        if len(w) != 3 or any(np.size(v) != x.size for v in w):
            raise VoxelStokesError(
                f"walls must return (s, kappa, aniso) arrays of {x.size} points each (one slab)"
            )
        w = [np.asarray(v, dtype=float).reshape(x.shape) for v in w]
        if not all(np.all(np.isfinite(v)) for v in w):
            raise VoxelStokesError("walls must return finite s, kappa and aniso")
        if np.any((w[2] < 1.0 / 3.0 - 1e-9) | (w[2] > 1.0 + 1e-9)):
            raise VoxelStokesError("walls: aniso = n_x^4 + n_y^4 + n_z^4 must lie in [1/3, 1]")
        pts.append(tuple(w))
    return combine(pts, profile, with_drag)


# ------------------------------------------------------------------------------------------
# memory

BYTES_PER_CELL = 2100
"""Peak bytes per cell of :func:`solve_diffuse_stokes` above the process's baseline, the
caller's :class:`DiffuseGrid` (80 B) included: the assembled blocks, the three pyamg
hierarchies, the MINRES vectors.  Fitted on the peak RSS (``/usr/bin/time -v``) of the tilted
cylinder array at 24 / 36 / 48 voxels per spacing (28 800 / 97 200 / 230 400 cells; ``python
benchmarks/diffuse3d.py product``): 1839 B per cell, intercept -8.7 MB, above the 3 600-cell
run's 175 MiB.  2100 is that slope + 14 %; it is 16-33 % above the measured increments of
all five grids measured (the spheres at 64^3 and 96^3: 1750 and 1681 B per cell;
``benchmarks/RESULTS.md``, dport23)."""

FIXED_BYTES = 0
"""Bytes on top of :data:`BYTES_PER_CELL` per solve (the fit's intercept is -8.7 MB)."""


def diffuse_memory_bytes(shape) -> float:
    """Estimated peak memory (bytes) :func:`solve_diffuse_stokes` adds to the running process on
    a grid of ``shape`` cells, with the :class:`DiffuseGrid` the caller holds (module
    :data:`BYTES_PER_CELL`, :data:`FIXED_BYTES`). On floats: an absurd shape (a spec's
    memory check) gives a huge or infinite estimate, never an overflow."""
    cells = float(np.prod([float(m) for m in shape]))
    return FIXED_BYTES + BYTES_PER_CELL * cells


def _check_memory(shape: tuple[int, int, int]) -> None:
    """Refuse, before any allocation, a solve whose estimate exceeds the available memory."""
    cells = float(np.prod(shape))
    need = diffuse_memory_bytes(shape)
    avail = vmem.available_bytes()
    if avail is not None and need > avail:
        raise VoxelStokesError(
            f"grid: the diffuse-wall solve of {cells:.3g} cells needs about {need / 2**30:.3g}"
            f" GiB ({need / cells:.0f} B per cell, assembled); {avail / 2**30:.3g} GiB are"
            " available: use a coarser voxel, a smaller RVE or the cut-face solver"
        )


# ------------------------------------------------------------------------------------------
# the solve


def _check_grid(grid: object) -> tuple[int, int, int]:
    """Shapes, dtypes and ranges of a :class:`DiffuseGrid`; its ``(nx, ny, nz)``."""
    if not isinstance(grid, DiffuseGrid):
        raise VoxelStokesError(f"grid must be a DiffuseGrid, got {type(grid).__name__}")
    names = ("cell", "face", "edge", "drag")
    for name in names:
        arr = getattr(grid, name)
        if not isinstance(arr, np.ndarray) or arr.dtype.kind != "f":
            raise VoxelStokesError(f"grid.{name} must be a float numpy array")
    if grid.cell.ndim != 3 or min(grid.cell.shape) < 1:
        raise VoxelStokesError(f"grid.cell must be 3-D (nx, ny, nz), got {grid.cell.shape}")
    shape = grid.shape
    for name in names[1:]:
        if getattr(grid, name).shape != (3, *shape):
            raise VoxelStokesError(
                f"grid.{name} must have shape {(3, *shape)}, got {getattr(grid, name).shape}"
            )
    for name in names[:3]:
        arr = getattr(grid, name)
        if not np.all((arr >= 0.0) & (arr <= 1.0)):
            raise VoxelStokesError(f"grid.{name}: eps must lie in [0, 1] (and not be NaN)")
    if not np.all(np.isfinite(grid.drag) & (grid.drag >= 0.0)):
        raise VoxelStokesError("grid.drag must be finite and >= 0 (1 / voxel^2)")
    if not np.any(grid.face > 1e-9):
        raise VoxelStokesError("grid has no fluid: eps is 0 on every face")
    return shape


def solve_diffuse_stokes(
    grid: DiffuseGrid,
    voxel_size: float,
    direction: str | int,
    viscosity: float = 1.0,
    tol: float = 1e-8,
    max_iter: int = 2000,
    progress: Callable[[int, float], None] | None = None,
    *,
    pressure_gradient: float = 1.0,
    return_velocity: bool = False,
) -> VoxelFlowResult:
    """Solve Stokes flow with the diffuse wall on a periodic grid; return fields and fluxes.

    Parameters
    ----------
    grid : DiffuseGrid
        eps and drag at the points of the grid (:meth:`DiffuseGrid.sample`).
    voxel_size : float
        Voxel edge in metres (> 0).
    direction : {'x', 'y', 'z', 0, 1, 2}
        Axis of the driving mean pressure gradient (a body force; periodic on all faces).
    viscosity : float
        Dynamic viscosity (Pa s, > 0); the velocities scale with ``1 / viscosity``.
    tol : float
        True relative residual ``||b - K x|| / ||b||`` to reach (0 < tol < 1).
    max_iter : int
        MINRES iterations in all (>= 1).
    progress : callable, optional
        ``progress(iterations, residual)`` every 25 iterations (the last true residual) and
        after each MINRES run.
    pressure_gradient : float
        Driving mean pressure gradient (Pa/m, > 0).
    return_velocity : bool
        Return the face velocities ``u`` (m/s, float32, ``(3, nx, ny, nz)``, the
        :class:`DiffuseGrid` face convention; the flux through a face is ``eps_face u``).

    Returns
    -------
    VoxelFlowResult
        ``wall_treatment="diffuse"``, ``bc="periodic"``; ``mean_velocity = mean(eps_face u)``
        per component (m/s), ``porosity`` the mean of ``grid.cell``, ``n_cells`` the pressure
        cells with a weighted face.  Darcy's law is applied by the caller.

    Raises
    ------
    VoxelStokesError (ValueError)
        A malformed grid (shapes, dtypes, eps outside [0, 1]), no fluid, no percolating fluid
        path along ``direction`` (cells with eps >= 0.5, face-connected, periodic), an option out
        of range, or a grid whose :func:`diffuse_memory_bytes` exceeds the available memory.
    """
    t0 = time.perf_counter()
    d = _check_direction(direction)
    _check_options(voxel_size, viscosity, tol, max_iter, "periodic", "periodic")
    if not (np.isfinite(pressure_gradient) and pressure_gradient > 0):
        raise VoxelStokesError(f"pressure_gradient must be > 0 Pa/m, got {pressure_gradient!r}")
    shape = _check_grid(grid)
    if not np.any(grid.face[d] > 1e-9):
        raise VoxelStokesError(f"grid has no fluid: eps is 0 on every face along {'xyz'[d]!r}")
    # fluid = eps >= 1/2 at the cell centre, the sharp wall's side (the staircase grid's fluid)
    check_percolates(grid.cell < 0.5, d, "grid (cells with eps >= 0.5)")
    _check_memory(shape)
    system = assemble(grid, np.eye(3)[d])
    x, info = minres_solve(system, tol, int(max_iter), progress)
    n = system.n
    u = x[: 3 * n].reshape(3, *shape)
    live = int(np.count_nonzero(system.live))
    del system, x
    return _result(
        grid, u, info, d, (voxel_size, viscosity, pressure_gradient), t0, live, return_velocity
    )


def _result(grid, u, info, d, units, t0, live, return_velocity) -> VoxelFlowResult:
    """Scale the voxel-unit solution (h = mu = G = 1) to SI fields and fluxes."""
    h, mu, g = units
    shape = grid.shape
    vel_scale = g * h * h / mu
    lat = tuple(b for b in range(3) if b != d)
    mean_u = np.array([float(np.mean(grid.face[a] * u[a])) for a in range(3)]) * vel_scale
    planes = (grid.face[d] * u[d]).sum(axis=lat) * vel_scale * h * h
    mean_q = float(planes.mean())
    imbalance = float((planes.max() - planes.min()) / mean_q) if mean_q > 0 else float("inf")
    return VoxelFlowResult(
        mean_velocity=mean_u,
        pressure_gradient=g,
        viscosity=mu,
        flow_rate=mean_q,
        plane_flow_rates=planes,
        direction=d,
        porosity=float(grid.cell.mean()),
        converged=bool(info["converged"]),
        iterations=int(info["iterations"]),
        residual=float(info["residual"]),
        n_cells=live,
        wall_time_s=time.perf_counter() - t0,
        peak_memory_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        velocity=(u * vel_scale).astype(np.float32) if return_velocity else None,
        history=list(info["history"]),
        periodic_treatment="periodic",
        flux_imbalance=imbalance,
        message=info["message"],
        bc="periodic",
        wall_treatment="diffuse",
        rve_slice=(0, shape[d]),
        voxel_size=h,
        rve_pressure_drop=g * shape[d] * h,
        rve_length=shape[d] * h,
        rve_area=float(shape[lat[0]] * shape[lat[1]]) * h * h,
        applied_pressure_drop=g * shape[d] * h,
    )
