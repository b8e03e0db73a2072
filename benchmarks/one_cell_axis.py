"""Voxel Stokes iterations on grids with an axis of one cell, and solution arrays to compare.

Session 50 (benchmarks/RESULTS.md, "Session 50: trust ..."): the periodic face from a cell to
itself along an axis of one cell is counted twice in the pressure preconditioner's diagonal
(``solvers.voxel.schur.schur_code``) and in the thin-cell count (``solvers.voxel.thin``). Run
this under each tree to compare (``PYTHONPATH=<tree>``), then compare the arrays::

    PYTHONPATH=/path/to/tree python benchmarks/one_cell_axis.py run out.npz
    python benchmarks/one_cell_axis.py compare before.npz after.npz

``run`` prints one line per case (iterations, convergence, true residual, mean velocity along
the drive in voxel units, wall time) and saves the velocity, pressure and iterations; ``compare``
says which cases are bitwise equal. The grids with every axis > 2 must be.
"""

from __future__ import annotations

import sys
import time

import numpy as np


def slot_and_pocket(nz: int) -> np.ndarray:
    """tests/unit/test_voxel_thin_one_cell.py's grid: a slot 4 cells high (plane Poiseuille,
    mean velocity (h / ny) (h^2 / 12 + 1 / 6) = 0.3) beside a closed pocket with dead-end slits."""
    solid = np.ones((24, 20, nz), bool)
    solid[:, 1:5, :] = False
    solid[4:20, 7:12, :] = False
    solid[5:19:3, 12:16, :] = False
    return solid


def random_solid(shape: tuple[int, int, int], frac: float = 0.35) -> np.ndarray:
    """Solid voxels at fraction ``frac``, seeded by the shape."""
    return np.random.default_rng(sum(shape)).random(shape) <= frac


def cylinder(n: int, r: float, nz: int) -> np.ndarray:
    """One cylinder along z of radius ``r`` voxels in an ``n x n x nz`` box."""
    x, y = np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5, indexing="ij")
    disc = (x - n / 2) ** 2 + (y - n / 2) ** 2 <= r * r
    return np.repeat(disc[:, :, None], nz, axis=2)


def cases() -> dict[str, tuple[np.ndarray, str]]:
    """Name -> (solid, drive direction); the last three have every axis > 2."""
    return {
        "slot_pocket_24x20x1_x": (slot_and_pocket(1), "x"),
        "random_14x13x1_x": (random_solid((14, 13, 1)), "x"),
        "random_20x20x1_y": (random_solid((20, 20, 1)), "y"),
        "random_1x16x15_z": (random_solid((1, 16, 15)), "z"),
        "cylinder_32x32x1_x": (cylinder(32, 9.0, 1), "x"),
        "random_40x40x1_x": (random_solid((40, 40, 1), 0.3), "x"),
        "slot_pocket_24x20x3_x": (slot_and_pocket(3), "x"),
        "random_24x24x24_z": (random_solid((24, 24, 24), 0.3), "z"),
        "cylinder_32x32x8_x": (cylinder(32, 9.0, 8), "x"),
    }


def run(path: str) -> None:
    """Solve every case to 1e-8 and save the fields and iterations to ``path``."""
    from solvers.voxel_stokes import solve_voxel_stokes

    out = {}
    for name, (solid, d) in cases().items():
        t0 = time.perf_counter()
        r = solve_voxel_stokes(
            solid, 1.0, d, tol=1e-8, max_iter=2000, return_velocity=True, return_pressure=True
        )
        u = r.mean_velocity["xyz".index(d)]
        print(
            f"{name:24s} iterations {r.iterations:4d} converged {r.converged} residual "
            f"{r.residual:.2e} mean u {u:.10e} ({time.perf_counter() - t0:.2f} s)",
            flush=True,
        )
        out |= {f"{name}_u": r.velocity, f"{name}_p": r.pressure, f"{name}_it": r.iterations}
    np.savez(path, **out)


def compare(a: str, b: str) -> None:
    """Which cases of two ``run`` files have bitwise equal velocity, pressure and iterations."""
    x, y = np.load(a), np.load(b)
    for name in cases():
        same = all(np.array_equal(x[name + s], y[name + s]) for s in ("_u", "_p", "_it"))
        print(f"{name:24s} {'bitwise equal' if same else 'differs'}")


if __name__ == "__main__":
    if sys.argv[1:2] == ["run"]:
        run(sys.argv[2])
    else:
        compare(sys.argv[2], sys.argv[3])
