"""The ``psdesign`` command: one module per sub-command, registered by :mod:`psdesign.cli.main`."""

from psdesign.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
