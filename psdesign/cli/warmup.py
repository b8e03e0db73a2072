"""``psdesign warmup``: compile the numba kernels into the on-disk cache ahead of the first
solve (run once after ``pip install``; see :mod:`psdesign.warmup`)."""

from __future__ import annotations

import argparse
import sys


def _cmd_warmup(args: argparse.Namespace) -> int:
    import numba

    from psdesign.errors import SpecError
    from psdesign.warmup import TASKS, warmup

    if args.jobs is not None and not 1 <= args.jobs <= 64:
        raise SpecError("--jobs", f"processes must be an integer in [1, 64], got {args.jobs}")
    tasks = tuple(args.only) if args.only else TASKS
    if "parallel" in tasks and numba.config.NUMBA_NUM_THREADS < 2:
        tasks = tuple(t for t in tasks if t != "parallel")
        if not args.quiet:
            print(
                "psdesign: warmup: NUMBA_NUM_THREADS=1, the parallel kernels are not compiled "
                "(they are never used with one thread)",
                file=sys.stderr,
            )
    if not args.quiet:
        print(
            f"psdesign: compiling the numba kernels ({', '.join(tasks)}) into the cache; "
            "a few minutes on 2 cores, once per install",
            file=sys.stderr,
            flush=True,
        )
    times = warmup(tasks, jobs=args.jobs)
    if not args.quiet:
        parts = ", ".join(f"{k} {v:.0f} s" for k, v in times.items() if k != "total")
        print(f"psdesign: warmup done in {times['total']:.0f} s ({parts})", file=sys.stderr)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Register ``warmup``."""
    p = sub.add_parser(
        "warmup",
        help="compile the numba kernels once (after install)",
        description="Compile every numba kernel signature the solvers use into numba's on-disk "
        "cache, once after install (4-16 min on 2 cores, idle to busy); "
        "later runs load them in seconds. Without it the first solves compile what they use "
        "and small grids run on one thread until the parallel kernels exist.",
    )
    p.add_argument(
        "--only",
        nargs="+",
        choices=("serial", "parallel"),
        default=None,
        help="only the one-thread (serial) or the multi-thread (parallel) kernels (default both)",
    )
    p.add_argument("--jobs", type=int, default=None, help="processes, 1-64 (default: CPUs)")
    p.add_argument("--quiet", action="store_true", help="no messages on stderr")
    p.set_defaults(func=_cmd_warmup)
