"""A demanding user's audit of the command line (audit20): each test is a defect found on main.

Rules enforced (product brief): bad input exits 2 with one line naming the key and the allowed
range *before any work starts*; never a traceback; a file the user owns is never overwritten.
"Before any work" is checked by making the RVE build raise: a check that runs after the build
would report the build's error instead.
"""

from __future__ import annotations

import json

import pytest
from cylinder_spec import CYLINDER_SPEC as SPEC
from printed_statuses import printed_statuses

from psdesign.cli.exit_status import status_code
from psdesign.cli.main import main


@pytest.fixture()
def spec(tmp_path):
    p = tmp_path / "spec.toml"
    p.write_text(SPEC)
    return p


@pytest.fixture()
def no_build(monkeypatch):
    """Any RVE build fails loudly: the command must have refused its input before."""

    def build_rve(*a, **k):
        raise AssertionError("the RVE was built before the arguments were checked")

    monkeypatch.setattr("psdesign.packing.build.build_rve", build_rve)


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("psdesign: error: ")
    assert "Traceback" not in err
    return err


# main: `pores --n-radii 0` ran with the default 16 (`if args.n_radii:`), `--n-radii 100000000`
# passed (pores.py checks only >= 2; the schema says 4..200) and scanned for minutes, and -3 was
# refused only after the RVE was built and voxelized.
@pytest.mark.parametrize("value", ["0", "-3", "3", "201", "100000000"])
def test_pores_n_radii_out_of_range_refused_before_work(spec, capsys, no_build, value):
    assert main(["pores", str(spec), "--n-radii", value]) == 2
    err = _one_line_error(capsys)
    # the option typed and its key (audit s34: it named only transport.n_radii)
    assert "psdesign: error: --n-radii (transport.n_radii): " in err and value in err


# main: `diffusivity --tol 0` ran with the default 1e-8 (`if args.tol:`); -1 was refused only
# after the build.
@pytest.mark.parametrize("value", ["0", "-1", "1", "nan"])
def test_diffusivity_tol_out_of_range_refused_before_work(spec, capsys, no_build, value):
    assert main(["diffusivity", str(spec), "--tol", value]) == 2
    err = _one_line_error(capsys)
    assert "psdesign: error: --tol (transport.tol): " in err  # the option typed (audit s34)


def test_a_bad_tol_in_the_spec_is_named_by_its_key(tmp_path, capsys, no_build):
    """The spec's own bad value is not the option's: it keeps its key alone."""
    bad = tmp_path / "bad.toml"
    bad.write_text(SPEC.replace("[transport]\n", "[transport]\ntol = 2.0\n"))
    assert main(["diffusivity", str(bad)]) == 2
    assert _one_line_error(capsys).startswith("psdesign: error: transport.tol: ")


def test_cli_overrides_reach_the_solver(spec, capsys):
    """The override path still applies valid values (truth: the scan's radii are
    ``linspace(r_max, 1, n)`` voxels, all distinct here, so n asked -> n diameters)."""
    for n in (6, 40):  # finished: 0 or 3 by the exit rule applied to what it printed
        code = main(["pores", str(spec), "--n-radii", str(n), "--json"])
        out = json.loads(capsys.readouterr().out)
        assert code == status_code(*printed_statuses(out)), (code, printed_statuses(out))
        assert len(out["diameters_m"]) == n


# main: `pores --plot FILE` replaced a user's existing file with the PNG, and a folder or a path
# below a file at --plot gave a Python traceback (IsADirectoryError / NotADirectoryError, exit 1)
# after all the work.
def test_pores_plot_never_overwrites_a_user_file(spec, tmp_path, capsys, no_build):
    mine = tmp_path / "mine.png"
    mine.write_bytes(b"my own data")
    assert main(["pores", str(spec), "--plot", str(mine)]) == 2
    assert "--plot" in _one_line_error(capsys)
    assert mine.read_bytes() == b"my own data"


@pytest.mark.parametrize("where", ["folder", "under_file", "missing_parent"])
def test_pores_plot_bad_path_is_one_line_before_work(spec, tmp_path, capsys, no_build, where):
    (tmp_path / "afile").write_text("keep")
    (tmp_path / "adir").mkdir()
    path = {
        "folder": tmp_path / "adir",
        "under_file": tmp_path / "afile" / "p.png",
        "missing_parent": tmp_path / "nope" / "p.png",
    }[where]
    assert main(["pores", str(spec), "--plot", str(path)]) == 2
    assert "--plot" in _one_line_error(capsys)
    assert (tmp_path / "afile").read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir", "afile", "spec.toml"]
    assert list((tmp_path / "adir").iterdir()) == []


# session 40 (s40-fuzz): `pores --plot p.pdf` (or p.txt, or p) wrote PNG bytes under that
# name, exit 0: a PDF no viewer opens. The one type written is PNG: another name is refused.
@pytest.mark.parametrize("name", ["p.pdf", "p.txt", "p", "p.png.jpg"])
def test_pores_plot_other_than_png_is_refused_before_work(spec, tmp_path, capsys, no_build, name):
    assert main(["pores", str(spec), "--plot", str(tmp_path / name)]) == 2
    line = _one_line_error(capsys)
    assert line.endswith(
        f"--plot: {name}: psdesign writes a PNG picture (allowed: a new file name ending in .png)"
    ), line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.toml"]


def test_pores_plot_new_file_written_and_no_temp_left(spec, tmp_path, capsys):
    png = tmp_path / "pores.png"
    assert main(["pores", str(spec), "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pores.png", "spec.toml"]


# main: `warmup --jobs 0` ran with the default (`jobs or cpu_count`) and `--jobs -2` with one
# process, silently.
@pytest.mark.parametrize("value", ["0", "-2", "65"])
def test_warmup_jobs_out_of_range_refused_before_compiling(capsys, monkeypatch, value):
    def warmup(*a, **k):
        raise AssertionError("compiled before the arguments were checked")

    monkeypatch.setattr("psdesign.warmup.warmup", warmup)
    assert main(["warmup", "--jobs", value]) == 2
    err = _one_line_error(capsys)
    assert "--jobs" in err and "[1, 64]" in err and value in err


# main: with NUMBA_NUM_THREADS=1 the start line said "compiling ... (serial, parallel)" and the
# parallel task was then skipped without a word ("warmup done ... (serial N s)").
def test_warmup_says_when_the_parallel_kernels_are_skipped(capsys, monkeypatch):
    import numba

    asked = []

    def warmup(tasks, jobs=None):
        asked.append(tasks)
        return {t: 1.0 for t in tasks} | {"total": 1.0}

    monkeypatch.setattr("psdesign.warmup.warmup", warmup)
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", 1)
    assert main(["warmup"]) == 0
    err = capsys.readouterr().err
    assert asked == [("serial",)]
    assert "parallel kernels are not compiled" in err
    assert "(serial)" in err and "(serial, parallel)" not in err


# main: "psdesign: error: --fields: .../afile is an existing file; -o takes a folder" (the option
# the user gave is --fields).
@pytest.mark.parametrize("command", ["permeability", "diffusivity"])
def test_fields_under_a_file_names_the_option_it_came_from(spec, tmp_path, capsys, command):
    (tmp_path / "afile").write_text("keep")
    for target in (tmp_path / "afile", tmp_path / "afile" / "sub"):
        assert main([command, str(spec), "--fields", str(target), "--quiet"]) == 2
        err = _one_line_error(capsys)
        assert err.startswith("psdesign: error: --fields: ") and "--fields takes a folder" in err
        assert "-o takes" not in err
    assert (tmp_path / "afile").read_text() == "keep"


# main: the text output of `pores` printed d10/d50/d90 and S_v without the error estimates its
# JSON carries (rule: every number printed carries its error estimate). Session 32: in the
# shape of the other commands' lines (psdesign.lines): the bar after the values, then
# `[status]  converged true|false` (it printed `rel. error 1.0e-01` and no flag), the pore
# sizes with their one-sided absolute bar (the scan measures low) covering the breakthrough
# diameter too, and the porosity with its error.
def test_pores_text_prints_the_error_estimates(spec, capsys):
    assert main(["pores", str(spec), "--json"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert main(["pores", str(spec)]) == 0
    sizes, surface = capsys.readouterr().out.splitlines()
    assert f"breakthrough {js['breakthrough_diameter_m']:.3e} m, each " in sizes
    assert f"each +{js['diameter_error_m']:.1e}/-0 m  [{js['pore_sizes_status']}]  " in sizes
    assert "converged true" in sizes and js["converged"] is True
    bar = f"+- {100 * js['specific_surface_rel_error']:.1f} %"
    assert f"1/m {bar}  [{js['specific_surface_status']}]  converged true  " in surface
    assert surface.endswith(f"porosity {js['porosity']:.4f} +- {js['porosity_error']:.1e}")


# main: "spec: file not found: adir" for a folder given as the spec (the path exists).
@pytest.mark.parametrize(
    "argv",
    [
        ["generate", "{d}", "-o", "{o}"],
        ["pores", "{d}"],
        ["permeability", "{d}"],
        ["study", "run", "{d}", "-o", "{o}"],
        ["forcefield", "{d}", "-o", "{o}"],
    ],
)
def test_a_folder_given_as_the_spec_is_named_a_folder(tmp_path, capsys, argv):
    d = tmp_path / "specs"
    d.mkdir()
    o = tmp_path / "out"
    assert main([a.format(d=d, o=o) for a in argv]) == 2
    err = _one_line_error(capsys)
    assert f"{d} is a folder; give a TOML file" in err
    assert not o.exists()


# main: `generate -o /proc/x` (a folder that cannot be written, also as root) ended in a
# FileNotFoundError traceback after the work; a folder the user may not write was not checked.
def test_unwritable_output_parent_refused_before_work(spec, tmp_path, capsys, monkeypatch):
    import os

    import psdesign.io.outputs as outputs

    real = os.access
    locked = tmp_path / "locked"
    locked.mkdir()
    monkeypatch.setattr(outputs.os, "access", lambda p, m: real(p, m) and p != locked)
    out = locked / "new"
    assert main(["generate", str(spec), "-o", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert f"-o: cannot write into {locked} (permission denied)" in err
    assert not out.exists()


def test_os_error_while_writing_is_one_line(spec, tmp_path, capsys, monkeypatch):
    import psdesign.io.outputs as outputs

    def mkdtemp(*a, **k):
        raise PermissionError(13, "Permission denied", str(tmp_path / "out" / ".psdesign-x"))

    monkeypatch.setattr(outputs.tempfile, "mkdtemp", mkdtemp)
    assert main(["generate", str(spec), "-o", str(tmp_path / "out"), "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"psdesign: error: {tmp_path / 'out' / '.psdesign-x'}: Permission denied"]


# main: `-o ""` and `--fields ""` meant the current folder (Path("") is "."): in an empty
# working folder psdesign wrote its files there.
@pytest.mark.parametrize(
    "argv",
    [["generate", "{s}", "-o", "", "--quiet"], ["diffusivity", "{s}", "--fields", "", "--quiet"]],
)
def test_empty_output_name_refused(spec, tmp_path, capsys, monkeypatch, argv):
    work = tmp_path / "empty_cwd"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main([a.format(s=spec) for a in argv]) == 2
    err = _one_line_error(capsys)
    assert "empty folder name" in err
    assert list(work.iterdir()) == []


# session 34 fuzz: `study run --timeout inf` (or 1e300) was accepted and ran the cases without
# a limit, while the study file's study.timeout_s allows (0, 1e7]: one rule, two ranges.
@pytest.mark.parametrize("value", ["inf", "1e300", "2e7"])
def test_study_run_timeout_beyond_the_study_files_range_refused(spec, tmp_path, capsys, value):
    study = tmp_path / "study.toml"
    study.write_text(
        'base = "spec.toml"\n[study]\nname = "s"\noutputs = ["porosity"]\n'
        '[parameters]\n"flow.viscosity" = [1e-5]\n'
    )
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main(["study", "run", str(study), "-o", str(out), "--quiet", "--timeout", value])
    assert exc.value.code == 2
    err = _one_line_error(capsys)
    assert "--timeout" in err and "<= 10000000" in err and "study.timeout_s" in err
    assert not out.exists()


REV_SPEC = """
[rve]
size = [50e-6, 50e-6, 50e-6]
voxel = 1e-6

[generator]
porosity = 0.85
diameter = 7e-6
"""


# session 34 fuzz: `rev --sizes 30e-6 30e-6` ran the same size twice; `--sizes 2` or `1e-9`
# was refused (after seconds of case expansion) as "parameters: case c0000-... (rve.size.0=2.0,
# ...) gives a bad spec", naming a study file the user never wrote instead of --sizes.
@pytest.mark.parametrize(
    ("sizes", "text"),
    [
        (["30e-6", "30e-6"], "each edge length once"),
        (["2"], "at 2 m, rve.size[0]: must be <= 1.0"),
        (["1e-9"], "at 1e-09 m, rve.voxel"),
        (["40e-6", "1"], "at 1 m, rve.voxel"),
    ],
)
def test_rev_sizes_refused_naming_sizes_before_work(tmp_path, capsys, monkeypatch, sizes, text):
    import psdesign.study.runner as runner

    monkeypatch.setattr(runner, "run_study", lambda *a, **k: pytest.fail("the study ran"))
    spec = tmp_path / "gen.toml"
    spec.write_text(REV_SPEC)
    out = tmp_path / "out"
    assert main(["rev", str(spec), "--sizes", *sizes, "-o", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: --sizes: ") and text in err, err
    assert "parameters" not in err and not out.exists()


# session 34 fuzz: an [image] path that does not exist and has no known extension, or that is
# a folder (path = "" is the spec's own folder), was refused as "image.format: cannot tell the
# format of 'scan'": the key named was not the one that is wrong. Since session 44 a folder
# is read as TIFF slices: one without any is refused so.
@pytest.mark.parametrize(
    ("path", "text"),
    [
        ("scan", "file not found"),
        ("", "no .tif / .tiff file in the folder"),
        ("sub", "in the folder"),
    ],
)
def test_image_path_missing_or_a_folder_names_image_path(tmp_path, capsys, no_build, path, text):
    (tmp_path / "sub").mkdir()
    spec = tmp_path / "img.toml"
    spec.write_text(f'[image]\npath = "{path}"\nvoxel_size = 1e-6\n')
    out = tmp_path / "out"
    assert main(["generate", str(spec), "-o", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: image.path: ") and text in err, err
    assert not out.exists()


# session 34 fuzz: generator.orientation = {anisotropy = 1e300} passed the schema (beta > 0);
# beta^2 overflowed, the sampled directions were NaN and the build ended, after the work had
# started, in "R must be a 3x3 orthogonal matrix" (no key named).
@pytest.mark.parametrize("beta", ["1e300", "2e6"])
def test_orientation_anisotropy_beyond_its_range_refused_before_work(
    tmp_path, capsys, no_build, beta
):
    spec = tmp_path / "gen.toml"
    spec.write_text(REV_SPEC + f"orientation = {{anisotropy = {beta}}}\n")
    out = tmp_path / "out"
    assert main(["generate", str(spec), "-o", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: generator.orientation.anisotropy: must be <= ")
    assert "(0, 1e6]" in err and not out.exists()


# session 34 fuzz: diffusivity / conductivity / pores read the spec with a reader of their own:
# an unreadable spec was "psdesign: error: .../spec.toml: Permission denied" with exit 1 (the
# other commands: exit 2 naming `spec`), and the 10 MiB size limit was not applied before reading.
@pytest.mark.parametrize("command", ["diffusivity", "conductivity", "pores"])
def test_unreadable_spec_is_bad_input_for_the_transport_commands(
    spec, capsys, monkeypatch, no_build, command
):
    import pathlib

    real_bytes, real_text = pathlib.Path.read_bytes, pathlib.Path.read_text

    def denied(self):
        if self.name == "spec.toml":
            raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(pathlib.Path, "read_bytes", lambda p: denied(p) or real_bytes(p))
    monkeypatch.setattr(pathlib.Path, "read_text", lambda p, *a, **k: denied(p) or real_text(p))
    assert main([command, str(spec), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert err == f"psdesign: error: spec: cannot read {spec}: Permission denied"


STUDY_HEAD = 'base = "spec.toml"\n[study]\nname = "s"\noutputs = ["porosity"]\n[parameters]\n'


# session 34 fuzz: a parameter given twice, once quoted and once dotted (TOML keeps both), ran
# the second one and dropped the first without a word; a level given twice ran the same case
# (same spec, same seeds) twice.
@pytest.mark.parametrize(
    ("params", "text"),
    [
        ('"flow.viscosity" = [1e-5]\nflow.viscosity = [2e-5, 3e-5]\n', "given twice (a quoted"),
        ('"flow.viscosity" = [1e-5, 2e-5, 1e-5]\n', "level 1e-05 given twice"),
    ],
)
def test_study_parameter_or_level_given_twice_refused(spec, tmp_path, capsys, params, text):
    study = tmp_path / "study.toml"
    study.write_text(STUDY_HEAD + params)
    out = tmp_path / "out"
    assert main(["study", "run", str(study), "-o", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: parameters.flow.viscosity: ") and text in err, err
    assert not out.exists()


# session 34 fuzz: "rve.voxel" = [5e-7, 1e-6] listed before "rve" = [{size = ..., voxel = 1e-6}]
# ran two identical cases (same hash) labelled rve.voxel 5e-7 and 1e-6: the cases set the
# parameters in file order, so each rve level replaced the voxel. After it, it is an override.
def test_study_parameter_listed_before_the_table_holding_it_refused(spec, tmp_path, capsys):
    rve = '"rve" = [{size = [20e-6, 20e-6, 20e-6], voxel = 1e-6}]\n'
    study = tmp_path / "study.toml"
    study.write_text(STUDY_HEAD + '"rve.voxel" = [5e-7, 1e-6]\n' + rve)
    out = tmp_path / "out"
    assert main(["study", "run", str(study), "-o", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: parameters.rve.voxel: lies inside 'rve', which ")
    assert not out.exists()
    from psdesign.study import expand_design, load_study

    study.write_text(STUDY_HEAD + rve + '"rve.voxel" = [5e-7, 1e-6]\n')  # after it: applied
    voxels = [c.spec["rve"]["voxel"] for c in expand_design(load_study(study))]
    assert voxels == [5e-7, 1e-6]


# session 34 fuzz: `study optimize --target k_z_m2=1e-12 --target k_z_m2=2e-12` (or >= 2e-12 with
# <= 1e-12) was accepted and spent the whole budget on targets no value meets together.
@pytest.mark.parametrize(
    "targets", [["k_z_m2=1e-12", "k_z_m2=2e-12"], ["k_z_m2>=2e-12", "k_z_m2<=1e-12"]]
)
def test_optimize_targets_that_exclude_each_other_refused(
    spec, tmp_path, capsys, monkeypatch, targets
):
    import psdesign.study.runner as runner

    monkeypatch.setattr(runner, "run_study", lambda *a, **k: pytest.fail("a case ran"))
    study = tmp_path / "opt.toml"
    study.write_text(
        'base = "spec.toml"\n[study]\nname = "o"\noutputs = ["porosity", "k_z"]\n'
        'design = "latin-hypercube"\nn_samples = 2\n[parameters]\n'
        '"flow.viscosity" = {low = 1e-5, high = 2e-5}\n'
    )
    out = tmp_path / "out"
    argv = ["study", "optimize", str(study), "-o", str(out), "--quiet"]
    assert main([*argv, *(a for t in targets for a in ("--target", t))]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: --target: ") and "can never both be met" in err
    assert not out.exists()


# session 34 fuzz: `study run --cluster-cores 4` (any --cluster-* without --cluster) and the
# three --tls-* files without a tls:// scheduler were ignored without a word: the cases ran on
# this machine, unencrypted or not, as if the options had not been given.
@pytest.mark.parametrize(
    ("extra", "flag"),
    [
        (["--cluster-cores", "4"], "--cluster-cores"),
        (["--cluster-memory", "16GB"], "--cluster-memory"),
        (["--cluster-walltime", "02:00:00"], "--cluster-walltime"),
        (["--cluster-queue", "gpu"], "--cluster-queue"),
        (["--cluster-account", "p1"], "--cluster-account"),
        (["--cluster-wait", "60"], "--cluster-wait"),
        (["--tls-ca-file", "{ca}", "--tls-cert", "{ca}", "--tls-key", "{ca}"], "--tls-ca-file"),
        (
            ["--scheduler", "tcp://127.0.0.1:8786", "--tls-ca-file", "{ca}", "--tls-cert", "{ca}"]
            + ["--tls-key", "{ca}"],
            "--tls-ca-file",
        ),
    ],
)
def test_study_run_options_that_would_be_ignored_refused(
    spec, tmp_path, capsys, monkeypatch, extra, flag
):
    import psdesign.study.runner as runner

    monkeypatch.setattr(runner, "run_study", lambda *a, **k: pytest.fail("the study ran"))
    (tmp_path / "ca.pem").write_text("x")
    study = tmp_path / "study.toml"
    study.write_text(STUDY_HEAD + '"flow.viscosity" = [1e-5]\n')
    out = tmp_path / "out"
    extra = [a.format(ca=tmp_path / "ca.pem") for a in extra]
    assert main(["study", "run", str(study), "-o", str(out), "--quiet", *extra]) == 2
    err = _one_line_error(capsys)
    assert err.startswith(f"psdesign: error: {flag}: only with "), err
    assert not out.exists()


# session 34 fuzz: the two-fiber case took f0 = 1e300 (overflow warnings, rve.json with
# f = 1e300) and any u_range: the bend rules of every fiber (f <= 1000 bends per period,
# |u| f <= 10, psdesign.schema.fibers) did not hold for the force field's fibers.
@pytest.mark.parametrize(
    ("line", "key", "text"),
    [
        ("f0 = 1e300", "f0", "must be <= 1000"),
        ("f0 = 999.5", "f_range", "f0 + f_range = 1000.5"),
        ("u_range = 1e300", "u_range", "must be <= 10"),
        ("f0 = 4.0\nu_range = 3.0", "u_range", "u_range x (f0 + f_range) = 15"),
    ],
)
def test_two_fiber_bends_beyond_the_fiber_rules_refused(
    tmp_path, capsys, monkeypatch, line, key, text
):
    import psdesign.forcefield.run as run

    monkeypatch.setattr(run, "run_forcefield", lambda *a, **k: pytest.fail("the search ran"))
    spec = tmp_path / "ff.toml"
    spec.write_text(f'[forcefield]\ncase = "two-fiber"\n[forcefield.two_fiber]\n{line}\n')
    out = tmp_path / "out"
    assert main(["forcefield", str(spec), "-o", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert err.startswith(f"psdesign: error: forcefield.two_fiber.{key}: ") and text in err, err
    assert not out.exists()


# session 34 fuzz: `study run --scheduler ""` (an empty shell variable) ran the cases on the
# local process pool, as if no scheduler had been given.
@pytest.mark.parametrize("command", ["run", "optimize"])
def test_empty_scheduler_address_refused(spec, tmp_path, capsys, monkeypatch, command):
    import psdesign.study.runner as runner

    monkeypatch.setattr(runner, "_claim", lambda *a, **k: pytest.fail("the folder was claimed"))
    study = tmp_path / "study.toml"
    study.write_text(
        'base = "spec.toml"\n[study]\nname = "s"\noutputs = ["porosity", "k_z"]\n'
        'design = "latin-hypercube"\nn_samples = 2\n[parameters]\n'
        '"flow.viscosity" = {low = 1e-5, high = 2e-5}\n'
    )
    out = tmp_path / "out"
    extra = ["--target", "k_z_m2>=1e-12"] if command == "optimize" else []
    argv = ["study", command, str(study), "-o", str(out), "--quiet", "--scheduler", "", *extra]
    assert main(argv) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: --scheduler: empty ('')"), err
    assert not out.exists()


BIG_FEM = """
[rve]
size = [1e-3, 1e-3, 1e-3]
voxel = 2e-6

[[fibers]]
shape = "cylinder"
diameter = 1e-4
direction = [0, 0, 1]

[flow]
solver = "fem"
bc = "periodic"
"""


# session 34 fuzz: the spec was checked against the budget of its own flow.solver only, so
# `permeability --solver voxel` on a spec written for the FEM (a 500^3 grid: 1.25e8 cells of
# 132 B, 15.4 GiB, over half a 24 GiB machine) passed and started building the RVE; the same
# spec with flow.solver = "voxel" was refused up front.
def test_permeability_solver_override_checked_against_its_budget(
    tmp_path, capsys, monkeypatch, no_build
):
    import psdesign.schema.budget as budget

    monkeypatch.setattr(budget, "machine_memory", lambda: 24 * 2**30)
    spec = tmp_path / "big.toml"
    spec.write_text(BIG_FEM)
    assert main(["permeability", str(spec), "--solver", "voxel", "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: rve.voxel: a 500x500x500 grid ") and "'voxel'" in err


# session 34 fuzz: rev's cases run with --solver (default voxel) but its sizes were validated
# with the spec's flow.solver: on a FEM spec a 500 um cube at 1 um (15.4 GiB of voxel solve on
# a 24 GiB machine) passed and the study started.
def test_rev_sizes_checked_against_the_budget_of_the_solver_the_cases_run(
    tmp_path, capsys, monkeypatch
):
    import psdesign.schema.budget as budget
    import psdesign.study.runner as runner

    monkeypatch.setattr(budget, "machine_memory", lambda: 24 * 2**30)
    monkeypatch.setattr(runner, "run_study", lambda *a, **k: pytest.fail("the study ran"))
    spec = tmp_path / "gen.toml"
    spec.write_text(
        "[rve]\nsize = [5e-4, 5e-4, 5e-4]\nvoxel = 1e-6\n[generator]\nporosity = 0.9\n"
        'diameter = 2e-5\n[flow]\nsolver = "fem"\nbc = "periodic"\nlattice_step = 2e-5\n'
    )
    out = tmp_path / "out"
    assert main(["rev", str(spec), "--sizes", "4e-4", "5e-4", "-o", str(out), "--quiet"]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: --sizes: at 0.0005 m, rve.voxel: a 500x500x500 grid")
    assert "solver 'voxel'" in err and not out.exists()


@pytest.mark.parametrize(
    "args,where",
    [
        (["--insulating", "solid", "--solid", "1"], "--solid: --insulating solid makes the solid"),
        (["--insulating", "fluid", "--fluid", "2"], "--fluid: --insulating fluid makes the fluid"),
    ],
)
def test_conductivity_refuses_a_value_for_the_insulating_phase(spec, capsys, no_build, args, where):
    """Audit (session 34): ``conductivity --insulating solid --solid 1`` ignored the 1 (the
    help: --insulating makes that phase a perfect insulator, conductivity 0) and printed sigma
    of an insulating solid. One line naming both options, before the build."""
    assert main(["conductivity", str(spec), *args]) == 2
    err = _one_line_error(capsys)
    assert where in err and "--insulating none" in err


def test_conductivity_refuses_a_value_for_the_spec_s_insulating_phase(tmp_path, capsys, no_build):
    bad = tmp_path / "ins.toml"
    bad.write_text(SPEC.replace("[transport]\n", '[transport]\ninsulating_phase = "solid"\n'))
    assert main(["conductivity", str(bad), "--solid", "1"]) == 2
    assert 'transport.insulating_phase = "solid"' in _one_line_error(capsys)


def _optimize_study(tmp_path):
    p = tmp_path / "opt.toml"
    p.write_text(
        f'[study]\nbase = "{tmp_path / "spec.toml"}"\ndesign = "latin-hypercube"\n'
        'n_samples = 4\nseeds = [1]\noutputs = ["k_z"]\n\n[parameters]\n'
        '"generator.porosity" = {low = 0.7, high = 0.9}\n'
    )
    return p


@pytest.mark.parametrize(
    "cmd,value",
    [("rev", "-1"), ("rev", "100000"), ("optimize", "-1"), ("optimize", "100000")]
    + [("run", "-1"), ("run", "100000")],
)
def test_workers_errors_name_the_option(spec, tmp_path, capsys, no_build, cmd, value):
    """Audit (session 34): ``rev --workers -1`` and ``study optimize --workers -1`` (and
    100000, above the local cap max_local_workers()) said "workers: ..." where the user typed
    --workers. The same values are refused (the runner's rule), now naming --workers, before
    any work (no output folder)."""
    out = tmp_path / "out"
    argv = {
        "rev": ["rev", str(spec), "--sizes", "2e-5", "-o", str(out)],
        "optimize": ["study", "optimize", str(_optimize_study(tmp_path)), "-o", str(out)],
        "run": ["study", "run", str(_optimize_study(tmp_path)), "-o", str(out)],
    }[cmd]
    if cmd == "optimize":
        argv += ["--target", "k_z_m2=5e-12"]
    assert main([*argv, "--quiet", "--workers", value]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("psdesign: error: --workers: "), err
    assert value in err
    assert not out.exists()


class _Reached(Exception):
    """Raised by a stand-in for the study: the command accepted its --workers."""


@pytest.mark.parametrize("cmd", ["run", "optimize", "rev"])
def test_workers_0_is_one_rule_in_this_process(tmp_path, capsys, monkeypatch, cmd):
    """Session 34 notes: ``study run --workers 0`` was refused ("argument --workers: expected
    an integer >= 1"), while ``rev`` and ``study optimize`` accepted it and ran the cases in
    this process (the runner's ``workers == 0``: no pool). One rule now (docs/study-files.md
    "Running"): 0 runs the cases in this process in all three; beside a scheduler it means
    nothing (a local Dask cluster of 0 workers started 1) and is refused in one line naming
    --workers and the range, before any work (no output folder, no dask started)."""
    from study_cases import write_study

    p = write_study(
        tmp_path,
        'design = "latin-hypercube"\nn_samples = 4\nseeds = [1]\noutputs = ["k_z"]',
        '"generator.porosity" = {low = 0.7, high = 0.9}',
    )
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    seen = {}

    def stand_in(*a, workers, **kw):
        seen["workers"] = workers
        raise _Reached

    monkeypatch.setattr("psdesign.analysis.rev.rev_study", stand_in)
    monkeypatch.setattr("psdesign.analysis.optimize.optimize_study", stand_in)

    def argv(out, *extra):
        return {
            "rev": ["rev", str(spec), "--sizes", "2e-5"],
            "optimize": ["study", "optimize", str(p), "--target", "k_z_m2=5e-12"],
            "run": ["study", "run", str(p), "--no-report"],
        }[cmd] + ["-o", str(out), "--quiet", "--workers", "0", *extra]

    out = tmp_path / "out"
    if cmd == "run":  # a real run on the fake solver: every case done here, none in a pool
        assert main(argv(out, "--case-fn", "study_cases:fake_case")) == 0, capsys.readouterr()
        last = json.loads((out / "run.json").read_text())["runs"][-1]
        assert last["workers"] == 0 and last["status_counts"] == {"ok": 4}, last
    else:
        with pytest.raises(_Reached):
            main(argv(out))
        assert seen["workers"] == 0
    schedulers = {"rev": [], "optimize": [["--scheduler", "local"]]}.get(
        cmd, [["--scheduler", "local"], ["--cluster", "slurm"]]
    )
    for extra in schedulers:
        assert main(argv(tmp_path / "sched", *extra)) == 2
        err = _one_line_error(capsys)
        assert err.startswith("psdesign: error: --workers: 0 runs the cases in this process"), err
        assert "give 1 or more" in err
        assert not (tmp_path / "sched").exists()
