"""Benchmark: ``fast`` placement of bent fibers, the capsule rasterizer before and after.

Usage::

    python benchmarks/bench_placement.py [CASE ...]     # default: bent10

Cases
-----
bent10   geom21's bent case: 60 um cube, D = 7 um, porosity 0.8, bent (default f in [1, 10]),
         fast with a 0.5 um gap, 0.6 um voxels, seed 1 (18 fibers, ~300 placements)
bent3    the same with f in [1, 3]

Each case is built twice in one process, first with :func:`reference_mark_capsules` and
:func:`reference_bent_capsules` (the rasterizer and the bent-capsule builder as of main
1edeb1d, copied here) patched into :mod:`psdesign.packing.sequential`, then with the
product's; one JSON line each: placement time, the time in
the rasterizer, calls, capsules, ejections, and the SHA-256 of the RVE document (identical
hashes = the same RVE bit for bit). The numba kernels are compiled before the timed runs.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time

import numba
import numpy as np

import psdesign.packing.sequential as seq
from psdesign.packing.build import rve_document
from psdesign.packing.generators import build_fibers
from psdesign.schema.spec import validate_spec


@numba.njit(cache=True)
def reference_mark_capsules(free, A, B, lim):  # pragma: no cover - compiled
    """The rasterizer as of 1edeb1d: every grid point of every capsule's box is tested."""
    k = free.shape[0]
    half = k // 2
    for m in range(A.shape[0]):
        ax, ay, bx, by, r = A[m, 0], A[m, 1], B[m, 0], B[m, 1], lim[m]
        ex, ey = bx - ax, by - ay
        L2 = max(ex * ex + ey * ey, 1e-30)
        i0 = int(np.floor(min(ax, bx) - r))
        i1 = int(np.ceil(max(ax, bx) + r))
        j0 = int(np.floor(min(ay, by) - r))
        j1 = int(np.ceil(max(ay, by) + r))
        for i in range(i0, i1 + 1):
            px = i - ax
            for j in range(j0, j1 + 1):
                py = j - ay
                t = (px * ex + py * ey) / L2
                t = min(1.0, max(0.0, t))
                dx = px - t * ex
                dy = py - t * ey
                if dx * dx + dy * dy < r * r:
                    free[(i + half) % k, (j + half) % k] = False


def reference_bent_capsules(trial, old, A, B, lim):
    """``sequential._bent_capsules`` as of 1edeb1d (numpy; its docstring says what it does)."""
    c, d = trial.center[0], trial.frames[0, 0]
    u, f, ph = float(trial.u[0]), float(trial.f[0]), float(trial.phase[0])
    sa, sb = (old.a - c) @ d, (old.b - c) @ d
    smin, smax = np.minimum(sa, sb), np.maximum(sa, sb)
    width = min(0.5 * float(lim.min()), 1.0 / (12.0 * f))
    m = np.maximum(1, np.ceil((smax - smin + 2 * lim) / width).astype(np.int64))
    rep = np.repeat(np.arange(len(m)), m)
    j = np.arange(len(rep)) - (np.cumsum(m) - m)[rep]
    h = ((smax - smin + 2 * lim) / m)[rep]
    s0 = smin[rep] - lim[rep] + j * h
    s1 = s0 + h
    g = np.maximum(0.0, np.maximum(s0 - smax[rep], smin[rep] - s1))
    r = np.sqrt(np.clip(lim[rep] ** 2 - g**2, 0.0, None))
    tp = 2 * np.pi
    th0 = tp * f * (s0 + 0.5) + ph
    th1 = tp * f * (s1 + 0.5) + ph
    has_max = np.floor(th1 / tp) >= np.ceil(th0 / tp)
    has_min = np.floor((th1 - np.pi) / tp) >= np.ceil((th0 - np.pi) / tp)
    cmax = np.where(has_max, 1.0, np.maximum(np.cos(th0), np.cos(th1)))
    cmin = np.where(has_min, -1.0, np.minimum(np.cos(th0), np.cos(th1)))
    w1, w2 = -u * cmax / tp, -u * cmin / tp
    wlo, whi = np.minimum(w1, w2), np.maximum(w1, w2)
    keep = g < lim[rep]
    shift = np.zeros((len(rep), 2))
    shift[:, 0] = 0.5 * (wlo + whi)
    A2 = (A[rep] - shift)[keep]
    B2 = (B[rep] - shift)[keep]
    return A2, B2, (r + 0.5 * (whi - wlo))[keep], old.fiber[rep][keep]


def spec(case: str) -> dict:
    """The validated spec of a case."""
    gen = {"kind": "bent", "porosity": 0.8, "diameter": 7e-6, "seed": 1}
    if case == "bent3":
        gen["f"] = {"dist": "uniform", "low": 1.0, "high": 3.0}
    elif case != "bent10":
        raise SystemExit(f"unknown case {case!r}; allowed: bent10, bent3")
    return validate_spec(
        {
            "rve": {"size": [60e-6] * 3, "voxel": 0.6e-6},
            "generator": gen,
            "intersections": {"method": "fast", "min_gap": 0.5e-6},
        }
    )


def rve_hash(result) -> str:
    """SHA-256 of the RVE document (centres, angles, phases, diameters of every fiber)."""
    text = json.dumps(rve_document(result.rve), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def run(case: str, kernel, bent, label: str) -> dict:
    """Build ``case`` with ``kernel`` as the rasterizer and ``bent`` as the bent-capsule
    builder; timings and the RVE hash."""
    stats = {"calls": 0, "capsules": 0, "kernel_s": 0.0}

    def timed(free, A, B, lim):
        t = time.perf_counter()
        kernel(free, A, B, lim)
        stats["kernel_s"] += time.perf_counter() - t
        stats["calls"] += 1
        stats["capsules"] += len(lim)

    saved = seq._mark_capsules, seq._bent_capsules
    seq._mark_capsules, seq._bent_capsules = timed, bent
    try:
        t0 = time.perf_counter()
        res = build_fibers(spec(case))
        wall = time.perf_counter() - t0
    finally:
        seq._mark_capsules, seq._bent_capsules = saved
    rep = res.report
    return {
        "case": case,
        "kernel": label,
        "wall_s": round(wall, 2),
        "placement_time_s": rep.get("placement_time_s"),
        "kernel_s": round(stats["kernel_s"], 2),
        "calls": stats["calls"],
        "capsules": stats["capsules"],
        "n_fibers": rep["n_fibers"],
        "n_ejections": rep.get("n_ejections"),
        "n_rejected": rep.get("n_rejected"),
        "porosity": rep["porosity"],
        "rve_sha256": rve_hash(res),
        "load": [round(x, 2) for x in os.getloadavg()],
    }


def main(cases: list[str]) -> int:
    # compile both kernels outside the timed runs
    free = np.ones((8, 8), bool)
    pts = np.zeros((1, 2))
    for kern in (reference_mark_capsules, seq._mark_capsules):
        kern(free.copy(), pts, pts + 1.0, np.ones(1))
    one = np.zeros(1)
    seq._bent_capsule_rows(
        one, one, one + 0.1, pts, pts, np.zeros(1, np.int64), 0.1, 2.0, 0.0, 0.05
    )
    same = True
    for case in cases:
        rows = [
            run(case, reference_mark_capsules, reference_bent_capsules, "reference 1edeb1d"),
            run(case, seq._mark_capsules, seq._bent_capsules, "product"),
        ]
        for r in rows:
            print(json.dumps(r), flush=True)
        equal = rows[0]["rve_sha256"] == rows[1]["rve_sha256"]
        same &= equal
        print(
            f"{case}: placement {rows[0]['placement_time_s']:.1f} s -> "
            f"{rows[1]['placement_time_s']:.1f} s, rasterizer {rows[0]['kernel_s']:.1f} s -> "
            f"{rows[1]['kernel_s']:.1f} s, same RVE: {equal}",
            flush=True,
        )
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:] or ["bent10"]))
