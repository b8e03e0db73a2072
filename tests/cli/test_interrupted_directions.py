"""``permeability --direction all`` interrupted after a direction finished (session 52
walk-mesh finding 3): the command solved every direction and then printed, so a Ctrl-C during
K_y exited 130 with an empty stdout and K_x, solved, was lost. Truth: the K_x printed is the
one the same command prints for ``--direction x`` alone (the same solve, deterministic)."""

from __future__ import annotations

import json

import pytest

import psdesign.cli.permeability as cli_perm
from psdesign.cli.main import main

SPEC = """[rve]
size = [40e-6, 40e-6, 40e-6]
voxel = 2e-6
[[fibers]]
shape = "cylinder"
diameter = 20.1850e-6
center = [20e-6, 20e-6, 20e-6]
direction = [0, 0, 1]
[flow]
viscosity = 1.8e-5
"""


def _interrupt_after_x(monkeypatch):
    """Ctrl-C as the second direction (y) starts: the real solve for x, an interrupt for y."""
    real = cli_perm._solve

    def solve(rve, fields, direction, *rest):
        if direction != "x":
            raise KeyboardInterrupt
        return real(rve, fields, direction, *rest)

    monkeypatch.setattr(cli_perm, "_solve", solve)


@pytest.mark.parametrize("as_json", [False, True])
def test_a_ctrl_c_keeps_the_finished_directions(tmp_path, monkeypatch, capsys, as_json):
    spec = tmp_path / "sq.toml"
    spec.write_text(SPEC)
    head = ["permeability", str(spec), "--solver", "voxel", "--quiet"]
    tail = ["--json"] if as_json else []
    assert main([*head, "--direction", "x", *tail]) in (0, 3)
    alone = capsys.readouterr().out
    _interrupt_after_x(monkeypatch)
    fields = tmp_path / "f"
    assert main([*head, "--direction", "all", "--fields", str(fields), *tail]) == 130
    cap = capsys.readouterr()
    assert not fields.exists()  # no half-written --fields folder
    assert "K_y, K_z not solved" in cap.err
    if as_json:
        out, one = json.loads(cap.out), json.loads(alone)
        assert out["interrupted"] is True and out["overall_status"] == "interrupted"
        assert out["unsolved_directions"] == ["y", "z"]
        assert out["permeability_m2"] == {"x": one["permeability_m2"]}
    else:
        assert cap.out == alone and cap.out.startswith("K_x = ")
