"""``psdesign permeability``: permeability by Darcy's law from a Stokes solve."""

from __future__ import annotations

import argparse
import json
import time

from psdesign.cli.progress import progress_printer


def _cmd_permeability(args: argparse.Namespace) -> int:
    import numpy as np

    from psdesign.flow.permeability import permeability
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = load_spec(args.spec)
    flow = dict(spec["flow"])
    if args.sides:
        flow["sides"] = args.sides
    solver = args.solver or flow["solver"]
    t0 = time.perf_counter()
    built = build_rve(spec)
    rve = built.rve
    fields = built.voxelize(spec["rve"]["voxel"])
    directions = ["x", "y", "z"] if args.direction == "all" else [args.direction]
    results = [
        permeability(
            rve,
            fields,
            d,
            flow,
            solver=solver,
            progress=None if args.quiet else progress_printer(d),
        )
        for d in directions
    ]
    if len(results) == 1:
        out = results[0]
    else:
        out = {
            "direction": "all",
            "solver": solver,
            "porosity": fields.porosity,
            "results": results,
            "permeability_m2": {r["direction"]: r["permeability_m2"] for r in results},
            "converged": all(r["converged"] for r in results),
            "flux_imbalance": max(r["flux_imbalance"] for r in results),
        }
        if solver == "voxel":
            tensor = np.column_stack([r["permeability_column_m2"] for r in results])
            out["tensor_m2"] = tensor.tolist()
            out["n_cells"] = results[0]["n_cells"]
        else:
            out["n_dofs"] = sum(r["n_dofs"] for r in results)
    out["wall_time_s"] = time.perf_counter() - t0
    if args.json:
        print(json.dumps(out, default=float))
    else:
        for r in results:
            flag = "" if r["converged"] else "  (NOT CONVERGED)"
            print(
                f"K_{r['direction']} = {r['permeability_m2']:.4e} m^2  porosity "
                f"{r['porosity']:.4f}  solver {r['solver']}  flux imbalance "
                f"{r['flux_imbalance']:.2e}{flag}"
            )
    return 0 if out["converged"] else 1


def register(sub: argparse._SubParsersAction) -> None:
    """Register ``permeability``."""
    perm = sub.add_parser("permeability", help="permeability by Darcy's law")
    perm.add_argument("spec")
    perm.add_argument("--direction", choices=("x", "y", "z", "all"), default="z")
    perm.add_argument("--solver", choices=("fem", "voxel"), default=None)
    perm.add_argument(
        "--sides",
        choices=("slip", "noslip"),
        default=None,
        help="lateral walls for the fem route (default: the spec's, slip)",
    )
    perm.add_argument("--json", action="store_true", help="print one JSON object")
    perm.add_argument(
        "--quiet", action="store_true", help="no progress lines on stderr during long voxel solves"
    )
    perm.set_defaults(func=_cmd_permeability)
