"""The status words of a result and the one rule that says which of them to trust.

Every measured or predicted value carries a ``status`` (``ok``, ``untrustworthy``,
``not_converged``, ``blocked``, a force-field search's ``converged`` / ``at_bound``...). A value
is trusted when its status is in :data:`TRUSTED`; :func:`passes` adds ``not_applicable`` (no
value, nothing to distrust). The exit status of every command (:mod:`psdesign.cli.exit_status`),
a study table's flags (:mod:`psdesign.analysis.columns`), the worst of several statuses
(:func:`psdesign.transport.effective.worst_status`) and the report read these. A package root
module like :mod:`psdesign.errors`: the stages and the CLI share it (in
``psdesign.cli.exit_status`` until session 52, which the stages imported).
"""

from __future__ import annotations

#: The statuses of a result to trust: ``ok`` (every measured or predicted value) and a
#: force-field search's ``converged`` and ``at_bound`` (:func:`psdesign.forcefield.run.
#: search_status`: a converged search whose optimum lies on the box the spec set is the
#: answer to the constrained problem it asked, a result since session 44). Every other status
#: of a finished result exits ``NOT_TRUSTED`` (:mod:`psdesign.cli.exit_status`). The worst of
#: several statuses (:func:`psdesign.transport.effective.worst_status`) ranks these with
#: ``ok``, so it is trusted exactly when the exit is 0.
TRUSTED = ("ok", "converged", "at_bound")
#: A study case's status when the run could not give it (exit ``FAILED``).
NOT_FINISHED = ("failed", "timeout")


def passes(status: str | None) -> bool:
    """Whether a result's ``status`` lets the exit be ``OK``: in :data:`TRUSTED`, or saying the
    value does not apply (``not_applicable``: an image's Omega,
    :data:`psdesign.packing.overlap_status.NOT_APPLICABLE`; no result, so nothing to
    distrust). The one rule of :func:`psdesign.cli.exit_status.status_code` and of
    :func:`psdesign.transport.effective.worst_status`'s ranking.

    >>> passes("at_bound"), passes("not_applicable"), passes("untrustworthy"), passes(None)
    (True, True, False, False)
    """
    return status in passing()


def passing() -> tuple[str, ...]:
    """The status words :func:`passes`: :data:`TRUSTED` and ``not_applicable``; what a study
    table's value columns are read by too: :func:`psdesign.analysis.columns.k_not_ok` (the
    fits, the red box) flags a value outside these, and
    :func:`~psdesign.analysis.columns.value_status` (the figures) and the report's tables read
    a :data:`TRUSTED` one as ``ok``. Until session 51 ``k_not_ok`` spelled ``ok`` and
    ``not_applicable`` itself and the others ``ok`` alone, so a value rated ``converged`` or
    ``at_bound`` was flagged there and passed here."""
    from psdesign.packing.overlap_status import NOT_APPLICABLE

    return (*TRUSTED, NOT_APPLICABLE)


#: What ``untrustworthy`` means for a value rated by its bar and its resolution
#: (:func:`psdesign.flow.error.status_of`: K, S_v, the transport values).
_BAR_OR_CELLS = "untrustworthy = error bar above 20 % or fewer than 8 cells per fiber diameter"

#: What the words of each status column of :data:`psdesign.analysis.columns.STATUS_COLUMNS`
#: mean, as the rating that writes it means them, one entry per column (until session 47 a
#: chain of tests on the column's name): tests/cli/test_exit_joins.py holds its keys equal to
#: the status columns, so a status column added without its words fails there.
STATUS_WORDS = {
    # a voxel count: its bar alone (analysis.columns.porosity_status)
    "porosity_status": "untrustworthy = error bar above 20 %",
    **{f"k_{d}_status": _BAR_OR_CELLS for d in "xyz"},  # flow.error.status_of
    # transport.effective.rating (the tortuosity shares the diffusivity's)
    **{
        f"{v}_{d}_status": f"{_BAR_OR_CELLS}, blocked = no conducting path"
        for v in ("diffusivity", "conductivity")
        for d in "xyz"
    },
    # transport.study_outputs.pore_sizes_status
    "pore_sizes_status": (
        f"{_BAR_OR_CELLS} or d90 above the smallest edge the geometry varies along"
    ),
    "specific_surface_status": _BAR_OR_CELLS,  # flow.error.status_of
    "intersection_volume_fraction_status": (  # packing.overlap_status
        "untrustworthy = the count missed overlaps the fibres' centre lines find, or "
        "overlaps thinner than a voxel (which the count may miss) plus the signed sum of the "
        "grid-aligned overlaps' errors, measured on the grid, exceed its error bar"
    ),
}


def flagged_words(status_column: str) -> str:
    """What the status words in ``status_column`` mean, as the rating that writes it means
    them (:data:`STATUS_WORDS`): the line of every command that names a flagged value
    (:func:`psdesign.analysis.columns.flagged_text`); "" for a column no rating here writes
    (named without words). Until review s46 every column read K's words, Omega's and the
    porosity's too.

    >>> flagged_words("porosity_status"), flagged_words("anisotropy_status")
    ('untrustworthy = error bar above 20 %', '')
    """
    return STATUS_WORDS.get(status_column, "")
