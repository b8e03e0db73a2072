"""The output of the Laplace commands (``diffusivity``, ``conductivity``): the per-direction
results combined for ``--direction all``, the blocked-direction messages, JSON or one line per
direction, and the exit status."""

from __future__ import annotations

import sys
from collections.abc import Callable

from psdesign.cli.exit_status import status_code
from psdesign.cli.lines import print_json


def combine(results: list[dict], bc: str, keys: tuple[str, ...]) -> dict:
    """One result as it is; several as ``{"direction": "all", ..., key: {d: value}}`` for each
    of ``keys``, converged when all are, with the worst ``status``, every warning and the
    porosity (with its error) they share.

    >>> combine([{"direction": "x", "D": 0.5, "converged": True, "status": "ok", "porosity": 0.8},
    ...          {"direction": "z", "D": 0.4, "converged": False, "status": "not_converged"}],
    ...         "periodic", ("D",))["status"]
    'not_converged'
    """
    from psdesign.transport.effective import worst_status

    if len(results) == 1:
        return results[0]
    out = {
        "direction": "all",
        "bc": bc,
        "porosity": results[0].get("porosity"),
        "porosity_error": results[0].get("porosity_error"),
        "results": results,
    }
    for key in keys:
        out[key] = {r["direction"]: r[key] for r in results}
    out["converged"] = all(r["converged"] for r in results)
    out["status"] = worst_status([r["status"] for r in results])
    out["warnings"] = [w for r in results for w in r.get("warnings", [])]
    return out


def emit(
    name: str, out: dict, results: list[dict], as_json: bool, line: Callable[[dict], str]
) -> int:
    """Print the blocked directions' messages and every warning on stderr, then ``out`` as JSON
    or ``line(r)`` per result on stdout (the line carries its error bar, ``[status]`` and
    ``converged``: :mod:`psdesign.lines`); 0 when every result's status is ``ok``, else 3
    (``untrustworthy``, ``not_converged``, ``blocked``: :func:`psdesign.cli.exit_status.
    status_code`)."""
    from psdesign.progress import warning

    for r in results:
        if r["blocked"]:
            print(f"psdesign: {name} {r['direction']}: {r['message']}", file=sys.stderr)
        for w in r.get("warnings", []):
            warning(w)
    if as_json:
        print_json(out)  # strict JSON: NaN as null (cli.lines)
    else:
        for r in results:
            print(line(r))
    return status_code(*(r.get("status") for r in results))


def laplace_progress(args, direction: str):
    """Progress lines of a Laplace (CG) solve on stderr; None with ``--quiet``."""
    from psdesign.progress import progress_printer

    return None if args.quiet else progress_printer(direction, solve="Laplace solve", method="CG")
