"""What the commands print besides a result's line (:mod:`psdesign.lines`): the one printer
of every command's ``--json`` object (:func:`print_json`, strict JSON) and the porosity's
status of ``generate`` and ``mesh`` (:func:`with_porosity_status`)."""

from __future__ import annotations


def with_porosity_status(out: dict) -> dict:
    """``out`` with ``porosity_status``: the porosity's rating by its bar alone, as a study
    case's (:func:`psdesign.analysis.columns.porosity_status`: ``ok`` up to a 20 % bar), so
    ``generate`` and ``mesh`` print their porosity with a status as every other number (until
    session 45 with its error only).

    >>> with_porosity_status({"porosity": 0.8, "porosity_error": 4e-4})["porosity_status"]
    'ok'
    >>> with_porosity_status({"porosity": 0.01, "porosity_error": 4e-3})["porosity_status"]
    'untrustworthy'
    """
    from psdesign.analysis.columns import porosity_status

    return out | {"porosity_status": porosity_status(out["porosity"], out.get("porosity_error"))}


def print_json(obj: object) -> None:
    """Print ``obj`` as strict JSON: NaN (no value, e.g. no cross-validated error, no CI of
    one seed) as ``null``, as in the files a study writes (Python's ``json.dumps`` printed the
    ``NaN`` token, which JSON has not: ``jq`` and JavaScript refuse the whole output).

    >>> print_json({"a": float("nan"), "b": 1.5})
    {"a": null, "b": 1.5}
    """
    from psdesign.study.store import json_text

    print(json_text(obj))
