"""When a running process started (Linux ``/proc``): tells a dead writer's temp file from a
live one's when the dead writer's pid was reused (:func:`psdesign.study.store.remove_dead_temp`).

Light on purpose: the standard library only.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["process_start_time"]


def _boot_time() -> float:
    """Seconds since the epoch at which the machine booted (``btime`` of ``/proc/stat``)."""
    for line in Path("/proc/stat").read_text().splitlines():
        if line.startswith("btime "):
            return float(line.split()[1])
    raise ValueError("no btime in /proc/stat")


def process_start_time(pid: int) -> float | None:
    """Seconds since the epoch at which process ``pid`` started, from field 22 of
    ``/proc/<pid>/stat`` (clock ticks after boot) and the boot time (whole seconds: within
    about 1 s); ``None`` when it cannot be told (no such process, no ``/proc``: not Linux).

    >>> import sys, time
    >>> t = process_start_time(os.getpid())
    >>> t is None if not sys.platform.startswith("linux") else 0 < time.time() - t < 1e7
    True
    >>> process_start_time(-1) is None
    True
    """
    try:
        stat = Path(f"/proc/{int(pid)}/stat").read_text()
        # the command name (field 2) is in parentheses and may hold spaces or ")"
        fields = stat[stat.rindex(")") + 2 :].split()  # field 3 (the state) onwards
        ticks = int(fields[22 - 3])
        return _boot_time() + ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None
