"""Stacked permeameter on one-period random RVEs and on arrays (issue 12; docs/permeability.md).

For each case: the periodic K, the permeameter K with one copy (``permeameter_copies = 1``, the
windowed drop over one period) and with the stack (``"auto"``: 2 copies on these periodic
one-period RVEs), and the face-plane-drop K of each permeameter (``K dp_rve / dp_faces``), with
the cost (cells or unknowns, wall time, memory) of each solve.

Cases: the periodic random RVEs of ``tests/validation/test_solver_agreement.py`` (five 8 um
straight fibres along x or y in a 40 um cube, seeded), through-plane (z) and in-plane (x).

    python benchmarks/stacked_permeameter.py random --route voxel --voxel 1e-6 --seeds 1 2 3
    python benchmarks/stacked_permeameter.py random --route fem --voxel 1e-6 --seeds 1 2
    python benchmarks/stacked_permeameter.py arrays
    python benchmarks/stacked_permeameter.py summary A.json B.json   # the docs table

Prints one markdown row per solve; ``--json FILE`` also writes the rows.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "tests" / "validation")]

MU = 1.8e-5
#: The permeameter solves of a random case: one copy, the stack ("auto": 2), and 3 copies (the
#: windowed K must not move from 2 to 3 copies if two periods make the window exact).
PERMEAMETERS = (("permeameter 1 copy", 1), ("permeameter auto", "auto"), ("permeameter 3", 3))


def _solve(rve, fields, direction: str, flow: dict, route: str) -> dict:
    from psdesign.flow.permeability import route_result

    t0 = time.perf_counter()
    res = route_result(rve, fields, direction, flow, route)
    res["bench_wall_s"] = time.perf_counter() - t0
    return res


def _row(case: str, route: str, label: str, res: dict, k_per: float | None) -> dict:
    k = float(res["permeability_m2"])
    row = {
        "case": case,
        "route": route,
        "solve": label,
        "k_m2": k,
        "vs_periodic": (k / k_per - 1.0) if k_per else None,
        "copies": res.get("permeameter_copies"),
        "size": res.get("n_cells") or res.get("n_dofs"),
        "wall_s": res["bench_wall_s"],
        "peak_gb": res.get("peak_memory_gb"),
        "converged": res.get("converged"),
    }
    if res.get("pressure_drop_faces_pa"):
        kf = k * res["pressure_drop_rve_pa"] / res["pressure_drop_faces_pa"]
        row["k_faces_m2"] = kf
        row["faces_vs_periodic"] = (kf / k_per - 1.0) if k_per else None
        row["definition_spread"] = abs(
            res["pressure_drop_rve_pa"] / res["pressure_drop_faces_pa"] - 1
        )
    return row


def _print(row: dict) -> None:
    def pct(v):
        return "" if v is None else f"{100 * v:+.2f} %"

    print(
        f"| {row['case']} | {row['route']} | {row['solve']} | {row['k_m2']:.4e} | "
        f"{pct(row['vs_periodic'])} | {row.get('k_faces_m2', float('nan')):.4e} | "
        f"{pct(row.get('faces_vs_periodic'))} | {row['copies'] or ''} | {row['size']} | "
        f"{row['wall_s']:.1f} | {row['peak_gb'] or ''} |",
        flush=True,
    )


def periodic_sides() -> None:
    """Diagnostic only (``--lateral periodic``): the voxel permeameter's lateral faces become
    periodic seams instead of slip walls (the operator is built without box walls), so the
    permeameter and the periodic BC differ only by the reservoirs and the pressure-drop
    definition; the route still reports ``sides = "slip"``."""
    import solvers.voxel_stokes as vs

    build = vs._Stokes.build.__func__

    def no_walls(cls, solid, phi=None, walls=None, d=0, rve=None, **kw):
        return build(cls, solid, phi, {}, d, rve, **kw)

    vs._Stokes.build = classmethod(no_walls)


def random_cases(args) -> list[dict]:
    from test_solver_agreement import periodic_spec

    from psdesign.packing.build import build_rve

    rows = []
    for seed in args.seeds:
        spec = periodic_spec("straight", seed=seed, voxel=args.voxel)
        built = build_rve(spec)
        fields = built.voxelize(args.voxel)
        for d in args.directions:
            case = f"random straight seed {seed} {d} {args.voxel * 1e6:g} um"
            if args.lateral == "periodic":
                case += " periodic sides"
            base = {"viscosity": MU, "aux_length": 0.2, "sides": "slip"}
            per = _solve(built.rve, fields, d, {**base, "bc": "periodic"}, args.route)
            k_per = float(per["permeability_m2"])
            rows.append(_row(case, args.route, "periodic", per, None))
            _print(rows[-1])
            for label, copies in PERMEAMETERS:
                if str(copies) not in args.copies:
                    continue
                flow = {**base, "bc": "permeameter", "permeameter_copies": copies}
                res = _solve(built.rve, fields, d, flow, args.route)
                rows.append(_row(case, args.route, label, res, k_per))
                _print(rows[-1])
    return rows


def array_cases(args) -> list[dict]:
    """Square and hexagonal arrays, 1-5 cells along and across, voxel route: the permeameter
    (auto copies) against the periodic K of one cell on the same grid."""
    from arrays import array_spec

    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    rows = []
    for kind, n in (("square", 24), ("hex", 26)):
        for phi in (0.1, 0.3):
            for flow_dir in ("across", "along"):
                d = "x" if flow_dir == "across" else "z"
                one = validate_spec(array_spec(kind, phi, n, n_cells=1))
                b1 = build_rve(one)
                f1 = b1.voxelize(one["rve"]["voxel"])
                per = _solve(b1.rve, f1, d, {**one["flow"], "bc": "periodic"}, "voxel")
                k_per = float(per["permeability_m2"])
                for cells in (1, 2, 3, 4, 5) if flow_dir == "across" else (1,):
                    spec = validate_spec(array_spec(kind, phi, n, n_cells=cells))
                    b = build_rve(spec)
                    f = b.voxelize(spec["rve"]["voxel"])
                    flow = {**spec["flow"], "bc": "permeameter"}
                    res = _solve(b.rve, f, d, flow, "voxel")
                    case = f"{kind} phi {phi} {flow_dir} {cells} cells"
                    rows.append(_row(case, "voxel", "permeameter auto", res, k_per))
                    _print(rows[-1])
    return rows


def summary(paths: list[Path]) -> None:
    """One row per random case from ``--json`` files: periodic K, 1 / 2 / 3 copies (windowed,
    relative to periodic), face drop of 2 / 3 copies."""
    cases: dict[str, dict] = {}
    for path in paths:
        for row in json.loads(path.read_text()):
            cases.setdefault(row["case"], {})[row["solve"]] = row

    def pct(r, key="vs_periodic"):
        return "-" if r is None or r.get(key) is None else f"{100 * r[key]:+.2f} %"

    for case, rows in cases.items():
        per = rows.get("periodic")
        two, three = rows.get("permeameter auto"), rows.get("permeameter 3")
        sides = "periodic" if "periodic sides" in case else "slip"
        name = case.replace(" periodic sides", "").replace("random straight ", "")
        print(
            f"| {name} | {sides} | {per['k_m2']:.3e} | {pct(rows.get('permeameter 1 copy'))} | "
            f"{pct(two)} | {pct(three)} | {pct(two, 'faces_vs_periodic')} / "
            f"{pct(three, 'faces_vs_periodic')} |"
        )


def main(argv: list[str] | None = None) -> int:
    if argv is None:
        argv = sys.argv[1:]
    if argv and argv[0] == "summary":
        summary([Path(a) for a in argv[1:]])
        return 0
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("random", "arrays"))
    ap.add_argument("--route", choices=("voxel", "fem"), default="voxel")
    ap.add_argument("--voxel", type=float, default=1e-6)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--directions", nargs="+", default=["z", "x"])
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--copies", nargs="+", default=["1", "auto", "3"], help="permeameters run")
    ap.add_argument(
        "--lateral",
        choices=("slip", "periodic"),
        default="slip",
        help="voxel route: 'periodic' replaces the slip side walls by periodic seams "
        "(diagnostic: separates the side walls' effect from the definition's)",
    )
    args = ap.parse_args(argv)
    if args.lateral == "periodic":
        if args.route != "voxel":
            ap.error("--lateral periodic: voxel route only")
        periodic_sides()
    print(
        "| case | route | solve | K (m^2) | vs periodic | K faces (m^2) | faces vs periodic | "
        "copies | cells / dofs | wall (s) | peak GB |\n|" + "---|" * 11
    )
    rows = random_cases(args) if args.what == "random" else array_cases(args)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
