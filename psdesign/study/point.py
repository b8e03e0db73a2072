"""A design point held to the schema key by key (``study predict --at``), before any work.

A point is the values of a study's parameters (``{"generator.porosity": 0.82}``). Each value
is set into the study's base spec and the table holding it is validated by the schema
(:mod:`psdesign.schema`, the one definition of every key's range): an error at the point's
key, or at a table above it (``generator.theta`` for ``generator.theta.high``), is the
point's. Errors of keys the point does not set (an image the study read from a folder that
has moved) and the checks between tables (the memory budget, a diameter against the voxel)
are left out: they say nothing of the value asked about, and a prediction needs no memory.
"""

from __future__ import annotations

import warnings
from typing import Any

from pydantic import ValidationError

from psdesign.errors import SpecError
from psdesign.schema.errors import spec_errors
from psdesign.schema.keys import table_model
from psdesign.study.design import apply_params
from psdesign.study.studyfile import _under

__all__ = ["check_design_point"]

#: Whole floats up to here are checked as ints (an integer key refuses a float, ``12.0``).
_EXACT_INT = 2**53


def _as_typed(v: float) -> Any:
    """``5.0`` -> ``5``: a whole number as an int, so that an integer key accepts it and a
    refusal says ``got 5`` as typed."""
    return int(v) if float(v).is_integer() and abs(v) <= _EXACT_INT else float(v)


def check_design_point(point: dict[str, float], study: dict | None = None) -> None:
    """Refuse a design point a value of which the schema does not allow.

    Parameters
    ----------
    point : dict
        Dotted spec path -> number (``{"generator.porosity": 0.82}``); a path that is not a
        spec table's (a case function's own column) is not checked.
    study : dict, optional
        The ``study`` table of the study's ``study.json``
        (:meth:`~psdesign.study.studyfile.Study.to_dict`): its ``base`` spec, into which the
        point is set, and ``solver`` (a ``[flow]`` key of one solver is checked against the
        study's). Without it the point is set into empty tables: each key's own range is
        checked, not the rules of its table that need the other keys (a distribution's
        support, ``generator.theta`` in [-360, 360]).

    Raises
    ------
    SpecError
        The first key of ``point`` (in the order given) of the errors the schema reports
        together, in the schema's words (each key's own range is reported with the others';
        a table's rules between keys run only once each of its keys passed):
        ``generator.porosity: must be < 1, got 5 (allowed: target in (0, 1): ...)``.

    Examples
    --------
    >>> check_design_point({"generator.porosity": 0.82})
    >>> check_design_point({"generator.porosity": 5.0})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    psdesign.errors.SpecError: generator.porosity: must be < 1, got 5 (allowed: ...
    """
    study = study or {}
    base = study.get("base") or {}
    spec = apply_params(base, {p: _as_typed(v) for p, v in point.items()})
    if study.get("solver") and isinstance(spec.get("flow"), dict):  # as the study ran it
        spec["flow"] = {**spec["flow"], "solver": study["solver"]}
    found = _point_errors(spec, point, bool(base))
    for path in point:  # the first wrong key as the point gives them, not as the schema does
        for err, above in found:
            # at the point's key, or a table above it (not the table's own rules: give one of
            # porosity or n_fibers), which only a base can fill (rve.size.2 of no rve.size)
            if _under(err.key, path) or (above and _under(path, _dotted(err.key))):
                raise err


def _point_errors(spec: dict, point: dict, has_base: bool) -> list[tuple[SpecError, bool]]:
    """The schema errors of the tables ``point`` sets in ``spec``, each with whether it may
    be a table's above a key (``has_base`` and not the table's own rule)."""
    found = []
    for table in dict.fromkeys(p.split(".")[0] for p in point):
        try:
            model = table_model(table)
        except KeyError:
            continue
        data = spec.get(table, {})
        # an array of tables (``[[fibers]]``, ``fibers.0.diameter``) element by element: as one
        # table the list was "fibers: must be a table" and every value was let through
        # (review s45: --at fibers.0.diameter=-1 was predicted, flagged extrapolated)
        items = enumerate(data) if isinstance(data, list) else [(None, data)]
        for i, item in items:
            prefix = table if i is None else f"{table}[{i}]"
            found += [(e, has_base and e.key != prefix) for e in _table_errors(model, item, prefix)]
    return found


def _dotted(key: str) -> str:
    """A spec error's key as a study parameter spells it: ``fibers[0].center`` ->
    ``fibers.0.center``."""
    return key.replace("[", ".").replace("]", "")


def _table_errors(model: type, data: Any, table: str) -> list[SpecError]:
    """Every schema error of ``data`` as the table ``table`` (``model``), warnings silenced
    (an image's voxel size note is the run's to give)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.model_validate(data)
    except ValidationError as exc:
        return spec_errors(exc, model, table)
    return []
