"""docs/architecture.md lists every module of psdesign/ and solvers/ (and nothing that is gone)."""

from __future__ import annotations

import ast
import re

from conftest import REPO_ROOT


def test_architecture_lists_every_module() -> None:
    doc = (REPO_ROOT / "docs" / "architecture.md").read_text()
    listed = set(re.findall(r"^- `([^`]+\.py)`", doc, flags=re.M))
    modules = {
        str(p.relative_to(REPO_ROOT))
        for root in ("psdesign", "solvers")
        for p in (REPO_ROOT / root).rglob("*.py")
    }
    assert modules - listed == set(), "add these to docs/architecture.md"
    assert listed - modules == set(), "these are listed but do not exist"


# ------------------------------------------------- the stages do not import the CLI layer
#: The modules that may import ``psdesign.cli``: the CLI itself and ``python -m psdesign``.
CLI_LAYER = ("psdesign/cli/", "psdesign/__main__.py")


def _imported(node: ast.AST, package: str) -> list[str]:
    """The absolute module names an import statement (or an ``importlib.import_module`` /
    ``__import__`` call with a literal name) inside ``package`` reaches: ``from a import b``
    gives ``a`` and ``a.b`` (``b`` may be a module), a relative import is resolved against
    ``package``."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if isinstance(node, ast.ImportFrom):
        base = node.module or ""
        if node.level:
            parts = package.split(".")
            parts = parts[: len(parts) - node.level + 1]
            base = ".".join([*parts, *([node.module] if node.module else [])])
        return [base, *(f"{base}.{a.name}" for a in node.names)]
    if isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
        f = node.func
        name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
        if name in ("import_module", "__import__") and isinstance(node.args[0].value, str):
            return [node.args[0].value]
    return []


def cli_imports(source: str, module: str) -> list[int]:
    """The lines of ``source`` (the module ``module``, dotted) that import ``psdesign.cli`` or
    a module of it, at module level or inside a function, in any form."""
    is_package = module.endswith(".__init__")
    package = module.removesuffix(".__init__") if is_package else module.rpartition(".")[0]

    def is_cli(name: str) -> bool:
        return name == "psdesign.cli" or name.startswith("psdesign.cli.")

    return sorted(
        node.lineno
        for node in ast.walk(ast.parse(source))
        if any(is_cli(n) for n in _imported(node, package))
    )


def test_the_cli_import_finder_sees_every_form() -> None:
    """The finder below must see each way to spell the import (a lazy one inside a function
    included: 22 stage modules imported the CLI so until session 52, unseen by this file)."""
    found = [
        "import psdesign.cli",
        "import psdesign.cli.progress as p",
        "from psdesign.cli import progress",
        "from psdesign.cli.exit_status import TRUSTED",
        "from psdesign import cli",
        "def f():\n    from psdesign.cli.lines import value_text",
        "class A:\n    def f(self):\n        import psdesign.cli.main",
        "import importlib\nimportlib.import_module('psdesign.cli.study')",
        "from ..cli import progress",  # in psdesign.report
        "from .. import cli",
    ]
    for src in found:
        assert cli_imports(src, "psdesign.report.html"), src
    assert cli_imports("from . import lines", "psdesign.cli.__init__")  # a package's own
    not_found = [
        "import psdesign.client",
        "from psdesign import clip",
        "from psdesign.status import TRUSTED",
        "from . import cli",  # psdesign.report.cli, not psdesign.cli
        "x = 'psdesign.cli.progress'",
    ]
    for src in not_found:
        assert not cli_imports(src, "psdesign.report.html"), src


def test_no_stage_imports_the_cli_layer() -> None:
    """docs/architecture.md: ``psdesign/cli/`` is a thin layer over the stages, so no module
    outside it imports it, at module level or inside a function (the stages imported its
    progress printer, status words and result lines until session 52: they now live in
    ``psdesign/progress.py``, ``psdesign/status.py``, ``psdesign/lines.py`` and the transport
    modules)."""
    offenders = []
    for root in ("psdesign", "solvers"):
        for p in sorted((REPO_ROOT / root).rglob("*.py")):
            rel = p.relative_to(REPO_ROOT).as_posix()
            if rel.startswith(CLI_LAYER):
                continue
            module = rel.removesuffix(".py").replace("/", ".")
            offenders += [f"{rel}:{n}" for n in cli_imports(p.read_text(), module)]
    assert offenders == [], "import these from the stage or package root module instead"


# ------------------------------------------ one name per definition: no module-level alias
def own_aliases(source: str) -> list[str]:
    """The module-level ``B = A`` of ``source`` where ``A`` is a name the module itself
    defined above (an assignment, function or class; an imported name re-exported under the
    module's own name is not one), as ``"B = A"``: a second name of one definition."""
    defined: set[str] = set()
    found = []
    for node in ast.parse(source).body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            defined.add(node.name)
        if not isinstance(node, ast.Assign | ast.AnnAssign):
            continue
        targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        names = [t.id for t in targets if isinstance(t, ast.Name)]
        if isinstance(node.value, ast.Name) and node.value.id in defined:
            found += [f"{n} = {node.value.id}" for n in names]
        defined.update(names)
    return found


def test_the_alias_finder_sees_an_own_alias_only() -> None:
    """The finder of the test below, on snippets: an alias of the module's own constant or
    function is found; a re-exported import, a new value and a call are not."""
    assert own_aliases("_OPTS = {}\n_CHUNK_OPTS = _OPTS\n") == ["_CHUNK_OPTS = _OPTS"]
    assert own_aliases("def f(): pass\ng: object = f\n") == ["g = f"]
    assert own_aliases("from a import B\nC = B\nD = dict(B)\nE = {**B}\n") == []


def test_no_module_defines_a_second_name_for_its_own_definition() -> None:
    """Project rule: one definition of each concept. Session 53: ``solvers/voxel/kernels.py``
    kept ``_CHUNK_OPTS = _OPTS`` (from session 50, once a different options dict), a dead
    second name a reader had to resolve; removed, and none may come back unnoticed."""
    offenders = []
    for root in ("psdesign", "solvers"):
        for p in sorted((REPO_ROOT / root).rglob("*.py")):
            rel = p.relative_to(REPO_ROOT).as_posix()
            offenders += [f"{rel}: {a}" for a in own_aliases(p.read_text())]
    assert offenders == [], "use the one name"
