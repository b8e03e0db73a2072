"""The brief's code-style rule "no function over ~100 lines or ~8 parameters without a reason",
counted on the source (session 42): lines = ``end_lineno - lineno + 1`` of the ``def`` (docstring
included), parameters without ``self`` / ``cls``.

Compiled kernels take flat arrays for a reason (numba has no objects to group them in); they are
left out (``solvers/voxel/`` holds the voxel solver's kernels and their drivers, and any function
with a numba or ``parallel_kernel`` decorator). Before session 42 four functions were over 100
lines (``solve_voxel_stokes`` 131, ``pattern_search`` 123, ``genetic`` 114, ``_fast_porosity``
107) and ``place_sequential``, ``genetic``, ``pattern_search`` and ``solve_voxel_stokes`` took
15-17 parameters. The line rule covers ``benchmarks/`` too (session 43: ``bench_study.main`` 177,
``bench_voxel.kernels`` 111, ``bench_compile.kernels_side_by_side`` 106 before).
"""

from __future__ import annotations

import ast
import dataclasses
import re

import pytest
from conftest import REPO_ROOT

#: Public functions with more than eight parameters not yet grouped or given a reason (none
#: after session 42; see benchmarks/RESULTS.md, "Session 42: function size and parameters").
LEFT: set[str] = set()

#: A stated reason: one line of the docstring such as "(Nine parameters: ...)".
REASON = re.compile(r"^\((\w+) parameters: ", re.M)


def _functions(roots: tuple[str, ...] = ("psdesign", "solvers")):
    """``(name, node)`` of every function under ``roots`` outside the kernels."""
    for root in roots:
        for path in sorted((REPO_ROOT / root).rglob("*.py")):
            rel = path.relative_to(REPO_ROOT).as_posix()
            if rel.startswith("solvers/voxel/"):
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                    decorators = " ".join(ast.unparse(d) for d in node.decorator_list)
                    if not re.search(r"jit|parallel_kernel|vectorize", decorators):
                        yield f"{rel}::{node.name}", node


def _parameters(node: ast.FunctionDef) -> tuple[int, int]:
    """(all parameters, those that can be given by position), ``self`` / ``cls`` aside."""
    a = node.args
    positional = [p.arg for p in a.posonlyargs + a.args if p.arg not in ("self", "cls")]
    n = len(positional) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)
    return n, len(positional)


def test_no_function_over_100_lines() -> None:
    long = {
        name: node.end_lineno - node.lineno + 1
        for name, node in _functions(("psdesign", "solvers", "benchmarks"))
        if node.end_lineno - node.lineno + 1 > 100
    }
    assert long == {}, "split these into named steps"


def test_many_parameters_are_grouped_or_keyword_only_with_a_reason() -> None:
    seen, bad = set(), {}
    for name, node in _functions():
        n, positional = _parameters(node)
        if n <= 8 or node.name.startswith("_"):
            continue
        seen.add(name)
        if name in LEFT:
            continue
        doc = ast.get_docstring(node) or ""
        if positional > 6 or not REASON.search(doc):
            bad[name] = (n, positional)
    assert bad == {}, "group settings into a dataclass, or keyword-only plus a reason line"
    assert LEFT <= seen, f"no longer over eight parameters, drop from LEFT: {LEFT - seen}"


@pytest.mark.parametrize(
    "module, name, example",
    [
        ("psdesign.packing.ga_settings", "GASettings", {"population": 10}),
        ("psdesign.packing.placement_settings", "PlacementSettings", {"gap": 0.01}),
        ("psdesign.forcefield.search_settings", "SearchSettings", {"min_step": 1e-6}),
    ],
)
def test_settings_are_frozen_data(module: str, name: str, example: dict) -> None:
    import importlib

    cls = getattr(importlib.import_module(module), name)
    settings = cls(**example)
    assert dataclasses.replace(settings) == settings
    key = next(iter(example))
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(settings, key, example[key])
