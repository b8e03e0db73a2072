"""Resolve the case function (kept free of heavy imports: used in every case's child process)."""

from __future__ import annotations

import importlib
import os
import threading
import time
import types
from collections.abc import Callable
from typing import Any

__all__ = [
    "CASE_FN_ARGUMENTS",
    "CaseFnNotCallable",
    "DEFAULT_CASE_FN",
    "case_fn_call_error",
    "check_case_fn_form",
    "case_fn_name",
    "load_case_fn",
    "runs_pipeline",
    "watch_parent",
]

DEFAULT_CASE_FN = "psdesign.study.case:run_case"
#: Case functions renamed by a layout change; old study folders record the old names.
RENAMED_CASE_FNS = {"psdesign.pipeline:run_case": DEFAULT_CASE_FN}
#: How every case calls it (psdesign.study.worker.run_case_inline): four positional arguments.
CASE_FN_ARGUMENTS = ("spec", "outputs", "solver", "workdir")


def case_fn_name(case_fn: Callable | str | None) -> str:
    """The ``"module:function"`` spelling of a case function, the one every message, record
    (``runs.json``) and child process uses: None is :data:`DEFAULT_CASE_FN`, a string is as
    given, a plain function its own module and qualified name (its globals' ``__name__`` and
    its code's ``co_qualname``: a ``functools.wraps`` adapter names itself, not the function
    whose ``__module__`` / ``__qualname__`` it copied; review s46), unless only the copied
    name imports back to it (a module-level function under a decorator: its module holds the
    wrapper by the wrapped name); another callable its ``__module__`` and ``__qualname__``
    (``?`` for one it lacks: a callable instance or a partial has no ``__qualname__``).

    >>> import functools, json
    >>> case_fn_name(None), case_fn_name("m:f"), case_fn_name(json.dumps)
    ('psdesign.study.case:run_case', 'm:f', 'json:dumps')
    >>> case_fn_name(functools.wraps(json.dumps)(lambda spec, outputs, solver, workdir: {}))
    'psdesign.study.casefn:<lambda>'
    """
    if case_fn is None:
        return DEFAULT_CASE_FN
    if isinstance(case_fn, str):
        return case_fn
    copied = f"{getattr(case_fn, '__module__', '?')}:{getattr(case_fn, '__qualname__', '?')}"
    if not isinstance(case_fn, types.FunctionType):
        return copied
    own = f"{case_fn.__globals__.get('__name__', '?')}:{case_fn.__code__.co_qualname}"
    if own != copied and imports_back(copied, case_fn) and not imports_back(own, case_fn):
        return copied
    return own


def imports_back(name: str, fn: Callable) -> bool:
    """Does ``name`` (``module:qualname``) load ``fn`` itself (:func:`load_case_fn`)?"""
    try:
        return load_case_fn(name) is fn
    except (ImportError, AttributeError, ValueError):
        return False


def runs_pipeline(case_fn: Callable | str | None) -> bool:
    """Is ``case_fn`` psdesign's own case function (None, its name, an old name of it, or the
    function itself)? Only then does a study plan the route's memory and time before any work
    (``psdesign.schema.budget.unplanned_route``) and check each case's spec as the pipeline
    runs it; another case function builds and solves what it chooses.

    >>> runs_pipeline(None), runs_pipeline("psdesign.pipeline:run_case"), runs_pipeline("m:f")
    (True, True, False)
    """
    name = case_fn_name(case_fn)
    return RENAMED_CASE_FNS.get(name, name) == DEFAULT_CASE_FN


def check_case_fn_form(case_fn: object) -> None:
    """Refuse, without importing anything, a ``case_fn`` that is neither None, a callable nor
    ``"module:function"`` text: one :class:`~psdesign.errors.StudyError` line (a
    ``ValueError``) naming ``case_fn``. The one rule of :func:`load_case_fn` and of
    :func:`psdesign.study.studyfile.load_study`, which wrote it again until session 47 (and
    took a name without a colon).

    >>> check_case_fn_form("study_cases:fake_case")
    >>> check_case_fn_form("fake_case")
    Traceback (most recent call last):
    ...
    psdesign.errors.StudyError: case_fn: expected a callable or 'module:function', got 'fake_case'
    """
    if case_fn is None or callable(case_fn) or (isinstance(case_fn, str) and ":" in case_fn):
        return
    from psdesign.errors import StudyError, short

    raise StudyError(f"case_fn: expected a callable or 'module:function', got {short(case_fn)}")


class CaseFnNotCallable(ValueError):
    """What a ``"module:function"`` ``case_fn`` names is not callable: its line names
    ``case_fn`` and the name, as a case's record shows it (:func:`load_case_fn` runs in each
    case too); ``kind`` is the type's name, for :class:`~psdesign.study.options.RunOptions`'
    own line.

    >>> str(CaseFnNotCallable("json:__name__", "str"))
    "case_fn: 'json:__name__' names a str, which is not callable"
    """

    def __init__(self, case_fn: str, kind: str) -> None:
        super().__init__(case_fn, kind)  # both in args: a pickled copy (a worker's) rebuilds
        self.case_fn, self.kind = case_fn, kind

    def __str__(self) -> str:
        return f"case_fn: {self.case_fn!r} names a {self.kind}, which is not callable"


def load_case_fn(case_fn: Callable | str | None) -> Callable:
    """Resolve a case function: a callable, ``"module:attr"``, or None (the default pipeline).

    Raises
    ------
    ValueError
        If ``case_fn`` is no callable or ``"module:attr"`` string
        (:func:`check_case_fn_form`), or what it names is not callable
        (:class:`CaseFnNotCallable`).
    ImportError, AttributeError
        If the module or attribute does not exist.
    """
    check_case_fn_form(case_fn)
    if case_fn is None:
        case_fn = DEFAULT_CASE_FN
    if callable(case_fn):
        return case_fn
    name, case_fn = case_fn, RENAMED_CASE_FNS.get(case_fn, case_fn)
    mod, _, attr = case_fn.partition(":")
    obj: Any = importlib.import_module(mod)
    for part in attr.split("."):
        obj = getattr(obj, part)
    if not callable(obj):
        # its own line names case_fn and the name: a case's record showed "ValueError: it
        # names a str, which is not callable", naming neither (review s48)
        raise CaseFnNotCallable(name, type(obj).__name__)
    return obj


def case_fn_call_error(fn: Callable) -> str:
    """Why ``fn`` cannot be called as ``fn(spec, outputs, solver, workdir)``, or ``""``.

    Checked once before a study runs: a function of other arguments failed every case with a
    TypeError after the output folder was made. A callable whose signature Python cannot
    read (some builtins) is given the benefit of the doubt. The signature read is ``fn``'s own,
    not the one ``functools.wraps`` copied from the function it wraps (``__wrapped__``): the
    worker calls ``fn`` itself.

    >>> case_fn_call_error(lambda spec, outputs, solver, workdir: {})
    ''
    >>> case_fn_call_error(lambda spec: {})
    'too many positional arguments'
    """
    import inspect

    try:
        inspect.signature(fn, follow_wrapped=False).bind(*CASE_FN_ARGUMENTS)
    except TypeError as exc:  # the arguments do not fit
        return " ".join(str(exc).split())
    except ValueError:  # no signature to read
        return ""
    return ""


def watch_parent(parent_pid: int, interval_s: float = 0.5) -> None:
    """Exit this process at once when ``parent_pid`` is gone (it was killed, e.g. kill -9).

    Runs a daemon thread; used by pool workers and per-case child processes so that no orphan
    keeps computing (or writing into the output folder) after the runner died.
    """

    def _watch() -> None:
        while True:
            if os.getppid() != parent_pid:
                os._exit(70)
            time.sleep(interval_s)

    threading.Thread(target=_watch, name="psdesign-watch-parent", daemon=True).start()
