"""Benchmark: random fiber generation with intersection removal (issue 3).

Usage::

    python benchmarks/bench_generators.py CASE      # one case per process (clean peak memory)
    python benchmarks/bench_generators.py all

Cases
-----
fast40     40 straight fibers, D = 7 um, 100 um cube, voxel 0.5 um, method fast
ga40       the same 40 drawn fibers, method ga (paper Sec. 7.1 ranges, analytic Omega objective)
ga40vox    the same, GA with the paper's voxel objective (2 um voxels), small budget
por80      porosity target 0.8 (straight, D = 7 um, 100 um, 0.5 um voxels), method fast
fast160_200  160 straight fibers in a 200 um cube (same density as fast40), 1 um voxels, fast
por80_200  porosity target 0.8 in a 200 um cube (about 200 fibers), 1 um voxels, method fast
bent20     20 bent fibers (u in [0.1, 0.3], f in [1, 3]), 100 um, 0.5 um voxels, method fast

Each case prints one JSON line: wall times, porosity, Omega before/after on voxels, number of
fibers, rejections, displacement statistics and the peak resident memory of the process.
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import time

from psdesign.packing.generators import build_fibers

BASE = {
    "rve": {"size": [100e-6] * 3, "voxel": 0.5e-6},
    "generator": {"kind": "straight", "diameter": 7e-6, "seed": 1},
}


def _spec(gen: dict, inter: dict, size: float = 100e-6, voxel: float = 0.5e-6) -> dict:
    g = dict(BASE["generator"])
    g.update(gen)
    return {"rve": {"size": [size] * 3, "voxel": voxel}, "generator": g, "intersections": inter}


CASES = {
    "fast40": _spec({"n_fibers": 40}, {"method": "fast"}),
    "ga40": _spec({"n_fibers": 40}, {"method": "ga"}),
    "ga40vox": _spec(
        {"n_fibers": 40},
        {
            "method": "ga",
            "objective": "voxel",
            "ga_voxel": 2e-6,
            "population": 12,
            "generations": 10,
        },
    ),
    "por80": _spec({"porosity": 0.8}, {"method": "fast"}),
    "fast160_200": _spec({"n_fibers": 160}, {"method": "fast"}, size=200e-6, voxel=1e-6),
    "por80_200": _spec({"porosity": 0.8}, {"method": "fast"}, size=200e-6, voxel=1e-6),
    "bent20": _spec(
        {"kind": "bent", "n_fibers": 20, "f": {"dist": "uniform", "low": 1.0, "high": 3.0}},
        {"method": "fast"},
    ),
}


def run(case: str) -> dict:
    t0 = time.perf_counter()
    r = build_fibers(CASES[case]).report
    out = {
        "case": case,
        "wall_s": round(time.perf_counter() - t0, 2),
        "wall_time_s": r["wall_time_s"],
        "n_fibers": r["n_fibers"],
        "porosity_target": r["target_porosity"],
        "porosity": round(r["porosity"], 5),
        "porosity_before": round(r["porosity_before"], 5),
        "omega_before": r["omega_before"],
        "omega_after": r["omega_after"],
        "n_rejected": r.get("n_rejected"),
        "displacement_mean_um": round(r["displacement_m"]["mean"] * 1e6, 2),
        "displacement_max_um": round(r["displacement_m"]["max"] * 1e6, 2),
        "rotation_max_deg": round(r["rotation_deg"]["max"], 3),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    }
    if "placement_time_s" in r:
        out["removal_s"] = round(r["placement_time_s"], 2)
    if "ga" in r:
        out["ga"] = [
            {k: (round(v, 6) if isinstance(v, float) else v) for k, v in g.items()} for g in r["ga"]
        ]
    return out


if __name__ == "__main__":
    which = sys.argv[1] if len(sys.argv) > 1 else "all"
    if which == "all":
        for c in CASES:
            subprocess.run([sys.executable, __file__, c], check=False)
    else:
        print(json.dumps(run(which)), flush=True)
