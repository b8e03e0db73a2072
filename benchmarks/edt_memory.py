"""Peak memory of the image route's signed distance (session 33).

``python benchmarks/edt_memory.py 200 fib`` (straight fibres 8 voxels wide along x and y, porosity
about 0.92) or ``... 200 big`` (one solid slab: a pore half a period wide, the worst case of a
transform that pads the mask): the peak RSS above the process after its imports, in bytes per
image voxel. Run it against an older checkout with ``PYTHONPATH`` to compare.
"""

from __future__ import annotations

import resource
import sys

import numba  # noqa: F401 - imported before the baseline, as the transforms import it
import numpy as np
import scipy.ndimage  # noqa: F401

from psdesign.image.fields import signed_distance


def test_image(n: int, mode: str) -> np.ndarray:
    """The solid mask of ``mode`` ("fib" or "big") on an ``n``^3 grid."""
    solid = np.zeros((n, n, n), bool)
    if mode == "big":
        solid[:2] = True
        return solid
    rng = np.random.default_rng(0)
    i = np.arange(n)
    for _ in range(int(n * 0.35)):
        c = rng.uniform(0, n, 2)
        disk = ((i[:, None] - c[0]) ** 2 + (i[None, :] - c[1]) ** 2) < 16
        solid |= disk[None, :, :] if rng.integers(0, 2) == 0 else disk[:, None, :]
    return solid


def main(argv: list[str]) -> None:
    n, mode = int(argv[0]), argv[1]
    solid = test_image(n, mode)
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    signed_distance(solid, 1e-6)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print(
        f"{mode} {n}^3 porosity {1 - solid.mean():.3f}: "
        f"peak above baseline {(peak - base) / n**3:.1f} B per voxel"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
