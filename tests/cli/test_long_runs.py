"""Long commands as a demanding user sees them: progress on stderr during every long stage,
and Ctrl-C / SIGTERM leaving exactly one line (``psdesign: interrupted``)."""

from __future__ import annotations

import io

import pytest

from psdesign.cli import main
from psdesign.cli import progress as pr
from solvers import jit


def test_interrupt_is_the_only_closing_line(monkeypatch, capsys):
    """Ctrl-C after kernels ran on one thread: ``psdesign: interrupted`` alone. The closing
    note (``numba kernels ran on one thread ...``) used to be printed first, on the way out of
    the interrupted command."""
    monkeypatch.setattr(jit, "_PENDING", set())
    stream = io.StringIO()
    with pytest.raises(KeyboardInterrupt), pr.activate(stream=stream):
        jit._PENDING.add("a_kernel")
        raise KeyboardInterrupt
    assert stream.getvalue() == ""
    assert pr.active() is None

    import psdesign.cli.pores as pores

    def interrupted(args):
        jit._PENDING.add("another_kernel")
        raise KeyboardInterrupt

    monkeypatch.setattr(pores, "_cmd", interrupted)
    assert main(["pores", "spec.toml"]) == 130
    assert capsys.readouterr().err.splitlines() == ["psdesign: interrupted"]
