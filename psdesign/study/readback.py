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

__all__ = [
    "REQUIRED_COLUMNS",
    "cases_not_run",
    "design_cases",
    "read_json_object",
    "read_results",
    "resume_command",
]

#: The column every ``results.csv`` ``study run`` writes has and every reader keys on: a table
#: without it (a file overwritten by hand, another program's CSV) is unreadable, not a study of
#: 0 cases (walk-cli finding 1, session 52: ``study report`` exited 0 on it). ``status`` is not
#: required: a table of values alone reads as every case ``ok`` (session 45,
#: ``tests/cli/test_exit_joins.py``'s ``no_status_column``).
REQUIRED_COLUMNS = ("case_id",)


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
        No ``results.csv``, or one that is empty, not UTF-8, not CSV or without a column of
        :data:`REQUIRED_COLUMNS`: one line naming it.
    """
    path = Path(out_dir) / "results.csv"
    if not path.is_file():
        raise ValueError(f"out_dir: no results.csv in {out_dir}; run the study first")
    try:
        df = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise _unreadable(path, " ".join(str(exc).split())) from None
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        raise _unreadable(path, f"no {' or '.join(missing)} column: not a study run's table")
    return df


def cases_not_run(out_dir: str | Path, df: pd.DataFrame) -> tuple[int, int]:
    """How many of the cases ``study.json`` lists have no row in ``df``, and how many it lists.

    A study interrupted before its last case (or a study grown by a rerun that did not
    finish) has fewer rows than its design: ``study report`` says so in the report's header
    and exits 3 instead of showing "cases 1" as if that were the study.

    Parameters
    ----------
    out_dir : str or Path
        A study output folder.
    df : pandas.DataFrame
        Its ``results.csv`` (:func:`read_results`).

    Returns
    -------
    tuple of int
        ``(n_not_run, n_design)``; ``(0, 0)`` without a ``study.json`` or a case list in it.

    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / "study.json").write_text('{"cases": [{"case_id": "a"}, {"case_id": "b"}]}')
    >>> cases_not_run(d, pd.DataFrame({"case_id": ["a"], "status": ["ok"]}))
    (1, 2)
    """
    path = Path(out_dir) / "study.json"
    if not path.is_file():
        return 0, 0
    ids = {c.get("case_id") for c in design_cases(read_json_object(path), path)}
    return len(ids - set(df["case_id"].astype(str))), len(ids)


def design_cases(design: dict, path: Path) -> list[dict]:
    """The case records of a ``study.json`` read as ``design`` (from ``path``): its ``cases``
    list, entries that are not objects left out. A ``cases`` that is not a list is a damaged
    file, one line (exit 2): every reader of the list goes through here (review C and F,
    session 52: ``{"cases": 5}`` was a TypeError traceback, twice).

    >>> design_cases({"cases": [{"case_id": "a"}, 3]}, Path("study.json"))
    [{'case_id': 'a'}]
    """
    cases = design.get("cases")
    if cases is not None and not isinstance(cases, list):
        raise _unreadable(path, f"cases is a {type(cases).__name__}, not a list")
    return [c for c in cases or [] if isinstance(c, dict)]


def resume_command(out_dir: str | Path) -> str:
    """The ``psdesign`` command that resumes the unfinished study in ``out_dir``: the one its
    marker says made it when that resumes itself (``study optimize``, ``rev``), else
    ``study run``. Review C (session 52): the advice always said ``study run``, and following
    it in an optimize folder rewrote ``results.csv`` with the study file's 4 cases in place of
    the optimizer's 10.

    >>> import tempfile
    >>> resume_command(tempfile.mkdtemp())
    'study run'
    """
    from psdesign.analysis.optimize import OPTIMIZE_COMMAND
    from psdesign.analysis.rev import REV_COMMAND
    from psdesign.io.outputs import read_marker

    # the commands that resume their folder themselves; any other (study run's, or a folder
    # study report marked) resumes with study run
    command = str((read_marker(Path(out_dir)) or {}).get("command", ""))
    return command if command in (OPTIMIZE_COMMAND, REV_COMMAND) else "study run"
