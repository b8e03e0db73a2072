"""Shared test set-up.

This folder is on ``sys.path`` (pytest's rootdir conftest), so tests import the shared helpers
by name: :mod:`reference_values` (published values with sources), :mod:`meshes` (small tagged
tet meshes), :mod:`study_cases` (fake case functions that pickle to workers); and from here
:func:`load_benchmark` (a ``benchmarks/`` script as a module).
"""

from __future__ import annotations

import importlib.util
import signal
import sys
from pathlib import Path
from types import ModuleType

import approx_guard
import file_order
import pytest
import worker_crash

approx_guard.install()  # a stated rel bar is the enforced one (approx_guard's docstring)

# A shell starts a background job with SIGINT ignored and every process it starts inherits
# that, so the Ctrl-C tests' signals were never delivered (session 47: six failures in a run
# started with `nohup ... &`). A handled signal is reset to its default across exec, so the
# processes these tests start get Python's KeyboardInterrupt again.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_configure(config: pytest.Config) -> None:
    worker_crash.no_worker_restart(config)  # a crashed xdist worker ends the run, not hangs it
    file_order.keep_file_order(config)  # loadfile hands files out in the order below


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    file_order.reorder(config, items)  # the costliest files first, so both workers end together


TESTS_DIR = Path(__file__).resolve().parent
REPO_ROOT = TESTS_DIR.parent
DATA_DIR = TESTS_DIR / "data"


def load_benchmark(name: str) -> ModuleType:
    """A fresh module object of ``benchmarks/<name>.py`` (the scripts are not a package).

    ``benchmarks/`` goes on ``sys.path`` first: some scripts import their sibling modules.
    """
    folder = str(REPO_ROOT / "benchmarks")
    if folder not in sys.path:
        sys.path.insert(0, folder)
    spec = importlib.util.spec_from_file_location(name, f"{folder}/{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """``tests/data``: small vendored inputs (every file named in ``data/README-puma.md``)."""
    return DATA_DIR


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT
