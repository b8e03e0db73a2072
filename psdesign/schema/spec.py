"""RVE spec files (TOML): load, validate, and build explicit fibers.

The schema (:class:`psdesign.schema.document.SpecDocument` and its tables) is the single
description of the spec; every check raises :class:`~psdesign.errors.SpecError` naming the key
and the allowed range, before anything is built. Lengths are in metres.
"""

from __future__ import annotations

import copy
import os
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from psdesign.errors import SpecError, short
from psdesign.geometry.fibers import Fiber, make_fiber
from psdesign.schema.document import SpecDocument, SpecWarning
from psdesign.schema.errors import spec_error
from psdesign.schema.fibers import BENT_FIXED_SHAPES, CELL_SHAPES, WOVEN_DEFAULTS, FiberTable
from psdesign.schema.flow import DEFAULT_FLOW, FlowTable

__all__ = [
    "CELL_SHAPES",
    "DEFAULT_FLOW",
    "FIBER_KEYS",
    "FLOW_KEYS",
    "KNOWN_TABLES",
    "MAX_FILE_BYTES",
    "RVE_KEYS",
    "SpecWarning",
    "explicit_fibers",
    "load_spec",
    "read_toml",
    "validate_document",
    "validate_spec",
]

#: Tables an RVE spec may hold (derived from the schema).
KNOWN_TABLES = tuple(SpecDocument.model_fields)
RVE_KEYS = ("size", "voxel", "period")
FIBER_KEYS = tuple(FiberTable.model_fields)
FLOW_KEYS = tuple(FlowTable.model_fields)
#: Spec and study files larger than this are refused unread.
MAX_FILE_BYTES = 10 * 2**20
#: What to give instead of TOML text where a spec or study file's path is asked for.
_AS_TEXT = "give a file's path or, in Python, the dict tomllib.loads(text) makes of the text"


def read_toml(path: str | Path, key: str = "spec", error: type[Exception] = SpecError) -> dict:
    """Parse a TOML file; every problem is one ``error`` line (no traceback).

    Missing or unreadable file, over :data:`MAX_FILE_BYTES`, not UTF-8, TOML syntax,
    nesting too deep for the parser. A leading UTF-8 byte-order mark is skipped. A path that
    is no file and holds a line break is refused as TOML text (session 54), before anything
    asks the file system (a real spec's text has parts over 255 bytes: ``Path.is_dir`` raised
    "File name too long", and the refusal quoted the whole text); a missing file whose name
    holds ``=`` is "file not found" with a hint, since ``a=b/spec.toml`` is a valid path. The
    API takes a path or a dict, and ``tomllib.loads(text)`` makes the dict (text is not taken
    as TOML, so that a mistyped path never parses as one).
    """

    def bad(msg: str) -> Exception:
        return error(key, msg) if error is SpecError else error(f"{key}: {msg}")

    name = str(path)
    # os.path.isfile never raises (False for a name too long or with a NUL byte); a str and a
    # Path say the same (the CLI's pores / diffusivity pass a Path, the others a str)
    if ("\n" in name or "\r" in name) and not os.path.isfile(name):
        # TOML text given as the path: "file not found: [rve]\nsize=..." spanned lines
        raise bad(f"got {short(name)}, which looks like TOML text, not a file name; {_AS_TEXT}")
    p = Path(path)
    try:
        if p.is_dir():
            raise bad(f"{p} is a folder; give a TOML file")
        if p.exists() and not p.is_file():  # /dev/stdin, a pipe <(...), /dev/null
            raise bad(f"{p} is not a regular file (a pipe or a device); give a TOML file")
        if not p.is_file():
            hint = f" (if that is TOML text, not a file name: {_AS_TEXT})" if "=" in name else ""
            raise bad(f"file not found: {p}{hint}")
        if p.stat().st_size > MAX_FILE_BYTES:
            raise bad(f"{p} is {p.stat().st_size} bytes (allowed: at most {MAX_FILE_BYTES})")
        # a UTF-8 byte-order mark (Windows Notepad writes one) is no TOML: tomllib's "Invalid
        # statement (at line 1, column 1)" pointed at a character the user cannot see
        text = p.read_bytes().decode("utf-8").removeprefix("\ufeff")
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise bad(f"TOML syntax error in {p}: {exc}") from None
    except UnicodeDecodeError as exc:
        raise bad(f"{p} is not UTF-8 text (byte {exc.start})") from None
    except RecursionError:
        raise bad(f"{p} nests tables or arrays too deeply (allowed: a few levels)") from None
    except OSError as exc:
        raise bad(f"cannot read {p}: {exc.strerror or exc}") from None


def load_spec(path: str | Path, flow: dict | None = None) -> dict:
    """Read and validate an RVE spec file.

    ``flow``: ``[flow]`` keys a command line chose (``--solver``, ``--mesher``), set before
    the validation, so that the up-front checks are those of the route that will run (a spec
    written for the FEM run with ``--solver voxel`` was refused by the FEM's checks, naming
    FEM keys).

    Raises
    ------
    SpecError
        Missing or unreadable file, TOML syntax error, or a bad value.
    """
    data = read_toml(path)
    chosen = {k: v for k, v in (flow or {}).items() if v is not None}
    if chosen and isinstance(data.get("flow", {}), dict):
        data["flow"] = {**data.get("flow", {}), **chosen}
    return validate_spec(data, base=Path(path).parent)


def validate_document(data: Any, base: str | Path | None = None) -> SpecDocument:
    """Validate a parsed spec against the schema; returns the typed document.

    ``base`` is the folder relative ``[image]`` paths start from (the spec file's; default
    the current folder).

    Raises
    ------
    SpecError
        The first problem, as ``key: message (allowed: ...)``.
    """
    if not isinstance(data, dict):
        raise SpecError("spec", f"must be a TOML table, got {type(data).__name__}")
    try:
        return SpecDocument.model_validate(data, context={"base": base})
    except ValidationError as exc:
        raise spec_error(exc, SpecDocument) from None
    except MemoryError:
        if "image" in data:  # the validator reads the image (its box and voxel)
            raise SpecError(
                "image.path",
                "the image does not fit in memory: read a part (image.crop)",
                names=("image.crop",),
            ) from None
        raise SpecError("spec", "cannot validate: out of memory") from None
    except (RecursionError, OverflowError) as exc:
        raise SpecError(
            "spec",
            f"cannot validate ({type(exc).__name__}): nested too deeply or numbers too large",
        ) from None


def validate_spec(data: dict, base: str | Path | None = None) -> dict:
    """Validate a parsed spec and fill defaults; returns a new plain dict.

    The shape is the one the pipeline reads: ``rve`` = ``{size, voxel, period}`` (voxel
    filled), ``fibers`` = list of fiber dicts, ``flow`` = defaults plus the keys given,
    ``generator``/``intersections``/``forcefield`` as given (validated). With ``[image]``
    (relative ``path`` from ``base``, default the current folder): ``image`` with the
    absolute path, format and voxel size filled in, ``rve`` the image's box and voxel,
    ``flow.wall_treatment = "staircase"`` (an image has no analytic surface).
    """
    doc = validate_document(data, base)
    skip = ("rve", "fibers", "flow", "image")
    spec = {k: _plain(copy.deepcopy(v)) for k, v in data.items() if k not in skip}
    period = doc.rve.period if doc.rve is not None else None
    spec["rve"] = {"size": list(doc.size), "voxel": doc.voxel, "period": period}
    spec["fibers"] = [fb.to_spec() for fb in doc.fibers]
    spec["flow"] = doc.flow.to_spec()
    if doc.image is not None:
        spec["image"] = doc.image.to_spec()
        spec["flow"].setdefault("wall_treatment", "staircase")
    return spec


def check_flow_override(spec: dict, flow: dict) -> None:
    """Validate ``spec`` again with the ``[flow]`` table ``flow`` (its own with a caller's
    overrides: ``--solver`` / ``--bc`` / ``--sides``, or ``Material.permeability``'s keywords)
    when it differs from the spec's, before any work: the memory budget and the route's own
    checks depend on the solver and bc (a spec written for the FEM with ``solver = "voxel"``
    given skipped the voxel solver's budget, and a 15 GiB solve started). ``SpecError``."""
    if flow != spec["flow"]:
        validate_spec({**spec, "flow": flow})


def check_directions(spec: dict, flow: dict, directions: Iterable[str]) -> None:
    """:func:`check_flow_override` with ``flow.direction`` pinned to each of ``directions``
    (``"x"``, ``"y"``, ``"z"``), before any work: along a direction an ``"auto"``
    permeameter of explicit fibers or of an image counts the copies it will stack
    (:func:`psdesign.schema.plan.planned_flow`; alone the spec counts the fewest over the axes; an
    image's mask is read once, ``psdesign.image.load.load_mask`` keeps it). Skipped for a
    generated RVE, whose copies are known once built.

    Parameters
    ----------
    spec : dict
        A validated spec.
    flow : dict
        Its ``[flow]`` table as the route runs it (the command's or method's solver and bc).
    directions : iterable of str
        The directions the route solves.

    Raises
    ------
    SpecError
        The first check that fails, naming its key (a memory refusal of the planned stack).
    """
    from psdesign.schema.plan import pinned_direction

    if "generator" in spec:
        return
    with pinned_direction():  # plan along d, not the fewest copies over the axes
        for d in directions:
            validate_spec({**spec, "flow": {**flow, "direction": d}})


def _plain(value: Any) -> Any:
    """``value`` with NumPy scalars and arrays (a notebook's spec dict) as Python numbers and
    lists, so that the validated spec is plain JSON data like a TOML file's."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()  # Python numbers, nested lists for an array
    return value


def explicit_fibers(spec: dict) -> list[Fiber]:
    """Build the ``[[fibers]]`` of a validated spec (normalized coordinates)."""
    size = np.asarray(spec["rve"]["size"])
    ref = spec["rve"]["period"] or float(size.max())
    fibers = []
    for i, fb in enumerate(spec["fibers"]):
        if fb["shape"] == "woven-cell":
            from psdesign.geometry.fibers import woven_cell, woven_cell_centre

            fibers.extend(
                woven_cell(
                    fb.get("thickness_axis", WOVEN_DEFAULTS["thickness_axis"]),
                    fb.get("layers", WOVEN_DEFAULTS["layers"]),
                    tuple(fb.get("layer_shift", WOVEN_DEFAULTS["layer_shift"])),
                    woven_cell_centre(size / ref),  # the box centre, as the other shapes'
                )
            )
            continue
        center = np.asarray(fb.get("center", size / 2)) / ref
        try:
            fibers.append(
                make_fiber(
                    fb["shape"],
                    diameter=fb.get("diameter", 0.0) / ref or None,
                    center=center,
                    theta=fb.get("theta"),
                    omega=fb.get("omega"),
                    direction=fb.get("direction"),
                    u=fb.get("u", 0.0),
                    f=fb.get("f", 1.0),
                    isovalue=fb.get("isovalue"),
                    minor_moment=fb.get("u") if fb["shape"] in BENT_FIXED_SHAPES else None,
                )
            )
        except SpecError as exc:  # make_fiber's own argument: fibers[i].diameter
            raise SpecError(f"fibers[{i}].{exc.key}", exc.message) from None
        except ValueError as exc:
            raise SpecError(f"fibers[{i}]", str(exc)) from None
    return fibers
