"""Memory of the voxel Stokes solver, estimated before anything is allocated.

Per cell of the *solved* grid (reservoirs and treatments included), counted from the arrays the
solve holds at its peak (Krylov phase) and checked against the traced peak
(``tests/unit/test_voxel_memory.py``, ``benchmarks/RESULTS.md``):

* solution ``x``: float32 ``hi`` 16 B plus, from the second refinement cycle, the int16
  extension ``lo`` 8 B (:class:`solvers.voxel.lanczos.Solution`; 48 bits: the true residual
  reaches about 2.5e-11 times the largest velocity in voxel units, float32 alone stalls near
  3e-6; int32, +8 B, for ``tol < 1e-7``): 24 B; with SYMMLQ (the default, :data:`KRYLOV`)
  on the active unknowns only (:class:`solvers.voxel.lanczos.Packing`: 24 B times their
  fraction, 0.77 on the Toray-like grids, plus 8 B per plane of a field for the offsets);
  for ``tol >=`` :data:`SHORT_SOLUTION_FROM` (1e-6, the default tolerance) an int8
  extension, 20 B;
* three float32 4-field vectors (the residual, which is MINRES' current Lanczos vector, the
  older Lanczos vector and the preconditioned vector; the operator product is written in
  place, see :mod:`solvers.voxel.lanczos`): 48 B;
* the directions: SYMMLQ's one (:data:`KRYLOV`, the default), float32 16 B, packed as the
  solution, so the peak is the second cycle's ``24 + 16`` (times the active fraction;
  ``20 + 12`` with the int8 extension and the 24-bit later direction for ``tol >=``
  :data:`SHORT_SOLUTION_FROM`, no more than the first cycle's ``16 + 16``); or
  MINRES' two unscaled directions (:class:`solvers.voxel.lanczos.Directions`): float32
  2 x 16 = 32 B, or int16 with one float32 scale per 16 entries, 2 x 9 = 18 B;
  :data:`DIRECTION_BITS` in the first refinement cycle, :data:`LATER_DIRECTION_BITS` from the
  second on (where the solution gains its 8 B), so the peak is ``max(16 + first, 24 + later)``;
* multigrid: no fine work array (the V-cycles smooth between the preconditioned vector's
  pressure field and their own output field); coarse levels (7-point operators, 1/8 + 1/64 +
  ... of the cells; the first coarse level of the staircase in uint8, the Galerkin sums of its
  integer operator, about 1.7 B; their ``x, t, b`` shared by the three components, about
  2 B): 4 B;
* finest operators: uint8 diagonals of the 3 components, 3 B; their couplings (9 B) only where
  the permeameter's box walls cut some (:func:`solvers.voxel.kernels.unit_couplings` on
  periodic grids: :data:`WALL_COUPLING_BYTES`); the staircase's one-byte pressure scale code
  1 B (formed at set-up, so its temporaries stay off the peak), 0 off the pressure cells, so it
  is the pressure-cell mask too (``_Stokes._mask_in_code``); sub-voxel walls keep a 1 B mask;
* sub-voxel walls keep the staircase's storage (uint8 diagonals, rounded, uint8 first coarse
  levels, the one-byte scale code as the mask, :mod:`solvers.voxel.cutfaces`) and add their
  cut faces: 6 B each (position, the diagonal's remainder and the weight), 0.43 per cell on
  the Toray-like grids (14 % of each component's active faces), 0.47 on the square cylinder
  array of the tests; counted as :data:`CUT_FACES_PER_CELL` per cell, 3 B (session 9, before
  the cut-face storage: +27 B).  The caller's float64 distance (8 B) comes on top while the
  caller holds it (the solve frees its own references after the set-up).  Their set-up (one
  component's float64 face distance and two float64 temporaries at a time,
  :func:`solvers.voxel.boundary.component_coefficients`, each component compressed at once)
  stays below the Krylov phase: 80 B per cell traced on the Toray-like 64^3 grid.

Sum, staircase, periodic: 96 B with SYMMLQ on a grid whose unknowns are all active (the
bound counted here: the estimate is made before the grid is known), 87 B at the Toray-like
grids' active fraction 0.77; sub-voxel 99 B (all active); with MINRES 112 B with float32
directions, 104 B with 16-bit directions from the second cycle, 98 B with 16-bit directions
throughout; 8 B less with SYMMLQ for ``tol >=`` :data:`SHORT_SOLUTION_FROM`.  Traced (numpy
allocations, ``python benchmarks/bench_voxel_scale.py memory 64``, issue 16 session 9, tol
1e-6): 80.7 B per cell staircase and 85.4 B sub-voxel on the Toray-like 64^3 grid, 87.9 B on
PuMA fibres_32 (session 10, with the cut-face storage; session 9: 84.2 / 115.5 / 87.9 B, and
86.6 / 118.8 / 95.0 B with :data:`SHORT_SOLUTION_FROM` at 1e-5;
session 8: 88.4 / 119.6 / 97.5 B; session 7: 88.4 / 133.0 / 97.5 B; MINRES, session 5:
113.7 / 143.2 / 115.6 B).  The process's peak RSS adds the interpreter, numba and the caller (about
0.3 GB): Toray-like 400^3, ``bench_voxel_scale.py 400 x``, 5 820 248 KiB = 5.96e9 B, the
pre-solve 0.31e9 B plus 88.3 B per cell, once the allocator's free heap is returned
(:func:`release_free_heap`; ``benchmarks/RESULTS.md``).

No numba and no numpy import here: :mod:`psdesign.schema.budget` uses it to refuse a spec.
"""

from __future__ import annotations

import math

DIRECTION_BITS = 32
"""Storage of the MINRES directions (:class:`solvers.voxel.lanczos.Directions`) in the first
refinement cycle: 32 (float32, 16 B per cell per direction) or 16 (int16 blocks, 9 B).
Measured before the two-level pressure block, Toray-like at 1 um, tol 1e-6, 16 vs 32 bits
throughout: 157 vs 150 MINRES iterations at 64^3, 222 vs 206 at 100^3, 279 vs 253 at 200^3
(+10 %): a refinement cycle then reduces the true residual by about 1e-3 instead of 1e-4, so a
third cycle is needed; K equal to 1e-8 (``benchmarks/RESULTS.md``)."""

LATER_DIRECTION_BITS = 32
"""Storage of the directions from the second refinement cycle on (new zero directions then:
MINRES restarts on each cycle's residual), when the solution gains its 8 B extension: 16 lowers
the staircase peak from 113 to 105 B per cell.  Measured, Toray-like at 1 um, tol 1e-6, with the
two-level pressure block, 16 vs 32: 120 vs 120 MINRES iterations at 64^3, but **167 vs 151 at
100^3** (+10.6 %: the 16-bit second cycle ends at 1.85e-6 instead of 2.6e-7, just above tol, so
a third cycle runs); K equal to 3e-8.  Hence 32 by default (``benchmarks/RESULTS.md``)."""

KRYLOV = "symmlq"
"""Krylov method of the voxel Stokes solve (:func:`solvers.voxel_stokes._solve_core`):
``"symmlq"`` (one float32 direction, 16 B per cell, and the solution on the active unknowns
only) or ``"minres"`` (two directions, :data:`DIRECTION_BITS`; the solution on the grid); the
same Lanczos recurrence and preconditioner."""

SHORT_SOLUTION_FROM = 1e-6
"""Tolerances from which the solution's extension is int8 instead of int16
(:class:`solvers.voxel.lanczos.Solution`: 40 bits per entry, one scale per row) and SYMMLQ's
direction is stored in :data:`LATER_SYMMLQ_BITS` from the second refinement cycle on: the
later cycles then hold ``4 + 1 + 3`` B per active entry instead of ``4 + 2 + 4``, no more than
the first cycle's ``4 + 4`` (-8 B per cell on a fully active grid; PuMA fibres_32 at tol 1e-6:
88.9 instead of 95.0 B per cell traced).  From the default 1e-6 on since session 9: the
rounding of either (the direction's 2^-16, the solution's 2^-31 of a row's largest entry)
leaves a true relative residual of about 2e-6 on the large Toray-like grids, so a third
refinement cycle runs there: 190 instead of 180 iterations at 200^3 (+5.6 %), 299 instead of
281 at 400^3 (+6.4 %; solve 293.2 vs 288.2 s, peak RSS 5.42e9 vs 5.89e9 B, K equal to 1e-9);
64^3, 100^3 and fibres_32 unchanged (``benchmarks/RESULTS.md``, issue 16 session 9).  Tighter
tolerances keep the int16 extension and the float32 direction."""

LATER_SYMMLQ_BITS = 24
"""Bits per entry of SYMMLQ's direction from the second refinement cycle on when ``tol >=``
:data:`SHORT_SOLUTION_FROM` (24: the float32's upper three bytes, relative round-off 2^-16;
32: float32).  A 16-bit direction (int16, a scale per 32 entries) added a third refinement
cycle already at 100^3 (160 instead of 153 iterations)."""

DIRECTION_BYTES = {32: 16, 16: 9}
"""Bytes per cell of one direction by its bits (16: int16 and a float32 scale per 16)."""

WALL_COUPLING_BYTES = 9
"""The finest couplings of the three components, stored only where box walls cut some (the
permeameter: :func:`solver_bytes` ``walls=True``)."""

CUT_FACE_BYTES = 6
"""Bytes of one cut face (:class:`solvers.voxel.cutfaces.CutFaces`: uint16 position, int16
remainder of the diagonal, uint16 weight)."""

CUT_FACES_PER_CELL = 0.5
"""Cut faces per cell counted for sub-voxel walls (the three components together; measured
0.43 on the Toray-like grids, 0.47 on the square cylinder array of the memory test)."""

_FIXED = {
    "staircase": 48 + 4 + 3 + 1,
    "subvoxel": 48 + 4 + 3 + 1 + round(CUT_FACES_PER_CELL * CUT_FACE_BYTES),
}
"""Bytes per cell besides the solution and the directions (module docstring)."""

_SMALL_GRID = 8
"""Allowance for the multigrid's and the coarse pressure term's small-grid overheads (PuMA
fibres_32 traces about 6 B per cell above the Toray-like 64^3 grid)."""


def _per_cell(wall_treatment: str, first: int, later: int) -> int:
    if KRYLOV == "symmlq":  # all unknowns active: the bound (module docstring)
        sol = 24 + DIRECTION_BYTES[32]
    else:
        sol = max(16 + 2 * DIRECTION_BYTES[first], 24 + 2 * DIRECTION_BYTES[later])
    return _FIXED[wall_treatment] + sol + _SMALL_GRID


BYTES_PER_CELL = {
    wall: _per_cell(wall, DIRECTION_BITS, LATER_DIRECTION_BITS)
    for wall in ("staircase", "subvoxel")
}
"""Peak bytes per solved cell of :func:`solvers.voxel_stokes.solve_voxel_stokes` by wall
treatment on a periodic grid (the Python/numba baseline of ~150 MB comes on top; the
permeameter's box walls add :data:`WALL_COUPLING_BYTES`): the counts above plus the
multigrid's small-grid overheads."""


TIGHT_TOL_BELOW = 1e-7
"""Tolerances below which the solution's extension is int32 instead of int16 (read by
:class:`solvers.voxel.lanczos.Solution`): +8 B per cell."""

TIGHT_TOL_EXTRA = 8

SHORT_TOL_SAVING = 8
"""Bytes per cell the solution and the direction save at ``tol >=`` :data:`SHORT_SOLUTION_FROM`
(int8 extension -4 B, 24-bit direction -4 B on a fully active grid)."""


def _tol_extra(tol: float) -> int:
    """Bytes per cell above :data:`BYTES_PER_CELL` (the count for tolerances in
    ``[TIGHT_TOL_BELOW, SHORT_SOLUTION_FROM)``): more below, less from the default 1e-6 on."""
    if tol < TIGHT_TOL_BELOW:
        return TIGHT_TOL_EXTRA
    return -SHORT_TOL_SAVING if tol >= SHORT_SOLUTION_FROM and KRYLOV == "symmlq" else 0


def solver_bytes(
    n_cells: float, wall_treatment: str = "subvoxel", tol: float = 1e-6, walls: bool = True
) -> float:
    """Estimated peak memory (bytes) a voxel Stokes solve on ``n_cells`` solved cells adds to
    the running process (``tol``: the solve's tolerance; below :data:`TIGHT_TOL_BELOW` the
    solution takes :data:`TIGHT_TOL_EXTRA` more bytes per cell, from
    :data:`SHORT_SOLUTION_FROM` on it and the direction :data:`SHORT_TOL_SAVING` less;
    ``walls``: box walls, i.e. the
    permeameter, whose cut couplings are stored, :data:`WALL_COUPLING_BYTES`)."""
    per = BYTES_PER_CELL[wall_treatment] + _tol_extra(tol)
    if walls:
        per += WALL_COUPLING_BYTES
    return per * float(n_cells)


_TRIM: object = None
"""glibc's ``malloc_trim`` once looked up (False where there is none)."""


def release_free_heap() -> bool:
    """Return the free pages inside the C heap to the system (glibc ``malloc_trim(0)``); False
    where the C library has no such call (nothing done).

    numpy allocates arrays below glibc's mmap threshold (which rises to 32 MiB once a block that
    large is freed) on the heap, where the set-up's freed temporaries stay resident until
    trimmed: measured 8 B per cell of the peak RSS of a Toray-like 200^3 solve (97.3 ->
    89.7 B per cell, ``benchmarks/RESULTS.md``).  Called after the set-up, after the
    percolation check and before each Krylov run; a few milliseconds.
    """
    global _TRIM
    if _TRIM is None:
        try:
            import ctypes

            _TRIM = ctypes.CDLL(None).malloc_trim
            _TRIM.argtypes = [ctypes.c_size_t]
        except (OSError, AttributeError):  # not glibc: nothing to trim
            _TRIM = False
    if _TRIM is False:
        return False
    _TRIM(0)
    return True


def available_bytes() -> float | None:
    """Memory the process can still allocate (psutil's ``available``), None when unknown."""
    try:
        import psutil

        return float(psutil.virtual_memory().available)
    except Exception:  # noqa: BLE001 - an estimate must never fail
        return None


def reservoir_cells(n_d: int, aux_length: float) -> int:
    """Cells of each empty reservoir of a permeameter solve: ``aux_length`` times the sample's
    ``n_d`` cells along the flow, rounded up, at least one (here, beside the bytes per cell,
    so that :mod:`psdesign.schema.budget` counts the cells the solve holds without importing
    the solver).

    >>> reservoir_cells(60, 0.2 / 3), reservoir_cells(5, 0.0)
    (4, 1)
    """
    return max(1, math.ceil(aux_length * n_d - 1e-9))


def solved_shape(
    shape: tuple[int, ...], d: int, bc: str, treatment: str = "periodic", aux_length: float = 0.2
) -> tuple[int, ...]:
    """The shape of the grid a solve of a ``shape`` sample holds (before any allocation): the
    permeameter's two reservoirs (:func:`reservoir_cells`) along ``d``, else the periodic
    treatment's (``mirror``: doubled along ``d``; ``frame``: one solid layer more across it).

    >>> solved_shape((60, 10, 10), 0, "permeameter", aux_length=0.2)
    (84, 10, 10)
    >>> solved_shape((60, 10, 10), 0, "periodic", "mirror")
    (120, 10, 10)
    >>> solved_shape((6, 4, 4), 0, "periodic", "frame")
    (6, 5, 5)
    """
    dims = [int(n) for n in shape]
    if bc == "permeameter":
        dims[d] += 2 * reservoir_cells(dims[d], aux_length)
    elif treatment == "mirror":
        dims[d] *= 2
    elif treatment == "frame":
        dims = [n + (b != d) for b, n in enumerate(dims)]
    return tuple(dims)
