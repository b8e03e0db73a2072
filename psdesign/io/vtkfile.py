"""Write a VTK dataset (``.vti``, ``.vtu``) so that a failed write raises.

pyvista's ``DataObject.save`` ignores the VTK writer's failure: on a full disk it leaves a
truncated file, returns normally and VTK prints some twenty lines of pipeline state on stderr
(audit s35).  :func:`save_vtk` catches VTK's errors (nothing reaches stderr), removes the
partial file and raises :class:`OSError`, which the CLI reports in one line (exit 1).
"""

from __future__ import annotations

import errno
import os
from pathlib import Path
from typing import Any

__all__ = ["save_vtk"]


def _write_errno(folder: Path) -> int:
    """ENOSPC when the file system of ``folder`` has no free block left, else EIO."""
    try:
        st = os.statvfs(folder)
    except OSError:
        return errno.EIO
    return errno.ENOSPC if st.f_bavail * st.f_frsize < 65536 else errno.EIO


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
        VTK reported an error while writing (``ENOSPC`` if the disk is full, else ``EIO``);
        the partial file (a regular file) is removed.
    """
    import pyvista as pv
    from pyvista.core.utilities.observers import VtkErrorCatcher

    path = Path(path)
    with (
        pv.vtk_verbosity("off"),
        VtkErrorCatcher(raise_errors=False, send_to_logging=False) as caught,
    ):
        dataset.save(path)
    if caught.events:
        code = _write_errno(path.parent)  # before the partial file's blocks are freed
        if path.is_file() and not path.is_symlink():
            path.unlink()
        raise OSError(code, f"{os.strerror(code)} (VTK could not write the file)", str(path))
    return path
