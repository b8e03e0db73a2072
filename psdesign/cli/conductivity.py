"""``psdesign conductivity``: effective conductivity of the fibre / pore medium."""

from __future__ import annotations

import argparse
import time

from psdesign.cli.laplace_report import combine, emit


def _cmd(args: argparse.Namespace) -> int:
    from psdesign.cli.laplace_report import laplace_progress
    from psdesign.fields import fields_folder
    from psdesign.schema.transport import check_conductivity
    from psdesign.transport.conductivity import effective_conductivity, result_line
    from psdesign.transport.effective import tensor_parts
    from psdesign.transport.load import load_case

    solid = None if args.solid is None else check_conductivity(args.solid, "--solid")
    fluid = None if args.fluid is None else check_conductivity(args.fluid, "--fluid")
    _check_insulating(args)
    t0 = time.perf_counter()
    dirs = ["x", "y", "z"] if args.direction == "all" else [args.direction]
    with fields_folder(args.fields, "conductivity", dirs) as writer:
        given = {"bc": args.bc, "insulating_phase": args.insulating, "conductivity_unit": args.unit}
        flags = {"bc": "--bc", "insulating_phase": "--insulating", "conductivity_unit": "--unit"}
        case = load_case(args.spec, given, flags)
        tr = dict(case.transport)
        results = [
            effective_conductivity(
                case.fields,
                d,
                solid,
                fluid,
                tr,
                progress=laplace_progress(args, d),
                capture=writer,
                cells_per_diameter=case.cells_per_diameter,
                resolution_measure=case.resolution_measure,
            ).to_dict()
            for d in dirs
        ]
    out = combine(results, tr["bc"], ("effective_conductivity",))
    out["conductivity_unit"] = results[0]["conductivity_unit"]
    if len(results) > 1 and tr["bc"] == "periodic":  # tensor, symmetric part, eigenvalues
        out.update(tensor_parts([r["conductivity_column"] for r in results]))
    out["wall_time_s"] = time.perf_counter() - t0
    return emit("conductivity", out, results, args.json, result_line)


def _check_insulating(args: argparse.Namespace) -> None:
    """Refuse ``--solid`` / ``--fluid`` for the phase made a perfect insulator (conductivity
    0) by ``--insulating`` or, without it, by the spec's ``transport.insulating_phase``: the
    value would be ignored. Before any work (the spec's table is read, nothing built)."""
    from pathlib import Path

    from psdesign.errors import SpecError
    from psdesign.schema.spec import read_toml
    from psdesign.schema.transport import validate_transport

    given = [f for f, v in (("solid", args.solid), ("fluid", args.fluid)) if v is not None]
    if not given:
        return
    if args.insulating is not None:
        phase, where = args.insulating, f"--insulating {args.insulating}"
    else:
        phase = validate_transport(read_toml(Path(args.spec)))["insulating_phase"]
        where = f'the spec\'s transport.insulating_phase = "{phase}"'
    if phase in given:
        raise SpecError(
            f"--{phase}",
            f"{where} makes the {phase} a perfect insulator (conductivity 0), so --{phase} "
            f"would be ignored; give one of them (--insulating none to use --{phase})",
        )


def register(sub: argparse._SubParsersAction) -> None:
    """Register ``conductivity``."""
    p = sub.add_parser("conductivity", help="effective thermal / electrical conductivity")
    p.add_argument(
        "spec", help="RVE spec (TOML): [rve] + fibers / [generator], or an [image] table"
    )
    p.add_argument(
        "--direction",
        choices=("x", "y", "z", "all"),
        default="z",
        help="direction of the applied gradient (default z)",
    )
    # the range is schema.transport.CONDUCTIVITY_RANGE, written out: importing the schema
    # (pydantic) to build the parser cost every command ~0.1 s (tests/cli: the help says it)
    p.add_argument(
        "--solid",
        type=float,
        default=None,
        help="solid (fibre) conductivity in --unit, in [1e-300, 1e12) (default: the "
        "spec's transport.solid_conductivity, 120)",
    )
    p.add_argument(
        "--fluid",
        type=float,
        default=None,
        help="fluid (pore) conductivity in --unit, in [1e-300, 1e12) (default: the "
        "spec's transport.fluid_conductivity, 0.026)",
    )
    p.add_argument(
        "--unit",
        choices=("W/(m K)", "S/m"),
        default=None,
        help="unit of --solid / --fluid and of the result (default: the spec's "
        "transport.conductivity_unit, W/(m K))",
    )
    p.add_argument(
        "--insulating",
        choices=("none", "solid", "fluid"),
        default=None,
        help="treat one phase as a perfect insulator (conductivity 0; its --solid / "
        "--fluid is then refused; default: the spec's transport.insulating_phase, none)",
    )
    p.add_argument(
        "--bc",
        choices=("periodic", "permeameter"),
        default=None,
        help="periodic (homogenized tensor) or fixed inlet/outlet with insulated sides "
        "(default: the spec's transport.bc, periodic)",
    )
    p.add_argument(
        "--fields",
        metavar="OUT/",
        default=None,
        help="write the potential and flux fields (VTI on the voxel grid), a PNG "
        "slice and fields.json into this folder",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(func=_cmd)
