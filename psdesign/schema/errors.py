"""Turn pydantic validation errors into one-line :class:`SpecError` / :class:`StudyError`.

The message names the dotted key path (``fibers[2].diameter``, ``generator.theta.low``) and
ends with ``(allowed: ...)``: the field's documented range (its ``description``, the same text
as the docs key table), or the bounds carried by the error.
"""

from __future__ import annotations

import difflib
import re
import types
import typing
from typing import Any

from pydantic import BaseModel, ValidationError
from pydantic_core import PydanticCustomError

from psdesign.errors import SpecError
from psdesign.schema.types import short

__all__ = ["did_you_mean", "dotted", "fail_error", "field_allowed", "spec_error", "spec_errors"]

_BOUND_TEXT = {"gt": "> {}", "ge": ">= {}", "lt": "< {}", "le": "<= {}"}


def did_you_mean(key: str, allowed: typing.Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest allowed name, or ``""``."""
    close = difflib.get_close_matches(key, list(allowed), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def dotted(parts: typing.Iterable[Any]) -> str:
    """``("fibers", 2, "diameter")`` -> ``"fibers[2].diameter"``."""
    out = ""
    for p in parts:
        if isinstance(p, int):
            out += f"[{p}]"
        elif p != "":
            out += f".{p}" if out else str(p)
    return out


_TYPE_NAMES = {"str", "int", "float", "bool", "list", "tuple", "dict", "none"}
_WRAPPERS = ("function-", "literal", "tagged-union", "nullable", "union", "lax-or-strict")


def _clean_loc(loc: tuple) -> tuple:
    # union tags ("dist=uniform"), union members ("list[literal[...]]") and pydantic's
    # function wrappers are not spec keys
    def is_key(p: Any) -> bool:
        if not isinstance(p, str):
            return True
        return not ("=" in p or "[" in p or "'" in p or p in _TYPE_NAMES or p.startswith(_WRAPPERS))

    return tuple(p for p in loc if is_key(p))


def _models(tp: Any) -> list[type[BaseModel]]:
    """Model classes reachable from an annotation (through Optional, Annotated, list, dict)."""
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [tp]
    origin = typing.get_origin(tp)
    if origin is typing.Annotated:
        return _models(typing.get_args(tp)[0])
    out: list[type[BaseModel]] = []
    if origin in (typing.Union, types.UnionType, list, tuple, dict):
        for arg in typing.get_args(tp):
            out += _models(arg)
    return out


def field_allowed(root: Any, loc: tuple) -> str:
    """The ``description`` of the field at ``loc`` under ``root`` (a model or annotation)."""
    cands = _models(root)
    desc = ""
    for part in loc:
        if isinstance(part, int):
            continue
        nxt: list[type[BaseModel]] = []
        found = False
        for m in cands:
            info = m.model_fields.get(part)
            if info is not None:
                if not found:
                    desc = info.description or ""
                found = True
                nxt += _models(info.annotation)
        if not found:
            return ""
        cands = nxt
    return desc


def _message(err: dict, root: Any, loc: tuple) -> tuple[str, str]:
    """(relative key suffix, message) for one pydantic error dict."""
    ctx = err.get("ctx") or {}
    typ = err["type"]
    if typ == "psdesign":
        allowed = ctx.get("allowed", "")
        return ctx.get("key", ""), ctx["message"] + (f" (allowed: {allowed})" if allowed else "")
    allowed = field_allowed(root, loc)
    got = short(err.get("input"))
    if typ in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        bound = {"greater_than": "gt", "greater_than_equal": "ge", "less_than": "lt"}.get(typ, "le")
        limit = _BOUND_TEXT[bound].format(ctx.get(bound))
        msg = f"must be {limit}, got {got}"
    elif typ == "missing":
        msg = "missing"
    elif typ == "literal_error":
        names = re.findall(r"'([^']*)'", str(ctx.get("expected", "")))
        return "", f"got {got}; allowed: {', '.join(names)}"
    elif typ in ("model_type", "dict_type", "model_attributes_type"):
        msg = f"must be a table, got {got}"
    elif typ in ("tuple_type", "list_type", "too_short", "too_long"):
        msg = f"must be a list of the allowed length, got {got}"
    elif typ == "union_tag_invalid":
        tag = str(ctx.get("tag", "")).partition("=")[2]
        names = [t.strip(" '").partition("=")[2] for t in str(ctx.get("expected_tags")).split(",")]
        return "dist", f"got {tag!r} (allowed: {', '.join(n for n in names if n != 'number')})"
    elif typ == "union_tag_not_found":
        return "dist", f"missing (allowed: {allowed or 'a distribution name'})"
    elif typ == "string_type":
        msg = f"must be a string, got {got}"
    else:
        msg = str(err.get("msg", "invalid value"))
        if (typ.endswith("_type") or typ.endswith("_parsing")) and "got" not in msg:
            msg = f"{msg}, got {got}"
    return "", msg + (f" (allowed: {allowed})" if allowed else "")


def _first(exc: ValidationError) -> dict:
    """The most specific error of ``exc`` (a union reports one per member; the deepest
    names the key)."""
    errs = exc.errors(include_url=False)
    return max(errs, key=lambda e: len(_clean_loc(tuple(e["loc"]))))


def _line(err: dict, root: Any, prefix: str) -> tuple[str, str]:
    """(dotted key, one-line message) of one pydantic error dict."""
    loc = _clean_loc(tuple(err["loc"]))
    suffix, msg = _message(err, root, loc)
    key = dotted((prefix, *loc, *(suffix.split(".") if suffix else ())))
    msg = " ".join(msg.split())  # one line
    return key or (prefix or "spec"), msg


def first_error(exc: ValidationError, root: Any, prefix: str = "") -> tuple[str, str]:
    """(dotted key, one-line message) of the first error of ``exc``."""
    return _line(_first(exc), root, prefix)


def spec_errors(exc: ValidationError, root: Any, prefix: str = "") -> list[SpecError]:
    """Every error of ``exc`` as a :class:`SpecError` (:func:`spec_error` gives the first):
    for a caller that asks about some keys only, whose error may not be the first (a design
    point's value beside a table key the point does not set)."""
    out = []
    for err in exc.errors(include_url=False):
        key, msg = _line(err, root, prefix)
        out.append(SpecError(key, msg, names=(err.get("ctx") or {}).get("names", ())))
    return out


def fail_error(exc: PydanticCustomError) -> SpecError:
    """The :class:`SpecError` of a :func:`psdesign.schema.types.fail` raised outside a
    validation (a route's check with the schema's wording), the same line as
    :func:`spec_error` gives it."""
    ctx = exc.context or {}
    key, msg = _message({"type": "psdesign", "ctx": ctx}, None, ())
    return SpecError(key, " ".join(msg.split()), names=ctx.get("names", ()))


def spec_error(exc: ValidationError, root: Any, prefix: str = "") -> SpecError:
    """A :class:`SpecError` for the first error of ``exc``, with the other keys its message
    names (:func:`psdesign.schema.types.fail`'s ``names``) in ``.names``."""
    key, msg = first_error(exc, root, prefix)
    ctx = _first(exc).get("ctx") or {}
    return SpecError(key, msg, names=ctx.get("names", ()))
