"""``psdesign forcefield SPEC -o OUT``: optimize a fiber assembly with the Sec. 6 force field."""

from __future__ import annotations

import argparse

from psdesign import progress
from psdesign.cli.exit_status import status_code
from psdesign.cli.lines import print_json
from psdesign.cli.options import add_force_argument


def _cmd_forcefield(args: argparse.Namespace) -> int:
    # OUTPUT_FILES: the one list of the command's files, which a rerun replaces (session 52)
    from psdesign.forcefield.run import OUTPUT_FILES, load_forcefield_spec, run_forcefield
    from psdesign.io.outputs import check_output_dir

    # the folder is checked first (like every -o command), then the spec; both before any work
    target = check_output_dir(
        args.output, force=args.force, command="forcefield", expected=OUTPUT_FILES
    )
    from psdesign.schema.budget import unplanned_route

    # no flow solve: an RVE spec is held to its voxel grid's memory, not to its [flow] solve
    with unplanned_route():
        ff = load_forcefield_spec(args.spec)
        summary = run_forcefield(ff, target, pictures=not args.no_pictures)
    keys = ("case", "U", "converged", "status", "at_bound", "message", "n_evals")
    keys += ("wall_time_s", "free_variables")
    print_json(  # strict JSON, as every --json
        {k: summary[k] for k in keys}
        # the error bars (docs/forcefield.md): U's quadrature error and each free
        # variable's +- (paper cases, the rod and the field relax routes)
        | {
            k: summary[k]
            for k in ("at_breaking_wall", "U_error", "free_variables_error")
            if k in summary
        }
    )
    # warnings on stderr: stdout stays one JSON object
    if summary["status"] == "not_converged":
        on = summary["at_bound"]
        where = f" (on the bound of {', '.join(on)})" if on else ""
        progress.warning(f"{summary['message']}, not converged; wrote the best point found{where}")
    elif summary["status"] == "contact_left":
        on = summary["at_bound"]
        where = (
            f"; the moves stop on the bound of {', '.join(on)}: widen forcefield.relax.max_shift"
            " or u_max"
            if on
            else ""
        )
        progress.warning(f"the fibers still overlap (contact_left{where}); wrote the best point")
    elif summary["at_bound"]:
        wall = summary.get("at_breaking_wall", [])
        box = [n for n in summary["at_bound"] if n not in wall]
        where = [f"the bound of {', '.join(box)}"] if box else []
        where += [f"the fiber-breaking wall of {', '.join(wall)}"] if wall else []
        progress.warning(
            f"optimum on {' and on '.join(where)} (a constrained stop, not converged); "
            "widen the ranges or read it as such"
        )
    elif not summary["converged"]:
        progress.warning(f"{summary['message']}; wrote the best point found")
    # a constrained optimum (at_bound) is a result; a search stopped early (not_converged) or
    # one that left an overlap (contact_left, 0 until session 45) is written but exits 3
    return status_code(summary["status"])


def register(subparsers) -> None:
    """Register ``forcefield`` on the ``psdesign`` sub-command parser."""
    p = subparsers.add_parser(
        "forcefield",
        help="bend and compress fibers by minimizing the empirical force field "
        "(paper Sec. 6); the paper's cases write rve.json, history.csv, before.png, after.png; "
        "case = relax writes relaxed.toml, rve.json, summary.json (docs/forcefield.md)",
    )
    p.add_argument(
        "spec",
        help="force-field spec (TOML: a [forcefield] table, case = two-fiber | six-fiber), or an "
        "RVE spec ([rve] with fibers, optional [forcefield.relax] table) whose fibers it relaxes",
    )
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.add_argument("--no-pictures", action="store_true", help="skip before.png / after.png")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    add_force_argument(p)
    p.set_defaults(func=_cmd_forcefield)
