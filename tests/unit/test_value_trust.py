"""One definition of "how trusted is this value" over a study table (session 46).

Until session 46 the rule was written several times: ``report.trust.value_status`` beside
``analysis.columns.value_ok`` (they disagreed on an empty own status), "a missing case status
reads ``unknown``" in four places, and ``study report``'s exit (``cli.exit_status.case_masks``)
beside its red box (``report.html._status_banner``), which disagreed on a table without a
``status`` column and on a status column without its value column. The truth here is each
rule's own statement, checked over every combination of the cells a table can hold: a value
is trusted exactly when its case is ``ok`` and its own status is a trusted word (``ok``, a
force-field search's ``converged``: the exit's rule, ``psdesign.status.TRUSTED``) or unset;
the red box is there exactly when ``study report`` exits 3.
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
# None: an empty cell; "": an in-memory empty string; "converged": trusted by the exit's rule,
# so by every reader (session 51: value_status read "ok" alone, k_not_ok the exit's list)
OWN = ["ok", "converged", "untrustworthy", None, ""]


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
        truth = (case == "ok") & (own.isna() | own.isin(["ok", "converged", ""]))
        assert value_ok(df, "k_z_m2").tolist() == truth.tolist(), df
        assert (value_status(df, "k_z_m2") == "ok").tolist() == truth.tolist(), df
        if "k_z_m2" in df:  # what the means and fits keep: the trusted values, no other
            kept = trusted(df)["k_z_m2"].notna()
            assert kept.tolist() == truth[case == "ok"].tolist(), df
        n += 1
    assert n == 4 * 2 * 35  # every combination was checked


def test_a_values_own_status_is_read_by_the_exits_one_rule():
    """Session 51: ``k_not_ok`` (the red box, the study exit's flagged values) spelled its good
    words ``ok`` and ``not_applicable`` itself, ``psdesign.status.passes`` (every command's exit)
    read ``TRUSTED`` and ``not_applicable``: a value rated ``converged`` or ``at_bound`` was
    flagged by one and passed by the other. Truth: the exit rule, word by word."""
    from psdesign.analysis.columns import k_not_ok
    from psdesign.status import passes

    words = ["ok", "converged", "at_bound", "not_applicable", "untrustworthy", "blocked"]
    words += ["not_converged", "extrapolated"]
    flagged = k_not_ok(pd.DataFrame({"k_z_status": words}), "k_z_m2").tolist()
    assert flagged == [not passes(w) for w in words]
    assert flagged == [False] * 4 + [True] * 4


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


# ------------------------------------- one rule for a value with an error bar and no status
#: A study table written before abe85ab (session 46): pore sizes with their absolute bar and S_v
#: with its relative one, but no pore_sizes_status / specific_surface_status. Case 1's pore
#: sizes have a 25 % bar (1 um on d50 = 4 um: the product's rating, pores.py rel_error), its
#: S_v a 35 % one; case 0's bars are 2.5 % and 2 %.
OLD_PORES = pd.DataFrame(
    {
        "case_id": ["c0", "c1"],
        "status": ["ok", "ok"],
        "pore_d10_m": [20e-6, 2e-6],
        "pore_d50_m": [40e-6, 4e-6],
        "pore_d90_m": [60e-6, 12e-6],
        "pore_diameter_error_m": [1e-6, 1e-6],
        "specific_surface_m-1": [1e5, 2e5],
        "specific_surface_rel_error": [0.02, 0.35],
    }
)


def _rated_tables():
    """``(column, table, rule's status)``: each rated value (STATUS_COLUMNS) of an ok case at
    0.5 with a bar of 10 % or 35 % or none, and an own status that is missing, empty, ok or
    untrustworthy; the status the rule gives it (a status says what it says, else a bar above
    20 % is untrustworthy, else ok: unrated)."""
    from psdesign.analysis.columns import (
        ABS_ERROR_COLUMNS,
        OMEGA_COLUMNS,
        REL_ERROR_COLUMNS,
        STATUS_COLUMNS,
    )

    for c, st in STATUS_COLUMNS.items():
        for bar, own in itertools.product((None, 0.1, 0.35), (None, "", "ok", "untrustworthy")):
            row = {"status": "ok", c: 0.5}
            if c.startswith("pore_d"):  # d10-d90 rated together by the bar over d50 (pores.py
                # rel_error): d10 0.2 with a 10 % bar is 25 % of itself, d90 1.0 with 35 % 17.5 %
                row.update({"pore_d10_m": 0.2, "pore_d50_m": 0.5, "pore_d90_m": 1.0})
            if bar is not None and c in REL_ERROR_COLUMNS:
                row[REL_ERROR_COLUMNS[c]] = bar
            elif bar is not None:
                row[ABS_ERROR_COLUMNS[c]] = bar * 0.5  # an absolute bar
            if own is not None:
                row[st] = own
            # Omega is rated by its lenses, never by its bar (docs/geometry.md): without its own
            # status (a table before session 46) it is unrated
            by_bar = bar is not None and bar > 0.2 and c not in OMEGA_COLUMNS
            truth = own or ("untrustworthy" if by_bar else "ok")
            yield c, pd.DataFrame([row], dtype=object), truth


def test_a_value_with_a_bar_and_no_status_is_rated_by_one_rule(capsys):
    """Review s46: ``error_bar`` (the report's values table, ``study optimize``'s target
    status) rated every value with a bar and no status by the 20 % rule, ``own_status`` (the
    exit, red box, means, frames) only the porosity: an old table's 50 % pore bar was
    ``[untrustworthy]`` in the values table and in the means, with no red box and exit 0. The
    truth is the rule (flow.error.UNTRUSTWORTHY_REL_ERROR, docs/permeability.md): a status
    says what it says, else a bar above 20 % is untrustworthy, else (no bar) unrated = ok;
    ``error_bar``, ``own_status``, ``trusted``, the red box and the exit give it for every
    rated value."""
    from psdesign.analysis.columns import error_bar, own_status

    n = 0
    for c, df, truth in _rated_tables():
        assert own_status(df, c).tolist() == [truth], (c, df.iloc[0].to_dict())
        shown = error_bar(df.iloc[0].to_dict(), c)[1]  # the values table's, optimize's
        assert shown == truth or (shown, truth) == ("unrated", "ok"), (c, df.iloc[0].to_dict())
        assert trusted(df)[c].notna().tolist() == [truth == "ok"], c
        assert (report_exit_status(df) == 3) == (truth != "ok"), (c, df.iloc[0].to_dict())
        assert bool(_status_banner(df)) == (truth != "ok"), (c, df.iloc[0].to_dict())
        n += 1
    from psdesign.analysis.columns import STATUS_COLUMNS

    assert n == len(STATUS_COLUMNS) * 12 >= 18 * 12  # every rated value, bar and own status
    capsys.readouterr()


def test_an_old_table_without_pore_and_surface_statuses_is_flagged_as_its_values_table_shows(
    capsys,
):
    """The reviewer's case: the values table shows case 1's pore sizes (25 % of d50) and S_v
    (35 %) ``[untrustworthy]``; now the red box counts them, ``study report`` exits 3,
    ``trusted`` leaves them out of the means and ``study optimize``'s target status says the
    same. The three pore sizes share one status (review s46: d90, 8.3 % of itself, was kept)."""
    from psdesign.analysis.targets import Target, target_report
    from psdesign.report.html import _values_table

    html = _values_table(OLD_PORES)
    assert html.count("[untrustworthy]") == 4, html  # d10, d50, d90 and S_v of c1
    assert report_exit_status(OLD_PORES) == 3
    box = _status_banner(OLD_PORES)
    assert "2 value(s) of ok cases not ok (pore_sizes_status, specific_surface_status)" in box
    t = trusted(OLD_PORES)  # out of the means
    for c in ("pore_d10_m", "pore_d50_m", "pore_d90_m", "specific_surface_m-1"):
        assert t[c].isna().tolist() == [False, True], c
    best = OLD_PORES.iloc[1].to_dict()
    assert target_report(Target.parse("specific_surface_m-1>=1e5"), best)["status"] == (
        "untrustworthy"
    )
    capsys.readouterr()


@pytest.mark.parametrize(
    ("d10_d50_d90", "error", "truth"),
    [
        ((10e-6, 20e-6, 40e-6), 3e-6, "ok"),  # 15 % of d50; d10's 30 % used to flag it
        ((10e-6, 12e-6, 40e-6), 3e-6, "untrustworthy"),  # 25 % of d50; d90's 7.5 % was kept
        ((10e-6, None, 40e-6), 3e-6, "ok"),  # no d50: no bar to rate by (unrated)
    ],
    ids=["d50_15pct", "d50_25pct", "no_d50"],
)
def test_an_old_tables_pore_sizes_are_rated_together_by_the_products_bar(
    d10_d50_d90, error, truth, capsys
):
    """Review s46: the product rates d10, d50 and d90 together by ``pore_diameter_error_m /
    pore_d50_m`` (``psdesign.transport.pores`` ``rel_error``, ``study_outputs.
    pore_sizes_status``), while the reading of a table without ``pore_sizes_status`` rated each
    by error / d_q: 3 um on 10/20/40 um flagged d10 (30 %) where the product says ok (15 %),
    exit 3; with d50 = 12 um (25 %: untrustworthy) ``trusted`` kept d90. Now all three carry
    the one status of their row: the values table, ``own_status``, ``trusted`` (all three or
    none), the red box and the exit."""
    from psdesign.analysis.columns import error_bar, own_status
    from psdesign.report.html import _values_table

    sizes = dict(zip(("pore_d10_m", "pore_d50_m", "pore_d90_m"), d10_d50_d90, strict=True))
    df = pd.DataFrame([{"case_id": "c0", "status": "ok", **sizes,
                        "pore_diameter_error_m": error}], dtype=object)  # fmt: skip
    kept = trusted(df)
    for c, v in sizes.items():
        if v is None:
            continue
        assert own_status(df, c).tolist() == [truth], c
        shown = truth if sizes["pore_d50_m"] else "unrated"  # its own bar, the row's status
        assert error_bar(df.iloc[0].to_dict(), c) == (error / v, shown), c
        assert kept[c].notna().tolist() == [truth == "ok"], c
    bad = truth != "ok"
    assert _values_table(df).count("[untrustworthy]") == 3 * bad  # d10, d50, d90 together
    assert (report_exit_status(df) == 3) == bad == bool(_status_banner(df))
    capsys.readouterr()


@pytest.mark.parametrize(
    ("own", "rel", "n_bad"),
    [
        (["ok", ""], [0.02, 0.03], 0),  # "": an in-memory unset own status
        (["ok", "untrustworthy"], [0.02, 0.03], 1),
        (None, [0.02, 0.30], 1),  # a table without k_z_status: rated by its 30 % bar
    ],
    ids=["empty_own_status", "untrustworthy", "old_table_30pct_bar"],
)
def test_the_k_and_convergence_tables_flag_the_k_the_red_box_counts(own, rel, n_bad, capsys):
    """Review s46: the Solver convergence and Permeability tables flagged a K by
    ``isinstance(st, str) and st != "ok"``: a K whose own status was an in-memory "" (unset,
    ``ok`` for the red box and the exit) was highlighted while the red box was empty. Now
    both read ``own_status`` (``k_not_ok``): the rows highlighted are the rows the red box
    counts, the exit 3 exactly when there are some."""
    from psdesign.report.html import _convergence, _k_table

    df = pd.DataFrame(
        {"case_id": ["c0", "c1"], "status": ["ok", "ok"], "k_z_m2": [1e-11, 2e-11],
         "k_z_rel_error": rel, "iterations_z": [40, 41]}
    )  # fmt: skip
    if own is not None:
        df["k_z_status"] = pd.Series(own, dtype=object)
    assert _convergence(df)[2] == n_bad
    assert _k_table(df).count('class="flag"') == n_bad
    assert bool(_status_banner(df)) == (n_bad > 0) == (report_exit_status(df) == 3)
    capsys.readouterr()


def test_a_value_rated_converged_is_trusted_by_every_reader_of_the_report(capsys):
    """Review s51: ``k_not_ok`` (the fits, the red box, the exit) read a value's own status by
    the exit's rule (``converged`` and ``at_bound`` pass), ``value_status`` and the report's
    tables by ``ok`` alone: a K rated ``converged`` stayed in the fits while its figures
    drew it "(not in fits)" and the values and K tables highlighted its row (a D_eff/D rated
    ``converged`` likewise). Truth: the exit's
    rule (``psdesign.status.TRUSTED``; docs: exit 0 for ``converged``), so the same table with
    ``ok`` in place of ``converged`` reads the same everywhere, and ``untrustworthy`` still
    flags (the rule is not "anything passes")."""
    from psdesign.analysis.columns import k_not_ok
    from psdesign.report.decision import add_anisotropy
    from psdesign.report.html import _k_table, _values_table
    from psdesign.report.trust import not_ok_status

    def table(word):
        return pd.DataFrame(
            {"case_id": ["c0", "c1"], "status": ["ok", "ok"], "k_x_m2": [4e-11, 4e-11],
             "k_x_rel_error": [0.02, 0.02], "k_x_status": ["ok", "ok"], "k_z_m2": [2e-11, 1e-11],
             "k_z_rel_error": [0.02, 0.03], "k_z_status": ["ok", word],
             "diffusivity_z": [0.5, 0.4], "diffusivity_z_rel_error": [0.02, 0.03],
             "diffusivity_z_status": ["ok", word]}
        )  # fmt: skip

    conv, bad = table("converged"), table("untrustworthy")
    assert k_not_ok(conv, "k_z_m2").tolist() == [False, False]  # in the fits
    assert value_ok(conv, "k_z_m2").tolist() == [True, True]
    assert not_ok_status(conv, "k_z_m2") == {}  # drawn as a trusted point, not "(not in fits)"
    assert list(not_ok_status(bad, "k_z_m2")) == ["untrustworthy"]
    assert not_ok_status(conv, "diffusivity_z", log=False) == {}
    assert add_anisotropy(conv)["anisotropy_status"].tolist() == ["ok", "ok"]
    assert add_anisotropy(bad)["anisotropy_status"].tolist() == ["ok", "untrustworthy"]
    for reader in (_values_table, _k_table):  # no row highlighted, as the red box counts none
        assert reader(conv).count('class="flag"') == 0 == bool(_status_banner(conv))
        assert reader(bad).count('class="flag"') == 1
    assert "[converged]" not in _values_table(conv) and "[untrustworthy]" in _values_table(bad)
    capsys.readouterr()


@pytest.mark.parametrize(
    "word",
    ["ok", "converged", "at_bound", "not_applicable", "untrustworthy", "blocked", "extrapolated"],
)
def test_the_k_and_values_tables_write_and_highlight_a_status_by_the_one_rule(word, capsys):
    """Session 52: the K table highlighted a row by ``passes`` (the red box's rule) but wrote
    every word other than ``ok`` under the K (``converged`` too, which every other reader
    reads as ``ok``); the values table wrote and highlighted every word outside ``TRUSTED``,
    so a ``not_applicable`` value's row was highlighted while the red box and the exit passed
    it. Truth: the one rule of :mod:`psdesign.status` as the exit applies it (docs: exit 0 for
    ``converged`` / ``at_bound``, ``not_applicable`` passes): a row is highlighted exactly
    when ``study report`` exits 3 for it, and a word is written exactly when it is not read
    as ``ok`` (not in ``TRUSTED``)."""
    from psdesign.report.html import _k_table, _values_table
    from psdesign.status import TRUSTED

    df = pd.DataFrame(
        {"case_id": ["c0"], "status": ["ok"], "k_z_m2": [1e-11], "k_z_rel_error": [0.02],
         "k_z_status": [word], "diffusivity_z": [0.4], "diffusivity_z_rel_error": [0.03],
         "diffusivity_z_status": [word]}
    )  # fmt: skip
    bad = report_exit_status(df) == 3
    assert bad == (word in ("untrustworthy", "blocked", "extrapolated"))  # the exit's rule
    k, values = _k_table(df, "fem"), _values_table(df)
    for table in (k, values):
        assert table.count('class="flag"') == bad, (word, table)
    written = word not in TRUSTED
    assert (f'<span class="kst">{word}' in k) == written, k
    assert (f"[{word}]" in values) == written, values
    capsys.readouterr()


@pytest.mark.parametrize("own", ["ok", "converged"])
def test_the_k_cell_of_a_failed_case_shows_the_case_status(own, capsys):
    """Review A (session 52): the K cell writes the case's word when the case is not ok and the
    value's own word passes (a trusted ``converged`` must not hide that the case failed); the
    test above used an ok case only, so a K cell writing its own word alone passed it."""
    from psdesign.report.html import _k_table

    df = pd.DataFrame(
        {"case_id": ["c0"], "status": ["failed"], "k_z_m2": [1e-11], "k_z_rel_error": [0.02],
         "k_z_status": [own]}
    )  # fmt: skip
    k = _k_table(df, "fem")
    assert '<span class="kst">failed' in k and f'<span class="kst">{own}' not in k, k
    capsys.readouterr()


def test_trusted_blanks_every_value_that_shares_a_blanked_bar():
    """``trusted`` blanked each not-ok value and its bar in turn, then rated the next value: the
    tortuosity of a table without ``diffusivity_x_status`` shares ``diffusivity_x_rel_error``,
    blanked with the diffusivity, so a 35 % tortuosity read unrated and stayed in the means
    (found mending review s46). The truth is the rule applied to each value alone
    (``own_status``): both untrustworthy, both blanked, the 2 % row kept."""
    from psdesign.analysis.columns import own_status

    df = pd.DataFrame(
        {
            "status": ["ok", "ok"],
            "diffusivity_x": [0.5, 0.6],
            "tortuosity_x": [1.6, 1.4],
            "diffusivity_x_rel_error": [0.35, 0.02],
        }
    )
    for c in ("diffusivity_x", "tortuosity_x"):
        assert own_status(df, c).tolist() == ["untrustworthy", "ok"], c
        assert trusted(df)[c].isna().tolist() == [True, False], c


def test_a_whole_column_is_rated_as_error_bar_rates_each_row():
    """``own_status`` rates an old table's column at once (session 47: one row at a time
    through ``error_bar`` took 20-60 ms per 2000 rows); the truth is ``error_bar``'s rule,
    row by row, over every cell a row can hold: a value missing, 0, negative, infinite or a
    string, a bar missing, 0, just under, at and over 20 %, infinite or a string, an own status
    missing, empty or set. A rule coded twice that disagreed on one cell fails here."""
    import numpy as np

    from psdesign.analysis.columns import error_bar, own_status

    values = [np.nan, 0.0, -0.5, 0.5, 2e-5, np.inf, "0.5", "x"]
    bars = [np.nan, 0.0, 0.0999, 0.1, 0.1001, 1.0, np.inf, "0.02", "y"]  # x 0.5: 20 % at 0.1
    owns = [None, "", "ok", "untrustworthy"]
    cells = list(itertools.product(values, bars, owns))
    for value, error, status in (
        ("porosity", "porosity_error", "porosity_status"),
        ("k_z_m2", "k_z_rel_error", "k_z_status"),
        ("pore_d10_m", "pore_diameter_error_m", "pore_sizes_status"),
    ):
        df = pd.DataFrame(cells, columns=[value, error, status], dtype=object)
        if value == "pore_d10_m":  # rated by d50's bar (RATED_BY): d50 is the cell's value
            df["pore_d50_m"] = df[value]
        for table in (df, df.drop(columns=status)):
            rows = table.to_dict("records")
            truth = []
            for r in rows:  # its own status when set, else error_bar's; unrated reads ok
                st = r.get(status) or error_bar(r, value)[1]
                truth.append(st if st not in ("unrated", "no trusted value") else "ok")
            assert own_status(table, value).tolist() == truth, value


@pytest.mark.parametrize("with_status", [False, True], ids=["old_table", "pore_sizes_status"])
def test_the_values_table_shows_the_bar_that_rates_the_pore_sizes(with_status, capsys):
    """Session 46 left it: an old table's d10, d50 and d90 are rated by
    ``pore_diameter_error_m / pore_d50_m`` (s46-mend4), while the values table printed each
    size ± its own fraction: 3 um on d10 = 10 um read "± 30.0 %" beside no flag (ok by d50's
    15 %), and on d90 = 40 um "± 7.5 %" beside ``[untrustworthy]`` (d50 = 12 um: 25 %). Each
    size is now printed ± the one absolute bar and d50 with the fraction that rates the three,
    so a cell's flag is read off the table: flagged exactly when that fraction is above 20 %.
    Truth: 3 / 20 = 15 %, 3 / 12 = 25 % (and the product's own rows, which carry
    ``pore_sizes_status``, are printed the same way)."""
    import re

    from psdesign.report.html import _values_table

    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1"],
            "status": ["ok", "ok"],
            "pore_d10_m": [10e-6, 10e-6],
            "pore_d50_m": [20e-6, 12e-6],
            "pore_d90_m": [40e-6, 40e-6],
            "pore_diameter_error_m": [3e-6, 3e-6],
        }
    )
    if with_status:
        df["pore_sizes_status"] = ["ok", "untrustworthy"]
    html = _values_table(df)
    rows = re.findall(r"<tr[^>]*>(.*?)</tr>", html.split("<tbody>", 1)[1], flags=re.S)
    cells = [re.findall(r"<td>(.*?)</td>", r) for r in rows]
    assert [c[2:] for c in cells] == [
        ["1e-05 +3.0e-06/-0", "2e-05 +3.0e-06/-0 (15.0 %)", "4e-05 +3.0e-06/-0"],
        [
            "1e-05 +3.0e-06/-0 [untrustworthy]",
            "1.2e-05 +3.0e-06/-0 (25.0 %) [untrustworthy]",
            "4e-05 +3.0e-06/-0 [untrustworthy]",
        ],
    ]  # each bar one-sided, above (session 48; test_pore_diameters_print_their_bar_one_sided)
    assert "30.0 %" not in html and "7.5 %" not in html  # no size's own fraction
    assert "rated together by the larger side over d50 (the % beside d50" in html
    assert "d90 above the smallest edge the geometry varies along" in html  # the rating's own words
    capsys.readouterr()


def test_pore_diameters_print_their_bar_one_sided():
    """Session 48 (the session-47 re-read): d10, d50 and d90 were printed ``value ± bar`` and
    drawn with a bar both ways, although their bar is one-sided: the local-thickness scan
    measures low (balls on voxel centres, the radius step), so the true diameter lies between
    the value and the value + ``pore_diameter_error_m``, never below (docs/transport.md,
    ``psdesign.transport.pores``). The values table prints ``+bar/-0``; a frame against a
    design parameter draws the numerical bar above the mean only: two seeds of d50 = 20 and
    22 um, bar 3 um, have the mean 21 um, the 95 % CI half-width t(0.975, 1) s / sqrt(2) =
    12.706 um (s = sqrt(2) um), so the bar reaches 12.706 + 3 um above and 12.706 um below;
    one case at the other level (no CI) 3 um above and 0 below."""
    import json
    import re

    from psdesign.report.decision import parameter_plots
    from psdesign.report.html import _values_table

    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1", "c2"],
            "status": ["ok"] * 3,
            "generator.porosity": [0.7, 0.7, 0.8],
            "seed": [1, 2, 1],
            "pore_d10_m": [10e-6, 11e-6, 15e-6],
            "pore_d50_m": [20e-6, 22e-6, 30e-6],
            "pore_d90_m": [40e-6, 41e-6, 50e-6],
            "pore_diameter_error_m": [3e-6] * 3,
            "pore_sizes_status": ["ok"] * 3,
        }
    )
    table = _values_table(df)
    assert "2e-05 +3.0e-06/-0 (15.0 %)" in table and "1e-05 +3.0e-06/-0" in table, table
    assert "±" not in table.split("<tbody>", 1)[1], table  # no pore diameter ± its bar
    html = parameter_plots(df, ["generator.porosity"])
    frame = r'id="psd-pore_d50_m-generator.porosity".*?newPlot\(\s*"[^"]+",\s*(\[.*?\]),\s*\{'
    fig = re.search(frame, html, re.S)
    trace = json.loads(fig.group(1))[0]
    assert trace["error_y"]["symmetric"] is False
    assert trace["error_y"]["array"] == pytest.approx([12.7062e-6 + 3e-6, 3e-6], rel=1e-4)
    assert trace["error_y"]["arrayminus"] == pytest.approx([12.7062e-6, 0.0], rel=1e-4, abs=1e-12)
    # the frame's title says so (plotly writes "/" as "\\u002f" in its JSON)
    title = "pore_d50_m vs generator.porosity (bar one-sided: +bar/-0)"
    assert title.replace("/", "\\u002f") in html


def test_a_pore_diameter_target_reads_its_bar_one_sided():
    """Session 48: ``study optimize``'s verdicts took a pore diameter's bar both ways. The
    true d50 lies between the measured value and the value + ``pore_diameter_error_m``
    (docs/transport.md), so d50 = 21 um with a 3 um bar (14.3 % of it) meets ``>= 20 um``
    with its whole bar (21-24 um; the symmetric 18-24 um "reached outside") and misses
    ``<= 20 um`` beyond its bar (the symmetric one "could not tell"); the line prints the bar
    ``+14.3 %/-0``. Truth: interval arithmetic on [21, 24] um."""
    from psdesign.analysis.targets import Target, measured_text, target_report

    row = {"pore_d50_m": 21e-6, "pore_diameter_error_m": 3e-6, "pore_sizes_status": "ok"}
    above = target_report(Target.parse("pore_d50_m>=20e-6"), row)
    assert above["met"] and above["error_bar_inside_target"]
    assert measured_text(above) == "measured 2.1e-05 +14.3 %/-0 [ok] (met)"
    below = target_report(Target.parse("pore_d50_m<=20e-6"), row)
    assert not below["met"] and not below["target_within_error_bar"]
    assert measured_text(below) == "measured 2.1e-05 +14.3 %/-0 [ok] (missed)"
    k = {"k_z_m2": 21e-12, "k_z_rel_error": 3 / 21, "k_z_status": "ok"}  # a K's bar: both ways
    r = target_report(Target.parse("k_z_m2<=20e-12"), k)
    assert r["target_within_error_bar"] and "+- 14.3 %" in measured_text(r)


def test_the_values_table_rates_d50_by_its_larger_side():
    """Session 54 review (/tmp/rr-mendpores/slit.py): the fraction beside d50 was the upper
    side over d50 alone (12.4 %) beside the [untrustworthy] its 55 % lower side gave. The
    product rates the pore sizes by the larger side over d50 (``rel_error``, the 20 % rule):
    d50 = 20 um +2.5/-11 um prints 11 / 20 = 55.0 %, and where every face repeats (NaN
    lower side) the upper side's 12.5 %."""
    from psdesign.report.html import _values_table

    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1"],
            "status": ["ok"] * 2,
            "pore_d10_m": [10e-6] * 2,
            "pore_d50_m": [20e-6] * 2,
            "pore_d90_m": [40e-6] * 2,
            "pore_diameter_error_m": [2.5e-6] * 2,
            "pore_diameter_error_below_m": [11e-6, float("nan")],
            "pore_sizes_status": ["untrustworthy", "ok"],
        }
    )
    table = _values_table(df)
    assert "2e-05 +2.5e-06/-1.1e-05 (55.0 %) [untrustworthy]" in table, table
    assert "2e-05 +2.5e-06/-0 (12.5 %)" in table, table
    assert "(12.5 %) [untrustworthy]" not in table
    assert "down to the value - pore_diameter_error_below_m (+bar/-below)" in table


def test_a_pore_diameter_target_reads_the_lower_bar_where_a_face_does_not_repeat():
    """Session 54 review (/tmp/rr-mendpores/slit.py): where a face of the box does not repeat
    the truth of d50 may lie ``pore_diameter_error_below_m`` below it, yet the verdicts took
    the bar +above/-0: d50 = 20 um, 2 um above, 3 um below, "met" ``>= 18 um`` with the bar
    inside although it reaches 17 um. Truth: interval arithmetic on [17, 22] um: it
    overlaps 18 um and up but does not lie inside; ``<= 17.5 um`` lies within it; ``>= 16.5
    um`` holds the whole of it. The bar prints +10 %/-15 %; an old row (no
    ``rel_error_below``) or NaN in the column keeps -0."""
    from psdesign.analysis.targets import Target, measured_text, target_report

    row = {
        "pore_d50_m": 2e-5,
        "pore_diameter_error_m": 2e-6,
        "pore_diameter_error_below_m": 3e-6,
        "pore_sizes_status": "ok",
    }
    r = target_report(Target.parse("pore_d50_m>=1.8e-5"), row)
    assert r["rel_error_below"] == pytest.approx(0.15)
    assert r["met"] and r["target_within_error_bar"] and not r["error_bar_inside_target"], r
    assert measured_text(r) == (
        "measured 2e-05 +10 %/-15 % [ok] (met; the error bar reaches outside the target)"
    )
    r = target_report(Target.parse("pore_d50_m<=1.75e-5"), row)
    assert not r["met"] and r["target_within_error_bar"], r
    assert "(missed; the target lies within the measurement's error bar)" in measured_text(r)
    r = target_report(Target.parse("pore_d50_m>=1.65e-5"), row)
    assert measured_text(r) == "measured 2e-05 +10 %/-15 % [ok] (met)"
    old = target_report(Target.parse("pore_d50_m>=1.8e-5"), row)
    del old["rel_error_below"]  # a row written before session 54: its stored words, -0
    old["error_bar_inside_target"] = True
    assert measured_text(old) == "measured 2e-05 +10 %/-0 [ok] (met)"
    periodic = {**row, "pore_diameter_error_below_m": float("nan")}
    r = target_report(Target.parse("pore_d50_m>=1.8e-5"), periodic)
    assert r["rel_error_below"] == 0.0 and r["error_bar_inside_target"]
    assert measured_text(r) == "measured 2e-05 +10 %/-0 [ok] (met)"


def test_a_pore_diameter_frame_draws_the_lower_bar_where_a_face_does_not_repeat():
    """Session 54 review: the frames against a design parameter drew a pore diameter's bar
    +bar/-0 (and titled it so) although a case whose box does not repeat along a face
    carries ``pore_diameter_error_below_m``. One case per level (no CI): the bar reaches
    3 um above and the row's 5 um (and 0 where the column is NaN) below, and the title says
    +bar/-below."""
    import json
    import re

    from psdesign.report.decision import parameter_plots

    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1"],
            "status": ["ok"] * 2,
            "generator.porosity": [0.7, 0.8],
            "seed": [1, 1],
            "pore_d10_m": [10e-6, 15e-6],
            "pore_d50_m": [20e-6, 30e-6],
            "pore_d90_m": [40e-6, 50e-6],
            "pore_diameter_error_m": [3e-6] * 2,
            "pore_diameter_error_below_m": [5e-6, float("nan")],
            "pore_sizes_status": ["ok"] * 2,
        }
    )
    html = parameter_plots(df, ["generator.porosity"])
    frame = r'id="psd-pore_d50_m-generator.porosity".*?newPlot\(\s*"[^"]+",\s*(\[.*?\]),\s*\{'
    trace = json.loads(re.search(frame, html, re.S).group(1))[0]
    assert trace["error_y"]["array"] == pytest.approx([3e-6, 3e-6])
    assert trace["error_y"]["arrayminus"] == pytest.approx([5e-6, 0.0], abs=1e-12)
    title = "pore_d50_m vs generator.porosity (bar +bar/-below: a face does not repeat)"
    assert title.replace("/", "\\u002f") in html
    assert "+bar\\u002f-0" not in html


def test_an_old_optimize_json_reads_a_pore_diameters_bar_one_sided():
    """Session 48 review: an ``optimize.json`` written before the one-sided pore bar stored
    the two-sided bar's verdicts, and the report printed them under the one-sided bar it
    shows: d50 = 21 um with a 3 um bar ``+14.3 %/-0`` (21-24 um) "missed; the target lies
    within the measurement's error bar" for ``<= 20 um``. The line re-reads a one-sided bar's
    verdicts from the row's target, value and bar. Truth: interval arithmetic on [21, 24] um,
    which lies wholly above 20 um (missed, beyond the bar) and wholly above 19 um (met, the
    whole bar inside ``>= 19 um``). The row needs ``output`` and ``target``: without
    ``output`` the line printed the bar ``+-`` (REPORT_KEYS did not list it)."""
    from psdesign.analysis.targets import REPORT_KEYS, measured_text

    old = {  # the row as the session-47 code wrote it: bar 18-24 um both ways
        "target": "pore_d50_m<=2e-05",
        "output": "pore_d50_m",
        "measured": 21e-6,
        "rel_error": 3 / 21,
        "status": "ok",
        "met": False,
        "target_within_error_bar": True,
        "error_bar_inside_target": False,
    }
    assert measured_text(old) == "measured 2.1e-05 +14.3 %/-0 [ok] (missed)"
    met = dict(old, target="pore_d50_m>=1.9e-05", met=True)  # the old code: bar 18-24 "outside"
    assert measured_text(met) == "measured 2.1e-05 +14.3 %/-0 [ok] (met)"
    k = dict(old, target="k_z_m2<=2e-11", output="k_z_m2", measured=21e-12)  # both ways: stored
    assert measured_text(k).endswith("(missed; the target lies within the measurement's error bar)")
    assert {"output", "target"} <= REPORT_KEYS


def test_a_pore_diameter_verdict_at_the_targets_edge_reads_the_stored_number():
    """Session 49: the one-sided bar's verdicts were recomputed from the row's target text,
    whose value is rounded to 6 digits (``pore_d50_m<=2e-05`` for 2.0000004e-05). d50 = 19 um
    with a bar up to 20.0000002 um lies wholly inside ``<= 20.0000004 um`` (stored: met, bar
    inside), but against the text's 20 um its bar "reached outside the target". The row now
    stores the number (``target_value``, ``target_tolerance``; through JSON, as optimize.json
    holds it) and the line reads it; a row without them (an older file) still reads its
    text. Truth: interval arithmetic on [19, 20.0000002] um."""
    import json

    from psdesign.analysis.targets import Target, measured_text, target_report

    row = {"pore_d50_m": 19e-6, "pore_diameter_error_m": 1.0000002e-6, "pore_sizes_status": "ok"}
    t = Target.parse("pore_d50_m<=2.0000004e-05")
    r = json.loads(json.dumps(target_report(t, row)))
    assert r["target"] == "pore_d50_m<=2e-05" and r["target_value"] == 2.0000004e-05
    assert r["target_tolerance"] is None  # a <= target has none
    band = target_report(Target.parse("pore_d50_m=2e-05+-5.00000004%"), row)
    assert band["target"] == "pore_d50_m=2e-05+-5%"
    assert band["target_tolerance"] == pytest.approx(0.0500000004, rel=1e-12)
    assert r["met"] and r["error_bar_inside_target"]
    assert measured_text(r) == "measured 1.9e-05 +5.26 %/-0 [ok] (met)"
    older = {k: v for k, v in r.items() if k not in ("target_value", "target_tolerance")}
    assert measured_text(older).endswith("(met; the error bar reaches outside the target)")
