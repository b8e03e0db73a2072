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


def _lines(run) -> list[str]:
    """stderr lines of ``run()`` under an active printer that throttles nothing."""
    stream = io.StringIO()
    with pr.activate(stream=stream) as printer:
        printer.every_s = 0.0
        run()
    return stream.getvalue().splitlines()


SPEC = """
[rve]
size = [40e-6, 40e-6, 40e-6]
voxel = 2e-6
[generator]
kind = "straight"
porosity = 0.85
diameter = 7e-6
seed = 1
[intersections]
method = "fast"
"""


@pytest.fixture
def spec(tmp_path):
    from psdesign.schema.spec import load_spec

    path = tmp_path / "spec.toml"
    path.write_text(SPEC)
    return load_spec(path)


def test_fast_placement_reports_fibers_placed(spec):
    """The ``fast`` placement (27 s silent at 200 um / 213 fibers) reports its fibers."""
    from psdesign.packing.generators import build_fibers

    lines = _lines(lambda: build_fibers(spec))
    placed = [ln for ln in lines if ln.startswith("psdesign: fiber placement: ")]
    assert placed, lines
    assert "placed, solid fraction" in placed[-1] and " of 0.1" in placed[-1]


def test_pore_scan_reports_radii(spec):
    """``pores``: the radius scan (the long stage at 200^3, silent before) reports
    radius i of n."""
    from psdesign.packing.build import build_rve
    from psdesign.transport.pores import pore_sizes

    fields = build_rve(spec).voxelize(2e-6)
    lines = _lines(lambda: pore_sizes(fields, n_radii=6))
    scan = [ln for ln in lines if ln.startswith("psdesign: pore scan: radius ")]
    assert scan[0].startswith("psdesign: pore scan: radius 1 of 6 ("), lines
    assert scan[-1].startswith("psdesign: pore scan: radius 6 of 6 ("), lines


def test_generate_and_pores_name_their_long_stages(tmp_path, capsys):
    """``generate`` says when it writes (8 s of VTK / STL / PNG at 200^3, silent before) and
    ``pores`` names the scan and the surface; ``--quiet`` silences both."""
    path = tmp_path / "spec.toml"
    path.write_text(SPEC)
    assert main(["generate", str(path), "-o", str(tmp_path / "a"), "--no-preview"]) == 0
    err = capsys.readouterr().err
    assert "psdesign: writing a: rve.json, field.vti, fibers.stl (" in err
    assert main(["pores", str(path), "--n-radii", "4"]) == 0
    err = capsys.readouterr().err
    assert "psdesign: pore sizes: scanning 4 radii (" in err
    assert "psdesign: specific surface (marching cubes) (" in err
    assert main(["generate", str(path), "-o", str(tmp_path / "b"), "--no-preview", "--quiet"]) == 0
    assert main(["pores", str(path), "--n-radii", "4", "--quiet"]) == 0
    assert "psdesign: " not in capsys.readouterr().err.replace("psdesign: warning", "")


def test_ga_reports_generation_of_total(tmp_path):
    """The GA's line says which generation of how many and names its objective (it said
    ``14 GA generation iterations, residual 8.2e-03``: no total, and no residual in a GA)."""
    from psdesign.packing.generators import build_fibers
    from psdesign.schema.spec import load_spec

    path = tmp_path / "ga.toml"
    path.write_text(
        SPEC.replace('method = "fast"', 'method = "ga"\ngenerations = 3\npopulation = 4')
    )
    lines = _lines(lambda: build_fibers(load_spec(path)))
    ga = [ln for ln in lines if ln.startswith("psdesign: fiber placement (GA): generation ")]
    assert ga and " of 3, overlap " in ga[-1] and "(analytic)" in ga[-1], lines
