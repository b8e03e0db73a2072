"""Memory of the voxel Stokes solver, estimated before anything is allocated.

Per cell of the *solved* grid (reservoirs and treatments included), counted from the arrays the
solve holds at its peak (MINRES phase) and checked against the traced peak
(``tests/unit/test_voxel_memory.py``, ``benchmarks/RESULTS.md``):

* solution ``x`` float64, 4 fields: 32 B; five float32 4-field vectors (the residual, which is
  MINRES' current Lanczos vector, the older Lanczos vector, the preconditioned vector and two
  unscaled directions; the operator product is written in place, see
  :mod:`solvers.voxel.lanczos`): 80 B;
* multigrid: one float32 fine work array 4 B (the other is the preconditioned vector's pressure
  field); coarse levels (float32 7-point operator per component, 1/8 + 1/64 + ... of the cells:
  about 7 B; their ``x, t, b`` shared by the three components: about 2 B): 13 B;
* finest operators: uint8 diagonal and couplings, 3 components: 12 B; pressure-cell mask 1 B;
  the solid mask of the solved grid: 1 B;
* sub-voxel walls add float32 diagonals (+9 B), face weights (12 B) and the pressure scaling
  (4 B); the caller's float64 distance (8 B) comes on top.

Traced (numpy allocations, ``python benchmarks/bench_voxel_scale.py memory 64``): 138.2 B per
cell staircase and 163.2 B sub-voxel on the Toray-like 64^3 grid, 145.7 B on PuMA fibres_32
(formerly 164.6 / 189.6 B on the 64^3 grid, with seven vectors and two fine work arrays).

No numba and no numpy import here: :mod:`psdesign.schema.budget` uses it to refuse a spec.
"""

from __future__ import annotations

BYTES_PER_CELL = {"staircase": 150, "subvoxel": 185}
"""Peak bytes per solved cell of :func:`solvers.voxel_stokes.solve_voxel_stokes` by wall
treatment (the Python/numba baseline of ~150 MB comes on top): the counts above (139 / 164 B)
plus the multigrid's small-grid overheads."""


def solver_bytes(n_cells: float, wall_treatment: str = "subvoxel") -> float:
    """Estimated peak memory (bytes) a voxel Stokes solve on ``n_cells`` solved cells adds to
    the running process."""
    return BYTES_PER_CELL[wall_treatment] * float(n_cells)


def available_bytes() -> float | None:
    """Memory the process can still allocate (psutil's ``available``), None when unknown."""
    try:
        import psutil

        return float(psutil.virtual_memory().available)
    except Exception:  # noqa: BLE001 - an estimate must never fail
        return None
