"""Single output files named on the command line (``pores --plot FILE``): never overwrite.

A folder output carries psdesign's marker (:mod:`psdesign.io.outputs`); a single file cannot,
so psdesign only ever creates a *new* file: :func:`check_new_file` refuses an existing path
(file, folder or symbolic link) and a missing or non-folder parent before any work starts, and
:func:`write_new_file` writes to a temporary name beside it and links it into place only if
the name is still free (all or nothing; a file created meanwhile is never replaced).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from psdesign.io.outputs import TEMP_PREFIX, OutputError

__all__ = ["check_new_file", "write_new_file"]


def _refuse_taken(p: Path, option: str) -> None:
    if os.path.lexists(p):
        kind = "folder" if p.is_dir() else "file"
        raise OutputError(
            option,
            f"{p} is an existing {kind}; psdesign never overwrites a file it may not have "
            "written: give a new file name",
        )


def check_new_file(path: str | os.PathLike, option: str, suffix: str | None = None) -> Path:
    """The absolute path of a new output file, or :class:`OutputError` (exit 2) naming ``option``.

    Parameters
    ----------
    path : str or path-like
        The file the user asked for.
    option : str
        The command-line option, for the message (``--plot``).
    suffix : str, optional
        The one file type written (``".png"``): another name's suffix is refused (``--plot
        p.pdf`` wrote PNG bytes into ``p.pdf``, a PDF no viewer opens).

    Raises
    ------
    OutputError
        The path exists (file, folder, link), ends in a separator, has another suffix than
        ``suffix``, or its folder is missing, is a file or is not writable.
    """
    text = os.fspath(path)
    if not text or text.endswith(os.sep):
        raise OutputError(option, f"{text!r} is not a file name: give a new file name")
    p = Path(os.path.abspath(text))
    _refuse_taken(p, option)
    parent = p.parent
    for up in (parent, *parent.parents):
        if up.exists() and not up.is_dir():
            raise OutputError(option, f"{p} is inside the file {up}; give a new file name")
    if not parent.is_dir():
        raise OutputError(option, f"folder {parent} does not exist; create it first")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(option, f"folder {parent} is not writable")
    if suffix is not None and p.suffix.lower() != suffix:
        raise OutputError(
            option,
            f"{p.name}: psdesign writes a {suffix[1:].upper()} picture (allowed: a new file "
            f"name ending in {suffix})",
        )
    return p


def write_new_file(path: Path, option: str, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` on a temporary name beside ``path``, then move it to ``path`` only
    if that name is still free; the temporary file is removed in every case.

    Raises
    ------
    OutputError
        ``path`` was taken while the work ran.
    OSError
        ``write`` failed (a full disk); one without a file name names ``path`` (the CLI's one
        line said only "No space left on device").
    """
    tmp = path.parent / f"{TEMP_PREFIX}{path.name}.{os.getpid()}.tmp"
    try:
        try:
            write(tmp)
        except OSError as exc:  # matplotlib's PNG on a full disk: no file name (audit s36)
            from psdesign.io.diskfull import named_write_error

            named = named_write_error(exc, path, path.parent)
            if named is exc:
                raise
            raise named from exc
        try:
            os.link(tmp, path)  # fails if the name is taken: never replaces
        except FileExistsError:
            _refuse_taken(path, option)
            raise
        except OSError:  # no hard links on this file system
            _refuse_taken(path, option)
            os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
