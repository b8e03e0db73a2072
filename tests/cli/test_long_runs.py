"""Long commands as a demanding user sees them: progress on stderr during every long stage,
and Ctrl-C / SIGTERM leaving exactly one line (``psdesign: interrupted``)."""

from __future__ import annotations

import io

import pytest

from psdesign import progress as pr
from psdesign.cli import main
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
    assert main(["pores", str(path), "--n-radii", "4"]) in (0, 3)  # finished
    err = capsys.readouterr().err
    assert "psdesign: pore sizes: scanning 4 radii (" in err
    assert "psdesign: specific surface (marching cubes) (" in err
    assert main(["generate", str(path), "-o", str(tmp_path / "b"), "--no-preview", "--quiet"]) == 0
    assert main(["pores", str(path), "--n-radii", "4", "--quiet"]) in (0, 3)
    assert "psdesign: " not in capsys.readouterr().err.replace("psdesign: warning", "")


def test_ga_reports_generation_of_total(tmp_path, monkeypatch):
    """The GA's line says which round and generation of how many and names its objective (it
    said ``14 GA generation iterations, residual 8.2e-03``); one throttled callback serves
    every porosity round (a new one per round printed nothing when rounds took < 5 s)."""
    from psdesign.packing import generators
    from psdesign.schema.spec import load_spec

    path = tmp_path / "ga.toml"
    path.write_text(
        SPEC.replace("seed = 1", "seed = 1\nporosity_tolerance = 1e-6").replace(
            'method = "fast"', 'method = "ga"\ngenerations = 3\npopulation = 4'
        )
    )
    reports = []
    real = generators.genetic

    def spy(*args, **kw):
        reports.append(kw.get("report"))
        return real(*args, **kw)

    monkeypatch.setattr(generators, "genetic", spy)
    spec = load_spec(path)

    def build():
        with pytest.raises(generators.GenerationError):  # 1e-6 is out of reach: every round
            generators.build_fibers(spec)

    lines = _lines(build)
    assert len(reports) > 1 and reports[0] is not None
    assert all(r is reports[0] for r in reports)
    ga = [ln for ln in lines if ln.startswith("psdesign: fiber placement (GA round 1): generation")]
    assert ga and " of 3, overlap " in ga[0] and "(analytic)" in ga[0], lines


@pytest.fixture
def python_sigint():
    """Python's own SIGINT handler for the test (another test file of this worker may have
    imported a library that replaced it, e.g. dask_jobqueue), restored afterwards."""
    import signal

    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


def test_ctrl_c_during_the_preview_render_is_not_lost(tmp_path, monkeypatch, python_sigint):
    """A Ctrl-C that lands in pyvista's smooth-shading algorithm (a Python VTK algorithm run
    by the render) was swallowed by VTK (an error dump on stderr) and ``generate`` finished
    with exit 0; it is now raised once the render returns."""
    import signal

    import numpy as np
    from pyvista.plotting.utilities import algorithms

    from psdesign.report.preview import render_preview

    original = algorithms.SmoothShadingAlgorithm.RequestData
    hits = []

    def interrupted(self, *args):
        hits.append(1)
        signal.raise_signal(signal.SIGINT)  # Ctrl-C while VTK runs the Python algorithm
        return original(self, *args)

    monkeypatch.setattr(algorithms.SmoothShadingAlgorithm, "RequestData", interrupted)
    x = np.linspace(-1.0, 1.0, 12)
    distance = np.sqrt(x[:, None, None] ** 2 + x[None, :, None] ** 2 + 0 * x) - 0.5
    with pytest.raises(KeyboardInterrupt):
        render_preview(distance, np.full(3, 1e-6), tmp_path / "p.png")
    assert hits
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_large_preview_is_rendered_from_a_coarser_grid(tmp_path, monkeypatch):
    """The preview of a 200^3 field is drawn from every second point (the full render took
    6-12 s, all of which an interrupt waits for)."""
    import numpy as np

    from psdesign.report import preview

    seen = []
    original = preview.fiber_surface
    monkeypatch.setattr(
        preview, "fiber_surface", lambda d, h: seen.append(d.shape) or original(d, h)
    )
    distance = np.ones((200, 150, 40), np.float32)
    preview.render_preview(distance, np.full(3, 1e-6), tmp_path / "p.png")
    assert seen == [(100, 75, 20)]


def test_held_signals_deliver_sigterm_after_the_body():
    """``held_signals``: a SIGTERM during the body is raised after it as
    :class:`Terminated` (the command's SIGTERM handler is back in place)."""
    import signal

    from psdesign.study.interrupt import Terminated, held_signals, terminate_as_interrupt

    done = []
    with pytest.raises(Terminated), terminate_as_interrupt():
        with held_signals():
            signal.raise_signal(signal.SIGTERM)
            done.append(1)  # the body runs to its end
    assert done == [1]


def test_field_relax_reports_its_polls():
    """``forcefield`` on woven / compressed fibers (``studies/forcefield_woven.toml``: over
    2 minutes without a line) reports the pattern search's polls as the rod route does."""
    from dataclasses import replace

    import numpy as np

    from psdesign.forcefield.contact import relax_contacts
    from psdesign.forcefield.search_settings import RELAX_SEARCH
    from psdesign.geometry.fibers import woven_cell

    cell = woven_cell("z", 1)
    pair = [cell[0], cell[4]]  # a warp and a weft crossing
    lines = _lines(
        lambda: relax_contacts(
            pair,
            np.zeros(3),
            np.ones(3),
            h=0.04,
            max_shift=0.05,
            u_max=0.4,
            search=replace(RELAX_SEARCH, max_evals=60),
        )
    )
    polls = [ln for ln in lines if ln.startswith("psdesign: relax (2 fibers, contacts on a grid)")]
    assert polls and " polls, " in polls[-1] and " evaluations, U = " in polls[-1], lines


def test_ctrl_c_during_the_force_field_pictures_is_not_lost(tmp_path, monkeypatch, python_sigint):
    """As the preview: ``forcefield``'s before.png / after.png render ran pyvista's
    smooth-shading algorithm, where VTK swallowed a Ctrl-C."""
    import signal

    from pyvista.plotting.utilities import algorithms

    from psdesign.forcefield import two_fiber_problem
    from psdesign.forcefield.render import render_fibers

    original = algorithms.SmoothShadingAlgorithm.RequestData

    def interrupted(self, *args):
        signal.raise_signal(signal.SIGINT)
        return original(self, *args)

    monkeypatch.setattr(algorithms.SmoothShadingAlgorithm, "RequestData", interrupted)
    prob = two_fiber_problem(f0=1.7)
    with pytest.raises(KeyboardInterrupt):
        render_fibers(prob.fields(prob.x0), tmp_path / "p.png", h=0.05)


def test_study_interrupt_leaves_one_line(monkeypatch, capsys):
    """``rev`` / ``study run``: Ctrl-C printed ``psdesign: interrupted; stopping workers ...``
    and then ``psdesign: interrupted``; the command's line is now the only one (library use,
    without a command, still gets the notice)."""
    import signal

    import psdesign.cli.pores as pores
    from psdesign.study.interrupt import stop_on_interrupt

    def run(args):
        with stop_on_interrupt():
            signal.raise_signal(signal.SIGINT)

    monkeypatch.setattr(pores, "_cmd", run)
    assert main(["pores", "spec.toml"]) == 130
    assert capsys.readouterr().err.splitlines() == ["psdesign: interrupted"]
    with pytest.raises(KeyboardInterrupt):
        run(None)
    assert capsys.readouterr().err.splitlines() == ["psdesign: interrupted; stopping workers ..."]


def test_voxel_solve_reports_from_its_first_iteration():
    """The voxel Stokes solve reports every Krylov iteration (its printer throttles): every
    25th left 13 s without a line at 200^3 on a loaded machine."""
    import numpy as np

    from solvers.voxel_stokes import solve_voxel_stokes

    n = 24
    x = (np.arange(n) + 0.5) / n - 0.5
    solid = np.broadcast_to(
        ((x[:, None] ** 2 + x[None, :] ** 2) < 0.2**2)[:, :, None], (n, n, 4)
    ).copy()
    calls = []
    solve_voxel_stokes(solid, 1.0 / n, "z", tol=1e-6, progress=lambda i, r: calls.append(i))
    assert calls[:3] == [1, 2, 3], calls


def test_fem_solve_names_its_steps_before_the_first_iteration():
    """FEM: assembly and the preconditioner's set-up ran 17 s (1.4 M unknowns) between the
    estimate and the first GMRES line without a word; ``stage`` names them."""
    from meshes import box_mesh, tag_box_boundary

    from solvers.fem_stokes import StokesOptions, solve_stokes

    lo, hi = (0.0, 0.0, 0.0), (1.0, 1.0, 2.0)
    pts, tets = box_mesh(lo, hi, (3, 3, 6))
    tags = tag_box_boundary(pts, tets, lo, hi, flow_axis=2)
    noslip = [k for k in tags if k.startswith("side_")]
    said: list[str] = []
    solve_stokes(
        pts, tets, tags, noslip=noslip, options=StokesOptions(direct_max_dofs=0, stage=said.append)
    )
    assert said == ["assembling the system", "preconditioner set-up (SA AMG), then GMRES"]


def test_stl_is_written_in_blocks_as_vtk_writes_it(tmp_path, monkeypatch):
    """``fibers.stl`` is written block by block (VTK wrote 136 MB at 200^3 in one 3 s C call
    that a Ctrl-C waited for); pyvista reads back the same triangles as from VTK's file."""
    import numpy as np
    import pyvista as pv

    from psdesign.report import preview

    x = np.linspace(-1.0, 1.0, 14)
    distance = np.sqrt(x[:, None, None] ** 2 + x[None, :, None] ** 2 + 0 * x) - 0.5
    surf = preview.fiber_surface(distance, np.full(3, 1e-6))
    surf.save(str(tmp_path / "vtk.stl"))
    monkeypatch.setattr(preview, "STL_CHUNK", 7)  # many blocks
    preview.write_stl(surf, tmp_path / "ours.stl")
    ours, vtk = pv.read(tmp_path / "ours.stl"), pv.read(tmp_path / "vtk.stl")
    assert ours.n_cells == vtk.n_cells == surf.n_cells > 7
    np.testing.assert_array_equal(ours.points, vtk.points)
    np.testing.assert_array_equal(ours.faces, vtk.faces)
    ours_bytes = (tmp_path / "ours.stl").read_bytes()
    vtk_bytes = (tmp_path / "vtk.stl").read_bytes()
    assert len(ours_bytes) == len(vtk_bytes) == 84 + 50 * surf.n_cells
    a = np.frombuffer(ours_bytes[84:], preview._STL_RECORD)
    b = np.frombuffer(vtk_bytes[84:], preview._STL_RECORD)
    np.testing.assert_array_equal(a["vertices"], b["vertices"])
    np.testing.assert_allclose(a["normal"], b["normal"], atol=1e-6)


def test_a_kernel_compile_is_announced():
    """A numba compile (a cold start: up to 100 s before the voxel solve's first line) says
    so, once per command; without a command nothing is printed."""
    import numba as nb

    import solvers.jit  # noqa: F401 - installs the compile listener

    @nb.njit
    def _fresh(x):
        return x + 1

    lines = _lines(lambda: _fresh(1))
    assert lines[0].startswith("psdesign: compiling numba kernels (once after an install"), lines
    assert sum("compiling numba kernels (" in ln for ln in lines) == 1
    assert any("compiling numba kernels: 1 so far (" in ln for ln in lines), lines

    @nb.njit
    def _other(x):
        return x + 2

    _other(1)  # no printer: silent (capsys is not needed: nothing may fail)


def test_fem_assembly_counts_its_elements():
    """The volume assembly (14 s at 1.4 M unknowns) said one stage line and no count; it now
    calls ``progress(elements_done, n_elements)`` after each batch, up to the total, through
    ``solve_stokes``'s ``assembly_progress`` too; the matrices do not change."""
    import numpy as np
    from meshes import box_mesh, tag_box_boundary

    from solvers.fem import assembly
    from solvers.fem_stokes import StokesOptions, solve_stokes

    lo, hi = (0.0, 0.0, 0.0), (1.0, 1.0, 2.0)
    pts, tets = box_mesh(lo, hi, (3, 3, 6))
    mesh = assembly.make_mesh(pts, tets)
    calls: list[tuple[int, int]] = []
    L, D, m = assembly.assemble_volume(mesh, chunk=100, progress=lambda *a: calls.append(a))
    n = len(tets)
    assert calls == [(100, n), (200, n), (300, n), (n, n)] and n == 324
    L1, D1, m1 = assembly.assemble_volume(mesh)
    assert abs(L - L1).max() < 1e-12 and np.allclose(m, m1, rtol=1e-13)
    assert all(abs(a - b).max() < 1e-12 for a, b in zip(D, D1, strict=True))
    tags = tag_box_boundary(pts, tets, lo, hi, flow_axis=2)
    noslip = [k for k in tags if k.startswith("side_")]
    said: list[tuple[int, int]] = []
    solve_stokes(
        pts,
        tets,
        tags,
        noslip=noslip,
        options=StokesOptions(assembly_progress=lambda *a: said.append(a)),
    )
    assert said == [(n, n)]
    (line,) = _lines(lambda: pr.counted("FEM solve z: assembling", "elements")(n, n))
    assert line.startswith(f"psdesign: FEM solve z: assembling: {n}/{n} elements, ")


def test_laplace_cg_reports_every_iteration():
    """The Laplace CG called ``progress`` every 10 iterations (a solve of 9 said nothing);
    now every iteration, as the voxel solver (``solvers.progress.PROGRESS_EVERY``), the
    printer throttling the lines."""
    import numpy as np

    from solvers.transport import solve_laplace

    sigma = np.ones((16, 8, 8))
    sigma[5:9, 2:6, :] = 1e-3
    calls: list[tuple[int, float]] = []
    res = solve_laplace(sigma, 0, "fixed", progress=lambda *a: calls.append(a))
    assert 1 < res.iterations < 10
    assert [i for i, _ in calls] == list(range(1, res.iterations + 1))
    assert [r for _, r in calls] == res.history[1:]


def test_stuffing_counts_its_steps_and_passes():
    """The lattice mesher said "meshing" and "mesh: N tets" only, with up to seven stuffing
    passes (volume matching) between; each pass now counts its steps to the total, on one
    throttled line naming the pass, and the mesh does not change; the component and quality
    steps after the passes are named."""
    import numpy as np

    from psdesign.meshing.pore_mesh import mesh_pore_space
    from psdesign.meshing.stuffing import STUFFING_STEPS, stuff_pore_space

    n, side = 16, 16e-6
    c = (np.arange(n) + 0.5) * side / n
    x, y, _ = np.meshgrid(c, c, c, indexing="ij")
    d = np.sqrt((x - side / 2) ** 2 + (y - side / 2) ** 2) - 0.3 * side
    args = (d, side / n, (side,) * 3, 2, 0.2, 2 * side / n)
    calls: list[tuple[int, int]] = []
    sm = stuff_pore_space(*args, progress=lambda *a: calls.append(a))
    assert calls == [(k, STUFFING_STEPS) for k in range(1, STUFFING_STEPS + 1)]
    ref = stuff_pore_space(*args)
    np.testing.assert_array_equal(sm.tets, ref.tets)
    np.testing.assert_array_equal(sm.points, ref.points)
    lines = _lines(
        lambda: mesh_pore_space(
            d, side / n, (side,) * 3, "z", mesher="stuffing", lattice_step=2 * side / n,
            min_gap_voxels=0,
        )
    )  # fmt: skip
    steps = [ln.rpartition(", ")[0] for ln in lines if "stuffing pass" in ln]  # no time
    assert steps[:STUFFING_STEPS] == [
        f"psdesign: stuffing pass 1: {k}/{STUFFING_STEPS} steps"
        for k in range(1, STUFFING_STEPS + 1)
    ]
    assert "psdesign: stuffing pass 2: 1/5 steps" in steps  # volume matching
    # then two vectorized steps as long as the passes (12 s and 18 s at 5 M tets) say so
    assert any("through-flow components and tags" in ln for ln in lines)
    assert any(ln.startswith("psdesign: mesh: quality checks") for ln in lines)
