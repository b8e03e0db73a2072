"""A ``--scheduler`` address checked before dask is imported: its form and its host.

Importing dask (and the study runner's pandas) takes seconds on a loaded machine; a typo in
the address (``bogus``, ``tcp://bogus.invalid:8786``) is refused here first, in well under a
second, with one line naming ``--scheduler``. A host that resolves but does not answer is left
to the runner's probe (:func:`psdesign.study.runner.probe_scheduler`, its 10 s timeout).
Light on purpose: the standard library and :mod:`psdesign.errors` only.
"""

from __future__ import annotations

import socket
import threading

from psdesign.errors import StudyError

__all__ = ["RESOLVE_TIMEOUT_S", "SchedulerError", "check_scheduler_address", "host_port"]

#: Seconds a host name may take to resolve (``socket.getaddrinfo`` has no timeout of its own).
RESOLVE_TIMEOUT_S = 5.0


class SchedulerError(RuntimeError):
    """The Dask scheduler (``--scheduler``) or batch cluster (``--cluster``) cannot be used:
    its host does not resolve, it does not answer or is not Dask, dask.distributed or the
    submit command is missing, the jobs are refused or no worker connects in time.  Raised
    before the output folder is touched (the CLI exits 2).  Bad scheduler options (a
    malformed address, missing TLS files) are :class:`~psdesign.errors.StudyError`."""


def host_port(address: str) -> tuple[str, str, int]:
    """``(scheme, host, port)`` of ``SCHEME://HOST:PORT`` (an IPv6 host in brackets).

    >>> host_port("tls://[::1]:8786")
    ('tls', '::1', 8786)
    """
    scheme, _, rest = address.partition("://")
    host, sep, port = rest.rpartition(":")
    host = host.strip("[]")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise _malformed(address)
    return scheme, host, int(port)


def _malformed(address: str) -> StudyError:
    return StudyError(
        "--scheduler: expected an address like tcp://HOST:PORT, tls://HOST:PORT (PORT "
        f"1-65535) or 'local', got {address!r}"
    )


def _resolve(host: str, timeout_s: float) -> str:
    """``""`` when ``host`` resolves within ``timeout_s``, else why not (one phrase)."""
    out: dict[str, BaseException] = {}

    def lookup() -> None:
        try:
            socket.getaddrinfo(host, None)
        except (OSError, UnicodeError) as exc:  # gaierror; an over-long label: UnicodeError
            out["error"] = exc

    worker = threading.Thread(target=lookup, name="psdesign-resolve", daemon=True)
    worker.start()
    worker.join(timeout_s)
    if worker.is_alive():
        return f"no answer from the name service within {timeout_s:g} s"
    exc = out.get("error")
    if exc is None:
        return ""
    return getattr(exc, "strerror", None) or " ".join(str(exc).split()) or type(exc).__name__


def check_scheduler_address(address: str, timeout_s: float = RESOLVE_TIMEOUT_S) -> None:
    """Refuse a ``--scheduler`` address that cannot name a Dask scheduler, before dask loads:
    ``local``, or ``tcp://HOST:PORT`` / ``tls://HOST:PORT`` whose HOST resolves.

    Raises
    ------
    StudyError
        A malformed address or an unsupported scheme (bad input).
    SchedulerError
        The host does not resolve (within ``timeout_s``).

    Examples
    --------
    >>> check_scheduler_address("local")
    >>> check_scheduler_address("tcp://127.0.0.1:8786")  # resolves; nothing is connected
    """
    if address == "local":
        return
    if "://" not in address:
        raise _malformed(address)
    scheme, host, _port = host_port(address)
    if scheme not in ("tcp", "tls"):
        raise StudyError(f"--scheduler: scheme {scheme}:// not supported; use tcp:// or tls://")
    why = _resolve(host, timeout_s)
    if why:
        raise SchedulerError(
            f"--scheduler: the host of {address} does not resolve ({why}); check the name; "
            "nothing was run or changed"
        )
