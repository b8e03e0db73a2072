"""A full disk is the machine's failure, not a case's: tell it apart from other errors.

A study case that fails because the disk filled (``ENOSPC``, or a quota: ``EDQUOT``) must not
be recorded as a failed case: a resume skips failed cases, so its row would stay failed (or,
for a preview picture, missing) after space is freed.  The runner stops the run instead and
the case runs again on the resume (audit s35).
"""

from __future__ import annotations

import errno

__all__ = ["DISK_FULL_ERRNOS", "is_disk_full"]

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
