"""Child-process entry point for a case with a timeout: ``python -m psdesign.study._child WORKDIR
[PARENT_PID]``.

Reads the case job as JSON from stdin (:func:`psdesign.study.exchange.read_job`), runs the case
function and writes ``{"ok": bool, "results" | "error", "traceback"}`` as JSON (+ npz for
arrays) into WORKDIR (:func:`psdesign.study.exchange.write_result`).  No pickle is involved.
"""

from __future__ import annotations

import signal
import sys
import traceback
from pathlib import Path


def main(argv: list[str]) -> int:
    """Run one case; returns the exit status (0 when a result was written)."""
    import warnings

    from psdesign.errors import show_warning_one_line
    from psdesign.io.diskfull import is_disk_full
    from psdesign.study.casefn import watch_parent
    from psdesign.study.exchange import read_job, write_result

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the runner decides when a case stops
    warnings.showwarning = show_warning_one_line  # one line per warning in case.log
    workdir = Path(argv[0])
    if len(argv) > 1:
        watch_parent(int(argv[1]))
    try:
        job = read_job(sys.stdin.buffer)
        from psdesign import progress
        from psdesign.study.worker import run_case_inline

        with progress.activate(stream=sys.stderr):  # solver progress lines go to case.log
            # its warnings named by the case id, as every other route shows them (they were
            # written to case.log without it until session 43)
            res = run_case_inline(job, Path(job["workdir"]))
        out = {"ok": True, "results": res}
    except Exception as exc:  # noqa: BLE001 - reported to the parent
        msg = " ".join(str(exc).split())
        out = {
            "ok": False,
            "error": f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__,
            "traceback": traceback.format_exc(),
        }
        if is_disk_full(exc):  # the runner stops the run; the case runs again on the resume
            out["disk_full"] = True
    write_result(workdir, out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
