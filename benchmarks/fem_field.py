"""The FEM's geometry against the spec's voxel (issue 12; ``psdesign/flow/fem_field.py``).

``woven``: the periodic FEM K of the 30 um woven cell of Eq. (19) (60 x 60 x 30 um, yarns
4.26 um wide; ``tests/validation/test_solver_agreement.py::periodic_spec``) on the spec grid
``--voxel`` at the lattice step ``--step``, with its error bar and the field it meshed.
``--spec-grid`` meshes the spec's grid as the FEM did before it sampled its own field.

Usage::

    python benchmarks/fem_field.py woven --voxel 1e-6 --step 2e-6 [--direction z]
        [--no-error-estimate] [--spec-grid]

One JSON line per run on stdout (``permeability_m2``, ``permeability_rel_error``,
``error_estimate``, ``fem_field``, ``n_tets``, ``wall_s``, ``load``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "tests" / "validation"))
sys.path.insert(0, str(ROOT))


def woven(args: argparse.Namespace) -> dict:
    """One periodic FEM solve of the woven cell (see module)."""
    from test_solver_agreement import periodic_spec

    import psdesign.flow.fem_field as ff
    from psdesign.flow.permeability import permeability
    from psdesign.packing.build import build_rve

    if args.spec_grid:
        ff.FIELD_VOXELS_PER_DIAMETER = 0.0  # never refine, no field term: the old FEM geometry
    flow = {"bc": "periodic", "lattice_step": args.step}
    spec = periodic_spec("woven", voxel=args.voxel, flow=flow)
    built = build_rve(spec)
    t0 = time.perf_counter()
    res = permeability(
        built.rve,
        built.voxelize(args.voxel),
        args.direction,
        spec["flow"],
        "fem",
        error_estimate=not args.no_error_estimate,
    )
    keep = ("permeability_m2", "permeability_rel_error", "error_estimate", "fem_field", "n_tets")
    out = {k: res.get(k) for k in keep}
    out |= {
        "voxel": args.voxel,
        "step": args.step,
        "direction": args.direction,
        "spec_grid": bool(args.spec_grid),
        "wall_s": time.perf_counter() - t0,
        "load": os.getloadavg()[0],
    }
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("woven", help="periodic FEM K of the 30 um woven cell")
    w.add_argument("--voxel", type=float, default=1e-6, help="spec grid, m")
    w.add_argument("--step", type=float, default=2e-6, help="lattice step, m")
    w.add_argument("--direction", default="z")
    w.add_argument("--no-error-estimate", action="store_true")
    w.add_argument("--spec-grid", action="store_true", help="mesh the spec grid (old behaviour)")
    args = p.parse_args(argv)
    print(json.dumps(woven(args), default=str), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
