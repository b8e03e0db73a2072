"""The ``psdesign`` command."""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import warnings
from collections.abc import Sequence

from psdesign.cli.exit_status import FAILED, INTERRUPTED, TERMINATED, fail
from psdesign.cli.exit_status import HELP as EXIT_HELP
from psdesign.cli.parser import Parser
from psdesign.errors import SpecError, show_warning_one_line
from psdesign.progress import activate

#: Sub-command modules, in ``--help`` order; each has ``register(subparsers)``.
COMMANDS = (
    "generate",
    "mesh",
    "permeability",
    "diffusivity",
    "conductivity",
    "pores",
    "study",
    "rev",
    "forcefield",
    "warmup",
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = Parser(
        prog="psdesign",
        description="Design fibrous porous media with generalized periodic-surface models.",
        epilog=EXIT_HELP,
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)

    for name in COMMANDS:
        importlib.import_module(f"psdesign.cli.{name}").register(sub)
    return parser


def _spec_warnings_once():
    """:func:`~psdesign.errors.show_warning_one_line` that shows each spec warning
    (:class:`~psdesign.schema.document.SpecWarning`) once per command: a command validates its
    spec more than once (on load and again when it builds), and the same line came twice before
    the error it foretold (session 52 walk: ``generate`` of a fast porosity 0.3 spec)."""
    shown: set[str] = set()

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        from psdesign.schema.document import SpecWarning

        if issubclass(category, SpecWarning):
            if str(message) in shown:
                return
            shown.add(str(message))
        show_warning_one_line(message, category, filename, lineno, file, line)

    return show


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    warnings.showwarning = _spec_warnings_once()  # one line per warning, a spec's once
    from psdesign.study.interrupt import terminate_as_interrupt

    try:
        # SIGTERM (kill, timeout, a batch system's cancel) leaves as Ctrl-C does: staged
        # outputs removed, one line, exit 143
        with terminate_as_interrupt(), activate(quiet=bool(getattr(args, "quiet", False))):
            return int(args.func(args) or 0)
    except SpecError as exc:
        return fail(str(exc))
    except (RecursionError, OverflowError) as exc:  # input nested too deeply / numbers too large
        if os.environ.get("PSDESIGN_DEBUG"):
            raise
        return fail(f"input: {type(exc).__name__} (nested too deeply or numbers too large)")
    except ValueError as exc:  # bad input found past the spec (geometry, mesh, arguments)
        if os.environ.get("PSDESIGN_DEBUG"):
            raise
        return fail(str(exc))
    except OSError as exc:  # writing or reading failed past the checks (disk, permissions)
        if os.environ.get("PSDESIGN_DEBUG"):
            raise
        where = f"{exc.filename}: " if exc.filename else ""
        return fail(f"{where}{exc.strerror or exc}", FAILED)
    except KeyboardInterrupt as exc:  # Ctrl-C; SIGTERM (Terminated)
        from psdesign.study.interrupt import Terminated

        term = isinstance(exc, Terminated)
        print(f"psdesign: {'terminated' if term else 'interrupted'}", file=sys.stderr)
        return TERMINATED if term else INTERRUPTED


def console() -> None:
    """The ``psdesign`` process (console script, ``python -m psdesign``): :func:`main`, then
    Ctrl-C ignored while Python shuts down.  The outputs are complete by then; a SIGINT there
    printed "Exception ignored in atexit callback ... KeyboardInterrupt" or ended the process
    by the signal with no message (session 35's failure audit: 4 of ~90 late Ctrl-C)."""
    status = main()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.exit(status)


if __name__ == "__main__":
    console()
