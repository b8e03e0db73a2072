"""The time and memory estimate printed before each voxel Stokes solve (the FEM route's is
:func:`psdesign.flow.fem._announce`), on the active progress printer: the command's, a study
case's log, the API's with ``progress=True``.

Printed by the route itself (:func:`psdesign.flow.voxel.permeability_voxel`) from the grid the
solver will hold (:func:`solvers.voxel_stokes.solved_shape`: the permeameter's stack and
reservoirs, the mirrored or framed periodic grid), once per solve: ``--bc both`` and the error
bar's second resolution get their own line. Until session 43 (review2) the command printed one
line before the first solve from a count of its own, which the API imported from the command's
module; it counted a mirrored periodic grid as the RVE's (half the cells) and said nothing of a
``--bc both`` run's periodic solve.
"""

from __future__ import annotations

from collections.abc import Sequence

#: Voxel Stokes solve time per grid cell, one thread and two (measured on the idle 2-core
#: machine: 100^3 in 9.5 s and 5.4 s, ``solvers.voxel.threads.PARALLEL_MIN_CELLS``).
VOXEL_SECONDS_PER_CELL = {1: 9.5e-6, 2: 5.4e-6}

#: The same for ``flow.wall_treatment = "diffuse"`` (wall sampling, assembly, AMG set-up and
#: 50-90 MINRES iterations): 7-10e-5 s per cell on grids of 2.6e4-2.1e5 cells, square arrays
#: (``benchmarks/diffuse_validation_runs.jsonl``, 2026-12-04, the shared 2-core machine).
DIFFUSE_SECONDS_PER_CELL = 9e-5
#: Plus the wall sampling per cell, fibre and box image (``psdesign.geometry.walls``): 1.3-4.1
#: us measured (square array 64^2 x 40, one fibre; hexagonal cell at 56, 5 fibres x 3 images;
#: 2026-12-04, idle), the larger kept.
WALL_SECONDS_PER_CELL_AND_COPY = 4.5e-6


def announce_voxel_solve(
    name: str, shape: Sequence[int], diffuse_images: int | None = None
) -> None:
    """Print ``voxel solve <name> (<cells> cells): estimated ~<t>, ~<m> GB`` for a solve whose
    grid has ``shape`` (the solved grid, :func:`solvers.voxel_stokes.solved_shape`); ``<m>`` is
    the process's peak (:data:`psdesign.schema.budget.PROCESS_FIXED_BYTES` with the grid's).

    Parameters
    ----------
    name : str
        The flow direction, ``"x"``, ``"y"`` or ``"z"``.
    shape : sequence of int
        The solved grid's cells per axis.
    diffuse_images : int, optional
        ``flow.wall_treatment = "diffuse"``: the fibres times their box images whose walls are
        sampled (its own rate and memory, :func:`solvers.voxel.diffuse.diffuse_memory_bytes`).
    """
    import math

    import numba

    from psdesign import progress
    from psdesign.schema.budget import (
        GEOMETRY_BYTES_PER_VOXEL,
        PROCESS_FIXED_BYTES,
        VOXEL_SOLVER_BYTES_PER_VOXEL,
    )

    cells = math.prod(int(n) for n in shape)
    rate = VOXEL_SECONDS_PER_CELL[1 if numba.get_num_threads() == 1 else 2]
    # the process's peak, not the solver's alone: 0.03 GB was printed for a 64^3 solve whose
    # process peaked at 0.37 GB (session 54; now 0.39, and 0.80 for 150^3's measured 0.65)
    per_cell = VOXEL_SOLVER_BYTES_PER_VOXEL + GEOMETRY_BYTES_PER_VOXEL
    need = PROCESS_FIXED_BYTES + per_cell * cells
    if diffuse_images is not None:
        from solvers.voxel.diffuse import diffuse_memory_bytes

        rate = DIFFUSE_SECONDS_PER_CELL + WALL_SECONDS_PER_CELL_AND_COPY * diffuse_images
        need = PROCESS_FIXED_BYTES + diffuse_memory_bytes(tuple(shape))
    progress.estimate(f"voxel solve {name} ({cells:.3g} cells)", rate * cells, need / 1e9)
