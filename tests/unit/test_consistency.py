"""The docs key tables and the schema agree: every schema key is documented, every documented
key exists in the schema, and docs/spec-keys.md is the generated text."""

from __future__ import annotations

import re
import typing
from pathlib import Path

import pytest
from pydantic import BaseModel

from psdesign.schema.distributions import DIST_MODELS
from psdesign.schema.docs import render
from psdesign.schema.document import SpecDocument
from psdesign.schema.study import BoundsParam, RangeParam, StudyTable
from psdesign.study.studyfile import KNOWN_SPEC_KEYS

DOC = Path(__file__).resolve().parents[2] / "docs" / "spec-keys.md"
KEY_CELL = re.compile(r"^\| `([^`]+)` \|", re.M)


def _models(tp) -> list[type[BaseModel]]:
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [tp]
    return [m for a in typing.get_args(tp) for m in _models(a)]


def _walk(model: type[BaseModel], prefix: str) -> set[str]:
    """Every key under ``model`` (independent of psdesign.schema.keys)."""
    out = set()
    for name, info in model.model_fields.items():
        out.add(prefix + name)
        if typing.get_origin(info.annotation) is dict:
            continue
        for sub in _models(info.annotation):
            if sub not in DIST_MODELS.values():
                out |= _walk(sub, f"{prefix}{name}.")
    return out


def schema_keys() -> set[str]:
    keys = set()
    for name, info in SpecDocument.model_fields.items():
        prefix = f"{name}[]." if name == "fibers" else f"{name}."
        keys.add(name)
        for sub in _models(info.annotation):
            keys |= _walk(sub, prefix)
    keys |= {f"<dist>.{k}" for m in DIST_MODELS.values() for k in m.model_fields}
    keys |= {"base", "study", "parameters"}
    keys |= _walk(StudyTable, "study.") | _walk(RangeParam, "<range>.")
    keys |= _walk(BoundsParam, "<bounds>.")
    return keys


def documented_keys() -> set[str]:
    return set(KEY_CELL.findall(DOC.read_text()))


def test_every_schema_key_is_documented_and_every_documented_key_exists():
    schema = schema_keys() - set(SpecDocument.model_fields)  # tables are the section titles
    docs = documented_keys()
    assert schema - docs == set(), "undocumented keys"
    assert docs - schema == set(), "documented keys missing from the schema"
    for table in SpecDocument.model_fields:
        assert f"## [{table}]" in DOC.read_text()


def test_docs_file_is_the_generated_text():
    assert DOC.read_text() == render(), "run: python -m psdesign.schema.docs > docs/spec-keys.md"


def test_study_parameter_paths_come_from_the_schema():
    spec_keys = {k for k in schema_keys() if k.split(".")[0] in ("rve", "generator", "flow")}
    spec_keys |= {k for k in schema_keys() if k.startswith("intersections.")}
    assert spec_keys <= KNOWN_SPEC_KEYS
    for key in KNOWN_SPEC_KEYS:
        table, _, rest = key.partition(".")
        assert table in SpecDocument.model_fields
        head = rest.split(".")[0]
        if head:
            assert head in _models(SpecDocument.model_fields[table].annotation)[0].model_fields


def test_forcefield_names_are_the_schemas_one_definition():
    # session 40: the force field code took its own copies of the names (checked equal here);
    # it now uses the schema's, and the paper's Table II tables are keyed by them
    from psdesign.forcefield import cases, potentials
    from psdesign.schema import forcefield as schema_ff

    assert cases.SIX_NAMES is schema_ff.SIX_NAMES
    assert potentials.SURFACE_TERMS is schema_ff.SURFACE_TERMS
    assert list(cases.TABLE_II_INITIAL) == list(schema_ff.SIX_NAMES) == list(cases.TABLE_II_RANGE)


def test_every_documented_key_states_what_is_allowed():
    # docs/spec-keys.md is what a user reads for a key's range; main's [transport] rows had an
    # empty 'allowed' column (the table's fields had no descriptions)
    rows = re.findall(r"^\| `([^`]+)` \| [^|]* \|([^|\n]*)\|$", DOC.read_text(), re.M)
    assert len(rows) == len(documented_keys())
    assert [key for key, allowed in rows if not allowed.strip()] == []


def test_transport_numbers_are_checked_like_every_other_table():
    # the [transport] table took strings ("1e-6") and whole floats for integers (pydantic's
    # lax mode) where every other table refuses them, and said "Input should be less than 1,
    # got nan" for a NaN, without the allowed range
    import math

    import pytest

    from psdesign.errors import SpecError
    from psdesign.schema.transport import validate_transport

    for table, key, text in [
        ({"tol": "1e-6"}, "transport.tol", "must be a number"),
        ({"tol": math.nan}, "transport.tol", "must be a finite number"),
        ({"n_radii": 16.0}, "transport.n_radii", "must be an integer"),
        ({"max_iter": True}, "transport.max_iter", "must be an integer"),
        ({"tool": 1e-6}, "transport.tool", "did you mean 'tol'"),
    ]:
        with pytest.raises(SpecError) as info:
            validate_transport({"transport": table})
        assert info.value.key == key and text in info.value.message
        assert "allowed" in info.value.message
    assert validate_transport({"transport": {"tol": 1e-6, "n_radii": 8}})["n_radii"] == 8


#: Keys whose table row need show no default: required (or one of two), an alternative to keys
#: that have one, a table, an optional cap or limit that is off when left out, or a key whose
#: default depends on its distribution or design (docs/study-files.md, the distribution module).
NO_DEFAULT = {
    "rve.size",
    "generator.porosity",
    "generator.n_fibers",
    "generator.diameter",
    "generator.orientation",
    "fibers[].direction",
    "intersections.max_shift_z",
    "intersections.time_limit_s",
    "flow.max_memory_gb",
    "forcefield.case",
    "forcefield.two_fiber",
    "forcefield.six_fiber",
    "image.threshold",
    "image.crop",
    "base",
    "parameters",
    "study.csv",
    "study.n_samples",
    "study.seeds",
    "study.replicates",
    "study.timeout_s",
    *(f"<range>.{k}" for k in ("start", "stop", "step")),
    *(f"<bounds>.{k}" for k in ("low", "high", "levels")),
    *(f"<dist>.{k}" for k in ("a", "b", "dist", "high", "low", "mean", "std", "value")),
}
ROW = re.compile(r"^\| `([^`]+)` \| ([^|]*) \| (.*) \|$", re.M)


def test_every_key_with_a_code_default_shows_it():
    """Walkthrough (session 53): README says docs/spec-keys.md lists "every key ... with its
    default", but 7 keys the code fills in showed none (intersections.max_rotation_deg 1 deg,
    orientation_tries 4, max_ejections 6, objective 'analytic', angle_range_deg 1 deg,
    shift_range 0.1, flow.tol 1e-6). Truth: what the code applies to a spec without them
    (the fast placement's settings, the GA's, the generator's draws, the FEM solve's options);
    every other key shows a default (its column or a "default ..." in its text) unless listed
    in NO_DEFAULT."""
    from psdesign.flow.fem import _solver_options
    from psdesign.packing.ga_settings import GASettings
    from psdesign.packing.generators import _fast_options, parse_generator

    rows = {k: (d.strip(), a) for k, d, a in ROW.findall(DOC.read_text())}
    spec = {
        "rve": {"size": [1e-4] * 3, "voxel": 1e-6},
        "generator": {"porosity": 0.8, "diameter": 7e-6, "kind": "bent"},
        "intersections": {"method": "fast"},
    }
    gs = parse_generator(spec, None)
    fast, ga = _fast_options(gs, 0.0), GASettings()
    applied = {
        "intersections.max_rotation_deg": fast.max_rotation_deg,
        "intersections.orientation_tries": fast.orientation_tries,
        "intersections.max_ejections": fast.max_ejections,
        "intersections.exceed_bounds": fast.exceed,
        "intersections.exceed_rotation_deg": fast.exceed_rotation_deg,
        **{f"intersections.{k}": getattr(ga, k) for k in ("objective", "population")},
        **{f"intersections.{k}": getattr(ga, k) for k in ("generations", "shift_range")},
        "intersections.angle_range_deg": ga.angle_range_deg,
    }
    assert applied == {
        "intersections.max_rotation_deg": 1.0,
        "intersections.orientation_tries": 4,
        "intersections.max_ejections": 6,
        "intersections.exceed_bounds": True,
        "intersections.exceed_rotation_deg": 5.0,
        "intersections.objective": "analytic",
        "intersections.population": 24,
        "intersections.generations": 40,
        "intersections.shift_range": 0.1,
        "intersections.angle_range_deg": 1.0,
    }  # the walkthrough's reading of the code (generators.py:469-471, ga_settings.py:44-51)
    for key, value in applied.items():
        assert rows[key][0] == repr(value), key
    tol = _solver_options({}, "z").tol
    assert tol == 1e-6 and rows["flow.tol"][0].startswith(f"{tol!r} ")
    for key, dist in [("theta", gs.theta), ("omega", gs.omega), ("tz", gs.t[2]), ("f", gs.f)]:
        lo, hi = dist.params["low"], dist.params["high"]
        assert rows[f"generator.{key}"][0] == f"uniform [{lo:g}, {hi:g}]", key
    missing = [
        k
        for k, (default, allowed) in rows.items()
        if not default and "default" not in allowed and "required" not in allowed
    ]
    assert sorted(set(missing) - NO_DEFAULT) == [], "show the code's default (keys.code_defaults)"


def test_woven_cell_defaults_applied_are_the_ones_documented(monkeypatch):
    """Review s53 (mendrev2): docs/spec-keys.md read a woven cell's defaults from woven_cell's
    signature, while FiberTable.to_spec applied its own (``or "z"``, ``or 1``, ``or (0.0,
    0.0)``) and schema/spec.py had a third copy: changing one moved the doc or the RVE, not
    both. Truth: a change of WOVEN_DEFAULTS moves the value applied to a spec without the key
    (the validated dict, and the woven_cell it builds: 6 fibers a layer) and the doc's
    default together; woven_cell's own keyword defaults equal it."""
    import inspect

    from psdesign.geometry.fibers import woven_cell
    from psdesign.schema import fibers
    from psdesign.schema.keys import code_defaults
    from psdesign.schema.spec import explicit_fibers

    params = inspect.signature(woven_cell).parameters
    assert {k: params[k].default for k in fibers.WOVEN_DEFAULTS} == fibers.WOVEN_DEFAULTS
    for key, value in (("layers", 3), ("thickness_axis", "x"), ("layer_shift", (0.25, 0.5))):
        monkeypatch.setitem(fibers.WOVEN_DEFAULTS, key, value)
        fb = fibers.FiberTable(shape="woven-cell").to_spec()
        assert fb[key] == (list(value) if key == "layer_shift" else value), key
        assert code_defaults()[f"fibers[].{key}"] == repr(value), key
    spec = {"rve": {"size": [1e-4] * 3, "period": None}, "fibers": [{"shape": "woven-cell"}]}
    assert len(explicit_fibers(spec)) == 6 * 3  # spec.py's fallback is the same dict


def test_ga_budget_and_max_shift_doc_read_the_one_definition(monkeypatch):
    """Review s53 (mendrev2): the spec check held a GA to ``population or 24`` x ``generations
    or 40``, a second copy of GASettings' defaults, and intersections.max_shift's text said
    "default 0.1 of the period" apart from PAPER_MAX_SHIFT. Truth: with other GA defaults the
    check refuses the work they make (10000 x 100000 x fibers, over budget.MAX_GA_WORK), and
    the doc's max_shift default is the fraction the fast placement applies."""
    from psdesign.errors import SpecError
    from psdesign.packing.ga_settings import PAPER_MAX_SHIFT, GASettings
    from psdesign.packing.generators import _fast_options, parse_generator
    from psdesign.schema import document
    from psdesign.schema.spec import validate_document

    spec = {
        "rve": {"size": [1e-4] * 3, "voxel": 1e-6},
        "generator": {"porosity": 0.8, "diameter": 7e-6},
        "intersections": {"method": "ga"},
    }
    validate_document(spec)  # the shipped defaults: within the budget
    big = GASettings(population=10_000, generations=100_000)
    monkeypatch.setattr(document, "GASettings", lambda: big)
    with pytest.raises(SpecError, match=r"population 10000 x generations 100000 x about \d+"):
        validate_document(spec)
    spec["intersections"]["method"] = "fast"
    assert _fast_options(parse_generator(spec, None), 0.0).max_shift == PAPER_MAX_SHIFT
    rows = {k: a for k, _, a in ROW.findall(DOC.read_text())}
    assert f"(default {PAPER_MAX_SHIFT:g} of the period" in rows["intersections.max_shift"]
