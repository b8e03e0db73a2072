"""Execution of one case inside a worker (process-pool worker, Dask worker or in-process).

:func:`execute_case` never raises for a failing case: it returns a record with status
``"ok"``, ``"not_converged"`` (a solve did not converge or a result is flagged, see
:func:`untrusted_reason`), ``"failed"`` or ``"timeout"``.  With a timeout the case runs in a
child process (``python -m psdesign.study._child``) in its own session, which is killed
(SIGKILL to the process group) when the time is up, so a runaway case is really stopped.
"""

from __future__ import annotations

import datetime as _dt
import errno
import json
import math
import os
import signal
import socket
import subprocess
import sys
import time
import traceback
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from psdesign.errors import warn_at_caller
from psdesign.io.atomic import json_default
from psdesign.io.child_env import child_env
from psdesign.io.diskfull import is_disk_full
from psdesign.study.casefn import DEFAULT_CASE_FN, case_fn_name, imports_back, load_case_fn

__all__ = ["DEFAULT_CASE_FN", "execute_case", "load_case_fn", "normalize_results"]

_AXES = "xyz"


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="milliseconds")


def _scalar(v: Any) -> Any:
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, Path):
        return str(v)
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else v
    return v


#: Result columns holding a picture a case wrote into its folder (the report reads them
#: relative to the study folder; ``fields_png`` was absolute until session 45, so the same
#: study in two folders gave two tables, and a moved folder lost its report's field pictures).
PICTURE_COLUMNS = ("preview_png", "fields_png")


def normalize_results(results: Any, out_dir: Path | None = None) -> dict:
    """Flatten a case function's result dict into JSON-friendly scalars.

    ``k_tensor_m2`` given as 9 values or a 3x3 array becomes ``k_xx_m2`` ... ``k_zz_m2``;
    The pictures (:data:`PICTURE_COLUMNS`: ``preview_png``, ``fields_png``) are stored relative
    to ``out_dir`` when they lie inside it, so a table does not depend on where its folder is;
    other arrays are kept as lists.

    >>> normalize_results({"fields_png": "/o/cases/c0/fields/flow_z.png"}, Path("/o"))
    {'fields_png': 'cases/c0/fields/flow_z.png'}

    Raises
    ------
    TypeError
        If ``results`` is not a mapping.
    """
    if not isinstance(results, dict):
        raise TypeError(f"case function returned {type(results).__name__}, expected a dict")
    out: dict[str, Any] = {}
    for k, v in results.items():
        k = str(k)
        if k == "k_tensor_m2" and v is not None:
            arr = np.asarray(v, dtype=float).reshape(-1)
            if arr.size != 9:
                raise TypeError(f"k_tensor_m2 has {arr.size} values, expected 9")
            for i, a in enumerate(_AXES):
                for j, b in enumerate(_AXES):
                    out[f"k_{a}{b}_m2"] = float(arr[3 * i + j])
            continue
        if k in PICTURE_COLUMNS and v is not None:
            p = Path(v)
            if out_dir is not None:
                try:
                    p = p.resolve().relative_to(Path(out_dir).resolve())
                except ValueError:
                    pass
            out[k] = str(p)
            continue
        if isinstance(v, np.ndarray):
            v = v.tolist()
        if isinstance(v, list | tuple):
            v = [_scalar(x) for x in v]
        elif isinstance(v, dict):
            v = {str(a): _scalar(b) for a, b in v.items()}
        else:
            v = _scalar(v)
        out[k] = v
    return out


def _one_line(exc: BaseException) -> str:
    msg = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__


def _kill_group(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError, AttributeError):
        try:
            proc.kill()
        except ProcessLookupError:
            pass
    proc.wait()


def importable_case_fn_name(case_fn: Callable | str | None) -> str:
    """:func:`~psdesign.study.casefn.case_fn_name` of ``case_fn``, sent to the per-case child
    process as text, checked to import back to ``case_fn`` itself.

    Raises
    ------
    ValueError
        If a callable cannot be imported back by that name (a lambda, a nested function, a
        partial, a callable instance), or is a script's (``__main__``: the child's
        ``__main__`` is its own module, not the script).
    """
    name = case_fn_name(case_fn)
    if case_fn is None or isinstance(case_fn, str):
        return name
    if not imports_back(name, case_fn) or "<" in name or name.startswith("__main__:"):
        raise ValueError(
            f"case_fn: with a timeout the case function must be importable as module:function, "
            f"got {name}"
        )
    return name


def _run_in_child(payload: dict, workdir: Path) -> tuple[str, dict | None, str | None]:
    """Run the case in a killable child process.  Returns (status, results, error).

    The case goes to the child as JSON on its stdin; the child writes its result as JSON (+ an
    npz for arrays) which is validated on read (:func:`psdesign.study.exchange.read_result`).
    Nothing read back from disk is ever unpickled.
    """
    from psdesign.study.exchange import CaseExchangeError, read_result, result_paths

    job = {
        "case_id": str(payload.get("case_id", "?")),  # its warnings in case.log name it
        "case_fn": importable_case_fn_name(payload["case_fn"]),
        "spec": payload["spec"],
        "outputs": list(payload["outputs"]),
        "solver": payload["solver"],
        "workdir": str(workdir),
        # the share the case is held to in the child too (run_case_inline)
        "at_once": int(payload.get("at_once", 1)),
        "workers_option": str(payload.get("workers_option", "workers")),
    }
    data = json.dumps(job, default=json_default).encode()
    outp, arrays = result_paths(workdir)
    outp.unlink(missing_ok=True)
    arrays.unlink(missing_ok=True)
    timeout = float(payload["timeout_s"])
    t0 = time.perf_counter()
    with open(workdir / "case.log", "ab") as log:
        proc = subprocess.Popen(
            [sys.executable, "-m", "psdesign.study._child", str(workdir), str(os.getpid())],
            stdout=log,
            stderr=log,
            stdin=subprocess.PIPE,
            env=child_env(),
            start_new_session=True,
        )
        try:
            proc.communicate(data, timeout=timeout)
        except subprocess.TimeoutExpired:
            _kill_group(proc)
            error = f"case exceeded the timeout of {timeout:g} s and was killed"
            # the failed-case line points to error.txt; a timeout has no traceback (session 53)
            (workdir / "error.txt").write_text(
                f"timeout: {error} (its process group, after {time.perf_counter() - t0:.1f} s; "
                "study.timeout_s or --timeout); its output so far is in case.log\n"
            )
            return "timeout", None, error
        except BaseException:
            _kill_group(proc)
            raise
    if not outp.is_file():
        rc = proc.returncode
        sig = ""
        if rc is not None and rc < 0:
            try:
                sig = f" ({signal.Signals(-rc).name})"
            except ValueError:
                sig = ""
        error = f"case process died with exit status {rc}{sig}; see case.log"
        (workdir / "error.txt").write_text(f"{error} (no Python traceback: crash or kill)\n")
        return "failed", None, error
    try:
        res = read_result(workdir)
    except CaseExchangeError as exc:
        return "failed", None, f"unreadable case result: {exc}"
    finally:
        outp.unlink(missing_ok=True)
        arrays.unlink(missing_ok=True)
    if res["ok"]:
        return "ok", res["results"], None
    if res.get("disk_full"):
        raise OSError(errno.ENOSPC, res["error"])
    (workdir / "error.txt").write_text(res["traceback"])
    return "failed", None, res["error"]


#: Result keys whose False value marks a case ``not_converged``: the key itself, with a
#: suffix (``converged_z``) or as the last part of a column name (``diffusivity_z_converged``).
TRUST_FLAGS = ("converged", "trusted", "trustworthy")


def _is_key(k: str, name: str) -> bool:
    return k == name or k.startswith(name + "_") or k.endswith("_" + name)


def untrusted_reason(results: dict) -> str | None:
    """Why a case's results cannot be trusted, or None.

    A case is ``not_converged`` when any ``converged`` / ``converged_*`` / ``*_converged`` (or
    ``trusted``, ``trustworthy`` in the same forms) result is False, or a ``status`` /
    ``status_*`` result is a string other than a trusted one (``"ok"``, ``"converged"``,
    ``"at_bound"``: :data:`psdesign.status.TRUSTED`), or a ``*_status``
    result is ``"not_converged"``. A K whose ``k_<d>_status`` is ``"untrustworthy"`` (error
    bar above 20 % or < 8 cells per fiber diameter) keeps the case ``ok``: its status column
    says so beside the number, and ``study run`` counts those cases and exits 3
    (:func:`psdesign.cli.exit_status.case_masks`).
    """
    from psdesign.status import TRUSTED

    bad = []
    for k, v in results.items():
        flag = any(_is_key(k, f) for f in TRUST_FLAGS)
        if flag and v is False:
            bad.append(f"{k}=False")
        elif (k == "status" or k.startswith("status_")) and isinstance(v, str):
            if v.strip().lower() not in TRUSTED:  # the exit rule's trusted statuses
                bad.append(f"{k}={v}")
        elif k.endswith("_status") and v == "not_converged":
            bad.append(f"{k}={v}")
    if not bad:
        return None
    return "not converged or flagged: " + ", ".join(sorted(bad))


def run_case_inline(payload: dict, workdir: Path) -> dict:
    """Call the case function in this process (no isolation, no timeout: a worker; with a
    timeout the case's child process, :mod:`psdesign.study._child`); the warnings it raises
    are shown once each, after it, naming the case (:func:`show_case_warnings`)."""
    from psdesign.schema.budget import concurrent_workers

    fn = load_case_fn(payload["case_fn"])
    caught: list = []
    # held to its worker's share while it runs (an "auto" permeameter's longer stack was
    # checked against the whole machine in each of N workers until session 54's review)
    share = concurrent_workers(payload.get("at_once", 1), payload.get("workers_option", "workers"))
    try:
        with share, warnings.catch_warnings(record=True) as caught:  # the filters decide
            return fn(payload["spec"], list(payload["outputs"]), payload["solver"], workdir)
    finally:
        show_case_warnings(caught, str(payload.get("case_id", "?")))


def show_case_warnings(caught: list, case_id: str | None) -> None:
    """Show each warning of ``caught`` once (the same text from another line or direction
    too), as ``case <case_id>: <message>``: a study of many cases printed "voxel grid has 7.0
    voxels ..." once per case with nothing saying which (session 42). ``case_id`` None: the
    warnings of the whole study's specs, checked before its cases run
    (:func:`psdesign.study.runner.validate_case_specs`), each text once, without a case.

    Parameters
    ----------
    caught : list of warnings.WarningMessage
        What ``warnings.catch_warnings(record=True)`` recorded.
    case_id : str or None
        The case's id (``c0003-3fa2b91c``), or None for the study's.
    """
    seen: set[tuple[type, str]] = set()
    for w in caught:
        text = " ".join(str(w.message).split())
        if (w.category, text) not in seen:
            seen.add((w.category, text))
            warn_at_caller(text if case_id is None else f"case {case_id}: {text}", w.category)


def execute_case(payload: dict) -> dict:
    """Run one case and return its record (never raises for a failing case).

    Parameters
    ----------
    payload : dict
        ``case_id``, ``spec``, ``outputs``, ``solver``, ``workdir``, ``out_dir``, ``case_fn``
        (callable or ``"module:attr"``), ``timeout_s`` (None for no limit) and ``at_once``
        with ``workers_option`` (the run's workers at once, whose share of the memory the
        case is held to while it runs, :func:`psdesign.schema.budget.concurrent_workers`).

    Returns
    -------
    dict
        ``status``, ``error``, ``results``, ``wall_time_s``, ``started_at``, ``finished_at``,
        ``host``, ``pid``.
    """
    t0 = time.perf_counter()
    started = _now()
    workdir = Path(payload["workdir"])
    status, results, error, disk_full = "failed", None, None, False
    try:
        workdir.mkdir(parents=True, exist_ok=True)
        # an earlier attempt's traceback (a full disk, --retry-failed) is not this run's
        (workdir / "error.txt").unlink(missing_ok=True)
        if payload.get("timeout_s"):
            status, raw, error = _run_in_child(payload, workdir)
        else:
            raw = run_case_inline(payload, workdir)
            status = "ok"
        if status == "ok":
            results = normalize_results(raw, payload.get("out_dir"))
            reason = untrusted_reason(results)
            if reason is not None:
                status, error = "not_converged", reason
    except Exception as exc:  # noqa: BLE001 - a failing case is data, not a crash
        status, results, error = "failed", None, _one_line(exc)
        disk_full = is_disk_full(exc)
        try:
            (workdir / "error.txt").write_text(traceback.format_exc())
        except OSError:
            pass
    record = {
        "status": status,
        "error": error,
        "results": results or {},
        "wall_time_s": time.perf_counter() - t0,
        "started_at": started,
        "finished_at": _now(),
        "host": socket.gethostname(),
        "pid": os.getpid(),
    }
    if disk_full:  # not the case's failure: the runner stops and does not record it
        record["disk_full"] = True
    return record
