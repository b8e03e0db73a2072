"""The parts every printed result line shares (``permeability``, ``diffusivity``,
``conductivity``): the error bar after the value, then its rating, ``[status]  bc B  converged
true|false``, so a reader finds the same words in the same place on every line."""

from __future__ import annotations


def error_bar(rel_error: float | None) -> str:
    """`` +- 3.1 %`` after a value, or "" without an estimate.

    >>> error_bar(0.031), error_bar(None)
    (' +- 3.1 %', '')
    """
    return "" if rel_error is None else f" +- {100 * rel_error:.1f} %"


def rating(r: dict) -> str:
    """``[status]  bc B  converged true|false`` of a result dict.

    >>> rating({"status": "ok", "bc": "periodic", "converged": False})
    '[ok]  bc periodic  converged false'
    """
    return f"[{r['status']}]  bc {r['bc']}  converged {str(r['converged']).lower()}"
