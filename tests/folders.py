"""Comparing two output folders of the same command (the product's rule: same spec and seed ->
identical output files)."""

from __future__ import annotations

from pathlib import Path

#: The hidden marker: byte-identical too since session 32 (it carried an ``updated_at``).
MARKER = ".psdesign-output.json"


def assert_identical_folders(a: Path, b: Path, record: str, timings: str) -> None:
    """Both folders hold the same files, ``record``, its ``timings`` file and the marker among
    them, and every file but ``timings`` is byte-identical."""
    files = sorted(p.name for p in a.iterdir())
    assert files == sorted(p.name for p in b.iterdir())
    varying = {timings}
    assert varying <= set(files) and {record, MARKER} <= set(files)
    for f in set(files) - varying:
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
