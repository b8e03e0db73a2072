"""numba's on-disk cache must not load a kernel compiled against an older helper module
(:class:`solvers.jit.DependencyLocator`; a stale ``lanczos.py`` cache once ran 2000 MINRES
iterations at residual 1.0 after a change to the ``kernels.py`` helpers it inlines)."""

from __future__ import annotations

import ast
import importlib
import re
import sys
from pathlib import Path

import numba
import pytest
from numba.core import caching

import solvers.jit as jit

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
        "solvers/voxel/kernels.py",
        "solvers/voxel/lanczos.py",
        "solvers/voxel/memory.py",
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
    """``jit.locked_save`` (installed by importing :mod:`solvers.jit`): two processes that
    compile two signatures of one kernel at once (``pytest -n 2``) each find their own code."""
    assert caching.IndexDataCacheFile.save is jit.locked_save
    reader = _racing_saves(tmp_path, monkeypatch)
    assert reader.load("sig-a") == "code of sig-a"
    assert reader.load("sig-b") == "code of sig-b"


def test_numba_unlocked_save_loses_a_signature(tmp_path, monkeypatch):
    """The race itself, with numba's own ``save``: both writers take data file 1 and the
    second index write drops the first signature (with other timings the index names the
    other signature's file)."""
    monkeypatch.setattr(caching.IndexDataCacheFile, "save", jit._NUMBA_SAVE)
    reader = _racing_saves(tmp_path, monkeypatch)
    assert reader.load("sig-a") is None
    assert reader.load("sig-b") == "code of sig-b"
