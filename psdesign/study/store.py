"""Atomic, resumable storage of study results.

Layout of an output folder ``OUT``::

    OUT/study.json            expanded design (study settings + every case's params, seed, spec;
                              an image study's image_header as the run read it)
    OUT/cases/<case_id>.json  one record per finished case (written via temp file + os.replace)
    OUT/cases/<case_id>/      the case's working folder (previews, logs)
    OUT/results.csv           consolidated table, one row per finished case, design order
    OUT/results.parquet       the same table in Parquet
    OUT/summary.csv           one row per design point: mean, std, 95 % CI, n of trusted outputs
    OUT/summary.parquet       the same table in Parquet
    OUT/run.json              run history (start/end, workers, scheduler, machine)

Per-case records are the source of truth; the tables are rebuilt from them.  Every file is
written to a temporary name in the same folder, flushed, fsynced and moved into place with
:func:`os.replace`, so a crash (even ``kill -9``) leaves either the old or the new file.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from psdesign.io.outputs import TEMP_PREFIX, OutputDir, check_added_files, is_psdesign_temp

__all__ = [
    "STUDY_FILES",
    "STUDY_FILES_NO_REPORT",
    "STUDY_LEGACY",
    "CaseStore",
    "StorageError",
    "TIMING_COLUMNS",
    "atomic_write_bytes",
    "atomic_write_json",
    "check_study_files",
    "is_timing_column",
    "json_text",
    "records_to_frame",
    "remove_dead_temp",
]

#: What ``study run`` writes in its output folder (a trailing ``/``: a whole sub-folder); checked
#: before the run, then listed in the marker.
STUDY_FILES = (
    "study.json",
    "results.csv",
    "results.parquet",
    "summary.csv",
    "summary.parquet",
    "run.json",
    "report.html",
    "cases/",
)
#: :data:`STUDY_FILES` of a run without its report (``study run --no-report``, ``rev``).
STUDY_FILES_NO_REPORT = tuple(f for f in STUDY_FILES if f != "report.html")
#: A study folder written by an older psdesign, before the marker: all of these exist.
STUDY_LEGACY = ("study.json", "cases")


#: How a file psdesign adds to a study folder begins (within its first KB): what a folder
#: without the marker may have of psdesign's (:func:`psdesign_wrote`). The report's title is
#: that of every report since the first (bebcd22b); surrogate.json is a JSON object whose
#: first key is its format's version.
ADDED_FILE_SIGNATURES = {
    "report.html": re.compile(rb"<title>psdesign study report: "),
    "surrogate.json": re.compile(rb'\A\{\s*"version":'),
}


def psdesign_wrote(path: Path) -> bool:
    """Whether ``path`` (a study folder's ``report.html`` or ``surrogate.json``) is
    recognisably a file psdesign wrote (:data:`ADDED_FILE_SIGNATURES`); any other name:
    ``True`` (an older ``study run``'s own files, :data:`STUDY_FILES`).

    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "report.html"
    >>> _ = p.write_text("MY OWN REPORT")
    >>> psdesign_wrote(p)
    False
    """
    sig = ADDED_FILE_SIGNATURES.get(path.name)
    if sig is None:
        return True
    try:
        with path.open("rb") as f:
            head = f.read(1024)
    except OSError:
        return False
    return sig.search(head) is not None


def check_study_files(
    out_dir: str | Path, files: Iterable[str], command: str, option: str = "out_dir"
) -> OutputDir:
    """Check that a command may add ``files`` to the study folder ``out_dir`` (``study fit``:
    ``surrogate.json``, ``study report``: ``report.html``); nothing is changed.

    A file psdesign did not write is never replaced
    (:func:`psdesign.io.outputs.check_added_files`, :class:`~psdesign.io.outputs.OutputError`);
    record the files with :func:`psdesign.io.outputs.claim_output_dir` just before writing.
    A folder without the marker (an older psdesign's, or a ``cp -r out/*`` copy) replaces
    such a file only when it is recognisably psdesign's (:func:`psdesign_wrote`).
    """
    return check_added_files(
        out_dir,
        files,
        command=command,
        option=option,
        legacy=STUDY_LEGACY,
        legacy_files=STUDY_FILES,
        legacy_owns=psdesign_wrote,
    )


#: Columns that vary from run to run (excluded when comparing tables for reproducibility).
TIMING_COLUMNS = ("started_at", "finished_at", "host", "pid", "wall_time_s", "runner_overhead_s")
LEADING = ("case_id", "index")
#: Permeability tensor columns, row-major (k_xx, k_xy, ..., k_zz).
TENSOR_KEYS = tuple(f"k_{a}{b}_m2" for a in "xyz" for b in "xyz")
RESULT_ORDER = (
    "seed",
    "status",
    "error",
    "porosity",
    "porosity_error",
    "porosity_status",
    "k_x_m2",
    "k_y_m2",
    "k_z_m2",
    *TENSOR_KEYS,
    "n_fibers",
)
_SAFE_ID = re.compile(r"^[A-Za-z0-9_.-]+$")


class StorageError(OSError):
    """Writing results failed (disk full, permissions ...); earlier results are intact.

    >>> str(StorageError(28, "cannot write x.csv: No space left on device"))
    'cannot write x.csv: No space left on device'
    """

    def __str__(self) -> str:  # the CLI's one line: no "[Errno 28] " before the message
        return self.strerror or super().__str__()


def is_timing_column(name: str) -> bool:
    """True for columns that legitimately differ between identical runs: when, where and how
    they ran (``thread_note_<d>``: fewer threads than numba's, e.g. kernels not compiled yet).

    >>> [is_timing_column(c) for c in ("pid", "time_mesh_s", "thread_note_z", "k_z_m2", 3)]
    [True, True, True, False, False]
    """
    return isinstance(name, str) and (  # a column that is not text (3): no timing column
        name in TIMING_COLUMNS
        or name.endswith("_time_s")
        or name.startswith(("time_", "thread_note_"))
    )


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


#: Seconds a temp file's mtime must precede its pid's process start to be a dead writer's (the
#: boot time the start is counted from is whole seconds).
PID_REUSE_MARGIN_S = 2.0


def remove_dead_temp(path: Path) -> list[Path]:
    """Delete the temp files of :func:`atomic_write_bytes` for ``path`` that a killed process
    left (``.psdesign-<name>.<pid>.tmp`` whose pid is not running here, or, on Linux, whose pid
    a process started after the temp was last written now has: a reused pid); a live
    writer's temp stays.  For commands that write one file into a study folder without the run
    lock (``study fit``: its killed write left ``.psdesign-surrogate.json.<pid>.tmp`` until the
    next ``study run``, session 35's failure audit; one whose pid was reused, as in a container
    where each command gets the same small pid, stayed for good).

    Returns
    -------
    list of Path
        The files removed.
    """
    import psutil

    path = Path(path)
    prefix = f"{TEMP_PREFIX}{path.name}."
    dead = []
    for tmp in path.parent.glob(f"{prefix}*.tmp"):
        pid = tmp.name[len(prefix) : -len(".tmp")]
        if pid.isdigit() and (
            (int(pid) != os.getpid() and not psutil.pid_exists(int(pid)))
            or _written_before_start(tmp, int(pid))
        ):
            dead.append(tmp)
    return _unlink_temps(dead)


def _written_before_start(tmp: Path, pid: int) -> bool:
    """``tmp`` was last written (:data:`PID_REUSE_MARGIN_S`) before process ``pid`` started:
    its writer was another process, gone, whose pid was reused.  False when the start cannot
    be told (no such process, or no access to it: the pid alone decides, as before)."""
    import psutil

    try:
        start = psutil.Process(pid).create_time()
        return tmp.lstat().st_mtime < start - PID_REUSE_MARGIN_S
    except (psutil.Error, OSError):
        return False


def _unlink_temps(paths) -> list[Path]:
    """Unlink the psdesign temp files (``.psdesign-*.tmp``, regular files, not links) among
    ``paths``; a user's ``*.tmp`` or one that cannot be removed is left.  Returns those
    removed."""
    removed = []
    for tmp in paths:
        if not is_psdesign_temp(tmp) or not tmp.is_file() or tmp.is_symlink():
            continue
        try:
            tmp.unlink()
            removed.append(tmp)
        except OSError:
            pass
    return removed


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (temp file in the same folder + os.replace).

    Raises
    ------
    StorageError
        On any OSError; ``path`` keeps its previous content and no temp file is left.
    """
    path = Path(path)
    tmp = path.with_name(f"{TEMP_PREFIX}{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        raise StorageError(
            exc.errno, f"cannot write {path}: {exc.strerror or exc}; earlier results are intact"
        ) from exc
    _fsync_dir(path.parent)


def jsonable(v: Any) -> Any:
    """``v`` as plain JSON data: NumPy scalars and arrays as numbers and lists, paths as text,
    NaN as ``None`` (JSON has no NaN) and infinities as ``"inf"`` / ``"-inf"``.

    >>> jsonable({"k": np.float32(2.5), "e": float("nan"), "a": np.arange(2), "n": np.nan})
    {'k': 2.5, 'e': None, 'a': [0, 1], 'n': None}
    >>> jsonable(np.float64("nan")), jsonable(np.float64("-inf"))
    (None, '-inf')
    """
    if isinstance(v, dict):
        return {str(k): jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [jsonable(x) for x in v]
    if isinstance(v, np.ndarray):
        return jsonable(v.tolist())
    if isinstance(v, np.generic):  # np.float64(nan) too: its item() is a NaN float
        return jsonable(v.item())
    if isinstance(v, Path):
        return str(v)
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return v


def json_text(obj: Any, indent: int | None = None) -> str:
    """``obj`` as strict JSON text (:func:`jsonable`: NaN as ``null``, never Python's ``NaN``
    token, which ``jq`` and JavaScript refuse; anything else not JSON as its text): what the
    ``--json`` outputs print (:func:`psdesign.cli.lines.print_json`) and ``optimize.json``
    holds.

    >>> json_text({"a": float("nan"), "b": 1.5, "c": Path("x")})
    '{"a": null, "b": 1.5, "c": "x"}'
    """
    return json.dumps(jsonable(obj), indent=indent, allow_nan=False, default=str)


def atomic_write_json(path: Path, obj: Any) -> None:
    """Atomically write ``obj`` as indented JSON (numpy values converted)."""
    text = json.dumps(jsonable(obj), indent=1, sort_keys=False, allow_nan=False)
    atomic_write_bytes(Path(path), text.encode())


def _cell(v: Any) -> Any:
    """Table cell: scalars as they are, anything else as compact JSON text."""
    if v is None or isinstance(v, bool | int | float | str):
        return v
    return json.dumps(jsonable(v), sort_keys=True, separators=(",", ":"))


def records_to_frame(records: Iterable[dict], param_names: list[str]) -> pd.DataFrame:
    """Build the consolidated results table from case records.

    Columns: ``case_id``, ``index``, the study's parameters, ``seed``, ``status``, ``error``,
    ``porosity``, permeabilities, tensor, then every other result (solver stats, timings) in
    sorted order.  Rows are in design order.
    """
    rows = []
    for rec in records:
        row = {"case_id": rec["case_id"], "index": rec["index"]}
        params = rec.get("params", {})
        for p in param_names:
            row[p] = _cell(params.get(p))
        row["seed"] = rec.get("seed")
        row["status"] = rec.get("status")
        row["error"] = rec.get("error")
        for k, v in (rec.get("results") or {}).items():
            if k in row or k in params:
                k = f"result.{k}"
            row[k] = _cell(v)
        for k in ("wall_time_s", "runner_overhead_s", "started_at", "finished_at", "host", "pid"):
            if k in rec:
                row[k] = rec[k]
        rows.append(row)
    rows.sort(key=lambda r: r["index"])
    df = pd.DataFrame(rows)
    if df.empty:
        return pd.DataFrame(columns=[*LEADING, *param_names, "seed", "status", "error"])
    first = [*LEADING, *param_names]
    present = [c for c in RESULT_ORDER if c in df.columns]
    rest = [c for c in df.columns if c not in first and c not in present]
    stats = sorted(c for c in rest if not is_timing_column(c))
    timing = sorted(c for c in rest if is_timing_column(c))
    df = df[first + present + stats + timing]
    # error is text even when every case succeeded (keeps CSV/Parquet schemas stable)
    df["error"] = df["error"].astype("object")
    return df.reset_index(drop=True)


class CaseStore:
    """Per-case records and consolidated tables in an output folder.

    Parameters
    ----------
    out_dir : Path
        The study's output folder (created if needed).
    """

    def __init__(self, out_dir: str | Path):
        self.out = Path(out_dir)
        self.cases_dir = self.out / "cases"

    # -- paths
    def record_path(self, case_id: str) -> Path:
        if not _SAFE_ID.match(case_id):
            raise ValueError(f"case_id: unsafe characters in {case_id!r}")
        return self.cases_dir / f"{case_id}.json"

    def workdir(self, case_id: str) -> Path:
        return self.cases_dir / case_id

    # -- setup
    def prepare(self) -> None:
        """Create the folders and check that they are writable (nothing is deleted here).

        Raises
        ------
        StorageError
            If the folder cannot be created or written.
        """
        try:
            self.cases_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise StorageError(
                exc.errno, f"cannot create output folder {self.cases_dir}: {exc.strerror or exc}"
            ) from exc
        probe = self.out / f"{TEMP_PREFIX}write-test.{os.getpid()}.tmp"
        atomic_write_bytes(probe, b"ok")
        try:
            probe.unlink()
        except OSError:
            pass

    def remove_stale_temp(self) -> list[Path]:
        """Delete temp files a killed run left (``.psdesign-*.tmp``); call with the lock held.

        Only psdesign's own temp names are touched, never a user's ``*.tmp``.

        Returns
        -------
        list of Path
            The files removed.
        """
        return _unlink_temps(
            [
                tmp
                for folder in (self.out, self.cases_dir)
                for tmp in folder.glob(f"{TEMP_PREFIX}*.tmp")
            ]
        )

    # -- records
    def load_records(self) -> dict[str, dict]:
        """All readable records by case_id (unreadable/partial files are skipped)."""
        out: dict[str, dict] = {}
        if not self.cases_dir.is_dir():
            return out
        for p in sorted(self.cases_dir.glob("*.json")):
            try:
                rec = json.loads(p.read_text())
            except (OSError, ValueError):
                continue
            if isinstance(rec, dict) and rec.get("case_id") == p.stem and "status" in rec:
                out[p.stem] = rec
        return out

    def write_record(self, record: dict) -> None:
        """Atomically write one case record."""
        atomic_write_json(self.record_path(record["case_id"]), record)

    def write_tables(self, records: Iterable[dict], param_names: list[str]) -> pd.DataFrame:
        """Rebuild ``results.csv`` and ``results.parquet`` atomically from ``records``."""
        df = records_to_frame(records, param_names)
        atomic_write_bytes(self.out / "results.csv", df.to_csv(index=False).encode())
        tmp = self.out / f"{TEMP_PREFIX}results.parquet.{os.getpid()}.tmp"
        try:
            df.to_parquet(tmp, index=False)
            os.replace(tmp, self.out / "results.parquet")
        except OSError as exc:
            try:
                tmp.unlink(missing_ok=True)
            except OSError:
                pass
            raise StorageError(
                exc.errno,
                f"cannot write {self.out / 'results.parquet'}: {exc.strerror or exc}; "
                "earlier results are intact",
            ) from exc
        except Exception:  # noqa: BLE001 - a Parquet schema problem must not stop the study
            try:
                tmp.unlink(missing_ok=True)
            except OSError:
                pass
            df.astype(str).to_parquet(tmp, index=False)
            os.replace(tmp, self.out / "results.parquet")
        from psdesign.analysis.replicates import write_summary

        write_summary(self.out, df, param_names)  # summary.csv: statistics over replicates
        return df

    def write_json(self, name: str, obj: Any) -> None:
        atomic_write_json(self.out / name, obj)
