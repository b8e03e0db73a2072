"""Wall times apart from the results: a record file and its ``<stem>_timings.json``.

The product's rule is that the same spec and seed give identical output files.  Wall times
(and counts that follow them, :data:`TIMING_DEPENDENT`) are the one thing a rerun changes, so
a record (``summary.json`` of ``generate`` and ``forcefield``, ``mesh.json``, the force
field's ``rve.json``) is written without them and its timings go to a file beside it
(``summary_timings.json``, ``mesh_timings.json``): two runs' folders then differ only there
(and in the hidden ``.psdesign-output.json`` marker).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

#: Record keys whose values follow the machine's timing, not the spec and seed: the force
#: field's ``n_speculative`` (poll points still running in a worker when a better one was
#: accepted) was 3 in one run's rve.json and 2 in the next of the same spec (audit s36).
TIMING_DEPENDENT = frozenset({"n_speculative"})


def is_timing(key: str) -> bool:
    """A wall-time key (``wall_time_s``, any ``*_time_s``) or a count that follows the
    timing (:data:`TIMING_DEPENDENT`): kept out of the record, in its timings file.

    >>> is_timing("wall_time_s"), is_timing("placement_time_s"), is_timing("time_limit_s")
    (True, True, False)
    >>> is_timing("n_speculative"), is_timing("n_evals")
    (True, False)
    """
    return key.endswith("_time_s") or key in TIMING_DEPENDENT


def split_timings(record: dict) -> tuple[dict, dict]:
    """``(record without its wall-time keys, those keys)``, nested dicts alike, also the dicts
    of a list (one per GA round in ``generate``'s ``summary.json``: their ``wall_time_s`` made
    the file differ between two runs of the same spec until session 42); a dict or list left
    empty of timings is dropped from the second, a list's entries keep their positions.

    >>> split_timings({"porosity": 0.8, "wall_time_s": 1.2, "ga": {"n": 3, "placement_time_s": 4}})
    ({'porosity': 0.8, 'ga': {'n': 3}}, {'wall_time_s': 1.2, 'ga': {'placement_time_s': 4}})
    >>> split_timings({"ga": [{"n": 10, "wall_time_s": 2.6}, {"n": 9, "wall_time_s": 3.9}]})
    ({'ga': [{'n': 10}, {'n': 9}]}, {'ga': [{'wall_time_s': 2.6}, {'wall_time_s': 3.9}]})
    """
    kept: dict[str, Any] = {}
    times: dict[str, Any] = {}
    for key, value in record.items():
        if is_timing(str(key)):
            times[key] = value
        elif isinstance(value, dict):
            kept[key], inner = split_timings(value)
            if inner:
                times[key] = inner
        elif isinstance(value, list) and any(isinstance(v, dict) for v in value):
            pairs = [split_timings(v) if isinstance(v, dict) else (v, {}) for v in value]
            kept[key] = [k for k, _ in pairs]
            if any(t for _, t in pairs):
                times[key] = [t for _, t in pairs]
        else:
            kept[key] = value
    return kept, times


def timings_name(name: str) -> str:
    """The timings file of record file ``name``: ``summary.json`` -> ``summary_timings.json``."""
    path = Path(name)
    return f"{path.stem}_timings{path.suffix}"


def write_record(folder: Path, name: str, record: dict) -> dict:
    """Write ``record`` to ``folder / name`` without its wall times and those to
    :func:`timings_name` beside it (atomically, :func:`psdesign.io.atomic.write_json`);
    returns the record as written."""
    from psdesign.io.atomic import write_json

    kept, times = split_timings(record)
    write_json(folder / name, kept)
    write_json(folder / timings_name(name), times)
    return kept
