"""Does the gap term (session 38, s38-gaps) widen the K bar of random fibre RVEs?

The product's designs: the porosity-sweep study's Toray-like papers (``studies/
porosity_sweep.toml``: straight 7 um fibres, 100 um cube at 120 voxels; here seed 1, porosity
0.75 and 0.85, K_x and K_z) with the default sub-voxel walls and with staircase walls, and the
quickstart's geometry (50 um cube, 1 um voxels, porosity 0.85 and 0.9, min_gap 0.5 um) on the
voxel route, also as a segmented image (staircase, wall distance from the voxel mask). Each
result is solved twice through ``permeability(..., "voxel")``: with the gap term and without
(``psdesign.flow.error.GAP`` emptied); one JSON line each with both bars and the throat.

    PYTHONPATH=. python benchmarks/narrow_gap_rve.py > /tmp/narrow_gap_rve.jsonl
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psdesign.flow import error as err  # noqa: E402
from psdesign.flow.permeability import permeability  # noqa: E402
from psdesign.packing.build import build_rve  # noqa: E402
from psdesign.schema.spec import validate_spec  # noqa: E402


def paper(size: float, voxel: float, porosity: float, seed: int, min_gap: float | None) -> dict:
    inter = {"method": "fast", **({"min_gap": min_gap} if min_gap else {})}
    return {
        "rve": {"size": [size] * 3, "voxel": voxel},
        "generator": {"kind": "straight", "porosity": porosity, "diameter": 7e-6, "seed": seed,
                      "theta": {"dist": "uniform", "low": -5.0, "high": 5.0},
                      "omega": {"dist": "uniform", "low": 0.0, "high": 180.0}},
        "intersections": inter,
        "flow": {"solver": "voxel", "viscosity": 1.8e-5},
    }  # fmt: skip


def both(built, fields, d: str, flow: dict) -> tuple[dict, dict]:
    saved = dict(err.GAP)
    err.GAP.clear()
    try:
        before = permeability(built.rve, fields, d, flow, "voxel")
    finally:
        err.GAP.update(saved)
    t0 = time.perf_counter()
    after = permeability(built.rve, fields, d, flow, "voxel")
    after["t_s"] = time.perf_counter() - t0
    return before, after


def cases():
    for por in (0.85, 0.9):
        for wall in ("subvoxel", "staircase", "image"):
            yield f"quickstart voxel {wall}", por, paper(50e-6, 1e-6, por, 1, 0.5e-6), wall
    for por in (0.75, 0.85):
        for wall in ("subvoxel", "staircase"):
            yield f"porosity_sweep {wall}", por, paper(100e-6, 1e-4 / 120, por, 1, None), wall


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        for name, por, spec, wall in cases():
            spec = validate_spec(spec)
            built = build_rve(spec)
            h = spec["rve"]["voxel"]
            fields = built.voxelize(h)
            if wall == "image":
                path = Path(tmp) / "img.npy"
                np.save(path, fields.solid.astype(np.uint8))
                spec = validate_spec({"image": {"path": str(path), "voxel_size": h}})
                built = build_rve(spec)
                fields = built.voxelize(h)
            else:
                spec["flow"] = {**spec["flow"], "wall_treatment": wall}
            for d in ("x", "z"):
                before, after = both(built, fields, d, spec["flow"])
                est = after["error_estimate"]
                print(json.dumps({
                    "case": name, "porosity_target": por,
                    "direction": d, "k": after["permeability_m2"],
                    "bar_before": before["permeability_rel_error"], "bar": after[
                        "permeability_rel_error"], "status_before": before["status"],
                    "status": after["status"], "gap": est["gap"], "throat_voxels": (
                        est["throat_m"] / h if est["throat_m"] else None),
                    "t_s": after["t_s"],
                }), flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
