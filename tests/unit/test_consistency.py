"""The docs key tables and the schema agree: every schema key is documented, every documented
key exists in the schema, and docs/spec-keys.md is the generated text."""

from __future__ import annotations

import re
import typing
from pathlib import Path

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
