"""One compile per numba signature across processes, and cache saves that keep every signature.

Processes that share one numba cache directory (``pytest -n 2``, ``psdesign warmup --jobs 2``, a
study's parallel workers) used to compile the same kernels side by side on a cold cache: 150-190
s of duplicated CPU per cold test run on two cores (``benchmarks/RESULTS.md``, suite15).
Importing :mod:`solvers.jit` installs two patches from this module into numba (once per
process):

- :func:`locked_compile` in place of ``numba.core.dispatcher.Dispatcher.compile``: for a
  dispatcher with an on-disk cache, the compile of one signature runs under an exclusive
  ``flock`` on a lock file of that signature (:func:`compile_lock_path`). numba's own
  ``compile`` then looks in the disk cache first (``Cache.load_overload`` reads the index file
  anew on every call), so a process that waited for another one loads its result instead of
  compiling it again.
- :func:`locked_save` in place of ``numba.core.caching.IndexDataCacheFile.save``: the index
  read-pick-write under an exclusive lock per function, data written before the index names it
  (numba issue 10128: two unlocked saves can leave an index naming another signature's code).

**Lock key: one per signature** (the function's cache file name plus a hash of the argument types
and the target machine).  A per-function key would make a process that needs ``prolong_jacobi``'s
uint8 signature wait (12 s of CPU, more under load) for another process compiling its sub-voxel
one, which it does not need.

**Nested compiles.** Compiling a function compiles the functions it calls (numba's typing calls
``Dispatcher.compile`` of each callee), so a process holds the locks of one path down the call
graph, taken in call order. The call graph of the project's kernels is acyclic, so two processes
cannot wait on each other; a thread that re-enters a lock it holds (numba compiling a signature
it is already compiling) counts depth instead of opening a second descriptor (``flock`` on a
second descriptor of one file blocks, even in the same process). Waiting is by polling with a
deadline (:data:`COMPILE_WAIT_S`): after it, numba's unlocked behaviour (compile anyway), so
even mutual recursion across two processes cannot hang. The lock is taken inside numba's
in-process ``global_compiler_lock``, so one thread per process waits or compiles at a time, as
numba already runs them.

**Unaffected:** dispatchers without ``cache=True`` (numba's ``NullCache``), a disabled cache,
``NUMBA_DISABLE_JIT`` (no dispatcher at all), platforms without ``fcntl`` (no lock: numba's own
behaviour). A holder that crashes releases its ``flock`` with its descriptors (the kernel does).
Lock files stay in the cache directory (removing one while another process waits on it would let
a third take a fresh lock on a new file).
"""

from __future__ import annotations

import contextlib
import hashlib
import itertools
import threading
import time
from collections.abc import Iterator

from numba.core import caching, dispatcher, sigutils
from numba.core.compiler_lock import global_compiler_lock

__all__ = [
    "COMPILE_WAIT_S",
    "compile_lock_path",
    "file_lock",
    "install",
    "locked_compile",
    "locked_save",
]

COMPILE_WAIT_S = 900.0
"""Longest wait (s) for another process's compile of one signature before compiling anyway.  The
largest single compiles take 12-15 s of CPU alone (``prolong_jacobi``) and 30-90 s of wall in a
busy test run; a process may wait for a whole call tree (a caller and the callees it compiles),
minutes under load (``benchmarks/RESULTS.md``, suite16)."""

_POLL_S = (0.01, 0.02, 0.05, 0.1)
"""Poll intervals while another process holds a lock (then the last one, repeated)."""

_LOCAL = threading.local()
"""``held``: the lock files this thread holds, path -> (open file, depth).  Per thread: another
thread of the process must wait like another process (its own descriptor's ``flock`` does)."""


def _held() -> dict[str, tuple[object, int]]:
    """This thread's registry of held lock files (see :data:`_LOCAL`)."""
    held = getattr(_LOCAL, "held", None)
    if held is None:
        held = _LOCAL.held = {}
    return held


_NUMBA_SAVE = caching.IndexDataCacheFile.save
_NUMBA_COMPILE = dispatcher.Dispatcher.compile


def _acquire(f: object, wait_s: float) -> bool:
    """Take an exclusive ``flock`` on the open file ``f``; False after ``wait_s`` seconds."""
    import fcntl

    deadline = time.monotonic() + wait_s
    for pause in itertools.chain(_POLL_S, itertools.repeat(_POLL_S[-1])):
        try:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            if time.monotonic() >= deadline:
                return False
            time.sleep(pause)
    return False  # pragma: no cover (the loop above only returns)


@contextlib.contextmanager
def file_lock(path: str, wait_s: float = COMPILE_WAIT_S) -> Iterator[bool]:
    """Hold an exclusive ``flock`` on ``path`` (created if missing) for the block.

    Re-entrant within a thread (a nested request for a lock the thread holds counts depth);
    exclusive between threads and processes.
    Yields True if locked; False (block runs unlocked, numba's own behaviour) where ``fcntl`` is
    missing, the file cannot be opened, or the lock was not free within ``wait_s`` seconds.
    """
    registry = _held()
    held = registry.get(path)
    if held is not None:
        registry[path] = (held[0], held[1] + 1)
        try:
            yield True
        finally:
            f, depth = registry[path]
            registry[path] = (f, depth - 1)
        return
    try:
        import fcntl  # noqa: F401 (POSIX only)

        f = open(path, "ab")  # noqa: SIM115 (closed below; closing releases the lock)
    except (ImportError, OSError):
        yield False
        return
    try:
        locked = _acquire(f, wait_s)
        if locked:
            registry[path] = (f, 1)
        try:
            yield locked
        finally:
            if locked:
                del registry[path]
    finally:
        f.close()


def compile_lock_path(disp: dispatcher.Dispatcher, sig: object) -> str | None:
    """Lock file for compiling ``sig`` of ``disp`` (``<cache file base>.<hash>.lock`` next to
    the cache index; the hash of the argument types and the target machine), or None if
    ``disp`` has no enabled on-disk cache."""
    cache = getattr(disp, "_cache", None)
    cache_file = getattr(cache, "_cache_file", None)
    if cache_file is None or not getattr(cache, "_enabled", False):
        return None
    # argument types only: callers pass a signature with or without a return type, and two
    # keys sharing a lock file cost a wait, never a wrong result
    args, _ = sigutils.normalize_signature(sig)
    key = (tuple(args), disp.targetctx.codegen().magic_tuple())
    digest = hashlib.sha256(repr(key).encode()).hexdigest()[:16]
    return f"{cache_file._index_path[: -len('.nbi')]}.{digest}.lock"


def locked_compile(self: dispatcher.Dispatcher, sig: object):
    """``numba.core.dispatcher.Dispatcher.compile`` under the signature's file lock (see the
    module docstring); numba's own ``compile`` inside the lock loads the result of a process
    that compiled it meanwhile."""
    args, _ = sigutils.normalize_signature(sig)
    existing = self.overloads.get(tuple(args))
    if existing is not None:
        return existing.entry_point
    try:
        path = compile_lock_path(self, sig)
        if path is not None:
            self._cache._impl.locator.ensure_cache_path()
    except Exception:  # a signature numba cannot key (it will say why in its compile)
        path = None
    if path is None:
        return _NUMBA_COMPILE(self, sig)
    with global_compiler_lock, file_lock(path):
        return _NUMBA_COMPILE(self, sig)


def locked_save(self: caching.IndexDataCacheFile, key: object, data: object) -> None:
    """``numba.core.caching.IndexDataCacheFile.save`` made safe for processes that save
    signatures of one function at once.

    numba reads the index, picks the first free data-file number, writes the index, then the
    data file, with no lock: two processes saving two signatures of one function both pick
    number 1, and the index can end up naming a data file that holds the *other* signature's
    code (loaded later without a type check; numba issue 10128 is the same race for gufuncs).
    Here the read-pick-write runs under an exclusive lock on ``<index>.lock`` and the data file
    is written before the index names it, so a reader without the lock sees either no entry or
    a complete file of its own signature.
    """
    with file_lock(self._index_path + ".lock"):
        overloads = self._load_index()
        name = overloads.get(key)
        if name is not None:  # same key: same signature, replace its file
            self._save_data(name, data)
            return
        used = set(overloads.values())
        name = next(n for n in map(self._data_name, itertools.count(1)) if n not in used)
        self._save_data(name, data)
        overloads[key] = name
        self._save_index(overloads)


def install() -> None:
    """Put :func:`locked_save` and :func:`locked_compile` into numba (idempotent)."""
    caching.IndexDataCacheFile.save = locked_save
    dispatcher.Dispatcher.compile = locked_compile
