"""Hand the costliest test files out first under ``--dist loadfile``, so both workers end together.

pytest-xdist's ``loadfile`` scheduler hands out whole files, by default the files with the most
tests first (``--loadscope-reorder``). A file of few long tests therefore went out last, and the
other worker waited for it: in session 49's cold run (``benchmarks/RESULTS.md``, "Session 49:
the default suite's time") ``tests/validation/test_permeability.py`` (2 tests, a CLI solve in a
child process) was handed out last and ran alone on one worker for the last 23 s of the run, and
the compile-heavy ``test_voxel_lanczos.py`` (40 tests, 143 s of numba compiling at load 6) and
``test_forcefield.py`` went out in the middle of the run only because of their test counts.

Installed from ``conftest.py``: under ``--dist loadfile`` the scheduler keeps the collection's
order of files (``--no-loadscope-reorder``), and each worker's collection puts the files of
:data:`HEAVY` first, in that order (longest first: the classic longest-processing-time rule, whose
idle tail is at most the last file handed out), then every other file by its number of tests,
most first (xdist's own rule), in collection order where the counts tie. The order of the tests
inside a file is kept. Without xdist (one process) the order is pytest's.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import pytest

HEAVY = (
    "tests/unit/test_voxel_kernels.py",
    "tests/unit/test_api.py",
    "tests/unit/test_voxel_lanczos.py",
    "tests/validation/test_error_estimate.py",
    "tests/unit/test_forcefield.py",
    "tests/cli/test_report_browser.py",
    "tests/unit/test_report.py",
    "tests/unit/test_study.py",
    "tests/unit/test_optimize_targets.py",
    "tests/unit/test_study_safety.py",
    "tests/cli/test_cli_permeability.py",
    "tests/validation/test_curvature_term.py",
    "tests/cli/test_cli_fields.py",
    "tests/unit/test_tetwild_rve.py",
    "tests/cli/test_exit_joins.py",
    "tests/cli/test_disk_full.py",
    "tests/unit/test_analysis.py",
    "tests/unit/test_stuffing.py",
    "tests/validation/test_permeability.py",
    "tests/unit/test_forcefield_contact.py",
    "tests/cli/test_outputs_safety.py",
    "tests/validation/test_geometry_truth.py",
)
"""The files that took >= 38 s of wall each in session 49's cold-cache run (load ~6, about a
third of that on an idle core), longest first; every other file took less."""


def _loadfile_run(config: pytest.Config) -> bool:
    return getattr(config.option, "dist", "no") == "loadfile"


def keep_file_order(config: pytest.Config) -> None:
    """Under ``--dist loadfile``, hand files out in the collection's order.

    Parameters
    ----------
    config
        The session's configuration, in ``pytest_configure`` (the scheduler reads the option
        when the workers have collected).
    """
    if _loadfile_run(config):
        config.option.loadscopereorder = False


def heavy_files_first(items: Sequence[pytest.Item]) -> list[pytest.Item]:
    """The items with :data:`HEAVY`'s files first, then the other files by test count.

    Parameters
    ----------
    items
        The collected items, each with a ``nodeid`` of the form ``path::name``.

    Returns
    -------
    list
        The same items; each file's items stay together and in their order.
    """
    files = [item.nodeid.split("::")[0] for item in items]
    count = Counter(files)
    first = {}
    for i, name in enumerate(files):
        first.setdefault(name, i)
    rank = {name: i for i, name in enumerate(HEAVY)}
    order = sorted(
        range(len(items)),
        key=lambda i: (rank.get(files[i], len(HEAVY)), -count[files[i]], first[files[i]], i),
    )
    return [items[i] for i in order]


def reorder(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Put the heavy files first in an xdist worker's collection (in place).

    A worker cannot tell which ``--dist`` its controller runs (xdist sets the worker's option to
    ``"no"``), so every worker reorders; only ``loadfile`` keeps that order (other schedulers
    hand tests out in collection order anyway, or sort it by their own rule)."""
    if hasattr(config, "workerinput"):
        items[:] = heavy_files_first(items)
