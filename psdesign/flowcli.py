"""``psdesign mesh`` and ``psdesign permeability`` subcommands."""

from __future__ import annotations

import argparse
import json
import sys
import time

from .errors import SpecError

MESH_FORMATS = ("vtu", "msh", "fluent", "stl", "openfoam")


def _load(path: str) -> dict:
    from .spec import load_spec

    return load_spec(path)


def _cmd_mesh(args: argparse.Namespace) -> int:
    from .atomic import staged_directory, write_json
    from .generate import build_rve
    from .mesh import export_mesh, mesh_pore_space
    from .permeability import mesher_options

    spec = _load(args.spec)
    flow = dict(spec["flow"])
    for fmt in args.format:
        if fmt not in MESH_FORMATS:
            raise SpecError("--format", f"unknown format {fmt!r}; allowed: "
                            f"{', '.join(MESH_FORMATS)}")
    t0 = time.perf_counter()
    built = build_rve(spec)
    rve = built.rve
    fields = built.voxelize(spec["rve"]["voxel"])
    if args.mesher:
        flow["mesher"] = args.mesher
    pm = mesh_pore_space(fields.distance, float(fields.grid.spacing[0]), rve.size,
                         args.direction, aux_length=float(flow["aux_length"]),
                         **mesher_options(flow))
    with staged_directory(args.output) as tmp:
        files = export_mesh(pm, tmp, formats=tuple(dict.fromkeys(["vtu", *args.format])))
        info = {"direction": args.direction, "porosity": fields.porosity,
                "porous_region_m": list(pm.porous_region), "quality": pm.quality,
                "files": sorted(p.name for p in files.values()),
                "wall_time_s": time.perf_counter() - t0}
        write_json(tmp / "mesh.json", info)
    print(json.dumps({k: info[k] for k in ("direction", "porosity", "wall_time_s")}
                     | {"n_tets": pm.quality.get("n_tets")}))
    return 0


def _progress_printer(direction: str, every_s: float = 5.0):
    """Progress callback of the voxel solver: one line on stderr at most every ``every_s``."""
    t0 = time.perf_counter()
    last = [t0]

    def report(iterations: int, residual: float) -> None:
        now = time.perf_counter()
        if now - last[0] >= every_s:
            last[0] = now
            print(f"psdesign: voxel solve {direction}: {iterations} MINRES iterations, "
                  f"residual {residual:.1e}, {now - t0:.0f} s", file=sys.stderr, flush=True)

    return report


def _cmd_permeability(args: argparse.Namespace) -> int:
    import numpy as np

    from .generate import build_rve
    from .permeability import permeability

    spec = _load(args.spec)
    flow = dict(spec["flow"])
    if args.sides:
        flow["sides"] = args.sides
    solver = args.solver or flow["solver"]
    t0 = time.perf_counter()
    built = build_rve(spec)
    rve = built.rve
    fields = built.voxelize(spec["rve"]["voxel"])
    directions = ["x", "y", "z"] if args.direction == "all" else [args.direction]
    results = [permeability(rve, fields, d, flow, solver=solver,
                            progress=None if args.quiet else _progress_printer(d))
               for d in directions]
    if len(results) == 1:
        out = results[0]
    else:
        out = {"direction": "all", "solver": solver, "porosity": fields.porosity,
               "results": results,
               "permeability_m2": {r["direction"]: r["permeability_m2"] for r in results},
               "converged": all(r["converged"] for r in results),
               "flux_imbalance": max(r["flux_imbalance"] for r in results)}
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
            print(f"K_{r['direction']} = {r['permeability_m2']:.4e} m^2  porosity "
                  f"{r['porosity']:.4f}  solver {r['solver']}  flux imbalance "
                  f"{r['flux_imbalance']:.2e}{flag}")
    return 0 if out["converged"] else 1


def add_flow_subcommands(sub: argparse._SubParsersAction) -> None:
    """Register ``mesh`` and ``permeability``."""
    mesh = sub.add_parser("mesh", help="tetrahedralize the pore space (with auxiliary zones)")
    mesh.add_argument("spec")
    mesh.add_argument("-o", "--output", required=True)
    mesh.add_argument("--direction", choices=("x", "y", "z"), default="z")
    mesh.add_argument("--mesher", choices=("stuffing", "pytetwild"), default=None,
                      help="tet mesher (default: the spec's flow.mesher, stuffing)")
    mesh.add_argument("--format", nargs="*", default=["vtu"], metavar="FMT",
                      help=f"extra formats: {', '.join(MESH_FORMATS)}")
    mesh.set_defaults(func=_cmd_mesh)

    perm = sub.add_parser("permeability", help="permeability by Darcy's law")
    perm.add_argument("spec")
    perm.add_argument("--direction", choices=("x", "y", "z", "all"), default="z")
    perm.add_argument("--solver", choices=("fem", "voxel"), default=None)
    perm.add_argument("--sides", choices=("slip", "noslip"), default=None,
                      help="lateral walls for the fem route (default: the spec's, slip)")
    perm.add_argument("--json", action="store_true", help="print one JSON object")
    perm.add_argument("--quiet", action="store_true",
                      help="no progress lines on stderr during long voxel solves")
    perm.set_defaults(func=_cmd_permeability)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(0)
