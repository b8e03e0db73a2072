"""Read a study output folder's files back (``results.csv``, ``study.json``, ``run.json``).

``study report``, ``study fit`` and ``rev`` read what ``study run`` wrote. A damaged file (cut
short, overwritten by hand, not UTF-8, JSON that is not an object) is one ``ValueError``
naming it: the CLI's one line, exit 2, where ``study fit`` printed pandas' "No columns to
parse from file" and a ``study.json`` holding a list was an ``AttributeError`` traceback.

>>> import tempfile
>>> from pathlib import Path
>>> d = Path(tempfile.mkdtemp())
>>> _ = (d / "study.json").write_text("[1, 2]")
>>> try:
...     read_json_object(d / "study.json")
... except ValueError as exc:
...     print(str(exc).split("study.json ")[1])
is unreadable (JSON but not an object: a list); rerun the study
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

__all__ = ["read_json_object", "read_results"]


def _unreadable(path: Path, why: str) -> ValueError:
    return ValueError(f"out_dir: {path} is unreadable ({why}); rerun the study")


def read_json_object(path: str | Path) -> dict:
    """The JSON object in ``path`` (a file ``study run`` wrote).

    Parameters
    ----------
    path : str or Path
        An existing file of a study output folder.

    Returns
    -------
    dict
        Its content.

    Raises
    ------
    ValueError
        Not UTF-8, not JSON, or JSON that is not an object: one line naming ``path``.
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise _unreadable(path, f"{type(exc).__name__}: {' '.join(str(exc).split())}") from None
    if not isinstance(doc, dict):
        raise _unreadable(path, f"JSON but not an object: a {type(doc).__name__}")
    return doc


def read_results(out_dir: str | Path) -> pd.DataFrame:
    """``OUT/results.csv`` as a table.

    Parameters
    ----------
    out_dir : str or Path
        A study output folder.

    Returns
    -------
    pandas.DataFrame
        One row per finished case.

    Raises
    ------
    ValueError
        No ``results.csv``, or one that is empty, not UTF-8 or not CSV: one line naming it.
    """
    path = Path(out_dir) / "results.csv"
    if not path.is_file():
        raise ValueError(f"out_dir: no results.csv in {out_dir}; run the study first")
    try:
        return pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise _unreadable(path, " ".join(str(exc).split())) from None
