"""Up-front time and memory estimates: refuse a spec before any allocation or long run.

Every check raises a schema error naming the key and the estimate. Figures:

* geometry: 16 bytes per voxel (float32 distance, uint8 count, uint16 mark, bool solid and a
  float64 temporary; ``benchmarks/RESULTS.md``: 7 bytes per voxel of fields);
* voxel Stokes solver: :data:`solvers.voxel.memory.BYTES_PER_CELL` (sub-voxel walls, the
  larger figure);
* the budget is half the machine's memory (``psutil.virtual_memory().total``).
"""

from __future__ import annotations

import math

from psdesign.schema.types import fail
from solvers.voxel.memory import BYTES_PER_CELL

GEOMETRY_BYTES_PER_VOXEL = 16
VOXEL_SOLVER_BYTES_PER_VOXEL = BYTES_PER_CELL["subvoxel"]
MEMORY_FRACTION = 0.5
#: Periodic copies of one fiber in the box (a tiny period multiplies the work).
MAX_COPIES = 1000
MAX_EXPLICIT_FIBERS = 2000
#: Cells of the stuffing mesher's lattice (a tiny flow.lattice_step).
MAX_LATTICE_CELLS = 5e7
#: GA work: population x generations x fibers fitness terms.
MAX_GA_WORK = 5e9
#: Study size: cases, seeds, levels of one parameter.
MAX_CASES = 100_000
MAX_SEEDS = 1000
MAX_LEVELS = 10_000


def machine_memory() -> float:
    """Total memory of the machine in bytes (8 GiB when psutil cannot tell)."""
    try:
        import psutil

        return float(psutil.virtual_memory().total)
    except Exception:  # noqa: BLE001 - an estimate must never fail
        return 8.0 * 2**30


def grid_shape(size: tuple[float, ...], voxel: float) -> list[float]:
    """Voxels per axis as floats (no overflow for absurd sizes)."""
    out = []
    for s in size:
        v = s / voxel
        out.append(max(1.0, float(math.floor(v + 0.5)) if math.isfinite(v) else v))
    return out


def check_grid(size: tuple[float, ...], voxel: float, solver: str, key: str = "rve.voxel") -> None:
    """Refuse a voxel grid whose estimated memory exceeds the budget."""
    shape = grid_shape(size, voxel)
    n = math.prod(shape)
    per = GEOMETRY_BYTES_PER_VOXEL + (VOXEL_SOLVER_BYTES_PER_VOXEL if solver == "voxel" else 0)
    need = n * per
    budget = MEMORY_FRACTION * machine_memory()
    if not need <= budget:
        vmin = voxel * (need / budget) ** (1 / 3)
        dims = "x".join(f"{s:.0f}" if s < 1e9 else f"{s:.2g}" for s in shape)
        raise fail(
            key,
            f"a {dims} grid ({n:.3g} voxels, {per} B each with solver {solver!r}) needs about "
            f"{need / 2**30:.3g} GiB; the budget is {budget / 2**30:.3g} GiB (half the machine)",
            f"voxel >= {vmin:.3g} m",
        )


def check_cells(key: str, size: tuple[float, ...], step: float, limit: float) -> None:
    """Refuse a lattice step giving more than ``limit`` cells in the box."""
    n = math.prod(grid_shape(size, step))
    if not n <= limit:
        raise fail(
            key,
            f"{step:g} m gives {n:.3g} cells",
            f"at most {limit:.0e} cells, step >= {step * (n / limit) ** (1 / 3):.3g} m",
        )


def check_copies(size: tuple[float, ...], period: float) -> None:
    """Refuse a period so small that every fiber has too many periodic copies."""
    copies = math.prod(s / period + 1.0 for s in size)
    if not copies <= MAX_COPIES:
        lo = max(size) / (MAX_COPIES ** (1 / 3) - 1.0)
        raise fail(
            "rve.period",
            f"gives about {copies:.3g} periodic copies of every fiber in the box",
            f"period >= {lo:.3g} m (at most {MAX_COPIES} copies)",
        )
    if period > 100.0 * max(size):
        raise fail(
            "rve.period",
            f"{period:g} m is over 100 x the largest edge",
            f"period <= {100 * max(size):.3g} m",
        )


def check_ga(population: int, generations: int, n_fibers: float) -> None:
    """Refuse a GA whose fitness work (population x generations x fibers) is unbounded."""
    work = population * generations * max(n_fibers, 1.0)
    if work > MAX_GA_WORK:
        raise fail(
            "intersections.generations",
            f"population {population} x generations {generations} x about {n_fibers:.0f} "
            f"fibers = {work:.3g} fitness terms",
            f"population x generations x fibers <= {MAX_GA_WORK:.0e}",
        )
