"""Every study and spec file shipped in studies/ loads, expands and validates.

A broken shipped file is a user-facing defect (a study that fails on its first case), so
every case of every study is validated down to the generator, which rejects kind-specific
keys (e.g. ``f`` for straight fibers) only when it parses the ``[generator]`` table.
"""

import tomllib
from pathlib import Path

import numpy as np
import pytest

from psdesign.forcefield.run import load_forcefield_spec
from psdesign.packing.generators import parse_generator, parse_rve
from psdesign.schema.spec import load_spec, validate_spec
from psdesign.study import expand_design, load_study

STUDIES = Path(__file__).resolve().parents[2] / "studies"
FILES = sorted(STUDIES.rglob("*.toml"))


def _kind(path: Path) -> str:
    data = tomllib.loads(path.read_text())
    if "study" in data:
        return "study"
    if "forcefield" in data:
        return "forcefield"
    return "spec"


def _check_rve_spec(spec: dict) -> None:
    spec = validate_spec(spec)
    if "generator" in spec:
        size = np.asarray(parse_rve(spec)[0], float)
        parse_generator(spec, size)


def test_the_studies_folder_is_not_empty():
    kinds = {_kind(p) for p in FILES}
    assert {"study", "spec", "forcefield"} <= kinds


@pytest.mark.parametrize("path", FILES, ids=[str(p.relative_to(STUDIES)) for p in FILES])
def test_shipped_file_is_valid(path: Path):
    kind = _kind(path)
    if kind == "forcefield":
        load_forcefield_spec(path)
    elif kind == "spec":
        _check_rve_spec(load_spec(path))
    else:
        cases = expand_design(load_study(path))
        assert cases
        for case in cases:
            _check_rve_spec(case.spec)
