"""Helpers shared by the CLI commands: progress lines on stderr, the ``--force`` option."""

from __future__ import annotations

import sys
import time


def progress_printer(
    direction: str, every_s: float = 5.0, solve: str = "voxel solve", method: str = "MINRES"
):
    """Progress callback ``report(iterations, residual)`` of an iterative solve: one line on
    stderr at most every ``every_s`` (``psdesign: voxel solve z: 40 MINRES iterations, ...``)."""
    t0 = time.perf_counter()
    last = [t0]

    def report(iterations: int, residual: float) -> None:
        now = time.perf_counter()
        if now - last[0] >= every_s:
            last[0] = now
            print(
                f"psdesign: {solve} {direction}: {iterations} {method} iterations, "
                f"residual {residual:.1e}, {now - t0:.0f} s",
                file=sys.stderr,
                flush=True,
            )

    return report


def laplace_progress(args, direction: str):
    """Progress lines of a Laplace (CG) solve on stderr; None with ``--quiet``."""
    return None if args.quiet else progress_printer(direction, solve="Laplace solve", method="CG")


FORCE_HELP = (
    "write into a non-empty folder psdesign did not create; files psdesign did not write are "
    "still never replaced, and / and the home folder are always refused"
)


def add_force_argument(parser) -> None:
    """Add ``--force`` (see :mod:`psdesign.io.outputs`) to a sub-command parser."""
    parser.add_argument("--force", action="store_true", help=FORCE_HELP)
