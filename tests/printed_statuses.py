"""Every status a command's ``--json`` printed, for tests that check the exit status against
the rule (:func:`psdesign.cli.exit_status.status_code`) instead of accepting 0 or 3."""

from __future__ import annotations


def printed_statuses(obj) -> list[str]:
    """Every ``status`` / ``*_status`` string in a JSON document, at any depth."""
    out = []
    if isinstance(obj, dict):
        for key, value in obj.items():
            if (key == "status" or key.endswith("_status")) and isinstance(value, str):
                out.append(value)
            else:
                out += printed_statuses(value)
    elif isinstance(obj, list):
        for value in obj:
            out += printed_statuses(value)
    return out
