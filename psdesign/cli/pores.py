"""``psdesign pores``: pore sizes, intrusion curve, specific surface, profiles, orientation."""

from __future__ import annotations

import argparse
import json
import time


def _cmd(args: argparse.Namespace) -> int:
    from psdesign.cli.progress import warning
    from psdesign.geometry.porosity import porosity_text
    from psdesign.io.newfile import check_new_file, write_new_file
    from psdesign.transport.load import load_case
    from psdesign.transport.study_outputs import pore_report

    t0 = time.perf_counter()
    plot = None if args.plot is None else check_new_file(args.plot, "--plot")
    case = load_case(args.spec, {"n_radii": args.n_radii, "thickness_axis": args.axis})
    out = pore_report(case.rve, case.fields, case.transport)
    out["wall_time_s"] = time.perf_counter() - t0
    if plot is not None:
        from psdesign.report.transport import pore_figure

        out["plot"] = str(write_new_file(plot, "--plot", lambda tmp: pore_figure(out, tmp)))
    for w in out["warnings"]:
        warning(w)
    if args.json:
        print(json.dumps(out, default=float))
    else:
        print(
            f"pore diameter d10 {out['pore_d10_m']:.3e} m  d50 {out['pore_d50_m']:.3e} m  "
            f"d90 {out['pore_d90_m']:.3e} m  (step {out['bin_width_m']:.1e} m, rel. error "
            f"{out['rel_error']:.1e})  breakthrough diameter "
            f"{out['breakthrough_diameter_m']:.3e} m  [{out['pore_sizes_status']}]"
            + ("" if out.get("converged", True) else "  (NOT CONVERGED)")
        )
        print(
            f"specific surface {out['specific_surface_m-1']:.4e} 1/m  rel. error "
            f"{out['specific_surface_rel_error']:.1e}  "
            f"porosity {porosity_text(out['porosity'], out.get('porosity_error'))}  "
            f"[{out['specific_surface_status']}]"
        )
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Register ``pores``."""
    p = sub.add_parser("pores", help="pore size distribution, intrusion, surface, orientation")
    p.add_argument("spec")
    p.add_argument(
        "--n-radii",
        type=int,
        default=None,
        help="radii of the scan (transport.n_radii, 4-200, default 16)",
    )
    p.add_argument("--axis", choices=("x", "y", "z"), default=None, help="through-plane axis")
    p.add_argument(
        "--plot",
        default=None,
        help="write the size / intrusion plot to this new PNG file (an existing path is "
        "refused: psdesign never overwrites a file it may not have written)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(func=_cmd)
