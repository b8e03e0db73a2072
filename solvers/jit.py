"""``parallel_kernel``: a numba ``parallel=True`` kernel with a serial twin for one-thread runs.

Compiling a ``parallel=True`` kernel costs 2-3 times the CPU time of the same function compiled
serially (the parfor passes and the gufunc wrapper; measured on the voxel Stokes kernels:
``jacobi`` 4.5 s vs 1.9 s, the former weighted residual 11.4 s vs 4.3 s), and on one thread the
parallel version buys nothing.  Small grids run on one thread
(:data:`solvers.voxel.threads.PARALLEL_MIN_CELLS`), so a cold start on a small case compiles only
the serial twins.  Both are compiled lazily on first use (only the specializations a solve
needs) and cached on disk (``cache=True``); :mod:`psdesign.warmup` fills that cache ahead of
time.  ``prange`` is a plain ``range`` in the serial twin, so both give the same results up to
the order of floating-point reductions.

**Cache stamps cover the imported sources.**  numba keys a function's on-disk cache on the hash
of the file that defines it only, so a cached kernel that inlines a helper (or reads a
constant) from another module would be loaded stale after that module changes (a stale
``lanczos.py`` cache once ran 2000 MINRES iterations at residual 1.0 after a ``kernels.py``
change).  Importing this module puts :class:`DependencyLocator` first in numba's list of cache
locators: for every cached function defined in a project package (:data:`CACHE_ROOTS`) the
source stamp is the file's hash *and* the hashes of every project module it imports,
transitively (:func:`dependency_files`), so a change to any of them recompiles it.  Kernel
modules import this module before their first ``cache=True`` decorator.

**One compile per signature across processes, locked cache writes.**  Importing this module also
installs :mod:`solvers.jit_locks` into numba: a cached function's compile of one signature runs
under a file lock of that signature, so a second process that needs it (``pytest -n 2``,
``psdesign warmup --jobs 2``, study workers) waits and loads it from the cache instead of
compiling it again; and the cache-file save runs under a lock per function, so processes saving
signatures of one function at once cannot leave an index entry pointing at another signature's
code.

**One compile rule per solve, per thread.**  A kernel whose parallel version is not compiled yet
compiles it on first use only for a large enough problem (:data:`COMPILE_PARALLEL_ABOVE`).
Inside a :func:`compile_rule` block the solve's grid cells decide for every kernel of the solve;
the block's cells live in a :class:`contextvars.ContextVar`, so solves that overlap in threads of
one process (a dask worker with ``--nthreads 2``, a user's thread pool) each keep their own rule,
and :func:`kernel_log` records each one's kernels apart.
"""

from __future__ import annotations

import ast
import contextlib
import contextvars
import functools
import hashlib
import os
import sys
import types
from collections.abc import Callable, Iterator
from pathlib import Path

import numba as nb
from numba.core import caching, compiler
from numba.core import event as numba_event

from solvers import jit_locks

__all__ = [
    "CACHE_ROOTS",
    "COMPILE_PARALLEL_ABOVE",
    "DependencyLocator",
    "KernelLog",
    "NoAliasCompiler",
    "SerialHelpers",
    "TwinKernel",
    "WARMUP_NOTE",
    "compile_rule",
    "compiles_parallel",
    "dependency_files",
    "dependency_stamp",
    "kernel_log",
    "parallel_kernel",
    "parallel_pending",
]

_REPO = Path(__file__).resolve().parents[1]

CACHE_ROOTS: list[Path] = [_REPO / "psdesign", _REPO / "solvers"]
"""Package directories whose cached numba functions get :class:`DependencyLocator` stamps;
their parent directory is the import root the modules are resolved against."""


def _module_file(name: str) -> Path | None:
    """Source file of project module ``name`` (a ``.py`` file or a package ``__init__.py``
    under one of :data:`CACHE_ROOTS`), or None."""
    for root in CACHE_ROOTS:
        parts = name.split(".")
        if parts[0] != root.name:
            continue
        base = root.parent.joinpath(*parts)
        for cand in (base.with_suffix(".py"), base / "__init__.py"):
            if cand.is_file():
                return cand.resolve()
    return None


def _package_of(path: Path) -> list[str]:
    """Dotted package of ``path`` relative to its root's parent (for relative imports)."""
    for root in CACHE_ROOTS:
        if path.is_relative_to(root):
            return list(path.relative_to(root.parent).parts[:-1])
    return []


@functools.cache
def _direct_imports(path: Path, mtime_ns: int, size: int) -> tuple[Path, ...]:
    """Project modules imported by the top-level statements of ``path`` (the only names a
    jitted function can see); ``from A import b`` counts ``A.b`` if it is a module, else
    ``A``."""
    tree = ast.parse(path.read_bytes(), filename=str(path))
    found: list[Path] = []
    for node in tree.body:
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level:
                pkg = _package_of(path)
                pkg = pkg[: len(pkg) - (node.level - 1)] if node.level > 1 else pkg
                mod = ".".join([*pkg, mod] if mod else pkg)
            for a in node.names:
                names.append(f"{mod}.{a.name}" if _module_file(f"{mod}.{a.name}") else mod)
        for name in names:
            f = _module_file(name)
            if f is not None and f != path:
                found.append(f)
    return tuple(dict.fromkeys(found))


def _stat_key(path: Path) -> tuple[Path, int, int]:
    st = path.stat()
    return path, st.st_mtime_ns, st.st_size


def dependency_files(py_file: str | os.PathLike) -> tuple[Path, ...]:
    """``py_file`` and every project module it imports, transitively (sorted; the inputs of
    :func:`dependency_stamp`)."""
    start = Path(py_file).resolve()
    seen = {start}
    todo = [start]
    while todo:
        for dep in _direct_imports(*_stat_key(todo.pop())):
            if dep not in seen:
                seen.add(dep)
                todo.append(dep)
    return tuple(sorted(seen))


@functools.cache
def _file_hash(path: Path, mtime_ns: int, size: int) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def dependency_stamp(py_file: str | os.PathLike) -> str:
    """SHA-256 over the contents of :func:`dependency_files` (``py_file`` and its project
    imports): the part of a cached kernel's numba source stamp that changes when any source it
    may depend on changes."""
    h = hashlib.sha256()
    for f in dependency_files(py_file):
        rel = f.relative_to(_REPO) if f.is_relative_to(_REPO) else f
        h.update(f"{rel.as_posix()}\0{_file_hash(*_stat_key(f))}\n".encode())
    return h.hexdigest()


class DependencyLocator(caching._CacheLocator):
    """numba cache locator for functions defined under :data:`CACHE_ROOTS`: the cache directory
    and file names of numba's own locator (``NUMBA_CACHE_DIR``, ``__pycache__``, ...), with the
    source stamp extended by :func:`dependency_stamp`.  numba discards a cache index whose
    stamp differs, so a changed dependency means a fresh compile."""

    def __init__(self, base: caching._CacheLocator, py_file: str) -> None:
        self._base = base
        self._py_file = py_file

    def ensure_cache_path(self) -> None:
        self._base.ensure_cache_path()

    def get_cache_path(self) -> str:
        return self._base.get_cache_path()

    def get_source_stamp(self) -> object:
        return (self._base.get_source_stamp(), dependency_stamp(self._py_file))

    def get_disambiguator(self) -> str:
        return self._base.get_disambiguator()

    @classmethod
    def from_function(cls, py_func: Callable, py_file: str) -> DependencyLocator | None:
        path = Path(py_file).resolve()
        if not path.is_file() or not any(path.is_relative_to(r) for r in CACHE_ROOTS):
            return None
        for other in caching.CacheImpl._locator_classes:
            if other is cls:
                continue
            base = other.from_function(py_func, py_file)
            if base is not None:
                return cls(base, py_file)
        return None


def _install_locator() -> None:
    """Put :class:`DependencyLocator` first in numba's locator list (once per process)."""
    classes = caching.CacheImpl._locator_classes
    if DependencyLocator not in classes:
        classes.insert(0, DependencyLocator)


_install_locator()

jit_locks.install()


class _CompileListener(numba_event.Listener):
    """Tells the running ``psdesign`` command that a kernel compile started (a cold start
    compiles for up to a minute or two before the first progress line): through
    :func:`psdesign.progress.compiling` when that module is loaded, else nothing."""

    def on_start(self, event) -> None:
        progress = sys.modules.get("psdesign.progress")
        if progress is None:
            return
        data = event.data or {}
        fn = getattr(data.get("dispatcher"), "py_func", None)
        progress.compiling(getattr(fn, "__qualname__", "kernel"))

    def on_end(self, event) -> None:
        pass


def _install_compile_listener() -> None:
    """Register :class:`_CompileListener` with numba's events (once per process); a numba
    without the event registry only loses the announcement."""
    try:
        registered = numba_event._registered["numba:compile"]
    except (AttributeError, KeyError, TypeError):  # pragma: no cover - another numba
        return
    if not any(isinstance(x, _CompileListener) for x in registered):
        numba_event.register("numba:compile", _CompileListener())


_install_compile_listener()

COMPILE_PARALLEL_ABOVE = 10_000_000
"""Problem size from which a parallel kernel that is not in the cache is compiled on first use
(:func:`compiles_parallel`: the solved grid's cells inside a :func:`compile_rule` block, else the
kernel's first argument's elements); the process's rule, read at each decision (``psdesign
warmup`` sets it to 0 to compile everything).  On 2 cores two threads save about 40 % of a
solve (100^3: 9.5 s -> 5.4 s), which pays for the extra ~1-2 min of compiling only from a few
hundred voxels per side. Smaller grids run the serial twin until ``psdesign warmup`` has
compiled the parallel kernels, and the voxel solve's result says so (``threads_used``,
``thread_note``; :class:`KernelLog`).  Re-measured in clean12 (``benchmarks/RESULTS.md``,
"Voxel solver hygiene"): the parallel set of one staircase route costs about 113 s CPU to
compile against 6-8 s saved by two threads on a 200^3 (8 M cells) solve at load 5-6 (about half
the solve idle): kept."""

_SOLVE_CELLS: contextvars.ContextVar[int | None] = contextvars.ContextVar(
    "psdesign_solve_cells", default=None
)
"""Cells of the solve whose :func:`compile_rule` block is open in this context (thread), or
None.  A ``ContextVar``, not a module global: until session 45 the voxel solve set
:data:`COMPILE_PARALLEL_ABOVE` itself, and two solves overlapping in threads of one process
shared the later one's decision (``benchmarks/RESULTS.md``, session 44 review3)."""


@contextlib.contextmanager
def compile_rule(n_cells: int) -> Iterator[None]:
    """Decide by ``n_cells`` inside the block: every :class:`TwinKernel` called in it compiles
    its missing parallel version if ``n_cells`` reaches :data:`COMPILE_PARALLEL_ABOVE`, whatever
    the size of its own first argument (a solve's 4-field vectors have 4 entries per cell and
    its diagonals 1: per argument, a 120^3 mirror solve compiled five vector kernels mid-solve
    and ran its operator kernels serially; ``benchmarks/RESULTS.md``, session 44 mirror).

    Parameters
    ----------
    n_cells : int
        Cells of the grid the block solves (the solved grid: treated or with reservoirs).

    Notes
    -----
    The rule holds in the calling thread (its ``contextvars`` context) only: a solve in another
    thread keeps its own, and the process's rule is untouched, also when the block raises.
    numba's worker threads are not Python threads and call no :class:`TwinKernel`; a Python
    thread started inside the block starts without it unless it runs its work in
    ``contextvars.copy_context().run``.
    """
    token = _SOLVE_CELLS.set(int(n_cells))
    try:
        yield
    finally:
        _SOLVE_CELLS.reset(token)


def compiles_parallel(size: int) -> bool:
    """Whether a :class:`TwinKernel` whose first argument has ``size`` elements compiles its
    missing parallel version here: the cells of the open :func:`compile_rule` block (else
    ``size``) against :data:`COMPILE_PARALLEL_ABOVE`."""
    cells = _SOLVE_CELLS.get()
    return (size if cells is None else cells) >= COMPILE_PARALLEL_ABOVE


_PENDING: set[str] = set()


def parallel_pending() -> tuple[str, ...]:
    """Kernels that ran on one thread in this process because their parallel version was not
    compiled yet (empty once ``psdesign warmup`` has run)."""
    return tuple(sorted(_PENDING))


WARMUP_NOTE = "parallel kernels not compiled yet; `psdesign warmup` compiles them once"
"""Why kernels ran on one thread although more were available (the one text of the solver
results and the CLI line)."""


class KernelLog:
    """Which :class:`TwinKernel` s ran, and how, while a :func:`kernel_log` block was open:
    ``parallel`` on the parallel dispatcher; ``fallback`` on the serial twin only because the
    parallel version was not compiled (one thread although numba had more)."""

    def __init__(self) -> None:
        self.parallel: set[str] = set()
        self.fallback: set[str] = set()


_LOG: contextvars.ContextVar[KernelLog | None] = contextvars.ContextVar(
    "psdesign_kernel_log", default=None
)
"""The innermost open :func:`kernel_log` of this context (thread), or None."""


@contextlib.contextmanager
def kernel_log() -> Iterator[KernelLog]:
    """Record in a :class:`KernelLog` the twin kernels called inside the block (innermost block
    of the calling thread only; for results that report the threads their solve really used).
    Per thread as :func:`compile_rule`: until session 45 a process-wide stack, and two solves
    overlapping in threads both logged into the later one's block."""
    log = KernelLog()
    token = _LOG.set(log)
    try:
        yield log
    finally:
        _LOG.reset(token)


_SERIAL_VARIANT: dict[object, object] = {}
"""Inline dispatcher -> its variant in the serial twins (every :class:`SerialHelpers`)."""


def _copy(fn: Callable, glb: dict, qualname: str | None = None) -> types.FunctionType:
    """``fn`` as a new function object over the globals ``glb`` (named ``qualname``)."""
    out = types.FunctionType(fn.__code__, glb, fn.__name__, fn.__defaults__, fn.__closure__)
    out.__qualname__ = qualname or fn.__qualname__
    out.__doc__ = fn.__doc__
    out.__module__ = fn.__module__
    return out


class SerialHelpers:
    """The helpers of one kernel module, compiled one way for the parallel kernels and another
    for the serial twins (:class:`TwinKernel` ``helpers=``).

    The module's names keep numba's ``inline="always"`` helpers and its plain ``@njit`` slab
    functions: the parallel kernels compile exactly as without this class.  The serial twins
    are compiled over :attr:`ns`, a copy of the module's globals (:meth:`seal`) in which

    - a :meth:`leaf` (a one-line helper with many call sites) is a plain ``@njit`` function
      with the kernels' options (``opts``, the disk cache left out): compiled once per
      signature and inlined by LLVM, instead of numba inlining its
      IR at every call site, recursively, which was 59-69 % of a kernel's compile time
      (``benchmarks/RESULTS.md``, suite16 and compile17);
    - an :meth:`inline` helper (the row and plane helpers, with few call sites) is still
      ``inline="always"``, over :attr:`ns`, so the leaves it calls are the plain ones;
    - a :meth:`slab` (a cached ``@njit`` function a kernel calls per plane) is a second cached
      dispatcher over :attr:`ns` (``<name>__serial``);
    - a :meth:`shared` body (a parallel kernel's ``prange`` body) is one cached function
      compiled over :attr:`ns` that the parallel twin calls, and ``inline="always"`` in the
      serial twin (its code unchanged); never with ``noalias`` (session 50's review: loaded
      from the cache, such a body gave other bits than the serial twin).

    Why not everywhere: a call to a plain helper in a loop keeps numba's reference-count
    pruning from removing the increments and decrements of the row views around it, and LLVM
    inlines the call only later, so the increments stay in the row loops (compile18: the
    optimized IR of ``lap_residual``'s serial twin had 22 ``NRT_incref`` calls, none with
    ``inline="always"``).  On one thread they cost nothing measurable (compile17); in a
    parallel kernel every thread updates the same arrays' counts, and the default two-thread
    path at 64^3 with a competitor took 1.12-1.33x the one-thread time (issue 16 item 1 bar
    1.1x; ``benchmarks/RESULTS.md``, session 17).  Results are bitwise those of the inline
    helpers."""

    def __init__(self, **opts: object) -> None:
        self.ns: dict = {}
        # the kernels' options for the plain leaves, without the disk cache: a leaf keeps its
        # helper's qualified name, under which numba would file the inline helper's cache too
        self._plain = {k: v for k, v in opts.items() if k != "cache"}
        self._serial: dict[str, object] = {}

    def leaf(self, fn: Callable) -> Callable:
        """Decorator: ``fn`` inline in the module, a plain ``@njit`` function over :attr:`ns`
        in :attr:`ns` (the leaves it calls are plain too)."""
        inline = nb.njit(inline="always")(fn)
        self._add(fn.__name__, inline, nb.njit(**self._plain)(_copy(fn, self.ns)))
        return inline

    def inline(self, fn: Callable) -> Callable:
        """Decorator: ``fn`` inline in the module and in :attr:`ns` (over :attr:`ns`)."""
        inline = nb.njit(inline="always")(fn)
        self._add(fn.__name__, inline, nb.njit(inline="always")(_copy(fn, self.ns)))
        return inline

    def slab(self, **opts: object) -> Callable[[Callable], Callable]:
        """Decorator: ``@njit(**opts)`` in the module; a second ``@njit(**opts)`` dispatcher
        over :attr:`ns`, named ``<qualname>__serial`` (numba names its cache files after it).

        A kernel may call a slab; a slab must not call another slab (make that one
        :meth:`inline`): the call would reach the callee's own compile or its copy linked into
        the caller, whichever a process loaded first, and under fastmath the two differ in
        the last bits (session 37; ``tests/unit/test_voxel_threads.py`` scans for it)."""

        def wrap(fn: Callable) -> Callable:
            disp = nb.njit(**opts)(fn)
            twin = _copy(fn, self.ns, f"{fn.__qualname__}__serial")
            self._add(fn.__name__, disp, nb.njit(**opts)(twin))
            return disp

        return wrap

    def shared(self, **opts: object) -> Callable[[Callable], Callable]:
        """Decorator for the body of a parallel kernel's ``prange`` loop (a plane, chunk or
        row block): in the module one cached ``@njit(**opts)`` dispatcher over :attr:`ns`,
        named ``<qualname>__serial``, which the parallel kernel calls; in :attr:`ns` an
        ``inline="always"`` copy, so the serial twin compiles exactly as with the body written
        in its loop.  The parallel kernel then no longer inlines the body's helpers by numba
        (its own copy cost 2-5x the serial twin's compile) and computes the serial twin's
        values; the serial twin keeps its code (a call per plane made some 2-4 % slower,
        ``benchmarks/RESULTS.md``, session 50)."""

        def wrap(fn: Callable) -> Callable:
            disp = nb.njit(**opts)(_copy(fn, self.ns, f"{fn.__qualname__}__serial"))
            self._add(fn.__name__, disp, nb.njit(inline="always")(_copy(fn, self.ns)))
            return disp

        return wrap

    def _add(self, name: str, module_disp: object, serial_disp: object) -> None:
        self._serial[name] = serial_disp
        _SERIAL_VARIANT[module_disp] = serial_disp

    def seal(self, module_globals: dict) -> None:
        """Fill :attr:`ns` from the module's globals (call it once, at the end of the module):
        every helper of any :class:`SerialHelpers` (also one imported from another module) by
        its serial variant."""
        self.ns.clear()
        for name, value in module_globals.items():
            try:
                self.ns[name] = _SERIAL_VARIANT.get(value, value)
            except TypeError:  # unhashable global
                self.ns[name] = value
        self.ns.update(self._serial)


class NoAliasCompiler(compiler.Compiler):
    """numba's default compiler with its ``noalias`` flag set: every pointer argument of the
    compiled function (an array's data among them) is marked ``noalias`` in LLVM, the promise
    that memory written through one argument is not read or written through another during
    the call.  LLVM then knows a kernel's output does not overlap its inputs and vectorises its
    loops without the run-time overlap checks it otherwise emits in front of each vectorised
    loop (re-done per block in the flat sweeps: ``benchmarks/RESULTS.md``, band20).  numba
    sets the same flag on a ``prange`` loop's gufunc when it finds no aliasing among its
    arrays; this sets it for the whole kernel and its serial twin.  Only for kernels whose
    callers never pass an output that overlaps an input (:func:`parallel_kernel`
    ``noalias=True``); read-only arguments may share memory (the flag only constrains memory
    that is written)."""

    def __init__(self, typingctx, targetctx, library, args, return_type, flags, locals):
        flags = flags.copy()
        flags.noalias = True
        super().__init__(typingctx, targetctx, library, args, return_type, flags, locals)


class TwinKernel:
    """A parallel and a serial numba dispatcher of one Python function.

    Calling it runs :attr:`serial` when numba runs on one thread
    (``numba.get_num_threads() == 1``) or when the first argument has fewer than
    ``serial_below`` elements.  Otherwise it runs :attr:`parallel` if that is already compiled
    for these argument types (in this process or in the on-disk cache, e.g. by
    ``psdesign warmup``) or if :func:`compiles_parallel` says the problem is long enough to pay
    for compiling it: inside a :func:`compile_rule` block (a voxel Stokes solve) its grid's
    cells reach :data:`COMPILE_PARALLEL_ABOVE`, outside one the first argument's elements do;
    else the serial twin (one thread), and :func:`parallel_pending` and the calling thread's
    open :func:`kernel_log` say so.  Call it from Python only (a jitted function cannot call
    it; jitted helpers stay plain ``numba.njit`` functions).
    """

    def __init__(
        self,
        fn: Callable,
        serial_below: int = 0,
        helpers: SerialHelpers | None = None,
        noalias: bool = False,
        **opts: object,
    ) -> None:
        self.py_func = fn
        self.serial_below = int(serial_below)
        self.parallel = nb.njit(parallel=True, **opts)(fn)
        if noalias:  # the serial twin only: in the parallel twins it broke bitwise equality
            opts = {**opts, "pipeline_class": NoAliasCompiler}
        # a copy of the function under its own qualified name: numba names its cache files
        # after ``__qualname__`` and does not key them on the ``parallel`` flag; over the
        # serial helpers' globals if given
        glb = fn.__globals__ if helpers is None else helpers.ns
        self.serial = nb.njit(**opts)(_copy(fn, glb, f"{fn.__qualname__}__serial"))
        self._ready: dict[tuple, bool] = {}
        functools.update_wrapper(self, fn)

    def __call__(self, *args):
        size = getattr(args[0], "size", 0)
        if nb.get_num_threads() == 1 or (self.serial_below and size < self.serial_below):
            return self.serial(*args)
        name = self.py_func.__qualname__
        log = _LOG.get()
        if compiles_parallel(size) or self._parallel_ready(args):
            if log is not None:
                log.parallel.add(name)
            return self.parallel(*args)
        _PENDING.add(name)
        if log is not None:
            log.fallback.add(name)
        return self.serial(*args)

    def _parallel_ready(self, args: tuple) -> bool:
        """True if :attr:`parallel` is compiled for the types of ``args`` (loads it from the
        on-disk cache if it is there; never compiles)."""
        key = tuple(
            (a.dtype.str, a.ndim, a.flags.c_contiguous) if hasattr(a, "dtype") else type(a)
            for a in args
        )
        ready = self._ready.get(key)
        if ready is None:
            d = self.parallel
            # the signature numba compiles for these arguments: a parameter left to its default
            # is typed ``omitted(default=...)`` (without it a call that omits one never found its
            # compiled parallel kernel and ran the serial twin; session 28's branch s28-stream)
            sig = tuple(d.fold_argument_types(tuple(d.typeof_pyval(a) for a in args), {})[1])
            ready = sig in d.overloads
            if not ready:
                try:  # numba's own lookup (Dispatcher.compile tries it before compiling)
                    ready = d._cache.load_overload(sig, d.targetctx) is not None
                except Exception:
                    ready = False
                if ready:
                    d.compile(sig)  # loads it from the cache
            self._ready[key] = ready
        return ready

    def __repr__(self) -> str:
        return f"<TwinKernel {self.py_func.__module__}.{self.py_func.__qualname__}>"


def parallel_kernel(
    serial_below: int = 0,
    helpers: SerialHelpers | None = None,
    noalias: bool = False,
    **opts: object,
) -> Callable[[Callable], TwinKernel]:
    """Decorator: ``@parallel_kernel(cache=True, fastmath=True)`` in place of
    ``@numba.njit(parallel=True, cache=True, fastmath=True)`` (see :class:`TwinKernel`);
    ``serial_below``: first-argument size below which the serial twin runs; ``helpers``: the
    module's :class:`SerialHelpers`, whose variants the serial twin calls; ``noalias``: compile
    the serial twin with :class:`NoAliasCompiler` (no argument the kernel writes may overlap
    another argument).  Not the parallel twin: there it made ``jacobi`` and the fused sweeps
    (``jacobi2_zero``, ``prolong_jacobi``) differ by an ulp, so the V-cycle of a two-thread
    solve after ``psdesign warmup`` was no longer one symmetric operator (session 20 review;
    ``tests/unit/test_voxel_kernels.py``).  Session 49: numba passes the flag to every array
    parameter of the parfor gufunc, also to arrays a kernel reshapes to hide them from it, and
    the stored-coupling row loops then gave other bits in a process that compiled the twin
    than in one that loaded it from the cache (``benchmarks/RESULTS.md``)."""

    def wrap(fn: Callable) -> TwinKernel:
        return TwinKernel(fn, serial_below=serial_below, helpers=helpers, noalias=noalias, **opts)

    return wrap
