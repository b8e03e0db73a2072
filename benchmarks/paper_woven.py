"""Woven Table III row (issue 17): sensitivity of K_z to the dimensions the paper leaves unstated.

Usage::

    nice python benchmarks/paper_woven.py sweep --voxel-fraction 0.02 --out woven_sweep.jsonl
    nice python benchmarks/paper_woven.py spec studies/table3/woven.toml --voxel 1e-6

``sweep`` builds the Table I cell (:func:`psdesign.geometry.fibers.woven_cell`) with a period
of 100 um for each (layers, layer_shift) and solves the periodic voxel Stokes problem along z
(through-plane). Stokes flow is scale-free, so K for any other period P is K(100 um) (P / 100
um)^2 on the same grid in periods (a 50 um period at 1 um voxels is the 100 um run at 2 um).
``spec`` solves one spec file (voxel route, through-plane) and prints the record.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

PAPER_WOVEN_Z = 2.55e-12


def solve(rve, voxel: float, direction: str = "z") -> dict:
    """Porosity, Omega and the voxel-route K along ``direction`` of an RVE."""
    from psdesign.flow.voxel import permeability_voxel

    t0 = time.perf_counter()
    fields = rve.voxelize(voxel)
    r = permeability_voxel(fields, direction, {"viscosity": 1.8e-5})
    return {
        "porosity": fields.porosity,
        "omega": fields.intersection_volume_fraction,
        f"k_{direction}_m2": r["permeability_m2"],
        "converged": r["converged"],
        "face_mismatch": r.get("face_mismatch"),
        "wall_time_s": time.perf_counter() - t0,
    }


def sweep(voxel_fraction: float, out: str) -> None:
    from psdesign.geometry.fibers import WOVEN_SPACING, woven_cell
    from psdesign.geometry.rve import RVE

    period = 100e-6
    half = WOVEN_SPACING / 2
    cases = [(1, (0.0, 0.0)), (2, (0.0, 0.0)), (3, (0.0, 0.0)), (2, (half, half))]
    cases += [(3, (half, half)), (3, (WOVEN_SPACING / 3, WOVEN_SPACING / 3))]
    for layers, shift in cases:
        rve = RVE([period] * 3, woven_cell("z", layers, shift), period=period)
        rec = {"period_m": period, "layers": layers, "layer_shift": list(shift)}
        rec.update(solve(rve, voxel_fraction * period))
        rec["k_z_at_50um_m2"] = rec["k_z_m2"] / 4
        with open(out, "a") as fh:
            fh.write(json.dumps(rec) + "\n")
        print(json.dumps(rec), flush=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("sweep")
    s.add_argument("--voxel-fraction", type=float, default=0.02)
    s.add_argument("--out", required=True)
    q = sub.add_parser("spec")
    q.add_argument("path")
    q.add_argument("--voxel", type=float, default=None)
    q.add_argument("--direction", default="z")
    a = p.parse_args(argv)
    if a.cmd == "sweep":
        sweep(a.voxel_fraction, a.out)
        return 0
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = load_spec(a.path)
    rve = build_rve(spec).rve
    rec = solve(rve, a.voxel or spec["rve"]["voxel"], a.direction)
    rec["paper_m2"] = PAPER_WOVEN_Z
    rec["ratio_to_paper"] = rec.get(f"k_{a.direction}_m2", np.nan) / PAPER_WOVEN_Z
    print(json.dumps(rec))
    return 0


if __name__ == "__main__":
    sys.exit(main())
