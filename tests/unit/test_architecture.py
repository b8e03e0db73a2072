"""docs/architecture.md lists every module of psdesign/ and solvers/ (and nothing that is gone)."""

from __future__ import annotations

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
