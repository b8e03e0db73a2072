"""Regression tests of the schema: every bad input of issue 11 gives one clean line naming the
key, and the schema is the one description the generator, the study runner and the CLI read."""

from __future__ import annotations

import copy
import math
import tomllib
import warnings
from pathlib import Path

import pytest
from toml_writer import dumps

from psdesign.cli.main import main
from psdesign.errors import SpecError
from psdesign.packing.generators import parse_generator, parse_rve
from psdesign.schema import budget
from psdesign.schema.spec import SpecWarning, load_spec, validate_spec
from psdesign.study.studyfile import KNOWN_SPEC_KEYS, StudyError, load_study, parse_study

ROOT = Path(__file__).resolve().parents[2]

BOX = [100e-6, 100e-6, 100e-6]
SPEC = {
    "rve": {"size": BOX, "voxel": 1e-6},
    "generator": {"kind": "straight", "porosity": 0.8, "diameter": 7e-6, "seed": 1},
    "intersections": {"method": "fast"},
    "flow": {"solver": "fem"},
}
STUDY = {
    "base": SPEC,
    "study": {"design": "full-factorial", "seeds": [1, 2], "outputs": ["porosity", "k_z"]},
    "parameters": {"generator.porosity": [0.75, 0.8]},
}


def with_(doc: dict, path: str, v) -> dict:
    out = copy.deepcopy(doc)
    node = out
    *head, last = path.split(".")
    for p in head:
        node = node.setdefault(p, {})
    node[last] = v
    return out


def spec_err(doc: dict) -> SpecError:
    with pytest.raises(SpecError) as ei:
        validate_spec(doc)
    msg = str(ei.value)
    assert "\n" not in msg and len(msg) < 2000
    return ei.value


def study_err(doc: dict) -> str:
    with pytest.raises(StudyError) as ei:
        parse_study(doc)
    msg = str(ei.value)
    assert "\n" not in msg and len(msg) < 3000
    return msg


def test_valid_spec_keeps_the_shape_and_fills_defaults():
    out = validate_spec(SPEC)
    assert out["rve"] == {"size": BOX, "voxel": 1e-6, "period": None}
    assert out["flow"] == {
        "solver": "fem",
        "viscosity": 1.8e-5,
        "aux_length": 0.2,
        "sides": "slip",
        "pressure_drop": 1.0,
        "mesher": "stuffing",
    }
    assert out["generator"] == SPEC["generator"] and out["fibers"] == []
    assert validate_spec(out) == out  # idempotent


def test_one_voxel_default_for_spec_and_generator():
    doc = copy.deepcopy(SPEC)
    del doc["rve"]["voxel"]
    assert validate_spec(doc)["rve"]["voxel"] == pytest.approx(1e-6)  # smallest edge / 100
    assert parse_rve(doc)[1] == pytest.approx(1e-6)
    # (voxel solver: the FEM's stacked permeameter of this box, 2.4 M tets at the default
    # lattice step, is over a 24 GB machine's budget)
    doc = with_(doc, "flow.solver", "voxel")
    assert parse_rve(with_(doc, "rve.size", [50e-6, 100e-6, 200e-6]))[1] == pytest.approx(
        0.5e-6, rel=1e-6, abs=0
    )


@pytest.mark.parametrize(
    "path, value, key",
    [
        ("rve.size", [1e300, 1e-4, 1e-4], "rve.size[0]"),
        ("rve.size", [1e-4, -1.0, 1e-4], "rve.size[1]"),
        ("rve.size", [1e-4, 1e-4], "rve.size[2]"),
        ("rve.size", [1e308, 1e308, 1e308], "rve.size[0]"),
        ("rve.voxel", 1e-12, "rve.voxel"),  # a 1e8-cube grid: refused before allocation
        ("rve.voxel", 1e-4, "rve.voxel"),
        ("rve.voxel", 4e-6, "rve.voxel"),  # under 2 voxels across a 7 um fiber
        ("rve.period", 1.0, "rve.period"),  # 1 m period in a 100 um box
        ("rve.period", 2e-6, "rve.period"),  # copies explode
        ("generator.porosity", 0.999, "generator.porosity"),
        ("generator.porosity", 1.0, "generator.porosity"),
        ("generator.porosity", "x", "generator.porosity"),
        ("generator.theta", 1e18, "generator.theta"),
        ("generator.theta", {"dist": "normal", "mean": 0, "std": 5}, "generator.theta"),
        ("generator.layers", 3, "generator.layers"),
        ("generator.max_fibers", 10**9, "generator.max_fibers"),
        ("generator.seed", -1, "generator.seed"),
        ("generator.seed", True, "generator.seed"),
        ("generator.diameter", {"dist": "gamma"}, "generator.diameter.dist"),
        ("intersections.population", 10**7, "intersections.population"),
        ("intersections.generations", 10**9, "intersections.generations"),
        ("intersections.time_limit_s", 1e18, "intersections.time_limit_s"),
        ("intersections.method", "magic", "intersections.method"),
        ("flow.direction", "w", "flow.direction"),
        ("flow.tol", [1], "flow.tol"),
        ("flow.bc", "open", "flow.bc"),
        ("flow.max_memory_gb", "x", "flow.max_memory_gb"),
        ("flow.max_memory_gb", -1, "flow.max_memory_gb"),
        ("flow.max_memory_gb", 0, "flow.max_memory_gb"),
        ("flow.lattice_step", 1.0, "flow.lattice_step"),
        ("flow.viscosity", float("nan"), "flow.viscosity"),
        ("flow.viscosty", 1.0, "flow.viscosty"),
        ("flow.lattice_step", 1e-9, "flow.lattice_step"),  # 1e15 lattice cells
        ("flow.edge_length", 1e-9, "flow.edge_length"),
        ("flow.pressure_drop", 1e300, "flow.pressure_drop"),
        ("intersections.ga_voxel", 1e-9, "intersections.ga_voxel"),  # 1e15 GA voxels
        ("intersections.step", 1e-15, "intersections.step"),
        ("generator.tz", {"dist": "uniform", "low": 0, "high": 1e9}, "generator.tz"),
        ("rve.size", [1e3, 1e-4, 1e-4], "rve.size[0]"),
        ("generator.u", 3.0, "generator.u"),  # only with kind = 'bent'
        ("mesh.anything", 1, "mesh"),
        ("output.dir", "x", "output"),
        ("forcefield.case", "garbage", "forcefield.case"),
        ("forcefield.garbage", 1, "forcefield.garbage"),
    ],
)
def test_bad_value_names_the_key(path, value, key):
    err = spec_err(with_(SPEC, path, value))
    assert err.key == key
    assert "allowed" in err.message


def test_the_ga_grid_refusal_says_what_it_counted():
    """``intersections.ga_voxel``'s memory refusal said "with solver 'fem'" (check_grid's
    solver argument, whatever [flow] solves; s44-left noticed): it counts the GA's overlap
    grid, and says so."""
    ga = with_(SPEC, "intersections.method", "ga")
    err = spec_err(with_(ga, "intersections.ga_voxel", 1e-9))
    assert "for the GA's overlap grid" in err.message and "solver" not in err.message


def test_a_grid_that_is_no_solves_says_what_it_counts_itself():
    """``budget._counted`` special-cased the key ``intersections.ga_voxel`` because the spec
    check passed solver "fem" for the GA's overlap grid (session 45): the caller now says
    what the grid is (``check_grid(..., counts=...)``), with no key special case. Main's
    check_grid takes no ``counts`` (TypeError). The estimate is the geometry fields' (the
    same bytes as with "fem": only the voxel solver adds its own grid)."""
    from pydantic_core import PydanticCustomError

    with pytest.raises(PydanticCustomError, match=r"B each for X's grid\) needs about"):
        budget.check_grid((1e-3,) * 3, 1e-9, "geometry", key="some.key", counts="for X's grid")
    assert budget.grid_bytes([10] * 3, "geometry") == budget.grid_bytes([10] * 3, "fem")


@pytest.mark.parametrize("path", ["flow.error_estimate", "intersections.exceed_bounds"])
@pytest.mark.parametrize("value", ["no", "false", "off", "yes", 0, 1, 0.0])
def test_true_false_keys_take_only_booleans(path, value):
    """docs/spec-keys.md documents these keys as ``true | false``.  Pydantic's lax bool took
    "no", "off", 0 and 1 (an audit in session 31 ran ``error_estimate = "no"`` without an
    error), so a typo'd or quoted value silently chose a setting; numbers already refuse bools."""
    err = spec_err(with_(SPEC, path, value))
    assert err.key == path
    assert "must be true or false" in err.message and "allowed" in err.message
    for ok in (True, False):
        got = validate_spec(with_(SPEC, path, ok))
        table, key = path.split(".")
        assert got[table][key] is ok


def test_unknown_keys_suggest_the_closest():
    assert "did you mean 'viscosity'" in spec_err(with_(SPEC, "flow.viscosty", 1.0)).message
    assert "did you mean 'fibers'" in spec_err({**SPEC, "fibres": []}).message


def test_explicit_fiber_checks():
    fb = {"shape": "rod", "diameter": 7e-6}
    doc = {"rve": {"size": BOX, "voxel": 1e-6}, "fibers": [fb]}
    assert validate_spec(doc)["fibers"][0]["theta"] == 0.0
    assert spec_err(with_(doc, "fibers", [{**fb, "theta": 1e18}])).key == "fibers[0].theta"
    assert spec_err(with_(doc, "fibers", [{**fb, "diameter": 2e-4}])).key == "fibers[0].diameter"
    assert spec_err(with_(doc, "fibers", [fb] * 20000)).key == "fibers"
    far = {**fb, "center": [1e300, 0.0, 0.0]}
    assert spec_err(with_(doc, "fibers", [far])).key == "fibers[0].center[0]"
    assert spec_err(with_(doc, "fibers", [{**fb, "f": 1e300}])).key == "fibers[0].f"
    zigzag = {**fb, "shape": "bent-rod", "u": 3.0, "f": 1000.0}
    assert spec_err(with_(doc, "fibers", [zigzag])).key == "fibers[0].f"
    tiny = {**fb, "direction": [1e-300, 0.0, 0.0]}
    assert spec_err(with_(doc, "fibers", [tiny])).key == "fibers[0].direction"


def test_memory_budget_refuses_a_1200_cube_before_allocating(monkeypatch):
    doc = with_(SPEC, "rve", {"size": [1.2e-3] * 3, "voxel": 1e-6})
    doc = with_(doc, "generator.porosity", 0.9)
    monkeypatch.setattr(budget, "machine_memory", lambda: 24 * 2**30)
    err = spec_err(doc)
    assert err.key == "rve.voxel" and "1200x1200x1200" in err.message and "GiB" in err.message
    # 27.6 GB of geometry fits a 64 GiB machine, the voxel solver's 180 B per voxel does not
    monkeypatch.setattr(budget, "machine_memory", lambda: 64 * 2**30)
    validate_spec(doc)
    assert spec_err(with_(doc, "flow.solver", "voxel")).key == "rve.voxel"


def test_memory_budget_counts_the_stacked_permeameter(monkeypatch, tmp_path, capsys):
    """A 230 um cube at 1 um on the voxel route, b the solver's bytes per solved cell with
    sub-voxel walls and the permeameter's box walls (solvers.voxel.memory, 107 + 9 B): the
    permeameter with one copy adds two reservoirs of 0.2 (16 + b x 1.4 B per voxel, 2.02 GiB);
    "auto" counts 2 copies (max(16, 5 x 3) + b x 2.4 B, 3.34 GiB). A 3 GiB budget holds one
    copy but not the stack (for any b from 104 to 177 B): refused up front, naming
    flow.permeameter_copies."""
    b = budget.VOXEL_SOLVER_BYTES_PER_VOXEL
    assert 104 <= b <= 177  # the premise's range
    monkeypatch.setattr(budget, "machine_memory", lambda: 6 * 2**30)
    doc = with_(SPEC, "rve.size", [230e-6] * 3)
    doc = with_(doc, "flow", {"solver": "voxel", "bc": "permeameter"})
    n = 230.0**3
    stack, one = n * (16 + b * 2.4), n * (16 + b * 1.4)
    assert budget.grid_bytes([230] * 3, "voxel", 2, {"aux": 0.2}) == pytest.approx(stack)
    assert budget.grid_bytes([230] * 3, "voxel", 1, {"aux": 0.2}) == pytest.approx(one)
    assert one < 3 * 2**30 < stack  # the premise of the refusal below
    for copies in ("auto", 2, 3):
        err = spec_err(with_(doc, "flow.permeameter_copies", copies))
        assert err.key == "flow.permeameter_copies", copies
        assert "GiB" in err.message and "budget is 3 GiB" in err.message
    assert f"{stack / 2**30:.3g} GiB, one copy {one / 2**30:.3g} GiB" in spec_err(doc).message
    validate_spec(with_(doc, "flow.permeameter_copies", 1))
    validate_spec(with_(doc, "flow.bc", "periodic"))
    # no copy fits: the voxel size is named, the stack counted in the estimate
    monkeypatch.setattr(budget, "machine_memory", lambda: 3 * 2**30)
    err = spec_err(doc)
    assert err.key == "rve.voxel" and "2 copies stacked" in err.message
    # the CLI: exit 2, one line, nothing solved
    monkeypatch.setattr(budget, "machine_memory", lambda: 6 * 2**30)
    path = tmp_path / "big.toml"
    path.write_text(dumps(doc))
    assert main(["permeability", str(path), "--direction", "z"]) == 2
    err_lines = capsys.readouterr().err.strip().splitlines()
    assert len(err_lines) == 1 and "flow.permeameter_copies" in err_lines[0]


def test_fem_budget_counts_the_stack(monkeypatch):
    """FEM permeameter (the default), 100 um cube, lattice step 1 um: 1e6 lattice cells at
    porosity 0.8 -> about 6.5 x (2 x 0.8 + 0.4 / 3) = 11.3 M tets stacked, 6.1 M for one copy;
    solvers.fem.memory's estimate of each against a budget between them."""
    from solvers.fem.memory import estimate_memory_gb

    doc = with_(SPEC, "flow.lattice_step", 1e-6)
    two = estimate_memory_gb(int(1.5 * 1.7333e6), int(6.5 * 1.7333e6)) * 1e9
    one = estimate_memory_gb(int(1.5 * 0.9333e6), int(6.5 * 0.9333e6)) * 1e9
    assert one < 0.6 * two
    monkeypatch.setattr(budget, "machine_memory", lambda: one + two)  # budget (one + two) / 2
    err = spec_err(doc)
    assert err.key == "flow.permeameter_copies" and "1.13e+07 tets (2 copies" in err.message
    validate_spec(with_(doc, "flow.permeameter_copies", 1))
    validate_spec(with_(doc, "flow.bc", "periodic"))
    monkeypatch.setattr(budget, "machine_memory", lambda: one)
    assert spec_err(with_(doc, "flow.permeameter_copies", 1)).key == "flow.lattice_step"


def test_fiber_counts_are_capped():
    doc = copy.deepcopy(SPEC)
    del doc["generator"]["porosity"]
    assert spec_err(with_(doc, "generator.n_fibers", 1e6)).key == "generator.n_fibers"
    assert spec_err(with_(doc, "generator.n_fibers", 10**6)).key == "generator.n_fibers"
    # 600 fibers of 7 um fill 2.3 x a 100 um cube: no zero-overlap placement exists
    assert spec_err(with_(doc, "generator.n_fibers", 600)).key == "generator.n_fibers"
    ok = with_(doc, "generator.n_fibers", 600)
    ok["intersections"]["method"] = "none"  # overlapping fibers: any count
    validate_spec(ok)


def test_fast_below_the_jamming_porosity_warns():
    with pytest.warns(SpecWarning, match="jams"):
        validate_spec(with_(SPEC, "generator.porosity", 0.6))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate_spec(with_(SPEC, "generator.porosity", 0.8))
    assert spec_err(with_(SPEC, "generator.porosity", 0.05)).key == "generator.porosity"


def test_generator_reads_validated_values():
    spec = validate_spec(SPEC)
    size, voxel, period = parse_rve(spec)
    gs = parse_generator(spec, size)
    assert (gs.porosity, gs.method, gs.seed, period) == (0.8, "fast", 1, 1e-4)
    assert gs.theta.params == {"low": -5.0, "high": 5.0}


# ----------------------------------------------------------------------------- files


def test_load_spec_file_problems(tmp_path):
    p = tmp_path / "s.toml"
    p.write_bytes(b"[rve]\nsize = [1e-4, 1e-4, 1e-4]\n# \xff\xfe not utf-8\n")
    with pytest.raises(SpecError, match="not UTF-8"):
        load_spec(p)
    p.write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(SpecError, match="spec: "):
        load_spec(p)
    p.write_text("a = 1\n" * (3 * 2**20))
    with pytest.raises(SpecError, match="bytes"):
        load_spec(p)
    with pytest.raises(SpecError, match="file not found"):
        load_spec(tmp_path / "none.toml")


def test_toml_text_given_as_a_path_is_named_in_one_line(tmp_path):
    """Session 54 (walk-api 6): ``psdesign.build('[rve]\\nsize=...')`` said "spec: file not
    found: [rve]" and the text's other lines. A path that is no file and holds a newline is now
    one line saying it looks like TOML text and how to pass it (the dict of ``tomllib.loads``),
    for a spec and a study file alike; a missing file name is as before."""
    import psdesign

    text = "[rve]\nsize = [2e-5, 2e-5, 2e-5]\nvoxel = 1e-6\n"
    for call, key in ((psdesign.build, "spec"), (psdesign.load_study, "study")):
        with pytest.raises(SpecError) as info:
            call(text)
        line = str(info.value)
        assert line.startswith(f"{key}: got '[rve]") and "\n" not in line, line
        assert "looks like TOML text" in line and "tomllib.loads(text)" in line, line
    with pytest.raises(SpecError, match="^spec: file not found: .*none.toml$"):
        load_spec(str(tmp_path / "none.toml"))
    # the advice works: the dict of the same text (with a fiber) builds
    fiber = '[[fibers]]\nshape = "cylinder"\ndiameter = 8e-6\ndirection = [0, 0, 1]\n'
    m = psdesign.build(tomllib.loads(text + fiber))
    assert m.spec["rve"]["voxel"] == 1e-6


def test_a_real_spec_files_text_is_one_line_for_every_entry(tmp_path):
    """Session 54 review: a real spec's text has a '/'-separated part over 255 bytes, and
    ``Path.is_dir`` raised ENAMETOOLONG before the text check: build(<three_rods.toml's text>)
    was the 24-line "cannot read <whole text>: File name too long". Now one line for build,
    load_spec, run_study and load_study, and run_study makes no folder."""
    import psdesign

    spec = (ROOT / "studies" / "examples" / "three_rods.toml").read_text()
    study = (ROOT / "studies" / "quickstart.toml").read_text()
    assert max(len(part) for part in spec.split("/")) > 255  # the trigger, in the file itself
    out = tmp_path / "out"
    calls = (
        ("spec", lambda: psdesign.build(spec)),
        ("spec", lambda: load_spec(spec)),
        ("spec", lambda: load_spec(Path(spec))),  # the CLI's pores / diffusivity pass a Path
        ("study", lambda: psdesign.run_study(study, out, workers=0)),
        ("study", lambda: psdesign.load_study(study)),
    )
    for key, call in calls:
        with pytest.raises(SpecError) as info:
            call()
        line = str(info.value)
        assert "\n" not in line and line.startswith(f"{key}: got '# "), line
        assert "looks like TOML text" in line, line
    assert not out.exists()


def test_a_missing_file_with_an_equals_sign_is_not_found(tmp_path):
    """Session 54 review: ``a=b/nope.toml`` and ``x=1.toml`` are file names (a folder may hold
    '='), so a missing one is "file not found" (with a hint on TOML text), not "looks like TOML
    text"; an existing one reads. The CLI says the same through a str (permeability) and a Path
    (pores, diffusivity)."""
    folder = tmp_path / "a=b"
    folder.mkdir()
    (folder / "spec.toml").write_text(
        (ROOT / "studies" / "examples" / "three_rods.toml").read_text()
    )
    assert load_spec(str(folder / "spec.toml"))["rve"]["voxel"] > 0
    for name in (str(folder / "nope.toml"), "x=1.toml", "voxel=1e-6"):
        for given in (name, Path(name)):
            with pytest.raises(SpecError) as info:
                load_spec(given)
            line = str(info.value)
            assert line.startswith(f"spec: file not found: {name} (if that is TOML text"), line
            assert "tomllib.loads(text)" in line and "\n" not in line, line
    with pytest.raises(SpecError, match="^study: file not found: x=1.toml "):
        load_study("x=1.toml")


@pytest.mark.parametrize("command", ["permeability", "pores", "diffusivity", "conductivity"])
@pytest.mark.parametrize("name", ["x=1.toml", "[rve]\nvoxel = 1e-6"])
def test_cli_commands_name_a_bad_spec_path_alike(command, name, capsys):
    # permeability and conductivity pass the str, pores and diffusivity a Path (session 54)
    assert main([command, name]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    head = "file not found: x=1.toml (if" if "=1" in name else "got '[rve]\\nvoxel"
    assert err.startswith(f"psdesign: error: spec: {head}"), err


def test_deep_nesting_in_a_valid_toml_is_one_line():
    deep: dict = {}
    node = deep
    for _ in range(5000):
        node["a"] = {}
        node = node["a"]
    err = spec_err(with_(SPEC, "flow.tol", deep))
    assert err.key == "flow.tol"
    assert study_err({**STUDY, "parameters": deep})


# ----------------------------------------------------------------------------- studies


@pytest.mark.parametrize(
    "path, value, key",
    [
        ("study.seeds", list(range(100_000)), "study.seeds"),
        ("study.replicates", 100_000, "study.replicates"),
        ("study.seeds", [1, 1], "study.seeds"),
        ("study.n_samples", 8, "study.n_samples"),  # given with a factorial design
        ("study.design", "taguchi", "study.design"),
        ("study.timeout_s", "x", "study.timeout_s"),
        ("study.outputs", ["k_q"], "study.outputs"),
        ("study.workers", 3, "study.workers"),
        ("study.fields", "off", "study.fields"),  # true | false only (session 31 audit)
        ("study.fields", 1, "study.fields"),
        ("parameters.generator\\.porosity", {"low": 0.6, "high": 0.9, "levels": 1e9}, "levels"),
        ("parameters.generator\\.porosity", {"low": 0.6, "high": 0.9, "levels": 10**9}, "levels"),
        ("parameters.generator\\.layers", [1, 2], "generator.layers"),
        ("parameters.generator\\.porosity", [0.8, 0.999], "parameters.generator.porosity"),
        ("parameters.flow\\.direction", ["w"], "parameters.flow.direction"),
        ("parameters.flow\\.bc", ["open"], "parameters.flow.bc"),
        ("base.flow.direction", "w", "base.flow.direction"),
        ("base.mesh", {"a": 1}, "base.mesh"),
        ("extra", 1, "extra"),
    ],
)
def test_bad_study_names_the_key(path, value, key):
    doc = copy.deepcopy(STUDY)
    head, _, last = path.replace("\\.", "\0").rpartition(".")
    node = doc
    for p in head.split(".") if head else []:
        node = node.setdefault(p.replace("\0", "."), {})
    node[last.replace("\0", ".")] = value
    assert key in study_err(doc)


@pytest.mark.parametrize(
    "design, level",
    [
        # the first level: 'base.rve.voxel: 1e-06 m gives under 2 voxels across the thinnest
        # generated fiber' blamed the base, which is valid (its diameter is 7 um)
        ({"design": "latin-hypercube", "n_samples": 4}, {"low": 1e-6, "high": 7e-6}),
        # a later level: not refused by the study's check (left to the runner, naming a case)
        ({}, [7e-6, 1e-6]),
    ],
)
def test_a_level_that_breaks_another_key_is_named_as_the_parameter(design, level):
    """session 40 (s40-fuzz): a ``generator.diameter`` level too thin for the base's
    ``rve.voxel`` was reported as ``base.rve.voxel`` (the base is valid) or not by the study's
    check at all. Rule: the line names the key the user must change, with its level."""
    doc = copy.deepcopy(STUDY)
    doc["study"] = {**doc["study"], **design}
    doc["parameters"] = {"generator.diameter": level}
    msg = study_err(doc)
    assert msg.startswith("parameters.generator.diameter: level 1e-06 gives rve.voxel: "), msg
    assert "(allowed: <= 5e-07 m)" in msg


def test_factorial_size_is_refused_before_expansion():
    params = {"flow.viscosity": {"low": 1e-5, "high": 2e-5, "levels": 10_000}}
    params["flow.aux_length"] = {"low": 0.1, "high": 0.3, "levels": 10_000}
    msg = study_err({**STUDY, "parameters": params})
    assert msg.startswith("parameters: full factorial gives 2e+08 cases")


@pytest.mark.parametrize(
    "path, values",
    [
        ("flow.mesher", ["stuffing", "pytetwild"]),
        ("flow.lattice_step", [3e-6, 4e-6]),  # 2 um: the FEM stack is over a 24 GB budget
        ("intersections.max_ejections", [2, 6]),
        ("flow.bc", ["permeameter", "periodic"]),
        ("generator.theta.high", [5.0, 10.0]),
    ],
)
def test_study_may_vary_any_schema_key_missing_from_the_base(path, values):
    assert path in KNOWN_SPEC_KEYS
    base = copy.deepcopy(SPEC)
    base["generator"]["theta"] = {"dist": "uniform", "low": -5.0, "high": 5.0}
    st = parse_study({**STUDY, "base": base, "parameters": {path: values}})
    assert st.parameters[path].values == tuple(values)


def test_generator_layers_is_accepted_nowhere():
    assert "generator.layers" not in KNOWN_SPEC_KEYS
    assert spec_err(with_(SPEC, "generator.layers", 2)).key == "generator.layers"


def test_load_study_file_problems(tmp_path):
    p = tmp_path / "s.toml"
    p.write_bytes(b"[study]\nname = '\xff'\n")
    with pytest.raises(StudyError, match="^study: .*not UTF-8"):
        load_study(p)
    p.write_text(dumps(STUDY))
    assert tomllib.loads(p.read_text())["study"]["seeds"] == [1, 2]
    assert len(load_study(p).seeds) == 2


def test_a_byte_order_mark_is_skipped(tmp_path):
    """session 40 (s40-fuzz): a spec or study saved with a UTF-8 byte-order mark (Windows
    Notepad) was refused as 'TOML syntax error ...: Invalid statement (at line 1, column 1)',
    a character the user cannot see. It reads as the same file without the mark."""
    for name, doc, load in (("spec", SPEC, load_spec), ("study", STUDY, load_study)):
        plain, marked = tmp_path / "plain" / f"{name}.toml", tmp_path / "bom" / f"{name}.toml"
        for p in (plain, marked):
            p.parent.mkdir(exist_ok=True)
        plain.write_text(dumps(doc))
        marked.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
        a, b = load(marked), load(plain)
        if name == "study":  # the study remembers its file
            a, b = a.to_dict(), b.to_dict()
        assert a == b


def test_a_pipe_or_device_is_not_called_missing(tmp_path):
    """session 40 (s40-fuzz): ``psdesign generate /dev/null`` or a pipe (``<(cat spec)``,
    /dev/stdin) said 'spec: file not found: /dev/null': the file is there. It is named as what
    it is (the spec is read from a regular file only)."""
    import os

    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    for path in (fifo, "/dev/null"):
        with pytest.raises(SpecError, match="is not a regular file .a pipe or a device.; give a"):
            load_spec(path)


# ----------------------------------------------------------------------------- CLI


@pytest.mark.parametrize(
    "cmd",
    [["generate"], ["mesh"], ["permeability"], ["forcefield"]],
)
def test_cli_bad_spec_exit_2_one_line_nothing_written(tmp_path, capsys, cmd):
    p = tmp_path / "bad.toml"
    p.write_text(dumps(with_(SPEC, "flow.direction", "w")))
    out = tmp_path / "out"
    args = [*cmd, str(p)] + ([] if cmd == ["permeability"] else ["-o", str(out)])
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("psdesign: error: ")
    # forcefield relaxes an RVE spec's fiber set, so it validates the same keys
    assert "flow.direction: got 'w'; allowed: x, y, z" in err
    assert not out.exists()


@pytest.mark.parametrize(
    "path, value, key, said",
    [
        # a diameter in micrometres (the unit slip of a new user, session 42)
        ("generator.diameter", 7, "generator.diameter", "got 7 m"),
        ("generator.theta", 400.0, "generator.theta", "got 400 degrees"),
        ("generator.tx", 3.0, "generator.tx", "got 3"),
    ],
)
def test_an_out_of_range_number_is_said_as_given_not_as_a_distribution(path, value, key, said):
    # before session 42 a plain number read "the distribution allows [7, 7] m (truncate with
    # low/high)": a hint about distributions for a value that is none
    err = spec_err(with_(SPEC, path, value))
    assert err.key == key
    assert said in str(err) and "distribution" not in str(err), str(err)


def test_an_out_of_range_distribution_still_says_its_interval_and_how_to_narrow_it():
    doc = with_(SPEC, "generator.diameter", {"dist": "normal", "mean": 7e-6, "std": 1e-6})
    err = spec_err(doc)
    assert err.key == "generator.diameter"
    assert "the distribution allows [-inf, inf] m (truncate with low/high)" in str(err), str(err)


def test_a_study_file_given_as_a_spec_says_so(tmp_path, capsys):
    # session 42 (new user's walk): `psdesign permeability studies/quickstart.toml` answered
    # "rve: missing [rve] table with size = [x, y, z] in metres" of a file that has one, under
    # [base.rve]; the line now names the mix-up and the command that runs a study
    err = spec_err(STUDY)
    assert err.key == "rve"
    assert "this is a study file" in str(err) and "psdesign study run" in str(err)
    path = tmp_path / "sweep.toml"
    path.write_text(dumps(STUDY))
    assert main(["permeability", str(path), "--quiet"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("psdesign: error: rve: no [rve] table: this is a study file")
    # a spec without [rve] that is no study keeps its plain line
    assert "this is a study file" not in str(spec_err({"flow": {"solver": "voxel"}}))


def test_a_spec_given_as_a_study_file_says_so():
    # session 42: `psdesign study run spec.toml` answered "rve: unknown top-level key
    # (allowed: base, study, parameters)"
    msg = study_err(SPEC)
    assert msg.startswith("study: this is an RVE spec") and 'base = "FILE"' in msg
    assert "unknown top-level key" not in msg
    # the rule's allowed part, as the other mix-up lines give it (review s42-review: none)
    assert msg.endswith('(allowed: [study], [parameters] and base = "FILE")'), msg
    # a study file with a stray table still gets the unknown-key line
    assert "unknown top-level key" in study_err({**STUDY, "rve": SPEC["rve"]})


def test_a_force_field_case_given_as_a_spec_says_so():
    # session 42: `psdesign permeability studies/forcefield_two_fiber.toml` answered "rve:
    # missing [rve] table with size = [x, y, z] in metres"
    err = spec_err({"forcefield": {"case": "two-fiber"}})
    assert err.key == "rve"
    assert "force-field case spec" in str(err) and "psdesign forcefield" in str(err)


def test_a_relax_spec_given_as_a_spec_says_so(tmp_path, capsys):
    # session 42's review: `psdesign permeability studies/forcefield_woven.toml` (an RVE spec
    # with [forcefield.relax], docs/spec-keys.md: only for `psdesign forcefield`) answered
    # "forcefield.relax: unknown key (allowed: case, surface, weights, ...)", a paper case's
    # keys; the line now names the command that relaxes it and the file the others take
    doc = {**SPEC, "forcefield": {"relax": {"max_shift": 1e-6}}}
    err = spec_err(doc)
    assert err.key == "forcefield.relax"
    assert "psdesign forcefield FILE -o OUT" in str(err) and "relaxed.toml" in str(err)
    path = tmp_path / "relax.toml"
    path.write_text(dumps(doc))
    out = tmp_path / "out"
    assert main(["generate", str(path), "-o", str(out), "--quiet"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("psdesign: error: forcefield.relax: this RVE spec is one to relax")
    assert not out.exists()
    # the forcefield command itself still relaxes it (its table is read there, not here)
    assert main(["forcefield", str(path), "-o", str(out), "--no-pictures", "--quiet"]) == 0


def test_the_study_files_top_level_tables_have_one_definition():
    # session 42 added the study file's tables to the spec reader (schema.document.STUDY_TABLES,
    # to name a study file given as a spec) beside the study reader's own tuple of the same
    # three names (studyfile._parse_study's top_allowed): one list now, read by both (review)
    from psdesign.schema import document
    from psdesign.study import studyfile

    assert studyfile.STUDY_TABLES is document.STUDY_TABLES
    assert study_err({**STUDY, "extra": {}}).startswith(
        "extra: unknown top-level key (allowed: base, study, parameters)"
    )


def test_a_generated_diameter_must_be_positive_in_its_own_table():
    """Session 45 (s45-ranges left it): ``study predict --at generator.diameter=-1e-6`` made a
    prediction flagged extrapolated, because the ``> 0`` rule of a generated diameter lived
    only in the whole-spec check beside the memory budget, which a design point does not run.
    The generator table holds it now (the half-period bound needs ``rve`` and stays there): a
    spec and a design point are refused with the key and its range."""
    from psdesign.study.point import check_design_point

    base = copy.deepcopy(SPEC)
    for d in (-1e-6, 0.0):
        err = spec_err(with_(SPEC, "generator.diameter", d))
        assert err.key == "generator.diameter" and "(0, period / 2) m" in err.message, err
        with pytest.raises(SpecError, match=r"^generator.diameter: got .* m \(allowed: \(0, "):
            check_design_point({"generator.diameter": d}, {"base": base})
    check_design_point({"generator.diameter": 7e-6}, {"base": base})


def test_a_non_positive_generated_diameter_never_reaches_the_half_period_check():
    """Session 46: document.py's half-period check of ``generator.diameter`` also tested
    ``dlo > 0``, which the generator table holds since session 45; the test was dropped there.
    Proof kept here: every diameter whose support starts at or below 0 (a number, a constant, a
    distribution without a positive ``low``: normal's support is (-inf, inf), beta's [0, 1])
    and NaN are refused by ``GeneratorTable`` alone, and the whole spec names
    ``generator.diameter``; a diameter over half the period is the document's (it needs the
    rve)."""
    from pydantic import ValidationError

    from psdesign.schema.generator import GeneratorTable

    normal = {"dist": "normal", "mean": 7e-6, "std": 1e-6}
    bad = [
        -1e-6,
        0.0,
        math.nan,
        {"dist": "constant", "value": -1e-6},
        normal,
        {**normal, "low": 0.0},
        {"dist": "uniform", "low": 0.0, "high": 1e-5},
        {"dist": "beta", "a": 2, "b": 2},
    ]
    for d in bad:
        with pytest.raises(ValidationError):
            GeneratorTable(porosity=0.8, diameter=d)
        assert spec_err(with_(SPEC, "generator.diameter", d)).key == "generator.diameter", d
    GeneratorTable(porosity=0.8, diameter=BOX[0])  # positive: the table lets it through
    err = spec_err(with_(SPEC, "generator.diameter", BOX[0]))  # over half the period
    assert err.key == "generator.diameter" and "half the period" in err.message, err


def test_a_bend_range_needs_no_other_key():
    """Session 46 review: the ranges of ``generator.f`` (0, 1000] and ``generator.u``
    (-pi, pi) (psdesign.schema.fibers MAX_BENDS, a fiber's bend) need no other key but were
    checked in the model's rule after "give exactly one of porosity or n_fibers" and after
    every field, so ``check_design_point({"generator.f": 5000.0})`` and ``({"generator.u":
    4.0})`` were accepted without a word (the empty table misses its diameter: the model rule
    never ran). Each is refused now with its key and range, as a spec is; a value inside is
    accepted; the rule between keys (slope max |u| x max f <= 10) stays the bent table's."""
    from psdesign.study.point import check_design_point

    for point, allowed in (
        ({"generator.f": 5000.0}, "(0, 1000]"),
        ({"generator.f": 0.0}, "(0, 1000]"),
        ({"generator.u": 4.0}, "(-pi, pi)"),
        ({"generator.u": -3.2}, "(-pi, pi)"),
    ):
        ((key, value),) = point.items()
        with pytest.raises(SpecError) as info:
            check_design_point(point)
        assert info.value.key == key and f"(allowed: {allowed})" in str(info.value), info.value
        for kind in ("bent", "straight"):  # the range before "only with kind = 'bent'"
            gen = {**SPEC["generator"], "kind": kind, key.split(".")[1]: value}
            err = spec_err(with_(SPEC, "generator", gen))
            assert err.key == key and f"(allowed: {allowed})" in str(err), err
    check_design_point({"generator.f": 5.0, "generator.u": 0.2})
    bent = {**SPEC["generator"], "kind": "bent", "u": 0.3, "f": 50.0}  # slope 15 > 10
    err = spec_err(with_(SPEC, "generator", bent))
    assert err.key == "generator.f" and "max |u| x max f <= 10" in str(err), err
    straight = {**SPEC["generator"], "f": 5.0}
    assert "only used with kind = 'bent'" in str(spec_err(with_(SPEC, "generator", straight)))


def test_a_design_point_names_its_first_wrong_key_of_field_and_table_rules():
    """Session 46 review: pydantic's field errors (porosity < 1) stopped the model rule that
    held the generated diameter's range, so ``{"generator.diameter": -1e-6,
    "generator.porosity": 5}`` named porosity, not the first key given. Every single-key
    range of the generator is a field's own check now: both are found, the first given is
    named, in either order."""
    from psdesign.study.point import check_design_point

    diameter, porosity = ("generator.diameter", -1e-6), ("generator.porosity", 5.0)
    f, theta = ("generator.f", 5000.0), ("generator.theta", 500.0)
    for first, then in ((diameter, porosity), (porosity, diameter), (f, theta), (theta, f)):
        with pytest.raises(SpecError) as info:
            check_design_point(dict([first, then]))
        assert info.value.key == first[0], str(info.value)


def test_a_design_point_without_its_study_names_its_first_wrong_key():
    """Session 46: ``check_design_point`` called from Python without a study sets the point
    into empty tables; the generator table's "give exactly one of porosity or n_fibers" (a
    rule between keys, left out as not the point's) fired before the diameter's own rule, so
    ``{"generator.diameter": -1e-6}`` was accepted without a word. Each key's own range is now
    checked before the rules between keys, and of several wrong keys the first one given is
    named (it was the schema's field order)."""
    from psdesign.study.point import check_design_point

    for d in (-1e-6, 0.0):
        with pytest.raises(SpecError, match=r"^generator.diameter: got .* m \(allowed: \(0, "):
            check_design_point({"generator.diameter": d})
    check_design_point({"generator.diameter": 7e-6})
    with pytest.raises(SpecError, match=r"^generator.theta: got 500 degrees \(allowed: \[-360, "):
        check_design_point({"generator.theta": 500.0, "generator.diameter": 7e-6})
    seed, porosity = ("generator.seed", -1.0), ("generator.porosity", 5.0)
    for first, then in ((seed, porosity), (porosity, seed)):
        with pytest.raises(SpecError) as info:
            check_design_point(dict([first, then]))
        assert info.value.key == first[0], str(info.value)
    # the spec file alike: a generator without porosity or n_fibers names the diameter first
    gen = {"kind": "straight", "diameter": -1e-6}
    assert spec_err(with_(SPEC, "generator", gen)).key == "generator.diameter"


def test_a_design_point_in_an_array_of_tables_is_held_to_its_element():
    """review s45: ``check_design_point`` validated ``[[fibers]]`` (a list) as one table, got
    "fibers: must be a table" (a table-root error it leaves out) and let every value through:
    ``study predict --at fibers.0.diameter=-1`` on a study of studies/examples/three_rods.toml
    varying it was a prediction flagged extrapolated. Each element is held to its table now,
    in the words a spec gets (``fibers[0].diameter: must be > 0``)."""
    from psdesign.study.point import check_design_point

    with open("studies/examples/three_rods.toml", "rb") as f:
        rods = tomllib.load(f)
    study = parse_study(
        {
            "base": rods,
            "study": {"design": "full-factorial", "outputs": ["porosity", "k_z"]},
            "parameters": {"fibers.0.diameter": [1.5e-5, 2e-5], "rve.size.2": [1e-4, 1.2e-4]},
        }
    ).to_dict()
    check_design_point({"fibers.0.diameter": 1.7e-5, "rve.size.2": 1.1e-4}, study)
    for d in (-1.0, 0.0):
        with pytest.raises(SpecError, match=r"^fibers\[0\]\.diameter: must be > 0, got "):
            check_design_point({"fibers.0.diameter": d, "rve.size.2": 1.1e-4}, study)
    with pytest.raises(SpecError, match=r"^rve\.size\[2\]: must be >= 1e-09"):
        check_design_point({"fibers.0.diameter": 1.7e-5, "rve.size.2": -1.0}, study)
    # an element the point does not set is not its refusal
    study["base"]["fibers"][1]["diameter"] = -1.0
    check_design_point({"fibers.0.diameter": 1.7e-5, "rve.size.2": 1.1e-4}, study)


def test_the_bc_models_are_one_list():
    """Session 48 (re-read of session 47): ``flow.bc``'s models were written five times (the
    schema's Literal, ``flow.permeability.BC_MODELS``, each route's ``BC_MODELS`` and ``BCS``).
    Now the schema holds the one list; every route names it, and the spec refuses a sixth."""
    from psdesign.flow import fem, voxel
    from psdesign.flow.permeability import supported_bc
    from psdesign.schema import flow

    assert flow.BC_MODELS == ("permeameter", "periodic")
    assert fem.BC_MODELS is flow.BC_MODELS and voxel.BC_MODELS is flow.BC_MODELS
    assert supported_bc("fem") == supported_bc("voxel") == flow.BC_MODELS
    assert flow.FlowTable(bc="periodic").bc == "periodic"
    with pytest.raises(ValueError, match="permeameter"):
        flow.FlowTable(bc="dirichlet")


def test_the_routes_refusals_list_solvers_and_bc_models_from_the_one_list():
    """Review s48: after ``BC_MODELS`` became one list, the refusals still spelled it by hand
    ("flow.bc must be 'permeameter' or 'periodic'" in flow.permeability and flow.fem, "solver
    must be 'fem' or 'voxel'" in flow.permeability and flow.compare, a plain ValueError in
    flow.voxel) and benchmarks/solver_agreement.py kept its own SOLVERS and BCS. Each line now
    is schema.flow.check_solver_bc's, listing schema.flow's lists, a SpecError naming its key."""
    from conftest import load_benchmark

    import psdesign
    from psdesign.flow.compare import permeability_both_bc
    from psdesign.flow.fem import permeability_fem
    from psdesign.flow.voxel import permeability_voxel
    from psdesign.schema import flow

    rod = {"shape": "cylinder", "diameter": 6e-6, "center": [1e-5] * 3, "direction": [0, 0, 1]}
    m = psdesign.build({"rve": {"size": [2e-5] * 3, "voxel": 2e-6}, "fibers": [rod]})
    bc_line = f"flow.bc: must be one of {', '.join(flow.BC_MODELS)}, got 'open'"
    solver_line = f"flow.solver: must be one of {', '.join(flow.SOLVERS)}, got 'lbm'"
    assert bc_line == "flow.bc: must be one of permeameter, periodic, got 'open'"
    assert solver_line == "flow.solver: must be one of fem, voxel, got 'lbm'"
    calls = [
        (lambda: psdesign.permeability(m.rve, m.fields, "z", {"bc": "open"}), bc_line),
        (lambda: psdesign.permeability(m.rve, m.fields, "z", {}, solver="lbm"), solver_line),
        (lambda: permeability_both_bc(m.rve, m.fields, "z", {}, solver="lbm"), solver_line),
        (lambda: permeability_fem(m.rve, m.fields, "z", {"bc": "open"}), bc_line),
        (lambda: permeability_voxel(m.fields, "z", {"bc": "open"}), bc_line),
    ]
    for call, line in calls:
        with pytest.raises(SpecError) as info:
            call()
        assert str(info.value) == line
        assert info.value.key == line.partition(":")[0]
    bench = load_benchmark("solver_agreement")
    assert bench.SOLVERS is flow.SOLVERS and bench.BC_MODELS is flow.BC_MODELS
    assert not hasattr(bench, "BCS")


@pytest.mark.parametrize(
    ("shape", "key", "value"),
    [
        ("rod", "isovalue", -2.0),  # the rod's isovalue is rod_isovalue(diameter)
        ("cylinder", "isovalue", -2.0),
        ("bent-rod", "isovalue", -2.0),
        ("woven", "diameter", 7e-6),  # a fixed shape's size is its equation's and isovalue's
        ("compressed-rod-a", "diameter", 7e-6),
        ("woven", "f", 3.0),  # a fixed shape's bend scale is its equation's
        ("compressed-bent", "f", 3.0),
        # u = 0: no bend for f to scale; accepted and ignored until mendff2 (session 53)
        ("rod", "f", 3.0),
        ("cylinder", "f", 3.0),
    ],
)
def test_a_key_the_fibers_shape_ignores_is_refused(shape, key, value):
    """walk-paper (session 53): these keys were read and silently had no effect (the walker's
    rod with isovalue -2.0 built the same rod as without; a woven fiber with f = 3 the same
    woven fiber), while ``u`` on a rod was already refused. Exit 2, one line naming the key
    and the shapes that take it."""
    fb = {"shape": shape, key: value}
    if shape in ("rod", "cylinder", "bent-rod"):
        fb["diameter"] = 7e-6
    doc = {"rve": {"size": BOX, "voxel": 1e-6}, "fibers": [fb]}
    err = spec_err(doc)
    assert err.key == f"fibers[0].{key}"
    assert f"not used by shape = '{shape}'" in str(err)
    takes = "woven" if key == "isovalue" else "bent-rod"
    assert takes in str(err)
    del fb[key]
    out = validate_spec(doc)["fibers"][0]  # without it: valid, and the same spec again
    assert validate_spec(with_(doc, "fibers", [out]))["fibers"][0] == out
    assert ("f" in out) == (shape == "bent-rod")


def test_a_fiber_along_an_axis_is_bounded_by_the_edges_across_it_only():
    """A cylinder along z never meets the z faces: its diameter may equal the z edge (16 um in
    a 32 x 32 x 16 um box), and the voxel porosity is the exact 1 - pi r^2 / A = 0.8037 within
    its error. Along x the same diameter crosses the 16 um z edge: refused, one line naming
    the key. Session 53 (walk-transport finding 6): the z-fibre was refused 'not below the
    cell (< 1.6e-05 m)'."""
    from psdesign.packing.build import build_rve

    fiber = {"shape": "cylinder", "diameter": 16e-6, "center": [16e-6, 16e-6, 8e-6]}
    rve = {"size": [32e-6, 32e-6, 16e-6], "voxel": 1e-6}
    spec = validate_spec({"rve": rve, "fibers": [{**fiber, "direction": [0, 0, 1]}]})
    fields = build_rve(spec).voxelize(1e-6)
    exact = 1 - math.pi * 8.0**2 / 32**2
    assert abs(fields.porosity - exact) <= fields.porosity_error
    with pytest.raises(SpecError) as exc:
        validate_spec({"rve": rve, "fibers": [{**fiber, "direction": [1, 0, 0]}]})
    assert exc.value.key == "fibers[0].diameter" and "not below the cell" in str(exc.value)


@pytest.mark.parametrize(
    "orient", [{"direction": [1, 0, 0]}, {"theta": 0, "omega": 0}, {}, {"theta": 360}]
)
def test_a_fiber_along_x_is_one_rule_however_its_orientation_is_spelled(orient):
    """The cylinder above laid along x (a 16 x 32 x 32 um box, diameter 16 um = the x edge):
    ``direction = [1, 0, 0]``, ``theta = omega = 0``, no key (the default, along x) and
    ``theta = 360`` place the same fibre (``placement_rotation``), so each is accepted and
    gives the exact porosity 1 - pi r^2 / A = 0.8037 within its error; tilted 45 degrees it
    crosses the 16 um x edge: refused. Session 53 review: only ``direction`` was read, so
    the theta/omega spellings were refused 'not below the cell'."""
    from psdesign.packing.build import build_rve

    fiber = {"shape": "cylinder", "diameter": 16e-6, "center": [8e-6, 16e-6, 16e-6]}
    rve = {"size": [16e-6, 32e-6, 32e-6], "voxel": 1e-6}
    spec = validate_spec({"rve": rve, "fibers": [{**fiber, **orient}]})
    fields = build_rve(spec).voxelize(1e-6)
    exact = 1 - math.pi * 8.0**2 / 32**2
    assert abs(fields.porosity - exact) <= fields.porosity_error
    with pytest.raises(SpecError) as exc:
        validate_spec({"rve": rve, "fibers": [{**fiber, "theta": 45}]})
    assert exc.value.key == "fibers[0].diameter" and "< 1.6e-05 m" in str(exc.value)
