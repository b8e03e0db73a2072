"""Property-based fuzzing of the validation entry points (issue 11, item 3).

Hypothesis builds malformed specs and studies from valid ones by one mutation that makes them
invalid by construction (a value no key accepts, a value outside the key's documented bounds,
an unknown key or table, a missing required key, an unreachable porosity, a bad parameter
form) and throws them at ``validate_spec``, ``load_spec``, ``parse_study``, ``load_study`` and
the CLI (in process). Each must end with ONE clean line naming the key, never a traceback.
About 650 inputs, well under 30 s.
"""

from __future__ import annotations

import contextlib
import copy
import io
import math
import tempfile
import typing
import warnings
from pathlib import Path

import annotated_types as at
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from toml_writer import dumps

from psdesign.cli.main import main
from psdesign.errors import SpecError
from psdesign.forcefield.run import load_forcefield_spec
from psdesign.schema.document import SpecDocument
from psdesign.schema.forcefield import ForceFieldTable
from psdesign.schema.spec import load_spec, validate_spec
from psdesign.schema.study import StudyTable
from psdesign.study.studyfile import StudyError, load_study, parse_study

BOX = [100e-6, 100e-6, 100e-6]
GEN_SPEC = {
    "rve": {"size": BOX, "voxel": 1e-6},
    "generator": {"kind": "straight", "porosity": 0.8, "diameter": 7e-6, "seed": 1},
    "intersections": {"method": "fast", "max_ejections": 6},
    "flow": {"solver": "fem", "viscosity": 1.8e-5, "aux_length": 0.2},
}
FIBER_SPEC = {
    "rve": {"size": BOX, "voxel": 1e-6},
    "fibers": [{"shape": "rod", "diameter": 7e-6, "center": [5e-5, 5e-5, 5e-5], "theta": 0.0}],
    "flow": {"solver": "voxel"},
}
STUDY = {
    "base": GEN_SPEC,
    "study": {"name": "fz", "design": "full-factorial", "seeds": [1, 2], "outputs": ["k_z"]},
    "parameters": {"flow.aux_length": [0.1, 0.2]},
}
FAST = settings(
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


def _table_fields(name: str) -> dict:
    model = typing.get_args(SpecDocument.model_fields[name].annotation)
    model = next(m for m in (model or (SpecDocument.model_fields[name].annotation,)) if m)
    while typing.get_origin(model) is list:
        model = typing.get_args(model)[0]
    return model.model_fields


def _bounds(info) -> list[float]:
    """Numbers just outside a field's documented bounds (from its pydantic constraints)."""
    out = []
    stack = [info.annotation]
    while stack:
        tp = stack.pop()
        stack += list(typing.get_args(tp))
        for m in getattr(tp, "__metadata__", ()):
            if isinstance(m, at.Interval):
                if m.gt is not None:
                    out.append(float(m.gt) - abs(float(m.gt)) - 1.0)
                    out.append(float(m.gt))
                if m.ge is not None:
                    out.append(float(m.ge) - abs(float(m.ge)) * 0.5 - 1.0)
                if m.lt is not None:
                    out.append(float(m.lt))
                if m.le is not None:
                    out.append(float(m.le) * 2 + 1.0)
    return out


def _takes_bool(info) -> bool:
    """Switch keys (``flow.error_estimate``) accept booleans: they are not 'always bad' there."""
    return "bool" in str(info.annotation)


#: (path, table, field info) of every key of the tables a mutation may hit (switch keys are
#: left out: the "always bad" values include booleans).
LEAVES = [
    (t, k, info)
    for t in ("rve", "generator", "intersections", "flow", "forcefield")
    for k, info in _table_fields(t).items()
    if not _takes_bool(info)
]
FIBER_LEAVES = list(_table_fields("fibers").items())
deep = {"a": 1}
for _ in range(200):  # the 5000-deep case is a regression test in test_schema.py
    deep = {"a": deep}
#: Values no key of the spec accepts.
ALWAYS_BAD = st.one_of(
    st.booleans(),
    st.sampled_from([math.nan, math.inf, -math.inf, deep, [deep], [{"zz": 1}], [[[]]]]),
    st.dictionaries(st.text("zqxj_", min_size=2, max_size=6), st.integers(), min_size=1),
    st.text(min_size=0, max_size=8)
    .filter(lambda s: s not in ("x", "y", "z"))
    .map(lambda s: "~" + s),
)
NAME = st.text("abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=12)


@st.composite
def bad_specs(draw) -> tuple[dict, str]:
    """(malformed spec, key prefix the error must name)."""
    base = copy.deepcopy(draw(st.sampled_from([GEN_SPEC, FIBER_SPEC])))
    kind = draw(st.integers(0, 7))
    if kind <= 2:  # a value no key accepts / outside its bounds, at any key of any table
        table, key, info = draw(st.sampled_from(LEAVES))
        bad = _bounds(info) if kind == 2 else []
        value = draw(st.sampled_from(bad)) if bad else draw(ALWAYS_BAD)
        if table == "rve" and key == "size":
            value = draw(st.sampled_from([[1e-4, 1e-4], [1e-4, 0.0, 1e-4], [1e300] * 3, value]))
        base.setdefault(table, {})[key] = value
        return base, table
    if kind == 3:  # an explicit fiber with a bad key
        key, info = draw(st.sampled_from(FIBER_LEAVES))
        bad = _bounds(info)
        value = draw(st.sampled_from(bad)) if bad and draw(st.booleans()) else draw(ALWAYS_BAD)
        base["fibers"] = [{"shape": "rod", "diameter": 7e-6, key: value}]
        return base, "fibers"
    if kind == 4:  # unknown key in a table, or unknown table
        name = draw(NAME)
        table = draw(st.sampled_from(["rve", "flow", "intersections", "generator", None]))
        if table is None:
            name = name if name not in SpecDocument.model_fields else name + "_x"
            base[name] = draw(st.one_of(st.integers(), st.just({"a": 1}), st.text()))
            return base, name
        fields = _table_fields(table)
        name = name if name not in fields else name + "_x"
        base.setdefault(table, {})[name] = draw(st.integers())
        return base, table
    if kind == 5:  # a table that is not a table
        table = draw(st.sampled_from(["rve", "flow", "intersections", "generator", "fibers"]))
        base[table] = draw(st.one_of(st.integers(), st.text(max_size=5), st.just([1, 2])))
        return base, table
    if kind == 6:  # missing required things
        which = draw(st.sampled_from(["rve", "size", "fibers"]))
        if which == "rve":
            del base["rve"]
        elif which == "size":
            del base["rve"]["size"]
        else:
            base.pop("generator", None)
            base["fibers"] = []
        return base, "rve" if which != "fibers" else "fibers"
    # cross-field: unreachable porosity, fiber wider than the box, too few voxels per fiber
    choice = draw(st.sampled_from(["porosity", "wide", "voxel", "period"]))
    if choice == "porosity":
        base = copy.deepcopy(GEN_SPEC)
        base["generator"]["porosity"] = draw(st.floats(0.9962, 0.99999))
        return base, "generator.porosity"
    if choice == "wide":
        base = copy.deepcopy(FIBER_SPEC)
        base["fibers"][0]["diameter"] = draw(st.floats(1e-4, 1.0))
        return base, "fibers"
    if choice == "period":
        base["rve"]["period"] = draw(st.sampled_from([1.0, 1e-6, 5e-6, 1e3]))
        return base, "rve.period"
    base["rve"]["voxel"] = draw(st.floats(3.6e-6, 2.5e-5))
    return base, "rve.voxel"


def _check(msg: str, key: str) -> None:
    assert "\n" not in msg and "Traceback" not in msg
    assert msg.split(":", 1)[0].replace("base.", "", 1).startswith(key), (key, msg)


def _spec_error(doc: dict) -> SpecError:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(SpecError) as ei:
            validate_spec(doc)
    return ei.value


@settings(FAST, max_examples=300)
@given(bad_specs())
def test_fuzz_validate_spec(case):
    doc, key = case
    err = _spec_error(doc)
    _check(str(err), key)
    assert "allowed" in err.message or "missing" in err.message or "give" in err.message


@settings(FAST, max_examples=80)
@given(bad_specs())
def test_fuzz_load_spec_file(case):
    doc, key = case
    try:
        text = dumps(doc)
    except (TypeError, RecursionError):  # not writable as TOML
        return
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "spec.toml"
        p.write_text(text)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with pytest.raises(SpecError) as ei:
                load_spec(p)
    assert "\n" not in str(ei.value)


STUDY_FIELDS = list(StudyTable.model_fields)


@st.composite
def bad_studies(draw) -> tuple[dict, str]:
    """(malformed study, key prefix the error must name)."""
    doc = copy.deepcopy(STUDY)
    kind = draw(st.integers(0, 5))
    if kind == 0:  # a bad [study] value
        key = draw(st.sampled_from(STUDY_FIELDS))
        value = draw(ALWAYS_BAD)
        if key in ("name", "description", "csv") and isinstance(value, str):
            value = [value]
        doc["study"][key] = value
        if key == "csv":
            return doc, "study"
        return doc, "study"
    if kind == 1:  # counts over the budget
        key, value = draw(
            st.sampled_from(
                [
                    ("seeds", list(range(5000))),
                    ("replicates", 10**6),
                    ("n_samples", 10),
                    ("timeout_s", -1.0),
                    ("design_seed", -3),
                    ("seeds", [1, 1]),
                    ("outputs", []),
                ]
            )
        )
        doc["study"][key] = value
        return doc, "study"
    if kind == 2:  # bad parameter forms
        value = draw(
            st.sampled_from(
                [
                    [],
                    1.0,
                    "x",
                    True,
                    {"low": 0.3, "high": 0.1},
                    {"low": 0.1, "high": 0.3},  # bounds without levels in a factorial
                    {"low": 0.1, "high": 0.3, "levels": 1e9},
                    {"low": 0.1, "high": 0.3, "levels": 10**9},
                    {"start": 0.3, "stop": 0.1, "step": 0.1},
                    {"start": 0.0, "stop": 1.0, "step": 1e-12},
                    {"start": 0.1, "stop": 0.3, "step": "x"},
                    [0.1, -5.0],
                    [0.1, "wide"],
                ]
            )
        )
        doc["parameters"] = {"flow.aux_length": value}
        return doc, "parameters"
    if kind == 3:  # unknown parameter path or top-level key
        name = draw(NAME)
        if draw(st.booleans()):
            doc["parameters"] = {f"generator.{name}_q": [1, 2]}
            return doc, "parameters"
        doc[name + "_q"] = 1
        return doc, name + "_q"
    if kind == 4:  # the base spec is malformed (outside the varied flow table)
        spec, key = draw(bad_specs())
        if key.startswith("flow") or "flow" not in spec or not isinstance(spec["flow"], dict):
            spec = copy.deepcopy(GEN_SPEC)
            spec["rve"]["voxel"] = "fine"
            key = "rve"
        spec["flow"] = {**spec["flow"], "aux_length": 0.2}
        doc["base"] = spec
        return doc, "" if key.startswith("rve") and "rve" not in spec else key
    # structure
    which = draw(st.sampled_from(["no-study", "study-str", "no-base", "base-int", "params-list"]))
    if which == "no-study":
        del doc["study"]
        return doc, "study"
    if which == "study-str":
        doc["study"] = "x"
        return doc, "study"
    if which == "no-base":
        del doc["base"]
        return doc, "base"
    if which == "base-int":
        doc["base"] = 3
        return doc, "base"
    doc["parameters"] = [1, 2]
    return doc, "parameters"


def _study_error(doc: dict) -> str:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(StudyError) as ei:
            parse_study(doc)
    return str(ei.value)


@settings(FAST, max_examples=200)
@given(bad_studies())
def test_fuzz_parse_study(case):
    doc, key = case
    msg = _study_error(doc)
    assert "\n" not in msg
    if key:
        assert key in msg.split(" ", 1)[0] or msg.startswith(key), (key, msg)


@settings(FAST, max_examples=40)
@given(st.one_of(bad_studies(), bad_specs().map(lambda c: ({**STUDY, "base": c[0]}, ""))))
def test_fuzz_load_study_file(case):
    doc, _ = case
    try:
        text = dumps(doc)
    except (TypeError, RecursionError):  # not writable as TOML
        return
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "study.toml"
        p.write_text(text)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                load_study(p)
            except StudyError as exc:
                assert "\n" not in str(exc)
                return
    # a spec mutation under the varied key may be deferred to the per-case check
    assert "flow" in doc.get("base", {})


def _cli(args: list[str]) -> tuple[int, str]:
    buf = io.StringIO()
    with contextlib.redirect_stderr(buf), contextlib.redirect_stdout(io.StringIO()):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rc = main(args)
    return rc, buf.getvalue()


@settings(FAST, max_examples=60)
@given(bad_specs(), st.sampled_from(["generate", "mesh", "permeability"]))
def test_fuzz_cli_spec(case, command):
    doc, _ = case
    try:
        text = dumps(doc)
    except (TypeError, RecursionError):  # not writable as TOML
        return
    with tempfile.TemporaryDirectory() as d:
        p, out = Path(d) / "spec.toml", Path(d) / "out"
        p.write_text(text)
        args = [command, str(p)] + ([] if command == "permeability" else ["-o", str(out)])
        rc, err = _cli(args)
        assert rc == 2
        assert len(err.strip().splitlines()) == 1 and err.startswith("psdesign: error: ")
        assert not out.exists()


@settings(FAST, max_examples=40)
@given(bad_studies())
def test_fuzz_cli_study(case):
    doc, _ = case
    try:
        text = dumps(doc)
    except (TypeError, RecursionError):  # not writable as TOML
        return
    with tempfile.TemporaryDirectory() as d:
        p, out = Path(d) / "study.toml", Path(d) / "out"
        p.write_text(text)
        rc, err = _cli(["study", "run", str(p), "-o", str(out), "--quiet", "--no-report"])
        assert rc == 2, err
        assert len(err.strip().splitlines()) == 1 and err.startswith("psdesign: error: ")
        assert not out.exists()


FF = {"case": "two-fiber", "max_iter": 50, "two_fiber": {"seed": 5}, "quadrature": {"h": 0.01}}


@st.composite
def bad_forcefields(draw) -> dict:
    doc = copy.deepcopy(FF)
    key, info = draw(st.sampled_from(list(ForceFieldTable.model_fields.items())))
    bad = _bounds(info)
    doc[key] = draw(st.sampled_from(bad)) if bad and draw(st.booleans()) else draw(ALWAYS_BAD)
    if draw(st.booleans()):
        doc[draw(NAME) + "_q"] = 1
    return doc


@settings(FAST, max_examples=60)
@given(bad_forcefields())
def test_fuzz_load_forcefield_spec(doc):
    try:
        text = dumps({"forcefield": doc})
    except (TypeError, RecursionError):
        return
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "ff.toml"
        p.write_text(text)
        with pytest.raises(SpecError) as ei:
            load_forcefield_spec(p)
    assert "\n" not in str(ei.value) and str(ei.value).startswith(("forcefield", "spec"))
