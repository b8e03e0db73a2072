"""Image route vs RVE route on the same geometry (docs/images.md).

An RVE spec (two crossing cylinders) is written as a TIFF stack by ``generate --format tiff``
and read back through an ``[image]`` spec. Both routes see the same voxels; the RVE route has
the analytic distance (sub-voxel walls, analytic surface), the image route only the voxels
(staircase walls, marching cubes on the voxel-face distance).

    PYTHONPATH=$PWD OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/image_vs_rve.py

Prints one markdown table row per quantity (results in benchmarks/RESULTS.md).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

RODS = """
[rve]
size = [{n}e-6, {n}e-6, {n}e-6]
voxel = 1e-6

[[fibers]]
shape = "cylinder"
diameter = {d1}e-6
center = [{c1x}e-6, {c1y}e-6, {half}e-6]
direction = [0, 0, 1]

[[fibers]]
shape = "cylinder"
diameter = {d2}e-6
center = [{half}e-6, {c2y}e-6, {c2z}e-6]
direction = [0, 1, 0]
"""


def spec_text(n: int) -> str:
    """Two cylinders (diameters n/3.2 and n/4 voxels) in an n^3 box of 1 um voxels."""
    return RODS.format(
        n=n,
        d1=n / 3.2,
        d2=n / 4,
        c1x=n * 0.31,
        c1y=n * 0.375,
        half=n / 2,
        c2y=n * 0.75,
        c2z=n * 0.69,
    )


def main(sizes=(24, 32, 48)) -> None:
    import psdesign
    from psdesign.cli.main import main as cli
    from psdesign.transport.pores import specific_surface

    print(
        "| box (voxels) | K_x RVE sub-voxel (m^2) | +- | K_x image staircase | +- | "
        "image / RVE - 1 | S_v RVE (1/m) | S_v image | image / RVE - 1 | wall s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in sizes:
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            rods = tmp / "rods.toml"
            rods.write_text(spec_text(n))
            assert (
                cli(
                    [
                        "generate",
                        str(rods),
                        "-o",
                        str(tmp / "out"),
                        "--format",
                        "tiff",
                        "--no-preview",
                    ]
                )
                == 0
            )
            img = tmp / "img.toml"
            img.write_text('[image]\npath = "out/rve.tif"\n')
            a, b = psdesign.build(rods), psdesign.build(img)
            ka = a.permeability("x", solver="voxel", bc="periodic")
            kb = b.permeability("x", solver="voxel", bc="periodic")
            sa, sb = specific_surface(a.fields), specific_surface(b.fields)
        print(
            f"| {n}^3 | {ka.permeability_m2:.4e} | {100 * ka.rel_error:.1f} % | "
            f"{kb.permeability_m2:.4e} | {100 * kb.rel_error:.1f} % | "
            f"{100 * (kb.permeability_m2 / ka.permeability_m2 - 1):+.1f} % | "
            f"{sa.specific_surface_m_1:.4e} | {sb.specific_surface_m_1:.4e} | "
            f"{100 * (sb.specific_surface_m_1 / sa.specific_surface_m_1 - 1):+.1f} % | "
            f"{time.perf_counter() - t0:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main(tuple(int(a) for a in sys.argv[1:]) or (24, 32, 48))
