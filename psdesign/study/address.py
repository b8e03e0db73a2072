"""A ``--scheduler`` address checked before dask is imported: its form and its host.

Importing dask (and the study runner's pandas) takes seconds on a loaded machine; a typo in
the address (``bogus``, ``tcp://bogus.invalid:8786``) is refused here first, in well under a
second, with one line naming ``--scheduler``. A host that resolves but does not answer is left
to the runner's probe (:func:`psdesign.study.runner.probe_scheduler`, its 10 s timeout).
The check returns a :class:`SchedulerAddress`, the address with the host's addresses: the
entry points that check it again (the CLI, :class:`~psdesign.study.options.RunOptions`,
:func:`~psdesign.study.runner.connect_scheduler`) and the probe use those, so one run looks
the host up once (it was five times: three checks, the loopback test and the probe).
Light on purpose: the standard library and :mod:`psdesign.errors` only.
"""

from __future__ import annotations

import socket
import threading

from psdesign.errors import StudyError

__all__ = [
    "RESOLVE_TIMEOUT_S",
    "SchedulerAddress",
    "SchedulerError",
    "check_scheduler_address",
    "host_port",
]

#: Seconds a host name may take to resolve (``socket.getaddrinfo`` has no timeout of its own).
RESOLVE_TIMEOUT_S = 5.0


class SchedulerError(RuntimeError):
    """The Dask scheduler (``--scheduler``) or batch cluster (``--cluster``) cannot be used:
    its host does not resolve, it does not answer or is not Dask, dask.distributed or the
    submit command is missing, the jobs are refused or no worker connects in time.  Raised
    before the output folder is touched (the CLI exits 2).  Bad scheduler options (a
    malformed address, missing TLS files) are :class:`~psdesign.errors.StudyError`."""


class SchedulerAddress(str):
    """A ``tcp://`` / ``tls://`` address that :func:`check_scheduler_address` accepted, with
    ``infos``: its host's ``socket.getaddrinfo`` entries (TCP, the address's port), looked up
    once for the run. A plain ``str`` everywhere else.

    >>> a = SchedulerAddress("tcp://127.0.0.1:8786", [])
    >>> a == "tcp://127.0.0.1:8786", a.infos
    (True, ())
    """

    infos: tuple

    def __new__(cls, address: str, infos) -> SchedulerAddress:
        self = super().__new__(cls, address)
        self.infos = tuple(infos)
        return self

    def __reduce__(self):
        return (SchedulerAddress, (str(self), self.infos))


def host_port(address: str, what: str = "--scheduler") -> tuple[str, str, int]:
    """``(scheme, host, port)`` of ``SCHEME://HOST:PORT`` (an IPv6 host in brackets); a
    malformed one is a :class:`StudyError` naming ``what``.

    >>> host_port("tls://[::1]:8786")
    ('tls', '::1', 8786)
    """
    scheme, _, rest = address.partition("://")
    host, sep, port = rest.rpartition(":")
    host = host.strip("[]")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise _malformed(address, what)
    return scheme, host, int(port)


def _malformed(address: str, what: str = "--scheduler") -> StudyError:
    return StudyError(
        f"{what}: expected an address like tcp://HOST:PORT, tls://HOST:PORT (PORT "
        f"1-65535) or 'local', got {address!r}"
    )


def _resolve(host: str, port: int, timeout_s: float) -> tuple[list, str]:
    """``(infos, "")`` when ``host`` resolves within ``timeout_s`` (``socket.getaddrinfo``'s
    TCP entries for ``port``), else ``([], why not)`` (one phrase)."""
    out: dict[str, object] = {}

    def lookup() -> None:
        try:
            out["infos"] = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
        except (OSError, UnicodeError) as exc:  # gaierror; an over-long label: UnicodeError
            out["error"] = exc

    worker = threading.Thread(target=lookup, name="psdesign-resolve", daemon=True)
    worker.start()
    worker.join(timeout_s)
    if worker.is_alive():
        return [], f"no answer from the name service within {timeout_s:g} s"
    exc = out.get("error")
    if exc is None:
        return list(out["infos"]), ""
    why = getattr(exc, "strerror", None) or " ".join(str(exc).split()) or type(exc).__name__
    return [], why


def check_scheduler_address(
    address: str, timeout_s: float = RESOLVE_TIMEOUT_S, what: str = "--scheduler"
) -> str:
    """Refuse a ``--scheduler`` address that cannot name a Dask scheduler, before dask loads:
    ``local``, or ``tcp://HOST:PORT`` / ``tls://HOST:PORT`` whose HOST resolves.

    Parameters
    ----------
    address : str
        The address as given.
    timeout_s : float
        Seconds the host's name may take to resolve.
    what : str
        How the one-line errors name the address: the command line's ``"--scheduler"``, the
        Python API's ``"scheduler"`` (:class:`~psdesign.study.options.RunOptions`).

    Returns
    -------
    str
        ``"local"``, or the address as a :class:`SchedulerAddress` with its host's
        addresses; one already checked is returned as it is (no second lookup).

    Raises
    ------
    StudyError
        A malformed address or an unsupported scheme (bad input).
    SchedulerError
        The host does not resolve (within ``timeout_s``).

    Examples
    --------
    >>> check_scheduler_address("local")
    'local'
    >>> a = check_scheduler_address("tcp://127.0.0.1:8786")  # resolves; nothing is connected
    >>> a.infos[0][4]
    ('127.0.0.1', 8786)
    >>> check_scheduler_address(a) is a
    True
    """
    if isinstance(address, SchedulerAddress):
        return address
    if not address.strip():  # "" ran on the local pool
        raise StudyError(
            f"{what}: empty ({address!r}); give tcp://HOST:PORT, tls://HOST:PORT or "
            "'local', or leave it out for the local process pool"
        )
    if address == "local":
        return address
    if "://" not in address:
        raise _malformed(address, what)
    scheme, host, port = host_port(address, what)
    if scheme not in ("tcp", "tls"):
        raise StudyError(f"{what}: scheme {scheme}:// not supported; use tcp:// or tls://")
    infos, why = _resolve(host, port, timeout_s)
    if why:
        raise SchedulerError(
            f"{what}: the host of {address} does not resolve ({why}); check the name; "
            "nothing was run or changed"
        )
    return SchedulerAddress(address, infos)
