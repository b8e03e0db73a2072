"""A minimal TOML writer for tests (inline tables; nan/inf and deep nesting allowed)."""

from __future__ import annotations

import json
import math


def _s(text: str) -> str:
    """A TOML basic string (JSON escapes, non-ASCII kept: TOML has no surrogate pairs)."""
    return json.dumps(text, ensure_ascii=False)


def value(v) -> str:
    """One TOML value."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _s(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_s(str(k))} = {value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"no TOML for {type(v).__name__}")


def dumps(doc: dict) -> str:
    """A document: top-level tables as ``[name]`` sections, everything inside inline."""
    lines = []
    for k, v in doc.items():
        if isinstance(v, dict):
            lines.append(f"[{_s(str(k))}]")
            lines += [f"{_s(str(kk))} = {value(vv)}" for kk, vv in v.items()]
        else:
            lines.insert(0, f"{_s(str(k))} = {value(v)}")
    return "\n".join(lines) + "\n"
