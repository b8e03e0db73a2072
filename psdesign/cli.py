"""The ``psdesign`` command."""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence

from .errors import SpecError


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(2, f"psdesign: error: {message}\n")


def _cmd_generate(args: argparse.Namespace) -> int:
    from .generate import write_generate_outputs
    from .spec import load_spec

    spec = load_spec(args.spec)
    summary = write_generate_outputs(spec, args.output, preview=not args.no_preview)
    print(json.dumps({k: summary[k] for k in ("porosity", "n_fibers",
                                             "intersection_volume_fraction")}))
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = _Parser(prog="psdesign", description="Design fibrous porous media with "
                     "generalized periodic-surface models.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    gen = sub.add_parser("generate", help="build an RVE and write rve.json, summary.json, "
                         "field.vti, fibers.stl, preview.png")
    gen.add_argument("spec", help="RVE spec (TOML)")
    gen.add_argument("-o", "--output", required=True, help="output folder")
    gen.add_argument("--no-preview", action="store_true", help="skip preview.png")
    gen.set_defaults(func=_cmd_generate)

    for module, hook in (("psdesign.flowcli", "add_flow_subcommands"),
                         ("psdesign.study.cli", "add_study_subcommands"),
                         ("psdesign.forcefield.cli", "add_forcefield_subcommand")):
        try:
            mod = __import__(module, fromlist=[hook])
        except ImportError:
            continue
        getattr(mod, hook)(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except SpecError as exc:
        print(f"psdesign: error: {exc}", file=sys.stderr)
        return 2
    except ValueError as exc:  # bad input found past the spec (geometry, mesh, arguments)
        if os.environ.get("PSDESIGN_DEBUG"):
            raise
        print(f"psdesign: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("psdesign: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
