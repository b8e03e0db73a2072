"""numba's on-disk cache must not load a kernel compiled against an older helper module
(:class:`solvers.jit.DependencyLocator`; a stale ``lanczos.py`` cache once ran 2000 MINRES
iterations at residual 1.0 after a change to the ``kernels.py`` helpers it inlines)."""

from __future__ import annotations

import ast
import importlib
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numba
import pytest
from numba.core import caching, dispatcher

import solvers.jit as jit
import solvers.jit_locks as jit_locks

_HELPER = "import numba\n\n\n@numba.njit(inline='always')\ndef bump(x):\n    return x + {inc}\n"
_USER = (
    "import numba\n\nimport solvers.jit  # noqa: F401\nfrom stalepkg.helpers import bump\n\n\n"
    "@numba.njit(cache=True)\ndef g(x):\n    return bump(x)\n"
)


def _package(root: Path, inc: int) -> None:
    pkg = root / "stalepkg"
    pkg.mkdir(exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "helpers.py").write_text(_HELPER.format(inc=inc))
    (pkg / "user.py").write_text(_USER)


def _fresh_g():
    """A new dispatcher of ``stalepkg.user.g`` (re-imported: it consults the disk cache)."""
    for name in [m for m in sys.modules if m.split(".")[0] == "stalepkg"]:
        del sys.modules[name]
    return importlib.import_module("stalepkg.user").g


def _run(g) -> tuple[int, int, int]:
    """(g(1), cache hits, cache misses) of a first call."""
    val = g(1)
    return val, sum(g.stats.cache_hits.values()), sum(g.stats.cache_misses.values())


@pytest.fixture
def stale_root(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(jit, "CACHE_ROOTS", [*jit.CACHE_ROOTS, (tmp_path / "stalepkg").resolve()])
    yield tmp_path
    for name in [m for m in sys.modules if m.split(".")[0] == "stalepkg"]:
        del sys.modules[name]


def test_changed_helper_recompiles_its_user(stale_root):
    _package(stale_root, 1)
    assert _run(_fresh_g()) == (2, 0, 1)  # compiled, saved
    assert _run(_fresh_g()) == (2, 1, 0)  # loaded from the disk cache
    (stale_root / "stalepkg" / "helpers.py").write_text(_HELPER.format(inc=10))
    assert _run(_fresh_g()) == (11, 0, 1)  # the helper changed: a fresh compile
    assert _run(_fresh_g()) == (11, 1, 0)


def test_without_the_locator_the_cache_is_stale(stale_root, monkeypatch):
    """The trap itself: numba's own stamp (the defining file only) loads the old code."""
    classes = [c for c in caching.CacheImpl._locator_classes if c is not jit.DependencyLocator]
    monkeypatch.setattr(caching.CacheImpl, "_locator_classes", classes)
    _package(stale_root, 1)
    assert _run(_fresh_g()) == (2, 0, 1)
    (stale_root / "stalepkg" / "helpers.py").write_text(_HELPER.format(inc=10))
    assert _run(_fresh_g()) == (2, 1, 0)  # stale: bump is now x + 10


def test_stamp_covers_imported_kernel_sources(monkeypatch):
    root = jit._REPO
    deps = {
        p.relative_to(root).as_posix()
        for p in jit.dependency_files(root / "solvers/voxel/lanczos.py")
    }
    assert deps == {
        "solvers/jit.py",
        "solvers/jit_locks.py",
        "solvers/voxel/kernels.py",
        "solvers/voxel/lanczos.py",
        "solvers/voxel/memory.py",
        "solvers/reduction.py",
        "solvers/voxel/simd.py",
    }
    before = jit.dependency_stamp(root / "solvers/voxel/lanczos.py")
    real = jit._file_hash
    kernels = (root / "solvers/voxel/kernels.py").resolve()

    def edited(path, *key):
        return "edited" if path == kernels else real(path, *key)

    monkeypatch.setattr(jit, "_file_hash", edited)
    assert jit.dependency_stamp(root / "solvers/voxel/lanczos.py") != before
    assert jit.dependency_stamp(root / "solvers/transport/kernels.py") == jit.dependency_stamp(
        root / "solvers/transport/kernels.py"
    )


_CACHED = re.compile(r"^@(?:numba|nb)\.njit\(.*cache=True|^@parallel_kernel\(", re.M)


def _cached_files() -> list[Path]:
    """Project files with a cached numba decorator."""
    root = jit._REPO
    return sorted(
        p
        for pkg in ("psdesign", "solvers")
        for p in (root / pkg).rglob("*.py")
        if _CACHED.search(p.read_text())
    )


def test_every_cached_module_installs_the_locator_first():
    """Each module with a cached numba function imports :mod:`solvers.jit` (which installs the
    locator) before its first decorator, whatever the import order of a process."""
    files = [p for p in _cached_files() if p.name != "jit.py"]
    assert len(files) >= 8
    for path in files:
        tree = ast.parse(path.read_text())
        first_import = None
        first_deco = None
        for node in tree.body:
            mods = []
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                mods = [node.module or ""] + [f"{node.module}.{a.name}" for a in node.names]
            if first_import is None and "solvers.jit" in mods:
                first_import = node.lineno
            if first_deco is None and getattr(node, "decorator_list", None):
                first_deco = node.lineno
        assert first_import is not None, f"{path} does not import solvers.jit"
        assert first_deco is None or first_import < first_deco, path


def test_project_dispatchers_use_the_locator():
    mods = [
        "solvers.voxel.kernels",
        "solvers.voxel.lanczos",
        "solvers.voxel.schur",
        "solvers.transport.kernels",
        "psdesign.geometry.raster",
        "psdesign.geometry.ps_kernel",
        "psdesign.packing.sequential",
        "psdesign.forcefield.kernels",
    ]
    seen = 0
    for name in mods:
        for obj in vars(importlib.import_module(name)).values():
            disps = [obj.parallel, obj.serial] if isinstance(obj, jit.TwinKernel) else [obj]
            for d in disps:
                cache = getattr(d, "_cache", None)
                if isinstance(d, numba.core.registry.CPUDispatcher) and cache is not None:
                    if isinstance(cache, caching.NullCache):
                        continue
                    assert isinstance(cache._impl.locator, jit.DependencyLocator), d
                    seen += 1
    assert seen >= 40


def _racing_saves(tmp_path: Path, monkeypatch) -> caching.IndexDataCacheFile:
    """Two writers (threads, each with its own ``IndexDataCacheFile`` as two processes have)
    save two keys of one function; each holds its index write for 0.3 s, so without a lock both
    read the empty index and pick data file 1.  Returns a reader of the result."""
    import threading
    import time

    slow_index = caching.IndexDataCacheFile._save_index

    def save_index(self, overloads):
        time.sleep(0.3)
        slow_index(self, overloads)

    monkeypatch.setattr(caching.IndexDataCacheFile, "_save_index", save_index)

    def writer(key: str) -> None:
        caching.IndexDataCacheFile(str(tmp_path), "f-1.py", "stamp").save(key, f"code of {key}")

    threads = [threading.Thread(target=writer, args=(k,)) for k in ("sig-a", "sig-b")]
    for t in threads:
        t.start()
        time.sleep(0.05)
    for t in threads:
        t.join()
    return caching.IndexDataCacheFile(str(tmp_path), "f-1.py", "stamp")


def test_concurrent_saves_of_one_function_keep_both_signatures(tmp_path, monkeypatch):
    """``jit_locks.locked_save`` (installed by importing :mod:`solvers.jit`): two processes that
    compile two signatures of one kernel at once (``pytest -n 2``) each find their own code."""
    assert caching.IndexDataCacheFile.save is jit_locks.locked_save
    reader = _racing_saves(tmp_path, monkeypatch)
    assert reader.load("sig-a") == "code of sig-a"
    assert reader.load("sig-b") == "code of sig-b"


def test_numba_unlocked_save_loses_a_signature(tmp_path, monkeypatch):
    """The race itself, with numba's own ``save``: both writers take data file 1 and the
    second index write drops the first signature (with other timings the index names the
    other signature's file)."""
    monkeypatch.setattr(caching.IndexDataCacheFile, "save", jit_locks._NUMBA_SAVE)
    reader = _racing_saves(tmp_path, monkeypatch)
    assert reader.load("sig-a") is None
    assert reader.load("sig-b") == "code of sig-b"


# --- one compile per signature across processes (solvers.jit_locks.locked_compile) ---------

_LOCKPKG = """import numba

import solvers.jit  # noqa: F401


@numba.njit(cache=True)
def h(x):
    return x + 1


@numba.njit(cache=True)
def g(x):
    return h(x) * 2


@numba.njit(cache=True)
def f(x):
    return g(x) + h(x)


@numba.njit
def plain(x):
    return x - 1
"""

_WORKER = '''import json, os, sys, time
from pathlib import Path

import solvers.jit_locks as jl
import lockpkg  # imports solvers.jit: installs the lock
from numba.core import dispatcher, event

if sys.argv[3] == "unlocked":
    dispatcher.Dispatcher.compile = jl._NUMBA_COMPILE

compiled = []


class Slow(event.Listener):
    """Count this package's compiles; make each one last 0.4 s longer, so two processes that
    start together overlap whatever the machine's load."""

    def on_start(self, ev):
        if ev.data["dispatcher"].py_func.__module__ == "lockpkg":
            compiled.append(ev.data["dispatcher"].py_func.__name__)
            time.sleep(0.4)

    def on_end(self, ev):
        pass


event.register("numba:compile", Slow())
Path(sys.argv[1] + ".ready." + str(os.getpid())).touch()
while not os.path.exists(sys.argv[1]):
    time.sleep(0.002)
value = getattr(lockpkg, sys.argv[2])(3)
print(json.dumps({"value": value, "compiled": compiled}))
'''

_VALUES = {"f": 12, "g": 8, "h": 4}  # f(3) = 2 (3 + 1) + (3 + 1), g(3) = 2 (3 + 1), h(3) = 4


@pytest.fixture
def lock_root(tmp_path):
    (tmp_path / "lockpkg.py").write_text(_LOCKPKG)
    (tmp_path / "worker.py").write_text(_WORKER)
    return tmp_path


def _env(root: Path, **extra: str) -> dict[str, str]:

    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(jit._REPO), str(root)])
    env["NUMBA_CACHE_DIR"] = str(root / "numba_cache")
    env["NUMBA_NUM_THREADS"] = "1"
    env.pop("NUMBA_DISABLE_JIT", None)
    env.update(extra)
    return env


def _race(root: Path, entries: tuple[str, ...], mode: str = "locked") -> list[dict]:
    """Start one process per entry point, release them together on a cold cache, and return
    what each printed (value, names of the functions it compiled)."""

    go = root / "go"
    procs = [
        subprocess.Popen(
            [sys.executable, str(root / "worker.py"), str(go), entry, mode],
            env=_env(root),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for entry in entries
    ]
    deadline = time.monotonic() + 120
    while len(list(root.glob("go.ready.*"))) < len(procs):
        assert time.monotonic() < deadline, "workers did not start"
        assert all(p.poll() is None for p in procs), [p.communicate() for p in procs]
        time.sleep(0.01)
    go.touch()
    out = []
    for p in procs:
        stdout, stderr = p.communicate(timeout=120)  # a deadlock fails here
        assert p.returncode == 0, stderr
        out.append(json.loads(stdout.strip().splitlines()[-1]))
    return out


def test_compile_is_locked_on_import():
    assert dispatcher.Dispatcher.compile is jit_locks.locked_compile
    assert caching.IndexDataCacheFile.save is jit_locks.locked_save


@pytest.mark.parametrize(
    "entries",
    [
        ("f", "f"),
        ("g", "f"),
        pytest.param(("h", "f"), marks=pytest.mark.slow),
        pytest.param(("f", "h"), marks=pytest.mark.slow),
    ],
)
def test_two_processes_compile_each_signature_once(lock_root, entries):
    """Two processes need one call graph (f -> g -> h) at once on an empty cache: every function
    is compiled by exactly one of them (the other waits for the lock and loads it from the
    cache), whichever end of the graph each starts from, without a deadlock.  Without the lock
    ("f", "f") and ("g", "f") compile f, g, h / g, h twice (checked: they fail with numba's own
    ``compile``); from h the other process finds h saved before it gets there either way."""
    out = _race(lock_root, entries)
    assert [o["value"] for o in out] == [_VALUES[e] for e in entries]
    names = [n for o in out for n in o["compiled"]]
    assert sorted(names) == ["f", "g", "h"], out


def test_without_the_compile_lock_both_processes_compile(lock_root):
    """The waste itself, with numba's own ``compile``: both processes compile all three."""
    out = _race(lock_root, ("f", "f"), mode="unlocked")
    assert [o["value"] for o in out] == [12, 12]
    assert sorted(n for o in out for n in o["compiled"]) == ["f", "f", "g", "g", "h", "h"]


@pytest.mark.slow
def test_after_the_race_the_cache_serves_both(lock_root):
    """A third process finds all three in the disk cache (what the waiting process loaded was
    saved completely)."""
    _race(lock_root, ("f", "f"))
    (lock_root / "go").unlink()
    for ready in lock_root.glob("go.ready.*"):
        ready.unlink()
    assert _race(lock_root, ("f",)) == [{"value": 12, "compiled": []}]


def test_recursive_function_does_not_wait_for_itself(tmp_path, monkeypatch):
    """A self-recursive cached function compiles under its own lock (numba types the
    recursion without re-entering ``compile``; a re-entry would count depth, see below)."""

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.syspath_prepend(str(tmp_path))
    (tmp_path / "recpkg.py").write_text(
        "import numba\n\nimport solvers.jit  # noqa: F401\n\n\n@numba.njit(cache=True)\n"
        "def fact(n):\n    if n <= 1:\n        return 1\n    return n * fact(n - 1)\n"
    )
    monkeypatch.delitem(sys.modules, "recpkg", raising=False)
    from numba.core import config

    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path))
    t0 = time.monotonic()
    assert importlib.import_module("recpkg").fact(5) == 120  # 5!
    assert time.monotonic() - t0 < 60
    monkeypatch.delitem(sys.modules, "recpkg")


def _lock_script(path: Path, wait_s: float, hold_s: float = 0.0) -> list[str]:
    """Command of another process that takes ``file_lock(path)`` (waiting up to ``wait_s``),
    prints 'held' or 'free' (lock not obtained), then keeps it for ``hold_s`` seconds."""
    code = (
        "import time\nimport solvers.jit_locks as jl\n"
        f"with jl.file_lock({str(path)!r}, wait_s={wait_s}) as ok:\n"
        "    print('held' if ok else 'free', flush=True)\n"
        f"    time.sleep({hold_s})\n"
    )
    return [sys.executable, "-c", code]


def _hold(path: Path, seconds: float) -> subprocess.Popen:
    """Another process that holds ``file_lock(path)`` for ``seconds`` (prints 'held')."""
    p = subprocess.Popen(
        _lock_script(path, jit_locks.COMPILE_WAIT_S, seconds),
        env=_env(path.parent),
        stdout=subprocess.PIPE,
        text=True,
    )
    assert p.stdout.readline().strip() == "held"
    return p


def test_lock_is_reentrant_in_one_process_and_exclusive_across(tmp_path):
    """A process re-entering a lock it holds does not block itself (``flock`` on a second
    descriptor would); another process waits while any depth is held."""

    path = str(tmp_path / "x.lock")
    with jit_locks.file_lock(path, wait_s=1) as outer:
        t0 = time.monotonic()
        with jit_locks.file_lock(path, wait_s=1) as inner:
            assert outer and inner
        assert time.monotonic() - t0 < 0.5  # no wait for itself
        assert jit_locks._held()[path][1] == 1
        other = _try_lock_elsewhere(tmp_path / "x.lock")
        assert other == "free"  # still held after the inner block: the other did not get it
    assert path not in jit_locks._held()
    assert _try_lock_elsewhere(tmp_path / "x.lock") == "held"


def _try_lock_elsewhere(path: Path) -> str:
    """'held' if another process gets ``path``'s lock within 0.3 s, else 'free'."""
    run = subprocess.run(
        _lock_script(path, 0.3), env=_env(path.parent), capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr
    return run.stdout.strip()


def test_a_killed_holder_releases_the_lock(tmp_path):
    """``kill -9`` of the process holding a compile lock frees it for the waiter (the kernel
    drops a dead process's ``flock``); a waiter past its deadline goes on unlocked."""

    path = tmp_path / "y.lock"
    holder = _hold(path, 60)
    try:
        t0 = time.monotonic()
        with jit_locks.file_lock(str(path), wait_s=0.3) as ok:
            assert not ok  # deadline passed: the block runs without the lock
        assert 0.3 <= time.monotonic() - t0 < 5
        holder.send_signal(signal.SIGKILL)
        holder.wait(timeout=10)
        with jit_locks.file_lock(str(path), wait_s=5) as ok:
            assert ok
    finally:
        holder.kill()
        holder.wait()


def test_uncached_functions_and_disabled_jit_are_unaffected(lock_root):
    """No lock file for a dispatcher without ``cache=True``; with ``NUMBA_DISABLE_JIT`` the
    functions are plain Python (no dispatcher, no cache directory)."""

    sys.path.insert(0, str(lock_root))
    try:
        lockpkg = importlib.import_module("lockpkg")
        assert jit_locks.compile_lock_path(lockpkg.plain, (numba.int64,)) is None
        assert lockpkg.plain(3) == 2
    finally:
        sys.path.remove(str(lock_root))
        sys.modules.pop("lockpkg", None)
    code = "import lockpkg\nprint(lockpkg.f(3), type(lockpkg.f).__name__)"
    run = subprocess.run(
        [sys.executable, "-c", code],
        env=_env(lock_root, NUMBA_DISABLE_JIT="1"),
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["12", "function"]
    assert not (lock_root / "numba_cache").exists()
