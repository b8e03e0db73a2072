"""``psdesign pores``: pore sizes, intrusion curve, specific surface, profiles, orientation."""

from __future__ import annotations

import argparse
import time

from psdesign.cli.exit_status import status_code
from psdesign.cli.lines import print_json


def _cmd(args: argparse.Namespace) -> int:
    from psdesign.geometry.porosity import porosity_text
    from psdesign.io.newfile import check_new_file, write_new_file
    from psdesign.lines import error_bar, rating
    from psdesign.progress import warning
    from psdesign.transport.load import load_case
    from psdesign.transport.study_outputs import pore_report

    t0 = time.perf_counter()
    plot = None if args.plot is None else check_new_file(args.plot, "--plot", ".png")
    case = load_case(
        args.spec,
        {"n_radii": args.n_radii, "thickness_axis": args.axis},
        {"n_radii": "--n-radii", "thickness_axis": "--axis"},
    )
    out = pore_report(case.rve, case.fields, case.transport)
    out["wall_time_s"] = time.perf_counter() - t0
    if plot is not None:
        from psdesign.report.transport import pore_figure

        out["plot"] = str(write_new_file(plot, "--plot", lambda tmp: pore_figure(out, tmp)))
    for w in out["warnings"]:
        warning(w)
    if args.json:
        print_json(out)  # strict JSON: NaN as null (cli.lines)
    else:
        print(_sizes_line(out))
        print(
            f"specific surface {out['specific_surface_m-1']:.4e} 1/m"
            f"{error_bar(out['specific_surface_rel_error'])}  "
            f"{rating({'status': out['specific_surface_status'], 'converged': True})}  "
            f"porosity {porosity_text(out['porosity'], out.get('porosity_error'))}"
        )
    # 3 when the pore sizes, the breakthrough or S_v are not ok (``status``: the worst); it exited 0
    # with both untrustworthy until session 45
    return status_code(out["status"])


def _sizes_line(out: dict) -> str:
    """The pore sizes' line: the three diameters and the breakthrough diameter (one scan, one
    bar: ``diameter_error_m`` above, the radius step plus the centre offset: the scan
    measures low; ``diameter_error_below_m`` below, 0 when every face repeats, else down to the
    scan with walls past the faces that do not, :func:`psdesign.transport.pores.walled`; the
    breakthrough there with its own lower side, :func:`_breakthrough_text`), the rating, the
    scan step."""
    from psdesign.lines import rating
    from psdesign.transport.effective import worst_status
    from psdesign.transport.pores import diameter_bar_text

    converged = bool(out.get("converged", True))
    # the line's numbers rated together: a blocked breakthrough says so in the [status] too
    status = worst_status([out["pore_sizes_status"], out["breakthrough_status"]])
    below = float(out.get("diameter_error_below_m", 0.0))
    bt_text, each = _breakthrough_text(out)
    walled = ""
    if out.get("walled_axes"):  # each value's own lower end: the scan with those faces walled
        d10, d50, d90 = out["walled_d10_d50_d90_m"]
        low = out["breakthrough_diameter_walled_m"]
        walled = (
            f"  (walled at {out['walled_axes']}: d10 {d10:.3e} m  d50 {d50:.3e} m  "
            f"d90 {d90:.3e} m  breakthrough {'none' if low is None else f'{low:.3e} m'})"
        )
    return (
        f"pore diameter d10 {out['pore_d10_m']:.3e} m  d50 {out['pore_d50_m']:.3e} m  "
        f"d90 {out['pore_d90_m']:.3e} m  breakthrough {bt_text}, "
        f"{each} {diameter_bar_text(out['diameter_error_m'], below)} m  "
        f"{rating({'status': status, 'converged': converged})}  "
        f"(scan step {out['bin_width_m']:.1e} m){walled}"
    )


def _breakthrough_text(out: dict) -> tuple[str, str]:
    """The breakthrough diameter as the sizes line prints it, and the words before the shared
    bar (``"each"``: the breakthrough's too). Where a face does not repeat the breakthrough has
    its own lower side, down to the walled scan's (``breakthrough_diameter_walled_m``; 0, no
    path, when the walls close every one), printed beside it, and the shared bar is said of
    d10-d90 alone: ``diameter_error_below_m`` is their gap, which the breakthrough's may
    exceed (session 54 review: 6.565e-06 m walled 2.0e-06 m, beside d10-d90's -3.0e-06)."""
    from psdesign.transport.pores import diameter_bar_text

    bt = out["breakthrough_diameter_m"]
    if bt is None and out.get("pore_space_crosses", False):  # narrower than the smallest ball
        return f"< {out['intrusion_diameter_m'][-1]:.3e} m (unresolved)", "each"
    if bt is None:  # no path crosses the sample (blocked; it printed 0 or a size, [ok])
        return f"none (no intrusion path along {out['thickness_axis']}: blocked)", "each"
    if not out.get("walled_axes"):
        return f"{bt:.3e} m", "each"
    low = out.get("breakthrough_diameter_walled_m") or 0.0
    bar = diameter_bar_text(out["diameter_error_m"], max(0.0, bt - low))
    return f"{bt:.3e} m {bar} m", "d10-d90 each"


def register(sub: argparse._SubParsersAction) -> None:
    """Register ``pores``."""
    p = sub.add_parser("pores", help="pore size distribution, intrusion, surface, orientation")
    p.add_argument(
        "spec", help="RVE spec (TOML): [rve] + fibers / [generator], or an [image] table"
    )
    p.add_argument(
        "--n-radii",
        type=int,
        default=None,
        help="radii of the scan (transport.n_radii, 4-200, default 16)",
    )
    p.add_argument(
        "--axis",
        choices=("x", "y", "z"),
        default=None,
        help="through-plane axis (transport.thickness_axis, default z)",
    )
    p.add_argument(
        "--plot",
        default=None,
        help="write the size / intrusion plot to this new PNG file (an existing path is "
        "refused: psdesign never overwrites a file it may not have written)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(func=_cmd)
