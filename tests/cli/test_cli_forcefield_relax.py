"""``psdesign forcefield`` on an RVE spec (the relax route): the ``[forcefield.relax]`` table is
checked before any work, and a run stopped on its iteration limit says not converged."""

from __future__ import annotations

import json

import numpy as np
import pytest

from psdesign.cli import main

D = 10e-6
#: Two rods of diameter D crossing at right angles, their axes 3 um apart (< D: they overlap).
RODS = f"""
[rve]
size = [1e-4, 1e-4, 1e-4]
voxel = 1e-6
[[fibers]]
shape = "rod"
diameter = {D}
center = [50e-6, 50e-6, 50e-6]
[[fibers]]
shape = "rod"
diameter = {D}
center = [50e-6, 50e-6, 53e-6]
omega = 90.0
[forcefield.relax]
max_shift = 10e-6
"""


def _no_build(*args, **kwargs):
    raise AssertionError("the RVE was built before the [forcefield.relax] table was refused")


@pytest.mark.parametrize(
    ("line", "key"),
    [
        ("weights = [-1e10, 1.0, 1.0]", "weights"),  # was run: U = -1.8e8 rewarded the overlap
        ("weights = [inf, 1.0, 1.0]", "weights"),  # was run: U = inf, a numpy warning
        ("weights = [0.0, 0.0, 0.0]", "weights"),
        ("max_iter = 2.5", "max_iter"),  # was run with max_iter = 2
        ("max_evals = 1e3", "max_evals"),
        ("u_max = 10", "u_max"),  # was refused only after the RVE was built
        ("u_max = 0.3\nf = 0", "f"),
        ("tie_bend = 1", "tie_bend"),
        ("grid = -1e-6", "grid"),
    ],
)
def test_relax_table_is_checked_before_any_work(tmp_path, capsys, monkeypatch, line, key):
    import psdesign.packing.build as build

    spec = tmp_path / "s.toml"
    spec.write_text(RODS + line + "\n")
    monkeypatch.setattr(build, "build_rve", _no_build)
    out = tmp_path / "out"
    assert main(["forcefield", str(spec), "-o", str(out), "--no-pictures"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"psdesign: error: forcefield.relax.{key}:"), err
    assert not out.exists()


GENERATED = """
[rve]
size = [60e-6, 60e-6, 60e-6]
voxel = 1e-6
[generator]
porosity = 0.85
diameter = 7e-6
"""


# session 34 fuzz: `grid` / `gap` / `tie_bend` (field-route keys) on rods, and an [image] spec
# (no fibers), were refused only after the RVE was built: a generator's placement first ran.
@pytest.mark.parametrize(
    ("spec_text", "key", "text"),
    [
        (RODS + "grid = 1e-6\n", "forcefield.relax.grid", "only used for woven / compressed"),
        (GENERATED + "[forcefield.relax]\ngap = 1e-6\n", "forcefield.relax.gap", "only used"),
        (
            GENERATED + "[forcefield.relax]\ntie_bend = true\n",
            "forcefield.relax.tie_bend",
            "only used",
        ),
        ('[image]\npath = "a.npy"\nvoxel_size = 1e-6\n', "fibers", "this spec has none"),
    ],
)
def test_relax_route_refusals_before_the_build(tmp_path, capsys, monkeypatch, spec_text, key, text):
    import psdesign.packing.build as build

    a = np.zeros((8, 8, 8), np.uint8)
    a[2:5] = 1
    np.save(tmp_path / "a.npy", a)
    spec = tmp_path / "s.toml"
    spec.write_text(
        spec_text + ("[rve]\nsize = [8e-6, 8e-6, 8e-6]\n" if "image" in spec_text else "")
    )
    monkeypatch.setattr(build, "build_rve", _no_build)
    out = tmp_path / "out"
    assert main(["forcefield", str(spec), "-o", str(out), "--no-pictures"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"psdesign: error: {key}: ") and text in err[0], err
    assert not out.exists()


def test_image_spec_without_rve_is_refused_as_an_rve_spec(tmp_path, capsys) -> None:
    # [rve] may be left out beside [image] (docs/images.md); such a spec was read as a paper
    # case and refused with "image: unknown table (allowed: forcefield)"
    a = np.zeros((8, 8, 8), np.uint8)
    a[2:5] = 1
    np.save(tmp_path / "a.npy", a)
    spec = tmp_path / "s.toml"
    spec.write_text('[image]\npath = "a.npy"\nvoxel_size = 1e-6\n')
    out = tmp_path / "out"
    assert main(["forcefield", str(spec), "-o", str(out), "--no-pictures"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("psdesign: error: fibers: "), err
    assert "this spec has none" in err[0] and not out.exists()


def test_a_study_file_given_to_forcefield_names_the_mix_up(tmp_path, capsys) -> None:
    # session 42 named a study file given where an RVE spec goes (permeability, generate, mesh,
    # ...) but not here: `psdesign forcefield studies/quickstart.toml` said "base: unknown
    # table (allowed: forcefield)", a table to delete, though the command also takes RVE specs
    from pathlib import Path

    study = Path(__file__).resolve().parents[2] / "studies" / "quickstart.toml"
    out = tmp_path / "out"
    assert main(["forcefield", str(study), "-o", str(out), "--no-pictures"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("psdesign: error: forcefield: "), err
    assert "this is a study file" in err[0] and "`psdesign study run FILE -o OUT`" in err[0]
    assert not out.exists()


def test_relax_stopped_on_its_iteration_limit_is_not_converged(tmp_path, capsys):
    """Two polls: the first fiber moves to its bound (10 um) and the overlap is gone, but the
    search stopped on ``max_iter``; the status is ``not_converged`` (it was ``at_bound``, which
    the docs call a constrained optimum) and the warning names the limit and the bound.

    Independent check of ``omega_analytic_after == 0``: two perpendicular cylinders of diameter
    D are disjoint iff the distance between their axes, the offset along d1 x d2, is >= D."""
    spec = tmp_path / "s.toml"
    spec.write_text(RODS + "max_iter = 2\n")
    out = tmp_path / "out"
    # 3: written, not converged (exit_status.NOT_TRUSTED)
    assert main(["forcefield", str(spec), "-o", str(out), "--no-pictures", "--quiet"]) == 3
    (warn,) = capsys.readouterr().err.strip().splitlines()
    assert "iteration limit (max_iter=2), not converged" in warn and "on the bound of" in warn
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "not_converged" and summary["converged"] is False
    assert summary["at_bound"] == ["t1[0]"]
    fibers = [
        block
        for block in (out / "relaxed.toml").read_text().split("[[fibers]]")[1:]
        if "shape" in block
    ]
    centers = [
        np.array(json.loads(b.split("center = ")[1].splitlines()[0])) for b in fibers
    ]  # rod 1 along x, rod 2 along y: their axes' distance is the z offset
    gap = abs(centers[1][2] - centers[0][2])
    assert gap == pytest.approx(13e-6, rel=1e-9)  # 3 um + the 10 um move on the bound
    assert (gap >= D) == (summary["omega_analytic_after"] == 0.0)
    assert summary["omega_analytic_before"] > 0.0  # 3 um < D at the start
    # session 47: each carries its bar and status (they were stored alone). Truth of the
    # start: the exact lens of the nominal cylinders, axes 3 um apart (Cavalieri, scipy
    # quad), as a fraction of the 100 um box
    from conftest import load_benchmark

    lens = load_benchmark("porosity_error_coverage").crossing_lens(D / 2, D / 2, 3e-6)
    before, bar = summary["omega_analytic_before"], summary["omega_analytic_before_error"]
    assert abs(before - lens / 1e-12) <= bar <= 0.2 * before
    # rods: the nominal cylinders' lens only bounds the rods' own overlap from above
    assert summary["omega_analytic_before_status"] == "untrustworthy"
    assert summary["omega_analytic_after_error"] == 0.0
    assert summary["omega_analytic_after_status"] == "ok"


def test_relax_reports_its_search_progress(tmp_path, monkeypatch):
    """Rule: progress on long work. audit s32: the force field's pattern searches printed
    nothing until done (a paper case: minutes). Each poll now reports its count, U and mesh
    size (a terminal redraws the line at once); the U it prints falls as the search goes."""
    import io
    import re

    from psdesign import progress as pr
    from psdesign.forcefield.run import load_forcefield_spec, run_forcefield

    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    spec = tmp_path / "s.toml"
    spec.write_text(RODS + "max_iter = 6\n")
    stream = Tty()
    monkeypatch.setattr(pr.time, "perf_counter", iter(np.arange(0.0, 1e6, 1.0)).__next__)
    with pr.activate(stream=stream):
        run_forcefield(load_forcefield_spec(spec), tmp_path / "out", pictures=False)
    lines = re.findall(
        r"relax \(2 fibers\): (\d+) polls, \d+ evaluations, U = (\S+),", stream.getvalue()
    )
    assert [int(n) for n, _ in lines] == list(range(1, len(lines) + 1)) and len(lines) >= 3
    u = [float(v) for _, v in lines]
    assert u == sorted(u, reverse=True) and u[-1] < u[0]


def _two_cylinder_volume(r: float, dist: float) -> float:
    """Volume shared by two perpendicular infinite cylinders of radius r, axes ``dist`` apart:
    ``int 2 sqrt(r^2 - z^2) 2 sqrt(r^2 - (z - dist)^2) dz`` (Steinmetz's construction, by
    adaptive quadrature: independent of the code's Gauss-Legendre rule)."""
    from scipy.integrate import quad

    def width(z: float) -> float:
        return 4.0 * np.sqrt(max(r * r - z * z, 0.0) * max(r * r - (z - dist) ** 2, 0.0))

    return quad(width, dist - r, r, epsabs=0.0, epsrel=1e-13, limit=200)[0]


def test_relax_prints_and_writes_error_bars(tmp_path, capsys):
    """Rule: every printed number carries an error estimate. s40: the relax route wrote U, the
    start's U and the moves with no bar (the paper cases had U_error and free_variables_error).
    Now U, its terms and the start's U carry the paper cases' quadrature bar (crossing volume at
    8 and 4 Gauss-Legendre nodes, potentials.quadrature_error) and each move the last poll's
    mesh. The moves are kept too small to clear the contact, so the final U has a crossing.

    Truth: the start's crossing volume of the two rods (D = 10 um, perpendicular, axes 3 um
    apart, box 1e-4 m = one period) by adaptive quadrature; the bar must cover the 8-node
    value's error and be a small fraction of U (measured: bar / true 5.8, bar / U 0.43 %)."""
    spec = tmp_path / "s.toml"
    spec.write_text(RODS.replace("max_shift = 10e-6", "max_shift = 1e-6") + "u_max = 0.01\n")
    out = tmp_path / "out"
    # 3: an overlap is left (below), whatever bound the moves touch (it was at_bound, exit 0)
    assert main(["forcefield", str(spec), "-o", str(out), "--no-pictures", "--quiet"]) == 3
    printed = json.loads(capsys.readouterr().out)
    summary = json.loads((out / "summary.json").read_text())
    rve = json.loads((out / "rve.json").read_text())["forcefield"]
    assert rve["U_error"] == summary["U_error"] == printed["U_error"]
    assert printed["free_variables_error"] == summary["free_variables_error"]
    # the start: one crossing, no bend; U = w1 * V / box
    true_u = 1e10 * _two_cylinder_volume(0.5 * D / 1e-4, 3e-6 / 1e-4)  # box volume 1
    start = summary["start"]
    assert abs(start["U"] - true_u) <= start["U_error"] <= 0.01 * start["U"]
    assert abs(start["U"] - true_u) > 0.0  # 8 nodes are not exact here: the bar is tested
    # the end: a crossing is left; U and its terms carry their bar, U_error = w1 * volume's bar
    assert summary["omega_analytic_after"] > 0.0 and summary["status"] == "contact_left"
    assert summary["potentials"]["U"] == summary["U"]
    err = summary["potentials_error"]
    assert summary["U_error"] == pytest.approx(1e10 * err["volume_interaction"], rel=1e-12)
    assert 0.0 < summary["U_error"] <= 0.01 * summary["U"]
    assert err["surface"] == 0.0  # the bending area is closed form
    # the moves: +- the last poll's mesh (< 2 min_step after a converged stop) times the range
    fv = summary["free_variables_error"]
    assert 0.0 < fv["shift_m"] <= 2e-3 * 2e-6 and 0.0 < fv["u"] <= 2e-3 * 0.02
    for name, e in summary["variables_error"].items():
        want = fv["u"] if name.startswith("u[") else fv["shift_m"] / 1e-4
        assert e == pytest.approx(want, rel=1e-12), name


def test_relax_on_its_bound_with_an_overlap_left_is_contact_left(tmp_path, capsys):
    """docs/forcefield.md: a relaxation that leaves an overlap is ``contact_left``, exit 3,
    also when a move stops on its bound (session 52 walk: ``at_bound``, exit 0, with 9 contacts
    before and 9 after). Truth: two perpendicular cylinders of diameter D are disjoint iff the
    distance of their axes is >= D; two 1 um moves from 3 um leave at most 5 um < D = 10 um, so
    they still cross (Steinmetz volume > 0), and the moves sit on their 1 um bound."""
    spec = tmp_path / "s.toml"
    spec.write_text(RODS.replace("max_shift = 10e-6", "max_shift = 1e-6") + "u_max = 0.01\n")
    out = tmp_path / "out"
    assert main(["forcefield", str(spec), "-o", str(out), "--no-pictures", "--quiet"]) == 3
    (warn,) = capsys.readouterr().err.strip().splitlines()
    assert "still overlap (contact_left; the moves stop on the bound of t1[0]" in warn
    summary = json.loads((out / "summary.json").read_text())
    fibers = [b for b in (out / "relaxed.toml").read_text().split("[[fibers]]")[1:] if "shape" in b]
    z = [json.loads(b.split("center = ")[1].splitlines()[0])[2] for b in fibers]
    assert abs(z[1] - z[0]) <= 5e-6 + 1e-12  # axes at most 3 + 2 x 1 um apart: < D, they cross
    assert _two_cylinder_volume(D / 2, abs(z[1] - z[0])) > 0.0
    assert summary["omega_analytic_after"] > 0.0
    assert summary["status"] == "contact_left" and summary["converged"] is False
    assert summary["at_bound"]  # the bound it stopped on stays in the record
    rve = json.loads((out / "rve.json").read_text())["forcefield"]
    assert rve["status"] == "contact_left" and rve["at_bound"] == summary["at_bound"]


def test_relax_says_the_units_of_its_numbers(tmp_path, capsys):
    """Session 49 (new user's walk): the relax route's summary.json gave U = 0, start U =
    1.16e7 and ``potentials.area`` 1.2566 for two 6 um rods in a 30 um box, with no unit (the
    paper cases' rve.json has ``units``, PAPER_UNITS): the numbers are the search's, lengths
    in periods. ``units`` now says so, in summary.json and rve.json's ``forcefield``. Truth:
    the area the summary gives is the rods' lateral area pi D L in the box, in period^2
    (1e-4 m here: one rod crosses the box once, two rods, no bend at the start)."""
    from psdesign.forcefield.run import RELAX_UNITS

    spec = tmp_path / "s.toml"
    spec.write_text(RODS.replace("max_shift = 10e-6", "max_shift = 1e-6") + "u_max = 0.01\n")
    out = tmp_path / "out"
    # 3: the 1 um moves leave the rods crossing (contact_left, session 52; it was at_bound, 0)
    assert main(["forcefield", str(spec), "-o", str(out), "--no-pictures", "--quiet"]) == 3
    summary = json.loads((out / "summary.json").read_text())
    assert summary["units"] == RELAX_UNITS
    assert json.loads((out / "rve.json").read_text())["forcefield"]["units"] == RELAX_UNITS
    assert "periods" in RELAX_UNITS and "_m in metres" in RELAX_UNITS
    lateral = 2 * np.pi * (D / 1e-4) * 1.0  # two rods, each 1 period long in the box
    bend = summary["potentials"]["surface"]  # the bending area, also in period^2
    assert summary["potentials"]["area"] == pytest.approx(lateral + bend, rel=1e-9)
