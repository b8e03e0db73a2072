"""Case input/output between the runner and a per-case child process (``--timeout`` mode).

No pickle: the job goes to the child as JSON on its stdin (:func:`read_job`), and the child's
result comes back as ``.psdesign-case-result.json`` plus ``.psdesign-case-arrays.npz`` for
numpy arrays (loaded with ``allow_pickle=False``).  Whoever can write the output folder can at
most make a case look failed; :func:`read_result` validates the shape of everything it reads.
Kept free of heavy imports (numpy only when arrays are present).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, BinaryIO

__all__ = [
    "CaseExchangeError",
    "read_job",
    "read_result",
    "result_paths",
    "write_result",
]

MAX_RESULT_BYTES = 64 << 20
"""Largest result JSON the runner reads back (a case result is a flat dict of scalars)."""
_ARRAY_TAG = "__psdesign_ndarray__"


class CaseExchangeError(ValueError):
    """A case job or result does not have the expected shape."""


def result_paths(workdir: Path) -> tuple[Path, Path]:
    """``(json, npz)`` paths of a case's result in its working folder."""
    workdir = Path(workdir)
    return workdir / ".psdesign-case-result.json", workdir / ".psdesign-case-arrays.npz"


def read_job(stream: BinaryIO) -> dict:
    """Read and validate a case job (JSON) from ``stream``.

    Raises
    ------
    CaseExchangeError
        If it is not ``{"case_id": str, "case_fn": str, "spec": dict, "outputs": [str],
        "solver": str, "workdir": str, "at_once": int, "workers_option": str}``.
    """
    try:
        job = json.loads(stream.read().decode("utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise CaseExchangeError(f"case job is not JSON: {exc}") from None
    types = {
        "case_id": str,
        "case_fn": str,
        "spec": dict,
        "outputs": list,
        "solver": str,
        "workdir": str,
        "at_once": int,  # the run's workers at once: the case's share of the memory
        "workers_option": str,
    }
    if not isinstance(job, dict) or set(job) != set(types):
        raise CaseExchangeError(f"case job must have exactly the keys {sorted(types)}")
    for k, t in types.items():
        if not isinstance(job[k], t):
            raise CaseExchangeError(f"case job: {k} must be {t.__name__}")
    if not all(isinstance(o, str) for o in job["outputs"]):
        raise CaseExchangeError("case job: outputs must be strings")
    return job


def _encode(value: Any, arrays: dict) -> Any:
    import numpy as np

    if isinstance(value, dict):
        return {str(k): _encode(v, arrays) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_encode(v, arrays) for v in value]
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biufc":
            return _encode(value.tolist(), arrays)
        name = f"a{len(arrays)}"
        arrays[name] = value
        return {_ARRAY_TAG: name}
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    if value is None or isinstance(value, bool | int | float | str):
        return value
    raise TypeError(f"case result value of type {type(value).__name__} is not JSON/npz data")


def write_result(workdir: Path, result: dict) -> None:
    """Write a child's result (``{"ok": ...}``) atomically as JSON (+ npz for arrays)."""
    jpath, npath = result_paths(workdir)
    arrays: dict = {}
    try:
        text = json.dumps(_encode(result, arrays))
    except TypeError as exc:
        text = json.dumps(
            {"ok": False, "error": f"TypeError: {exc}", "traceback": f"TypeError: {exc}\n"}
        )
        arrays = {}
    if arrays:
        import numpy as np

        tmp = npath.with_name(f".psdesign-case-arrays.{os.getpid()}.tmp.npz")
        np.savez(tmp, **arrays)
        os.replace(tmp, npath)
    tmp = jpath.with_name(f".psdesign-case-result.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, jpath)


def _decode(value: Any, npz) -> Any:
    if isinstance(value, dict):
        if set(value) == {_ARRAY_TAG}:
            name = value[_ARRAY_TAG]
            if npz is None or not isinstance(name, str) or name not in npz.files:
                raise CaseExchangeError(f"case result names a missing array {name!r}")
            return npz[name]
        return {k: _decode(v, npz) for k, v in value.items()}
    if isinstance(value, list):
        return [_decode(v, npz) for v in value]
    return value


def read_result(workdir: Path) -> dict:
    """Read and validate a child's result.

    Returns
    -------
    dict
        ``{"ok": True, "results": dict}`` or ``{"ok": False, "error": str, "traceback": str}``
        (with ``"disk_full": True`` when the case met a full disk).

    Raises
    ------
    CaseExchangeError
        Missing, too large, not JSON, or not of that shape.
    """
    jpath, npath = result_paths(workdir)
    try:
        if jpath.is_symlink() or jpath.stat().st_size > MAX_RESULT_BYTES:
            raise CaseExchangeError(f"{jpath.name} is a link or larger than {MAX_RESULT_BYTES} B")
        res = json.loads(jpath.read_text())
    except OSError as exc:
        raise CaseExchangeError(f"cannot read {jpath.name}: {exc.strerror or exc}") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise CaseExchangeError(f"{jpath.name} is not JSON: {exc}") from None
    if not isinstance(res, dict) or not isinstance(res.get("ok"), bool):
        raise CaseExchangeError(f"{jpath.name} must be an object with a boolean 'ok'")
    if res["ok"]:
        if set(res) != {"ok", "results"} or not isinstance(res["results"], dict):
            raise CaseExchangeError(f"{jpath.name}: 'results' must be an object")
        npz = None
        if npath.is_file() and not npath.is_symlink():
            import numpy as np

            try:
                npz = np.load(npath, allow_pickle=False)
            except (OSError, ValueError) as exc:
                raise CaseExchangeError(f"{npath.name} is not a valid npz: {exc}") from None
        try:
            return {"ok": True, "results": _decode(res["results"], npz)}
        except ValueError as exc:  # an object array in the npz refused by allow_pickle=False
            raise CaseExchangeError(f"{npath.name}: {exc}") from None
        finally:
            if npz is not None:
                npz.close()
    if not {"ok", "error", "traceback"} <= set(res) <= {"ok", "error", "traceback", "disk_full"}:
        raise CaseExchangeError(f"{jpath.name}: a failure needs 'error' and 'traceback' strings")
    if not all(isinstance(res[k], str) for k in ("error", "traceback")) or not isinstance(
        res.get("disk_full", False), bool
    ):
        raise CaseExchangeError(f"{jpath.name}: a failure needs 'error' and 'traceback' strings")
    return res
