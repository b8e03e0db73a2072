"""One definition of "how trusted is this value" over a study table (session 46).

Until session 46 the rule was written several times: ``report.trust.value_status`` beside
``analysis.columns.value_ok`` (they disagreed on an empty own status), "a missing case status
reads ``unknown``" in four places, and ``study report``'s exit (``cli.exit_status.case_masks``)
beside its red box (``report.html._status_banner``), which disagreed on a table without a
``status`` column and on a status column without its value column. The truth here is each
rule's own statement, checked over every combination of the cells a table can hold: a value
is trusted exactly when its case is ``ok`` and its own status is ``ok`` or unset; the red box
is there exactly when ``study report`` exits 3.
"""

from __future__ import annotations

import itertools

import pandas as pd
import pytest

from psdesign.analysis.columns import case_status, trusted, value_ok, value_status
from psdesign.cli.exit_status import case_counts
from psdesign.cli.study import report_exit_status
from psdesign.report.html import _status_banner

CASE = ["ok", "failed", "timeout", "not_converged", None, "", "blocked"]
OWN = ["ok", "untrustworthy", None, ""]  # None: an empty cell; "": an in-memory empty string


def _tables():
    """Every row of a case status and a K_z status, alone and after an all-ok row, with and
    without its status columns and its value column."""
    for (case, own), first in itertools.product(itertools.product(CASE, OWN), (False, True)):
        rows = [("ok", "ok")] * first + [(case, own)]
        df = pd.DataFrame(
            {
                "status": [r[0] for r in rows],
                "k_z_m2": [1e-11] * len(rows),
                "k_z_status": [r[1] for r in rows],
            },
            dtype=object,
        )
        yield df
        yield df.drop(columns="k_z_m2")  # a status without its value
        yield df.drop(columns="status")  # a table of values only
        yield df.drop(columns="k_z_status")  # an unrated value


def test_a_value_is_trusted_exactly_when_its_case_is_ok_and_its_own_status_ok_or_unset():
    n = 0
    for df in _tables():
        case = df["status"] if "status" in df else pd.Series("ok", index=df.index)
        own = df["k_z_status"] if "k_z_status" in df else pd.Series(None, index=df.index)
        truth = (case == "ok") & (own.isna() | own.isin(["ok", ""]))
        assert value_ok(df, "k_z_m2").tolist() == truth.tolist(), df
        assert (value_status(df, "k_z_m2") == "ok").tolist() == truth.tolist(), df
        if "k_z_m2" in df:  # what the means and fits keep: the trusted values, no other
            kept = trusted(df)["k_z_m2"].notna()
            assert kept.tolist() == truth[case == "ok"].tolist(), df
        n += 1
    assert n == 4 * 2 * 28  # every combination was checked


@pytest.mark.parametrize("status", [None, float("nan"), ""])
def test_a_missing_case_status_reads_unknown_everywhere(status):
    """One helper (``case_status``): the values' status, the exit's count (failed) and the red
    box all say ``unknown``; review s45 found the tables printing such a case ``ok``."""
    df = pd.DataFrame({"status": ["ok", status], "k_z_m2": [1e-11, 1e-11]})
    assert case_status(df).tolist() == ["ok", "unknown"]
    assert value_status(df, "k_z_m2").tolist() == ["ok", "unknown"]
    assert case_counts(df).failed == 1
    assert "1 unknown of 2 cases" in _status_banner(df)


def test_study_reports_exit_is_3_exactly_when_its_red_box_is_there(capsys):
    """Over every table of ``_tables``: the red box and the exit read one function, so they
    agree, and the box is there for the tables the rule calls not ok (pinned: a table of
    values only with an untrustworthy K has a box, one of ok values only has none)."""
    for df in _tables():
        try:
            code = report_exit_status(df)
        except KeyError:  # the exit of a table without a status column before session 46
            code = None
        assert bool(_status_banner(df)) == (code == 3), df
    capsys.readouterr()
    values_only = pd.DataFrame({"k_z_m2": [1e-11, 1e-11], "k_z_status": ["ok", "untrustworthy"]})
    assert report_exit_status(values_only) == 3 and "1 value(s)" in _status_banner(values_only)
    assert report_exit_status(values_only.iloc[:1]) == 0 and _status_banner(values_only[:1]) == ""


def test_the_convergence_table_flags_the_cases_the_red_box_counts():
    """The Solver convergence section flagged every row of a table without a ``status`` column
    (``row.get("status") != "ok"``) while the red box, the K table and the means read it as
    ok; now it reads ``case_status`` too: a flag for the missing status only."""
    from psdesign.report.html import _convergence

    values_only = pd.DataFrame({"k_z_m2": [1e-11, 2e-11], "iterations_z": [40, 41]})
    assert _convergence(values_only)[2] == 0 and _status_banner(values_only) == ""
    missing = values_only.assign(status=["ok", None])
    assert _convergence(missing)[2] == 1 and "1 unknown" in _status_banner(missing)
