"""Refuse a study output folder that holds another study's results (before any work).

``study run B.toml -o OUT`` on the folder of study A replaced A's tables and report with
B's. A folder is another study's when the ``study.json`` it holds names another study
**and** another base spec: a renamed study file (its name defaults to the file's stem) and
an edited base each still resume, as do ``rev`` (always named ``rev``) and ``optimize``
(the study's own name and base, round after round). A folder without a readable
``study.json`` (new, older psdesign, damaged) is not judged here.
"""

from __future__ import annotations

import json
from pathlib import Path

from psdesign.study.readback import read_json_object
from psdesign.study.store import jsonable
from psdesign.study.studyfile import Study, StudyError


def stored_study(out_dir: str | Path) -> dict | None:
    """The ``study`` table of ``out_dir/study.json``, or None (no file, unreadable, no table).

    Parameters
    ----------
    out_dir : str or Path
        A study output folder.

    Returns
    -------
    dict or None
        ``name``, ``base``, ... as :meth:`Study.to_dict` wrote them.
    """
    try:
        data = read_json_object(Path(out_dir) / "study.json")
    except (OSError, ValueError):  # none, unreadable or not an object: not judged
        return None
    table = data.get("study")
    return table if isinstance(table, dict) else None


def _normal(value: object) -> object:
    """``value`` as it reads back from ``study.json`` (tuples as lists, numpy as Python)."""
    return json.loads(json.dumps(jsonable(value)))


def check_same_study(study: Study, out_dir: str | Path, option: str = "-o") -> None:
    """Raise :class:`StudyError` when ``out_dir`` holds another study's results.

    Parameters
    ----------
    study : Study
        The study about to run.
    out_dir : str or Path
        Its output folder.
    option : str
        How the message names the folder (``-o``; ``out_dir`` in the Python API).

    Raises
    ------
    StudyError
        The stored ``study.json`` names another study and another base spec.
    """
    stored = stored_study(out_dir)
    if stored is None or "name" not in stored or "base" not in stored:
        return
    if stored["name"] == study.name or _normal(stored["base"]) == _normal(study.base):
        return
    raise StudyError(
        f"{option}: {out_dir} holds the results of study {stored['name']!r} (another name and "
        f"base spec than {study.name!r}); give another {option} folder, or to resume that "
        f"study with an edited file keep its name: name = {json.dumps(stored['name'])} in [study]"
    )
