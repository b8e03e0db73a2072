"""Progress on stderr, one printer for every long step.

:class:`Printer` writes stage lines (``psdesign: meshing (stuffing) ...``), estimates before long
runs and the iterations of iterative solves: a redrawn status line on a terminal, plain lines at
most every ``every_s`` otherwise; ``quiet`` silences it. The CLI activates one printer per
command (:func:`activate`); library code reports through the module functions :func:`stage`,
:func:`estimate` and :func:`iterations`, which do nothing when no printer is active (API use,
tests, ``--quiet``). stdout is never written.

A package root module like :mod:`psdesign.errors`: every stage reports through it and the CLI
only activates it (until session 52 it was ``psdesign.cli.progress``, which 14 stage modules
imported; the options it also held are :mod:`psdesign.cli.options`).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TextIO

__all__ = [
    "Printer",
    "activate",
    "active",
    "compiling",
    "counted",
    "estimate",
    "iterations",
    "progress_printer",
    "stage",
    "throttled",
    "warning",
]


class Printer:
    """Progress lines on ``stream`` (default stderr).

    Parameters
    ----------
    quiet
        Print nothing.
    stream
        Text stream; a terminal gets a redrawn line (``\\r``), anything else plain lines.
    every_s
        Plain-line mode: at most one iteration line per solve every ``every_s`` seconds.
    """

    def __init__(
        self, quiet: bool = False, stream: TextIO | None = None, every_s: float = 5.0
    ) -> None:
        self.quiet = quiet
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.every_s = every_s
        self.t0 = time.perf_counter()
        self._open = False  # a redrawn (unterminated) line is on the terminal
        self.warned: list[str] = []  # warnings printed by :func:`warning` during the command
        self.compiles = 0  # numba compiles started during the command (:meth:`compiling`)
        self._compile_report: Callable[..., None] | None = None

    def _write(self, text: str, redraw: bool = False) -> None:
        if self.quiet:
            return
        if self.tty:
            self.stream.write(("\r" if self._open else "") + text + ("\033[K" if redraw else ""))
            if not redraw:
                self.stream.write("\n")
            self._open = redraw
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def stage(self, message: str) -> None:
        """One line ``psdesign: <message> (<elapsed> s)``."""
        self._write(f"psdesign: {message} ({time.perf_counter() - self.t0:.0f} s)")

    def estimate(self, what: str, seconds: float | None, memory_gb: float | None) -> None:
        """``psdesign: <what>: estimated ~T, ~M GB`` before a long run."""
        parts = []
        if seconds is not None:
            parts.append(f"~{_duration(seconds)}")
        if memory_gb is not None:
            parts.append(f"~{memory_gb:.2g} GB")
        self._write(f"psdesign: {what}: estimated {', '.join(parts) or 'unknown'}")

    def iterations(self, label: str, method: str) -> Callable[[int, float], None]:
        """Callback ``report(iterations, residual)`` of one iterative solve."""
        return self.throttled(
            lambda s, n, residual: (
                f"psdesign: {label}: {n} {method} iterations, residual {residual:.1e}, {s:.0f} s"
            )
        )

    def counted(self, label: str, unit: str) -> Callable[[int, int], None]:
        """Callback ``report(done, total)`` of counted work (elements assembled, steps of a
        mesher): ``psdesign: <label>: <done>/<total> <unit>, <elapsed> s``, throttled."""
        return self.throttled(
            lambda s, done, total: f"psdesign: {label}: {done}/{total} {unit}, {s:.0f} s"
        )

    def throttled(self, line: Callable[..., str]) -> Callable[..., None]:
        """Callback ``report(*args)`` writing ``line(elapsed_s, *args)``: on a terminal one
        redrawn line at most every 0.2 s (the first at once), else a plain line every
        ``every_s``."""
        t0 = time.perf_counter()
        last = [float("-inf") if self.tty else t0]  # a terminal line is drawn at once

        def report(*args) -> None:
            now = time.perf_counter()
            if self.quiet or now - last[0] < (0.2 if self.tty else self.every_s):
                return
            last[0] = now
            self._write(line(now - t0, *args), redraw=self.tty)

        return report

    def compiling(self, name: str) -> None:
        """A numba kernel compile started: the first says so in one stage line, the rest
        are counted on a throttled line."""
        if self._compile_report is None:
            self.stage(
                "compiling numba kernels (once after an install or a change; `psdesign warmup` "
                "compiles them ahead)"
            )
            self._compile_report = self.throttled(
                lambda s, n, kernel: (
                    f"psdesign: compiling numba kernels: {n} so far ({kernel}), {s:.0f} s"
                )
            )
        self.compiles += 1
        self._compile_report(self.compiles, name)

    def close(self) -> None:
        """End a redrawn line."""
        if self._open and not self.quiet:
            self.stream.write("\n")
            self.stream.flush()
        self._open = False


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


_ACTIVE: list[Printer] = []


@contextmanager
def activate(quiet: bool = False, stream: TextIO | None = None) -> Iterator[Printer]:
    """Make a :class:`Printer` the target of :func:`stage`, :func:`estimate`, :func:`iterations`
    for the duration of the block (the CLI wraps each command in it).

    The closing note (kernels that ran on one thread) is printed only when the block ends
    normally: after Ctrl-C, SIGTERM or an error the command's one line
    (``psdesign: interrupted``) must stay the only one."""
    printer = Printer(quiet=quiet, stream=stream)
    _ACTIVE.append(printer)
    before = _pending_kernels()
    try:
        yield printer
    except BaseException:  # Ctrl-C, SIGTERM, an error: its one line is the last word
        _ACTIVE.remove(printer)
        printer.close()
        raise
    _ACTIVE.remove(printer)
    if _pending_kernels() - before:  # this command ran kernels on one thread
        from solvers.jit import WARMUP_NOTE

        if not any(WARMUP_NOTE in w for w in printer.warned):  # not said already
            printer.stage(f"numba kernels ran on one thread: {WARMUP_NOTE}")
    printer.close()


def _pending_kernels() -> set[str]:
    """Kernels that ran serially because their parallel version is not compiled yet."""
    jit = sys.modules.get("solvers.jit")
    return set(jit.parallel_pending()) if jit is not None else set()


def active() -> Printer | None:
    """The printer of the running command, or None (library use)."""
    return _ACTIVE[-1] if _ACTIVE else None


def stage(message: str) -> None:
    """Report a stage of a long step on the active printer (no-op without one)."""
    if _ACTIVE:
        _ACTIVE[-1].stage(message)


def warning(text: str) -> None:
    """Print ``psdesign: warning: <text>`` on stderr (also with ``--quiet``: a warning is part
    of the result) and remember it on the active printer, so the command's closing notes do not
    repeat it."""
    print(f"psdesign: warning: {text}", file=sys.stderr)
    if _ACTIVE:
        _ACTIVE[-1].warned.append(text)


def estimate(what: str, seconds: float | None = None, memory_gb: float | None = None) -> None:
    """Report a time / memory estimate before a long run (no-op without a printer)."""
    if _ACTIVE:
        _ACTIVE[-1].estimate(what, seconds, memory_gb)


def iterations(label: str, method: str) -> Callable[[int, float], None] | None:
    """Iteration callback of the active printer, or None without one."""
    return _ACTIVE[-1].iterations(label, method) if _ACTIVE else None


def counted(label: str, unit: str) -> Callable[[int, int], None] | None:
    """The active printer's :meth:`Printer.counted` callback ``report(done, total)``, or None
    without a printer (library use, tests)."""
    return _ACTIVE[-1].counted(label, unit) if _ACTIVE else None


def throttled(line: Callable[..., str]) -> Callable[..., None] | None:
    """The active printer's :meth:`Printer.throttled` callback ``report(*args)`` writing
    ``line(elapsed_s, *args)`` (the progress of a long loop: fibers placed, radii scanned), or
    None without a printer (library use, tests)."""
    return _ACTIVE[-1].throttled(line) if _ACTIVE else None


def compiling(name: str) -> None:
    """A numba kernel compile started (:mod:`solvers.jit`'s listener): once per command the
    line ``psdesign: compiling numba kernels ...`` (a cold start compiled for up to 100 s
    before the first progress line), then a throttled count (:meth:`Printer.compiling`);
    no-op without a printer."""
    if _ACTIVE:
        _ACTIVE[-1].compiling(name)


def search_progress(label: str) -> Callable[[dict], None] | None:
    """Callback of a pattern search (:func:`psdesign.forcefield.pattern.pattern_search`'s
    history entries): ``psdesign: <label>: N polls, E evaluations, U = u, mesh size s, T s``,
    as often as iterative solves report; None without a printer."""
    if not _ACTIVE:
        return None
    return _ACTIVE[-1].throttled(
        lambda s, e: (
            f"psdesign: {label}: {e['iter']} polls, {e['n_evals']} evaluations, "
            f"U = {e['fun']:.6g}, mesh size {e['step']:.1e}, {s:.0f} s"
        )
    )


def progress_printer(
    direction: str, every_s: float = 5.0, solve: str = "voxel solve", method: str = "MINRES"
) -> Callable[[int, float], None]:
    """Progress callback ``report(iterations, residual)`` of an iterative solve: one line on
    stderr at most every ``every_s`` (``psdesign: voxel solve z: 40 MINRES iterations, ...``);
    the active printer's (a redrawn line on a terminal) when a command runs."""
    printer = active() or Printer(every_s=every_s)
    if printer.every_s != every_s:
        printer = Printer(quiet=printer.quiet, stream=printer.stream, every_s=every_s)
    return printer.iterations(f"{solve} {direction}", method)
