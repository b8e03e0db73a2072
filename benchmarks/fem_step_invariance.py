"""Session 54 femmem: the FEM's default lattice step of every study spec, before and after the
memory estimate's recalibration (``solvers/fem/memory.py``, ``budget.DEFAULT_STEP_UNKNOWNS``).

Every ``studies/**.toml`` study (each case of its design) and spec is validated with
``flow.solver = "fem"``, periodic and permeameter, no ``flow.lattice_step``; the arguments of
each ``budget.fem_lattice_step`` call are collected and the step is computed by the old rule
(``tests/unit/test_lattice_step.py``'s written-out estimate before session 54 with its 11 GiB)
and the new one, on the reference machine's budget (half of 23.54 GiB) and on a 64 GiB one.

Usage::

    PYTHONPATH=. python benchmarks/fem_step_invariance.py
"""

from __future__ import annotations

import copy
import glob
import importlib.util
import json
import tomllib
from pathlib import Path

import pytest

from psdesign.schema import budget
from psdesign.schema.spec import validate_spec
from psdesign.study.design import expand_design
from psdesign.study.studyfile import load_study

ROOT = Path(__file__).resolve().parents[1]


def _old_rule():
    """``_old_and_new_step`` of the unit test (the one written-out old rule)."""
    path = ROOT / "tests" / "unit" / "test_lattice_step.py"
    spec = importlib.util.spec_from_file_location("test_lattice_step", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod._old_and_new_step


def _specs(path: str) -> list[dict]:
    try:
        return [c.spec for c in expand_design(load_study(path))]
    except Exception:  # noqa: BLE001 - not a study: a spec, or neither (force-field cases)
        return [tomllib.loads(Path(path).read_text())]


def collect() -> list[tuple]:
    """The distinct ``fem_lattice_step`` argument tuples of the study specs."""
    calls: set[str] = set()
    plan = budget.fem_lattice_step

    def spy(size, *args, **kw):
        calls.add(json.dumps([list(size), *args[:5]]))
        return plan(size, *args, **kw)

    budget.fem_lattice_step = spy
    try:
        for path in sorted(glob.glob(str(ROOT / "studies" / "**" / "*.toml"), recursive=True)):
            for spec in _specs(path):
                for bc in ("periodic", "permeameter"):
                    doc = copy.deepcopy(spec)
                    flow = doc.setdefault("flow", {})
                    for key in ("lattice_step", "max_memory_gb", "mesher"):
                        flow.pop(key, None)
                    flow.update(solver="fem", bc=bc)
                    try:
                        validate_spec(doc)
                    except Exception:  # noqa: BLE001, S112 - a spec the FEM refuses plans no step
                        continue
    finally:
        budget.fem_lattice_step = plan
    return [tuple([tuple(c[0]), *c[1:]]) for c in map(json.loads, sorted(calls))]


def main() -> None:
    compare = _old_rule()
    with pytest.MonkeyPatch.context() as mp:
        rows = collect()
        differ = coarsened = 0
        for args in rows:
            for gib in (23.54 / 2, 64 / 2):
                old, new = compare(mp, args, gib * 2**30)
                coarsened += old[1] is not None
                same = old[0] == new[0] and (old[1] is None) == (new[1] is None)
                differ += not same
                if old[1] is not None or not same:
                    print(f"{args} machine/2 {gib:.2f} GiB: old {old[0]:.6g} new {new[0]:.6g}")
    print(f"{len(rows)} step plans x 2 machines: {coarsened} coarsened, {differ} differ")


if __name__ == "__main__":
    main()
