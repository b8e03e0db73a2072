"""``psdesign permeability``: permeability by Darcy's law from a Stokes solve, with its
boundary-condition model, error bar and status."""

from __future__ import annotations

import argparse
import contextlib
import time
import warnings
from collections.abc import Iterator
from typing import TYPE_CHECKING

from psdesign.cli.exit_status import status_code
from psdesign.cli.lines import print_json
from psdesign.progress import progress_printer, warning

if TYPE_CHECKING:
    from psdesign.geometry.rve import VoxelFields


def _first_solve_flow(flow: dict, args: argparse.Namespace) -> dict:
    """The flow table of the command's first solve, which the up-front no-path check reads:
    ``--bc both`` solves the permeameter's grid first
    (:func:`psdesign.flow.compare.permeability_both_bc`)."""
    return {**flow, "bc": "permeameter"} if args.bc == "both" else flow


def _solve(rve, fields, direction: str, flow: dict, args: argparse.Namespace, solver: str, capture):
    from psdesign.flow.compare import permeability_both_bc
    from psdesign.flow.permeability import permeability

    progress = None if args.quiet else progress_printer(direction)
    estimate = False if args.no_error_estimate else None
    if args.bc == "both":
        return permeability_both_bc(rve, fields, direction, flow, solver, progress, estimate)
    return permeability(rve, fields, direction, flow, solver, progress, estimate, capture)


def _solve_each(rve, fields, directions: list[str], flow: dict, args, solver: str, writer):
    """Every direction's result; on Ctrl-C the finished ones are printed (their lines, or the
    JSON with ``"interrupted": true``) before the interrupt goes on to exit 130 and remove the
    ``--fields`` staging folder: ``--direction all`` printed its lines only after the last solve,
    so a Ctrl-C during K_y lost a finished K_x silently (session 52 walk-mesh finding 3)."""
    results: list[dict] = []
    try:
        for d in directions:
            results.append(_solve(rve, fields, d, flow, args, solver, writer))
    except KeyboardInterrupt:
        if results:
            _print_finished(results, directions, solver, fields, args)
        raise
    return results


def _print_finished(results: list[dict], directions: list[str], solver: str, fields, args):
    """The results of an interrupted ``--direction all`` (:func:`_solve_each`)."""
    done = [r["direction"] for r in results]
    missing = [d for d in directions if d not in done]
    for w in dict.fromkeys(w for r in results for w in r.get("warnings", [])):
        warning(w)
    warning(f"interrupted: K_{', K_'.join(missing)} not solved; the finished directions follow")
    if args.json:
        out = _combine(results, solver, fields)
        out.update(interrupted=True, unsolved_directions=missing, overall_status="interrupted")
        print_json(out)
    else:
        for r in results:
            print(_line(r), flush=True)


def _combine(results: list[dict], solver: str, fields: VoxelFields) -> dict:
    import numpy as np

    from psdesign.transport.effective import worst_status

    out = {
        "direction": "all",
        "solver": solver,
        "porosity": fields.porosity,
        "porosity_error": fields.porosity_error,
        "results": results,
        "bc": results[0]["bc"],
        "converged": all(r["converged"] for r in results),
        "flux_imbalance": max(r["flux_imbalance"] for r in results),
        "status": worst_status([r.get("status") for r in results]),
        "warnings": [w for r in results for w in r.get("warnings", [])],
    }
    for key in ("permeability_m2", "permeability_rel_error"):
        out[key] = {r["direction"]: r.get(key) for r in results}
    if all("permeability_column_m2" in r for r in results):
        out["tensor_m2"] = np.column_stack([r["permeability_column_m2"] for r in results]).tolist()
        out["n_cells"] = results[0].get("n_cells")
    if all("n_dofs" in r for r in results):
        out["n_dofs"] = sum(r["n_dofs"] for r in results)
    if all("bc_sensitivity" in r for r in results):
        out["bc_sensitivity"] = {r["direction"]: r["bc_sensitivity"] for r in results}
    return out


def _line(r: dict) -> str:
    from psdesign.geometry.porosity import porosity_text
    from psdesign.lines import rating, value_text

    sens = r.get("bc_sensitivity")
    extra = f"  bc_sensitivity {100 * sens:.1f} %" if sens is not None else ""
    return (
        f"{value_text('permeability', r['direction'], r)}  {rating(r)}  porosity "
        f"{porosity_text(r['porosity'], r.get('porosity_error'))}  solver {r['solver']}  "
        f"flux imbalance {r['flux_imbalance']:.2e}{extra}{_other_bc(r)}"
    )


def _other_bc(r: dict) -> str:
    """``--bc both``: the other model's K with its bar and rating, which the line compares
    (until session 45 only ``--json`` had it), or why it is missing; "" otherwise. The K is
    spelled as the line's own (:func:`~psdesign.lines.value_text`; until session 50
    ``K = ...`` without its direction, a format of its own).

    >>> other = {"permeability_m2": 2e-11, "permeability_rel_error": 0.02, "status": "ok",
    ...          "bc": "permeameter", "converged": True, "solver": "voxel"}
    >>> r = {"bc": "periodic", "solver": "voxel", "direction": "z",
    ...      "bc_results": {"permeameter": other}}
    >>> _other_bc(r)
    '  (against K_z = 2.0000e-11 m^2 +- 2.0 %  [ok]  bc permeameter  converged true)'
    """
    from psdesign.lines import rating, value_text

    others = {bc: o for bc, o in (r.get("bc_results") or {}).items() if bc != r.get("bc")}
    parts = []
    for bc, o in others.items():
        if not isinstance(o, dict) or o.get("permeability_m2") is None:
            parts.append(f"bc {bc}: {o}")  # "n/a: <why>"
            continue
        route = "" if o.get("solver") in (None, r.get("solver")) else f"  solver {o['solver']}"
        k = value_text("permeability", r["direction"], o)
        parts.append(f"against {k}  {rating(o)}{route}")
    return "".join(f"  ({p})" for p in parts)


def _fields_folder(args: argparse.Namespace, directions: list[str], solver: str):
    """The ``--fields`` writer (checked now, before any solve), or a null context."""
    from psdesign.errors import SpecError
    from psdesign.fields import fields_folder

    if args.fields and args.bc == "both":
        raise SpecError("--fields", "not with --bc both; give --bc permeameter or periodic")
    return fields_folder(args.fields, "permeability", directions, solver)


def _check_wall(spec: dict, flow: dict, solver: str, args: argparse.Namespace) -> None:
    """What the diffuse wall cannot do, refused before any work: ``--bc permeameter|both`` and
    ``--fields`` (the assembled solve keeps no pressure field); when ``--solver voxel``
    overrides a spec written for the FEM, :func:`_check_overrides` applies the spec's own
    diffuse-wall checks."""
    from psdesign.errors import SpecError

    if solver != "voxel" or flow.get("wall_treatment") != "diffuse":
        return
    if args.bc in ("permeameter", "both"):
        raise SpecError(
            "--bc",
            f"{args.bc!r} with flow.wall_treatment = 'diffuse' (periodic only); allowed: periodic",
        )
    if args.fields:
        raise SpecError(
            "--fields",
            "not with flow.wall_treatment = 'diffuse' (its assembled solve keeps no pressure "
            "field); allowed: wall_treatment 'subvoxel' or no --fields",
        )


def _check_overrides(
    spec: dict, flow: dict, solver: str, args: argparse.Namespace, directions: list[str]
) -> None:
    """The spec validated again with the command line's solver, bc and sides, and each of
    ``directions``, before the RVE is built: the memory budget and the route's own checks
    depend on them (``--solver voxel`` on a spec written for the FEM skipped the voxel solver's
    budget, and a 15 GiB solve started building; the two copies an ``"auto"`` permeameter of a
    periodic RVE stacks were refused once it was built, session 43)."""
    from psdesign.schema.spec import check_directions, check_flow_override

    bcs = ["permeameter", "periodic"] if args.bc == "both" else [flow.get("bc")]
    for bc in bcs:
        table = {**flow, "solver": solver}
        if bc is not None:
            table["bc"] = bc
        check_flow_override(spec, table)
        check_directions(spec, table, directions)


def _check_route(flow: dict, solver: str, args: argparse.Namespace) -> None:
    """What the chosen solver and bc would not apply, refused before the RVE is built:
    ``--sides`` on a periodic solve (no side walls), ``flow.periodic_treatment`` mirror /
    frame off the voxel periodic solve (:func:`psdesign.flow.permeability.check_route_keys`)."""
    from psdesign.errors import SpecError
    from psdesign.flow.permeability import NATIVE_BC, check_route_keys

    bcs = (
        ["permeameter", "periodic"] if args.bc == "both" else [flow.get("bc") or NATIVE_BC[solver]]
    )
    if args.sides and bcs == ["periodic"]:
        raise SpecError(
            "--sides",
            f"the periodic bc (solver {solver!r}) has no side walls; give --bc permeameter "
            "or --bc both, or no --sides",
        )
    for bc in bcs:
        check_route_keys(flow, solver, bc)


@contextlib.contextmanager
def _result_says_resolution() -> Iterator[None]:
    """The voxel route's ``ResolutionWarning`` silenced: each result's own line ("K_z: only
    7.0 voxels across the thinnest fiber diameter (< 8); refine rve.voxel", printed below)
    says it under the same condition, and the command printed both (session 42)."""
    from psdesign.flow.voxel import ResolutionWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResolutionWarning)
        yield


def _cmd_permeability(args: argparse.Namespace) -> int:
    from psdesign.flow.darcy import flow_direction
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = load_spec(args.spec, {"solver": args.solver})  # the chosen route's checks
    flow = dict(spec["flow"])
    if args.sides:
        flow["sides"] = args.sides
    if args.bc in ("permeameter", "periodic"):
        flow["bc"] = args.bc
    solver = args.solver or flow["solver"]
    _check_wall(spec, flow, solver, args)
    _check_route(flow, solver, args)
    direction = flow_direction(args.direction, flow)
    directions = ["x", "y", "z"] if direction == "all" else [direction]
    _check_overrides(spec, flow, solver, args, directions)
    t0 = time.perf_counter()
    with _fields_folder(args, directions, solver) as writer, _result_says_resolution():
        built = build_rve(spec)
        rve = built.rve
        fields = built.voxelize(spec["rve"]["voxel"])
        if solver == "voxel":  # a grid without a path: its one line, before any estimate
            from psdesign.flow.voxel import refuse_without_path

            for d in directions:
                refuse_without_path(fields, d, _first_solve_flow(flow, args), rve)
        results = _solve_each(rve, fields, directions, flow, args, solver, writer)
    out = results[0] if len(results) == 1 else _combine(results, solver, fields)
    out["overall_status"] = overall_status(results)
    out["wall_time_s"] = time.perf_counter() - t0
    for w in dict.fromkeys(out.get("warnings", [])):
        warning(w)
    if args.json:
        print_json(out)  # strict JSON: NaN as null (cli.lines)
    else:
        for r in results:
            print(_line(r))
    return status_code(out["overall_status"])  # the JSON's overall_status is what exits


def result_statuses(results: list[dict]) -> list[str | None]:
    """The ``status`` of every printed result: each direction's, and with ``--bc both`` that of
    the other model too (its K is in the JSON and in ``bc_sensitivity``); a model that could
    not be solved (``"n/a: ..."``, said in the warnings) has none.

    >>> result_statuses([{"status": "ok", "bc_results": {"periodic": {"status": "ok"},
    ...                                                 "permeameter": "n/a: no walls"}}])
    ['ok', 'ok']
    """
    out = []
    for r in results:
        out.append(r.get("status"))
        out += [m.get("status") for m in r.get("bc_results", {}).values() if isinstance(m, dict)]
    return out


def overall_status(results: list[dict]) -> str | None:
    """The worst (:func:`~psdesign.transport.effective.worst_status`) of every status the exit
    status reads (:func:`result_statuses`): ``ok`` exactly when the command exits 0. The
    JSON's ``status`` is the K's own (the chosen model's; the worst over the directions with
    ``--direction all``): with ``--bc both`` a script reading it saw ``ok`` beside exit 3 when
    the other model's K was untrustworthy (review s45).

    >>> overall_status([{"status": "ok", "bc_results": {"periodic": {"status": "ok"},
    ...                  "permeameter": {"status": "untrustworthy"}}}])
    'untrustworthy'
    """
    from psdesign.transport.effective import worst_status

    return worst_status(result_statuses(results))


def register(sub: argparse._SubParsersAction) -> None:
    """Register ``permeability``."""
    perm = sub.add_parser("permeability", help="permeability by Darcy's law")
    perm.add_argument(
        "spec", help="RVE spec (TOML): [rve] + fibers / [generator], or an [image] table"
    )
    perm.add_argument(
        "--direction",
        choices=("x", "y", "z", "all"),
        default=None,
        help="flow direction (default: the spec's flow.direction, else z)",
    )
    perm.add_argument(
        "--solver",
        choices=("fem", "voxel"),  # schema.flow.SOLVERS, written out: --help imports no pydantic
        default=None,
        help="fem (tet mesh, Taylor-Hood) or voxel (MAC grid) (default: the spec's flow.solver, "
        "else fem)",
    )
    perm.add_argument(
        "--sides",
        choices=("slip", "noslip"),
        default=None,
        help="side walls of the permeameter, either solver (default: the spec's flow.sides, "
        "slip); refused with the periodic bc, which has none",
    )
    perm.add_argument(
        "--bc",
        choices=("permeameter", "periodic", "both"),
        default=None,
        help="boundary-condition model (default: the spec's flow.bc, else the solver's own: "
        "fem permeameter, voxel periodic); 'both' also reports bc_sensitivity",
    )
    perm.add_argument(
        "--no-error-estimate",
        action="store_true",
        help="skip the second, coarser solve (the error bar is then the resolution floor)",
    )
    perm.add_argument(
        "--fields",
        metavar="OUT/",
        default=None,
        help="write velocity (m/s) and pressure (Pa) fields (VTU on the tet mesh, VTI on the voxel "
        "grid), a PNG slice and fields.json into this folder",
    )
    perm.add_argument("--json", action="store_true", help="print one JSON object")
    perm.add_argument(
        "--quiet",
        action="store_true",
        help="no progress lines on stderr (meshing stages, each solve's time and memory "
        "estimate, solver iterations); warnings and errors are still printed",
    )
    perm.set_defaults(func=_cmd_permeability)
