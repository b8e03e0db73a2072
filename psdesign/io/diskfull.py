"""A full disk is the machine's failure, not a case's: tell it apart from other errors.

A study case that fails because the disk filled (``ENOSPC``, or a quota: ``EDQUOT``) must not
be recorded as a failed case: a resume skips failed cases, so its row would stay failed (or,
for a preview picture, missing) after space is freed.  The runner stops the run instead and
the case runs again on the resume (audit s35).
"""

from __future__ import annotations

import errno
import os

__all__ = ["DISK_FULL_ERRNOS", "is_disk_full", "named_write_error", "short_write_errno"]

#: ``errno`` values of a full file system or an exhausted quota.
DISK_FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT})


def is_disk_full(exc: BaseException | None) -> bool:
    """True if ``exc``, or an exception it was raised from or during, is an ``OSError`` of a
    full disk.

    >>> is_disk_full(OSError(errno.ENOSPC, "No space left on device"))
    True
    >>> is_disk_full(ValueError("porosity"))
    False
    """
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, OSError) and exc.errno in DISK_FULL_ERRNOS:
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def short_write_errno(folder: str | os.PathLike) -> int:
    """The ``errno`` of a write that failed without one: ``ENOSPC`` if the file system of
    ``folder`` has less than 64 KiB free, else ``EIO``.

    numpy's ``tofile`` (meshio's binary STL writer) raises ``OSError("2550 requested and 1964
    written")`` with no ``errno`` on a full disk (audit s36, ``mesh --format stl`` on a 1 MB
    tmpfs).  Ask while the partial file still holds its blocks.
    """
    try:
        st = os.statvfs(folder)
    except OSError:
        return errno.EIO
    return errno.ENOSPC if st.f_bavail * st.f_frsize < 65536 else errno.EIO


def named_write_error(
    exc: OSError, path: str | os.PathLike, folder: str | os.PathLike, what: str = ""
) -> OSError:
    """``exc`` if it names a file, else an :class:`OSError` naming ``path`` (``errno`` from
    :func:`short_write_errno` of ``folder`` when ``exc`` has none; `` (what)`` after the
    reason if given): the CLI's one line must say which file a full disk stopped (failure audit
    s36: matplotlib's PNG and meshio's ``open`` block raise with no file name, numpy's short
    write with no ``errno``).

    >>> import errno
    >>> e = named_write_error(OSError(errno.ENOSPC, "full"), "/tmp/x.png", "/tmp")
    >>> (e.errno, e.filename)
    (28, '/tmp/x.png')
    """
    if exc.filename is not None:
        return exc
    code = exc.errno if exc.errno is not None else short_write_errno(folder)
    reason = os.strerror(code) + (f" ({what})" if what else "")
    return OSError(code, reason, str(path))
