"""The parts every printed result line shares (``permeability``, ``diffusivity``,
``conductivity``): the error bar after the value, then its rating, ``[status]  bc B  converged
true|false``, so a reader finds the same words in the same place on every line; and the one
printer of every command's ``--json`` object (:func:`print_json`, strict JSON)."""

from __future__ import annotations


def error_bar(rel_error: float | None) -> str:
    """`` +- 3.1 %`` after a value, or "" without an estimate; a bar under 0.05 % keeps one
    significant digit (it printed ``+- 0.0 %`` before session 32).

    >>> error_bar(0.031), error_bar(None), error_bar(0.00004)
    (' +- 3.1 %', '', ' +- 0.004 %')
    """
    if rel_error is None:
        return ""
    pct = 100 * rel_error
    return f" +- {pct:.1f} %" if pct >= 0.05 or pct == 0 else f" +- {pct:.1g} %"


def rating(r: dict) -> str:
    """``[status]  bc B  converged true|false`` of a result dict (without ``bc`` where the
    result has none: the pore scan).

    >>> rating({"status": "ok", "bc": "periodic", "converged": False})
    '[ok]  bc periodic  converged false'
    >>> rating({"status": "ok", "converged": True})
    '[ok]  converged true'
    """
    bc = f"  bc {r['bc']}" if "bc" in r else ""
    return f"[{r['status']}]{bc}  converged {str(r['converged']).lower()}"


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
