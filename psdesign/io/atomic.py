"""Write output folders atomically: all files appear together, or none do."""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterable, Iterator
from pathlib import Path

from psdesign.io.outputs import TEMP_PREFIX, OutputDir, check_output_dir, staged_output


@contextlib.contextmanager
def staged_directory(
    out_dir: str | Path | OutputDir, replaces: Iterable[str] = ()
) -> Iterator[Path]:
    """Yield a temporary sibling folder; on success move its files into ``out_dir``, and
    remove the files of ``replaces`` (the command's possible outputs) an earlier run left
    there that this one did not write (:func:`psdesign.io.outputs.staged_output`).

    On any exception the temporary folder is removed and ``out_dir`` is left as it was (not
    created if it did not exist).  ``out_dir`` is best checked first with
    :func:`psdesign.io.outputs.check_output_dir` (before the work); a plain path is checked
    here with the same rules and no ``--force``.  Only files psdesign wrote are ever replaced
    (see :mod:`psdesign.io.outputs`).
    """
    out = out_dir if isinstance(out_dir, OutputDir) else check_output_dir(out_dir)
    with staged_output(out, replaces) as tmp:
        yield tmp


def write_json(path: str | Path, data: object) -> None:
    """Write JSON atomically (temp file + rename)."""
    path = Path(path)
    tmp = path.with_name(f"{TEMP_PREFIX}{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, indent=2, default=json_default))
    os.replace(tmp, path)


def json_default(obj: object) -> object:
    """``json.dumps`` ``default=``: numpy arrays and scalars as lists / Python numbers, paths as
    strings (the one encoder of psdesign's JSON files)."""
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")
