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
    warning = stop_warning(summary)
    if warning:  # on stderr: stdout stays one JSON object
        progress.warning(warning)
    # a constrained optimum (at_bound) is a result; a search stopped early (not_converged) or
    # one that left an overlap (contact_left, 0 until session 45) is written but exits 3
    return status_code(summary["status"])


def stop_warning(summary: dict) -> str | None:
    """The warning of a run that did not converge cleanly, or None.

    Parameters
    ----------
    summary : dict
        ``run_forcefield``'s summary (``status``, ``at_bound``, ``at_breaking_wall``, ...).

    Returns
    -------
    str or None
        One line naming where the search stopped; a range to widen only for variables on a
        box bound (a variable against the fiber-breaking wall is inside its range: no range
        moves the wall; mendff2, session 53).
    """
    status, on = summary["status"], summary["at_bound"]
    where, advice = _stop_places(summary)
    if status == "not_converged":
        at = f" (on {where})" if on else ""
        return f"{summary['message']}, not converged; wrote the best point found{at}"
    if status == "contact_left":
        at = (
            f"; the moves stop on the bound of {', '.join(on)}: widen forcefield.relax.max_shift"
            " or u_max"
            if on
            else ""
        )
        return f"the fibers still overlap (contact_left{at}); wrote the best point"
    if status == "untrustworthy":  # the bar's coarser quadrature broke a fiber
        at = f" (on {where})" if on else ""
        return (
            f"U's error bar is unknown{at}: the coarser quadrature of the bar breaks a fiber "
            "at the optimum (on the fiber-breaking wall within the quadrature's resolution); "
            "untrustworthy, wrote the best point found"
        )
    if on:
        return f"optimum on {where} (a constrained stop, not converged); {advice}"
    if not summary["converged"]:
        return f"{summary['message']}; wrote the best point found"
    return None


def _stop_places(summary: dict) -> tuple[str, str]:
    """Where the search stopped ("the bound of kappa1 and on the fiber-breaking wall of mu1")
    and the advice for each kind of stop."""
    from psdesign.forcefield.tube import NECK_DEPTH_FRACTION

    wall = summary.get("at_breaking_wall", [])
    box = [n for n in summary["at_bound"] if n not in wall]
    where, advice = [], []
    if box:
        where.append(f"the bound of {', '.join(box)}")
        advice.append(f"widen the ranges of {', '.join(box)} or read it as such")
    if wall:
        where.append(f"the fiber-breaking wall of {', '.join(wall)}")
        advice.append(
            f"beyond the wall a fiber breaks (a neck thinner than {NECK_DEPTH_FRACTION} of its "
            "median section depth, tube.NECK_DEPTH_FRACTION): no range moves it"
        )
    return " and on ".join(where), "; ".join(advice)


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
