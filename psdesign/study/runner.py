"""Run a study: local process pool (default) or a Dask cluster, resumable and atomic.

Every finished case is written at once (``OUT/cases/<case_id>.json``, atomically); the
consolidated ``results.csv`` / ``results.parquet`` are rebuilt from the records every few
seconds (:class:`TableWriter`) and always when the run ends or is interrupted.  Re-running the same
command skips cases whose record says ``ok`` (and ``failed``/``timeout`` unless
``retry_failed``), so a crash or ``kill -9`` loses at most the cases that were running.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import datetime as _dt
import errno
import json
import multiprocessing
import numbers
import os
import platform
import socket
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, replace
from dataclasses import fields as fields_of
from functools import partial
from pathlib import Path
from typing import Any

import pandas as pd

from psdesign.errors import short
from psdesign.io.outputs import OutputDir, check_output_dir, claim_output_dir, remove_owned_files
from psdesign.schema.budget import concurrent_workers, workers_at_once
from psdesign.schema.study import k_directions
from psdesign.study.address import (
    SchedulerAddress,
    SchedulerError,
    check_scheduler_address,
    host_port,
)
from psdesign.study.casefn import case_fn_name, runs_pipeline, watch_parent
from psdesign.study.cluster import DEFAULT_WAIT_S, has_worker
from psdesign.study.design import Case, expand_design, match_finished
from psdesign.study.interrupt import (
    GRACE_S,
    held_signals,
    ignore_sigint,
    restore_dask_logs,
    sigint_blocked,
    stop_on_interrupt,
)
from psdesign.study.options import RunOptions, refuse_unknown_keywords
from psdesign.study.progress import Progress
from psdesign.study.sameness import check_same_study
from psdesign.study.stages import StageWatcher
from psdesign.study.store import (
    STUDY_FILES,
    STUDY_FILES_NO_REPORT,
    STUDY_LEGACY,
    CaseStore,
    StorageError,
    psdesign_wrote,
)
from psdesign.study.studyfile import Study, StudyError, load_study
from psdesign.study.worker import execute_case, importable_case_fn_name

__all__ = ["SchedulerError", "WorkersLost", "run_study"]

CONNECT_TIMEOUT_S = 10.0
_MAX_POOL_BREAKS = 2


class WorkersLost(RuntimeError):
    """No Dask worker for ``--cluster-wait`` seconds (``run_study``'s ``worker_wait_s``) while
    cases wait: batch jobs past their walltime, a scheduler whose workers all left or never
    came. The finished cases are saved; rerunning the command resumes."""


_POLL_S = 0.5


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


# ----------------------------------------------------------------------------- lock


def _pid_alive(pid: int) -> bool:
    try:
        import psutil

        return psutil.pid_exists(pid)
    except ImportError:  # pragma: no cover
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True


@contextmanager
def _run_lock(out: Path, option: str = "out_dir") -> Iterator[None]:
    """Refuse two runs writing into the same folder; a stale lock (dead pid) is taken over.
    ``option`` names the folder in the refusal: the command's ``-o`` (``out_dir`` said so until
    session 50), the API's ``out_dir``."""
    lock = out / ".lock"
    me = {"pid": os.getpid(), "host": socket.gethostname()}
    for _ in range(3):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                other = json.loads(lock.read_text())
            except (OSError, ValueError):
                other = {}
            if (
                other.get("host") == me["host"]
                and isinstance(other.get("pid"), int)
                and _pid_alive(other["pid"])
                and other["pid"] != me["pid"]
            ):
                raise StudyError(
                    f"{option}: {out} is in use by a running study (pid {other['pid']}); "
                    "wait for it or choose another folder"
                ) from None
            if other.get("host") not in (None, me["host"]):
                raise StudyError(
                    f"{option}: {out} is locked by host {other['host']} (pid {other.get('pid')}); "
                    f"delete {lock} if that run is dead"
                ) from None
            try:
                lock.unlink()
            except FileNotFoundError:
                pass
            continue
        except OSError as exc:
            raise StorageError(exc.errno, f"cannot write {lock}: {exc.strerror or exc}") from exc
        with os.fdopen(fd, "w") as fh:
            json.dump(me, fh)
        break
    else:  # pragma: no cover - lost a race three times
        raise StudyError(f"{option}: cannot lock {out}")
    try:
        yield
    finally:
        try:
            lock.unlink()
        except OSError:
            pass


# ----------------------------------------------------------------------------- backends


def _mp_context():
    return multiprocessing.get_context("spawn")


def concurrent_cases(workers: int, scheduler, n_cases: int) -> int:
    """Cases of a run that hold their memory at once on this machine: the local pool's (or a
    local Dask cluster's) workers, at most one per case; 1 in this process (``workers=0``) or
    on a remote scheduler or batch cluster (its workers' machines have their own memory).

    >>> concurrent_cases(2, None, 9), concurrent_cases(4, "local", 3), concurrent_cases(0, None, 9)
    (2, 3, 1)
    """
    if scheduler is not None and scheduler != "local":
        return 1
    if isinstance(workers, bool) or not isinstance(workers, numbers.Integral):
        return 1  # refused by the run's own check (check_workers), with its line
    return max(1, min(int(workers), int(n_cases)))


@dataclass
class _RunShare:
    """One memory share and one thread warning for a run of several :func:`run_study` calls
    (:func:`one_share`)."""

    at_once: int | None = None
    warned: bool = False


_SHARE: ContextVar[_RunShare | None] = ContextVar("psdesign_run_share", default=None)


@contextmanager
def one_share() -> Iterator[None]:
    """:func:`run_study` calls inside share the first one's workers at once (the memory share
    each case is held to, and the pool's size) and print the thread warning
    (:func:`oversubscribed`) once: ``study optimize`` runs a study per round, and each round
    recounted its share from every case, finished ones included (a case accepted in round 1
    could be refused in round 2), and warned again (session 54's review)."""
    token = _SHARE.set(_RunShare())
    try:
        yield
    finally:
        _SHARE.reset(token)


def _at_once(opts: RunOptions, cases: list[Case], out_dir) -> int:
    """The run's workers at once (:func:`concurrent_cases`) over the cases still to run (a
    resumed folder's finished ones hold no memory), or, inside :func:`one_share`, the first
    run's over all its cases: a resumed ``study optimize`` whose first round had finished
    counted 0 to run and ran every later round one case at a time (session 54's late review)."""
    held = _SHARE.get()
    if held is not None and held.at_once is not None:
        return held.at_once
    n_cases = len(cases) if held is not None else _pending(cases, out_dir, opts)
    n = concurrent_cases(opts.workers, opts.scheduler, n_cases)
    if held is not None:
        held.at_once = n
    return n


def _pending(cases: list[Case], out_dir, opts: RunOptions) -> int:
    """Cases of ``cases`` a run in ``out_dir`` would run (:func:`_todo` of its readable
    records, read only; all of them for ``force`` or an unreadable folder)."""
    if opts.force:
        return len(cases)
    try:
        loaded = CaseStore(out_dir).load_records()
        stored = match_finished(cases, loaded)
        records = {c: loaded[r] for c, r in stored.items()}
    except (OSError, TypeError, ValueError):
        return len(cases)
    return len(_todo(cases, records, opts))


def _warn_once() -> bool:
    """True unless a :func:`one_share` run already printed its thread warning."""
    held = _SHARE.get()
    if held is None:
        return True
    first, held.warned = not held.warned, True
    return first


def workers_option(out_option: tuple[str, str | None]) -> str:
    """How a refusal names the workers: ``--workers`` where messages name a command's flags
    (``out_option`` ``("-o", ...)``), else the keyword ``workers``."""
    return "--workers" if out_option[0].startswith("-") else "workers"


def _check_main_script(opts: RunOptions) -> None:
    """Refuse local worker processes when they cannot start: a spawned worker re-imports the
    ``__main__`` script by its path, and a script read from stdin (``python - < run.py``, a
    heredoc) has the path ``<stdin>``, no file; each case then died as "crash or out of memory"
    (session 50's walk); a local Dask cluster (``scheduler="local"``) spawns its workers so
    too (its nanny failed with a 60-line traceback, session 50's review). Jupyter, ``python
    -c`` and ``python -m`` have no such path."""
    if opts.scheduler not in (None, "local") or opts.workers < 1:
        return
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if path is None or getattr(getattr(main, "__spec__", None), "name", None):
        return  # spawn imports a module by its name, or nothing
    # spawn resolves a relative path against the folder the process started in
    start = multiprocessing.process.ORIGINAL_DIR or os.getcwd()
    if not Path(start, path).is_file():
        raise StudyError(
            f"workers: worker processes re-import the main script, and {path} is no file (a "
            "script read from stdin?) (allowed: workers=0 without a scheduler, or the script "
            "run from a file)"
        )


THREAD_VARS = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Thread-count variables shared out among pool workers (numba kernels, BLAS)."""


def threads_per_worker(workers: int, cpus: int | None = None) -> int:
    """Threads each of ``workers`` local processes may use: the CPUs shared out, at least 1."""
    return max(1, (cpus or os.cpu_count() or 1) // max(1, workers))


@contextmanager
def _thread_budget(workers: int):
    """Set the thread variables (unless the user set them) while worker processes are spawned.

    Spawned workers inherit the environment; without this, N workers each start numba and BLAS
    with one thread per CPU and oversubscribe the machine (2 workers x 2 threads on 2 cores:
    6 voxel-route cases took 1 091 s, more than the ~840 s of one worker).
    """
    n = str(threads_per_worker(workers))
    added = [v for v in THREAD_VARS if v not in os.environ]
    for v in added:
        os.environ[v] = n
    try:
        yield
    finally:
        for v in added:
            os.environ.pop(v, None)


#: The solver threads a user's value is kept for in every worker (:func:`oversubscribed`).
SOLVER_THREAD_VARS = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS")


def oversubscribed(workers: int, cpus: int | None = None) -> str | None:
    """The warning line when a solver thread count the user set (kept in every worker, the
    rule: the user's value wins) times ``workers`` is over the CPUs and over the share the
    runner gives (:func:`threads_per_worker`); None otherwise. Session 54: ``NUMBA_NUM_THREADS=2
    --workers 2`` ran 4 solver threads on 2 cores, silently."""
    cpus = cpus or os.cpu_count() or 1
    share = threads_per_worker(workers, cpus)
    over = []
    for var in SOLVER_THREAD_VARS:
        try:
            n = int(os.environ.get(var, ""))
        except ValueError:  # unset or not a count: the runner's share, or numba's own refusal
            continue
        if n > share and n * workers > cpus:
            over.append(f"{var}={n}")
    if not over:
        return None
    verb, it = ("is", "it") if len(over) == 1 else ("are", "them")
    return (
        f"psdesign: warning: {' and '.join(over)} {verb} kept in each of {workers} workers: more "
        f"threads than the {cpus} CPUs (unset {it} to share the CPUs out, {share} per worker)"
    )


def _run_pool(payloads: list[dict], workers: int, on_done: Callable[[dict, dict], None]) -> None:
    """Run payloads on a spawn-based ProcessPoolExecutor.

    If a worker process dies (segfault, out-of-memory kill) the pool breaks and every unfinished
    case fails with BrokenProcessPool.  Those cases are re-queued on a fresh pool; a case hit by
    two breaks is then run alone in its own one-worker pool, and recorded as failed only if it
    breaks that pool too, so innocent queued cases are never blamed.
    """
    line = oversubscribed(min(workers, len(payloads)))
    if line and _warn_once():
        print(line, file=sys.stderr)
    normal = list(payloads)
    isolate: list[dict] = []
    breaks: dict[str, int] = {}
    while normal or isolate:
        if normal:
            batch, normal, n_workers, alone = normal, [], workers, False
        else:
            batch, n_workers, alone = [isolate.pop(0)], 1, True
        ex = _new_pool(n_workers)
        try:
            with _thread_budget(n_workers), sigint_blocked():  # workers start with it blocked
                futs = {ex.submit(execute_case, p): p for p in batch}
            for fut in cf.as_completed(futs):
                p = futs[fut]
                try:
                    rec = fut.result()
                except BrokenProcessPool:
                    if alone:
                        rec = _failed(
                            p,
                            "worker process died while running this case (crash or out of memory)",
                        )
                    else:
                        n = breaks[p["case_id"]] = breaks.get(p["case_id"], 0) + 1
                        (isolate if n >= _MAX_POOL_BREAKS else normal).append(p)
                        continue
                except cf.CancelledError:  # pragma: no cover - only after shutdown
                    continue
                on_done(p, rec)
        except BaseException:
            procs = _pool_processes(ex)  # shutdown forgets them (CPython sets _processes None)
            ex.shutdown(wait=False, cancel_futures=True)
            _terminate_pool(procs)
            raise
        ex.shutdown(wait=True)


def _new_pool(n_workers: int) -> cf.ProcessPoolExecutor:
    """A spawn-based pool of ``n_workers`` (they start at its first submit), made with SIGINT
    and SIGTERM held (:func:`~psdesign.study.interrupt.held_signals`): each of its queues'
    named semaphores is registered with multiprocessing's resource tracker a few lines before
    its finalizer exists, and a Ctrl-C raised in between left it to the tracker, which printed
    "There appear to be 1 leaked semaphore objects" (2 lines) under the runner's one line
    (session 53's CI: 1 of ~25 stops at 0.0 s; SIGINT at each of the 425 lines of
    multiprocessing's code run while the pool is made: 60 leaked one, session 54).  The held
    signal is raised once it is made; no worker or thread has started yet."""
    with held_signals():
        return cf.ProcessPoolExecutor(
            max_workers=n_workers,
            mp_context=_mp_context(),
            initializer=_init_worker,
            initargs=(os.getpid(),),
        )


def max_local_workers() -> int:
    """Most worker processes a study may start on this machine: 4 per CPU, at least 64 (each
    case can take GBs; more processes than that only thrash)."""
    return max(64, 4 * (os.cpu_count() or 1))


def check_workers(
    workers, scheduler=None, what: str = "workers", more: str = "scheduler= (Dask)"
) -> None:
    """The one rule of a study's worker count (``study run``, ``study optimize``, ``rev`` and
    :func:`run_study`): an integer >= 0, where 0 runs the cases in this process; on this
    machine (no ``scheduler`` or ``"local"``) at most :func:`max_local_workers`; with a
    scheduler or a batch cluster (``scheduler`` given) at least 1, as there is no "this
    process" there (a local Dask cluster of 0 workers started one). Else a one-line
    :class:`StudyError` naming ``what`` (``"--workers"`` from the command line); past the
    local cap it advises ``more``, the caller's own way to more workers (``study run``'s
    ``"--scheduler or --cluster"``, ``study optimize``'s ``"--scheduler"``; ``""`` for
    ``rev``, which has none)."""
    # numbers.Integral: NumPy's integers too (np.int64 from a notebook was "must be an
    # integer, got np.int64(2)"), as the schema's integer keys take them
    if isinstance(workers, bool) or not isinstance(workers, numbers.Integral) or workers < 0:
        raise StudyError(
            f"{what}: must be an integer >= 0 (0: the cases in this process), got {short(workers)}"
        )
    if scheduler is not None and workers == 0:
        raise StudyError(
            f"{what}: 0 runs the cases in this process, which a Dask scheduler or batch "
            "cluster does not; give 1 or more (Dask workers or batch jobs), got 0"
        )
    local = scheduler is None or scheduler == "local"
    if local and workers > max_local_workers():
        raise StudyError(
            f"{what}: at most {max_local_workers()} processes on this machine (64 or 4 per "
            f"CPU, whichever is more), got {workers}" + (f"; use {more} for more" if more else "")
        )


def _init_worker(parent_pid: int) -> None:
    """Pool-worker start-up: exit when the runner dies; Ctrl-C is the runner's to handle;
    warnings one line each, as in the runner (the case records them in its results)."""
    import warnings

    from psdesign.errors import show_warning_one_line

    warnings.showwarning = show_warning_one_line
    ignore_sigint()
    watch_parent(parent_pid)


def _pool_processes(ex: cf.ProcessPoolExecutor) -> list:
    """The pool's worker processes, taken before ``ex.shutdown``, which drops its record of
    them (review s53: :func:`_terminate_pool` then found none, and after an error that is not
    an interrupt the workers ran their cases on after the lock was released)."""
    return list((getattr(ex, "_processes", None) or {}).values())


def _terminate_pool(procs: list) -> None:
    """Stop the pool's worker processes ``procs`` (:func:`_pool_processes`) after an error or
    interrupt, and join them within :data:`GRACE_S` in all (then kill, and join again):
    multiprocessing must reap its own workers (see
    :func:`~psdesign.study.interrupt.stop_children`) or the pool's manager thread waits for
    them for ever."""
    from psdesign.study.interrupt import join_within

    for proc in procs:
        with contextlib.suppress(Exception):
            proc.terminate()
    join_within(procs, GRACE_S)
    alive = [p for p in procs if p.is_alive()]
    for proc in alive:
        with contextlib.suppress(Exception):
            proc.kill()
    join_within(alive, GRACE_S)


def _run_inline(payloads: list[dict], on_done: Callable[[dict, dict], None]) -> None:
    for p in payloads:
        on_done(p, execute_case(p))


def _is_loopback(address: SchedulerAddress) -> bool:
    """Every address of the checked ``address``'s host is a loopback one."""
    import ipaddress

    infos = address.infos
    try:
        return bool(infos) and all(ipaddress.ip_address(i[4][0]).is_loopback for i in infos)
    except ValueError:  # pragma: no cover
        return False


MAX_HANDSHAKE_BYTES = 1 << 20
"""Largest first message accepted from a scheduler while probing it (a Dask handshake is
a few hundred bytes; dask itself has no such limit and would allocate whatever a peer claims)."""


def _recv_exact(sock, n: int) -> bytes:
    buf = bytearray()
    while len(buf) < n:
        chunk = sock.recv(min(n - len(buf), 65536))
        if not chunk:
            raise ConnectionError("connection closed by the peer")
        buf += chunk
    return bytes(buf)


def _connect(infos, timeout_s: float) -> socket.socket:
    """A TCP connection to the first of ``infos`` (``socket.getaddrinfo`` entries) that
    accepts one: :func:`socket.create_connection` without its own name lookup.

    >>> import socket
    >>> _connect([], 1.0)
    Traceback (most recent call last):
    ...
    OSError: no address to connect to
    """
    err: OSError = OSError("no address to connect to")
    for family, kind, proto, _name, sockaddr in infos:
        sock = socket.socket(family, kind, proto)
        try:
            sock.settimeout(timeout_s)
            sock.connect(sockaddr)
            return sock
        except OSError as exc:
            sock.close()
            err = exc
    raise err


def probe_scheduler(
    address: str, timeout_s: float, ssl_context=None, what: str = "--scheduler"
) -> None:
    """Check that a Dask scheduler (not some other server) answers at ``address``.

    A Dask comm sends its handshake as soon as a connection is made: an 8-byte little-endian
    length, then the frames (8-byte frame count, 8-byte lengths).  The probe reads it with
    bounded sizes and a timeout, so a non-Dask peer gives a clean error instead of dask trying
    to allocate whatever length the peer's first bytes spell.

    Raises
    ------
    SchedulerError
        One line naming ``what`` (the command line's option, or the Python keyword):
        nothing answers, or the peer does not speak the Dask protocol.
    """
    import struct

    address = check_scheduler_address(address, what=what)  # checked: no second lookup
    _scheme, host, _port = host_port(address, what)
    where = f"{what}: {address}"
    try:
        raw = _connect(address.infos, timeout_s)
    except OSError as exc:
        raise SchedulerError(
            f"{what}: no Dask scheduler answers at {address} within {timeout_s:g} s "
            f"({type(exc).__name__}); nothing was run or changed"
        ) from None
    try:
        raw.settimeout(timeout_s)
        sock = ssl_context.wrap_socket(raw, server_hostname=host) if ssl_context else raw
        (total,) = struct.unpack("<Q", _recv_exact(sock, 8))
        if not 16 <= total <= MAX_HANDSHAKE_BYTES:
            raise ValueError(f"first message claims {total} bytes")
        body = _recv_exact(sock, total)
        (n_frames,) = struct.unpack_from("<Q", body)
        if not 1 <= n_frames <= 64 or 8 * (n_frames + 1) > total:
            raise ValueError(f"first message claims {n_frames} frames")
        sizes = struct.unpack_from(f"<{n_frames}Q", body, 8)
        if sum(sizes) > MAX_HANDSHAKE_BYTES:
            raise ValueError("first message frames too large")
    except TimeoutError:
        raise SchedulerError(
            f"{where} accepted the connection but sent no Dask handshake within "
            f"{timeout_s:g} s; is it a Dask scheduler? nothing was run or changed"
        ) from None
    except (OSError, ValueError, struct.error) as exc:
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise SchedulerError(
            f"{where} does not speak the Dask protocol ({msg}); nothing was run or changed"
        ) from None
    finally:
        raw.close()


def scheduler_security(
    tls_ca_file: str | None = None, tls_cert: str | None = None, tls_key: str | None = None
):
    """A :class:`distributed.security.Security` for a ``tls://`` scheduler, or None.

    With no file given, None: dask's own configuration (``distributed.comm.tls.*``) applies.

    Raises
    ------
    StudyError
        A file is missing or only some of the three are given.
    """
    given = {"--tls-ca-file": tls_ca_file, "--tls-cert": tls_cert, "--tls-key": tls_key}
    if not any(given.values()):
        return None
    missing = [k for k, v in given.items() if not v]
    if missing:
        raise StudyError(f"{missing[0]}: required with the other --tls-* options")
    for k, v in given.items():
        if not Path(v).is_file():
            raise StudyError(f"{k}: no such file {v}")
    from distributed.security import Security

    return Security(
        tls_ca_file=tls_ca_file,
        tls_client_cert=tls_cert,
        tls_client_key=tls_key,
        require_encryption=True,
    )


def connect_scheduler(
    address: str,
    workers: int,
    timeout_s: float | None = None,
    security=None,
    what: str = "--scheduler",
):
    """Return ``(client, cluster_or_None)`` for a Dask scheduler address or ``"local"``.

    ``tcp://`` to a non-loopback host is unencrypted and unauthenticated: one warning line on
    stderr.  ``tls://`` uses ``security`` (a :class:`distributed.security.Security`, see
    :func:`scheduler_security`) or dask's ``distributed.comm.tls`` configuration.  The remote
    end is probed first (:func:`probe_scheduler`), and dask's connect timeouts are set to
    ``timeout_s``.  Errors about the address name ``what``: the command line's
    ``--scheduler``, or :func:`psdesign.run_study`'s ``scheduler``.

    Raises
    ------
    StudyError
        If the address is malformed or the TLS options do not fit its scheme.
    SchedulerError
        If dask.distributed is missing, nothing answers at ``address`` within ``timeout_s``
        (default :data:`CONNECT_TIMEOUT_S`) or the peer is not a Dask scheduler.
    """
    if isinstance(address, str):  # form and host, before the seconds of dask's import
        address = check_scheduler_address(address, what=what)  # checked: no second lookup
    try:
        import dask
        from distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover - dependency of psdesign
        raise SchedulerError(f"{what}: dask.distributed is not installed ({exc})") from exc
    if timeout_s is None:
        timeout_s = CONNECT_TIMEOUT_S
    from psdesign.study import cluster as cluster_mod

    if isinstance(address, cluster_mod.ClusterOptions):  # --cluster slurm|pbs: one job/worker
        _check_submit_command(address)
        return _start_batch_cluster(address, workers, Client)
    if address == "local":
        cluster = LocalCluster(
            n_workers=max(1, workers),
            threads_per_worker=1,
            processes=True,
            scheduler_kwargs=dict(cluster_mod.SCHEDULER_HTTP),
        )
        return Client(cluster), cluster
    scheme, _host, _port = host_port(address, what)  # tcp:// or tls:// (checked above)
    ssl_context = None
    if scheme == "tls":
        from distributed.security import Security

        sec = security if security is not None else Security()
        ssl_context = sec.get_connection_args("client").get("ssl_context")
        if ssl_context is None:
            raise StudyError(
                f"{what}: tls:// needs --tls-ca-file, --tls-cert and --tls-key "
                "(security= in Python, or dask config distributed.comm.tls.*)"
            )
        security = sec
    else:
        if security is not None:
            raise StudyError(
                f"--tls-ca-file: TLS options given but {address} is plain tcp://; use tls://"
            )
        if not _is_loopback(address):
            print(
                f"psdesign: warning: {address} is unencrypted and unauthenticated tcp:// to "
                "another machine; use tls:// with --tls-ca-file/--tls-cert/--tls-key",
                file=sys.stderr,
            )
    probe_scheduler(address, timeout_s, ssl_context, what)
    limits = {
        "distributed.comm.timeouts.connect": f"{timeout_s}s",
        "distributed.comm.timeouts.tcp": f"{max(timeout_s, 30.0)}s",
    }
    try:
        with dask.config.set(limits):
            client = Client(address, timeout=timeout_s, security=security)
    except (OSError, TimeoutError) as exc:
        raise SchedulerError(
            f"{what}: no Dask scheduler answers at {address} within {timeout_s:g} s "
            f"({type(exc).__name__}); nothing was run or changed"
        ) from exc
    except (MemoryError, ValueError) as exc:  # garbage after a valid-looking handshake
        raise SchedulerError(
            f"{what}: {address} does not speak the Dask protocol ({type(exc).__name__}); "
            "nothing was run or changed"
        ) from None
    return client, None


def _start_batch_cluster(opts, workers: int, client_cls):
    """Submit ``workers`` batch jobs and wait for the first worker (``--cluster-wait``).

    A refused submission (bad partition, account) or no worker in time: the jobs are cancelled
    and one :class:`SchedulerError` line is raised, before the output folder is touched.
    """
    from psdesign.study import cluster as cluster_mod

    cluster = cluster_mod.make_cluster(opts)
    client = None
    try:
        cluster.scale(jobs=max(1, workers))
        client = client_cls(cluster)
        cluster_mod.wait_for_first_worker(client, cluster, opts)
    except BaseException as exc:
        if client is not None:
            client.close(timeout=5)
        cluster.close(timeout=5)
        if isinstance(exc, ValueError):
            raise SchedulerError(str(exc)) from None
        raise
    return client, cluster


def _run_dask(
    client,
    payloads: list[dict],
    on_done: Callable[[dict, dict], None],
    no_worker_s: float = DEFAULT_WAIT_S,
) -> None:
    """Submit the cases to ``client`` and record each as it finishes; stop with
    :class:`WorkersLost` after ``no_worker_s`` seconds without any worker (dask would keep
    the cases queued for ever)."""
    from distributed import as_completed

    futs = {}
    for p in payloads:
        f = client.submit(
            execute_case,
            p,
            pure=False,
            key=f"psdesign-case-{p['case_id']}-{os.getpid()}-{time.monotonic_ns()}",
        )
        futs[f] = p
    done = as_completed(list(futs))
    alone_since = None
    try:
        while not done.is_empty():
            batch = done.next_batch(block=False)
            if not batch:
                alone_since = _check_workers(client, alone_since, no_worker_s, done.count())
                time.sleep(_POLL_S)
                continue
            for fut in batch:
                p = futs[fut]
                try:
                    rec = fut.result()
                except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker
                    rec = _failed(p, f"dask: {type(exc).__name__}: {' '.join(str(exc).split())}")
                on_done(p, rec)
    except BaseException:
        client.cancel(list(futs))
        raise


def _check_workers(client, alone_since: float | None, limit_s: float, waiting: int):
    """When the scheduler has had no worker for ``limit_s`` seconds, raise
    :class:`WorkersLost`; returns the time the workers went (None while there are some)."""
    if has_worker(client):
        return None
    now = time.monotonic()
    alone_since = now if alone_since is None else alone_since
    if now - alone_since >= limit_s:
        raise WorkersLost(
            f"no Dask worker for {limit_s:g} s while {waiting} case(s) wait (batch jobs past "
            "their walltime? workers stopped or never started?); finished cases are saved, "
            "rerun the command to resume (--cluster-wait SECONDS to wait longer)"
        )
    return alone_since


def _failed(payload: dict, error: str) -> dict:
    return {
        "status": "failed",
        "error": error,
        "results": {},
        "wall_time_s": None,
        "started_at": None,
        "finished_at": _now(),
        "host": None,
        "pid": None,
    }


# ----------------------------------------------------------------------------- main entry


def _machine() -> dict:
    info = {
        "host": socket.gethostname(),
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "cpu_count": os.cpu_count(),
    }
    try:
        import psutil

        info["memory_gb"] = round(psutil.virtual_memory().total / 2**30, 1)
    except Exception:  # noqa: BLE001, S110
        pass
    return info


def validate_case_specs(
    cases: list[Case], solver: str | None = None, outputs: Sequence[str] = ()
) -> None:
    """Check every case spec with the spec validators of the pipeline (before running), with
    ``solver`` (the study's, which the cases run) in its ``[flow]`` table when given: the
    memory budget depends on it; held to the work of the cases' ``outputs``
    (:func:`psdesign.schema.study.validate_case_spec`: no flow solve's memory without a K);
    and along each direction of their K (the copies an ``"auto"`` permeameter of explicit
    fibers stacks, :func:`psdesign.schema.spec.check_directions`).

    The image's warnings (:class:`psdesign.schema.image.ImageWarning`: "z is taken equal to
    x and y" of a slice folder, a voxel size against the file's) are the specs', not a case's:
    shown here once each for the study (:func:`psdesign.study.worker.show_case_warnings`), and
    the default case function does not repeat them (a 3-case study over a slice folder printed
    the z line 8 times, session 44).

    Raises
    ------
    StudyError
        Naming the first bad case, its parameters and the spec error.
    """
    import warnings

    from psdesign.study.worker import show_case_warnings

    caught: list = []
    try:
        with warnings.catch_warnings(record=True) as caught:  # the filters in force decide
            _validate_cases(cases, solver, outputs)
    finally:
        show_case_warnings(caught, None)


def _validate_cases(cases: list[Case], solver: str | None, outputs: Sequence[str]) -> None:
    """:func:`validate_case_specs`' checks, one case after the other."""
    import numpy as np

    from psdesign.schema.spec import check_directions
    from psdesign.schema.study import validate_case_spec

    directions = k_directions(outputs)

    try:
        from psdesign.packing.generators import parse_generator
    except ImportError:  # pragma: no cover - generators not available
        parse_generator = None
    for c in cases:
        try:
            spec = c.spec
            if solver is not None and isinstance(spec.get("flow"), dict):
                spec = {**spec, "flow": {**spec["flow"], "solver": solver}}
            spec = validate_case_spec(spec, outputs)
            check_directions(spec, spec["flow"], directions)
            if parse_generator is not None and "generator" in spec:
                parse_generator(spec, np.asarray(spec["rve"]["size"], dtype=float))
        except ValueError as exc:
            params = ", ".join(f"{k}={v}" for k, v in c.params.items())
            raise StudyError(
                f"parameters: case {c.case_id} ({params}, seed={c.seed}) gives a bad spec: {exc}"
            ) from exc


def check_study_dir(
    out_dir: str | Path,
    force: bool = False,
    force_option: str | None = "--force",
    files: Iterable[str] = STUDY_FILES,
    command: str = "study run",
    option: str = "-o",
) -> OutputDir:
    """:func:`psdesign.io.outputs.check_output_dir` for a study's output folder (``-o``);
    ``force_option`` None for a command without ``--force`` (``rev``); ``files`` what the
    command will write there (``rev``: also ``rev.csv``, ``rev.json``), each refused now if it
    exists and psdesign did not write it; ``command`` the command the folder's marker names;
    ``option`` the name messages give the folder (``out_dir`` in the Python API)."""
    return check_output_dir(
        out_dir,
        force=force,
        option=option,
        command=command,
        expected=tuple(files),
        legacy=STUDY_LEGACY,
        force_option=force_option,
        legacy_owns=psdesign_wrote,
    )


def _timeout(opts: RunOptions, study: Study) -> float | None:
    """The per-case time limit of a run: ``timeout_s`` (``--timeout``), else the study's."""
    return opts.timeout_s if opts.timeout_s is not None else study.timeout_s


def _check_case_fn_for_timeout(case_fn, timeout_s: float | None) -> None:
    """With a timeout every case runs in a child process that imports the case function by
    its name (:func:`psdesign.study.worker.importable_case_fn_name`): a callable that does not
    import back is refused here, before the output folder is made (it failed every case
    after it was, review s46)."""
    if timeout_s is None:  # a name or None: importable_case_fn_name returns it unchecked
        return
    try:
        importable_case_fn_name(case_fn)
    except ValueError as exc:
        raise StudyError(
            f"{exc} (each case runs in a child process that imports it); allowed: a "
            "module-level function of a module, or no timeout_s"
        ) from None


def run_study(
    study: str | Path | Study,
    out_dir: str | Path,
    options: RunOptions | None = None,
    *,
    command: str = "study run",
    out_option: tuple[str, str | None] = ("out_dir", "force=True"),
    scheduler_option: str = "scheduler",
    **fields: Any,
) -> pd.DataFrame:
    """Run (or resume) a study and return its results table.

    Parameters
    ----------
    study : str, Path, dict or Study
        A study file, its tables as a dict, or a loaded :class:`Study`.
    out_dir : str or Path
        Output folder (created; an existing one is resumed).
    options : RunOptions, optional
        Workers or scheduler, case function, time limit, retries, report, ``force``
        (default ``RunOptions()``: one local worker).
    command : str
        The command the output folder's marker names (``psdesign rev`` runs its study here).
    out_option : (str, str or None)
        How messages name ``out_dir`` and ``force``: this function's keywords
        ``("out_dir", "force=True")`` (the default); a command passes its flags (``study
        run``'s ``("-o", "--force")``, ``rev``'s ``("-o", None)``: it has no ``--force``).
    scheduler_option : str
        How messages about the scheduler's connection name it: the keyword ``"scheduler"``
        (the default, as :class:`RunOptions` names it), a command's ``"--scheduler"``.
    **fields
        :class:`RunOptions` fields as keywords, e.g. ``run_study(study, out, workers=2)``: the
        same as ``run_study(study, out, RunOptions(workers=2))`` (over ``options``' own
        values when both are given).

    Returns
    -------
    pandas.DataFrame
        One row per finished case of the design, in design order.

    Raises
    ------
    StudyError
        Invalid study or options (a :class:`psdesign.errors.SpecError`).
    SchedulerError
        The scheduler or batch cluster cannot be used (does not answer, no worker in time).
    psdesign.io.outputs.OutputError
        ``out_dir`` is refused (``/``, home, a file, a non-empty folder of the user's).
    StorageError
        Writing results failed (disk full, permissions); records written so far are intact.
    """
    # an unknown keyword: the one-line StudyError of rev_study / optimize_study (Python's
    # TypeError "run_study() got an unexpected keyword argument" until session 48)
    check_run_keywords(fields, {}, "run_study")
    _check_naming(command, out_option, scheduler_option)
    opts = _run_options(options, fields)
    _check_main_script(opts)
    if not isinstance(study, Study):  # a case function of the user's: no route planned
        study = load_study(study, opts.case_fn)
    cases = expand_design(study)
    # each case held to its worker's share of the memory, up front and while it runs
    share = partial(concurrent_workers, _at_once(opts, cases, out_dir), workers_option(out_option))
    if runs_pipeline(opts.case_fn):
        with share():
            validate_case_specs(cases, study.solver, study.outputs)
    _check_case_fn_for_timeout(opts.case_fn, _timeout(opts, study))
    option, force_option = out_option
    target = check_study_dir(
        out_dir, force=opts.force, force_option=force_option, command=command, option=option
    )
    check_same_study(study, target.path, option)  # another study's folder: refused, untouched
    with share():  # the payloads carry it (_payloads), the pool is at most that size
        return _connect_and_run(study, cases, target, opts, scheduler_option)


_OPTION_FIELDS = frozenset(f.name for f in fields_of(RunOptions))


def run_keywords() -> frozenset[str]:
    """The keywords :func:`run_study` takes besides ``study`` and ``out_dir``: ``options``,
    its naming and marker keywords and every :class:`RunOptions` field."""
    return _OPTION_FIELDS | {"options", "command", "out_option", "scheduler_option"}


def check_run_keywords(run_kw: dict, own: dict[str, str], caller: str, extra: str = "") -> None:
    """Refuse, before any work, a keyword of ``run_kw`` that :func:`run_study` does not take
    (its ``TypeError`` named ``run_study()``) or one that ``caller`` (a function running its
    study through :func:`run_study`, or :func:`run_study` itself) sets itself (``own``:
    keyword -> why; it was "got multiple values for keyword argument"): one
    :class:`StudyError` line naming the keyword, the allowed ones listed as ``extra`` (the
    caller's own, if any) and the runner's.

    >>> check_run_keywords({"wrkers": 2}, {"command": "set"}, "f", "a")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    psdesign.errors.StudyError: wrkers: not a keyword of f (allowed: a and the runner's case_fn, ...
    """
    for key in run_kw:
        if key in own:
            raise StudyError(f"{key}: set by {caller} itself ({own[key]})")
    refuse_unknown_keywords(run_kw, run_keywords() - own.keys(), caller, extra)


def _check_naming(command, out_option, scheduler_option) -> None:
    """``command`` a text, ``out_option`` a pair (text, text or None), ``scheduler_option`` a
    text, else one :class:`StudyError` line naming the keyword (``command=3`` was written into
    the folder's marker; ``out_option=3`` was "cannot unpack non-iterable int object")."""
    pair = isinstance(out_option, tuple | list) and len(out_option) == 2
    if not (pair and isinstance(out_option[0], str) and isinstance(out_option[1], str | None)):
        raise StudyError(
            "out_option: must be a pair (name of out_dir, name of force or None), such as "
            f"('out_dir', 'force=True'), got {short(out_option)}"
        )
    for key, value in (("command", command), ("scheduler_option", scheduler_option)):
        if not isinstance(value, str) or not value.strip():
            raise StudyError(f"{key}: must be a non-empty text, got {short(value)}")


def _run_options(options: RunOptions | None, fields: dict) -> RunOptions:
    """``options`` (default ``RunOptions()``) with the keyword ``fields`` over it."""
    if options is None:
        return RunOptions(**fields)
    if not isinstance(options, RunOptions):
        raise StudyError(
            f"options: must be a psdesign.study.RunOptions, got {type(options).__name__} "
            "(workers, scheduler, ... are keywords: run_study(study, out_dir, workers=2))"
        )
    return replace(options, **fields) if fields else options


def _connect_and_run(
    study: Study, cases: list[Case], target, opts: RunOptions, scheduler_option: str
) -> pd.DataFrame:
    """Connect to the scheduler, claim and lock the output folder, run the cases.

    The scheduler is connected first: a dead one must not touch the output folder; its
    errors name ``scheduler_option``.
    """
    store = CaseStore(target.path)
    client = cluster = None
    try:
        with stop_on_interrupt():
            if opts.scheduler:
                _check_submit_command(opts.scheduler)  # before the "submitting" line
                _say_waiting(opts.scheduler, opts.workers, opts.progress)
                with _local_worker_preload(opts.scheduler):
                    client, cluster = connect_scheduler(
                        opts.scheduler, opts.workers, security=opts.security, what=scheduler_option
                    )
            # the folder and its marker (report.html only when written); nothing is deleted
            # before the lock
            _claim(target, STUDY_FILES if opts.report else STUDY_FILES_NO_REPORT)
            store.prepare()
            # workers stop before the lock; its refusal names the command's option (-o)
            with _run_lock(target.path, target.option), stop_on_interrupt():
                store.remove_stale_temp()
                if not opts.report:  # before the cases: an interrupted run left the old one
                    remove_owned_files(target.path, ["report.html"])
                return _run_locked(study, cases, store, list(study.parameters), client, opts)
    finally:
        if client is not None:
            client.close(timeout=5)
        if cluster is not None:
            cluster.close(timeout=5)
        restore_dask_logs()  # quieted while an interrupted run stopped its workers


def _fewer_points_note(study, cases) -> str:
    """``" (n_samples = 8 gave 2 distinct points)"`` when coinciding samples of a latin
    hypercube / Sobol design ran once each (review s53: the smaller design went unsaid)."""
    n = study.n_samples if study.design in ("latin-hypercube", "sobol") else None
    from psdesign.study.design import point_key

    points = len({point_key(c.params) for c in cases})
    if not n or points >= n:
        return ""
    return f" (n_samples = {n} gave {points} distinct points)"


def _local_worker_preload(scheduler):
    """For ``scheduler="local"``: the cluster's workers ignore Ctrl-C (``_dask_preload``)."""
    if scheduler != "local":
        return contextlib.nullcontext()
    import dask
    import distributed  # noqa: F401 - its config defaults first: set() undoes only its key

    # beside the user's own worker preloads from their dask config, not instead (review s53)
    theirs = list(dask.config.get("distributed.worker.preload", None) or [])
    return dask.config.set(
        {"distributed.worker.preload": [*theirs, "psdesign.study._dask_preload"]}
    )


def _check_submit_command(scheduler) -> None:
    """For ``--cluster``: the batch system's submit command is on ``PATH`` (SchedulerError
    naming the option otherwise); nothing for a ``--scheduler`` address."""
    from psdesign.study import cluster as cluster_mod

    if isinstance(scheduler, cluster_mod.ClusterOptions):
        try:
            cluster_mod.check_submit_command(scheduler)
        except ValueError as exc:
            raise SchedulerError(str(exc)) from None


def _say_waiting(scheduler, workers: int, progress: bool) -> None:
    """One line while batch jobs queue: the wait can be long and the folder is not yet made."""
    wait_s = getattr(scheduler, "wait_s", None)
    if progress and wait_s is not None:
        print(
            f"[study] submitting {max(1, workers)} {scheduler.submit_command} job(s); waiting up "
            f"to {wait_s:g} s for the first worker (--cluster-wait)",
            file=sys.stderr,
        )


def _claim(target, files) -> None:
    try:
        claim_output_dir(target, files)
    except OSError as exc:
        raise StorageError(
            exc.errno, f"cannot write {target.path}: {exc.strerror or exc}; nothing was changed"
        ) from exc


def _run_locked(
    study: Study,
    cases: list[Case],
    store: CaseStore,
    param_names: list[str],
    client,
    opts: RunOptions,
) -> pd.DataFrame:
    """Run the cases still to do (the output folder claimed and locked), then write the
    tables, the run's entry in ``runs.json`` and the report."""
    by_id = {c.case_id: c for c in cases}
    timeout = _timeout(opts, study)
    out = store.out
    t_start = time.perf_counter()
    started = _now()
    key, records = _stored_records(study, cases, store, by_id)
    todo = _todo(cases, records, opts)

    prog = Progress(len(cases), already_done=len(cases) - len(todo), enabled=opts.progress)
    prog.start(
        f"[study] {study.name}: {len(cases)} cases, {len(cases) - len(todo)} already done, "
        f"{len(todo)} to run on {_backend(opts)} -> {out}{_fewer_points_note(study, cases)}"
    )

    def on_done(payload: dict, rec: dict) -> None:
        c = by_id[payload["case_id"]]
        full = {
            "case_id": key[c.case_id],
            "index": c.index,
            "params": c.params,
            "seed": c.seed,
            **rec,
        }
        watcher.done(c.case_id)
        if full.pop("disk_full", False):  # the disk, not the case: stop, resume runs it again
            raise StorageError(
                errno.ENOSPC,
                f"case {key[c.case_id]} stopped, the disk is full ({full['error']}); it is not "
                "recorded: free space and run the same command again to resume",
            )
        store.write_record(full)  # raises StorageError: stop, earlier rows intact
        records[c.case_id] = _at(full, c)
        tables.changed()
        prog.update(c.case_id, full["status"], full.get("wall_time_s"), full.get("error"))

    payloads = _payloads(study, todo, store, key, opts.case_function(), timeout)
    # each running case's stage (generate -> solve K_d -> transport -> preview) every 15 s
    watch = {p["case_id"]: Path(p["workdir"]) for p in payloads} if opts.progress else {}
    watcher = StageWatcher(watch)
    tables = TableWriter(store, records, param_names, TABLE_INTERVAL_S)
    with watcher, tables.flushed_on_error():
        _dispatch(client, payloads, on_done, opts)

    df = tables.flush()
    counts = df["status"].value_counts().to_dict() if len(df) else {}
    times = {
        "started_at": started,
        "finished_at": _now(),
        "wall_time_s": time.perf_counter() - t_start,
    }
    _append_run(store, _run_entry(times, opts, timeout, len(cases), len(payloads), counts, study))
    if opts.report:
        _write_report(out)
    summary = ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
    prog.finish(
        f"[study] done in {time.perf_counter() - t_start:.1f} s: {summary} -> {out / 'results.csv'}"
    )
    return df


def _stored_records(study: Study, cases: list[Case], store: CaseStore, by_id: dict):
    """Write ``study.json`` and return ``(key, records)``: the id each case is stored under
    and the finished records, as cases of the current design."""
    loaded = store.load_records()
    # a case finished at another position (a seed or level dropped) keeps its record and
    # folder under the id it ran with; its id in the tables is the design's
    stored = match_finished(cases, loaded)
    key = {c.case_id: stored.get(c.case_id, c.case_id) for c in cases}
    table = study.to_dict()
    doc = {
        "study": table,
        "n_cases": len(cases),
        "cases": [{**c.to_dict(), "stored_as": key[c.case_id]} for c in cases],
    }
    from psdesign.report.image_source import HEADER_KEY, image_header

    # what the report shows of the image, as the run read it (a file replaced since showed
    # its own header in a report written later; session 45)
    header = image_header(table, store.out)
    store.write_json("study.json", doc if header is None else {**doc, HEADER_KEY: header})
    return key, {c: _at(loaded[r], by_id[c]) for c, r in stored.items()}


def _todo(cases: list[Case], records: dict, opts: RunOptions) -> list[Case]:
    """The cases to run: no record, or one ``opts`` says to retry."""
    skip = {"ok"} if opts.retry_failed else {"ok", "failed", "timeout"}
    if not opts.retry_not_converged:
        skip.add("not_converged")
    return [c for c in cases if records.get(c.case_id, {}).get("status") not in skip]


def _backend(opts: RunOptions) -> str:
    """Where the cases run, for the start line."""
    if opts.scheduler:
        return f"dask {opts.scheduler}"
    return "in-process" if opts.workers == 0 else f"{opts.workers} local worker(s)"


def _payloads(study: Study, todo: list[Case], store: CaseStore, key: dict, case_fn, timeout):
    """What a worker needs to run each case of ``todo``, with the run's workers at once
    (:func:`~psdesign.schema.budget.workers_at_once`: the share it is held to)."""
    at_once, option = workers_at_once()
    return [
        {
            "case_id": c.case_id,
            "spec": c.spec,
            "outputs": list(study.outputs),
            "solver": study.solver,
            "workdir": str(store.workdir(key[c.case_id])),
            "out_dir": str(store.out),
            "case_fn": case_fn,
            "timeout_s": timeout,
            "at_once": at_once,
            "workers_option": option,
        }
        for c in todo
    ]


def _dispatch(client, payloads: list[dict], on_done, opts: RunOptions) -> None:
    """Run ``payloads`` on the Dask ``client``, in this process or on the local pool."""
    if payloads and client is not None:
        _run_dask(client, payloads, on_done, opts.wait_s())
    elif payloads and opts.workers == 0:
        _run_inline(payloads, on_done)
    elif payloads:  # never more at once than the share the cases were checked at
        at_once = workers_at_once()[0]
        _run_pool(payloads, min(opts.workers, len(payloads), at_once), on_done)


def _run_entry(
    times: dict, opts: RunOptions, timeout, n_cases: int, n_run: int, counts, study: Study
) -> dict:
    """This run's entry in ``runs.json``: ``times`` (started, finished, wall time) first, the
    study file's path (``study_file``: run metadata, kept out of ``study.json``) last."""
    return {
        **times,
        "workers": opts.workers,
        "scheduler": None if opts.scheduler is None else str(opts.scheduler),
        "timeout_s": timeout,
        "n_cases": n_cases,
        "n_run": n_run,
        "status_counts": {str(k): int(v) for k, v in counts.items()},
        "case_fn": case_fn_name(opts.case_fn),
        "study_file": None if study.source is None else str(study.source),
        "machine": _machine(),
    }


def _at(record: dict, case: Case) -> dict:
    """``record`` as ``case`` of the current design: its id and position (rows in design
    order), whatever id the record is stored under."""
    return {
        **record,
        "case_id": case.case_id,
        "index": case.index,
        "params": case.params,
        "seed": case.seed,
    }


TABLE_INTERVAL_S = 5.0
"""Least time between two rebuilds of results.csv/.parquet while cases finish."""
TABLE_SHARE = 0.1
"""Most of the run's wall time spent rebuilding the tables (the interval grows with them)."""


class TableWriter:
    """Rebuild the results tables at the first case, then at most every few seconds, and
    always at the end.

    Rebuilding after every case was quadratic (60 000 cases: 60 000 rebuilds of up to 60 000
    rows).  The wait after a rebuild is ``max(interval_s, rebuild time / TABLE_SHARE)``, so at
    most ~10 % of the run goes to tables however big they get.  The records stay the source of
    truth; :meth:`flushed_on_error` rebuilds them on an interrupt or error too, so the tables
    on disk hold every finished case whenever the run stops (short of ``kill -9``: the next
    run rebuilds them).

    Parameters
    ----------
    store : CaseStore
    records : dict
        case_id -> record, updated by the caller as cases finish.
    param_names : list of str
    interval_s : float
        Least time between two rebuilds.
    clock : callable
        Seconds, monotonic (a benchmark simulates the arrival of cases with its own).
    """

    def __init__(
        self,
        store: CaseStore,
        records: dict,
        param_names: list[str],
        interval_s: float,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.store, self.records, self.param_names = store, records, param_names
        self.interval_s, self.clock = interval_s, clock
        self._next = clock()  # the first finished case shows at once, then the throttle
        self._dirty = True  # tables a killed run left may lack records: rebuild them at least once

    def changed(self) -> None:
        """A record was added: rebuild now if the wait is over."""
        self._dirty = True
        if self.clock() >= self._next:
            self.flush()

    def flush(self) -> pd.DataFrame:
        """Rebuild the tables from every record now (atomic writes) and return the table."""
        t0 = self.clock()
        df = self.store.write_tables(self.records.values(), self.param_names)
        spent = self.clock() - t0
        self._dirty = False
        self._next = self.clock() + max(self.interval_s, spent / TABLE_SHARE)
        return df

    @contextmanager
    def flushed_on_error(self) -> Iterator[None]:
        """On any exception (Ctrl-C, storage error) leave tables holding every finished case."""
        try:
            yield
        except BaseException:
            if self._dirty:
                try:
                    self.flush()
                except Exception:  # noqa: BLE001, S110 - the first error is the one to report
                    pass
            raise


def _write_report(out: Path) -> None:
    try:
        from psdesign.report import write_report

        write_report(out)
    except StorageError:
        raise
    except Exception as exc:  # noqa: BLE001 - the results are safe; say why no report
        print(f"[study] warning: report not written: {type(exc).__name__}: {exc}", file=sys.stderr)


def _append_run(store: CaseStore, entry: dict) -> None:
    path = store.out / "run.json"
    runs = []
    if path.is_file():
        try:
            runs = json.loads(path.read_text()).get("runs", [])
        except (OSError, ValueError, AttributeError):
            runs = []
    runs.append(entry)
    store.write_json("run.json", {"runs": runs})
