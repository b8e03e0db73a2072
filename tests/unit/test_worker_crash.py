"""A crashed xdist worker ends the README's test command instead of hanging it.

Truth: the behaviour pytest-xdist's own tracker describes (issue 1323: under ``--dist loadfile``
a replaced worker is handed a file its dead predecessor had finished and waits forever) and the
session-44 reproduction (the same layout as below hung until stopped, ``benchmarks/RESULTS.md``,
"Session 44"). The crash runs in a throwaway project under ``tmp_path``, never in the suite.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path
from types import SimpleNamespace

import pytest

pytest.importorskip("xdist")

TESTS_DIR = Path(__file__).resolve().parents[1]

HANG_S = 90.0
"""The fixed run takes 3-9 s (two workers start, collect 19 tests, one aborts); the old one never
ends. 90 s leaves a loaded machine's slow worker start-up far inside the bar."""

_OK_FILE = """
import pytest

@pytest.mark.parametrize("i", range(4))
def test_ok(i):
    assert i >= 0
"""

# Fewer tests than the other files: loadfile hands it out last, to a worker that has finished a
# file already (the case that hung).
_CRASH_FILE = """
import os

def test_before():
    pass

def test_abort():
    os.abort()

def test_after():
    pass
"""

# The throwaway project runs the suite's own pytest_configure (tests/conftest.py, loaded by path).
_CONFTEST = f"""
import importlib.util
import sys

sys.path.insert(0, {str(TESTS_DIR)!r})
_spec = importlib.util.spec_from_file_location("suite_conftest", {str(TESTS_DIR / "conftest.py")!r})
_suite = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_suite)
if hasattr(_suite, "pytest_configure"):  # a conftest without one runs xdist's defaults
    pytest_configure = _suite.pytest_configure
"""


def _project(root: Path) -> None:
    """Four passing files and one whose middle test aborts its worker."""
    (root / "pytest.ini").write_text("[pytest]\n")
    (root / "conftest.py").write_text(textwrap.dedent(_CONFTEST))
    for name in "abcd":
        (root / f"test_{name}_ok.py").write_text(textwrap.dedent(_OK_FILE))
    (root / "test_z_crash.py").write_text(textwrap.dedent(_CRASH_FILE))


def _run(root: Path) -> subprocess.CompletedProcess[str]:
    """The README's ``python -m pytest -n 2 --dist loadfile`` in ``root``, killed after HANG_S."""
    cmd = [sys.executable, "-m", "pytest", "-n", "2", "--dist", "loadfile"]
    proc = subprocess.Popen(
        cmd,
        cwd=root,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,  # its workers in its group, so a hang is stopped whole
    )
    try:
        out, _ = proc.communicate(timeout=HANG_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        pytest.fail(f"pytest -n 2 --dist loadfile still running after {HANG_S} s:\n{out[-3000:]}")
    return subprocess.CompletedProcess(cmd, proc.returncode, out)


def test_a_crashed_worker_fails_the_run_naming_its_test(tmp_path: Path) -> None:
    _project(tmp_path)
    run = _run(tmp_path)
    assert run.returncode == 1, run.stdout[-3000:]
    assert "crashed while running 'test_z_crash.py::test_abort'" in run.stdout
    assert "worker restarting disabled" in run.stdout
    # 16 ok tests and test_before passed; test_after never ran (the worker died first)
    assert "1 failed, 17 passed" in run.stdout, run.stdout[-3000:]


def test_an_explicit_max_worker_restart_is_kept() -> None:
    import worker_crash

    given = SimpleNamespace(option=SimpleNamespace(maxworkerrestart="3"))  # only .option is read
    worker_crash.no_worker_restart(given)
    assert given.option.maxworkerrestart == "3"
    unset = SimpleNamespace(option=SimpleNamespace(maxworkerrestart=None))
    worker_crash.no_worker_restart(unset)
    assert unset.option.maxworkerrestart == "0"
    without_xdist = SimpleNamespace(option=SimpleNamespace())  # -p no:xdist: no such option
    worker_crash.no_worker_restart(without_xdist)
    assert not hasattr(without_xdist.option, "maxworkerrestart")
