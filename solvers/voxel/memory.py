"""Memory of the voxel Stokes solver, estimated before anything is allocated.

Per cell of the *solved* grid (reservoirs and treatments included), counted from the arrays the
solve holds at its peak (MINRES phase) and checked against the traced peak
(``tests/validation/test_voxel_stokes.py``, ``benchmarks/RESULTS.md``):

* solution ``x`` float64, 4 fields: 32 B; residual / right-hand side float32: 16 B; five float32
  MINRES work vectors: 80 B (MINRES accumulates straight into ``x``: no correction vector);
* multigrid: two shared float32 fine work arrays 8 B, coarse levels (float32 ``x, t, b`` and
  7-point operator, 1/8 + 1/64 + ... of the cells) about 4 B per component: 12 B;
* finest operators: uint8 diagonal and couplings, 3 components: 12 B; pressure-cell mask 1 B;
  the solid masks of the input and the solved grid: 3 B;
* sub-voxel walls add float32 diagonals (+9 B), face weights (12 B), the pressure scaling
  (4 B) and the caller's float64 distance (8 B).

No numba and no numpy import here: :mod:`psdesign.schema.budget` uses it to refuse a spec.
"""

from __future__ import annotations

BYTES_PER_CELL = {"staircase": 176, "subvoxel": 210}
"""Peak bytes per solved cell of :func:`solvers.voxel_stokes.solve_voxel_stokes` by wall
treatment (the Python/numba baseline of ~150 MB comes on top): the counts above plus the
multigrid's small-grid overheads; traced peak on PuMA fibres_32 172.5 / 206.1 B per cell."""


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
