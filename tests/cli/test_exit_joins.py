"""The exit status agrees with the statuses the command printed (session 45 review).

Four branches met in session 45: one exit rule (:func:`psdesign.cli.exit_status.status_code`),
``--bc both`` printing the other model's K, the transport and pore commands' statuses. The
truth here is the rule itself read off the printed JSON: every ``status`` (and ``*_status``) a
command's ``--json`` prints, at any depth, is ``ok`` (or a search's ``converged`` /
``at_bound``) exactly when it exits 0; else it exits 3. Each case also pins the code it must
give on the one-cylinder RVE (closed forms: the 8 um cylinder along z in a 20 um cell does not
span x, so an insulating fluid blocks sigma_eff along x and y), so the test is not vacuous.
"""

from __future__ import annotations

import json

import pytest
from cylinder_spec import CYLINDER_SPEC as SPEC
from printed_statuses import printed_statuses

from psdesign.cli.exit_status import status_code
from psdesign.cli.main import main


@pytest.mark.parametrize(
    ("argv", "code"),
    [
        (["diffusivity", "--direction", "z"], 0),
        (["conductivity", "--direction", "all", "--insulating", "fluid", "--solid", "10"], 3),
        (["conductivity", "--direction", "z", "--insulating", "fluid", "--solid", "10"], 0),
        (["permeability", "--solver", "voxel", "--direction", "z", "--bc", "both"], 0),
        (["pores"], 0),
    ],
)
def test_the_exit_status_is_the_rule_applied_to_the_printed_statuses(tmp_path, capsys, argv, code):
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC)
    got = main([argv[0], str(spec), *argv[1:], "--json", "--quiet"])
    out = json.loads(capsys.readouterr().out)
    printed = printed_statuses(out)
    assert printed, out  # every command prints its status
    assert got == status_code(*printed), (got, printed)
    if code is not None:
        assert got == code, printed


def test_the_flagged_line_words_each_status_column_as_its_rating_means(capsys):
    """Review s46: ``flagged_text`` (``study run``'s and ``rev``'s line) gave every status
    column K's meaning, "untrustworthy = error bar above 20 % or fewer than 8 cells per fiber
    diameter, blocked = no conducting path". Each rating says what its words mean: the
    porosity by its bar alone (``columns.porosity_status``); Omega by the overlaps its count
    may miss (``packing.overlap_status``); K by ``flow.error.status_of`` (bar, resolution; no
    ``blocked``); the transport values by ``transport.effective.rating`` (also ``blocked``);
    the pore sizes also by d90 against the RVE (``study_outputs.pore_sizes_status``)."""
    import pandas as pd

    from psdesign.analysis.columns import STATUS_COLUMNS, flagged_text

    bar, cells = "error bar above 20 %", "fewer than 8 cells per fiber diameter"
    for st in dict.fromkeys(STATUS_COLUMNS.values()):
        line = flagged_text(pd.DataFrame({"status": ["ok"], st: ["untrustworthy"]}))
        assert f"({st}: " in line, f"{st} has no words (psdesign.status.STATUS_WORDS): {line}"
        words = line.split(f"({st}: ")[1]
        assert words.startswith("untrustworthy = "), line
        overlap = "overlaps thinner than a voxel (which the count may miss)" in words
        assert overlap == (st == "intersection_volume_fraction_status"), line
        assert (bar in words) == (not overlap), line
        assert (cells in words) == (not overlap and st != "porosity_status"), line
        assert ("d90" in words) == (st == "pore_sizes_status"), line
        blocked = st.startswith(("diffusivity_", "conductivity_"))
        assert ("blocked = no conducting path" in words) == blocked, line
    two = pd.DataFrame({"status": ["ok", "ok"], "porosity_status": ["untrustworthy", "ok"],
                        "k_z_status": ["ok", "untrustworthy"]})  # fmt: skip
    assert flagged_text(two) == (
        f"2 ok case(s) have a value whose own status is not ok (porosity_status: untrustworthy "
        f"= {bar}; k_z_status: untrustworthy = {bar} or {cells})"
    )
    capsys.readouterr()


def test_the_words_are_a_table_of_exactly_the_status_columns():
    """Session 47: the words were a chain of tests on a column's name beside the ratings, and
    a new status column needed a line there that only the test above noticed (as an
    IndexError). They are one table keyed by status column: its keys are exactly the status
    columns of ``analysis.columns.STATUS_COLUMNS`` (a column without words, or words of a
    column that is gone, fails here), each with words."""
    from psdesign.analysis.columns import STATUS_COLUMNS
    from psdesign.status import STATUS_WORDS

    columns = set(STATUS_COLUMNS.values())
    assert set(STATUS_WORDS) == columns, set(STATUS_WORDS) ^ columns
    assert all(w.startswith("untrustworthy = ") for w in STATUS_WORDS.values()), STATUS_WORDS


# ------------------------------------------------------- study report: its exit and its red box
def _report_folder(tmp_path_factory):
    """The factorial fake study (12 ok cases, porosity 0.7-0.9, K_x and K_z with 2 % bars):
    the folder whose results.csv each edge case below rewrites."""
    from study_cases import FAC_PARAMS, FACTORIAL, fake_case, write_study

    from psdesign.study import run_study

    tmp = tmp_path_factory.mktemp("report_exit")
    out = tmp / "out"
    run_study(write_study(tmp, FACTORIAL, FAC_PARAMS), out, workers=0, case_fn=fake_case,
              progress=False, report=False)  # fmt: skip
    return out


@pytest.fixture(scope="module")
def report_folder(tmp_path_factory):
    return _report_folder(tmp_path_factory)


def _no_status_column(df):
    return df.drop(columns="status")  # a table of values only: every case ok (trusted's reading)


def _status_without_value(df):
    df["k_y_status"] = ["untrustworthy"] + ["ok"] * (len(df) - 1)  # the study solved no K_y
    return df


def _missing_case_status(df):
    df["status"] = df["status"].astype(object)
    df.loc[0, "status"] = None  # an empty cell: "unknown", counted failed
    return df


def _coarse_porosity(df):
    """An ok case whose porosity has a 27 % bar, in a table written before session 46 (no
    porosity_status: rated by its bar, as generate rates it; the report's values table said
    untrustworthy while the exit, the box and the frames took it as ok)."""
    df["porosity_error"] = [0.27 * df.loc[0, "porosity"]] + [1e-3] * (len(df) - 1)
    return df.drop(columns="porosity_status", errors="ignore")


def _old_pore_table(df):
    """A table written before abe85ab: pore sizes with their absolute bar and S_v with its
    relative one, no pore_sizes_status / specific_surface_status; case 0's pore bar 25 % of
    d50 (the product's rating of all three), its S_v bar 35 % (review s46: the values table
    said untrustworthy, the exit 0, no red box)."""
    n = len(df)
    df["pore_d10_m"], df["pore_d50_m"], df["pore_d90_m"] = 2e-6, 8e-6, 12e-6
    df["pore_diameter_error_m"] = [2e-6] + [1e-7] * (n - 1)
    df["specific_surface_m-1"] = 2e5
    df["specific_surface_rel_error"] = [0.35] + [0.02] * (n - 1)
    return df.drop(columns=["pore_sizes_status", "specific_surface_status"], errors="ignore")


def _old_pore_table_ok(df):
    """``_old_pore_table`` with every bar below 20 %: no flag (the 20 % rule, not any bar)."""
    df = _old_pore_table(df)
    df["pore_diameter_error_m"] = 1e-7
    df["specific_surface_rel_error"] = 0.19
    return df


def _old_pore_table_d10_bar_30pct(df):
    """``_old_pore_table_ok`` with case 0's pore bar 3 um on d 10/20/40 um: 15 % of d50, ``ok``
    as the product rates the three together (pores.py ``rel_error``; review s46: d10's own
    30 % flagged it, exit 3)."""
    df = _old_pore_table_ok(df)
    df["pore_d10_m"], df["pore_d50_m"], df["pore_d90_m"] = 10e-6, 20e-6, 40e-6
    df["pore_diameter_error_m"] = [3e-6] + [1e-7] * (len(df) - 1)
    return df


def _scattered_k(df):
    """Review s52 (walk-report 2): K_z scattered over two decades by a seeded draw, each with
    its 2 % bar (every case ok), so the surrogate the report draws cross-validates far above
    20 % (`study fit` exits 3 on it); `study report` exited 0 with no red box."""
    import numpy as np

    rng = np.random.default_rng(52)
    df["k_z_m2"] = df["k_z_m2"] * 10.0 ** rng.uniform(-1.0, 1.0, len(df))
    return df


@pytest.mark.parametrize(
    ("edit", "code"),
    [
        (lambda df: df, 0),
        (_scattered_k, 3),  # review s52: exit 0, the untrustworthy fit in its section only
        (_no_status_column, 0),  # session 45: the red box said "12 unknown", the exit crashed
        (_status_without_value, 3),  # session 45: exit 3, no red box
        (_missing_case_status, 3),
        (_coarse_porosity, 3),  # session 45: exit 0, no red box
        (_old_pore_table, 3),  # review s46: exit 0, no red box, [untrustworthy] cells
        (_old_pore_table_ok, 0),
        (_old_pore_table_d10_bar_30pct, 0),  # review s46: exit 3, d10 rated by error / d10
    ],
    ids=[
        "all_ok",
        "scattered_k",
        "no_status_column",
        "status_without_value",
        "missing_case_status",
        "coarse_porosity",
        "old_pore_table",
        "old_pore_table_ok",
        "old_pore_table_d10_bar_30pct",
    ],
)
def test_study_report_exits_3_exactly_when_its_red_box_is_there(report_folder, capsys, edit, code):
    """``study report``'s exit (``cli.exit_status.case_masks``) and its red box
    (``report.html._status_banner``) read one definition of a case not ok
    (``analysis.columns.case_status``, ``flagged_values``): until session 46 they were two
    checks, which disagreed on a table without a ``status`` column (the box showed every case
    as ``unknown``; the exit raised KeyError) and on a status column without its value
    column (the exit counted it, the box did not). The truth is the rule read off the report
    itself: exit 3 exactly when the red box is there; each edge case also pins its code."""
    import pandas as pd

    results = report_folder / "results.csv"
    original = results.read_bytes()
    try:
        edit(pd.read_csv(results)).to_csv(results, index=False)
        capsys.readouterr()
        got = main(["study", "report", str(report_folder)])
        html = (report_folder / "report.html").read_text()
        box = 'id="psd-status-alert"' in html
    finally:
        results.write_bytes(original)
    assert got == (3 if box else 0), (got, box, capsys.readouterr().err)
    assert got == code
    # the values table's [untrustworthy] cells (error_bar) and the box read one rule (s46)
    assert ("[untrustworthy]" in html) <= box


def test_study_report_exits_3_when_its_design_decision_is_not_met(tmp_path, capsys):
    """Review s52 (walk-report 2): after `study optimize` exited 3 (NOT MET), `study report`
    of the folder exited 0 under a report headed by the red NOT MET box. Truth: the fake
    case's K_z = 2 KC(eps) (study_cases.kc_truth) is below 5e-11 m² over porosity 0.8-0.88
    (KC(0.88, 3.5 um) = 1.1e-11), so a target of 1e-9 m² +-10 % cannot be met; the same
    folder with its outcome edited to met exits 0 and has no box (4 cases: no surrogate)."""
    from study_cases import write_study

    study = 'design = "latin-hypercube"\nn_samples = 4\nseeds = [1]\noutputs = ["porosity", "k_z"]'
    p = write_study(tmp_path, study, '"generator.porosity" = {low = 0.8, high = 0.88}')
    out = tmp_path / "opt"
    argv = ["study", "optimize", str(p), "-o", str(out), "--budget", "4", "--workers", "0"]
    argv += ["--quiet", "--case-fn", "study_cases:fake_case", "--target", "k_z_m2=1e-9+-10%"]
    assert main(argv) == 3
    capsys.readouterr()
    assert main(["study", "report", str(out)]) == 3
    err = capsys.readouterr().err
    assert "the design decision (study optimize) is NOT MET for k_z_m2=1e-09+-10%" in err
    box = (out / "report.html").read_text().split('id="psd-status-alert">')[1].split("</p>")[0]
    assert "NOT MET for k_z_m2=1e-09+-10%" in box
    doc = json.loads((out / "optimize.json").read_text())
    (out / "optimize.json").write_text(json.dumps({**doc, "met": True}))
    assert main(["study", "report", str(out)]) == 0
    assert 'id="psd-status-alert"' not in (out / "report.html").read_text()


@pytest.mark.parametrize(("y", "code"), [("13.3e-6", 0), ("17.6e-6", 3)])
def test_generate_exits_by_both_statuses_it_prints(tmp_path, capsys, y, code):
    """``generate`` prints the porosity's and Omega's statuses (session 46) and exits by the
    rule on both. Two perpendicular 8 um cylinders in a 20 um cell at 1 um voxels: axes 3.3 um
    apart, a lens 4.7 um deep, the second axis off the voxel faces (Omega resolved, ``ok``);
    7.6 um apart, a lens 0.4 um deep that
    holds no voxel centre (Omega ``0 +- 0`` against the exact 2.45e-4: ``untrustworthy``)."""
    cyl = '\n[[fibers]]\nshape = "cylinder"\ndiameter = 8e-6\n'
    spec = tmp_path / "s.toml"
    spec.write_text(
        "[rve]\nsize = [20e-6, 20e-6, 20e-6]\nvoxel = 1e-6\n"
        + cyl
        + "center = [10e-6, 10e-6, 10e-6]\ndirection = [1, 0, 0]\n"
        + cyl
        + f"center = [10e-6, {y}, 10e-6]\ndirection = [0, 0, 1]\n"
    )
    got = main(["generate", str(spec), "-o", str(tmp_path / "out"), "--no-preview", "--quiet"])
    printed = printed_statuses(json.loads(capsys.readouterr().out))
    assert len(printed) == 2, printed  # the porosity's and Omega's
    assert got == status_code(*printed) == code, printed
