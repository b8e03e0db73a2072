"""Progress on stderr (one printer, psdesign.progress), ``--quiet``, a clean stdout; the
cold-start pieces: ``--help`` imports no numerical library, serial twins of parallel kernels."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from dataclasses import replace

import numba as nb
import numpy as np
import pytest
from meshes import box_mesh, tag_box_boundary

from psdesign import progress as pr
from psdesign.cli import main
from solvers import jit

SPEC = """
[rve]
size = [24e-6, 24e-6, 12e-6]
voxel = 1e-6
[[fibers]]
shape = "cylinder"
diameter = 8e-6
center = [12e-6, 12e-6, 6e-6]
direction = [0, 0, 1]
[flow]
lattice_step = 2e-6
"""


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_printer_plain_lines_tty_redraw_and_quiet():
    plain = io.StringIO()
    p = pr.Printer(stream=plain, every_s=0.0)
    p.stage("meshing")
    p.estimate("voxel solve z", 120.0, 1.5)
    cb = p.iterations("FEM solve z", "MINRES")
    cb(10, 1e-3)
    cb(20, 1e-5)
    lines = plain.getvalue().splitlines()
    assert lines[0].startswith("psdesign: meshing (")
    assert lines[1] == "psdesign: voxel solve z: estimated ~2 min, ~1.5 GB"
    assert lines[2:] == [
        "psdesign: FEM solve z: 10 MINRES iterations, residual 1.0e-03, 0 s",
        "psdesign: FEM solve z: 20 MINRES iterations, residual 1.0e-05, 0 s",
    ]
    tty = _Tty()
    t = pr.Printer(stream=tty)
    t.iterations("voxel solve z", "MINRES")(5, 0.1)
    t.stage("done")
    text = tty.getvalue()
    assert text.startswith("psdesign: voxel solve z: 5 MINRES") and "\r" in text  # redrawn
    quiet = io.StringIO()
    q = pr.Printer(quiet=True, stream=quiet, every_s=0.0)
    q.stage("x")
    q.estimate("y", 1.0, 1.0)
    q.iterations("z", "CG")(1, 1.0)
    assert quiet.getvalue() == ""


def test_plain_lines_are_throttled():
    out = io.StringIO()
    cb = pr.Printer(stream=out, every_s=3600.0).iterations("solve", "CG")
    for n in range(100):
        cb(n, 1.0)
    assert out.getvalue() == ""


def test_library_calls_are_silent_without_a_command(capsys):
    pr.stage("nothing")
    pr.estimate("nothing", 1.0, 1.0)
    assert pr.iterations("x", "CG") is None
    assert capsys.readouterr().err == ""


def test_permeability_estimate_on_stderr_json_clean_quiet_silent(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC)
    args = ["permeability", str(spec), "--solver", "voxel", "--json", "--no-error-estimate"]
    assert main(args) == 0
    cap = capsys.readouterr()
    res = json.loads(cap.out)  # stdout is the JSON object only
    assert res["permeability_m2"] > 0
    cells = 24 * 24 * 12
    assert f"psdesign: voxel solve z ({cells:.3g} cells): estimated" in cap.err
    assert main([*args, "--quiet"]) == 0
    cap = capsys.readouterr()
    assert json.loads(cap.out)["permeability_m2"] == pytest.approx(
        res["permeability_m2"], rel=1e-6, abs=0
    )
    assert "estimated" not in cap.err and "MINRES" not in cap.err


def test_mesh_stages_on_stderr(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC)
    assert main(["mesh", str(spec), "-o", str(tmp_path / "m")]) == 0
    err = capsys.readouterr().err
    assert "psdesign: meshing the pore space (stuffing, z)" in err
    n_tets = json.loads((tmp_path / "m" / "mesh.json").read_text())["quality"]["n_tets"]
    assert f"{n_tets} tets (" in err
    assert main(["mesh", str(spec), "-o", str(tmp_path / "q"), "--quiet"]) == 0
    assert "meshing" not in capsys.readouterr().err


def test_fem_gmres_reports_progress():
    """The FEM solver's progress hook: called after every GMRES iteration with its residual,
    which falls to the solver's final residual; the solution does not change."""
    from solvers.fem_stokes import StokesOptions, solve_stokes

    lo, hi = (0.0, 0.0, 0.0), (1.0, 1.0, 2.0)
    pts, tets = box_mesh(lo, hi, (3, 3, 6))
    tags = tag_box_boundary(pts, tets, lo, hi, flow_axis=2)
    noslip = [k for k in tags if k.startswith("side_")]
    opts = StokesOptions(direct_max_dofs=0, tol=1e-8)
    ref = solve_stokes(pts, tets, tags, noslip=noslip, options=opts)
    calls: list[tuple[int, float]] = []
    hooked = replace(opts, progress=lambda n, r: calls.append((n, r)))
    res = solve_stokes(pts, tets, tags, noslip=noslip, options=hooked)
    assert len(calls) == res.iterations
    assert [n for n, _ in calls] == list(range(1, res.iterations + 1))
    assert calls[-1][1] == pytest.approx(res.residual, rel=1e-6, abs=0)
    assert calls[-1][1] < 1e-3 * calls[0][1]
    np.testing.assert_allclose(res.flux["outlet"], ref.flux["outlet"], rtol=1e-12)


def test_help_imports_no_numerical_library():
    code = (
        "import sys\nfrom psdesign.cli.main import build_parser\nbuild_parser().format_help()\n"
        "print(sorted(m for m in ('numpy', 'numba', 'meshio', 'scipy') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_serial_twin_matches_parallel_and_has_its_own_cache_name():
    @jit.parallel_kernel(cache=False)
    def scale_sum(x, a):
        s = 0.0
        for i in nb.prange(x.size):
            s += a * x[i]
        return s

    x = np.arange(1000, dtype=np.float64)
    assert scale_sum.serial(x, 2.0) == scale_sum.parallel(x, 2.0) == 2.0 * x.sum()
    assert scale_sum.serial.py_func.__qualname__.endswith("scale_sum__serial")
    assert scale_sum.parallel.py_func.__qualname__.endswith("scale_sum")
    # parallel not compiled for these types and the grid small: the serial twin runs
    y = np.arange(10, dtype=np.float32)
    if nb.get_num_threads() > 1:
        assert scale_sum(y, 1.0) == pytest.approx(45.0)
        assert "scale_sum" in " ".join(jit.parallel_pending())
        assert len(scale_sum.parallel.signatures) == 1  # only the float64 one from above


GEN_SPEC = """
[rve]
size = [40e-6, 40e-6, 40e-6]
voxel = 1e-6
[generator]
kind = "straight"
porosity = 0.85
diameter = 7e-6
seed = 1
"""


def test_generate_reports_generation_and_quiet_silences(tmp_path, capsys):
    spec = tmp_path / "g.toml"
    spec.write_text(GEN_SPEC)
    assert main(["generate", str(spec), "-o", str(tmp_path / "a")]) == 0
    captured = capsys.readouterr()
    assert "psdesign: generating the RVE (straight fibers, target porosity 0.85, seed 1)" in (
        captured.err
    )
    n = json.loads(captured.out)["n_fibers"]
    assert f"RVE generated: {n} fibers in " in captured.err
    assert main(["generate", str(spec), "-o", str(tmp_path / "b"), "--quiet"]) == 0
    assert "generating" not in capsys.readouterr().err
    # session 40 (s40-fuzz): without kind and seed, and with n_fibers, the line said
    # 'generating the RVE (? fibers, target porosity ?, seed ?)'; the schema's defaults now
    spec.write_text(
        GEN_SPEC.replace('kind = "straight"\n', "")
        .replace("seed = 1\n", "")
        .replace("porosity = 0.85", "n_fibers = 3")
    )
    assert main(["generate", str(spec), "-o", str(tmp_path / "c"), "--no-preview"]) == 0
    assert "psdesign: generating the RVE (straight fibers, n_fibers 3, seed 0)" in (
        capsys.readouterr().err
    )


def test_warmup_note_is_said_once(monkeypatch, capsys):
    """A voxel solve that fell back to one thread says so in its result warning; the command's
    closing line must not repeat it (session 12 printed it twice), and says it when nothing
    else did."""
    monkeypatch.setattr(jit, "_PENDING", set())
    stream = io.StringIO()
    with pr.activate(stream=stream):
        jit._PENDING.add("a_kernel")
        pr.warning(f"K_x: voxel solve ran on 1 of 2 threads: {jit.WARMUP_NOTE}")
    assert jit.WARMUP_NOTE not in stream.getvalue()
    assert capsys.readouterr().err.count(jit.WARMUP_NOTE) == 1
    with pr.activate(stream=stream):
        jit._PENDING.add("another_kernel")
    assert stream.getvalue().count(jit.WARMUP_NOTE) == 1
