"""``psdesign diffusivity``: relative diffusivity and tortuosity factor of the pore space."""

from __future__ import annotations

import argparse
import time

from psdesign.cli.laplace_report import combine, emit


def _solve(args: argparse.Namespace, case, tr: dict, dirs: list[str], writer):
    from psdesign.cli.laplace_report import laplace_progress
    from psdesign.transport.diffusivity import diffusivity_tensor, relative_diffusivity

    if args.direction == "all" and tr["bc"] == "periodic":
        cpd, measure = case.cells_per_diameter, case.resolution_measure
        out = diffusivity_tensor(case.fields, tr, writer, cpd, measure)
        out["direction"] = "all"
        out["bc"] = "periodic"
        results = out["results"]
    else:
        results = [
            relative_diffusivity(
                case.fields,
                d,
                tr,
                progress=laplace_progress(args, d),
                capture=writer,
                cells_per_diameter=case.cells_per_diameter,
                resolution_measure=case.resolution_measure,
            ).to_dict()
            for d in dirs
        ]
        out = combine(
            results,
            tr["bc"],
            ("relative_diffusivity", "tortuosity_factor"),
        )
    return out, results


def _cmd(args: argparse.Namespace) -> int:
    from psdesign.fields import fields_folder
    from psdesign.transport.diffusivity import result_line
    from psdesign.transport.load import load_case

    t0 = time.perf_counter()
    dirs = ["x", "y", "z"] if args.direction == "all" else [args.direction]
    with fields_folder(args.fields, "diffusivity", dirs) as writer:
        case = load_case(
            args.spec, {"bc": args.bc, "tol": args.tol}, {"bc": "--bc", "tol": "--tol"}
        )
        tr = dict(case.transport)
        out, results = _solve(args, case, tr, dirs, writer)
    out["wall_time_s"] = time.perf_counter() - t0
    return emit("diffusivity", out, results, args.json, result_line)


def register(sub: argparse._SubParsersAction) -> None:
    """Register ``diffusivity``."""
    p = sub.add_parser("diffusivity", help="effective diffusivity and tortuosity of the pores")
    p.add_argument(
        "spec", help="RVE spec (TOML): [rve] + fibers / [generator], or an [image] table"
    )
    p.add_argument(
        "--direction",
        choices=("x", "y", "z", "all"),
        default="z",
        help="direction of the applied gradient (default z)",
    )
    p.add_argument(
        "--bc",
        choices=("periodic", "permeameter"),
        default=None,
        help="periodic (homogenized tensor) or fixed inlet/outlet with insulated sides "
        "(default: the spec's transport.bc, periodic)",
    )
    p.add_argument(
        "--tol",
        type=float,
        default=None,
        help="CG relative residual (transport.tol, in (0, 1), default 1e-8)",
    )
    p.add_argument(
        "--fields",
        metavar="OUT/",
        default=None,
        help="write the concentration and flux fields (VTI on the voxel grid), a PNG "
        "slice and fields.json into this folder",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(func=_cmd)
