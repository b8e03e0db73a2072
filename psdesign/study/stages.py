"""Progress inside a running study case: the case writes its current stage to
``<workdir>/stage.txt`` (:func:`mark_stage`), the runner prints the stages of the cases still
running every few seconds (:class:`StageWatcher`).

A file, not a pipe: it works alike for in-process, pool, child-process and shared-filesystem
Dask workers, and the last stage of a case that died stays readable next to its ``case.log``.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path
from typing import TextIO

STAGE_FILE = "stage.txt"

#: Seconds between two stage reports of the runner.
STAGE_EVERY_S = 15.0


def mark_stage(workdir: Path | str | None, text: str) -> None:
    """Record ``text`` as the current stage of the case in ``workdir`` (atomic replace; a
    case must never fail over its progress note, so write errors are ignored)."""
    if workdir is None:
        return
    path = Path(workdir) / STAGE_FILE
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(text)
        os.replace(tmp, path)
    except OSError:
        pass


def clear_stage(workdir: Path | str | None) -> None:
    """Remove the stage note of a finished case."""
    if workdir is not None:
        (Path(workdir) / STAGE_FILE).unlink(missing_ok=True)


def running_stages(workdirs: dict[str, Path], now: float | None = None) -> list[str]:
    """One line per case whose stage note exists: ``case_id: stage (N s)``, N the time since
    the stage began.

    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> mark_stage(d, "solving K_z (fem, permeameter)")
    >>> running_stages({"c0000": d}, now=(d / STAGE_FILE).stat().st_mtime + 12)
    ['c0000: solving K_z (fem, permeameter) (12 s)']
    """
    now = time.time() if now is None else now
    lines = []
    for case_id, wd in workdirs.items():
        path = Path(wd) / STAGE_FILE
        try:
            text = path.read_text().strip()
            age = now - path.stat().st_mtime
        except OSError:
            continue
        if text:
            lines.append(f"{case_id}: {text} ({age:.0f} s)")
    return lines


class StageWatcher:
    """Background thread printing ``[study] running <case>: <stage> (N s)`` for the cases in
    ``workdirs`` not yet :meth:`done`, every ``every_s`` seconds, on ``stream`` (stderr)."""

    def __init__(
        self,
        workdirs: dict[str, Path],
        every_s: float = STAGE_EVERY_S,
        stream: TextIO | None = None,
    ) -> None:
        self.workdirs = dict(workdirs)
        self.every_s = float(every_s)
        self.stream = stream if stream is not None else sys.stderr
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._loop, daemon=True, name="study-stages")

    def __enter__(self) -> StageWatcher:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)

    def done(self, case_id: str) -> None:
        """Stop reporting ``case_id`` and remove its stage note."""
        with self._lock:
            wd = self.workdirs.pop(case_id, None)
        clear_stage(wd)

    def _loop(self) -> None:
        while not self._stop.wait(self.every_s):
            with self._lock:
                lines = running_stages(self.workdirs)
            for line in lines:
                print(f"[study] running {line}", file=self.stream, flush=True)
