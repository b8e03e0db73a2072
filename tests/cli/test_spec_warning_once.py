"""A spec warning is shown once per command, however often the command validates its spec.

Session 52 walk (geometry): ``generate`` of a fast porosity 0.3 spec printed "0.3 is below
0.72 ... jams" twice (the spec is validated on load and again when the RVE is built), then the
error it foretold. Truth: the spec-keys rule, the warning of ``FAST_JAM_POROSITY`` (0.72) once,
then the one error line, exit 2, nothing written.
"""

from __future__ import annotations

from psdesign.cli.main import main

JAM = """[rve]
size = [30e-6, 30e-6, 20e-6]
voxel = 1e-6
[generator]
diameter = 7e-6
seed = 1
porosity = 0.3
[intersections]
method = "fast"
"""


def test_the_jam_warning_once_then_the_error(tmp_path, capsys):
    spec = tmp_path / "jam.toml"
    spec.write_text(JAM)
    out = tmp_path / "g"
    assert main(["generate", str(spec), "-o", str(out), "--quiet"]) == 2
    warn, error = capsys.readouterr().err.strip().splitlines()
    assert warn.startswith("psdesign: warning: generator.porosity: 0.3 is below 0.72")
    assert error.startswith("psdesign: error: generator.porosity: target 0.3 not reached")
    assert not out.exists()
