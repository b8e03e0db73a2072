"""How a study runs: workers or scheduler, the case function, time limits, retries, report.

:class:`RunOptions` holds the options of ``psdesign study run`` for
:func:`psdesign.study.runner.run_study`; each is checked once, on creation.
"""

from __future__ import annotations

import inspect
import numbers
from collections.abc import Callable, Iterable
from dataclasses import dataclass, fields
from typing import Any, NoReturn

from psdesign.errors import short
from psdesign.schema.budget import MAX_TIMEOUT_S
from psdesign.study.address import check_scheduler_address
from psdesign.study.casefn import (
    CASE_FN_ARGUMENTS,
    DEFAULT_CASE_FN,
    case_fn_call_error,
    case_fn_name,
)
from psdesign.study.cluster import DEFAULT_WAIT_S, ClusterOptions, check_wait_s
from psdesign.study.studyfile import StudyError

__all__ = ["RunOptions"]

_FLAGS = ("progress", "retry_failed", "report", "force", "retry_not_converged")


def refuse_unknown_keywords(
    given: Iterable[str], allowed: Iterable[str], caller: str, extra: str = ""
) -> None:
    """The first of ``given`` not in ``allowed``: one :class:`StudyError` line naming it and
    listing the allowed ones (``extra``, a caller's own, before "the runner's" ``allowed``),
    the one wording of every study entry point's unknown keyword (:class:`RunOptions`,
    :func:`~psdesign.study.runner.run_study` and, by
    :func:`~psdesign.study.runner.check_run_keywords`, ``rev_study`` / ``optimize_study``).

    >>> refuse_unknown_keywords(["wrkers"], ["workers", "force"], "f")
    Traceback (most recent call last):
    ...
    psdesign.errors.StudyError: wrkers: not a keyword of f (allowed: force, workers)
    """
    allowed = set(allowed)
    for key in given:
        if key not in allowed:
            listed = ", ".join(sorted(allowed))
            listed = f"{extra} and the runner's {listed}" if extra else listed
            raise StudyError(f"{key}: not a keyword of {caller} (allowed: {listed})")


@dataclass(frozen=True)
class RunOptions:
    """The options of a study run (``psdesign study run``'s, one to one).

    Attributes
    ----------
    workers : int
        Local worker processes; ``0`` runs the cases in this process (debugging).  With a
        scheduler ``"local"`` it is the number of Dask workers; ignored for a remote scheduler
        (>= 1 with any scheduler: :func:`psdesign.study.runner.check_workers`).  Default 1.
    scheduler : str or ClusterOptions, optional
        ``tcp://HOST:PORT`` / ``tls://HOST:PORT`` of a Dask scheduler, ``"local"`` for a local
        Dask cluster, or ``--cluster``'s :class:`~psdesign.study.cluster.ClusterOptions`.
        Default None: the local process pool.
    case_fn : callable or str, optional
        ``case_fn(spec, outputs, solver, workdir) -> dict``; a module-level function (it is
        pickled to workers) or ``"module:function"``.  Default None:
        ``psdesign.study.case:run_case``.
    progress : bool
        Progress bar (TTY) or log lines on stderr; default True.
    timeout_s : float, optional
        Per-case time limit in seconds, in (0, ``MAX_TIMEOUT_S``] (overrides
        ``study.timeout_s``, the default); cases over it are killed and recorded with status
        ``"timeout"``.
    retry_failed : bool
        Re-run cases recorded as ``failed`` or ``timeout`` (``ok`` cases are always skipped);
        default False.
    retry_not_converged : bool
        Re-run cases recorded as ``not_converged`` (otherwise they count as finished); default
        False.
    report : bool
        Write ``OUT/report.html`` at the end; default True.  False removes an earlier
        run's (psdesign's own) before the cases run, so a stopped or failed run leaves none
        showing other cases.
    force : bool
        Accept a non-empty output folder psdesign did not create (``--force``); a file psdesign
        did not write is still never replaced (:mod:`psdesign.io.outputs`).  Default False.
    security : distributed.security.Security, optional
        TLS settings for a remote ``tls://`` scheduler (see
        :func:`psdesign.study.runner.connect_scheduler`); refused without one, as the command
        line refuses ``--tls-*``.
    worker_wait_s : float, optional
        ``--cluster-wait``: seconds (> 0, finite) a Dask run waits while the scheduler has no
        worker at all before it stops with :class:`~psdesign.study.runner.WorkersLost`;
        default (:meth:`wait_s`) a ``ClusterOptions`` scheduler's ``wait_s``, else
        :data:`psdesign.study.cluster.DEFAULT_WAIT_S` (600).

    Raises
    ------
    StudyError
        On creation, one line naming the option and what it allows (a
        :class:`psdesign.errors.SpecError`), an unknown keyword too
        (:func:`refuse_unknown_keywords`).
    SchedulerError
        On creation, one line naming ``scheduler``: its host does not resolve (the address is
        well formed, the name service says no; see
        :func:`psdesign.study.address.check_scheduler_address`).

    Examples
    --------
    >>> opts = RunOptions(workers=0, timeout_s=60, report=False)
    >>> opts.timeout_s, opts.wait_s()
    (60.0, 600.0)
    >>> RunOptions(report="no")
    Traceback (most recent call last):
    ...
    psdesign.errors.StudyError: report: must be True or False, got 'no'
    """

    workers: int = 1
    scheduler: str | ClusterOptions | None = None
    case_fn: Callable | str | None = None
    progress: bool = True
    timeout_s: float | None = None
    retry_failed: bool = False
    retry_not_converged: bool = False
    report: bool = True
    force: bool = False
    security: Any = None
    worker_wait_s: float | None = None

    def __new__(cls, *args: Any, **kwargs: Any) -> RunOptions:
        # an unknown keyword (RunOptions(wrkers=2)): run_study's one StudyError line, not the
        # dataclass's TypeError (session 48); __init__ then takes the arguments
        refuse_unknown_keywords(kwargs, (f.name for f in fields(cls)), "RunOptions")
        return super().__new__(cls)

    def __post_init__(self) -> None:
        from psdesign.study.runner import check_workers  # the runner's rule (runner imports us)

        if self.timeout_s is not None:
            object.__setattr__(self, "timeout_s", _check_timeout(self.timeout_s))
        scheduler = _check_run_arguments(
            self.scheduler, self.case_fn, *(getattr(self, f) for f in _FLAGS)
        )
        object.__setattr__(self, "scheduler", scheduler)  # an address: its host looked up once
        check_workers(self.workers, self.scheduler)  # after the scheduler's type: 0 is refused
        object.__setattr__(self, "workers", int(self.workers))  # a NumPy integer as int
        _check_security(self.security, self.scheduler)
        if self.worker_wait_s is not None:
            try:
                wait_s = check_wait_s(self.worker_wait_s, "worker_wait_s")
            except ValueError as exc:  # the StudyError (a SpecError) of every bad option
                raise StudyError(str(exc)) from None
            object.__setattr__(self, "worker_wait_s", wait_s)

    def case_function(self) -> Callable | str:
        """``case_fn`` or its default, ``DEFAULT_CASE_FN`` (``psdesign.study.case:run_case``)."""
        return DEFAULT_CASE_FN if self.case_fn is None else self.case_fn

    def wait_s(self) -> float:
        """Seconds a Dask run waits with no worker: ``worker_wait_s`` or its default."""
        if self.worker_wait_s is None:
            return getattr(self.scheduler, "wait_s", DEFAULT_WAIT_S)
        return self.worker_wait_s


def _fields_signature(cls: type) -> inspect.Signature:
    """``cls.__init__``'s signature without ``self``: the one :func:`inspect.signature`,
    ``help()`` and IDEs show for ``cls`` (a ``__new__(cls, *args, **kwargs)`` hides it)."""
    init = inspect.signature(cls.__init__)
    return init.replace(
        parameters=list(init.parameters.values())[1:],
        return_annotation=inspect.Signature.empty,
    )


# __new__ (unknown keywords refused in one line) made inspect.signature(RunOptions) and help()
# read "(*args, **kwargs)": the 11 fields were lost to help() and completion (review s48)
RunOptions.__signature__ = _fields_signature(RunOptions)  # type: ignore[attr-defined]


def _check_timeout(timeout_s) -> float:
    if (
        isinstance(timeout_s, bool)
        or not isinstance(timeout_s, numbers.Real)  # NumPy's numbers too, as the schema's
        or not 0 < timeout_s <= MAX_TIMEOUT_S  # also NaN
    ):
        raise StudyError(
            f"timeout_s: must be a number > 0 and <= {MAX_TIMEOUT_S:.0f} (seconds, as "
            f"study.timeout_s), got {short(timeout_s)}"
        )
    return float(timeout_s)


def _check_security(security, scheduler) -> None:
    """``security`` only with a ``tls://`` scheduler, and a ``distributed`` ``Security``: the
    command line's rule for ``--tls-*`` (until session 45 the keyword was accepted and ignored
    without one, so a caller believed the run was encrypted).

    >>> _check_security(None, None)
    >>> _check_security("zz", None)
    Traceback (most recent call last):
    ...
    psdesign.errors.StudyError: security: only with a scheduler tls://HOST:PORT, got scheduler None
    """
    if security is None:
        return
    if not (isinstance(scheduler, str) and scheduler.startswith("tls://")):
        shown = scheduler if isinstance(scheduler, str | None) else type(scheduler).__name__
        raise StudyError(
            f"security: only with a scheduler tls://HOST:PORT, got scheduler {shown!r}"
        )
    from distributed.security import Security

    if not isinstance(security, Security):
        raise StudyError(
            "security: must be a distributed.security.Security (TLS files of the tls:// "
            f"scheduler), got {type(security).__name__}"
        )


#: What ``case_fn`` may be, as a refusal says it.
_CASE_FN_ALLOWED = "allowed: a callable or an importable 'module:function'"


def _check_run_arguments(scheduler, case_fn, *flags: object):
    """The other options, before any work: each flag a bool (a string such as ``report="no"``
    was taken as true), ``scheduler`` an address or the CLI's
    :class:`~psdesign.study.cluster.ClusterOptions` (an int failed in the connection with a
    TypeError), ``case_fn`` loadable here (a misspelled one failed every case after the output
    folder was made; so did one of other arguments than ``(spec, outputs, solver,
    workdir)``).  Returns ``scheduler``, an address as checked
    (:class:`~psdesign.study.address.SchedulerAddress`: its host looked up here, once)."""
    import numpy as np

    for name, value in zip(_FLAGS, flags, strict=True):
        if not isinstance(value, bool | np.bool_):
            raise StudyError(f"{name}: must be True or False, got {short(value)}")
    if scheduler is not None and not isinstance(scheduler, str | ClusterOptions):
        raise StudyError(
            "scheduler: must be an address tcp://HOST:PORT or tls://HOST:PORT, or 'local', "
            f"got {type(scheduler).__name__}"
        )
    if isinstance(scheduler, str):  # before the case function's imports and dask's
        # (one already checked: no lookup); a host that does not resolve: SchedulerError
        scheduler = check_scheduler_address(scheduler, what="scheduler")
    if case_fn is not None:
        _check_case_fn(case_fn)
    return scheduler


def _check_case_fn(case_fn: Callable | str) -> None:
    """``case_fn`` loadable here and callable as a case is called, else one
    :class:`StudyError` line naming it."""
    from psdesign.study.casefn import CaseFnNotCallable, check_case_fn_form, load_case_fn

    try:
        check_case_fn_form(case_fn)
    except StudyError:  # the form's rule is the line's "allowed": its own line in the
        # brackets said the key, the value and the rule twice (session 48)
        why = "no ':' between module and function" if isinstance(case_fn, str) else None
        _cannot_load(case_fn, why or f"{type(case_fn).__name__} is not callable")
    try:  # apart from the form: a StudyError its module raises while importing is its own
        # (review s48: it was told "no ':' between module and function")
        fn = load_case_fn(case_fn)
    except CaseFnNotCallable as exc:  # its line names case_fn and the name, as this one does
        _cannot_load(case_fn, f"it names a {exc.kind}, which is not callable")
    except (StudyError, ModuleNotFoundError, AttributeError) as exc:  # a refusal of the
        # module's own, or no such module or function: their text names it
        _cannot_load(case_fn, _text(exc))
    except (Exception, SystemExit) as exc:  # anything else its module raised while importing:
        # a RuntimeError was a traceback from RunOptions / study run (session 49)
        _cannot_load(case_fn, f"importing it raised {type(exc).__name__}: {_text(exc)}")
    why = case_fn_call_error(fn)
    if why:  # it failed every case with a TypeError, the output folder made
        raise StudyError(
            f"case_fn: {case_fn_name(case_fn)!r} cannot be called as case_fn("
            f"{', '.join(CASE_FN_ARGUMENTS)}) ({why}); allowed: a function of those four "
            "arguments returning a dict"
        )


def _text(exc: BaseException) -> str:
    """``exc``'s message on one line (``SystemExit(2)``'s is its code)."""
    return " ".join(str(exc).split())


def _cannot_load(case_fn: object, why: str) -> NoReturn:
    """The one line of a ``case_fn`` that cannot be loaded, ``why`` in brackets."""
    raise StudyError(f"case_fn: cannot load {short(case_fn)} ({why}); {_CASE_FN_ALLOWED}") from None
