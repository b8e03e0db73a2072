"""Benchmark: union field + porosity of random straight fibers (issue 2).

Usage::

    python benchmarks/bench_geometry.py            # 50 fibers, D = 7 um, 100 um cube, 100^3..400^3

Each grid size runs in a fresh subprocess so its peak memory (max RSS) is its own.
"""

from __future__ import annotations

import json
import subprocess
import sys

CHILD = r"""
import json, resource, time
import numpy as np
from psdesign.geometry.fibers import make_fiber
from psdesign.geometry.rve import RVE
n = {n}
rng = np.random.default_rng(0)
L, D = 100e-6, 7e-6
fibers = [make_fiber("rod", diameter=D / L, center=rng.uniform(0, 1, 3),
                     theta=rng.uniform(-5, 5), omega=rng.uniform(0, 180)) for _ in range(50)]
rve = RVE([L, L, L], fibers)
rve.voxelize(L / 50)  # warm-up (imports, caches)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
best = 1e9
for _ in range(3):
    t = time.perf_counter()
    vf = rve.voxelize(L / n)
    por = vf.porosity
    best = min(best, time.perf_counter() - t)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({{"n": n, "time_s": best, "porosity": por, "peak_rss_mb": peak / 1024,
                  "omega": vf.intersection_volume_fraction}}))
"""


def main() -> None:
    rows = []
    for n in (100, 200, 300, 400):
        out = subprocess.run(
            [sys.executable, "-c", CHILD.format(n=n)], capture_output=True, text=True, check=True
        )
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
        print(rows[-1], flush=True)
    import math

    t100, t400 = rows[0]["time_s"], rows[-1]["time_s"]
    print(
        f"growth exponent in N = n^3 from 100^3 to 400^3: "
        f"{math.log(t400 / t100) / math.log(64):.2f}"
    )


if __name__ == "__main__":
    main()
