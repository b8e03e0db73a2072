"""Error types shared by all stages."""

from __future__ import annotations

import os
import re
import sys
import warnings


class SpecError(ValueError):
    """A bad value in a spec or study file.

    Parameters
    ----------
    key : str
        Dotted path of the offending key, e.g. ``"fibers[2].diameter"``.
    message : str
        What is wrong and what is allowed.
    names : tuple of str
        Other spec keys ``message`` names as written (a memory refusal's ``"a coarser
        rve.voxel"``): a study re-spells them as its file does, like ``key``.
    """

    def __init__(self, key: str, message: str, names: tuple[str, ...] = ()) -> None:
        self.key = key
        self.message = message
        self.names = tuple(names)
        super().__init__(f"{key}: {message}")

    def __reduce__(self):
        # pickled by its state, not by ``args`` (the one joined line, which ``__init__``
        # does not take): a SpecError raised in a study worker process reached the parent
        # as "TypeError: missing 1 required positional argument"
        return _restore, (type(self), dict(self.__dict__), self.args)


class StudyError(SpecError):
    """Invalid study file or study argument: bad input (the CLI maps it to exit status 2).

    A :class:`~psdesign.errors.SpecError`, so ``except psdesign.SpecError`` catches every
    bad-input error of specs and studies alike.  A study that cannot run (the scheduler does
    not answer, no worker) raises other errors (``SchedulerError``, ``WorkersLost``).

    Parameters
    ----------
    message : str
        ``"key: what is wrong"``: ``key`` (before the first ``": "``; ``"study"`` if there
        is none) becomes :attr:`key`, the rest :attr:`message`.
    """

    def __init__(self, message: str) -> None:
        key, sep, rest = message.partition(": ")
        if not sep:
            key, rest = "study", message
        super().__init__(key, rest)


def short(value: object, limit: int = 60) -> str:
    """``repr`` of a user value for a one-line refusal: cut to ``limit`` characters, the type's
    name for a value whose ``repr`` spans lines (a NumPy array, a pandas Series: "got
    DataFrame", as :func:`psdesign.geometry.rve.checked_fields` words it) or fails; never
    raises.

    >>> import numpy as np
    >>> short("a" * 80)[-5:], short(np.arange(3)), short(np.zeros((2, 2)))
    ('aa...', 'array([0, 1, 2])', 'ndarray')
    """
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 - e.g. a value whose repr overflows
        return type(value).__name__
    if "\n" in text or "\r" in text:  # a refusal is one line (session 47 review)
        return type(value).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _restore(cls: type, state: dict, args: tuple) -> SpecError:
    """A :class:`SpecError` (or subclass) from its pickled state, without ``__init__``."""
    err = cls.__new__(cls)
    ValueError.__init__(err, *args)
    err.__dict__.update(state)
    return err


def show_warning_one_line(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` replacement: ``psdesign: warning: <message>`` on one line of
    stderr (no source file, no code line). Installed by the ``psdesign`` command and in the
    study runner's worker processes."""
    print(f"psdesign: warning: {' '.join(str(message).split())}", file=file or sys.stderr)


#: The folder of the psdesign package: a frame whose file lies in it is psdesign's own.
_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep


def warn_at_caller(message: str, category: type[Warning]) -> None:
    """Issue a warning at the line of the first frame outside psdesign (the user's call, as
    Python 3.12's ``skip_file_prefixes``), under the filters in force (``"error"`` raises
    there), shown on every call (a fresh registry: Python's once-per-line would hide the second
    study's line). A study's in-process case re-shows its warnings with this: they pointed at
    psdesign's own line (``psdesign/flow/permeability.py:178: ResolutionWarning: case ...``)."""
    frame = sys._getframe(1)
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(_PACKAGE_DIR):
        frame = frame.f_back
    if frame is None:  # no caller outside psdesign (the command's own process)
        filename, lineno, module_globals = "psdesign", 0, None
    else:
        filename, lineno, module_globals = frame.f_code.co_filename, frame.f_lineno, frame.f_globals
    warnings.warn_explicit(
        message, category, filename, lineno, registry={}, module_globals=module_globals
    )


#: Bad input found past the spec by modules that know nothing of :class:`SpecError`
#: (``module``, class name, the key a line without one names).
PAST_SPEC_ERRORS = (
    ("solvers.fem.periodic", "PeriodicMeshError", "flow.bc"),
    ("psdesign.meshing.errors", "PoreTopologyError", "rve.voxel"),
    ("solvers.voxel_stokes", "NoFluidPathError", "rve.voxel"),
)
_TABLES = ("image", "fibers", "generator", "rve", "flow")
_LEADING_KEY = re.compile(r"([A-Za-z_][\w.]*)(?: = [^:]*)?: ")


def as_spec_error(exc: BaseException) -> SpecError | None:
    """``exc`` as a :class:`SpecError` when it is bad input found past the spec, else None.

    The mesher's ``PoreTopologyError`` and the solvers' ``PeriodicMeshError`` and
    ``NoFluidPathError`` are plain ``ValueError``\\ s (``solvers/`` and ``meshing/`` know
    nothing of psdesign's errors); the CLI exits 2 for them with their line. The returned
    error has the same line (``str``) and as :attr:`SpecError.key` the spec key the line
    begins with (``"flow.bc = 'periodic': ..."`` -> ``flow.bc``; ``"image: ..."`` ->
    ``image``), else the key of :data:`PAST_SPEC_ERRORS`.

    Parameters
    ----------
    exc : BaseException
        The error raised.

    Returns
    -------
    SpecError or None
        The error to raise ``from exc``; None when ``exc`` is not one of those.

    Examples
    --------
    >>> from psdesign.meshing.errors import PoreTopologyError
    >>> err = as_spec_error(PoreTopologyError("rve.voxel: disconnected pore space"))
    >>> err.key, str(err)
    ('rve.voxel', 'rve.voxel: disconnected pore space')
    >>> as_spec_error(ValueError("x")) is None
    True
    """
    for module, name, default_key in PAST_SPEC_ERRORS:
        cls = getattr(sys.modules.get(module), name, None)  # not imported: not raised
        if cls is not None and isinstance(exc, cls):
            line = str(exc)
            match = _LEADING_KEY.match(line)
            if match and "." not in match.group(1) and match.group(1) not in _TABLES:
                match = None  # "periodic: face x1 ...": a solver's word, not a spec key
            key = match.group(1) if match else default_key
            err = SpecError(key, line[match.end() :] if match else line)
            ValueError.__init__(err, line)  # its line as the CLI prints it
            return err
    return None
