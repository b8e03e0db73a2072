"""Memory of the voxel Stokes solver, estimated before anything is allocated.

Per cell of the *solved* grid (reservoirs and treatments included), counted from the arrays the
solve holds at its peak (MINRES phase) and checked against the traced peak
(``tests/unit/test_voxel_memory.py``, ``benchmarks/RESULTS.md``):

* solution ``x``: float32 ``hi`` 16 B plus, from the second refinement cycle, the int16
  extension ``lo`` 8 B (:class:`solvers.voxel.lanczos.Solution`; 48 bits: the true residual
  reaches about 2.5e-11 times the largest velocity in voxel units, float32 alone stalls near
  3e-6; int32, +8 B, for ``tol < 1e-7``): 24 B;
* three float32 4-field vectors (the residual, which is MINRES' current Lanczos vector, the
  older Lanczos vector and the preconditioned vector; the operator product is written in
  place, see :mod:`solvers.voxel.lanczos`): 48 B;
* two unscaled MINRES directions (:class:`solvers.voxel.lanczos.Directions`), float32 by
  default: 2 x 16 = 32 B (:data:`DIRECTION_BITS` = 16 stores int16 and one float32 scale per
  16 entries, 2 x 9 = 18 B, at about 10 % more iterations);
* multigrid: one float32 fine work array 4 B (the other is the preconditioned vector's pressure
  field); coarse levels (float32 7-point operator per component, 1/8 + 1/64 + ... of the cells:
  about 7 B; their ``x, t, b`` shared by the three components: about 2 B): 13 B;
* finest operators: uint8 diagonal and couplings, 3 components: 12 B; pressure-cell mask 1 B;
  the solid mask of the solved grid: 1 B;
* sub-voxel walls add float32 diagonals (+9 B), face weights (12 B) and the pressure scaling
  (4 B); the caller's float64 distance (8 B) comes on top.

Sum: 131 B staircase (117 B with 16-bit directions).  Traced (numpy allocations, ``python
benchmarks/bench_voxel_scale.py memory 64``): 130.7 B per cell staircase and 155.7 B sub-voxel
on the Toray-like 64^3 grid, 136.9 B on PuMA fibres_32 (16-bit directions: 116.2 / 141.2 /
121.4 B; formerly 137.8 / 162.8 / 145.7 B with a float64 solution and
float32 directions, and 164.6 / 189.6 B with seven vectors and two fine work arrays).

No numba and no numpy import here: :mod:`psdesign.schema.budget` uses it to refuse a spec.
"""

from __future__ import annotations

DIRECTION_BITS = 32
"""Storage of the MINRES directions (:class:`solvers.voxel.lanczos.Directions`): 32 (float32,
16 B per cell per direction; the default: the iteration count of float32 directions) or 16
(int16 blocks, 9 B; 14 B per cell less for about 10 % more iterations, issue 16 asks at most
10 %).  Measured, Toray-like at 1 um, tol 1e-6, 16 vs 32 bits: 157 vs 150 MINRES iterations
at 64^3, 222 vs 206 at 100^3, 279 vs 253 at 200^3 (+10 %): a refinement cycle then reduces the
true residual by about 1e-3 instead of 1e-4, so a third cycle is needed; K equal to 1e-8
(``benchmarks/RESULTS.md``)."""

BYTES_PER_CELL = {
    wall: per + (14 if DIRECTION_BITS == 32 else 0)
    for wall, per in (("staircase", 130), ("subvoxel", 160))
}
"""Peak bytes per solved cell of :func:`solvers.voxel_stokes.solve_voxel_stokes` by wall
treatment (the Python/numba baseline of ~150 MB comes on top): the counts above (131 / 156 B;
117 / 142 B with 16-bit directions) plus the multigrid's small-grid overheads; 14 B more with
float32 directions (the default)."""


TIGHT_TOL_BELOW = 1e-7
"""Tolerances below which the solution's extension is int32 instead of int16 (read by
:class:`solvers.voxel.lanczos.Solution`): +8 B per cell."""

TIGHT_TOL_EXTRA = 8


def solver_bytes(n_cells: float, wall_treatment: str = "subvoxel", tol: float = 1e-6) -> float:
    """Estimated peak memory (bytes) a voxel Stokes solve on ``n_cells`` solved cells adds to
    the running process (``tol``: the solve's tolerance; below :data:`TIGHT_TOL_BELOW` the
    solution takes :data:`TIGHT_TOL_EXTRA` more bytes per cell)."""
    per = BYTES_PER_CELL[wall_treatment] + (TIGHT_TOL_EXTRA if tol < TIGHT_TOL_BELOW else 0)
    return per * float(n_cells)


def available_bytes() -> float | None:
    """Memory the process can still allocate (psutil's ``available``), None when unknown."""
    try:
        import psutil

        return float(psutil.virtual_memory().available)
    except Exception:  # noqa: BLE001 - an estimate must never fail
        return None
