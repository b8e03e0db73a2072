"""Ctrl-C (and SIGTERM) for the study runner: stop everything within seconds, leave a
resumable folder.

The first SIGINT (Ctrl-C, to the runner alone or to its whole process group as a terminal sends
it) raises :class:`KeyboardInterrupt` in the runner; further SIGINTs while it stops are ignored,
so a second quick Ctrl-C can no longer break the clean-up half-way and leave workers running.
SIGTERM (``kill PID``, ``timeout``, ``scancel``) takes the same way out and raises
:class:`Terminated`, so the lock ``OUT/.lock`` is released as well.
On the way out every process the runner started (pool workers, per-case child processes, a
local Dask cluster; child processes that existed before the run are left alone) is sent
SIGTERM and, if still alive after :data:`GRACE_S`, SIGKILL.  Case records are written
atomically, so the folder is resumable: rerunning the command resumes.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator

__all__ = [
    "GRACE_S",
    "Terminated",
    "held_signals",
    "ignore_sigint",
    "restore_dask_logs",
    "sigint_blocked",
    "stop_children",
    "stop_on_interrupt",
    "terminate_as_interrupt",
]

GRACE_S = 1.5
"""Seconds between SIGTERM and SIGKILL for the runner's child processes."""


class Terminated(KeyboardInterrupt):  # noqa: N818 - a KeyboardInterrupt, caught as one
    """SIGTERM (``kill``, ``timeout``, a batch system cancelling the job) during a run: stops
    the run as Ctrl-C does; the command exits with status 143 (128 + SIGTERM)."""


def ignore_sigint() -> None:
    """In a worker process: ignore SIGINT (the runner decides when workers stop), then
    unblock it (:func:`sigint_blocked`: a Ctrl-C held since the start is dropped)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


@contextlib.contextmanager
def sigint_blocked() -> Iterator[None]:
    """Block SIGINT in this thread while the body starts worker processes, which inherit the
    mask: a Ctrl-C to the process group then waits in a worker until its initializer ignores
    it (:func:`ignore_sigint`).  Before, a worker still importing got it and printed a 20-80
    line ``KeyboardInterrupt`` traceback (or "Fatal Python error: init_import_site") under
    the runner's line (walk-study, session 53).  The runner gets the signal after the body, or
    during it when another of its threads has SIGINT unblocked (the submit loop's ``except
    BaseException`` then stops the run as on any interrupt)."""
    if not hasattr(signal, "pthread_sigmask") or (
        threading.current_thread() is not threading.main_thread()
    ):
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _key(proc) -> tuple[int, float]:
    try:
        return proc.pid, proc.create_time()
    except Exception:  # noqa: BLE001 - gone already
        return proc.pid, -1.0


def _children_now() -> set[tuple[int, float]]:
    try:
        import psutil

        return {_key(c) for c in psutil.Process().children()}
    except Exception:  # noqa: BLE001 - psutil missing or no access
        return set()


def _multiprocessing_helpers() -> set[int]:
    """Pids of multiprocessing's own helper processes (the resource tracker, the fork server):
    they exit with this process.  Killed with the workers, the tracker was relaunched and
    printed a ``KeyError: '/mp-...'`` traceback for each semaphore the pool then released
    (session 35's failure audit: 4 of 10 Ctrl-C of a two-worker ``study run``)."""
    pids = set()
    for module, obj, attr in (
        ("multiprocessing.resource_tracker", "_resource_tracker", "_pid"),
        ("multiprocessing.forkserver", "_forkserver", "_forkserver_pid"),
    ):
        mod = sys.modules.get(module)
        pid = getattr(getattr(mod, obj, None), attr, None)
        if isinstance(pid, int):
            pids.add(pid)
    return pids


def stop_children(grace_s: float = GRACE_S, keep: set[tuple[int, float]] | None = None) -> int:
    """Terminate the child processes of this one and all their descendants (SIGTERM, SIGKILL).

    Parameters
    ----------
    grace_s : float
        Seconds between SIGTERM and SIGKILL.
    keep : set of (pid, create_time), optional
        Direct children to leave alone (those that existed before the run started).

    Returns
    -------
    int
        Number of processes that were signalled.
    """
    try:
        import psutil
    except ImportError:  # pragma: no cover - psutil is a dependency
        return 0
    keep = keep or set()
    helpers = _multiprocessing_helpers()
    targets = []
    try:
        for child in psutil.Process().children():
            if _key(child) in keep or child.pid in helpers:
                continue
            targets.append(child)
            with contextlib.suppress(psutil.Error):
                targets.extend(child.children(recursive=True))
    except psutil.Error:  # pragma: no cover
        return 0
    for k in targets:
        with contextlib.suppress(psutil.Error):
            k.terminate()
    # multiprocessing's own children are waited for by multiprocessing: reaped here (psutil
    # waits with waitpid), their Process objects stayed "alive" for ever and a process pool's
    # manager thread spun in shutdown_workers, so the runner never exited after "interrupted"
    # (walk-study, session 53: 2 of 3 Ctrl-C, 2 of 9 SIGTERM)
    pids = {k.pid for k in targets}
    owned = {pid: p for pid, p in _multiprocessing_children().items() if pid in pids}
    others = [k for k in targets if k.pid not in owned]
    join_within(owned.values(), grace_s)
    _gone, alive = psutil.wait_procs(others, timeout=grace_s)
    for k in alive + [k for k in targets if k.pid in owned and owned[k.pid].is_alive()]:
        with contextlib.suppress(psutil.Error):
            k.kill()
    join_within(owned.values(), grace_s)
    psutil.wait_procs(alive, timeout=grace_s)
    return len(targets)


def _multiprocessing_children() -> dict:
    """This process's live :mod:`multiprocessing` children (pool workers), by pid."""
    import multiprocessing

    return {p.pid: p for p in multiprocessing.active_children() if p.pid is not None}


def join_within(procs, grace_s: float) -> None:
    """Join multiprocessing ``procs`` within ``grace_s`` seconds in all."""
    import time

    deadline = time.monotonic() + grace_s
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(max(0.0, deadline - time.monotonic()))


_STATE: dict = {"depth": 0, "hit": False, "before": set()}


def _on_sigint(signum, frame) -> None:
    if _STATE["hit"]:
        return  # already stopping; the clean-up is bounded by GRACE_S
    if _unsafe_to_raise(frame):  # inside an import (VTK: segfault) or an LLVM callback
        _resend_later(signum, _on_sigint)
        return
    _STATE["hit"] = True
    _quiet_dask_logs()  # at once: a group signal already stops a local cluster's workers
    term = signum == signal.SIGTERM
    if _cli_command() is None:  # library use: say why the run stops; a command says it once
        what = "terminated (SIGTERM)" if term else "interrupted"
        print(f"psdesign: {what}; stopping workers ...", file=sys.stderr, flush=True)
    raise Terminated if term else KeyboardInterrupt


def _cli_command():
    """The running command's progress printer, or None (library use): the ``psdesign``
    command prints its one line (``psdesign: interrupted``) on the way out."""
    progress = sys.modules.get("psdesign.progress")
    return progress.active() if progress is not None else None


@contextlib.contextmanager
def stop_on_interrupt() -> Iterator[None]:
    """Run the body with the Ctrl-C policy of this module (main thread only; nestable).

    On :class:`KeyboardInterrupt` all child processes are stopped before it propagates (so
    an inner use inside the output-folder lock stops the workers before the lock is released).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    outer = _STATE["depth"] == 0
    if outer:
        _STATE["hit"] = False
        _STATE["before"] = _children_now()
        previous = signal.signal(signal.SIGINT, _on_sigint)
        previous_term = signal.signal(signal.SIGTERM, _on_sigint)
    _STATE["depth"] += 1
    try:
        yield
    except KeyboardInterrupt:
        _STATE["hit"] = True  # also for an interrupt raised before the handler saw it
        _quiet_dask_logs()
        stop_children(keep=_STATE["before"])
        raise
    finally:
        _STATE["depth"] -= 1
        if outer:
            signal.signal(signal.SIGINT, previous)
            signal.signal(signal.SIGTERM, previous_term)


def _quiet_dask_logs() -> None:
    """Stopping: a local Dask cluster's nannies (in this process) log "distributed.nanny -
    WARNING - Restarting worker" for each worker :func:`stop_children` ends, 1-4 lines above
    the command's one line (walk-study, session 53).  Until :func:`restore_dask_logs`."""
    if "distributed" not in sys.modules or "dask_level" in _STATE:
        return
    import logging

    log = logging.getLogger("distributed")
    _STATE["dask_level"] = log.level
    log.setLevel(logging.CRITICAL)


def restore_dask_logs() -> None:
    """Dask's log level as it was before an interrupt quieted it (once its cluster is closed)."""
    if "dask_level" in _STATE:
        import logging

        logging.getLogger("distributed").setLevel(_STATE.pop("dask_level"))


_TERM: dict = {"pid": None, "hit": False}


def _on_sigterm(signum, frame) -> None:  # noqa: ARG001
    if os.getpid() != _TERM["pid"]:  # a forked child that kept the handler: die as by default
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGTERM)
        return
    if _TERM["hit"]:
        return  # already stopping: a second SIGTERM must not break the clean-up half-way
    if _unsafe_to_raise(frame):  # inside an import (VTK: segfault) or an LLVM callback
        _resend_later(signal.SIGTERM, _on_sigterm)
        return
    _TERM["hit"] = True
    raise Terminated


def _on_sigint_cli(signum, frame) -> None:  # noqa: ARG001
    """Ctrl-C in a command: :class:`KeyboardInterrupt`, as Python's own handler, but not
    inside an ``import``: a KeyboardInterrupt half-way through importing VTK (pyvista's first
    import, ``diffusivity --fields`` at 5 s) ended the process with SIGSEGV, no line and the
    staging folder left (failure audit s36, 2 of 8 Ctrl-C at 5.0-5.5 s)."""
    if os.getpid() != _TERM["pid"]:  # a forked child that kept the handler: Python's own
        signal.default_int_handler(signum, frame)
    if _unsafe_to_raise(frame):
        _resend_later(signal.SIGINT, _on_sigint_cli)
        return
    raise KeyboardInterrupt


def _resend_later(signum: int, handler) -> None:
    """Send ``signum`` to this process again in 50 ms (once the import is done), if the
    command (:func:`terminate_as_interrupt`) still runs or ``handler`` is still installed.

    Not only while ``handler`` is: a study run or :func:`held_signals` replaces it right after
    the imports, and the signal was dropped (``study optimize`` Ctrl-C'd at 1.5-2.5 s ran all
    its cases; failure audit s36)."""

    def resend() -> None:
        if _TERM["pid"] == os.getpid() or signal.getsignal(signum) is handler:
            os.kill(os.getpid(), signum)

    timer = threading.Timer(0.05, resend)
    timer.daemon = True
    timer.start()


def _unsafe_to_raise(frame) -> bool:
    """True where raising would do harm, so the signal is sent again in 50 ms: ``frame`` runs
    inside an ``import`` (the import system's frames are below it), or inside llvmlite, whose
    Python code LLVM calls back from C while numba compiles a kernel.  A
    :class:`KeyboardInterrupt` raised in such a ctypes callback is printed ("Exception ignored
    on calling ctypes callback function") and dropped, LLVM's object cache misses the code, and
    numba then stopped with ``RuntimeError: no compiled object yet`` on its cache save: a
    Ctrl-C during a cold compile gave a traceback and exit 1, not ``psdesign: interrupted``
    (session 36: 5 of 12 Ctrl-C at 3-50 s into a cold voxel solve; 0 of 6 after)."""
    while frame is not None:
        name = frame.f_code.co_filename
        if name.startswith("<frozen importlib._bootstrap") or _LLVMLITE in name:
            return True
        frame = frame.f_back
    return False


_LLVMLITE = f"{os.sep}llvmlite{os.sep}binding{os.sep}"
"""Path part of llvmlite's ctypes bindings (the callbacks LLVM makes into Python)."""


def _reset_sigterm_in_child() -> None:
    """After ``fork``: a child (a forked worker pool) dies on SIGTERM as by default and gets
    Python's own SIGINT handler back."""
    with contextlib.suppress(ValueError, OSError):
        if signal.getsignal(signal.SIGTERM) is _on_sigterm:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
        if signal.getsignal(signal.SIGINT) is _on_sigint_cli:
            signal.signal(signal.SIGINT, signal.default_int_handler)


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_reset_sigterm_in_child)


@contextlib.contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Run the body with SIGTERM raising :class:`Terminated` (a :class:`KeyboardInterrupt`).

    ``kill PID``, ``timeout`` or a batch system's cancel then leaves a command the way Ctrl-C
    does: ``finally`` blocks run, so a staged output folder (``.psdesign-*.tmp``) is removed
    and nothing half-written is left.  A SIGTERM that arrives during an ``import`` takes
    effect when the import is done (an exception half-way through importing VTK crashed the
    process with SIGSEGV, leaving the staging folder), and so does a SIGINT (Ctrl-C), which
    otherwise raises :class:`KeyboardInterrupt` as Python's own handler (when Python's handler
    is the one in place).  Further SIGTERMs while it stops are ignored; forked child processes
    get the default actions back.  Main thread only (elsewhere a no-op); the previous handlers
    are restored on the way out.
    :func:`stop_on_interrupt` (a study run) installs its own handler inside and restores
    this one after.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGTERM)
    previous_int = signal.getsignal(signal.SIGINT)
    saved = dict(_TERM)
    _TERM.update(pid=os.getpid(), hit=False)
    signal.signal(signal.SIGTERM, _on_sigterm)
    if previous_int is signal.default_int_handler:  # not an ignored / a caller's own Ctrl-C
        signal.signal(signal.SIGINT, _on_sigint_cli)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)
        if signal.getsignal(signal.SIGINT) is _on_sigint_cli:
            signal.signal(signal.SIGINT, previous_int)
        _TERM.update(saved)


@contextlib.contextmanager
def held_signals() -> Iterator[None]:
    """Hold SIGINT and SIGTERM during the body and deliver them when it ends.

    For C code that calls back into Python and swallows the exceptions raised there: a VTK
    render (pyvista's smooth shading runs as a Python VTK algorithm; a Ctrl-C raised inside it
    was printed as a VTK error dump and lost, and ``generate`` went on and exited 0).  The
    signal is re-raised (:func:`signal.raise_signal`) with the previous handlers back in place,
    so it takes its usual way out (``psdesign: interrupted``, exit 130) once the body returns.
    And for making a spawn-based process pool: multiprocessing registers each of its named
    semaphores with its resource tracker a few lines before the semaphore's finalizer exists,
    so an interrupt in between left the tracker's "leaked semaphore" warning (session 54).
    Keep such bodies short: the interrupt waits for them.  Main thread only (elsewhere a no-op).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []

    def hold(signum, frame) -> None:  # noqa: ARG001
        held.append(signum)

    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    for sig in previous:
        signal.signal(sig, hold)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)
        if held:
            signal.raise_signal(held[0])
