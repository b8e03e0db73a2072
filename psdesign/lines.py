"""The parts every printed result line shares (``permeability``, ``diffusivity``,
``conductivity``, the pore scan): the value with its error bar after it (:func:`value_text`),
then its rating, ``[status]  bc B  converged true|false`` (:func:`rating`), so a reader finds
the same words in the same place on every line: the commands, a result's ``__str__``
(:func:`psdesign.transport.diffusivity.result_line`) and the field pictures' titles
(:func:`psdesign.fields.writer.result_words`). A package root module beside
:mod:`psdesign.notebook` (a result's HTML table); in ``psdesign.cli.lines`` until session 52.
"""

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
