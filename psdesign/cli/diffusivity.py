"""``psdesign diffusivity``: relative diffusivity and tortuosity factor of the pore space."""

from __future__ import annotations

import argparse
import time

from psdesign.cli.laplace_report import combine, emit


def _solve(args: argparse.Namespace, case, tr: dict, dirs: list[str], writer):
    from psdesign.cli.progress import laplace_progress
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


def result_line(r: dict) -> str:
    """The printed line of one diffusivity result dict (``to_dict()``; its ``__str__``)."""
    from psdesign.cli.lines import error_bar, rating, value_text
    from psdesign.geometry.porosity import porosity_text

    tau = r["tortuosity_factor"]  # porosity / D: a count over D, so D's relative bar
    tau_text = tortuosity_undefined(r) if tau is None else f"{tau:.4f}{error_bar(r['rel_error'])}"
    return (
        f"{value_text('diffusivity', r['direction'], r)}  {rating(r)}  tortuosity factor "
        f"{tau_text}  porosity {porosity_text(r['porosity'], r.get('porosity_error'))}"
    )


def tortuosity_undefined(r: dict) -> str:
    """The words for a tortuosity factor with no value (JSON ``null``, porosity / 0), with the
    status it shares with D_eff/D: the text line and the notebook printed a bare ``inf`` /
    ``n/a`` until session 51.

    >>> tortuosity_undefined({"blocked": True, "direction": "x", "status": "blocked"})
    'undefined (no pore path along x) [blocked]'
    >>> tortuosity_undefined({"blocked": False, "direction": "z", "status": "untrustworthy"})
    'undefined (D_eff/D = 0) [untrustworthy]'
    """
    why = f"no pore path along {r['direction']}" if r.get("blocked") else "D_eff/D = 0"
    return f"undefined ({why}) [{r['status']}]"


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
