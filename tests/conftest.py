"""Shared test set-up.

This folder is on ``sys.path`` (pytest's rootdir conftest), so tests import the shared helpers
by name: :mod:`reference_values` (published values with sources), :mod:`meshes` (small tagged
tet meshes), :mod:`study_cases` (fake case functions that pickle to workers).
"""

from __future__ import annotations

from pathlib import Path

import approx_guard
import pytest
import worker_crash

approx_guard.install()  # a stated rel bar is the enforced one (approx_guard's docstring)


def pytest_configure(config: pytest.Config) -> None:
    worker_crash.no_worker_restart(config)  # a crashed xdist worker ends the run, not hangs it


TESTS_DIR = Path(__file__).resolve().parent
REPO_ROOT = TESTS_DIR.parent
DATA_DIR = TESTS_DIR / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """``tests/data``: small vendored inputs (every file named in ``data/README-puma.md``)."""
    return DATA_DIR


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT
