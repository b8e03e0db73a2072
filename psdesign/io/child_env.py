"""The environment of a ``python -m psdesign...`` child process: the parent's, with the
parent's import path (a checkout run with ``PYTHONPATH`` or from its folder imports the same
psdesign in the child)."""

from __future__ import annotations

import os
import sys


def child_env() -> dict[str, str]:
    """``os.environ`` with ``PYTHONPATH`` set to the parent's ``sys.path`` (then its own)."""
    env = dict(os.environ)
    paths = [p for p in sys.path if p]
    if env.get("PYTHONPATH"):
        paths.append(env["PYTHONPATH"])
    env["PYTHONPATH"] = os.pathsep.join(dict.fromkeys(paths))
    return env
