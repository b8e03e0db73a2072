"""The Python API (psdesign.build, Material, PermeabilityResult, run_study's main-guard check)."""

from __future__ import annotations

import functools
import math
import os
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import psdesign
from psdesign.api import PermeabilityResult, _unguarded_call_in_main_script
from psdesign.study.case import run_case as _pipeline_case


def test_import_is_light() -> None:
    # a fresh interpreter: `import psdesign` pulls in none of the heavy stacks (issue 16 item 6)
    code = (
        "import sys, psdesign; heavy = [m for m in ('numba', 'scipy', 'pyvista', 'matplotlib',"
        " 'pandas', 'dask') if m in sys.modules]; print(heavy)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_cli_help_is_light() -> None:
    # `psdesign --help` (the console script's entry point) imports none of the heavy stacks;
    # pandas too: a top-level import of analysis.columns in cli/study.py cost every CLI start
    # +500 modules and 2-4 s (session 54)
    code = (
        "import sys\nfrom psdesign.cli import main\ntry:\n    main(['--help'])\n"
        "except SystemExit:\n    pass\nheavy = [m for m in ('numba', 'scipy.stats', 'pyvista',"
        " 'matplotlib', 'numpy', 'pandas', 'dask') if m in sys.modules]\n"
        "print(heavy, file=sys.stderr)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "usage" in out.stdout
    assert out.stderr.strip().splitlines()[-1] == "[]"


def test_build_porosity_matches_the_exact_cylinder_area() -> None:
    # one z-aligned circular cylinder of diameter 8 um in a 20 um box: porosity 1 - pi r^2 / A
    spec = {
        "rve": {"size": [20e-6, 20e-6, 20e-6], "voxel": 0.25e-6},
        "fibers": [{"shape": "cylinder", "diameter": 8e-6, "direction": [0, 0, 1]}],
    }
    m = psdesign.build(spec)
    exact = 1.0 - math.pi * 4e-6**2 / 20e-6**2
    assert m.porosity == pytest.approx(exact, abs=2e-3)
    # its error estimate covers the count's true error (psdesign.geometry.porosity)
    assert abs(m.porosity - exact) <= m.porosity_error < 2e-3
    assert repr(m) == "Material(2e-05 x 2e-05 x 2e-05 m, 1 fibers)"  # SI, as every output
    page = m._repr_html_()  # the notebook's table: the porosity with its bar and rating
    assert "80 x 80 x 80" in psdesign.build(spec)._repr_html_()  # a display: no voxelization
    # "&plusmn;" as every other row (review s52: the porosity row alone wrote "+-")
    assert f"{m.porosity:.4f} &plusmn; {m.porosity_error:.1e}" in page and ">ok</span>" in page
    assert "80 x 80 x 80 of 2.5e-07 m" in page


def test_build_rejects_a_bad_spec_naming_the_key() -> None:
    with pytest.raises(psdesign.SpecError, match=r"rve\.size"):
        psdesign.build({"rve": {"size": [1, 2]}, "fibers": []})


def test_permeability_result_repr_and_html() -> None:
    d = {
        "direction": "z",
        "permeability_m2": 1.25e-12,
        "converged": False,
        "solver": "voxel",
        "bc": "periodic",
        "porosity": 0.8,
        "porosity_error": 4.2e-4,
        "iterations": 3,
    }
    r = PermeabilityResult.from_dict(d)
    assert r.status == "not_converged" and r.details["iterations"] == 3
    assert "1.25e-12" in repr(r) and "details" not in repr(r)
    assert "1.2500e-12" in r._repr_html_() and "0.8000 &plusmn; 4.2e-04" in r._repr_html_()
    # to_dict, as the transport results have (session 31 audit: PermeabilityResult had none)
    back = r.to_dict()
    assert back["iterations"] == 3 and back["status"] == "not_converged"
    assert PermeabilityResult.from_dict(back) == r


@pytest.mark.parametrize(
    ("body", "unguarded"),
    [
        ("import psdesign\npsdesign.run_study('s.toml', 'out', workers=2)\n", True),
        ("from psdesign import run_study\ndf = run_study('s.toml', 'out')\n", True),
        ("import psdesign\nif __name__ == '__main__':\n    psdesign.run_study('s', 'o')\n", False),
        ("import psdesign\ndef main():\n    psdesign.run_study('s', 'o')\n", False),
    ],
)
def test_main_guard_detection(tmp_path, monkeypatch, body, unguarded) -> None:
    script = tmp_path / "script.py"
    script.write_text(textwrap.dedent(body))
    fake_main = type(sys)("__main__")
    fake_main.__file__ = str(script)
    monkeypatch.setitem(sys.modules, "__main__", fake_main)
    assert _unguarded_call_in_main_script("run_study") is unguarded


def test_unguarded_script_fails_with_one_line(tmp_path) -> None:
    script = tmp_path / "script.py"
    script.write_text("import psdesign\npsdesign.run_study('nope.toml', 'out', workers=2)\n")
    proc = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path
    )
    assert proc.returncode != 0
    assert 'if __name__ == "__main__":' in proc.stderr
    assert not (tmp_path / "out").exists()


def test_a_script_read_from_stdin_is_refused_worker_processes(tmp_path) -> None:
    """Session 50 (walk): ``python - < script.py`` (a heredoc) calling ``run_study(...,
    workers=1)``: spawned workers re-import the main script by its path, ``<stdin>``, which is
    no file, so every case died as "worker process died while running this case (crash or out
    of memory)" and the run exited 0 with a results.csv of failed cases. Now one line naming
    ``workers`` before any folder is made; ``workers=0`` runs the cases in the process."""
    from study_cases import FACTORIAL, write_study

    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    tests = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    root = os.path.dirname(tests)  # this tree's psdesign, not an installed one

    # one interpreter for the three runs (each start-up imports psdesign: ~1.5 s of CPU); the
    # refusal that ends it uncaught comes last, so its traceback's last line is stderr's
    def run(out: str, kw: str) -> str:
        return (
            f"psdesign.run_study({str(p)!r}, {str(tmp_path / out)!r}, "
            f"case_fn='study_cases:fake_case', progress=False, {kw})"
        )

    local = "workers=1, scheduler='local'"
    script = (
        f"import sys; sys.path[:0] = [{root!r}, {tests!r}]\n"
        "import psdesign\n"
        # a local Dask cluster spawns its workers the same way (a 60-line nanny traceback
        # before: session 50's review)
        "try:\n"
        f"    {run('o', local)}\n"
        "except Exception as e:\n"
        "    print('local:', type(e).__name__ + ':', e)\n"
        f"df = {run('o0', 'workers=0')}\n"
        "print(sorted(df['status']))\n"
        f"{run('o', 'workers=1')}\n"
    )
    proc = subprocess.run(
        [sys.executable, "-"], input=script, capture_output=True, text=True, cwd=tmp_path
    )
    assert proc.returncode != 0, proc.stdout
    last = proc.stderr.strip().splitlines()[-1]
    assert "StudyError: workers: worker processes re-import the main script" in last, last
    assert "(allowed: workers=0 without a scheduler, or the script run from a file)" in last
    dask = [ln for ln in proc.stdout.splitlines() if ln.startswith("local: ")]
    assert len(dask) == 1 and "StudyError: workers: worker processes" in dask[0], proc.stdout
    assert not (tmp_path / "o").exists()
    # workers=0 runs the cases in the process
    assert "['ok', 'ok', 'ok', 'ok']" in proc.stdout, proc.stderr


def test_permeability_result_html_marks_a_status_that_is_not_ok() -> None:
    d = {"direction": "x", "permeability_m2": 3e-12, "converged": True, "status": "untrustworthy"}
    d |= {"permeability_rel_error": 0.3, "warnings": ["error bar 30 % above the 20 % limit"]}
    page = PermeabilityResult.from_dict(d)._repr_html_()
    assert "background:#c00" in page and ">untrustworthy</span>" in page
    assert "&plusmn; 30 %" in page and "error bar 30 % above the 20 % limit" in page
    ok = PermeabilityResult.from_dict({**d, "status": "ok", "warnings": []})._repr_html_()
    assert "background:#c00" not in ok and ">ok</span>" in ok


def test_an_unrated_material_is_not_shown_as_an_alarm() -> None:
    """Session 54 (walk-api 7): a Material not yet voxelized showed its status "unrated" in
    the red of an untrustworthy result, so the red lost its weight. It is grey now; once
    voxelized, the porosity's own status decides (ok: green, no red)."""
    m = psdesign.build(
        {
            "rve": {"size": [20e-6] * 3, "voxel": 2e-6},
            "fibers": [{"shape": "cylinder", "diameter": 8e-6, "direction": [0, 0, 1]}],
        }
    )
    page = m._repr_html_()
    assert ">unrated</span>" in page and "background:#c00" not in page, page
    assert "color:#555" in page  # the neutral badge
    m.porosity  # noqa: B018  (voxelizes)
    page = m._repr_html_()
    assert ">ok</span>" in page and "background:#c00" not in page, page


def _transport_fields() -> dict:
    return {
        "direction": "z",
        "bc": "periodic",
        "porosity": 0.8,
        "converged": False,
        "residual": 1e-3,
        "iterations": 500,
        "flux_imbalance": 1e-3,
        "rel_error": 0.05,
        "error_method": "two-grid",
        "blocked": False,
        "message": "maximum iterations reached",
        "n_cells": 8000,
        "wall_time_s": 0.1,
    }


def _diffusivity_result(column: list[float]):
    """A not-converged diffusivity result of D_eff/D 0.61 +- 5 % (the values are the test's)."""
    from psdesign.transport.diffusivity import DiffusivityResult

    return DiffusivityResult(
        relative_diffusivity=0.61,
        tortuosity_factor=1.31,
        relative_diffusivity_column=column,
        bulk_diffusivity_m2_s=2e-5,
        effective_diffusivity_m2_s=1.22e-5,
        **_transport_fields(),
        porosity_error=3.1e-4,
    )


def _conductivity_result(column: list[float]):
    """A converged conductivity result of 12 W/(m K) +- 5 %."""
    from psdesign.transport.conductivity import ConductivityResult

    return ConductivityResult(
        effective_conductivity=12.0,
        conductivity_column=column,
        solid_conductivity=100.0,
        fluid_conductivity=0.03,
        insulating_phase="none",
        solid_fraction=0.2,
        wiener_bounds=[0.04, 20.0],
        hashin_shtrikman_bounds=[5.0, 14.0],
        **{**_transport_fields(), "converged": True, "message": "converged"},
        porosity_error=3.1e-4,
    )


def test_transport_results_have_short_repr_and_html_with_units() -> None:
    column = [0.5] * 200  # one value per slice: kept out of the repr
    dr = _diffusivity_result(column)
    assert len(repr(dr)) < 700 and "0.5, 0.5" not in repr(dr)
    # the plain repr carries the rating too (session 31: it showed rel_error, not status)
    assert repr(dr).endswith("status='not_converged')")
    assert dr.to_dict()["relative_diffusivity_column"] == column
    page = dr._repr_html_()
    assert dr.status == "not_converged" and ">not_converged</span>" in page
    assert "m<sup>2</sup>/s" in page and "1.2200e-05" in page and "&plusmn; 5 %" in page
    assert (
        "0.8000 &plusmn; 3.1e-04" in page
    )  # the porosity with its error (psdesign.geometry.porosity)
    cr = _conductivity_result(column)
    assert len(repr(cr)) < 700 and "0.5, 0.5" not in repr(cr)
    assert repr(cr).endswith("status='ok')")
    page = cr._repr_html_()
    assert cr.status == "ok" and ">ok</span>" in page and "[5, 14]" in page


def test_transport_reprs_show_the_value_with_its_unit_bar_convergence_and_status() -> None:
    """Session 43 (s43-polish item 5): the transport results' reprs listed every field (22
    for the diffusivity: bounds, residual, timings, ...); the repr now shows what the
    permeability result's does (direction, the value with its unit, the bar, convergence, bc,
    status) and ``str`` the command's line; every field stays (``to_dict``)."""
    from dataclasses import fields

    dr = _diffusivity_result([0.61])
    assert repr(dr) == (
        "DiffusivityResult(direction='z', relative_diffusivity=0.61, "
        "effective_diffusivity_m2_s=1.22e-05, tortuosity_factor=1.31, rel_error=0.05, "
        "converged=False, bc='periodic', status='not_converged')"
    )
    assert str(dr).startswith("D_eff/D_z = 0.6100 +- 5.0 %  [not_converged]  bc periodic")
    assert len(fields(dr)) >= 22 and dr.to_dict()["n_cells"] == 8000
    cr = _conductivity_result([12.0])
    assert repr(cr) == (
        "ConductivityResult(direction='z', effective_conductivity=12.0, "
        "conductivity_unit='W/(m K)', rel_error=0.05, converged=True, bc='periodic', "
        "status='ok')"
    )
    assert str(cr) == (
        "sigma_eff_z = 12 W/(m K) +- 5.0 %  [ok]  bc periodic  converged true  (solid 100, "
        "fluid 0.03 W/(m K))"
    )


def _one_cylinder() -> dict:
    # 20 um cube, 1 um voxels, one z-cylinder of 8 um: builds in well under a second
    return {
        "rve": {"size": [20e-6, 20e-6, 20e-6], "voxel": 1e-6},
        "fibers": [{"shape": "cylinder", "diameter": 8e-6, "direction": [0, 0, 1]}],
        "flow": {"solver": "voxel"},
    }


@pytest.mark.parametrize(
    ("call", "key", "text"),
    [
        (lambda m: m.permeability("z", viscosty=1e-5), "flow.viscosty", "did you mean 'viscosity'"),
        (lambda m: m.permeability("z", viscosity=-1.0), "flow.viscosity", "(allowed: Pa s in (0"),
        (lambda m: m.permeability("z", viscosity=math.nan), "flow.viscosity", "finite"),
        (lambda m: m.permeability("z", solver="lbm"), "flow.solver", "fem, voxel"),
        (lambda m: m.permeability("z", bc="foo"), "flow.bc", "permeameter, periodic"),
        (lambda m: m.permeability("w"), "direction", "'x', 'y' or 'z'"),
        (lambda m: m.diffusivity("q"), "direction", "'x', 'y' or 'z'"),
        (lambda m: m.conductivity("xy", solid=1.0, fluid=0.1), "direction", "'x', 'y' or 'z'"),
    ],
)
def test_method_keywords_are_checked_like_the_spec_file(monkeypatch, call, key, text) -> None:
    # common.md: bad input is one error naming the key and the allowed range; a Python call
    # gets the product's SpecError, as the spec file and the CLI do. On main a misspelled
    # [flow] keyword was silently dropped (the solve ran with the spec's viscosity), a negative
    # viscosity failed deep in the voxel solver and a bad direction was a bare ValueError.
    import psdesign.flow.permeability as perm
    import psdesign.transport.conductivity as cond
    import psdesign.transport.diffusivity as diff

    def solved(*args, **kwargs):
        raise AssertionError("the call reached the solver")

    monkeypatch.setattr(perm, "permeability", solved)
    monkeypatch.setattr(diff, "relative_diffusivity", solved)
    monkeypatch.setattr(cond, "effective_conductivity", solved)
    m = psdesign.build(_one_cylinder())
    with pytest.raises(psdesign.SpecError) as info:
        call(m)
    assert info.value.key == key and text in info.value.message


def test_method_keywords_reach_the_solver_validated(monkeypatch) -> None:
    import psdesign.flow.permeability as perm

    seen = {}

    def fake(rve, fields, direction, table, route, progress=None, capture=None):
        seen.update(table=table, route=route, direction=direction)
        return {"direction": direction, "permeability_m2": 1e-12, "converged": True}

    monkeypatch.setattr(perm, "permeability", fake)
    m = psdesign.build(_one_cylinder())
    r = m.permeability(2, bc="permeameter", viscosity=1e-3)  # an axis index is accepted
    assert seen["direction"] == "z" and r.direction == "z" and seen["route"] == "voxel"
    assert seen["table"]["viscosity"] == 1e-3 and seen["table"]["bc"] == "permeameter"
    m.permeability("x", solver="fem")
    assert seen["route"] == "fem" and seen["table"]["solver"] == "fem"


def test_numpy_numbers_in_a_spec_dict_are_numbers() -> None:
    # a notebook computes spec values with NumPy (np.float32, np.int64 from np.arange):
    # they are numbers, validated like Python's, and the validated spec is plain JSON data
    import json

    import numpy as np

    plain = {
        "rve": {"size": [30e-6, 30e-6, 30e-6], "voxel": 1e-6},
        "generator": {"kind": "straight", "n_fibers": 3, "diameter": 6e-6, "seed": 1},
    }
    numpy_spec = {
        "rve": {"size": np.full(3, 30e-6), "voxel": np.float32(1e-6)},
        "generator": {
            "kind": "straight",
            "n_fibers": np.int64(3),
            "diameter": np.float64(6e-6),
            "seed": np.arange(2)[1],
        },
    }
    a, b = psdesign.build(plain), psdesign.build(numpy_spec)
    json.dumps(b.spec)  # raised TypeError (np.int64) before
    assert b.spec["rve"]["voxel"] == pytest.approx(1e-6, rel=1e-7)  # float32's own rounding
    assert b.porosity == pytest.approx(a.porosity, rel=1e-12)
    with pytest.raises(psdesign.SpecError, match=r"rve\.voxel: must be a number"):
        psdesign.build({**plain, "rve": {"size": [30e-6] * 3, "voxel": np.bool_(True)}})


def test_run_study_bad_workers_is_the_runner_message(tmp_path, monkeypatch) -> None:
    # from a script's top level, workers=-1 was answered with the main-guard message (which
    # told the user to pass workers=0); it is the runner's one line naming `workers`
    import psdesign.api as api
    from psdesign.study import StudyError

    monkeypatch.setattr(api, "_unguarded_call_in_main_script", lambda name: True)
    for bad in (-1, "2", 1.5):
        with pytest.raises(StudyError, match=r"workers: must be an integer >= 0"):
            psdesign.run_study("studies/quickstart.toml", tmp_path / "o", workers=bad)
    assert not (tmp_path / "o").exists()


def test_run_study_unknown_keyword_is_the_runner_message(tmp_path, monkeypatch) -> None:
    # review s48: run_study("x.toml", out, wrkers=2) at a script's top level was told to put
    # the call under the main guard (the default workers=1 beside the misspelled one); it is
    # the one line every study entry point gives an unknown keyword (check_run_keywords)
    import psdesign.api as api
    from psdesign.study import StudyError

    monkeypatch.setattr(api, "_unguarded_call_in_main_script", lambda name: True)
    with pytest.raises(StudyError) as info:
        psdesign.run_study("x.toml", tmp_path / "o", wrkers=2)
    line = str(info.value)
    assert line.startswith("wrkers: not a keyword of run_study (allowed: case_fn, command,")
    assert info.value.key == "wrkers" and "workers" in line and "__main__" not in line
    assert not (tmp_path / "o").exists()


def test_run_study_bad_options_is_the_runner_message(tmp_path, monkeypatch) -> None:
    # session 46 walk of the API: run_study(study, out, 3) from a script's top level was told
    # to put the call under the main guard (the default workers=1 of an options it could not
    # read); it is the runner's one line naming `options`, as workers=-1's names `workers`
    import psdesign.api as api
    from psdesign.study import StudyError

    monkeypatch.setattr(api, "_unguarded_call_in_main_script", lambda name: True)
    for bad in (3, {"workers": 0}):
        with pytest.raises(StudyError, match=r"^options: must be a psdesign.study.RunOptions"):
            psdesign.run_study(_tiny_study(), tmp_path / "o", bad)
    assert not (tmp_path / "o").exists()


def test_a_case_function_of_other_arguments_is_refused_before_the_run(tmp_path) -> None:
    # session 46 walk of the API: run_study(..., case_fn=lambda spec: {}) was accepted, made
    # the output folder and failed every case with "TypeError: <lambda>() takes 1 positional
    # argument but 4 were given"; a case is called case_fn(spec, outputs, solver, workdir)
    # (psdesign.study.worker.run_case_inline), so one that cannot take those four is refused
    # up front in one line naming case_fn; a function that can (*args too) is accepted.
    out = tmp_path / "o"
    for bad, shown in (
        (lambda spec: {}, "<lambda>"),
        (lambda spec, outputs, solver, workdir, extra: {}, "<lambda>"),
        ("json:dumps", "'json:dumps'"),  # dumps(obj, *, ...): one positional argument
    ):
        with pytest.raises(psdesign.StudyError) as info:
            psdesign.run_study(_tiny_study(), out, workers=0, case_fn=bad, progress=False)
        line = str(info.value)
        assert line.startswith("case_fn: ") and shown in line and len(line.splitlines()) == 1
        assert "cannot be called as case_fn(spec, outputs, solver, workdir)" in line, line
        assert not out.exists()
    from psdesign.study.casefn import case_fn_call_error

    assert case_fn_call_error(lambda *args: {}) == ""
    assert case_fn_call_error(lambda spec, outputs, solver, workdir, x=1: {}) == ""


def _spec_only(spec) -> dict:
    """A case function of the spec alone (what a functools.wraps adapter wraps)."""
    return {"n_fibers": float(spec["generator"]["n_fibers"])}


class _CallableCase:
    """A callable instance taking the four case arguments."""

    def __call__(self, spec, outputs, solver, workdir) -> dict:
        return _spec_only(spec)


@functools.wraps(_spec_only)
def _wraps_case(spec, outputs, solver, workdir) -> dict:
    """A module-level ``functools.wraps`` adapter: ``__qualname__`` says ``_spec_only``, the
    module's attribute (how a child process imports it) is ``_wraps_case``."""
    return _spec_only(spec)


def _adapt(fn):
    """A decorator: its module-level result is held by its module under ``fn``'s name."""

    @functools.wraps(fn)
    def wrapper(spec, outputs, solver, workdir):
        return fn(spec)

    return wrapper


@_adapt
def _decorated_case(spec) -> dict:
    return _spec_only(spec)


@functools.wraps(_pipeline_case)
def _wraps_pipeline(spec, outputs, solver, workdir) -> dict:
    """An adapter around psdesign's own case function: not the pipeline (it runs what it
    chooses), though its copied name is ``psdesign.study.case:run_case``."""
    return {"n_fibers": float(spec["generator"]["n_fibers"])}


def test_a_wraps_adapter_partial_or_instance_is_a_case_function(tmp_path) -> None:
    # session 46 review: case_fn_call_error read inspect.signature(fn), which follows
    # __wrapped__: a functools.wraps adapter wrapper(spec, outputs, solver, workdir) around
    # f(spec) was refused ("too many positional arguments") though the worker calls the
    # adapter itself with four arguments. Independent truth: the run calls it and each row
    # holds the n_fibers of its case's spec (study.parameters).
    import functools

    @functools.wraps(_spec_only)
    def adapter(spec, outputs, solver, workdir):
        return _spec_only(spec)

    from psdesign.study.casefn import case_fn_call_error

    partial = functools.partial(lambda extra, spec, outputs, solver, workdir: {}, 1)
    for fn in (adapter, partial, _CallableCase()):
        assert case_fn_call_error(fn) == "", fn
        psdesign.RunOptions(case_fn=fn)  # accepted
    study = _tiny_study()
    study["parameters"] = {"generator.n_fibers": [2, 3]}
    df = psdesign.run_study(study, tmp_path / "o", workers=0, case_fn=adapter, progress=False)
    assert sorted(df["n_fibers"]) == [2.0, 3.0]
    assert set(df["status"]) == {"ok"}


def test_a_case_function_is_spelled_one_way_everywhere(tmp_path) -> None:
    # session 46 review: the "module:qualname" spelling of a case function had four copies
    # (casefn.runs_pipeline and worker.case_fn_name with "" for a missing name, runner's
    # run.json entry and options' refusal with "?"); one case_fn_name in casefn now, and
    # every use reads it. Truth: the names Python gives (json.dumps is json:dumps; an
    # instance has no __qualname__), the run.json a run writes, the refusal a run gives.
    import json

    from psdesign.study.case import run_case
    from psdesign.study.casefn import case_fn_name, runs_pipeline
    from psdesign.study.worker import importable_case_fn_name

    inst = _CallableCase()
    assert case_fn_name(None) == case_fn_name(run_case) == "psdesign.study.case:run_case"
    assert case_fn_name(inst) == f"{_CallableCase.__module__}:?"
    assert runs_pipeline(run_case) and not runs_pipeline(inst)
    assert importable_case_fn_name(_spec_only) == case_fn_name(_spec_only)
    with pytest.raises(ValueError, match=re.escape(f"got {case_fn_name(inst)}") + "$"):
        importable_case_fn_name(inst)
    bad = _spec_only  # one argument: refused, named as run.json would name it
    with pytest.raises(psdesign.StudyError) as info:
        psdesign.RunOptions(case_fn=bad)
    assert str(info.value).startswith(f"case_fn: {case_fn_name(bad)!r} cannot be called")
    out = tmp_path / "o"
    psdesign.run_study(_tiny_study(), out, workers=0, case_fn=inst, progress=False, report=False)
    runs = json.loads((out / "run.json").read_text())["runs"]
    assert [r["case_fn"] for r in runs] == [case_fn_name(inst)]
    # review s46: a module-level wraps adapter was spelled by the name it copied (run.json said
    # _spec_only; one around run_case passed for the pipeline); its own name is the attribute
    # its module holds, and it imports back (a timeout's child process loads it by that name)
    own = f"{__name__}:_wraps_case"
    assert sys.modules[__name__]._wraps_case is _wraps_case
    assert case_fn_name(_wraps_case) == importable_case_fn_name(_wraps_case) == own
    assert case_fn_name(_wraps_pipeline) == f"{__name__}:_wraps_pipeline"
    assert not runs_pipeline(_wraps_pipeline)
    # a decorated module-level function: its own code is _adapt's wrapper, which no module
    # holds; the name it copied is its module's attribute, so that name imports back
    decorated = f"{__name__}:_decorated_case"
    assert case_fn_name(_decorated_case) == importable_case_fn_name(_decorated_case) == decorated
    out = tmp_path / "wraps"
    psdesign.run_study(_tiny_study(), out, workers=0, case_fn=_wraps_case, progress=False,
                       report=False)  # fmt: skip
    runs = json.loads((out / "run.json").read_text())["runs"]
    assert [r["case_fn"] for r in runs] == [own]


def test_with_a_timeout_a_case_function_must_import_by_its_name_before_the_run(tmp_path):
    # review s46: with a timeout each case runs in a child process that imports the case
    # function by name; a nested wraps adapter, a partial or an instance failed every case
    # AFTER the output folder was made ("with a timeout the case function must be importable
    # as module:function"). Now refused up front in one line naming case_fn, the folder never
    # made, whether the timeout is the run's (timeout_s) or the study's (study.timeout_s); a
    # module-level wraps adapter runs in the child by its own name (independent truth: each
    # row's n_fibers is its spec's, study.parameters).
    @functools.wraps(_spec_only)
    def nested(spec, outputs, solver, workdir):
        return _spec_only(spec)

    partial = functools.partial(lambda extra, spec, outputs, solver, workdir: {}, 1)
    study = _tiny_study()
    study["study"]["timeout_s"] = 60
    out = tmp_path / "o"
    for fn in (nested, partial, _CallableCase()):
        for kw, table in (({"timeout_s": 60}, _tiny_study()), ({}, study)):
            with pytest.raises(psdesign.StudyError) as info:
                psdesign.run_study(table, out, workers=0, case_fn=fn, progress=False, **kw)
            line = str(info.value)
            assert line.startswith("case_fn: ") and "importable" in line, line
            assert len(line.splitlines()) == 1 and not out.exists()
    study["parameters"] = {"generator.n_fibers": [2, 3]}
    df = psdesign.run_study(study, out, workers=0, case_fn=_wraps_case, progress=False,
                            report=False)  # fmt: skip
    assert sorted(df["n_fibers"]) == [2.0, 3.0] and set(df["status"]) == {"ok"}


def test_with_a_timeout_a_scripts_case_function_is_refused_before_the_run(tmp_path):
    # found mending review s46: a script's case function is __main__:case, which imports
    # back in the script, but a timeout's child process runs `python -m psdesign.study._child`,
    # whose __main__ is that module: every case failed (AttributeError) after the output folder
    # was made. Refused up front now, one line naming case_fn, no folder.
    out = tmp_path / "o"
    script = tmp_path / "run.py"
    script.write_text(
        textwrap.dedent(
            f"""
            import psdesign

            def case(spec, outputs, solver, workdir):
                return {{"n_fibers": 1.0}}

            if __name__ == "__main__":
                try:
                    psdesign.run_study({_tiny_study()!r}, {str(out)!r}, workers=0,
                                       case_fn=case, progress=False, timeout_s=60)
                except psdesign.StudyError as exc:
                    print(exc)
            """
        )
    )
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=300, check=True)  # fmt: skip
    line = run.stdout.strip()
    assert line.startswith("case_fn: ") and "__main__:case" in line, (line, run.stderr)
    assert not out.exists()


def test_too_many_local_workers_points_to_the_keyword(tmp_path) -> None:
    # session 46 walk of the API: RunOptions(workers=10**6) advised "use --scheduler or
    # --cluster", flags a Python caller has not; the keyword is named now (the CLI keeps its
    # flags: test_study_safety)
    from psdesign.study.runner import max_local_workers

    with pytest.raises(psdesign.StudyError) as info:
        psdesign.RunOptions(workers=max_local_workers() + 1)
    line = str(info.value)
    assert line.startswith("workers: at most ") and "use scheduler=" in line, line
    assert "--" not in line


def test_run_options_take_numpy_numbers_as_the_schema_does(tmp_path, monkeypatch) -> None:
    # session 46 walk of the API: a notebook's NumPy numbers were refused with a line that
    # contradicted itself ("workers: must be an integer >= 0 ..., got np.int64(2)"; timeout_s
    # and worker_wait_s alike), while every spec key takes them (schema.types: numbers.Real /
    # numbers.Integral). They are taken now, as Python numbers; a NumPy bool, a float worker
    # count and a non-finite wait are still refused. And a script's top-level call with
    # workers=np.int64(2) meets the main-guard rule as workers=2 does.
    import psdesign.api as api

    opts = psdesign.RunOptions(
        workers=np.int64(2), timeout_s=np.int64(60), scheduler="local", worker_wait_s=np.int32(5)
    )
    assert (opts.workers, opts.timeout_s, opts.worker_wait_s) == (2, 60.0, 5.0)
    assert type(opts.workers) is int and type(opts.timeout_s) is float
    assert type(opts.worker_wait_s) is float
    for bad in (
        {"workers": np.bool_(True)},
        {"workers": np.float64(2.0)},
        {"timeout_s": np.bool_(True)},
        {"timeout_s": np.float32("nan")},
        {"scheduler": "local", "worker_wait_s": np.float64("inf")},
    ):
        key = next(k for k in bad if k != "scheduler")
        with pytest.raises(psdesign.StudyError, match=f"^{key}: "):
            psdesign.RunOptions(**bad)
    monkeypatch.setattr(api, "_unguarded_call_in_main_script", lambda name: True)
    with pytest.raises(psdesign.StudyError, match=r"^run_study: called at the top level"):
        psdesign.run_study(_tiny_study(), tmp_path / "o", workers=np.int64(2))
    assert not (tmp_path / "o").exists()


def test_fields_folder_errors_name_the_keyword_not_a_cli_option(tmp_path, monkeypatch) -> None:
    # a notebook user passed fields=...; main's message named '--fields' and advised '--force',
    # neither of which exists in the Python API. The user's folder stays untouched.
    import psdesign.flow.permeability as perm
    from psdesign.io.outputs import OutputError

    monkeypatch.setattr(perm, "permeability", lambda *a, **k: pytest.fail("solved"))
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    m = psdesign.build(_one_cylinder())
    for call in (m.permeability, m.diffusivity):
        with pytest.raises(OutputError) as info:
            call("z", fields=mine)
        assert info.value.key == "fields" and "--" not in info.value.message
        assert "non-empty folder psdesign did not create" in info.value.message
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]
    assert (mine / "notes.txt").read_text() == "keep"


def test_material_pores_is_the_pores_command(monkeypatch) -> None:
    # every command has its Material method (README: "every command and from_image take it");
    # main had permeability / diffusivity / conductivity but no pores. Independent truth: the
    # specific surface of one z-cylinder, S_v = pi D L / V = pi 8e-6 / (20e-6)^2 = 62832 1/m.
    m = psdesign.build(_one_cylinder())
    out = m.pores(n_radii=8)
    exact = math.pi * 8e-6 / 20e-6**2
    assert out["specific_surface_m-1"] == pytest.approx(exact, rel=0.03)
    assert abs(out["specific_surface_m-1"] / exact - 1) <= max(
        out["specific_surface_rel_error"], 0.01
    )
    assert out["porosity"] == pytest.approx(m.porosity, rel=1e-12)
    assert 0 < out["pore_d10_m"] <= out["pore_d50_m"] <= out["pore_d90_m"] < 20e-6
    with pytest.raises(psdesign.SpecError, match=r"transport\.n_radii"):
        m.pores(n_radii=0)


def test_load_spec_of_a_dict_says_where_a_dict_goes() -> None:
    # main: "TypeError: expected str, bytes or os.PathLike object, not dict" from pathlib
    for bad in ({"rve": {}}, None, 3):
        with pytest.raises(psdesign.SpecError, match=r"^spec: load_spec takes a file name"):
            psdesign.load_spec(bad)


def test_transport_html_carries_converged_and_error_bars_on_an_image(tmp_path) -> None:
    """A notebook user sees every number with its convergence flag and error estimate
    (PermeabilityResult's table has a "converged" row; the transport tables had none, and
    D_eff and the tortuosity factor had no bar; audit s32). A layered image (plates of 4 of
    20 voxels along y) has closed forms: along the plates D_eff / D = porosity = 0.8 and
    tortuosity factor 1; across them the conductivity is the harmonic (series) mean
    1 / (0.8 / 1 + 0.2 / 10) (the Wiener bounds are attained by a laminate: Wiener 1912)."""
    import psdesign

    solid = np.zeros((20, 20, 20), np.uint8)
    solid[:, :4, :] = 1
    np.save(tmp_path / "plates.npy", solid)
    m = psdesign.from_image(tmp_path / "plates.npy", voxel_size=1e-6)
    dr = m.diffusivity("x")
    assert dr.relative_diffusivity == pytest.approx(0.8, rel=1e-9)
    assert dr.tortuosity_factor == pytest.approx(1.0, rel=1e-9)
    page = dr._repr_html_()
    bar = f"&plusmn; {100 * dr.rel_error:.2g} %"
    assert f'>converged</th><td style="text-align:left">{dr.converged}<' in page
    assert f"1 {bar}<" in page and f"{dr.effective_diffusivity_m2_s:.4e} {bar}<" in page
    cr = m.conductivity("y", solid=10.0, fluid=1.0)
    assert cr.effective_conductivity == pytest.approx(1 / (0.8 / 1 + 0.2 / 10), rel=1e-6)
    assert f'>converged</th><td style="text-align:left">{cr.converged}<' in cr._repr_html_()


def _tiny_study() -> dict:
    """Two straight-fiber cases on a 10^3 grid, porosity only (about a second in-process)."""
    return {
        "base": {
            "rve": {"size": [20e-6] * 3, "voxel": 2e-6},
            "generator": {"kind": "straight", "n_fibers": 2, "diameter": 6e-6, "seed": 1},
            "flow": {"solver": "voxel"},
        },
        "study": {"name": "tiny", "seeds": [1], "outputs": ["porosity"], "solver": "voxel"},
        "parameters": {"generator.diameter": [5e-6, 6e-6]},
    }


def test_run_study_takes_a_study_dict_as_build_takes_a_spec_dict(tmp_path) -> None:
    # build() takes a spec dict or file; run_study / load_study took only a file: a dict gave
    # pathlib's "TypeError: expected str, bytes or os.PathLike object, not dict" (audit s33).
    # Independent truth: each case's porosity is what build() gives for that case's spec.
    import copy

    from toml_writer import dumps

    study = _tiny_study()
    given = copy.deepcopy(study)
    quiet = {"workers": 0, "report": False, "progress": False}
    df = psdesign.run_study(study, tmp_path / "d", **quiet)
    assert study == given  # the caller's dict is not changed
    (tmp_path / "s.toml").write_text(dumps(study))
    from_file = psdesign.run_study(tmp_path / "s.toml", tmp_path / "f", **quiet)
    assert list(df["case_id"]) == list(from_file["case_id"])
    for diameter, porosity in zip(df["generator.diameter"], df["porosity"], strict=True):
        spec = copy.deepcopy(study["base"])
        spec["generator"]["diameter"] = float(diameter)
        assert porosity == pytest.approx(psdesign.build(spec).porosity, abs=1e-12)
    assert psdesign.load_study(study).parameters.keys() == {"generator.diameter"}
    for bad in (None, 3, [study]):
        with pytest.raises(psdesign.StudyError, match=r"^study: must be a study file name"):
            psdesign.run_study(bad, tmp_path / "x", **quiet)
    assert not (tmp_path / "x").exists()


def test_output_folder_refusals_name_the_api_keywords(tmp_path) -> None:
    # run_study(out_dir=...) refused a user's folder with "-o: ... or --force to add ...", and
    # fields="/" with "even with --force": options the Python API does not have (its keywords
    # are out_dir and force=True). A folder name of the wrong type was pathlib's TypeError.
    from toml_writer import dumps

    import psdesign.flow.permeability as perm

    study = tmp_path / "s.toml"
    study.write_text(dumps(_tiny_study()))
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    quiet = {"workers": 0, "report": False, "progress": False}
    with pytest.raises(psdesign.OutputError) as info:
        psdesign.run_study(study, mine, **quiet)
    assert info.value.key == "out_dir" and "--" not in info.value.message
    assert info.value.message.endswith("or force=True to add psdesign's files beside them")
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]
    with pytest.raises(psdesign.OutputError, match=r"^out_dir: must be a folder name \(str or"):
        psdesign.run_study(study, 3, **quiet)
    m = psdesign.build(_one_cylinder())
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(perm, "permeability", lambda *a, **k: pytest.fail("solved"))
        with pytest.raises(psdesign.OutputError) as info:
            m.permeability("z", fields="/")
        assert info.value.key == "fields" and "force" not in info.value.message
        with pytest.raises(psdesign.OutputError, match=r"^fields: must be a folder name"):
            m.permeability("z", fields=3)


def test_axis_index_zero_is_x_and_a_bool_is_no_axis(monkeypatch) -> None:
    # m.permeability(0) solved along z and labelled the result 'z' (`given or default` took
    # the axis index 0 for "not given"); True passed as axis 1 ('y') (audit s33)
    import psdesign.flow.permeability as perm

    seen = []

    def fake(rve, fields, direction, table, route, progress=None, capture=None):
        seen.append(direction)
        return {"direction": direction, "permeability_m2": 1e-12, "converged": True}

    monkeypatch.setattr(perm, "permeability", fake)
    m = psdesign.build(_one_cylinder())
    assert [m.permeability(d).direction for d in (0, np.int64(0), 1, "x")] == ["x", "x", "y", "x"]
    assert seen == ["x", "x", "y", "x"]
    for bad in (True, np.bool_(False)):
        with pytest.raises(psdesign.SpecError, match=r"^direction: must be 'x', 'y' or 'z'"):
            m.permeability(bad)
        with pytest.raises(psdesign.SpecError, match=r"^direction: must be 'x', 'y' or 'z'"):
            m.diffusivity(bad)
    assert len(seen) == 4


def test_from_image_wrong_types_are_one_spec_error(tmp_path) -> None:
    # an array for the path gave "image.format: cannot tell the format of '[[[0. 0. ..." (the
    # whole array printed), flow="voxel" a bare ValueError from dict() (audit s33)
    with pytest.raises(psdesign.SpecError) as info:
        psdesign.from_image(np.zeros((8, 8, 8), np.uint8), voxel_size=1e-6)
    assert info.value.key == "image.path" and "got ndarray" in info.value.message
    assert len(str(info.value)) < 200
    np.save(tmp_path / "a.npy", np.zeros((8, 8, 8), np.uint8))
    with pytest.raises(psdesign.SpecError, match=r"^flow: must be a table, got 'voxel'"):
        psdesign.from_image(tmp_path / "a.npy", voxel_size=1e-6, flow="voxel")


def test_progress_keyword_reports_on_stderr_and_leaves_nothing_on(monkeypatch, capsys) -> None:
    # the CLI prints stages and solver iterations; the API had no way to ask for them (a
    # minutes-long FEM solve in a notebook was silent). progress=True activates the same
    # printer for the call only; the default stays silent (audit s33).
    import psdesign.flow.permeability as perm
    import psdesign.progress as prog
    import psdesign.transport.diffusivity as diff

    seen = []

    def fake_perm(rve, fields, direction, table, route, progress=None, capture=None):
        seen.append((callable(progress), prog.active() is not None))
        prog.stage("solving")  # as the library's stages do
        return {"direction": direction, "permeability_m2": 1e-12, "converged": True}

    def fake_diff(fields, direction, table, progress=None, **kwargs):
        seen.append((callable(progress), prog.active() is not None))
        raise KeyboardInterrupt  # the printer is switched off on the way out, too

    monkeypatch.setattr(perm, "permeability", fake_perm)
    monkeypatch.setattr(diff, "relative_diffusivity", fake_diff)
    m = psdesign.build(_one_cylinder())
    m.permeability("z")
    assert seen.pop() == (False, False) and capsys.readouterr().err == ""
    m.permeability("z", progress=True)
    assert seen.pop() == (True, True) and prog.active() is None
    assert "psdesign: solving (" in capsys.readouterr().err
    with pytest.raises(KeyboardInterrupt):
        m.diffusivity("z", progress=True)
    assert seen.pop() == (True, True) and prog.active() is None


def test_progress_true_prints_the_voxel_solves_estimate_as_the_command_does(capsys) -> None:
    # session 43 (notebook walk): README promises "a time and memory estimate before each
    # solve" with progress=True; `psdesign permeability --solver voxel` printed it, the API's
    # voxel route printed only the throttled iteration lines (none for a short solve).
    m = psdesign.build(_one_cylinder())
    capsys.readouterr()
    m.permeability("x", solver="voxel", error_estimate=False)
    assert capsys.readouterr().err == ""  # silent by default
    m.permeability("x", solver="voxel", error_estimate=False, progress=True)
    cells = int(m.fields.solid.size)
    assert f"psdesign: voxel solve x ({cells:.3g} cells): estimated ~" in capsys.readouterr().err


def test_warnings_point_at_the_callers_line_and_repeat_per_material():
    """A ``ResolutionWarning`` raised inside psdesign pointed at psdesign's line, so Python's
    default filter showed it for the first under-resolved material only (API audit, s33);
    re-issued at the caller's line, each call shows its own."""
    import warnings

    from psdesign.flow.voxel import ResolutionWarning

    spec = {
        "rve": {"size": [20e-6] * 3, "voxel": 1e-6},
        "fibers": [{"shape": "cylinder", "diameter": 7e-6, "direction": [0, 0, 1]}],
    }
    a, b = psdesign.build(spec), psdesign.build(spec)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        a.permeability("x", solver="voxel", error_estimate=False)
        b.permeability("x", solver="voxel", error_estimate=False)
    ours = [w for w in caught if issubclass(w.category, ResolutionWarning)]
    assert len(ours) == 2, [str(w.message) for w in caught]
    assert {w.filename for w in ours} == {__file__}


def test_study_file_errors_are_spec_errors_and_scheduler_failures_are_not(tmp_path) -> None:
    """``except psdesign.SpecError`` missed study-file errors (StudyError was a bare
    ValueError); now every bad study input is a SpecError with its key, while a scheduler
    that does not answer (a runtime failure, not bad input) is not one."""
    import pickle

    from study_cases import FAC_PARAMS, FACTORIAL, write_study

    from psdesign.study import SchedulerError

    bad = tmp_path / "bad.toml"
    bad.write_text('[study]\nname = "b"\ndesign = "taguchi"\n')
    with pytest.raises(psdesign.SpecError) as info:
        psdesign.load_study(bad)
    assert isinstance(info.value, psdesign.StudyError) and info.value.key == "study.design"
    assert str(info.value).startswith("study.design: ") and info.value.message in str(info.value)
    again = pickle.loads(pickle.dumps(info.value))  # workers send errors back pickled
    assert type(again) is psdesign.StudyError and str(again) == str(info.value)
    good = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    with pytest.raises(psdesign.SpecError, match="^workers: must be an integer"):
        psdesign.run_study(good, tmp_path / "o", workers=-1)
    with pytest.raises(psdesign.SpecError, match="^scheduler: expected an address"):
        psdesign.run_study(good, tmp_path / "o", scheduler="127.0.0.1:9")
    with pytest.raises(SchedulerError, match="no Dask scheduler answers") as down:
        psdesign.run_study(good, tmp_path / "o", scheduler="tcp://127.0.0.1:9")
    assert not isinstance(down.value, psdesign.SpecError | ValueError)
    assert not (tmp_path / "o").exists()


def test_spec_errors_survive_pickling() -> None:
    """Errors cross process boundaries pickled (study workers, Dask). SpecError(key, message)
    was pickled by its one joined line and could not be rebuilt ("missing 1 required
    positional argument: 'message'"). Truth: the same class, text, key and message after a
    round trip."""
    import pickle

    from psdesign.errors import SpecError
    from psdesign.study.studyfile import StudyError

    for err in (SpecError("fibers[2].diameter", "must be > 0"), StudyError("parameters: empty")):
        back = pickle.loads(pickle.dumps(err))
        assert type(back) is type(err) and str(back) == str(err)
        assert (back.key, back.message) == (err.key, err.message)


def test_run_study_arguments_checked_before_the_output_folder(tmp_path) -> None:
    # session 34 fuzz: timeout_s=inf (or 1e300) was accepted though study.timeout_s allows
    # (0, 1e7]; report="no" was taken as true (a report written); scheduler=3 failed inside the
    # connection with a TypeError; a misspelled case_fn made the output folder and then failed
    # every case. Each is now one StudyError naming the keyword, and nothing is created.
    quiet = {"workers": 0, "report": False, "progress": False}
    out = tmp_path / "o"
    cases = [
        ({"timeout_s": math.inf}, r"^timeout_s: must be a number > 0 and <= 10000000"),
        ({"timeout_s": 1e300}, r"^timeout_s: must be a number > 0 and <= 10000000"),
        ({"report": "no"}, r"^report: must be True or False, got 'no'"),
        ({"force": 1}, r"^force: must be True or False"),
        ({"retry_failed": "yes"}, r"^retry_failed: must be True or False"),
        ({"scheduler": 3}, r"^scheduler: must be an address .* got int"),
        ({"case_fn": "nope_module_x:run"}, r"^case_fn: cannot load 'nope_module_x:run'"),
        ({"case_fn": 3}, r"^case_fn: cannot load 3"),
    ]
    for kwargs, match in cases:
        with pytest.raises(psdesign.StudyError, match=match):
            psdesign.run_study(_tiny_study(), out, **{**quiet, **kwargs})
        assert not out.exists()


@pytest.mark.parametrize(
    ("case_fn", "why"),
    [
        ("fake_case", "no ':' between module and function"),
        (3, "int is not callable"),
        ("json:__name__", "it names a str, which is not callable"),
        ("nope_module_x:run", "No module named 'nope_module_x'"),
    ],
)
def test_run_options_case_fn_refusal_says_each_thing_once(case_fn, why) -> None:
    """Session 47 re-read: ``RunOptions(case_fn="fake_case")`` was "case_fn: cannot load
    'fake_case' (case_fn: expected a callable or 'module:function', got 'fake_case');
    allowed: a callable or an importable 'module:function'": the key, the value and the rule
    twice (the form's own refusal put in the brackets; so was "case_fn: ... is not
    callable"). One line, each once; "cannot load" kept."""
    with pytest.raises(psdesign.StudyError) as info:
        psdesign.RunOptions(case_fn=case_fn)
    line = str(info.value)
    assert line == (
        f"case_fn: cannot load {case_fn!r} ({why}); "
        "allowed: a callable or an importable 'module:function'"
    )
    assert info.value.key == "case_fn"


def test_run_options_case_fn_whose_module_refuses_on_import_says_why(tmp_path, monkeypatch) -> None:
    """Review s48: any StudyError out of loading ``case_fn`` was taken for its form, so a
    module of the user's that raises a StudyError (or SpecError) while importing was told
    "no ':' between module and function" though the name has one; its own text now."""
    (tmp_path / "mendc_refusing_cases.py").write_text(
        "from psdesign.errors import StudyError\n"
        "raise StudyError('fibers.count: must be >= 1, got 0 (set in the module)')\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(psdesign.StudyError) as info:
        psdesign.RunOptions(case_fn="mendc_refusing_cases:run")
    assert str(info.value) == (
        "case_fn: cannot load 'mendc_refusing_cases:run' (fibers.count: must be >= 1, got 0 "
        "(set in the module)); allowed: a callable or an importable 'module:function'"
    )
    assert info.value.key == "case_fn"


@pytest.mark.parametrize(
    ("body", "why"),
    [
        ("raise RuntimeError('no licence server')", "RuntimeError: no licence server"),
        ("raise ValueError('bad table')", "ValueError: bad table"),
        ("import sys; sys.exit(3)", "SystemExit: 3"),
        ("raise ImportError('needs licence_lib')", "ImportError: needs licence_lib"),
    ],
)
def test_case_fn_module_raising_on_import_is_one_line_exit_2_no_folder(
    tmp_path, monkeypatch, capsys, body, why
) -> None:
    """Session 49: a case function's module raising anything but a StudyError while it is
    imported (a RuntimeError) was a traceback out of ``RunOptions`` and ``psdesign study run
    --case-fn`` (exit status 1 from Python, after the argument checks). Now one line naming
    ``case_fn``, the name, and the exception's type and text: a StudyError from the API, exit
    status 2 from the command, before any folder is made."""
    from psdesign.cli.study import main

    module = f"walk_boom_{why.split(':')[0].lower()}"  # one module per case: none cached
    (tmp_path / f"{module}.py").write_text(body + "\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    line = (
        f"case_fn: cannot load '{module}:run' (importing it raised {why}); "
        "allowed: a callable or an importable 'module:function'"
    )
    with pytest.raises(psdesign.StudyError) as info:
        psdesign.RunOptions(case_fn=f"{module}:run")
    assert str(info.value) == line and info.value.key == "case_fn"
    study = tmp_path / "s.toml"
    study.write_text(
        '[base.rve]\nsize = [2e-5, 2e-5, 2e-5]\nvoxel = 1e-6\n[study]\nname = "t"\n'
        'outputs = ["porosity"]\n[parameters]\n"rve.voxel" = [1e-6]\n'
    )
    out = tmp_path / "out"
    rc = main(["study", "run", str(study), "-o", str(out), "--case-fn", f"{module}:run"])
    err = capsys.readouterr().err
    assert rc == 2 and err == f"psdesign: error: {line}\n", err
    assert not out.exists()


@pytest.mark.parametrize("timeout_s", [None, 60])
def test_a_case_whose_case_fn_is_not_callable_records_case_fn_and_the_name(
    tmp_path, timeout_s
) -> None:
    """Review s48: load_case_fn's not-callable line was cut to "it names a str, which is not
    callable" for RunOptions' brackets, but each case loads the function too
    (worker.run_case_inline, in the worker or the case's child process), where the record
    named neither ``case_fn`` nor the name. Its line is whole again; RunOptions words its own
    (test_run_options_case_fn_refusal_says_each_thing_once)."""
    from psdesign.study.worker import execute_case

    payload = {
        "case_id": "c0001-00000000",
        "spec": {},
        "outputs": [],
        "solver": "fem",
        "workdir": str(tmp_path / "case"),
        "out_dir": str(tmp_path),
        "case_fn": "json:__name__",
        "timeout_s": timeout_s,  # None: in this process; 60: the case's child process
    }
    record = execute_case(payload)
    assert record["status"] == "failed"
    assert record["error"] == (
        "CaseFnNotCallable: case_fn: 'json:__name__' names a str, which is not callable"
    )


def test_run_options_name_the_keyword_not_the_command_line_option(tmp_path) -> None:
    # audit s45: RunOptions(timeout_s=-1) was refused as "timeout: ...", scheduler="zz" /
    # scheduler="" as "--scheduler: ..." and worker_wait_s=0 as "--cluster-wait: ...": the
    # command's option, not the keyword the caller wrote (docs/study-files.md: "each checked
    # when it is made (one line naming it)"); `.key` is what `except SpecError` reads.
    cases = [
        ({"timeout_s": -1}, "timeout_s", "must be a number > 0 and <= 10000000"),
        ({"scheduler": "zz"}, "scheduler", "expected an address like tcp://HOST:PORT"),
        ({"scheduler": ""}, "scheduler", "empty (''); give tcp://HOST:PORT"),
        ({"worker_wait_s": 0}, "worker_wait_s", "expected seconds > 0 (finite), got 0"),
    ]
    for kwargs, key, message in cases:
        with pytest.raises(psdesign.StudyError) as info:
            psdesign.RunOptions(**kwargs)
        assert info.value.key == key and str(info.value).startswith(f"{key}: "), str(info.value)
        assert message in str(info.value)
        with pytest.raises(psdesign.StudyError, match=f"^{key}: "):
            psdesign.run_study(_tiny_study(), tmp_path / "o", workers=0, **kwargs)
    assert not (tmp_path / "o").exists()


def test_a_scheduler_host_that_does_not_resolve_names_the_keyword(tmp_path) -> None:
    # session 46: RunOptions renamed "--scheduler: ..." to "scheduler: ..." only for a
    # StudyError; a host that does not resolve is a SchedulerError, which escaped the rename:
    # RunOptions(scheduler="tcp://nohost.invalid:8786") and run_study(...) said "--scheduler:
    # the host of ...", the command line's option. Truth: ".invalid" never resolves (RFC 6761,
    # section 6.4); the line starts with the keyword as written, nothing is created.
    from psdesign.study import SchedulerError
    from psdesign.study import run_study as runner_run_study

    address = "tcp://nohost.invalid:8786"
    line = f"scheduler: the host of {address} does not resolve ("
    with pytest.raises(SchedulerError) as info:
        psdesign.RunOptions(scheduler=address)
    assert str(info.value).startswith(line) and len(str(info.value).splitlines()) == 1
    for run in (psdesign.run_study, runner_run_study):
        with pytest.raises(SchedulerError) as info:
            run(_tiny_study(), tmp_path / "o", workers=1, scheduler=address, progress=False)
        assert str(info.value).startswith(line), str(info.value)
    assert not (tmp_path / "o").exists()


def test_a_scheduler_that_does_not_answer_is_named_as_the_caller_named_it(tmp_path, capsys) -> None:
    # session 46: psdesign.run_study(..., scheduler="tcp://127.0.0.1:9") raised "--scheduler:
    # no Dask scheduler answers at ...", the command line's option; the runner's connection
    # now names what its caller calls it: "scheduler" from Python, "--scheduler" from `study
    # run` (exit 2, one line). Truth: port 9 (discard) on the loopback refuses the connection
    # at once; nothing is created either way.
    from study_cases import FAC_PARAMS, FACTORIAL, write_study

    from psdesign.cli.main import main
    from psdesign.study import SchedulerError

    good, out = write_study(tmp_path, FACTORIAL, FAC_PARAMS), tmp_path / "o"
    with pytest.raises(SchedulerError) as info:
        psdesign.run_study(good, out, scheduler="tcp://127.0.0.1:9", progress=False)
    assert str(info.value).startswith("scheduler: no Dask scheduler answers at tcp://127.0.0.1:9")
    argv = ["study", "run", str(good), "-o", str(out), "--scheduler", "tcp://127.0.0.1:9"]
    assert main([*argv, "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        "psdesign: error: --scheduler: no Dask scheduler answers at tcp://127.0.0.1:9"
    ), err
    assert not out.exists()


def test_the_study_runner_names_python_keywords_and_each_command_its_flags(
    tmp_path, capsys
) -> None:
    # session 46 review: psdesign.study.run_study (the runner's, public) defaulted to the
    # command line's names: a scheduler that does not answer was "--scheduler: ...", a user's
    # folder "-o: ... or --force", while RunOptions named "scheduler"; optimize_study alike.
    # The Python keywords are the runner's defaults now and each command passes its flags:
    # `study optimize` names --scheduler. Truth: port 9 (discard) on the loopback refuses
    # the connection at once; nothing is created or changed either way.
    from study_cases import write_study

    from psdesign.analysis.optimize import optimize_study
    from psdesign.analysis.targets import Target
    from psdesign.cli.main import main
    from psdesign.study import SchedulerError
    from psdesign.study import run_study as runner_run_study

    down = "tcp://127.0.0.1:9"
    study = 'design = "latin-hypercube"\nn_samples = 4\nseeds = [1]\noutputs = ["k_z"]'
    p = write_study(tmp_path, study, '"generator.porosity" = {low = 0.7, high = 0.9}')
    out = tmp_path / "o"
    target = [Target.parse("k_z_m2=5e-12")]
    for call in (
        lambda: runner_run_study(p, out, scheduler=down, progress=False),
        lambda: optimize_study(p, out, target, scheduler=down, progress=False),
    ):
        with pytest.raises(SchedulerError) as info:
            call()
        assert str(info.value).startswith(f"scheduler: no Dask scheduler answers at {down}")
    argv = ["study", "optimize", str(p), "-o", str(out), "--target", "k_z_m2=5e-12"]
    assert main([*argv, "--scheduler", down, "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    line = f"psdesign: error: --scheduler: no Dask scheduler answers at {down}"
    assert len(err) == 1 and err[0].startswith(line), err
    assert not out.exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    with pytest.raises(psdesign.OutputError) as refused:
        runner_run_study(p, mine, workers=0, progress=False, report=False)
    assert refused.value.key == "out_dir" and "--" not in refused.value.message
    assert refused.value.message.endswith("or force=True to add psdesign's files beside them")
    assert [f.name for f in mine.iterdir()] == ["notes.txt"]


def test_conductivity_and_from_image_bad_arguments_name_the_key(tmp_path) -> None:
    # session 34 fuzz: m.conductivity(solid=True) solved with a solid of 1.0 and solid="2"
    # with 2.0 (float() of a bool and of a string); from_image(<a folder>) was refused as
    # "image.format: cannot tell the format of ...", not naming the path.
    m = psdesign.build(_one_cylinder())
    for bad in (True, "2", np.bool_(True)):
        with pytest.raises(psdesign.SpecError) as info:
            m.conductivity("z", solid=bad, fluid=0.1)
        assert info.value.key == "transport.solid_conductivity", str(info.value)
        assert "must be a number >= 1e-300 and < 1e12" in info.value.message
    with pytest.raises(psdesign.SpecError) as info:
        psdesign.from_image(tmp_path, voxel_size=1e-6)
    assert info.value.key == "image.path" and "no .tif / .tiff file in the folder" in str(
        info.value
    )  # a folder is read as TIFF slices since session 44


def test_expand_design_and_write_report_take_what_run_study_takes(tmp_path) -> None:
    # session 34 fuzz: psdesign.expand_design(3) was an AttributeError ('int' object has no
    # attribute 'parameters') and a study dict was refused the same way; write_report(3) was
    # pathlib's TypeError. Now a dict or file is loaded as run_study loads it, and a bad type
    # is the one-line error naming the argument.
    study = _tiny_study()
    cases = psdesign.expand_design(study)
    assert [c.params["generator.diameter"] for c in cases] == [5e-6, 6e-6]
    with pytest.raises(psdesign.StudyError, match=r"^study: must be a study file name"):
        psdesign.expand_design(3)
    for bad in (3, None):
        with pytest.raises(psdesign.OutputError, match=r"^out_dir: must be a folder name"):
            psdesign.write_report(bad)


def test_progress_keyword_is_a_flag(monkeypatch) -> None:
    # session 34 fuzz: m.diffusivity("z", progress="no") printed the progress lines (any
    # non-empty string was true); a flag is now True or False, NumPy's too
    import psdesign.flow.permeability as perm

    monkeypatch.setattr(perm, "permeability", lambda *a, **k: pytest.fail("solved"))
    m = psdesign.build(_one_cylinder())
    for call in (m.permeability, m.diffusivity, m.conductivity):
        for bad in ("no", 1, None):
            with pytest.raises(psdesign.SpecError, match=r"^progress: must be True or False"):
                call("z", progress=bad)
    assert m.diffusivity("z", progress=np.bool_(False)).converged


def test_permeability_solver_keyword_checked_against_its_budget(monkeypatch) -> None:
    """Audit (session 34), the API twin of the CLI's 507243d: ``Material.permeability(
    solver="voxel")`` on a spec written for the FEM skipped the voxel solver's memory budget.
    Truth (as the CLI test): a 1 mm cube at 2 um voxels is a 500^3 grid, 1.25e8 cells of 132 B
    = 15.4 GiB, over half of a 24 GiB machine: refused naming rve.voxel, before voxelizing."""
    import psdesign.schema.budget as budget

    monkeypatch.setattr(budget, "machine_memory", lambda: 24 * 2**30)
    spec = {
        "rve": {"size": [1e-3, 1e-3, 1e-3], "voxel": 2e-6},
        "fibers": [{"shape": "cylinder", "diameter": 1e-4, "direction": [0, 0, 1]}],
        "flow": {"solver": "fem", "bc": "periodic"},
    }
    m = psdesign.build(spec)

    def voxelize(*a, **k):
        raise AssertionError("voxelized before the budget was checked")

    monkeypatch.setattr(m._built, "voxelize", voxelize)
    with pytest.raises(psdesign.SpecError, match=r"^rve\.voxel: a 500x500x500 grid .*'voxel'"):
        m.permeability(solver="voxel")


@pytest.mark.parametrize(
    ("keywords", "spec_phase", "key"),
    [
        ({"solid": 1.0, "insulating_phase": "solid"}, None, "solid"),
        ({"fluid": 2.0, "solid": 5.0, "insulating_phase": "fluid"}, None, "fluid"),
        ({"solid": 1.0}, "solid", "solid"),  # the spec's insulating_phase
    ],
)
def test_conductivity_refuses_a_value_for_the_insulating_phase(
    monkeypatch, keywords, spec_phase, key
) -> None:
    """Session 34 notes: ``m.conductivity(solid=1, insulating_phase="solid")`` (and
    ``effective_conductivity(fields, solid=1, transport={"insulating_phase": "solid"})``)
    solved with the solid at 0 and the 1 ignored, while the CLI refuses ``--insulating solid
    --solid 1``. A SpecError naming the keyword, before the voxels are computed."""
    import psdesign.transport.conductivity as cond
    from psdesign.transport.conductivity import effective_conductivity

    monkeypatch.setattr(cond, "solve_effective", lambda *a, **k: pytest.fail("solved"))
    spec = _one_cylinder()
    if spec_phase:
        spec["transport"] = {"insulating_phase": spec_phase}
    m = psdesign.build(spec)
    with pytest.raises(psdesign.SpecError) as info:
        m.conductivity("z", **keywords)
    assert info.value.key == key, str(info.value)
    assert f'insulating_phase = "{key}" makes the {key} a perfect insulator' in str(info.value)
    assert m._fields is None  # refused before the voxelization
    table = {k: v for k, v in keywords.items() if k == "insulating_phase"}
    table |= spec.get("transport", {})
    values = {k: v for k, v in keywords.items() if k in ("solid", "fluid")}
    with pytest.raises(psdesign.SpecError, match=f"^{key}: insulating_phase"):
        effective_conductivity(m.fields, "z", transport=table, **values)


def test_conductivity_with_an_insulating_solid_is_the_fluid_through_the_pore() -> None:
    """The value of the other phase is used: one z-cylinder, solid insulating, fluid 2.0:
    along the cylinder the straight pore carries sigma_eff = 2.0 * porosity exactly (the
    parallel, Wiener upper mean, attained by any medium uniform along the axis)."""
    m = psdesign.build(_one_cylinder())
    r = m.conductivity("z", fluid=2.0, insulating_phase="solid")
    assert r.solid_conductivity == 0.0 and r.fluid_conductivity == 2.0
    assert r.effective_conductivity == pytest.approx(2.0 * m.porosity, rel=1e-6)


def test_an_unreachable_porosity_is_a_spec_error_naming_its_key() -> None:
    """Session 42 (new user's walk): the quickstart's base at seed 2 cannot reach porosity
    0.85 +- 0.005 in its 50 um box (one 7 um fibre moves it 0.015; closest 0.8418). The CLI
    says so in one line, exit 2; `psdesign.build` raised a bare ValueError, which README's
    `except psdesign.SpecError` ("catches any bad input") let through as a traceback."""
    import pickle

    spec = {
        "rve": {"size": [50e-6] * 3, "voxel": 1e-6},
        "generator": {
            "kind": "straight",
            "porosity": 0.85,
            "diameter": 7e-6,
            "seed": 2,
            "theta": {"dist": "uniform", "low": -5.0, "high": 5.0},
            "omega": {"dist": "uniform", "low": 0.0, "high": 180.0},
        },
        "intersections": {"method": "fast", "min_gap": 0.5e-6},
    }
    with pytest.raises(psdesign.SpecError) as info:
        psdesign.build(spec)
    err = info.value
    assert err.key == "generator.porosity"
    assert str(err).startswith("generator.porosity: target 0.85 not reached within +-0.005")
    assert err.closest_porosity == pytest.approx(0.8418, abs=5e-5)
    back = pickle.loads(pickle.dumps(err))  # a study worker sends it to the parent
    assert (type(back), str(back), back.key) == (type(err), str(err), err.key)
    assert back.closest_porosity == err.closest_porosity


def test_one_axis_refusal_for_every_entry_that_takes_an_axis() -> None:
    """Session 47: ``api._direction`` and ``pore_sizes``' thickness axis each wrapped
    ``axis_of`` with their own message (the material's methods said "must be 'x', 'y' or
    'z'" though they take 0-2 too); ``porosity_profile(axis="w")`` and
    ``relative_diffusivity(fields, "w")`` were a bare ValueError "direction must be ..."
    (the profile's argument is ``axis``). One helper now (``flow.darcy.checked_axis``): one
    SpecError line naming the argument, the same words everywhere."""
    from psdesign.transport.diffusivity import relative_diffusivity
    from psdesign.transport.pores import pore_sizes, porosity_profile

    m = psdesign.build(_one_cylinder())
    words = "must be 'x', 'y' or 'z' (or 0-2), got 'w'"
    for key, call in (
        ("direction", lambda: m.permeability("w")),
        ("direction", lambda: m.diffusivity("w")),
        ("direction", lambda: relative_diffusivity(m.fields, "w")),
        ("transport.thickness_axis", lambda: pore_sizes(m.fields, thickness_axis="w")),
        ("axis", lambda: porosity_profile(m.fields, "w")),
    ):
        with pytest.raises(psdesign.SpecError) as info:
            call()
        assert (info.value.key, str(info.value)) == (key, f"{key}: {words}")


def test_permeability_result_from_a_dict_that_is_not_a_record_is_one_line() -> None:
    # main: from_dict(3) was AttributeError ('int' object has no attribute 'get'), from_dict({})
    # KeyError: 'direction'
    for bad, shown in ((3, "int"), ({}, "[]"), ({"k": 1.0}, "['k']")):
        with pytest.raises(psdesign.SpecError) as info:
            psdesign.PermeabilityResult.from_dict(bad)
        assert str(info.value).startswith("d: must be a dict with 'direction' and ")
        assert str(info.value).endswith(f"got {shown}")
    ok = {"direction": "z", "permeability_m2": 1e-12, "converged": True}
    assert psdesign.PermeabilityResult.from_dict(ok).permeability_m2 == 1e-12


@pytest.mark.parametrize(
    ("kw", "line"),
    [
        ({"out_option": 3}, "out_option: must be a pair"),  # main: "cannot unpack non-iterable"
        ({"out_option": ("-o",)}, "out_option: must be a pair"),
        ({"command": 3}, "command: must be a non-empty text, got 3"),  # main: the marker's
        ({"scheduler_option": None}, "scheduler_option: must be a non-empty text, got None"),
    ],
)
def test_the_runner_refuses_naming_keywords_of_other_types(tmp_path, kw, line) -> None:
    from study_cases import FACTORIAL, fake_case, write_study

    from psdesign.study import StudyError, is_timing_column
    from psdesign.study import run_study as runner_run_study

    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    with pytest.raises(StudyError) as info:
        runner_run_study(p, tmp_path / "o", case_fn=fake_case, workers=0, progress=False, **kw)
    assert str(info.value).startswith(line)
    assert not (tmp_path / "o").exists()
    assert is_timing_column(3) is False  # main: AttributeError ('int' ... 'endswith')


def test_load_study_refuses_a_case_fn_that_is_neither_callable_nor_a_name(tmp_path) -> None:
    # session 47 walk: load_study(path, case_fn=3) was taken (as a user's case function: the
    # route's memory left unplanned); run_study refused the same value by RunOptions' rule
    from study_cases import FACTORIAL, write_study

    from psdesign.study import StudyError, load_study

    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    # "fake_case" (no module): taken by load_study until the review of session 47, refused by
    # run_study's load_case_fn; one rule now (casefn.check_case_fn_form)
    for bad in (3, 2.5, ["m:f"], "fake_case"):
        with pytest.raises(StudyError, match=r"^case_fn: expected a callable or 'module:function'"):
            load_study(p, bad)
    assert load_study(p, "study_cases:fake_case").parameters  # a name is still taken


def _array_refusals(tmp_path):
    """(name, call) of Python refusals given a 2-D NumPy array or a pandas Series."""
    import pandas as pd
    from study_cases import FACTORIAL, fake_case, write_study

    from psdesign.analysis.optimize import optimize_study
    from psdesign.analysis.targets import Target
    from psdesign.flow.darcy import checked_axis
    from psdesign.schema.transport import check_conductivity
    from psdesign.study import RunOptions, run_study

    a2 = np.zeros((4, 4))
    s = pd.Series(np.arange(5.0))
    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    box = write_study(
        tmp_path,
        'design = "latin-hypercube"\nn_samples = 4\nseeds = [1]\noutputs = ["k_z"]',
        '"generator.porosity" = {low = 0.7, high = 0.9}',
        name="box.toml",
    )
    t = [Target.parse("k_z_m2=5e-12")]
    opt = functools.partial(optimize_study, box, tmp_path / "o", case_fn=fake_case, workers=0)
    return [
        ("targets", lambda: opt(a2)),
        ("targets", lambda: opt(s)),
        ("targets", lambda: opt([Target("k_z_m2", "=", a2)])),
        ("budget", lambda: opt(t, budget=a2)),
        ("timeout_s", lambda: RunOptions(timeout_s=a2)),
        ("report", lambda: RunOptions(report=s)),
        ("workers", lambda: RunOptions(workers=a2)),
        ("command", lambda: run_study(p, tmp_path / "o", command=a2, case_fn=fake_case)),
        ("direction", lambda: checked_axis(a2, "direction")),
        ("transport.conductivity", lambda: check_conductivity(a2, "transport.conductivity")),
        ("progress", lambda: psdesign.api._progress_flag(s)),
    ]


def test_refusals_show_an_array_by_its_type_name_on_one_line(tmp_path) -> None:
    """Session 47 review: ``got {value!r}`` of a NumPy array or a pandas Series spans lines,
    so the refusal of ``optimize_study(targets=series)``, ``RunOptions(timeout_s=array)``,
    ``checked_axis(array)`` ... was several lines. ``psdesign.errors.short`` words such a
    value by its type's name (as ``checked_fields`` does): one line naming the key."""
    from psdesign.errors import SpecError

    for key, call in _array_refusals(tmp_path):
        with pytest.raises(SpecError) as info:
            call()
        text = str(info.value)
        assert text.startswith(f"{key}: ") and "\n" not in text, text
        assert text.endswith(("ndarray", "Series")) or "got ndarray" in text, text
    assert not (tmp_path / "o").exists()


_LEVELS_LINE = (
    "parameters.generator.porosity: optimize needs {low, high} bounds for every parameter, "
    "not levels (a list or a {start, stop, step} range) (allowed: {low, high}, with "
    "levels = N in a full-factorial design)"
)
_CSV_LINE = (
    "study.csv: optimize needs {low, high} bounds, not a csv design (allowed: [parameters] "
    "of {low, high}, with levels = N in a full-factorial design)"
)


@pytest.mark.parametrize(
    ("params", "line"),
    [
        ('"generator.porosity" = [0.7, 0.8]', _LEVELS_LINE),
        ('"generator.porosity" = {start = 0.7, stop = 0.8, step = 0.1}', _LEVELS_LINE),
        ("csv", _CSV_LINE),
    ],
    ids=["list", "range", "csv"],
)
def test_optimize_refuses_a_parameter_of_levels_as_a_study_error(
    tmp_path, capsys, params, line
) -> None:
    """Session 47: a bare ValueError (``except psdesign.SpecError`` missed it). Session 49
    (walk): the key as the study file spells it (its other refusals say
    parameters.generator.porosity), and the levels a full-factorial design needs with bounds
    (its own refusal came on the next run). Session 49's review: a range {start, stop, step}
    was told "not a list", and a csv design was refused naming parameters.<its column>, a key
    its study file does not have: it is study.csv. The command: exit 2, that one line."""
    from study_cases import FACTORIAL, fake_case, write_entangled_study, write_study

    from psdesign.analysis.optimize import optimize_study
    from psdesign.analysis.targets import Target
    from psdesign.cli import main

    if params == "csv":
        p = write_entangled_study(tmp_path)
    else:
        p = write_study(tmp_path, FACTORIAL, params)
    with pytest.raises(psdesign.SpecError) as info:
        optimize_study(p, tmp_path / "o", [Target.parse("k_z_m2=5e-12")], case_fn=fake_case)
    assert str(info.value) == line
    assert not (tmp_path / "o").exists()
    argv = ["study", "optimize", str(p), "-o", str(tmp_path / "o"), "--target", "k_z_m2=5e-12"]
    capsys.readouterr()
    assert main(argv) == 2
    assert capsys.readouterr().err == f"psdesign: error: {line}\n"
    assert not (tmp_path / "o").exists()


def test_optimize_of_bounds_without_levels_is_told_every_way_out(tmp_path, capsys) -> None:
    """Session 50 (walk): a study file written as ``study optimize --help`` said ("every
    parameter a {low, high} range") in the default full-factorial design was refused by the
    study loader with "(or give a list/range)", which optimize then refuses too. The line
    lists what a full-factorial design takes and the sampled designs, says lists and ranges
    are not for optimize, and the help names the levels a full-factorial design needs."""
    from study_cases import fake_case, write_study

    from psdesign.analysis.optimize import optimize_study
    from psdesign.analysis.targets import Target
    from psdesign.cli import main

    p = write_study(
        tmp_path, 'name = "o"\nseeds = [1]\n', '"generator.porosity" = {low = 0.7, high = 0.8}\n'
    )
    with pytest.raises(psdesign.SpecError) as info:
        optimize_study(p, tmp_path / "o", [Target.parse("k_z_m2=5e-12")], case_fn=fake_case)
    text = str(info.value)
    assert text.startswith("parameters.generator.porosity: bounds need levels = N"), text
    assert "study.design = latin-hypercube / sobol" in text and "not with study optimize" in text
    assert "\n" not in text and not (tmp_path / "o").exists()
    with pytest.raises(SystemExit):
        main(["study", "optimize", "--help"])
    assert "levels = N in a full-factorial design" in " ".join(capsys.readouterr().out.split())


def test_notebook_html_escapes_the_file_name_and_result_strings(tmp_path) -> None:
    """Session 52 I/O review, finding 5: ``Material._repr_html_`` put the image file name in
    raw, so ``a<i>b&c.npy`` opened an ``<i>`` element in the notebook; ``PermeabilityResult.
    from_dict`` takes any direction / solver / bc strings, put in raw as well. Each is shown
    as its text (``html.escape``), and the table's own markup stays."""
    import html

    import psdesign

    name = "a<i>b&c.npy"
    solid = np.zeros((6, 6, 6), np.uint8)
    solid[:, :2] = 1
    np.save(tmp_path / name, solid)
    page = psdesign.from_image(tmp_path / name, voxel_size=1e-6)._repr_html_()
    assert html.escape(name) in page and name not in page and "<i>" not in page
    d = {"direction": "<b>x", "permeability_m2": 3e-12, "solver": "voxel&", "bc": "<s>"}
    page = PermeabilityResult.from_dict(d)._repr_html_()
    assert "&lt;b&gt;x" in page and "voxel&amp; / &lt;s&gt;" in page
    assert "<b>x" not in page and "<s>" not in page and "K (m<sup>2</sup>)" in page


def test_run_study_warns_of_flagged_cases_as_the_cli_exits_3(tmp_path) -> None:
    """Session 54 (walk-api 1): ``psdesign.run_study`` printed "done ...: ok 3" and nothing else
    when every ``k_z_status`` was untrustworthy; ``study run`` on the same table prints "N ok
    case(s) have a value whose own status is not ok (...)" and exits 3. The API now warns with
    the same sentence (one function, ``flagged_text``), at the caller's line; a table with
    every value ok warns nothing. Truth: the fake case sets k_z_status itself (a 30 % bar on
    the porosity-0.9, seed-1 case), so exactly one ok case is flagged."""
    import warnings

    from study_cases import write_study

    from psdesign.cli.exit_status import case_counts

    FlaggedCasesWarning = psdesign.FlaggedCasesWarning  # the README names it bare (review s54)
    assert "FlaggedCasesWarning" in psdesign.__all__

    study = 'name = "f"\nseeds = [1]\noutputs = ["porosity", "k_z"]\nsolver = "voxel"\n'
    p = write_study(tmp_path, study, '"generator.porosity" = [0.8, 0.9]')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = psdesign.run_study(
            p, tmp_path / "o", workers=0, case_fn="study_cases:mixed_status_case", progress=False
        )
    assert case_counts(df).flagged == 1  # what makes `study run` exit 3
    flagged = [w for w in caught if w.category is FlaggedCasesWarning]
    assert len(flagged) == 1, [str(w.message) for w in caught]
    text = str(flagged[0].message)
    assert text.startswith("run_study: 1 ok case(s) have a value whose own status is not ok ")
    assert "(k_z_status: untrustworthy = " in text and "\n" not in text, text
    assert flagged[0].filename == __file__  # the caller's line, not psdesign's
    ok = write_study(tmp_path, study, '"generator.porosity" = [0.8]', name="ok.toml")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        psdesign.run_study(
            ok, tmp_path / "o2", workers=0, case_fn="study_cases:mixed_status_case", progress=False
        )
    assert not [w for w in caught if w.category is FlaggedCasesWarning]


def test_library_deprecation_warnings_are_not_reissued_at_main(tmp_path) -> None:
    """Session 54 (walk-api 2): ``_warns_at_caller`` recorded every warning with ``"always"``
    and re-issued it at the caller's line, so a library's ``DeprecationWarning`` (scikit-fem's,
    on every FEM call) was shown at ``__main__`` under Python's default filters. Recorded under
    the filters in force, it stays hidden as Python hides it, while psdesign's own warnings
    (a ``UserWarning``) still reach the script's line. Run as a script: only ``__main__``'s
    DeprecationWarnings are shown by default."""
    script = tmp_path / "user.py"
    script.write_text(
        "import warnings\n"
        "from psdesign.api import _warns_at_caller\n"
        "lib = {'__name__': 'somelib', 'warnings': warnings}\n"  # a library's module
        'exec(\'def f():\\n    warnings.warn("old api", DeprecationWarning)\\n'
        '    warnings.warn("too coarse", UserWarning)\\n    return 1\', lib)\n'
        "assert _warns_at_caller(lib['f'])() == 1\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env["PYTHONPATH"] = root  # this tree's psdesign
    proc = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, env=env, cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    assert "DeprecationWarning" not in proc.stderr, proc.stderr
    assert f"{script}:5: UserWarning: too coarse" in proc.stderr, proc.stderr


def test_bad_input_to_every_public_name_is_a_spec_error(tmp_path) -> None:
    """Session 54 (walk-api 3): README promises ``except psdesign.SpecError`` catches any bad
    input, but ``mesh_pore_space`` raised ``MeshInputError(ValueError)``, ``make_fiber("rodd")``
    a bare ``ValueError``, ``write_report("nope")`` ``ReportError(ValueError)`` and
    ``Material(<unvalidated dict>)`` ``KeyError: 'period'``. Each is now a SpecError whose key
    is the argument and whose one line names it (and the allowed values where there is a
    list); the CLI still exits 2 for the report's (``study report``)."""
    import numpy as np

    d = np.ones((10, 10, 10))
    cases = [
        (lambda: psdesign.mesh_pore_space(d, 1e-6, (1e-5,) * 3, "w"), "direction", "'x', 'y'"),
        (lambda: psdesign.mesh_pore_space(d[:1], 1e-6, (1e-5,) * 3, "x"), "distance", "3-D"),
        (lambda: psdesign.make_fiber("rodd", diameter=0.1), "shape", "allowed: rod, cylinder"),
        (lambda: psdesign.make_fiber("rod", diameter=1.5), "diameter", "(0, 1) periods"),
        # review of session 54: NumPy's reshape ValueError, isfinite TypeError, u=nan keyed f
        (lambda: psdesign.make_fiber("rod", 0.2, center=[0.1, 0.2]), "center", "three finite"),
        (lambda: psdesign.make_fiber("rod", diameter="a"), "diameter", "got 'a'"),
        (lambda: psdesign.make_fiber("bent-rod", 0.2, u=float("nan")), "u", "finite u"),
        (lambda: psdesign.make_fiber("bent-rod", 0.2, u=0.1, f=0.0), "f", "f > 0"),
        (lambda: psdesign.make_fiber("rod", 0.2, theta="a"), "theta", "degrees"),
        (lambda: psdesign.make_fiber("rod", 0.2, direction=[1, 2]), "direction", "got [1, 2]"),
        (lambda: psdesign.write_report(tmp_path / "nope"), "out_dir", "no results.csv"),
        (lambda: psdesign.Material({"rve": {"size": [2e-5] * 3, "voxel": 1e-6}}), "spec", "build"),
    ]
    for call, key, words in cases:
        with pytest.raises(psdesign.SpecError) as info:
            call()
        line = str(info.value)
        assert info.value.key == key and line.startswith(key) and words in line, line
        assert "\n" not in line, line
    proc = subprocess.run(
        [sys.executable, "-m", "psdesign", "study", "report", str(tmp_path / "nope")],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": os.getcwd()},
    )
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_diffusivity_takes_error_estimate_false_as_permeability_does() -> None:
    """Session 54 (walk-api 8): ``m.permeability(..., error_estimate=False)`` works but
    ``m.diffusivity(..., error_estimate=False)`` was refused ("allowed: resolution,
    residual"). The bool means the same in both (docs/permeability.md: ``false`` skips the
    coarse solve and the bar is the floor alone, doubled; docs/transport.md: ``residual`` is the
    staircase floor doubled): False is ``residual``, True ``resolution``, the same numbers."""
    m = psdesign.build(
        {
            "rve": {"size": [20e-6] * 3, "voxel": 2e-6},
            "fibers": [{"shape": "cylinder", "diameter": 8e-6, "direction": [0, 0, 1]}],
        }
    )
    for flag, word in ((False, "residual"), (True, "resolution")):
        a, b = m.diffusivity("x", error_estimate=flag), m.diffusivity("x", error_estimate=word)
        assert a.to_dict() == b.to_dict() | {"wall_time_s": a.to_dict()["wall_time_s"]}, flag
    with pytest.raises(psdesign.SpecError, match="^transport.error_estimate: got 'no'; allowed"):
        m.diffusivity("x", error_estimate="no")
