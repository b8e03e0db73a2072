"""Session 54 femmem: where the FEM solve's peak memory comes from.

Runs ``python -m psdesign ARGS`` in this process with a 50 ms RSS sampler and writes to
``$PROF_LOG`` the RSS at entry and exit of the assembly, the AMG set-up, GMRES / MINRES and the
solve, then the largest RSS sampled in each phase. Wrap it in ``/usr/bin/time -v`` for the
whole-process peak (benchmarks/RESULTS.md "Session 54: femmem")::

    PROF_LOG=case.prof /usr/bin/time -v python benchmarks/fem_memory_phases.py \\
        permeability case.toml --solver fem --direction z --no-error-estimate --json
"""

from __future__ import annotations

import atexit
import functools
import os
import runpy
import sys
import threading
import time

import psutil

import solvers.fem.assembly as assembly
import solvers.fem.linsolve as linsolve
import solvers.fem_stokes as fem_stokes

_PROC = psutil.Process()
_T0 = time.monotonic()
_STATE: dict = {"phase": "start", "peak": {}}


def _sample() -> None:
    while True:
        rss = _PROC.memory_info().rss
        phase = _STATE["phase"]
        _STATE["peak"][phase] = max(rss, _STATE["peak"].get(phase, 0))
        time.sleep(0.05)


def _mark(out, name: str) -> None:
    _STATE["phase"] = name
    out.write(f"{time.monotonic() - _T0:8.2f} {_PROC.memory_info().rss / 1e9:.4f} {name}\n")


def _wrap(out, module, name: str) -> None:
    func = getattr(module, name)

    @functools.wraps(func)
    def marked(*args, **kwargs):
        _mark(out, f"enter {name}")
        try:
            return func(*args, **kwargs)
        finally:
            _mark(out, f"exit {name}")
            _STATE["phase"] = f"after {name}"

    setattr(module, name, marked)


def main() -> None:
    out = open(os.environ["PROF_LOG"], "w", buffering=1)  # noqa: SIM115 - closed at exit
    threading.Thread(target=_sample, daemon=True).start()
    for name in ("velocity_preconditioners", "gmres", "solve_gmres", "solve_minres"):
        _wrap(out, linsolve, name)
    for name in ("solve_iterative", "solve_stokes", "solve_stokes_periodic"):
        _wrap(out, fem_stokes, name)
    _wrap(out, assembly, "assemble_volume")

    @atexit.register
    def _peaks() -> None:
        _mark(out, "end")
        for phase, rss in _STATE["peak"].items():
            out.write(f"peak {rss / 1e9:.4f} {phase}\n")
        out.close()

    sys.argv = ["psdesign", *sys.argv[1:]]
    runpy.run_module("psdesign", run_name="__main__")


if __name__ == "__main__":
    main()
