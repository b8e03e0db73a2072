"""Which columns of a study table are design parameters, which are outputs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

#: Columns that describe a case, not a result.
CASE_COLUMNS = ("case_id", "index", "seed", "status", "error")
#: Permeability columns of a results table and their own status columns (``ok``,
#: ``untrustworthy``: error bar above 20 % or < 8 cells per fiber diameter, ``not_converged``).
K_STATUS_COLUMNS = {"k_x_m2": "k_x_status", "k_y_m2": "k_y_status", "k_z_m2": "k_z_status"}
#: Every rated value column and its status column: K, and the transport values
#: (:func:`psdesign.transport.effective.rating`; the tortuosity shares the diffusivity's).
STATUS_COLUMNS = {
    # the porosity (a voxel count) is rated by its bar alone (:func:`porosity_status`); a table
    # written before a value's status column (porosity_status: session 46; pore_sizes_status,
    # specific_surface_status: abe85ab) has a bar only: :func:`own_status` rates it by that
    "porosity": "porosity_status",
    **K_STATUS_COLUMNS,
    **{f"diffusivity_{d}": f"diffusivity_{d}_status" for d in "xyz"},
    **{f"tortuosity_{d}": f"diffusivity_{d}_status" for d in "xyz"},
    **{f"conductivity_{d}": f"conductivity_{d}_status" for d in "xyz"},
    **{f"pore_d{q}_m": "pore_sizes_status" for q in (10, 50, 90)},
    "specific_surface_m-1": "specific_surface_status",
    # the delivered RVE's overlap Omega (psdesign.packing.overlap_status; session 46)
    "intersection_volume_fraction": "intersection_volume_fraction_status",
}

#: The relative error column of each value that has one (the tortuosity, porosity / D_eff/D
#: with the porosity a voxel count, carries the diffusivity's).
REL_ERROR_COLUMNS = {
    **{f"k_{d}_m2": f"k_{d}_rel_error" for d in "xyz"},
    **{f"diffusivity_{d}": f"diffusivity_{d}_rel_error" for d in "xyz"},
    **{f"tortuosity_{d}": f"diffusivity_{d}_rel_error" for d in "xyz"},
    **{f"conductivity_{d}": f"conductivity_{d}_rel_error" for d in "xyz"},
    "specific_surface_m-1": "specific_surface_rel_error",
}
#: The overlap Omega's columns (the delivered RVE's, the generator's before and after): rated by
#: their lenses (:mod:`psdesign.packing.overlap_status`), never by their relative bar, which
#: grows without bound as Omega -> 0 (session 45).
OMEGA_COLUMNS = ("intersection_volume_fraction", "omega_before", "omega_after")
#: The absolute error column of each value that has one instead.
ABS_ERROR_COLUMNS = {
    "porosity": "porosity_error",
    **{c: f"{c}_error" for c in OMEGA_COLUMNS},
    **{f"pore_d{q}_m": "pore_diameter_error_m" for q in (10, 50, 90)},
}

#: The values whose absolute bar is one-sided, the truth at or above the value by up to the bar:
#: the pore diameters' scan measures low (:func:`psdesign.transport.pores.diameter_bar_text`),
#: so the report prints them ``+bar/-0`` and draws their bar upward only (session 48).
UPPER_BARS = frozenset(c for c, e in ABS_ERROR_COLUMNS.items() if e == "pore_diameter_error_m")

#: How far below the pore diameters their truth may lie where a face of the case's box does not
#: repeat (:func:`psdesign.transport.pores.walled`; written only there, absent or NaN: 0, the
#: ``-0`` of :data:`UPPER_BARS`); the report, the targets (:func:`rel_error_below`) and the
#: decision figure read it (session 54).
LOWER_BAR_COLUMN = "pore_diameter_error_below_m"
#: Every error column: an estimate of a value's error, not an output of its own.
ERROR_COLUMNS = (
    frozenset(REL_ERROR_COLUMNS.values())
    | frozenset(ABS_ERROR_COLUMNS.values())
    | {LOWER_BAR_COLUMN}
)
#: The value whose bar rates a value that has no status of its own, where that is another's:
#: the product rates d10, d50 and d90 together by ``pore_diameter_error_m / pore_d50_m``
#: (:mod:`psdesign.transport.pores` ``rel_error``, ``study_outputs.pore_sizes_status``), so a
#: table without ``pore_sizes_status`` gives its row's one status to all three (review s46).
RATED_BY = {f"pore_d{q}_m": "pore_d50_m" for q in (10, 90)}


def status_column(column: str) -> str:
    """The column holding the own status of a value column: :data:`STATUS_COLUMNS` (the
    tortuosity shares the diffusivity's, d10-d90 ``pore_sizes_status``), else
    ``<column>_status`` (a value the report derives, :func:`psdesign.report.decision.
    add_anisotropy`).

    >>> status_column("tortuosity_x"), status_column("anisotropy")
    ('diffusivity_x_status', 'anisotropy_status')
    """
    return STATUS_COLUMNS.get(column, f"{column}_status")


def bar_status(rel: float | None) -> str:
    """The status of a rated value (:data:`STATUS_COLUMNS`) that has a relative error bar
    ``rel`` and no status of its own (a table written before its status column existed: the
    porosity before session 46, pore sizes and S_v before abe85ab): ``ok`` up to
    :data:`~psdesign.flow.error.UNTRUSTWORTHY_REL_ERROR` (20 %, the rule of every rated value),
    ``untrustworthy`` above, ``"unrated"`` without a bar. :func:`error_bar` and
    :func:`own_status` (the exit, red box, means, values table, optimize) both read it.

    >>> bar_status(0.118), bar_status(0.5), bar_status(None)
    ('ok', 'untrustworthy', 'unrated')
    """
    from psdesign.flow.error import UNTRUSTWORTHY_REL_ERROR

    if rel is None or rel != rel:
        return "unrated"
    return "ok" if rel <= UNTRUSTWORTHY_REL_ERROR else "untrustworthy"


# bar_status and _rel_error rate one row (error_bar: 5 us a call, the values table's cells);
# _bar_words and _rel_errors the same rule over a column at once (own_status: numpy on one
# value took 50 us). tests/unit/test_value_trust.py holds the two equal over every kind of cell.
def _bar_words(rel: np.ndarray) -> np.ndarray:
    """:func:`bar_status` of every relative bar in ``rel`` (NaN: ``unrated``)."""
    from psdesign.flow.error import UNTRUSTWORTHY_REL_ERROR

    ok = np.where(rel <= UNTRUSTWORTHY_REL_ERROR, "ok", "untrustworthy")
    return np.where(np.isnan(rel), "unrated", ok)


def cell_number(value) -> float | None:
    """One cell of a table or one value of a summary as a float, None where it is not a number
    (missing, None, NaN, text): the one reader of such a value (until session 48 also
    ``report.preview._given``). :func:`column_numbers` reads a whole column, NaN for None.

    >>> cell_number("2.5e-05"), cell_number(None), cell_number(float("nan")), cell_number("x")
    (2.5e-05, None, None, None)
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if v == v else None


def column_numbers(df: pd.DataFrame, column: str) -> np.ndarray:
    """``df[column]`` as floats (NaN where it is not a number or the column is missing): what
    :func:`cell_number` reads of one cell."""
    if column not in df:
        return np.full(len(df), np.nan)
    return pd.to_numeric(df[column], errors="coerce").to_numpy(dtype=float, na_value=np.nan)


def _rel_error(row: dict, column: str) -> float | None:
    """The relative error of ``row[column]``: its ``*_rel_error``, else its absolute error over
    the value (:data:`ABS_ERROR_COLUMNS`), else None."""
    if column in REL_ERROR_COLUMNS:
        return cell_number(row.get(REL_ERROR_COLUMNS[column]))
    y, e = cell_number(row.get(column)), cell_number(row.get(ABS_ERROR_COLUMNS.get(column, "")))
    return e / abs(y) if e is not None and y else None


def _rel_errors(df: pd.DataFrame, column: str) -> np.ndarray:
    """:func:`_rel_error` of every row of ``df`` at once (NaN for None)."""
    if column in REL_ERROR_COLUMNS:
        return column_numbers(df, REL_ERROR_COLUMNS[column])
    y, e = column_numbers(df, column), column_numbers(df, ABS_ERROR_COLUMNS.get(column, ""))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.isnan(e) | np.isnan(y) | (y == 0), np.nan, e / np.abs(y))


def error_bar(row: dict, column: str) -> tuple[float | None, str]:
    """``(relative error, status)`` of ``row[column]``: the value's own ``*_rel_error`` and
    status (:data:`REL_ERROR_COLUMNS`, :func:`status_column`; the porosity's and a pore
    diameter's absolute error over the value, :data:`ABS_ERROR_COLUMNS`). A rated value with
    an error but no status (a row written before its status column) is rated by the bar the
    product rates it by (:func:`bar_status`, as :func:`own_status` rates it: the pore sizes by
    theirs over d50, :data:`RATED_BY`); ``"unrated"`` where the table rates nothing, ``"no
    trusted value"`` where the value is missing.

    >>> error_bar({"k_z_m2": 1e-11, "k_z_rel_error": 0.118, "k_z_status": "ok"}, "k_z_m2")
    (0.118, 'ok')
    >>> error_bar({"porosity": 0.8, "porosity_error": 0.0004}, "porosity")
    (0.0005, 'ok')
    >>> old = {"intersection_volume_fraction": 0.002, "intersection_volume_fraction_error": 0.0027}
    >>> error_bar(old, "intersection_volume_fraction")  # no status (before session 46): not its bar
    (1.35, 'unrated')
    >>> pores = {"pore_d10_m": 1e-5, "pore_d50_m": 2e-5, "pore_diameter_error_m": 3e-6}
    >>> error_bar(pores, "pore_d10_m")  # its own bar 30 %, rated as the product does: 15 % of d50
    (0.3, 'ok')
    >>> image = {"intersection_volume_fraction_status": "not_applicable"}  # no fibres: no Omega
    >>> error_bar(image, "intersection_volume_fraction")
    (None, 'not_applicable')
    >>> error_bar({"tortuosity_x": None, "diffusivity_x_status": "blocked"}, "tortuosity_x")
    (None, 'blocked')
    """
    if cell_number(row.get(column)) is None:
        from psdesign.packing.overlap_status import NOT_APPLICABLE
        from psdesign.transport.effective import BLOCKED

        # no value by its status: an image's Omega, a blocked tortuosity (porosity / 0)
        said = row.get(status_column(column))
        return None, said if said in (NOT_APPLICABLE, BLOCKED) else "no trusted value"
    rel = _rel_error(row, column)
    status = row.get(status_column(column))
    if isinstance(status, str) and status:
        return rel, status
    if column in OMEGA_COLUMNS or column not in STATUS_COLUMNS:  # Omega: rated by its lenses
        return rel, "unrated"  # only (a table before session 46), never by its bar
    return rel, bar_status(_rel_error(row, RATED_BY.get(column, column)))


def rel_error_below(row: dict, column: str) -> float:
    """How far below ``row[column]`` its truth may lie, relative to the value: a pore
    diameter's :data:`LOWER_BAR_COLUMN` over it where a face of the box does not repeat, 0
    where the column is absent or NaN (every face repeats: the ``-0`` of :data:`UPPER_BARS`)
    or the value has no one-sided bar (its lower side is its :func:`error_bar`).

    >>> row = {"pore_d50_m": 2e-5, "pore_diameter_error_m": 2e-6}
    >>> walled = {**row, LOWER_BAR_COLUMN: 3e-6}
    >>> rel_error_below(walled, "pore_d50_m"), rel_error_below(row, "pore_d50_m")
    (0.15, 0.0)
    """
    y, low = cell_number(row.get(column)), cell_number(row.get(LOWER_BAR_COLUMN))
    if column not in UPPER_BARS or not y or low is None:
        return 0.0
    return low / abs(y)


def porosity_status(porosity: float | None, error: float | None) -> str:
    """The porosity's own status, by its bar alone (:func:`error_bar`: a voxel count, ``ok`` up
    to a 20 % bar, ``untrustworthy`` above; ``unrated`` without a bar): what ``generate``,
    ``mesh``, the notebook and a study case (``porosity_status``, since session 46) print.

    >>> porosity_status(0.8, 4e-4), porosity_status(0.088, 0.024)
    ('ok', 'untrustworthy')
    """
    return error_bar({"porosity": porosity, "porosity_error": error}, "porosity")[1]


def case_warnings(row: dict) -> dict[str, str]:
    """The non-empty ``warnings_<d>`` cells of a case (what the solve said about its K, e.g. a
    periodic bc on a non-periodic RVE), ``{column: text}``: the words `study optimize` prints
    and the report's decision section shows beside the chosen case.

    >>> case_warnings({"warnings_z": "K_z: bc = 'periodic' on ...", "warnings_x": "", "k": 1})
    {'warnings_z': "K_z: bc = 'periodic' on ..."}
    """
    return {k: v for k, v in row.items() if k.startswith("warnings_") and isinstance(v, str) and v}


def trusted(df: pd.DataFrame) -> pd.DataFrame:
    """The ``ok`` cases of a results table (:func:`case_status`), with each rated value that is
    not ``ok`` by its own status (``k_x_status``, ``porosity_status``, ...: :func:`own_status`)
    set to NaN, and its error with it (:data:`REL_ERROR_COLUMNS`, :data:`ABS_ERROR_COLUMNS`: a
    mean bar must not hold the 300 % of a value left out): what summaries, fits, the optimizer
    and the report use.

    Examples
    --------
    >>> df = pd.DataFrame({"status": ["ok", "ok", "failed"], "k_z_m2": [1.0, 2.0, 3.0],
    ...                    "k_z_status": ["ok", "untrustworthy", "ok"],
    ...                    "k_z_rel_error": [0.02, 3.0, 0.02]})
    >>> t = trusted(df)
    >>> t["k_z_m2"].tolist(), t["k_z_rel_error"].tolist()
    ([1.0, nan], [0.02, nan])
    """
    out = ok_cases(df).copy()
    # every value's status before any bar is blanked: d10-d90 share one bar, the tortuosity the
    # diffusivity's, and a blanked bar would rate the next value unrated (kept)
    bads = {c: k_not_ok(out, c) for c in STATUS_COLUMNS if c in out}
    for c, bad in bads.items():
        out[c] = pd.to_numeric(out[c], errors="coerce").mask(bad)
        e = REL_ERROR_COLUMNS.get(c, ABS_ERROR_COLUMNS.get(c))
        if e in out:  # its bar goes with it (the report's mean bar, summary.csv)
            out[e] = pd.to_numeric(out[e], errors="coerce").mask(bad)
    return out


def distinct_realizations(df: pd.DataFrame, params: list[str]) -> pd.DataFrame:
    """The rows of a results table less those that repeat an earlier row's design point and
    ``seed``: the same parameters and seed build the same RVE, so a design point listed twice
    (a csv design) is one realization computed twice, not two replicates (its spread would
    read 0 and its 95 % CI zero width).

    >>> df = pd.DataFrame({"a": [1, 1, 1], "seed": [1, 1, 2], "k": [2.0, 2.0, 3.0]})
    >>> distinct_realizations(df, ["a"])["k"].tolist()
    [2.0, 3.0]
    """
    keys = [c for c in [*params, "seed"] if c in df.columns]
    if "seed" not in keys:
        return df
    return df[~df.duplicated(subset=keys, keep="first")]


#: How a case whose status is missing (an empty ``status`` cell) reads: not ``ok``, and
#: counted with the cases the run could not give (:func:`psdesign.cli.exit_status.case_masks`).
MISSING_STATUS = "unknown"


def case_status(df: pd.DataFrame) -> pd.Series:
    """Each case's status as every table, figure, count and exit reads it: its ``status``,
    :data:`MISSING_STATUS` where that is missing or empty (not ``"nan"``, not ``ok``); ``ok``
    for every row of a table with no ``status`` column (a table of values only).

    >>> case_status(pd.DataFrame({"status": ["ok", None, "failed", ""]})).tolist()
    ['ok', 'unknown', 'failed', 'unknown']
    >>> case_status(pd.DataFrame({"k_z_m2": [1e-11]})).tolist()
    ['ok']
    """
    if "status" not in df:
        return pd.Series("ok", index=df.index, dtype=object)
    st = df["status"]
    return st.where(st.notna() & (st.astype(str) != ""), MISSING_STATUS).astype(str)


def ok_cases(df: pd.DataFrame) -> pd.DataFrame:
    """The rows of a results table whose case is ``ok`` (:func:`case_status`: every row of a
    table without a ``status`` column), values as they are (:func:`trusted` also drops the
    values not ok by their own status).

    >>> ok_cases(pd.DataFrame({"status": ["ok", None, "failed"], "k": [1, 2, 3]}))["k"].tolist()
    [1]
    """
    return df[case_status(df) == "ok"]


def own_status(df: pd.DataFrame, column: str) -> pd.Series:
    """The own status of each row's value in ``column``, whatever its case's: its status column
    (:func:`status_column`), else the status :func:`error_bar` gives it (a rated value with a
    bar but no status, a table written before its status column: by its bar,
    :func:`bar_status`; d10-d90 all by their row's bar over d50, :data:`RATED_BY`), else ``ok``
    (an unrated value, a missing one).

    >>> df = pd.DataFrame({"porosity": [0.8, 0.088], "porosity_error": [4e-4, 0.024],
    ...                    "k_z_status": ["untrustworthy", ""]})
    >>> own_status(df, "k_z_m2").tolist(), own_status(df, "porosity").tolist()
    (['untrustworthy', 'ok'], ['ok', 'untrustworthy'])
    """
    st = df.get(status_column(column))
    # numpy, not pandas, over the rows: a pandas object Series took ~5 ms per column
    # (trusted() reads 17) on 2000 rows
    vals = np.full(len(df), None, object) if st is None else st.to_numpy(object, copy=True)
    unset = pd.isna(vals)  # a missing or empty status says nothing
    unset[~unset] = vals[~unset] == ""
    vals[unset] = None
    by = RATED_BY.get(column, column)  # d10, d90: their row's one status, d50's
    if by in df and _error_column(by) in df and unset.any():
        # error_bar's rule over the whole column (row by row until session 47: 20-60 ms per
        # 2000 rows): no value reads "no trusted value", no bar "unrated", both left unset
        words = _bar_words(_rel_errors(df, by))
        words = np.where(~np.isnan(column_numbers(df, by)) & (words != "unrated"), words, None)
        vals[unset] = words[unset]
    vals[pd.isna(vals)] = "ok"
    return pd.Series(vals, index=df.index, name=None if st is None else st.name).astype(str)


def _error_column(column: str) -> str | None:
    """The error column of a value rated by its bar when it has no status (:data:`STATUS_COLUMNS`),
    relative or absolute; None for Omega, which is rated by its lenses only (:func:`error_bar`
    gives it ``unrated``: no row of an old table need be read for it)."""
    if column not in STATUS_COLUMNS or column in OMEGA_COLUMNS:
        return None
    return REL_ERROR_COLUMNS.get(column, ABS_ERROR_COLUMNS.get(column))


def value_status(df: pd.DataFrame, column: str) -> pd.Series:
    """The status of each row's value in ``column`` (``k_x_m2``, ``diffusivity_z``, ...): its
    case's (:func:`case_status`: ``failed``, ``not_converged``, ``unknown``...) when that is not
    ``ok``, else its own (:func:`own_status`: ``ok`` for an unrated value), read as ``ok`` when
    the exit trusts it (:data:`psdesign.status.TRUSTED`: ``converged``, ``at_bound``;
    the rule of :func:`k_not_ok` and the fits, session 51). ``not_applicable`` stays its word:
    no value to draw or to call trusted (:func:`k_not_ok` does not flag it either).

    >>> df = pd.DataFrame({"status": ["ok", "ok", "not_converged", "ok"],
    ...                    "k_z_status": ["ok", "untrustworthy", "ok", "converged"]})
    >>> value_status(df, "k_z_m2").tolist()
    ['ok', 'untrustworthy', 'not_converged', 'ok']
    """
    from psdesign.status import TRUSTED

    case, own = case_status(df), own_status(df, column)
    return case.where(case != "ok", own.where(~own.isin(TRUSTED), "ok"))


def value_ok(df: pd.DataFrame, column: str) -> pd.Series:
    """Rows whose value in ``column`` is trusted: :func:`value_status` ``ok`` (its case ``ok``
    and the value trusted by its own status, :data:`psdesign.status.TRUSTED`, or
    unrated).

    >>> df = pd.DataFrame({"status": ["ok", "ok", "failed"], "k_z_status": ["ok", "x", "ok"]})
    >>> value_ok(df, "k_z_m2").tolist()
    [True, False, False]
    """
    return value_status(df, column) == "ok"


def k_not_ok(df: pd.DataFrame, k_column: str) -> pd.Series:
    """Rows whose value in ``k_column`` (``k_x_m2``, ``diffusivity_z``, ...) is not ``ok`` by its
    own status (:func:`own_status`) by the exit's rule
    (:func:`psdesign.status.passing`: :data:`~psdesign.status.TRUSTED`, as
    :func:`value_status` reads it, and ``not_applicable``), whatever its case's; False for an
    unrated value and for one that does not apply (an image's Omega: ``not_applicable``, no
    value to distrust).

    >>> k_not_ok(pd.DataFrame({"intersection_volume_fraction_status": ["not_applicable", "x"]}),
    ...          "intersection_volume_fraction").tolist()
    [False, True]
    """
    from psdesign.status import passing

    return ~own_status(df, k_column).isin(passing())


def flagged_values(df: pd.DataFrame) -> dict[str, pd.Series]:
    """``{status column: row mask}`` of the ``ok`` cases (:func:`case_status`) with a value
    that is not ``ok`` by its own status (:func:`own_status`), one entry per status column
    with such a row (the tortuosity shares the diffusivity's, d10-d90 ``pore_sizes_status``),
    in :data:`STATUS_COLUMNS` order: the values ``study run``'s and ``study report``'s exit
    (:func:`psdesign.cli.exit_status.case_masks`) and the report's red box count. A status
    column is read with or without its value column (a status says what it says).

    >>> df = pd.DataFrame({"status": ["ok", "ok", "failed"], "k_z_status": ["x", "ok", "x"]})
    >>> {k: m.tolist() for k, m in flagged_values(df).items()}
    {'k_z_status': [True, False, False]}
    """
    ok = case_status(df) == "ok"
    out: dict[str, pd.Series] = {}
    for c, st in STATUS_COLUMNS.items():
        if c in RATED_BY:  # d10, d90: d50's status (own_status), read once
            continue
        rated = st in df or (c in df and _error_column(c) in df)  # by its bar: own_status
        if rated and (m := ok & k_not_ok(df, c)).any():
            # the tortuosity shares the diffusivity's status and bar: either flags the row
            out[st] = out[st] | m if st in out else m
    return out


def other_status(status: pd.Series) -> pd.Series:
    """The cases of ``status`` (:func:`case_status`) that finished with a status word other
    than ``ok`` / ``not_converged``: flagged by their own word."""
    from psdesign.status import NOT_FINISHED

    return ~status.isin((*NOT_FINISHED, MISSING_STATUS, "ok", "not_converged"))


class FlaggedCasesWarning(UserWarning):
    """A study finished with flagged cases (:func:`flagged_text` says which: an ``ok`` case
    with a value not ok by its own status, or one finished with another status word):
    :func:`psdesign.run_study`'s counterpart of ``study run``'s exit status 3 for them (not for
    ``not_converged``, failed or timed-out cases, which it does not warn of)."""


#: What becomes of the flagged cases' values (:func:`flagged_text`'s tail in ``study run``'s
#: line and :func:`psdesign.run_study`'s warning).
FLAGGED_KEPT = "their values are kept in results.csv and left out of fits and summaries"


def flagged_text(df: pd.DataFrame) -> str:
    """Why the ``flagged`` cases of a results table (:func:`psdesign.cli.exit_status.
    case_masks`) are not ok, the one sentence ``study run``'s and ``rev``'s lines and
    :func:`psdesign.run_study`'s warning print: the ``ok`` cases with a value not ok by its own
    status, naming the status columns that say so (:func:`flagged_values`, the columns the
    report's red box names), then the finished cases with another status word; "" when there
    are none. Until session 46 ``rev`` said "a K flagged" also for a flagged porosity; until
    session 54 the API's ``run_study`` did not say it (it printed "done ...: ok 3").

    >>> df = pd.DataFrame({"status": ["ok", "ok", "blocked"], "porosity": [0.8, 0.1, 0.8],
    ...                    "porosity_error": [1e-3, 0.03, 1e-3]})
    >>> flagged_text(df).split("; ")  # doctest: +NORMALIZE_WHITESPACE
    ['1 ok case(s) have a value whose own status is not ok (porosity_status: untrustworthy =
      error bar above 20 %)', '1 finished case(s) have another status (blocked)']
    """
    from psdesign.status import flagged_words

    parts = []
    if values := flagged_values(df):
        n = int(sum(values.values()).astype(bool).sum())
        # the columns that mean one thing, then its words (flagged_words), in values' order
        groups: dict[str, list[str]] = {}
        for st in values:
            groups.setdefault(flagged_words(st), []).append(st)
        cols = "; ".join(
            ", ".join(sts) + (f": {words}" if words else "") for words, sts in groups.items()
        )
        parts.append(f"{n} ok case(s) have a value whose own status is not ok ({cols})")
    status = case_status(df)
    other = status[other_status(status)]
    if len(other):
        words = ", ".join(sorted(set(other)))
        parts.append(f"{len(other)} finished case(s) have another status ({words})")
    return "; ".join(parts)


def first_error(df: pd.DataFrame) -> str:
    """``" (first error: ...)"`` from a results table's ``error`` column, or ``""``."""
    errors = df["error"].dropna().astype(str) if "error" in df else []
    return f" (first error: {errors.iloc[0]})" if len(errors) else ""


def study_table(out_dir: str | Path) -> dict:
    """The ``study`` table of ``OUT/study.json`` (:meth:`psdesign.study.Study.to_dict`: its
    ``parameters``, ``base`` spec, ``solver``, ...)."""
    path = Path(out_dir) / "study.json"
    if not path.is_file():
        raise FileNotFoundError(
            f"out_dir: no study.json in {out_dir}; is this a study output folder?"
        )
    from psdesign.study.readback import read_json_object

    doc = read_json_object(path)
    study = doc.get("study", doc)
    params = study.get("parameters", {}) if isinstance(study, dict) else None
    if not isinstance(params, dict):
        raise ValueError(f"out_dir: {path} is unreadable (no parameters table); rerun the study")
    return study


def study_parameters(out_dir: str | Path) -> dict[str, dict]:
    """The ``parameters`` table of ``OUT/study.json`` (path -> kind, values, low, high, ...)."""
    return dict(study_table(out_dir)["parameters"])


def is_design_parameter(name: str) -> bool:
    """Whether a results-table column (or a key of one of its rows) is a design parameter: a
    dotted spec path (``generator.porosity``), not a result that
    :func:`psdesign.study.store.records_to_frame` renamed ``result.<key>`` because it met a
    parameter's or a case column's name.

    >>> [is_design_parameter(c) for c in ("generator.porosity", "result.seed", "k_z_m2")]
    [True, False, False]
    """
    return "." in name and not name.startswith("result.")


def numeric_parameters(df: pd.DataFrame, params: list[str]) -> list[str]:
    """Parameters whose every value is a finite number (whole-table levels are left out)."""
    out = []
    for p in params:
        if p in df.columns and pd.api.types.is_numeric_dtype(df[p]) and df[p].notna().all():
            out.append(p)
    return out


def varying_categories(df: pd.DataFrame, params: list[str]) -> list[str]:
    """Parameters that are not numeric (:func:`numeric_parameters`: a whole-table level, a
    wall model's name) and take more than one value in ``df``: no input of a surrogate, so a
    fit over the numeric ones would mix their levels."""
    num = set(numeric_parameters(df, params))
    return [
        p for p in params if p in df.columns and p not in num and df[p].astype(str).nunique() > 1
    ]


def output_columns(df: pd.DataFrame, params: list[str]) -> list[str]:
    """Numeric result columns (K, porosity, errors, solver statistics; timings left out)."""
    from psdesign.study.store import is_timing_column

    skip = set(CASE_COLUMNS) | set(params)
    return [
        c
        for c in df.columns
        if c not in skip
        and not is_timing_column(c)
        and pd.api.types.is_numeric_dtype(df[c])
        and not pd.api.types.is_bool_dtype(df[c])
    ]
