"""Comparing two output folders of the same command (the product's rule: same spec and seed ->
identical output files)."""

from __future__ import annotations

from pathlib import Path

#: Files that differ between identical runs: the hidden marker (its ``updated_at``).
MARKER = ".psdesign-output.json"


def assert_identical_folders(a: Path, b: Path, record: str, timings: str) -> None:
    """Both folders hold the same files, ``record`` and its ``timings`` file among them, and
    every file but ``timings`` and the marker is byte-identical."""
    files = sorted(p.name for p in a.iterdir())
    assert files == sorted(p.name for p in b.iterdir())
    varying = {timings, MARKER}
    assert varying <= set(files) and record in files
    for f in set(files) - varying:
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
