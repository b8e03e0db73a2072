"""Progress display: a bar with ETA on a terminal, plain log lines otherwise (stderr)."""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress", "format_duration"]


def format_duration(seconds: float) -> str:
    """``H:MM:SS`` for a duration in seconds (``--:--`` when unknown)."""
    if seconds is None or seconds != seconds or seconds < 0 or seconds == float("inf"):
        return "--:--"
    s = int(round(seconds))
    h, rem = divmod(s, 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}"


class Progress:
    """Report finished cases.

    Parameters
    ----------
    total : int
        Cases in the design.
    already_done : int
        Cases skipped because they were finished in an earlier run.
    enabled : bool
        False silences everything.
    stream : file, optional
        Defaults to ``sys.stderr``; a bar is drawn only if it is a TTY.
    """

    def __init__(
        self, total: int, already_done: int = 0, enabled: bool = True, stream: TextIO | None = None
    ):
        self.total = int(total)
        self.skipped = int(already_done)
        self.done = 0
        self.counts: dict[str, int] = {}
        self.enabled = enabled
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.monotonic()
        self._last_draw = 0.0

    @property
    def todo(self) -> int:
        return self.total - self.skipped

    def eta(self) -> float:
        """Seconds left, extrapolated from this run's throughput."""
        if self.done == 0:
            return float("nan")
        rate = self.done / max(time.monotonic() - self.t0, 1e-9)
        return (self.todo - self.done) / rate

    def start(self, message: str) -> None:
        if self.enabled:
            self._line(message)

    def update(
        self, case_id: str, status: str, wall_time_s: float | None, error: str | None = None
    ) -> None:
        """Record one finished case and redraw / log."""
        self.done += 1
        self.counts[status] = self.counts.get(status, 0) + 1
        if not self.enabled:
            return
        if self.tty:
            if status != "ok":
                self._clear()
                self._line(f"{case_id} {status}: {error or ''}".rstrip())
            now = time.monotonic()
            if now - self._last_draw > 0.1 or self.done == self.todo:
                self._draw()
                self._last_draw = now
        else:
            n = self.skipped + self.done
            wt = f" {wall_time_s:.1f} s" if wall_time_s is not None else ""
            err = f" ({error})" if error and status != "ok" else ""
            self._line(
                f"[study] {n}/{self.total} {case_id} {status}{wt}{err} "
                f"| elapsed {format_duration(time.monotonic() - self.t0)} "
                f"ETA {format_duration(self.eta())}"
            )

    def finish(self, message: str = "") -> None:
        if not self.enabled:
            return
        if self.tty:
            self._draw()
            self.stream.write("\n")
        if message:
            self._line(message)
        self.stream.flush()

    # -- drawing
    def _bar(self, width: int = 30) -> str:
        n = self.skipped + self.done
        frac = n / self.total if self.total else 1.0
        fill = int(round(frac * width))
        stats = " ".join(f"{k} {v}" for k, v in sorted(self.counts.items()))
        return (
            f"\r[{'#' * fill}{'.' * (width - fill)}] {n}/{self.total} {100 * frac:3.0f}% "
            f"{stats} | {format_duration(time.monotonic() - self.t0)} "
            f"ETA {format_duration(self.eta())}\033[K"
        )

    def _draw(self) -> None:
        self.stream.write(self._bar())
        self.stream.flush()

    def _clear(self) -> None:
        self.stream.write("\r\033[K")

    def _line(self, text: str) -> None:
        self.stream.write(text + "\n")
        self.stream.flush()
