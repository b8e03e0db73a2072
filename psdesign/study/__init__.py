"""Parameter studies: study files, designs of experiments, a resumable parallel runner.

Public API
----------
load_study(path) -> Study
expand_design(study) -> list[Case]
run_study(study, out_dir, options=None, **fields) -> pandas.DataFrame
RunOptions(workers=1, scheduler=None, case_fn=None, progress=True, ...)   (how a study runs)
write_report(out_dir) -> Path          (from :mod:`psdesign.report`)

Names are imported lazily so that the per-case child process (``psdesign.study._child``)
starts without pulling in pandas or dask.
"""

from __future__ import annotations

import importlib
from pathlib import Path

__all__ = [
    "KNOWN_SPEC_KEYS",
    "Case",
    "RunOptions",
    "SchedulerError",
    "StorageError",
    "Study",
    "StudyError",
    "WorkersLost",
    "expand_design",
    "is_timing_column",
    "load_study",
    "run_study",
    "write_report",
]

_LAZY = {
    "Case": "design",
    "RunOptions": "options",
    "expand_design": "design",
    "SchedulerError": "address",
    "run_study": "runner",
    "WorkersLost": "runner",
    "StorageError": "store",
    "is_timing_column": "store",
    "KNOWN_SPEC_KEYS": "studyfile",
    "Study": "studyfile",
    "StudyError": "studyfile",
    "load_study": "studyfile",
}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)


def write_report(out_dir: str | Path) -> Path:
    """Write ``OUT/report.html`` (see :func:`psdesign.report.write_report`)."""
    from psdesign.report import write_report as _write

    return _write(out_dir)
