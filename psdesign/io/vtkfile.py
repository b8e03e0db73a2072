"""Write a VTK dataset (``.vti``, ``.vtu``) so that a failed write raises.

pyvista's ``DataObject.save`` ignores the VTK writer's failure: on a full disk it leaves a
truncated file, returns normally and VTK prints some twenty lines of pipeline state on stderr
(audit s35).  VTK's XML writer on a full disk may also crash the process: ``psdesign mesh``'s
``pore.vtu`` on an 8 or 40 kB tmpfs ended in a segmentation fault or ``free(): invalid
pointer`` (abort), no message and the staging folder left (audit s36).  :func:`save_vtk` has
VTK write into memory (its errors caught, nothing on stderr) and writes the bytes with Python,
whose failed write raises :class:`OSError` (``ENOSPC`` named); the partial file is removed and
the CLI reports it in one line (exit 1).  In memory the file is held twice (VTK's string and
Python's copy: a 400^3 flow field's file is about a gigabyte), so where the disk has room for
the dataset's uncompressed arrays twice over VTK streams the file itself, as pyvista's ``save``
does (same bytes), its errors still caught.
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path
from typing import Any

from psdesign.io.diskfull import named_write_error, short_write_errno

__all__ = ["save_vtk"]

#: Characters encoded and written at a time: the file is not held twice in memory as text and
#: as bytes (VTK's text is the compressed, base64-encoded file: a fraction of the arrays).
_CHUNK = 1 << 24

#: Free bytes on the target's file system, beyond twice the dataset's memory, from which VTK
#: writes the file itself (streaming) rather than into memory.
STREAM_MARGIN = 64 << 20


def _vtk_text(dataset: Any, suffix: str) -> str | bytes:
    """The file ``dataset.save(name + suffix)`` writes (pyvista's writer for the XML VTK
    ``suffix``, binary, zlib-compressed: ``save``'s defaults), made in memory: VTK's output
    string (``str`` unless it is not UTF-8).  VTK's errors raise :class:`OSError` (``EIO``);
    nothing reaches stderr."""
    import pyvista as pv
    from pyvista.core.utilities.observers import VtkErrorCatcher

    store = getattr(dataset, "_store_metadata", None)  # as save: complex arrays as field data
    if store is not None:
        store()
    writer = type(dataset)._WRITERS[suffix]("memory" + suffix, dataset)
    writer._apply_kwargs_safely(texture=None, data_format="binary", compression="zlib")
    vtk_writer = writer.writer
    vtk_writer.WriteToOutputStringOn()
    with (
        pv.vtk_verbosity("off"),
        VtkErrorCatcher(raise_errors=False, send_to_logging=False) as caught,
    ):
        ok = vtk_writer.Write()
    text = vtk_writer.GetOutputString()
    if caught.events or not ok or not text:
        raise OSError(errno.EIO, f"{os.strerror(errno.EIO)} (VTK could not write the data)")
    return text


def save_vtk(dataset: Any, path: str | os.PathLike) -> Path:
    """Save a pyvista ``dataset`` to ``path``; a VTK write failure raises.

    Parameters
    ----------
    dataset : pyvista.DataSet
        What to write; the format follows the suffix, as ``dataset.save``.
    path : str or path-like
        The file (in a staging folder: psdesign writes outputs there).

    Returns
    -------
    Path

    Raises
    ------
    OSError
        The write failed (``ENOSPC`` if the disk is full) or VTK reported an error (``EIO``);
        a partial file is removed.
    """
    path = Path(path)
    if _free_bytes(path.parent) > 2 * dataset.actual_memory_size * 1024 + STREAM_MARGIN:
        return _stream(dataset, path)
    text = _vtk_text(dataset, path.suffix.lower())
    try:
        with open(path, "wb") as fh:
            for i in range(0, len(text), _CHUNK):
                part = text[i : i + _CHUNK]
                fh.write(part if isinstance(part, bytes) else part.encode("utf-8"))
    except OSError as exc:
        named = named_write_error(exc, path, path.parent)  # before the blocks are freed
        _remove_partial(path)
        if named is exc:
            raise
        raise named from exc
    return path


def _free_bytes(folder: Path) -> int:
    """Free bytes on the file system of ``folder`` (0 if it cannot be told)."""
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return 0


def _stream(dataset: Any, path: Path) -> Path:
    """pyvista's ``save`` with VTK's errors caught (nothing on stderr): a failure raises."""
    import pyvista as pv
    from pyvista.core.utilities.observers import VtkErrorCatcher

    with (
        pv.vtk_verbosity("off"),
        VtkErrorCatcher(raise_errors=False, send_to_logging=False) as caught,
    ):
        dataset.save(path)
    if caught.events:
        code = short_write_errno(path.parent)  # ENOSPC on a full disk: before the blocks go
        _remove_partial(path)
        raise OSError(code, f"{os.strerror(code)} (VTK could not write the file)", str(path))
    return path


def _remove_partial(path: Path) -> None:
    if path.is_file() and not path.is_symlink():
        path.unlink()
