"""Voxel solver on exact cylinder-array distance fields: resolution, cell width and alignment.

Usage::

    python benchmarks/voxel_alignment.py KIND FLOW PHI CASE [CASE ...]

``KIND`` square | hex, ``FLOW`` across | along, ``PHI`` the solid fraction; each ``CASE`` is
``n[:ny][@dx,dy]``: ``n`` voxels per spacing, ``ny`` the cell width in voxels (default ``n``
square, ``round(sqrt(3) n)`` hexagonal; the lattice is scaled to it, the radius kept, as
``tests/arrays.array_spec`` does), ``dx,dy`` a sub-voxel shift of the cylinders (voxels). One
JSON line per case: the true error against the published value (``validation_tables.
reference_k``), the width error and the MINRES iterations. Solves
:func:`solvers.voxel_stokes.solve_voxel_stokes` directly (periodic, sub-voxel walls, a slab 4
voxels thick: the flow is independent of z), tol 1e-8.

Examples (``docs/validation.md``, ``benchmarks/RESULTS.md``)::

    python benchmarks/voxel_alignment.py hex across 0.2 40 40:70 41:70 41 41:72 56 97 112 153
    python benchmarks/voxel_alignment.py square across 0.3 24 24@0.25,0.1 24@0.5,0.37 32 ...
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT))

from arrays import L, radius_of  # noqa: E402

from solvers.voxel_stokes import solve_voxel_stokes  # noqa: E402


def distance(
    kind: str, phi: float, n: int, ny: int, nz: int, shift: tuple[float, float]
) -> np.ndarray:
    """Exact signed distance (voxels, > 0 in the fluid) of the array on an ``n x ny x nz``
    grid: square, one cylinder at the cell centre; hexagonal, at the centre and the corners."""
    x = np.arange(n) + 0.5
    y = np.arange(ny) + 0.5
    xx, yy = np.meshgrid(x, y, indexing="ij")
    lattice = "square" if kind == "square" else "hexagonal"
    a = radius_of(phi, lattice, spacing=n)
    centres = [(n / 2, ny / 2)] + ([(0.0, 0.0)] if kind == "hex" else [])
    best = np.full(xx.shape, np.inf)
    for cx, cy in centres:
        dx = xx - cx - shift[0]
        dy = yy - cy - shift[1]
        dx -= n * np.round(dx / n)
        dy -= ny * np.round(dy / ny)
        best = np.minimum(best, np.hypot(dx, dy))
    return np.repeat((best - a)[:, :, None], nz, axis=2)


def run_case(kind: str, flow: str, phi: float, token: str) -> dict:
    """Solve one ``n[:ny][@dx,dy]`` case; returns the JSON record."""
    from validation_tables import reference_k

    shift = (0.0, 0.0)
    if "@" in token:
        token, off = token.split("@")
        shift = tuple(float(v) for v in off.split(","))
    n, _, ny_s = token.partition(":")
    n = int(n)
    ny = int(ny_s) if ny_s else (n if kind == "square" else round(math.sqrt(3.0) * n))
    d = distance(kind, phi, n, ny, 4, shift)
    h = L / n
    axis = 0 if flow == "across" else 2
    t0 = time.perf_counter()
    res = solve_voxel_stokes(d <= 0, h, axis, distance=(d * h).astype(np.float32), tol=1e-8)
    k = float(res.mean_velocity[axis] / res.pressure_gradient)
    width_err = ny / (n * math.sqrt(3.0)) - 1.0 if kind == "hex" else ny / n - 1.0
    return {
        "kind": kind,
        "flow": flow,
        "phi": phi,
        "n": n,
        "ny": ny,
        "shift": list(shift),
        "width_error": width_err,
        "true_error": k / reference_k(kind, flow, phi) - 1.0,
        "iterations": int(res.iterations),
        "converged": bool(res.converged),
        "wall_s": time.perf_counter() - t0,
    }


def main(argv: list[str] | None = None) -> int:
    """Print one JSON line per case."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) < 4:
        print(__doc__)
        return 2
    kind, flow, phi = args[0], args[1], float(args[2])
    for token in args[3:]:
        print(json.dumps(run_case(kind, flow, phi, token)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
