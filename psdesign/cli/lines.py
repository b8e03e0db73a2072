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


#: Each solve's printed value: its result key, its relative error's key, its name (``{d}``:
#: the direction) and format (``{unit}``: the result's ``conductivity_unit``), for
#: :func:`value_text`, the one spelling of the command lines and the field pictures' titles.
VALUE_FORMATS = {
    "permeability": ("permeability_m2", "permeability_rel_error", "K_{d}", "{:.4e} m^2"),
    "diffusivity": ("relative_diffusivity", "rel_error", "D_eff/D_{d}", "{:.4f}"),
    "conductivity": ("effective_conductivity", "rel_error", "sigma_eff_{d}", "{:.5g} {unit}"),
}


def value_text(quantity: str, direction: str, r: dict) -> str:
    """A result's value with its error bar, as its printed line starts (``quantity`` one of
    :data:`VALUE_FORMATS`); "" without the value. The command lines and the field pictures'
    titles (:func:`psdesign.fields.writer.result_words`) spelled it each until session 49.

    >>> value_text("permeability", "z", {"permeability_m2": 2.1678e-11,
    ...            "permeability_rel_error": 0.086})
    'K_z = 2.1678e-11 m^2 +- 8.6 %'
    >>> value_text("conductivity", "x", {"effective_conductivity": 0.035215,
    ...            "conductivity_unit": "W/(m K)", "rel_error": None})
    'sigma_eff_x = 0.035215 W/(m K)'
    """
    key, rel, name, fmt = VALUE_FORMATS[quantity]
    value = r.get(key)
    if value is None:
        return ""
    text = fmt.format(value, unit=r.get("conductivity_unit", ""))
    return f"{name.format(d=direction)} = {text}{error_bar(r.get(rel))}"


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
