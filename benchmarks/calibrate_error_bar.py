"""Calibration data for the error bar (``psdesign/flow/error.py``) and the permeameter window.

Usage::

    python benchmarks/calibrate_error_bar.py --out /tmp/calib.jsonl

Solves the CALIBRATION set of cylinder arrays (resolutions and cell counts disjoint from the
validation set of ``benchmarks/validation_tables.py``, which reports the coverage) with the voxel
route through the dispatcher, both boundary conditions, and prints one JSON line per case:
the result ``K_h``, its coarse companion ``K_H``, the published value, the flow length scale
``R = sqrt(8 K / eps)``, the step, and for the permeameter the RVE length and the relative gap
between the face-plane drop and the windowed drop. The constants of ``error.py`` are chosen from
these lines (the smallest that cover every case, rounded up).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from arrays import array_spec, exact_k  # noqa: E402

from psdesign.flow import error as err  # noqa: E402
from psdesign.flow.permeability import permeability  # noqa: E402
from psdesign.packing.build import build_rve  # noqa: E402
from psdesign.schema.spec import validate_spec  # noqa: E402

#: (array, flow, solid fractions, voxels per spacing): disjoint from validation_tables.VOXEL_GRID.
PERIODIC = [
    ("square", "across", (0.1, 0.2, 0.3, 0.4, 0.5), (20, 32, 40)),
    ("square", "along", (0.1, 0.2, 0.3, 0.4), (20, 32, 40)),
    ("hex", "across", (0.1, 0.2), (26, 40)),
    ("hex", "along", (0.1, 0.2, 0.3), (26, 40)),
]
#: permeameter: (array, flow, solid fractions, voxels per spacing, cells along the flow).
PERMEAMETER = [
    ("square", "across", (0.1, 0.3, 0.5), (20, 32), (2, 3)),
    ("square", "along", (0.1, 0.3), (20, 32), (2, 3)),
    ("hex", "across", (0.1, 0.2), (26,), (2, 3)),
]


def solve(kind: str, flow: str, phi: float, n: int, bc: str, cells: int = 1) -> dict:
    """One case through the dispatcher; returns the calibration record."""
    along = flow == "along"
    spec = array_spec(
        kind, phi, n, n_cells=1 if along else cells, depth_voxels=cells * n if along else None
    )
    spec = validate_spec(spec)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    res = permeability(
        built.rve, fields, "z" if along else "x", {**spec["flow"], "bc": bc}, "voxel"
    )
    k = res["permeability_m2"]
    est = res["error_estimate"]
    rec = {
        "case": f"{kind} {flow} phi {phi:g} n {n} cells {cells} {bc}",
        "bc": bc,
        "k": k,
        "exact": exact_k(kind, flow, phi),
        "true": k / exact_k(kind, flow, phi) - 1.0,
        "k_coarse": est["permeability_coarse_m2"],
        "ratio": est["ratio"],
        "bar": res["permeability_rel_error"],
        "step": float(fields.grid.spacing[0]),
        "R": err.flow_length_scale(k, res["porosity"]),
        "solver": est["solver"],
    }
    if bc == "permeameter":
        rec["length"] = float(built.rve.size[2 if along else 0])
        rec["faces_gap"] = res["pressure_drop_faces_pa"] / res["pressure_drop_rve_pa"] - 1.0
        rec["alt_gap"] = res["pressure_drop_plane_window_pa"] / res["pressure_drop_rve_pa"] - 1.0
        rec["k_periodic"] = solve(kind, flow, phi, n, "periodic")["k"]
    return rec


def main(argv: list[str] | None = None) -> int:
    """Run the calibration set; one JSON line per case to stdout and ``--out``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None)
    ap.add_argument("--only", choices=("periodic", "permeameter"), default=None)
    args = ap.parse_args(argv)
    out = open(args.out, "w") if args.out else None  # noqa: SIM115
    jobs = []
    if args.only != "permeameter":
        jobs += [
            (kind, flow, phi, n, "periodic", 1)
            for kind, flow, phis, ns in PERIODIC
            for phi in phis
            for n in ns
        ]
    if args.only != "periodic":
        jobs += [
            (kind, flow, phi, n, "permeameter", c)
            for kind, flow, phis, ns, cs in PERMEAMETER
            for phi in phis
            for n in ns
            for c in cs
        ]
    for job in jobs:
        line = json.dumps(solve(*job))
        print(line, flush=True)
        if out:
            out.write(line + "\n")
            out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
