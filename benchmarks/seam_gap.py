"""K against the seam of a stack: how periodic must an RVE be along the flow to be stacked?

``flow.permeameter_copies = "auto"`` stacks copies of an RVE whose end planes along the flow match
(:func:`psdesign.flow.stack.end_planes`). A Toray-like RVE's tilted fibers are periodic along z
only to ``L (1 / cos(theta) - 1)`` (a PS fiber's copies are one period apart across its own axis,
so ``L / cos(theta)`` apart along z), so its stack has a seam: at each joint, the structure jumps
by that gap along the flow, as if a slab of that thickness were cut out of every period.

This script measures what such a seam does to K on an RVE that has none: the spec's generator
with every fiber in-plane (``theta = 0``: periodic along z to rounding), on the voxel grid of
``--voxel``; a seam of ``k`` voxels is made by cutting ``k`` layers out of the period at height
``z0`` (the wrapped grid then jumps by ``k h`` there, as the stack of a tilted RVE jumps at its
joints). Each grid is solved with ``bc = "periodic"`` along z (the limit of the stack of many
copies; no window, no reservoirs), one thread. Output: one JSON line per solve (stdout and
``--out``), then a table of ``K(gap) / K(0) - 1`` against ``gap / d`` and ``gap / L``.

Usage::

    NUMBA_NUM_THREADS=1 python benchmarks/seam_gap.py studies/rev_toray.toml --size 60e-6 \\
        --voxel 5e-7 --gaps 0 1 2 4 8 --z0 0 0.5 --out /tmp/seam_gap.jsonl
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def in_plane_rve(spec_path: str, size: float):
    """The spec's first case in a cube of edge ``size`` with ``theta = 0`` (built)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from solver_agreement import first_case

    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    spec, _ = first_case(ROOT / spec_path)
    spec = {**spec, "rve": {**spec["rve"], "size": [size] * 3}}
    spec["generator"] = {**spec["generator"], "theta": 0.0}
    spec["flow"] = {**spec["flow"], "solver": "voxel", "bc": "periodic"}  # no FEM budget check
    spec = validate_spec(spec)
    return build_rve(spec), spec


def cut(fields, k: int, z0: int):
    """``fields`` with ``k`` layers along z removed from layer ``z0`` on (a seam of ``k h``)."""
    from psdesign.geometry.rve import VoxelGrid

    if k == 0:
        return fields
    keep = np.r_[0:z0, z0 + k : fields.grid.shape[2]]
    g = fields.grid
    shape = (*g.shape[:2], len(keep))
    size = np.asarray(g.size, float).copy()
    size[2] = shape[2] * float(g.spacing[2])
    grid = VoxelGrid(size=size, shape=shape, spacing=np.asarray(g.spacing, float).copy())
    dist = np.ascontiguousarray(fields.distance[:, :, keep])
    count = np.ascontiguousarray(fields.count[:, :, keep])
    return type(fields)(distance=dist, count=count, grid=grid)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("spec")
    ap.add_argument("--size", type=float, default=60e-6, help="cube edge (m)")
    ap.add_argument("--voxel", type=float, default=5e-7, help="voxel edge (m)")
    ap.add_argument("--gaps", type=int, nargs="+", default=[0, 1, 2, 4, 8], help="voxels cut")
    ap.add_argument("--z0", type=float, nargs="+", default=[0.0, 0.5], help="cut height / L")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()

    from psdesign.flow.permeability import permeability
    from psdesign.flow.stack import end_planes

    built, spec = in_plane_rve(args.spec, args.size)
    fields = built.voxelize(args.voxel)
    d = float(spec["generator"]["diameter"])
    ep = end_planes(built.rve, fields, 2)
    print(f"# in-plane RVE: {len(built.rve.fibers)} fibers, z end planes: {ep.detail}", flush=True)
    flow = {**spec["flow"], "bc": "periodic"}
    n = fields.grid.shape[2]
    rows = []
    for z0f in args.z0:
        for k in args.gaps:
            if k == 0 and rows:  # one uncut solve
                continue
            z0 = int(round(z0f * n))
            f = cut(fields, k, z0)
            t0, c0 = time.perf_counter(), time.process_time()
            res = permeability(None, f, "z", flow, "voxel", error_estimate=False)
            row = {
                "spec": args.spec,
                "size_m": args.size,
                "voxel_m": args.voxel,
                "z0_layer": z0,
                "gap_voxels": k,
                "gap_m": k * args.voxel,
                "gap_over_d": k * args.voxel / d,
                "gap_over_L": k / n,
                "porosity": float(f.porosity),
                "k_m2": float(res["permeability_m2"]),
                "converged": bool(res["converged"]),
                "iterations": res.get("iterations"),
                "cpu_s": time.process_time() - c0,
                "wall_s": time.perf_counter() - t0,
                "load_1min": os.getloadavg()[0],
                "utc": time.strftime("%H:%M:%S", time.gmtime()),
            }
            rows.append(row)
            print(json.dumps(row), flush=True)
            if args.out is not None:
                with args.out.open("a") as fh:
                    fh.write(json.dumps(row) + "\n")
    print("| z0 / L | gap (um) | gap / d | gap / L | porosity | K (m^2) | K / K(0) - 1 |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        ref = next(x["k_m2"] for x in rows if x["gap_voxels"] == 0)
        print(
            f"| {r['z0_layer'] / n:.2f} | {r['gap_m'] * 1e6:.3g} | {r['gap_over_d']:.3f} | "
            f"{r['gap_over_L']:.4f} | {r['porosity']:.4f} | {r['k_m2']:.4e} | "
            f"{100 * (r['k_m2'] / ref - 1):+.2f} % |"
        )


if __name__ == "__main__":
    main()
