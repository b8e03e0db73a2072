"""The copies an ``"auto"`` permeameter will stack, planned from a spec before any work.

``"auto"`` stacks 2 copies of a geometry periodic along the flow with one period per copy, else 1
(:func:`psdesign.flow.stack.plan_copies`, on the built RVE). Where the spec holds the geometry
(explicit fibers: their analytic field; an image: its solid mask, which the schema reads anyway)
and the direction (``flow.direction`` as a route pins it before any work:
:func:`psdesign.schema.spec.check_directions`, :func:`pinned_direction`), the same test is run
on it here (:func:`psdesign.flow.stack.spec_auto_copies`) and the memory checks count the
planned copies, the machine budget and ``flow.max_memory_gb`` alike
(:func:`psdesign.schema.budget.stack_of`). A generated RVE (its fibers are drawn when it is
built) keeps ``"auto"``: the budget counts 2, the cap 1, and the planned stack is checked once
it is built (:func:`psdesign.schema.budget.check_planned_stack`).

A spec validated alone (a file as it is loaded, ``psdesign.build``, a study's levels) counts the
fewest copies over the three axes: its ``flow.direction`` is only the default of a command line
or a study's outputs, which may solve another (s43-ends planned along it and refused a spec with
``direction = "z"`` run with ``--direction x``, whose one copy ran; review2).

The test runs only where it can change an outcome: when one copy fits and two do not (10-30 ms a
direction on explicit fibers, a pass over the mask on an image).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from pydantic_core import PydanticCustomError

from psdesign.schema.budget import solved_bc
from psdesign.schema.flow import AUTO_PERMEAMETER_COPIES, FlowTable

#: True while a route validates its spec along the direction it solves (:func:`pinned_direction`).
_PINNED: ContextVar[bool] = ContextVar("psdesign_pinned_direction", default=False)


@contextmanager
def pinned_direction() -> Iterator[None]:
    """Validations inside plan along ``flow.direction``: the direction the route solves
    (:func:`psdesign.schema.spec.check_directions`), not a default another may override."""
    token = _PINNED.set(True)
    try:
        yield
    finally:
        _PINNED.reset(token)


def solved_axis(flow: FlowTable) -> int | None:
    """The axis a route solves: ``flow.direction``'s inside :func:`pinned_direction`, else
    None (any direction may be solved)."""
    if flow.direction is not None and _PINNED.get():
        return "xyz".index(flow.direction)
    return None


def _pinned(flow: FlowTable, copies: int) -> FlowTable:
    return flow.model_copy(update={"permeameter_copies": copies})


def _fits(checks: Callable[[FlowTable], None], flow: FlowTable) -> bool:
    """``checks`` (the route's memory checks, raising a schema error) pass with ``flow``."""
    try:
        checks(flow)
    except PydanticCustomError:
        return False
    return True


def planned_flow(
    flow: FlowTable,
    checks: Callable[[FlowTable], None],
    plan: Callable[[int], int | None],
) -> FlowTable:
    """``flow`` with ``"auto"`` copies replaced by ``plan(axis)`` (the copies the geometry
    plans along ``flow.direction`` inside :func:`pinned_direction`, else the fewest over the
    three axes; None: it cannot tell) where that can change the outcome of ``checks``: an
    ``"auto"`` permeameter (``flow.bc``, or the FEM's default) whose one copy fits and two
    copies do not. Else ``flow`` itself.

    Parameters
    ----------
    flow : FlowTable
        The spec's ``[flow]`` table.
    checks : callable
        The memory checks of the spec's route at a ``[flow]`` table (a schema error over the
        budget or the cap).
    plan : callable
        The copies ``"auto"`` plans along an axis (0, 1, 2), or None.
    """
    auto = flow.permeameter_copies in (None, "auto") and solved_bc(flow) == "permeameter"
    if not auto:
        return flow
    if _fits(checks, _pinned(flow, AUTO_PERMEAMETER_COPIES)) or not _fits(checks, _pinned(flow, 1)):
        return flow  # the plan changes no outcome
    if flow.direction is not None and _PINNED.get():
        copies = plan("xyz".index(flow.direction))
    else:  # any direction may be solved: refuse only what none of them fits
        each = [plan(axis) for axis in range(3)]
        copies = None if None in each else min(each)
    return flow if copies is None else _pinned(flow, copies)
