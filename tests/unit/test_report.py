"""Tests of the study report and its reference permeability models."""

from __future__ import annotations

import base64
import json
import math
import re

import numpy as np
import pandas as pd
import pytest
from study_cases import (
    FAC_PARAMS,
    FACTORIAL,
    failing_case,
    fake_case,
    kc_truth,
    mixed_status_case,
    untrusted_case,
    write_entangled_study,
    write_study,
)

from psdesign.analysis.columns import value_status
from psdesign.report import (
    ReportError,
    kozeny_carman,
    tomadakis_sotirchos,
    write_report,
)
from psdesign.report.sensitivity import main_effects, sensitivity_table
from psdesign.report.trust import NOT_OK_MARKERS, status_style
from psdesign.study import run_study


def test_kozeny_carman_hand_value():
    # eps = 0.8, r = 3.5 um, k_K = 5:
    # K = r^2 eps^3 / (4 k_K (1-eps)^2) = 1.225e-11 * 0.512 / (20 * 0.04) = 7.84e-12 m^2
    assert kozeny_carman(0.8, 3.5e-6) == pytest.approx(7.84e-12, rel=1e-12, abs=0)
    assert kozeny_carman(0.8, 3.5e-6, k_kozeny=4.0) == pytest.approx(9.8e-12, rel=1e-12, abs=0)
    assert np.isnan(kozeny_carman(1.0, 3.5e-6)) and np.isnan(kozeny_carman(0.0, 3.5e-6))


def test_tomadakis_sotirchos_hand_value():
    # eps = 0.8, r = 3.5 um, eps_p = 0.11, alpha = 0.785 (through-plane), by hand:
    #   (eps - eps_p)^(alpha+2) = 0.69^2.785 = exp(2.785 * -0.371064) = 0.355770
    #   ln^2(0.8) = (-0.223144)^2 = 0.0497931
    #   (1 - eps_p)^alpha = 0.89^0.785 = exp(0.785 * -0.116534) = 0.912579
    #   ((alpha+1) eps - eps_p)^2 = (1.785 * 0.8 - 0.11)^2 = 1.318^2 = 1.737124
    #   K = 1.225e-11 * 0.8 * 0.355770 / (8 * 0.0497931 * 0.912579 * 1.737124) = 5.5214e-12
    k = tomadakis_sotirchos(0.8, 3.5e-6, alpha=0.785, eps_p=0.11)
    assert k == pytest.approx(5.5214e-12, rel=2e-4, abs=0)
    # alpha = 0.521 (in-plane):
    #   0.69^2.521 = exp(2.521 * -0.371064) = 0.392641 ; 0.89^0.521 = 0.941092
    #   (1.521 * 0.8 - 0.11)^2 = 1.1068^2 = 1.225006
    #   K = 1.225e-11 * 0.8 * 0.392641 / (8 * 0.0497931 * 0.941092 * 1.225006) = 8.374e-12
    k_in = tomadakis_sotirchos(0.8, 3.5e-6, alpha=0.521)
    assert k_in == pytest.approx(8.374e-12, rel=2e-4, abs=0)
    # below the percolation threshold there is no flow path: NaN; K -> 0 at eps_p
    assert np.isnan(tomadakis_sotirchos(0.1, 3.5e-6))
    assert tomadakis_sotirchos(0.1101, 3.5e-6) < 1e-6 * tomadakis_sotirchos(0.5, 3.5e-6)
    # K scales with r^2
    assert tomadakis_sotirchos(0.7, 7e-6) == pytest.approx(
        4 * tomadakis_sotirchos(0.7, 3.5e-6), rel=1e-6, abs=0
    )
    with pytest.raises(ValueError, match="^r:"):
        tomadakis_sotirchos(0.8, -1.0)


def test_sensitivity_and_main_effects_against_hand_values():
    x1 = np.repeat([1.0, 2.0, 3.0], 3)
    x2 = np.tile([10.0, 20.0, 30.0], 3)
    logk = -12 + 0.5 * x1  # depends on x1 only
    df = pd.DataFrame(
        {"a": x1, "b": x2, "k_z_m2": 10**logk, "porosity": 0.5 + 0.1 * x1, "status": "ok"}
    )
    s = sensitivity_table(df, ["a", "b"]).set_index(["parameter", "response"])
    assert s.loc[("a", "log10 k_z_m2"), "spearman"] == pytest.approx(1.0)
    assert s.loc[("b", "log10 k_z_m2"), "spearman"] == pytest.approx(0.0, abs=1e-12)
    assert s.loc[("a", "log10 k_z_m2"), "src"] == pytest.approx(1.0)
    assert s.loc[("b", "log10 k_z_m2"), "src"] == pytest.approx(0.0, abs=1e-12)
    me = main_effects(df, ["a", "b"])
    row = me[(me["parameter"] == "a") & (me["level"] == "2.0")].iloc[0]
    assert row["mean log10 k_z_m2"] == pytest.approx(-11.0)
    assert row["n log10 k_z_m2"] == row["n porosity"] == 3
    rows_b = me[me["parameter"] == "b"]
    assert np.allclose(rows_b["mean log10 k_z_m2"], -11.0)  # (-11.5 - 11 - 10.5) / 3


def test_report_is_self_contained(tmp_path):
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    df = run_study(p, out, workers=0, case_fn=failing_case, progress=False)  # writes the report
    html = (out / "report.html").read_text()
    # scripts (plotly.js and the report's helpers) are inline: no <script src=...>
    scripts = re.findall(r"<script\b([^>]*)>", html, flags=re.I)
    assert scripts and not any("src" in attrs.lower() for attrs in scripts)
    markup = re.sub(r"<script\b[^>]*>.*?</script>", "", html, flags=re.I | re.S)
    # no external resources: every src/href of the markup is a data: URI or a fragment
    refs = re.findall(r"""(?:src|href)\s*=\s*["']?([^"'\s>]+)""", markup, flags=re.I)
    assert refs, "expected embedded images"
    assert all(r.startswith(("data:", "#")) for r in refs), refs
    assert not re.search(r"url\(\s*['\"]?(https?:)?//", markup)
    # figures decode as PNG, the fake previews (paged: data-src) as JPEG (since session 43)
    uris = re.findall(r'src="data:image/png;base64,([^"]+)"', markup)
    assert len(uris) >= 2
    assert all(base64.b64decode(u)[:8] == b"\x89PNG\r\n\x1a\n" for u in uris)
    jpegs = re.findall(r'data-src="data:image/jpeg;base64,([^"]+)"', markup)
    assert len(jpegs) >= 1 and all(base64.b64decode(u)[:3] == b"\xff\xd8\xff" for u in jpegs)
    # every case is in the results table, failed cases are flagged with their error
    for cid in df["case_id"]:
        assert cid in html
    assert html.count('<tr class="flag">') >= 2 * 4  # convergence + results tables
    assert "RuntimeError: mesh failed second line" in html
    assert "Tomadakis" in html and "Kozeny" in html and "Spearman" in html
    assert "Main effects" in html
    # report again from the folder alone (psdesign study report OUT)
    path = write_report(out)
    assert path == out / "report.html"


def test_report_without_results(tmp_path):
    with pytest.raises(ReportError, match="^out_dir: no results.csv"):
        write_report(tmp_path)


def _always_fails(spec, outputs, solver, workdir):
    raise RuntimeError("mesh failed")


@pytest.mark.parametrize(("case_fn", "code"), [(fake_case, 0), (_always_fails, 3)])
def test_study_report_exits_3_exactly_when_its_red_box_shows_a_case_not_ok(
    tmp_path, capsys, case_fn, code
):
    """Session 45: ``psdesign study report`` of a folder whose every case failed exited 0 (a
    script took the report for a good one). The exit table (cli.exit_status): the report
    finished and is complete, so not 1 (a run that could not finish); 0 is "every result's
    status ok"; a report showing cases not ok is "finished, a result's status is not ok": 3,
    with one line, exactly when its red box is there (the same cases: case_counts)."""
    from psdesign.cli import main

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=case_fn, progress=False, report=False)
    capsys.readouterr()
    assert main(["study", "report", str(out)]) == code  # main: 0 for both
    cap = capsys.readouterr()
    assert cap.out.strip() == str(out / "report.html")
    assert ('id="psd-status-alert"' in (out / "report.html").read_text()) == bool(code)
    if code:
        (line,) = cap.err.strip().splitlines()
        assert line == (
            "psdesign: the report shows 12 of 12 case(s) not ok (12 failed or timed out, 0 "
            "not_converged, 0 ok with a value not ok): read its red box"
        )
    else:
        assert cap.err == ""


def test_study_reports_exit_follows_its_red_box_for_every_kind_of_case(mixed_report):
    """The mixed study (4 failed, 2 not_converged, 2 ok with an untrustworthy K_z, 4 ok): its
    red box is there, so ``study report`` exits 3; the report of its 4 all-ok cases has none
    and exits 0; a not_converged case alone is 3 (``study report`` takes no
    ``--allow-not-converged``: its exit says whether the red box is there)."""
    from psdesign.cli.study import report_exit_status

    df, html = mixed_report
    assert 'id="psd-status-alert"' in html and report_exit_status(df) == 3
    ok = df[(df["status"] == "ok") & (df["k_z_status"] == "ok")]
    assert len(ok) == 4 and report_exit_status(ok) == 0
    assert report_exit_status(df[df["status"] == "not_converged"]) == 3
    assert report_exit_status(df[(df["status"] == "ok") & (df["k_z_status"] != "ok")]) == 3


def test_study_run_no_report_removes_an_earlier_runs_report(tmp_path, capsys):
    """walk-cli finding 3 (session 52): ``study run --no-report`` into a folder with an
    earlier run's report.html kept it (it said "cases 1" beside 6 rows of results.csv). The
    report psdesign wrote goes, with its entry in the marker; ``study report`` writes it."""
    from psdesign.cli import main
    from psdesign.io.outputs import read_marker

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    argv = ["study", "run", str(p), "-o", str(out), "--workers", "0", "--quiet"]
    argv += ["--case-fn", "study_cases:fake_case"]
    assert main(argv) == 0 and (out / "report.html").is_file()
    assert main([*argv, "--no-report"]) == 0
    assert not (out / "report.html").exists()
    assert "report.html" not in read_marker(out)["files"]
    assert main(["study", "report", str(out)]) == 0 and (out / "report.html").is_file()


def interrupting_case(spec, outputs, solver, workdir):
    """Ctrl-C in the first case (``--workers 0``: the runner's own process)."""
    raise KeyboardInterrupt


def test_an_interrupted_no_report_run_removes_the_earlier_report_first(tmp_path, capsys):
    """walk-study item 5 (session 53): the earlier run's report.html was removed only after a
    ``--no-report`` run succeeded, so a Ctrl-C'd (or failed) one left it showing the old cases,
    though ``--help`` says it is removed. Now it goes once the folder is locked, before any case."""
    from psdesign.cli import main
    from psdesign.io.outputs import read_marker

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    argv = ["study", "run", str(p), "-o", str(out), "--workers", "0", "--quiet"]
    assert main([*argv, "--case-fn", "study_cases:fake_case"]) == 0
    assert (out / "report.html").is_file()
    p.write_text(p.read_text().replace("[0.7, 0.8, 0.9]", "[0.7, 0.8, 0.9, 0.85]"))  # 4 to run
    assert main([*argv, "--no-report", "--case-fn", "test_report:interrupting_case"]) == 130
    assert not (out / "report.html").exists()
    assert "report.html" not in read_marker(out)["files"]


def test_report_of_an_unfinished_study_says_so_and_exits_3(tmp_path, capsys):
    """walk-cli finding 1 (session 52): a study interrupted after 3 of its 12 cases gave a
    report saying "cases 3", exit 0, nowhere that 9 cases of study.json never ran. Truth: the
    design's 12 case ids in study.json against the 3 rows kept. The report is finished but is
    not the study: 3 ("read it"; no case failed, so not 1), one line, a red box in its header;
    the finished study's report has no box (byte-identical) and exits 0."""
    from psdesign.cli import main

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    assert main(["study", "report", str(out)]) == 0
    whole = (out / "report.html").read_bytes()
    assert b"psd-incomplete-alert" not in whole
    full = pd.read_csv(out / "results.csv")
    full.head(3).to_csv(out / "results.csv", index=False)  # what an interrupted run keeps
    capsys.readouterr()
    assert main(["study", "report", str(out)]) == 3
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == (
        "psdesign: the report shows 3 of 12 case(s); 9 not run: rerun study run to resume"
    )
    html = (out / "report.html").read_text()
    assert "<b>Incomplete study:</b> this report shows 3 of the 12 cases" in html
    full.to_csv(out / "results.csv", index=False)  # resumed to the end: the same report again
    assert main(["study", "report", str(out)]) == 0
    assert (out / "report.html").read_bytes() == whole


def test_unfinished_is_one_of_the_reports_alerts_and_the_exit_reads_only_them(tmp_path, capsys):
    """Session 53 (left by s52): "the study is unfinished" was decided twice, by the report's
    red box and again by ``study report``'s own count. Truth: study.json's 12 case ids against
    the 3 rows kept; the report returns it as one of its alerts (beside nothing else: the 3
    fake cases are ok), and the exit reads the alerts alone: the alert with an all-ok table
    is 3 and its one line, the same table without it 0 and silent."""
    from psdesign.cli.study import report_exit_status
    from psdesign.report import ReportAlert, write_report_alerts

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    assert write_report_alerts(out)[1] == []
    df = pd.read_csv(out / "results.csv").head(3)
    df.to_csv(out / "results.csv", index=False)
    _, alerts = write_report_alerts(out)
    assert alerts == [
        ReportAlert("the report shows 3 of 12 case(s); 9 not run", "rerun study run to resume")
    ]
    capsys.readouterr()
    assert report_exit_status(df, alerts) == 3
    assert capsys.readouterr().err == (
        "psdesign: the report shows 3 of 12 case(s); 9 not run: rerun study run to resume\n"
    )
    assert report_exit_status(df) == 0 and capsys.readouterr().err == ""


def test_an_unfinished_optimize_folder_is_told_to_resume_with_optimize(tmp_path, capsys):
    """Review C (session 52): the unfinished-study advice always said ``study run``; in a
    ``study optimize`` folder that rewrote results.csv with the study file's cases in place of
    the optimizer's. Truth: the folder's marker names the command that made it; the line and
    the red box must name that one."""
    from psdesign.cli import main
    from psdesign.io.outputs import read_marker

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    marker = read_marker(out)
    marker["command"] = "study optimize"  # what an optimize run writes (io.outputs marker)
    (out / ".psdesign-output.json").write_text(json.dumps(marker))
    pd.read_csv(out / "results.csv").head(5).to_csv(out / "results.csv", index=False)
    capsys.readouterr()
    assert main(["study", "report", str(out)]) == 3
    assert capsys.readouterr().err.strip().endswith("rerun study optimize to resume")
    assert "Rerun <code>psdesign study optimize</code>" in (out / "report.html").read_text()


def test_a_study_json_whose_cases_is_not_a_list_is_one_line_exit_2(tmp_path, capsys):
    """Review C (session 52): ``{"cases": 5}`` in study.json raised a TypeError traceback from
    the incomplete-study check; a damaged file is bad input: exit 2, one line naming it."""
    from psdesign.cli import main

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    doc = json.loads((out / "study.json").read_text())
    (out / "study.json").write_text(json.dumps(doc | {"cases": 5}))
    capsys.readouterr()
    assert main(["study", "report", str(out)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "study.json" in line and "cases is a int, not a list" in line


def test_report_of_a_table_without_case_id_is_bad_input(tmp_path, capsys):
    """walk-cli finding 1: ``echo garbage > OUT/results.csv; study report OUT`` exited 0 with a
    report of "cases 0". A table without the case_id column every study run writes is
    unreadable: exit 2, one line naming the file and the missing column, no report written."""
    from psdesign.cli import main

    (tmp_path / "results.csv").write_text("garbage\n")
    assert main(["study", "report", str(tmp_path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == (
        f"psdesign: error: OUT: {tmp_path / 'results.csv'} is unreadable (no case_id column: "
        "not a study run's table); rerun the study"
    )
    assert not (tmp_path / "report.html").exists()


def test_results_csv_is_checked_once_by_the_reader(tmp_path, monkeypatch, capsys):
    """session 41 (s41-routes): the report checked results.csv exists, then read_results
    checked again with the same words: two checks of one file to keep in step. The reader's
    is the one (its line decides); the user's line and exit status are unchanged, and an
    unreadable results.csv is a ReportError too."""
    from psdesign.cli import main
    from psdesign.study import readback

    assert main(["study", "report", str(tmp_path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == f"psdesign: error: OUT: no results.csv in {tmp_path}; run the study first"
    (tmp_path / "results.csv").write_bytes(b"")
    with pytest.raises(ReportError, match="is unreadable"):
        write_report(tmp_path)

    def reader(out):
        raise ValueError("out_dir: the reader's own check")

    monkeypatch.setattr(readback, "read_results", reader)
    (tmp_path / "results.csv").unlink()
    with pytest.raises(ReportError, match="^out_dir: the reader's own check$"):
        write_report(tmp_path)


@pytest.fixture(scope="module")
def mixed_report(tmp_path_factory):
    """The factorial fake study (porosity 0.7 / 0.8 / 0.9 x diameter 6 / 8 um x seeds 1, 2)
    with every status: 0.7 fails (4 cases), 0.9 seed 2 does not converge along z (2 cases),
    0.9 seed 1 is ok with an untrustworthy K_z (2 cases), 0.8 is ok (4 cases)."""
    tmp = tmp_path_factory.mktemp("mixed")
    p = write_study(tmp, FACTORIAL, FAC_PARAMS)
    df = run_study(p, tmp / "out", workers=0, case_fn=mixed_status_case, progress=False)
    return df, (tmp / "out" / "report.html").read_text()


def test_report_marks_failed_not_converged_and_untrustworthy(mixed_report):
    df, html = mixed_report
    assert (df["status"] == "failed").sum() == 4 and (df["status"] == "not_converged").sum() == 2
    # a red box at the top says how many and where they show
    alert = re.search(r'<p class="alert" id="psd-status-alert">(.*?)</p>', html, flags=re.S)
    assert alert is not None
    assert "4 failed" in alert.group(1) and "2 not_converged" in alert.group(1)
    assert "2 value(s) of ok cases not ok (k_z_status)" in alert.group(
        1
    ) and "of 12 cases" in alert.group(1)
    # the error-bar table: failed cases are highlighted and say failed (they used to be blank)
    table = html.split("<h3>Permeability with error bars</h3>", 1)[1].split("</table>", 1)[0]
    for cid in df.loc[df["status"] == "failed", "case_id"]:
        assert re.search(rf'<tr class="flag"><td>{cid}</td><td>failed</td>', table), cid
    untrusted = df[(df["status"] == "ok") & (df["k_z_status"] == "untrustworthy")]
    assert len(untrusted) == 2
    for cid in untrusted["case_id"]:
        assert re.search(rf'<tr class="flag"><td>{cid}</td><td>ok</td>', table), cid
    assert table.count("± 30.0 %") == 2 and table.count("± 2.0 %") == 14
    # the porosity-permeability plot: 2 not-converged cases x 2 directions + 2 untrustworthy K_z
    assert f"6 K value(s) that are not ok ({NOT_OK_MARKERS})" in html
    assert "4 failed or timed-out case(s) have no K and are not plotted." in html


def test_untrustworthy_k_is_left_out_of_means_fits_and_sensitivity(mixed_report):
    from psdesign.analysis.columns import trusted

    df, html = mixed_report
    t = trusted(df)
    assert len(t) == 6  # the ok cases
    assert t["k_z_m2"].notna().sum() == 4 and t["k_x_m2"].notna().sum() == 6
    # sensitivity over what is trusted: n = 4 for K_z (porosity 0.8 only), 6 for K_x; porosity
    # is constant over the K_z rows, so no SRC (it used to fail the whole report: NaN in lstsq)
    s = sensitivity_table(t, ["generator.porosity", "generator.diameter"])
    s = s.set_index(["parameter", "response"])
    assert s.loc[("generator.porosity", "log10 k_z_m2"), "n"] == 4
    assert s.loc[("generator.porosity", "log10 k_x_m2"), "n"] == 6
    assert np.isnan(s.loc[("generator.porosity", "log10 k_z_m2"), "src"])
    # K_x = kc_truth * noise: log K rises with porosity and diameter
    assert s.loc[("generator.porosity", "log10 k_x_m2"), "spearman"] > 0.8


def test_sensitivity_with_a_parameter_constant_on_a_response():
    # b varies over the table but not over the rows that have k_z: no SRC, no exception
    df = pd.DataFrame(
        {
            "a": [1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
            "b": [1.0, 1.0, 1.0, 1.0, 2.0, 2.0],
            "k_z_m2": [1e-12, 2e-12, 3e-12, 4e-12, np.nan, np.nan],
            "status": "ok",
        }
    )
    s = sensitivity_table(df, ["a", "b"]).set_index(["parameter", "response"])
    assert s.loc[("a", "log10 k_z_m2"), "spearman"] == pytest.approx(1.0)
    assert np.isnan(s.loc[("b", "log10 k_z_m2"), "spearman"])
    assert np.isnan(s.loc[("a", "log10 k_z_m2"), "src"])


def test_parameter_units_follow_the_schema():
    from psdesign.report.units import parameter_label, parameter_unit
    from psdesign.schema.keys import key_rows

    # the schema's range text (docs/spec-keys.md) names the unit of these keys
    rows = {k: a for table in key_rows().values() for k, _, a in table}
    assert rows["generator.diameter"].startswith("metres")
    for key, unit in [
        ("generator.diameter", "m"),
        ("rve.size", "m"),
        ("rve.voxel", "m"),
        ("intersections.min_gap", "m"),
        ("flow.lattice_step", "m"),
        ("image.voxel_size", "m"),
        ("generator.theta", "deg"),
        ("flow.viscosity", "Pa s"),
        ("flow.pressure_drop", "Pa"),
        ("flow.density", "kg/m³"),
        ("generator.porosity", "-"),
        ("flow.aux_length", "-"),
        ("transport.bulk_diffusivity_m2_s", "m²/s"),
        ("generator.n_fibers", ""),
    ]:
        assert parameter_unit(key) == unit, key
    for key, text in rows.items():
        if text.startswith("metres"):
            assert parameter_unit(key) == "m", key
        if text.startswith("degrees"):
            assert parameter_unit(key) == "deg", key
    assert parameter_label("generator.diameter") == "generator.diameter (m)"
    assert parameter_label("generator.n_fibers") == "generator.n_fibers"


def test_parameter_plots_label_units_and_join_only_like_points(mixed_report):
    from psdesign.analysis.columns import trusted
    from psdesign.analysis.replicates import replicate_summary
    from psdesign.report.decision import _line_groups

    df, html = mixed_report
    # axis titles and legends carry the units; SI-prefixed ticks carry metres (6μm)
    assert '"title":{"text":"generator.diameter (m)"}' in html
    assert '"ticksuffix":"m"' in html and '"exponentformat":"SI"' in html
    assert '"name":"x (in-plane), generator.diameter = 6e-06 m"' in html
    assert "porosity (-)" in html
    # a line joins the porosity levels of one diameter only (it used to zig-zag through both)
    params = ["generator.porosity", "generator.diameter"]
    summary = replicate_summary(trusted(df), params)
    groups, mode = _line_groups(summary, "generator.porosity", params)
    assert mode == "markers+lines" and len(groups) == 2
    for _, g in groups:
        assert g["generator.porosity"].is_unique and g["generator.diameter"].nunique() == 1
    # titles sit below Plotly's tool bar
    assert '"yref":"paper"' in html and '"yanchor":"bottom"' in html


def test_parameter_lines_are_split_by_a_categorical_parameter():
    """A refinement study over ``rve.voxel`` x ``flow.wall_treatment`` (studies/voxel_walls.toml):
    one line per wall model (it used to join the two models' means at each voxel size into one
    zig-zag line), labelled by the level."""
    from psdesign.report.decision import _line_groups, parameter_plots, surrogate_plots

    df = pd.DataFrame(
        {
            "case_id": [f"c{i}" for i in range(6)],
            "status": ["ok"] * 6,
            "seed": [0] * 6,
            "rve.voxel": [1e-6, 1e-6, 1.5e-6, 1.5e-6, 2e-6, 2e-6],
            "flow.wall_treatment": ["diffuse", "subvoxel"] * 3,
            "k_z_m2": [3.58e-11, 3.60e-11, 3.57e-11, 3.598e-11, 3.55e-11, 3.599e-11],
            "k_z_status": ["ok"] * 6,
        }
    )
    params = ["rve.voxel", "flow.wall_treatment"]
    groups, mode = _line_groups(df, "rve.voxel", params)
    assert mode == "markers+lines"
    assert [label for label, _ in groups] == [
        "flow.wall_treatment = diffuse",
        "flow.wall_treatment = subvoxel",
    ]
    assert all(g["flow.wall_treatment"].nunique() == 1 for _, g in groups)
    assert '"name":"z (through-plane), flow.wall_treatment = diffuse"' in parameter_plots(
        df, params
    )
    # the surrogate takes numeric inputs only: a fit over rve.voxel would mix the wall models
    # (`study fit` rates it untrustworthy), so the report draws none and says why (review s53:
    # a red box and exit 3 on every such study, studies/voxel_walls.toml among them)
    from psdesign.report.decision import fit_alert, report_fit

    assert report_fit(df, params, {}) is None and fit_alert(None) == ""
    note = surrogate_plots(df, params, {})
    assert "No surrogate drawn: the cases differ in flow.wall_treatment" in note
    assert "psd-surface" not in note


def test_response_surface_leaves_room_for_its_colour_bars(mixed_report):
    from psdesign.analysis.columns import trusted
    from psdesign.analysis.surrogate import fit_surrogate, parameter_bounds
    from psdesign.report.decision import SURFACE_GAP, _surface_2d

    df, _ = mixed_report
    ok = trusted(df)
    ok = ok[ok["k_x_m2"].notna()]
    num = ["generator.porosity", "generator.diameter"]
    s = fit_surrogate(ok, "k_x_m2", num, parameter_bounds(ok, num, {}))
    fig = _surface_2d(s, ok, num, num, "k_x_m2")
    left, right = fig.layout.xaxis.domain, fig.layout.xaxis2.domain
    assert right[0] - left[1] == pytest.approx(SURFACE_GAP) and SURFACE_GAP >= 0.25
    bar = fig.data[0].colorbar
    assert left[1] < bar.x < left[1] + 0.05 and bar.xanchor == "left"
    assert bar.title.text.startswith("log10 K")
    assert fig.layout.yaxis.title.text == "generator.diameter (m)"
    assert fig.layout.xaxis2.title.text == "generator.porosity (-)"
    # the relative uncertainty varies here: contours of bar / mean rounded to 0.01 %, ticked
    # in % (review s52: a raw field drew 1e-16 noise and a tick "0.1998213424444766073")
    rel = fig.data[1]
    assert rel.type == "contour" and rel.colorbar.tickformat == ".1%"
    z = np.asarray(rel.z)
    assert np.ptp(z) > 1e-4 and np.array_equal(z, np.round(z, 4))


def test_report_with_no_trusted_k_says_so_instead_of_empty_frames(tmp_path):
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    run_study(p, tmp_path / "out", workers=0, case_fn=untrusted_case, progress=False)
    html = (tmp_path / "out" / "report.html").read_text()
    assert "24 value(s) of ok cases not ok (k_x_status, k_z_status)" in html  # 12 x (K_x, K_z)
    assert f"24 K value(s) that are not ok ({NOT_OK_MARKERS})" in html
    assert "No trusted K: every K value is not ok" in html
    # session 45: the K frame draws each untrusted K by its status (it used to be left out)
    frame = html.split('id="psd-k-generator.porosity"', 1)[1].split("</script>", 1)[0]
    assert "x (in-plane): untrustworthy (not in the lines)" in frame
    assert 'id="psd-porosity-generator.porosity"' in html  # porosity is still plotted
    assert "warnings_x" in html


def test_report_element_ids_are_unique_and_both_galleries_page(mixed_report):
    _, html = mixed_report
    markup = re.sub(r"<script\b[^>]*>.*?</script>", "", html, flags=re.I | re.S)
    ids = re.findall(r'\bid="([^"]+)"', markup)
    assert len(ids) == len(set(ids)), sorted(i for i in set(ids) if ids.count(i) > 1)
    # previews and flow-field pictures: two galleries, each paged by its own id
    for gid in ("psd-thumbs", "psd-fields"):
        gallery = re.search(rf'<div class="psd-gallery" id="{gid}"[^>]*>(.*?)</div>', markup)
        assert gallery is not None and gallery.group(1).count("<figure>") == 8, gid
        assert f"psdPage('{gid}'" in markup


def test_two_case_study_explains_its_blank_cells_and_draws_no_interaction_note(tmp_path):
    # the quickstart's shape: one parameter at two levels, one seed
    study = FACTORIAL.replace("seeds = [1, 2]", "seeds = [1]")
    p = write_study(tmp_path, study, '"generator.porosity" = [0.8, 0.9]')
    run_study(p, tmp_path / "out", workers=0, case_fn=mixed_status_case, progress=False)
    html = (tmp_path / "out" / "report.html").read_text()
    sens = html.split("<h2>Sensitivity</h2>", 1)[1].split("<h2>", 1)[0]
    assert re.search(r"<td>generator.porosity</td><td>porosity</td><td></td><td></td>", sens)
    assert "A blank Spearman or SRC cell is not defined: fewer than 3 cases" in sens
    assert "Parallel lines in the interaction plot" not in html  # there is none


def test_surrogate_uses_only_cases_with_a_trusted_k(mixed_report):
    df, html = mixed_report
    # K_x is trusted in 6 cases (porosity 0.8 and 0.9 seed 1), K_z in 4 (porosity 0.8 only):
    # the surrogate takes K_x and its 6 cases; K_z's would extrapolate from one porosity
    assert (
        "Gaussian-process surrogate of k_x_m2 over generator.porosity, generator.diameter " in html
    )
    assert "from 6 cases" in html
    # six cases on the corners of a 2 x 2 design: leave-one-out cannot predict a corner
    cv = float(re.search(r"from 6 cases; cross-validated error ([0-9.]+) %", html).group(1))
    assert cv > 20 and "[untrustworthy] k_x_m2: cross-validated error" in html
    assert "exceeds 20 %" in html and "the Sobol indices are not reliable" in html


def test_report_is_byte_identical_from_the_same_folder(tmp_path, monkeypatch):
    """Audit (session 33): the metadata table stamped the clock time of writing, so
    ``psdesign study report OUT`` twice on one folder gave two different files. The report is
    a function of the folder: here the clock moves a day on every reading."""
    import datetime

    class MovingClock(datetime.datetime):
        calls = 0

        @classmethod
        def now(cls, tz=None):
            cls.calls += 1
            return datetime.datetime(2030, 1, 1, tzinfo=tz) + datetime.timedelta(days=cls.calls)

    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    out = tmp_path / "out"
    run_study(p, out, workers=0, case_fn=mixed_status_case, progress=False, report=False)
    monkeypatch.setattr(datetime, "datetime", MovingClock)
    first = write_report(out).read_bytes()
    second = write_report(out).read_bytes()
    assert first == second


def test_report_surrogate_carries_the_fit_rating_and_the_modelled_output(monkeypatch):
    """Audit (session 33): the report judged its surrogate by its own 20 % rule on the
    cross-validated error alone (a length scale on its bound, untrustworthy in ``study fit``,
    passed unflagged), printed no status, and titled the Sobol bars "of log10 K" also when
    the fit models K itself (K spanning less than a factor 3)."""
    from psdesign.analysis.surrogate import Surrogate
    from psdesign.report.decision import surrogate_plots

    x = np.random.default_rng(3).random((12, 2))
    k = 1e-11 * (1 + 0.5 * x[:, 0] + 0.2 * x[:, 1])  # 1.0-1.7e-11: modelled linearly
    df = pd.DataFrame({"a": x[:, 0], "b": x[:, 1], "status": "ok", "k_z_m2": k})
    text = surrogate_plots(df, ["a", "b"], {})
    assert "Sobol indices of k_z_m2 (95 % CI)" in text and "of log10 k_z_m2" not in text
    assert "[ok]" in text and "not reliable" not in text
    why = "k_z_m2: the fit's length scale along a is on its lower bound"
    monkeypatch.setattr(Surrogate, "rating", lambda self: ("untrustworthy", [why]))
    text = surrogate_plots(df, ["a", "b"], {})
    assert "[untrustworthy]" in text and why.replace("'", "&#x27;") in text
    assert "not reliable" in text


def test_surfaces_of_a_loguniform_parameter_are_on_its_log_scale():
    """A ``loguniform`` parameter's cases are drawn, and its surrogate input scaled, on a log
    scale; the report's surfaces gridded it linearly and held it at the arithmetic middle
    (1e-6 .. 1e-4: 5.05e-5, where no case lies; design-loop audit, s33)."""
    from types import SimpleNamespace

    import numpy as np

    from psdesign.report.decision import _at_mid_range, _axis_grid

    s = SimpleNamespace(low=[0.5, 1e-6], high=[0.9, 1e-4], log_params=[False, True])
    g = _axis_grid(s, ["porosity", "d"], "d")
    np.testing.assert_allclose(g[1:] / g[:-1], (1e-4 / 1e-6) ** (1 / 29))
    np.testing.assert_allclose(np.diff(_axis_grid(s, ["porosity", "d"], "porosity")), 0.4 / 29)
    np.testing.assert_allclose(_at_mid_range(s, 2), [[0.7, 1e-5], [0.7, 1e-5]])


def test_report_draws_no_sobol_bars_of_a_k_constant_to_noise():
    """K = 1e-11 (1 + 1e-9 N(0, 1)) depends on neither parameter (by construction): the
    report must not draw Sobol bars of its noise, and must say why they are missing (it drew
    bars, S_T up to 0.9, before)."""
    from psdesign.report.decision import surrogate_plots

    rng = np.random.default_rng(0)
    x = rng.random((12, 2))
    k = 1e-11 * (1 + 1e-9 * rng.standard_normal(12))
    df = pd.DataFrame({"a": x[:, 0], "b": x[:, 1], "status": "ok", "k_z_m2": k})
    text = surrogate_plots(df, ["a", "b"], {})
    assert "psd-sobol" not in text and "Sobol indices not shown: k_z_m2 varies no more" in text


def test_report_draws_no_frame_over_a_parameter_that_never_varied(tmp_path):
    """``generator.porosity = [0.8]``: every case has porosity 0.8 (the design, by hand), so a
    "K vs generator.porosity" frame is one x value, no trend; it was drawn (with its porosity
    output twin). Now the report names the held parameter and plots against the diameter
    only."""
    p = write_study(
        tmp_path,
        'design = "latin-hypercube"\nn_samples = 6\nseeds = [1]\noutputs = ["porosity", "k_z"]',
        '"generator.diameter" = {low = 6e-6, high = 9e-6}\n"generator.porosity" = [0.8]',
    )
    run_study(p, tmp_path / "out", workers=0, case_fn=fake_case, progress=False)
    html = (tmp_path / "out" / "report.html").read_text()
    assert "K vs generator.diameter" in html and "porosity vs generator.diameter" in html
    assert "vs generator.porosity" not in html
    assert "Not plotted against (one value in every case with a trusted output): " in html
    assert "output): generator.porosity = 0.8.</p>" in html


def _random_kc_study() -> pd.DataFrame:
    """12 ok cases at random porosity (0.7-0.9) and diameter (6-9 um): K_z by Kozeny-Carman
    (``kc_truth``), a D_eff/D of about 6.5e-4 (a small dimensionless output)."""
    rng = np.random.default_rng(2)
    eps, d = rng.uniform(0.7, 0.9, 12), rng.uniform(6e-6, 9e-6, 12)
    return pd.DataFrame(
        {
            "generator.porosity": eps,
            "generator.diameter": d,
            "status": "ok",
            "porosity": eps,
            "diffusivity_z": 6.5e-4 + 1e-5 * eps,
            "k_z_m2": kc_truth(eps, d),
        }
    )


def test_axes_without_a_unit_tick_plain_or_exponent_numbers(monkeypatch):
    """Plotly's default tick format (``exponentformat = "B"``, plotly.js reference:
    layout.xaxis.exponentformat) writes 6.5e-4 as "650µ", an SI prefix that reads as a unit
    on a dimensionless axis (porosity_error then; seen in a real browser; here a D_eff/D).
    Every axis and colour bar of the report's figures must tick ``"e"`` numbers (0.0065,
    6.5e-4) unless it carries a unit with its SI prefix (``6µm``)."""
    from psdesign.report import decision

    figs = []
    real = decision.figure_html

    def keep(fig, *args, **kw):
        out = real(fig, *args, **kw)
        figs.append(fig)
        return out

    monkeypatch.setattr(decision, "figure_html", keep)
    df = _random_kc_study()
    params = ["generator.porosity", "generator.diameter"]
    decision.parameter_plots(df, params)
    decision.effect_plots(df, params)
    decision.surrogate_plots(df, params, {})
    formats = []
    for fig in figs:
        for ax in [*fig.select_xaxes(), *fig.select_yaxes()]:
            formats.append((ax.exponentformat, ax.ticksuffix))
        formats += [(t.colorbar.exponentformat, None) for t in fig.data if hasattr(t, "colorbar")]
    assert len(figs) >= 8 and ("SI", "m") in formats  # the diameter's axes: 6µm
    assert set(formats) == {("e", None), ("SI", "m")}, set(formats)
    err = [f for f in figs if f.layout.title.text == "diffusivity_z vs generator.porosity"]
    assert err and err[0].layout.yaxis.exponentformat == "e"


def test_a_loguniform_parameter_is_plotted_on_a_log_axis(monkeypatch):
    """A ``loguniform`` diameter of 1e-7 to 1e-3 m: its cases are spread evenly in log10 d,
    so on a linear axis d = 1e-5 (the log middle) sits at (1e-5 - 1e-7) / (1e-3 - 1e-7) =
    0.99 % of the width (hand value) and 3/4 of the cases crowd the first 1 %. Every frame
    over it (outputs vs it, the surrogate's surfaces) must use a log axis; the porosity's
    stays linear."""
    from psdesign.report import decision

    figs = []
    real = decision.figure_html
    monkeypatch.setattr(
        decision, "figure_html", lambda fig, *a, **k: (figs.append(fig), real(fig, *a, **k))[1]
    )
    rng = np.random.default_rng(4)
    eps, d = rng.uniform(0.7, 0.9, 12), 10 ** rng.uniform(-7, -3, 12)
    df = pd.DataFrame(
        {
            "generator.porosity": eps,
            "generator.diameter": d,
            "status": "ok",
            "k_z_m2": (d / 2) ** 2 * eps**3 / (20 * (1 - eps) ** 2),
        }
    )
    params = ["generator.porosity", "generator.diameter"]
    spec = {
        "generator.porosity": {"low": 0.7, "high": 0.9},
        "generator.diameter": {"low": 1e-7, "high": 1e-3, "dist": "loguniform"},
    }
    decision.parameter_plots(df, params, {"parameters": spec})
    decision.effect_plots(df, params, {"parameters": spec})
    decision.surrogate_plots(df, params, {"parameters": spec})
    kinds = {}
    for fig in figs:
        for ax in [*fig.select_xaxes(), *fig.select_yaxes()]:
            title = ax.title.text or ""
            if title.startswith("generator."):
                kinds.setdefault(title, set()).add(ax.type)
    assert kinds["generator.diameter (m)"] == {"log"}
    assert kinds["generator.porosity (-)"] == {None}


def test_src_of_two_parameters_that_moved_together_is_blank():
    """A design with diameter = 1e-5 * porosity (a csv study) and the output porosity = the
    porosity parameter (the fake solver returns it): by construction SRC_porosity = 1 and
    SRC_diameter = 0, but no regression on these cases can tell them apart (the two columns
    are one). Least squares split it 0.50 / 0.50; the SRC cells must be blank (NaN), the
    Spearman ones stay (each parameter's rank correlation is 1, hand value)."""
    eps = np.linspace(0.7, 0.9, 8)
    df = pd.DataFrame(
        {"a": eps, "d": 1e-5 * eps, "status": "ok", "porosity": eps, "k_z_m2": 1e-11 * eps}
    )
    t = sensitivity_table(df, ["a", "d"])
    assert t["src"].isna().all()
    np.testing.assert_allclose(t["spearman"], 1.0)
    # independent columns keep their SRC: porosity = a exactly, so SRC_a = 1, SRC_d = 0
    df["d"] = np.random.default_rng(0).permutation(df["d"].to_numpy())
    t = sensitivity_table(df, ["a", "d"]).set_index(["response", "parameter"])
    assert t.loc[("porosity", "a"), "src"] == pytest.approx(1.0, abs=1e-9)
    assert t.loc[("porosity", "d"), "src"] == pytest.approx(0.0, abs=1e-9)


def test_a_design_point_listed_twice_counts_once_in_spearman_and_main_effects(monkeypatch):
    """A csv design listing a = 5 twice with the same seed (two case labels, one RVE: the
    same spec and seed build the same case) is one realization: the report's Spearman table,
    main-effects table and main-effects plot counted it twice (session 34 notes). Truth: the
    five distinct cases, k = (1, 3, 2, 5, 4) e-12 over a = 1..5, rank correlation
    1 - 6 * 4 / (5 * 24) = 0.8 by hand (scipy.stats.spearmanr on them agrees; with the copy
    scipy gives 0.7647). Main effects of b: b = 1 at a = 1, 3, 5, mean log10 k =
    log10(8e-36) / 3 = -11.699 (the copy drew it to -11.624).
    """
    from scipy.stats import spearmanr

    from psdesign.report import decision

    a = [1.0, 2.0, 3.0, 4.0, 5.0, 5.0]
    k = [1e-12, 3e-12, 2e-12, 5e-12, 4e-12, 4e-12]
    b = [1.0, 2.0, 1.0, 2.0, 1.0, 1.0]  # a second parameter, so main effects pool over a
    df = pd.DataFrame(
        {
            "case_id": [f"c{i}" for i in range(6)],
            "a": a,
            "b": b,
            "seed": 7,
            "status": "ok",
            "k_z_m2": k,
        }
    )
    want = spearmanr(a[:5], np.log10(k[:5])).statistic
    assert want == pytest.approx(0.8, abs=1e-12)
    assert spearmanr(a, np.log10(k)).statistic != pytest.approx(want, abs=1e-3)  # it matters
    s = sensitivity_table(df, ["a", "b"]).set_index(["parameter", "response"])
    assert s.loc[("a", "log10 k_z_m2"), "spearman"] == pytest.approx(want, abs=1e-12)
    assert s.loc[("a", "log10 k_z_m2"), "n"] == 5
    # b = 1 at a = 1, 3, 5: mean log10 k over the three distinct cases (the copy drew it
    # towards log10 4e-12)
    me = main_effects(df, ["a", "b"]).set_index(["parameter", "level"])
    want_b1 = np.mean(np.log10([1e-12, 2e-12, 4e-12]))
    assert me.loc[("b", "1.0"), "mean log10 k_z_m2"] == pytest.approx(want_b1, abs=1e-12)
    assert (
        me.loc[("b", "1.0"), "n log10 k_z_m2"] == 3 and me.loc[("a", "5.0"), "n log10 k_z_m2"] == 1
    )
    figs = []
    real = decision.figure_html
    monkeypatch.setattr(
        decision, "figure_html", lambda fig, *x, **kw: (figs.append(fig), real(fig, *x, **kw))[1]
    )
    decision.effect_plots(df, ["a", "b"])
    line = [t for t in figs[0].data if t.name == "b: k_z_m2"][0]
    assert line.y[0] == pytest.approx(want_b1, abs=1e-12)


def test_no_response_surface_over_two_parameters_that_moved_together(tmp_path):
    """Session 34 notes: a csv study with diameter = 1e-5 * porosity (b = 2a in kind: the
    cases lie on one line of the box) got no Sobol indices (``no_indices_reason``: the cases
    cannot tell the two effects apart) but a 2-D surface over those two parameters, a GP
    surface over a box the cases never filled. The same rule now gives no surface either,
    and one sentence where it would be. Truth: the two columns are one (correlation 1 by
    construction)."""
    p = write_entangled_study(tmp_path)
    run_study(p, tmp_path / "out", workers=0, case_fn=fake_case, progress=False)
    html = (tmp_path / "out" / "report.html").read_text()
    why = "generator.porosity and generator.diameter moved together over the cases"
    assert "psd-surface" not in html
    assert f'<p class="note">Response surface not shown: {why} (correlation 1.000)' in html
    # two independent parameters keep their surface (the same cases, diameter shuffled)
    from psdesign.report.decision import surrogate_plots

    df = pd.read_csv(tmp_path / "out" / "results.csv")
    params = ["generator.porosity", "generator.diameter"]
    df["generator.diameter"] = np.random.default_rng(1).permutation(df["generator.diameter"])
    text = surrogate_plots(df, params, {})
    assert "psd-surface" in text and "Response surface not shown" not in text


def test_response_surface_keeps_a_third_parameter_tied_as_in_the_cases(tmp_path, monkeypatch):
    """Session 35 notes: the entangled-pair rule saw pairs only. A csv study with porosity and
    diameter free and flow.aux_length = 0.3 porosity (which the fake solver ignores) got a
    surface over porosity and diameter with aux_length held at mid-range: designs the study
    never had, where the GP (which gave aux_length part of porosity's effect) was up to 78 % off
    at the ends of porosity. The groups rule (psdesign.analysis.entangled) lets aux_length
    follow porosity as in the cases, and one sentence says so. Truth: the fake solver's
    k_z = 2 Kozeny-Carman (tests/study_cases.py, independent of psdesign)."""
    from psdesign.report import decision

    rng = np.random.default_rng(3)
    eps, d = rng.uniform(0.7, 0.9, 12), rng.uniform(6e-6, 9e-6, 12)
    cols = {"generator.porosity": eps, "generator.diameter": d, "flow.aux_length": 0.3 * eps}
    pd.DataFrame(cols).to_csv(tmp_path / "pts.csv", index=False)
    study = 'design = "csv"\ncsv = "pts.csv"\nseeds = [1]\noutputs = ["porosity", "k_z"]\n'
    p = write_study(tmp_path, study + 'solver = "voxel"', "")
    run_study(p, tmp_path / "out", workers=0, case_fn=fake_case, progress=False)
    html = (tmp_path / "out" / "report.html").read_text()
    assert "psd-surface" in html and "psd-sobol" not in html  # the group has no Sobol index
    assert (
        "Response surface: flow.aux_length follows generator.porosity as in the cases (they "
        "moved together), not held at mid-range" in html
    )
    assert (  # the interaction plot is of the cases themselves: shown, with the tie said
        "psd-interaction" in html
        and "Interaction: flow.aux_length moved with generator.porosity in every case" in html
    )
    figs = []
    real = decision.figure_html
    monkeypatch.setattr(
        decision, "figure_html", lambda fig, *x, **kw: (figs.append(fig), real(fig, *x, **kw))[1]
    )
    df = pd.read_csv(tmp_path / "out" / "results.csv")
    decision.surrogate_plots(df, list(cols), {})
    mean = figs[-1].data[0]  # log10 K (GP mean) over porosity (x) and diameter (y)
    E, D = np.meshgrid(np.asarray(mean.x), np.asarray(mean.y))
    truth = np.log10(2 * kc_truth(E, D))
    err = 10 ** np.abs(np.asarray(mean.z) - truth) - 1
    assert err.max() < 0.05  # 1.0 % now; 78 % with aux_length held at mid-range


def test_parameter_plots_draw_each_error_on_its_value_not_as_an_output(monkeypatch):
    """The quickstart's report drew ``porosity_error vs generator.porosity`` as an output of its
    own and K with no bar at all (one seed: no CI), while each case carried its numerical bar.
    Now an error column is drawn only as its value's bar, and the bar on a design point's mean
    is the 95 % CI of the replicate mean (Student, ``t_{0.975,2} = 4.302653`` for three seeds)
    plus the mean of the cases' own bars (a discretization error is not averaged away)."""
    from psdesign.report import decision

    figs = []
    real = decision.figure_html
    monkeypatch.setattr(
        decision, "figure_html", lambda fig, *a, **k: (figs.append(fig), real(fig, *a, **k))[1]
    )
    k = [1.0e-11, 1.2e-11, 1.1e-11, 2.0e-11]  # three seeds at 0.8, one at 0.9
    df = pd.DataFrame(
        {
            "generator.porosity": [0.8, 0.8, 0.8, 0.9],
            "seed": [1, 2, 3, 1],
            "status": "ok",
            "porosity": [0.80, 0.81, 0.79, 0.9],
            "porosity_error": [0.001, 0.002, 0.003, 0.004],
            "k_z_m2": k,
            "k_z_rel_error": [0.04, 0.05, 0.06, 0.03],
            "k_z_status": "ok",
            "diffusivity_z": [0.5, 0.52, 0.51, 0.6],
            "diffusivity_z_rel_error": [0.01, 0.01, 0.01, 0.02],
            "diffusivity_z_status": "ok",
        }
    )
    decision.parameter_plots(df, ["generator.porosity"], None)
    titles = [f.layout.title.text for f in figs]
    assert not any("error" in t.split(" vs ")[0] for t in titles), titles
    bars = {f.layout.title.text.split(" vs ")[0]: f.data[0].error_y.array for f in figs}
    k_bar = next(v for t, v in bars.items() if t.startswith("K"))
    ci = 4.302653 * np.std(k[:3], ddof=1) / np.sqrt(3)
    assert k_bar[0] == pytest.approx(ci + 0.05 * 1.1e-11, rel=1e-6)
    assert k_bar[1] == pytest.approx(0.03 * 2.0e-11, rel=1e-12)  # one seed: its own bar
    ci_p = 4.302653 * np.std([0.80, 0.81, 0.79], ddof=1) / np.sqrt(3)
    assert bars["porosity"][0] == pytest.approx(ci_p + 0.002, rel=1e-6)
    assert bars["porosity"][1] == pytest.approx(0.004, rel=1e-12)
    assert bars["diffusivity_z"][1] == pytest.approx(0.02 * 0.6, rel=1e-12)


def test_parameter_plots_bar_is_student_half_width_where_the_ci_is_clipped(monkeypatch):
    """session 40: the 95 % CI of a porosity near 1 is clipped at 1 (summary.csv gave 1.016),
    so ``high - mean`` is no longer the half-width; the report's bar reads the table's
    ``X_ci95_half``: Student's ``t_{0.975, 1} s / sqrt(2)`` (t = tan(0.475 pi) = 12.706,
    NIST/SEMATECH e-Handbook Sec. 1.3.6.7.2) plus the cases' mean numerical bar."""
    from psdesign.report import decision

    figs = []
    real = decision.figure_html
    monkeypatch.setattr(
        decision, "figure_html", lambda fig, *a, **k: (figs.append(fig), real(fig, *a, **k))[1]
    )
    phi = [0.95, 0.99]  # mean 0.97 + Student half 0.254 > 1: the interval is clipped
    df = pd.DataFrame(
        {
            "generator.porosity": [0.95, 0.95, 0.99],
            "seed": [1, 2, 1],
            "status": "ok",
            "porosity": [*phi, 0.99],
            "porosity_error": [0.001, 0.003, 0.004],
            "k_z_m2": [1e-11, 1.1e-11, 2e-11],
            "k_z_rel_error": [0.04, 0.06, 0.03],
            "k_z_status": "ok",
        }
    )
    decision.parameter_plots(df, ["generator.porosity"], None)
    bars = {f.layout.title.text.split(" vs ")[0]: f.data[0].error_y.array for f in figs}
    half = math.tan(0.475 * math.pi) * np.std(phi, ddof=1) / math.sqrt(2)
    assert bars["porosity"][0] == pytest.approx(half + 0.002, rel=1e-9)
    assert bars["porosity"][1] == pytest.approx(0.004, rel=1e-12)


def _errorbar_calls(monkeypatch) -> list:
    """``(x, y, kwargs)`` of every matplotlib ``errorbar`` call of the code under test, the
    real method still called."""
    import matplotlib.axes

    calls = []
    real = matplotlib.axes.Axes.errorbar
    monkeypatch.setattr(
        matplotlib.axes.Axes,
        "errorbar",
        lambda self, x, y, **kw: (calls.append((list(x), list(y), kw)), real(self, x, y, **kw))[1],
    )
    return calls


def test_the_diffusivity_figure_draws_bars_and_marks_values_that_are_not_ok(monkeypatch):
    """The report's D_eff/D figure drew every row alike: an ``untrustworthy`` diffusivity (a
    300 % bar at a neck) looked like a trusted point, and no value had its bar. Now each point
    carries ``|rel_error * D|`` and a value whose status is not ``ok`` is an open marker (in
    its status's colour since session 45) counted in the caption, as the K figure does."""
    from psdesign.report.transport import transport_figure

    calls = _errorbar_calls(monkeypatch)
    df = pd.DataFrame(
        {
            "status": ["ok", "ok", "ok", "failed"],
            "porosity": [0.7, 0.8, 0.9, 0.85],
            "diffusivity_z": [0.40, 0.55, 0.75, np.nan],
            "diffusivity_z_rel_error": [0.05, 3.0, 0.02, np.nan],
            "diffusivity_z_status": ["ok", "untrustworthy", "ok", None],
        }
    )
    png, caption = transport_figure(df)
    assert png and f"1 value(s) that are not ok ({NOT_OK_MARKERS})" in caption
    (gx, gy, gkw), (bx, by, bkw) = calls
    assert (gx, gy) == ([0.7, 0.9], [0.40, 0.75]) and bx == [0.8] and by == [0.55]
    np.testing.assert_allclose(gkw["yerr"], [0.02, 0.015], rtol=1e-12)
    np.testing.assert_allclose(bkw["yerr"], [1.65], rtol=1e-12)
    # session 45: one colour per status (it was red for any), named in the legend
    assert bkw["mec"] == status_style("untrustworthy")[2] and bkw["mfc"] == "none"
    assert bkw["label"] == "diffusivity_z: untrustworthy (not in fits)"


def test_the_diffusivity_figure_draws_a_blocked_zero_by_its_status(monkeypatch):
    """Session 45: a ``blocked`` D_eff/D (0: the pore space closed along the direction, the
    most not-ok value a transport solve gives) was left out of the D_eff/D figure and its
    caption's count, though its axis is linear: ``not_ok_status`` drew positive values only,
    for the K figures' log axes. It is drawn at 0 with its status's marker and counted."""
    from psdesign.report.transport import transport_figure

    calls = _errorbar_calls(monkeypatch)
    df = pd.DataFrame(
        {
            "status": ["ok", "ok"],
            "porosity": [0.7, 0.3],
            "diffusivity_z": [0.40, 0.0],
            "diffusivity_z_rel_error": [0.05, 0.0],
            "diffusivity_z_status": ["ok", "blocked"],
        }
    )
    _, caption = transport_figure(df)
    assert f"1 value(s) that are not ok ({NOT_OK_MARKERS})" in caption  # main: no count
    (bx, by, bkw) = calls[-1]
    assert (bx, by) == ([0.3], [0.0]) and bkw["label"] == "diffusivity_z: blocked (not in fits)"
    assert bkw["mec"] == status_style("blocked")[2]


def _transport_case(spec, outputs, solver, workdir):
    """``fake_case`` with a D_eff/D per case: the Tomadakis-Sotirchos through-plane value
    (eps ((eps - 0.11) / 0.89)^0.785); porosity 0.9 is ``untrustworthy`` (a 300 % bar at a
    neck), the rest ``ok`` with a 2 % bar."""
    out = fake_case(spec, outputs, solver, workdir)
    eps = out["porosity"]
    out["diffusivity_z"] = eps * ((eps - 0.11) / 0.89) ** 0.785
    bad = eps == 0.9
    out["diffusivity_z_rel_error"] = 3.0 if bad else 0.02
    out["diffusivity_z_status"] = "untrustworthy" if bad else "ok"
    return out


def test_a_transport_study_report_plots_diffusivity_and_counts_values_not_ok(tmp_path):
    """The report's porosity-diffusivity figure (``report/transport.py``) was written but never
    put in the report, and its red box counted only K values that are not ok: a study whose
    D_eff/D was untrustworthy at porosity 0.9 (4 of 12 cases, K all ok) showed no box."""
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    run_study(p, tmp_path / "out", workers=0, case_fn=_transport_case, progress=False)
    html = (tmp_path / "out" / "report.html").read_text()
    assert '<h2>Porosity vs diffusivity</h2><img src="data:image/png;base64,' in html
    assert f"4 value(s) that are not ok ({NOT_OK_MARKERS})" in html
    alert = re.search(r'<p class="alert" id="psd-status-alert">(.*?)</p>', html, flags=re.S)
    assert alert and "4 value(s) of ok cases not ok (diffusivity_z_status)" in alert.group(1)
    # each case's D_eff/D with its bar and status: T-S at 0.8 is 0.8 (0.69 / 0.89)^0.785
    table = html.split("<h3>Porosity and transport values with error bars</h3>", 1)[1]
    table = table.split("</table>", 1)[0]
    d08, d09 = (e * ((e - 0.11) / 0.89) ** 0.785 for e in (0.8, 0.9))
    assert f"<td>{d08:.4g} ± 2.0 %</td>" in table
    assert f"<td>{d09:.4g} ± 300.0 % [untrustworthy]</td>" in table
    assert table.count('class="flag"') == 4  # the 4 untrustworthy cases (porosity 0.9)
    # the headings carry the units (session 40: they were bare column names)
    assert "<th>porosity (-)</th>" in table and "<th>diffusivity_z: D_eff/D (-)</th>" in table


def test_every_output_frame_has_a_unit_on_its_axis(monkeypatch):
    """Session 40 (new user's walk): on the inverse_design study's report the frames of
    diffusivity_z and tortuosity_z against the parameters had bare column names as y titles
    (no unit, where porosity read "porosity (-)" and K "K (m²)"). Every output frame's y title
    must carry its unit; the conductivity's is the study's ``transport.conductivity_unit``."""
    from psdesign.report import decision

    figs = []
    real = decision.figure_html
    monkeypatch.setattr(
        decision, "figure_html", lambda fig, *a, **k: (figs.append(fig), real(fig, *a, **k))[1]
    )
    eps = np.linspace(0.75, 0.9, 6)
    df = pd.DataFrame(
        {
            "generator.porosity": eps,
            "status": "ok",
            "porosity": eps,
            "diffusivity_z": eps**1.5,
            "tortuosity_z": eps / eps**1.5,
            "conductivity_z": 3 * (1 - eps),
            "pore_d50_m": 2e-5 * eps,
            "specific_surface_m-1": 1e5 * (1 - eps),
        }
    )
    study = {"base": {"transport": {"conductivity_unit": "S/m"}}}
    decision.parameter_plots(df, ["generator.porosity"], study)
    titles = {f.layout.title.text.split(" vs ")[0]: f.layout.yaxis.title.text for f in figs}
    assert titles == {
        "porosity": "porosity (-)",
        "diffusivity_z": "diffusivity_z: D_eff/D (-)",
        "tortuosity_z": "tortuosity_z (-)",
        "conductivity_z": "conductivity_z (S/m)",
        "pore_d50_m": "pore_d50_m (m)",
        "specific_surface_m-1": "specific_surface_m-1 (1/m)",
    }


@pytest.mark.parametrize("decades", [1.0, 2.0, 3.0, 4.0])
def test_pore_figure_tick_labels_do_not_overlap(tmp_path, monkeypatch, decades):
    """Session 40 (new user's walk): `psdesign pores --plot` of a 20 um box (intrusion
    diameters 2e-6 to 2e-5 m, one decade) labelled every minor tick of the log axis, and
    "4x10^-6" ran into "3x10^-6". No two drawn tick labels of either panel may overlap, and
    the log axis keeps at least two labels; the axes name their units."""
    from psdesign.report import png, transport

    drawn = []

    def capture(fig):  # the layout figure_png gives it, then drawn (closed: a new canvas)
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        png.figure_png(fig)
        FigureCanvasAgg(fig).draw()
        drawn.append(fig)
        return b""

    monkeypatch.setattr(transport, "figure_png", capture)
    d = np.linspace(1e-6, 2e-5, 20)
    pores = {
        "diameters_m": d,
        "volume_fraction": np.full(d.size, 1 / d.size),
        "pore_d10_m": 3e-6,
        "pore_d50_m": 1e-5,
        "pore_d90_m": 1.8e-5,
        "intrusion_diameter_m": np.geomspace(2e-5, 2e-5 / 10**decades, 14),
        "intrusion_saturation": np.linspace(0.4, 1.0, 14),
    }
    transport.pore_figure(pores, tmp_path / "p.png")
    (fig,) = drawn
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        assert "(m)" in ax.get_xlabel() and "(-)" in ax.get_ylabel()
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            labels = [
                t
                for tick, t in [
                    (t, t.label1) for t in axis.get_major_ticks() + axis.get_minor_ticks()
                ]
                if t.get_visible() and t.get_text() and lo <= tick.get_loc() <= hi
            ]
            boxes = sorted(
                (t.get_window_extent(renderer) for t in labels), key=lambda b: (b.x0, b.y0)
            )
            assert len(boxes) >= 2
            for b0, b1 in zip(boxes[:-1], boxes[1:], strict=True):
                assert not b0.overlaps(b1), [t.get_text() for t in labels]


def test_the_reports_surrogate_note_does_not_contradict_study_fit():
    """Session 49 (new user's walk): a 3-case study's report said "A surrogate needs at least 6
    finished cases", while ``psdesign study fit`` on the same folder fitted one from the 3
    (analysis.surrogate's minimum). The note now says the 6 are the report's and that
    ``study fit`` fits from 3. Truth: fit_surrogate fits the 3 cases without refusal and
    refuses 2. Session 49's review: the note spelled the 3 apart from fit_surrogate's minimum
    (now analysis.surrogate.MIN_FIT_CASES) and showed raw backticks in the HTML, where the
    other notes mark a command with <code>."""
    from psdesign.analysis.surrogate import fit_surrogate, parameter_bounds
    from psdesign.report.decision import MIN_CASES_SURROGATE, surrogate_plots

    df = pd.DataFrame(
        {
            "generator.porosity": [0.8, 0.85, 0.9],
            "status": "ok",
            "porosity": [0.795, 0.852, 0.910],
            "k_z_m2": [2.04e-12, 4.15e-12, 9.95e-12],
            "k_z_status": "ok",
        }
    )
    params = ["generator.porosity"]
    bounds = parameter_bounds(df, params, {})
    assert fit_surrogate(df, "k_z_m2", params, bounds).output == "k_z_m2"
    with pytest.raises(ValueError, match="need at least 3 finished cases"):
        fit_surrogate(df.iloc[:2], "k_z_m2", params, bounds)
    note = surrogate_plots(df, params, {})
    assert f"The report fits its surrogate from at least {MIN_CASES_SURROGATE}" in note, note
    assert "<code>psdesign study fit</code> fits from 3" in note and "needs at least" not in note
    assert "`" not in note


def _pores(scale: float, status: str) -> dict:
    """A pore scan's dict for :func:`psdesign.report.transport.pore_figure`, its diameters
    ``scale`` times those of a 20 um box."""
    d = np.linspace(1e-6, 2e-5, 20) * scale
    return {
        "diameters_m": d,
        "volume_fraction": np.full(d.size, 1 / d.size),
        "pore_d10_m": 3e-6 * scale,
        "pore_d50_m": 1e-5 * scale,
        "pore_d90_m": 1.8e-5 * scale,
        "diameter_error_m": 2.7e-6 * scale,
        "pore_sizes_status": status,
        "intrusion_diameter_m": np.geomspace(2e-5, 2e-6, 14) * scale,
        "intrusion_saturation": np.linspace(0.4, 1.0, 14),
    }


def test_pore_figure_has_one_size_and_room_for_its_title_and_labels(tmp_path, monkeypatch):
    """Session 49: ``psdesign pores --plot`` was saved with ``bbox_inches="tight"`` (its two
    panels under a title did not fit :func:`~psdesign.report.png.figure_png`'s fixed
    margins), so its size followed its labels: 862 x 394 px for the three-rod example, other
    sizes for other data. It now takes figure_png, whose margins hold a title and side by
    side panels: every input gives the figure's 9 x 3.4 in at 100 dpi, and, drawn, no text
    leaves the picture, the title clears both panels and the right panel's y label clears
    the left panel."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    from psdesign.report import png, transport

    drawn = []
    monkeypatch.setattr(
        transport, "figure_png", lambda fig: (drawn.append(fig), png.figure_png(fig))[1]
    )
    sizes = set()
    for i, (scale, status) in enumerate([(1.0, "ok"), (1e-3, "untrustworthy"), (40.0, "")]):
        out = transport.pore_figure(_pores(scale, status), tmp_path / f"p{i}.png")
        sizes.add(Image.open(out).size)
        fig = drawn[-1]
        FigureCanvasAgg(fig).draw()  # figure_png closed it: its canvas went with it
        renderer = fig.canvas.get_renderer()
        page = fig.bbox
        left, right = fig.axes
        boxes = [ax.get_tightbbox(renderer) for ax in fig.axes]  # labels and ticks drawn
        if fig._suptitle is not None:
            boxes.append(fig._suptitle.get_window_extent(renderer))
        for box in boxes:
            assert page.x0 - 1 <= box.x0 and box.x1 <= page.x1 + 1, (i, box)
            assert page.y0 - 1 <= box.y0 and box.y1 <= page.y1 + 1, (i, box)
        if fig._suptitle is not None:
            title = fig._suptitle.get_window_extent(renderer)
            for ax in fig.axes:
                assert title.y0 >= ax.get_tightbbox(renderer).y1, fig._suptitle.get_text()
        label = right.yaxis.get_tightbbox(renderer)
        assert label.x0 > left.get_tightbbox(renderer).x1
    assert sizes == {(900, 340)}


def test_an_explicit_fibers_diameter_as_parameter_normalizes_k(monkeypatch):
    """Session 40 (new user's walk): a study over ``fibers.0.diameter`` (6, 8, 10 um; one
    cylinder) drew K in m^2 against reference curves for the base fibre's r = 4 um, which hold
    for the middle case only: the report normalized K by r^2 only when the parameter was
    ``generator.diameter``. docs/study-files.md: ``K / r^2`` when the diameter varies. Truth:
    each case's own r = d / 2 (K 2.117e-11 at d = 6 um plots at K / (3 um)^2 = 2.35)."""
    from psdesign.report import html as report_html

    drawn = []
    monkeypatch.setattr(report_html, "_png", lambda fig: (drawn.append(fig), "")[1])
    df = pd.DataFrame(
        {
            "fibers.0.diameter": [6e-6, 8e-6, 1e-5],
            "status": "ok",
            "porosity": [0.92, 0.874, 0.80],
            "k_z_m2": [2.117e-11, 1.328e-11, 7.999e-12],
            "k_z_status": "ok",
        }
    )
    study = {"base": {"fibers": [{"shape": "cylinder", "diameter": 8e-6}]}}
    _, note = report_html._perm_figure(df, study)
    assert note.startswith("Diameter varies: permeability shown as K / r^2."), note
    (ax,) = drawn[0].axes
    y = [float(v) for line in ax.lines for v in line.get_ydata()]
    for k, d in zip(df["k_z_m2"], df["fibers.0.diameter"], strict=True):
        assert any(abs(v / (k / (d / 2) ** 2) - 1) < 1e-9 for v in y), (k, d)


def test_parameter_units_of_list_element_paths():
    """Session 40 (new user's walk): a study over ``fibers.0.diameter`` had its axes titled
    "fibers.0.diameter" with ticks 0.6e-5 ... 1e-5 and no unit, and docs/study-files.md's
    own example ``rve.size.2`` had none either: the schema names them ``fibers[].diameter``
    and ``rve.size`` (metres, docs/spec-keys.md)."""
    from psdesign.report.units import parameter_label, parameter_unit

    for key, unit in [
        ("fibers.0.diameter", "m"),
        ("fibers.12.theta", "deg"),
        ("fibers.0.center.2", "m"),
        ("rve.size.2", "m"),
    ]:
        assert parameter_unit(key) == unit, key
    assert parameter_label("fibers.0.diameter") == "fibers.0.diameter (m)"


def test_pore_figure_names_the_diameters_their_bar_and_the_status(tmp_path, monkeypatch):
    """Session 42 (new user's walk): `psdesign pores --plot` drew d10 / d50 / d90 as three
    unnamed dashed lines, without their one-sided error bar or the scan's status, so an
    untrustworthy scan (the line printed "[untrustworthy]", bar +2.7e-06/-0 m) looked like an
    ok one. The picture now names each line with its value, shades [d, d + bar] and puts the
    status in a red title."""
    import matplotlib.colors as mcolors

    from psdesign.report import transport

    drawn = []
    monkeypatch.setattr(transport, "figure_png", lambda fig: drawn.append(fig) or b"")
    d = np.linspace(1e-6, 2e-5, 20)
    pores = {
        "diameters_m": d,
        "volume_fraction": np.full(d.size, 1 / d.size),
        "pore_d10_m": 3e-6,
        "pore_d50_m": 1e-5,
        "pore_d90_m": 1.8e-5,
        "diameter_error_m": 2.7e-6,
        "pore_sizes_status": "untrustworthy",
        "intrusion_diameter_m": np.geomspace(2e-5, 2e-6, 14),
        "intrusion_saturation": np.linspace(0.4, 1.0, 14),
    }
    transport.pore_figure(pores, tmp_path / "p.png")
    (fig,) = drawn
    title = fig._suptitle
    assert "[untrustworthy]" in title.get_text() and "+2.7e-06/-0 m" in title.get_text()
    assert mcolors.same_color(title.get_color(), "tab:red")
    sizes = fig.axes[0]
    names = [t.get_text() for t in sizes.get_legend().get_texts()]
    assert names == ["d10 3e-06 m", "d50 1e-05 m", "d90 1.8e-05 m"]
    spans = sorted(
        (p.get_x(), p.get_width())
        for p in sizes.patches
        if hasattr(p, "get_x") and p.get_alpha() == pytest.approx(0.12)
    )
    for (x, w), q in zip(spans, (3e-6, 1e-5, 1.8e-5), strict=True):
        assert x == pytest.approx(q) and w == pytest.approx(2.7e-6)


def test_the_report_is_small_self_contained_and_unpacks_the_same_plotly(tmp_path) -> None:
    """Walkthrough (session 43): a 12-case report was 5.9 MB, 4.8 MB of it plotly.js inlined
    as text (82 %) and 0.96 MB of base64 PNG previews (480 x 400 px, shown 300 px wide). Now
    plotly.js goes in gzip-compressed (base64, 1.96 MB; the browser unpacks it offline,
    assets/plotly_loader.js) and the previews as JPEG at their own size: 2.6 MB for those
    12 cases, 2.2 MB for 2. Truth: the packed library unpacks to plotly's own script byte for
    byte; nothing is loaded from outside the file; the same folder gives the same file."""
    import gzip

    from plotly.offline import get_plotlyjs

    from psdesign.report import build_html

    out = tmp_path / "out"
    run_study(write_study(tmp_path, FACTORIAL, FAC_PARAMS), out, workers=0, case_fn=fake_case)
    html = build_html(out)
    assert len(html.encode("utf-8")) < 2.5e6, len(html)  # 4.9 MB before (the library alone)
    packed = re.search(r'<script type="application/gzip;base64" id="psd-plotly-gz">(.*?)<', html)
    assert packed is not None
    assert gzip.decompress(base64.b64decode(packed.group(1))).decode("utf-8") == get_plotlyjs()
    assert get_plotlyjs()[:2000] not in html  # once, packed: never as text too
    assert "<script src" not in html and not re.search(r'(src|href)="https?:', html)
    assert html.count('<script type="text/psd-plot">') >= 4  # run once plotly is unpacked
    assert "data:image/jpeg;base64," in html  # the previews
    assert build_html(out) == html
    # the inflater for browsers without DecompressionStream (session 44): once, inert text
    # run by the loader only there, with its licence and version
    assert html.count('<script type="text/psd-inflate" id="psd-inflate">') == 1
    assert html.count("fflate 0.8.3") == 1 and "MIT License" in html


def test_the_packed_plotly_is_compressed_once_per_process(monkeypatch) -> None:
    """Session 47: every report compressed plotly.js again (level-9 gzip of 4.82 MB, 0.22-0.24 s
    of CPU per report; a study's ``report`` and a search's outcome write several per process).
    Truth: two reports' head scripts are the same text from one ``gzip.compress`` call, and
    that text unpacks to plotly's own script (the test above)."""
    import gzip

    from psdesign.report import interactive

    calls = []
    compress = gzip.compress

    def counted(*args, **kwargs):
        calls.append(1)
        return compress(*args, **kwargs)

    getattr(interactive.plotly_gz, "cache_clear", lambda: None)()  # a fresh process's state
    monkeypatch.setattr(gzip, "compress", counted)
    first = interactive.head_scripts()
    assert interactive.head_scripts() == first
    assert len(calls) == 1  # main: 2, one per report


def test_response_surface_band_is_the_bar_study_predict_prints():
    """Review (session 43): `study predict` prints a bar never smaller than the fit's measured
    hold-out error (psdesign.analysis.prediction.holdout_bar), but the report's response
    surface still drew +-2 GP std: on K_z = 2 Kozeny-Carman (tests/study_cases.py, 1 % seed
    noise) at 5 porosity levels x 2 seeds the cross-validated error is 5.1 % and the GP std
    about a tenth of that bar, so the band was ~10x narrower than the printed +-. Now the
    band's half-width at each point is 2 x prediction_bar (GP std, never below holdout_bar),
    the 2-D panel plots that bar / mean, and the caption says so. Since session 44 the figure
    inside the box is the estimated error between the design points (``bar_error``), the one
    `study predict` prints there too."""
    from psdesign.analysis.prediction import bar_error, holdout_bar
    from psdesign.analysis.surrogate import fit_surrogate, parameter_bounds
    from psdesign.report.decision import _surface_1d, _surface_2d, surrogate_plots

    eps = np.repeat([0.7, 0.75, 0.8, 0.85, 0.9], 2)
    noise = 1 + 0.01 * np.random.default_rng(0).standard_normal(eps.size)
    ok = pd.DataFrame(
        {
            "generator.porosity": eps,
            "k_z_m2": 2 * kc_truth(eps, 7e-6) * noise,
            "status": "ok",
            "seed": np.tile([1, 2], 5),
            "case_id": [f"c{i}" for i in range(eps.size)],
        }
    )
    num = ["generator.porosity"]
    s = fit_surrogate(ok, "k_z_m2", num, parameter_bounds(ok, num, {}))
    fig = _surface_1d(s, ok, num, num[0], "k_z_m2")
    grid, mean = np.asarray(fig.data[2].x), np.asarray(fig.data[2].y)
    half = (np.asarray(fig.data[0].y) - mean) / 2
    _, gp_std = s.predict(grid[:, None])
    held = holdout_bar(s, mean)
    assert (held > gp_std).any()  # the premise: the hold-out figure is the wider bar somewhere
    # K ~ 1e-13 m^2: no abs slack
    assert half == pytest.approx(np.maximum(held, gp_std), rel=1e-12, abs=0)
    # two parameters: the right panel is bar / mean, i.e. the relative hold-out error here
    ok["generator.diameter"] = np.tile([6e-6, 8e-6], 5)
    two = ["generator.porosity", "generator.diameter"]
    s2 = fit_surrogate(ok, "k_z_m2", two, parameter_bounds(ok, two, {}))
    # (1 % noise: the GP std is below the hold-out floor everywhere, so the panel is the
    # floor in one line, not contours of a constant: review s52, walk-report 4)
    fig = _surface_2d(s2, ok, two, two, "k_z_m2")
    assert [t.type for t in fig.data] == ["contour", "scatter", "scatter"]
    note = f"bar = {100 * bar_error(s2)[0]:.1f} % of the mean everywhere in the box<br>(the fit"
    assert [a.text[: len(note)] for a in fig.layout.annotations if "bar =" in a.text] == [note]
    text = surrogate_plots(ok.drop(columns="generator.diameter"), num, {})
    rel_pct = f"{100 * bar_error(s)[0]:.3g} %"
    assert (
        "Response surface: its band (and relative uncertainty) is the bar study predict "
        "prints, the GP std never below the fit&#x27;s estimated error between the study&#x27;s "
        f"design points, {rel_pct}" in text
    )


def test_every_reference_curve_cites_its_entry_of_the_references(monkeypatch):
    """Session 45 looked at the report as pictures: the legends named "Tomadakis-Sotirchos"
    and "Kozeny-Carman" (the diffusivity figure "T-S") without a source, the References list
    at the page's foot unlinked to them. Every reference curve of the porosity-permeability
    and porosity-diffusivity figures now cites its numbered entry ("[1]"), and that entry names
    the same model and year (Tomadakis & Sotirchos, AIChE J. 1993; Carman, Trans. Inst. Chem.
    Eng. 1937)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from psdesign.report import html as report_html
    from psdesign.report import transport

    entries = re.findall(r"<li>(.*?)</li>", report_html._references(), flags=re.S)
    fig, ax = plt.subplots()
    report_html._reference_curves(ax, pd.Series([0.7, 0.9]), 3.5e-6, normalize=False)
    labels = list(ax.get_legend_handles_labels()[1])
    plt.close(fig)
    figs = []
    monkeypatch.setattr(transport, "figure_png", lambda f: figs.append(f) or b"")
    eps = np.array([0.7, 0.8, 0.9])
    transport.transport_figure(pd.DataFrame({"porosity": eps, "diffusivity_z": eps**1.5}))
    labels += [t for t in figs[0].axes[0].get_legend_handles_labels()[1] if "diffusivity" not in t]
    assert len(labels) == 5, labels
    for label in labels:
        cited = re.search(r"(\w+)-(\w+) (\d{4}) \[(\d)\]", label)
        assert cited, label
        first, second, year, n = cited.groups()
        entry = entries[int(n) - 1]
        assert entry.startswith(f"{first}-{second}:") and f"({year})" in entry, (label, entry)


def test_the_report_opens_on_its_answer_the_trusted_k_range_and_where(mixed_report):
    """Session 45 read the report as a person does: it opened on the run's metadata and the
    answer (which design gives the most / least permeable medium) was 2-4 screens down.
    "At a glance" now comes first, after the red box: per direction the highest and lowest
    K over trusted values only, with its bar and design point. Truth: Kozeny-Carman
    (``kc_truth``, the fake solver, times 1 + 0.5 i per direction and a 1 % noise); the
    untrustworthy K_z at porosity 0.9 (higher than any trusted one) and the not-converged
    cases must not be named."""
    df, html = mixed_report
    assert html.index('<h2 id="psd-glance">At a glance</h2>') < html.index("<h2>Study</h2>")
    table = html.split('<h2 id="psd-glance">', 1)[1].split("</table>", 1)[0]
    rows = {
        r[0]: r[1:] for r in (re.findall(r"<td>(.*?)</td>", tr) for tr in table.split("<tr>")[2:])
    }
    expect = {  # direction: (highest at eps, d; lowest at eps, d; trusted of 12; factor)
        "K_x (m²), in-plane": ((0.9, 8e-6), (0.8, 6e-6), 6, 1.0),
        "K_z (m²), through-plane": ((0.8, 8e-6), (0.8, 6e-6), 4, 2.0),
    }
    assert set(rows) == set(expect)
    for name, (hi, lo, n, factor) in expect.items():
        cells = rows[name]
        assert cells[2] == f"{n} of 12"
        for cell, (eps, d) in zip(cells[:2], (hi, lo), strict=True):
            k = float(cell.split(" ")[0])
            assert k == pytest.approx(kc_truth(eps, d) * factor, rel=0.03), (name, cell)
            assert "± 2.0 %" in cell  # the trusted values' bar (the untrusted one: 30 %)
            assert f"generator.porosity={eps:g}, generator.diameter={d:g} (" in cell, cell


def test_every_log_axis_ticks_whole_numbers(monkeypatch):
    """Session 45 looked at a 2-parameter voxel study's report: its K axes within about a
    decade ticked "3", "2", "1e-11", "9", "8", ... (plotly's ``minorloglabels`` "small digits",
    plotly.js reference: layout.yaxis.minorloglabels): digits that read as values of K. Every
    log axis of the report's figures (K, a loguniform parameter) now ticks whole numbers
    ("3e-11") at its minor ticks."""
    from psdesign.report import decision

    figs = []
    real = decision.figure_html
    monkeypatch.setattr(
        decision, "figure_html", lambda fig, *a, **k: (figs.append(fig), real(fig, *a, **k))[1]
    )
    df = _random_kc_study()
    params = ["generator.porosity", "generator.diameter"]
    decision.parameter_plots(df, params)
    decision.surrogate_plots(df, params, {})
    logs = [a for f in figs for a in [*f.select_xaxes(), *f.select_yaxes()] if a.type == "log"]
    assert len(logs) >= 2, len(logs)  # K against each parameter
    assert {a.minorloglabels for a in logs} == {"complete"}


def test_a_line_with_no_trusted_value_says_so_in_its_legend():
    """Session 45: a 2-parameter voxel study whose 6 um fibers were all untrustworthy (7.6
    voxels per diameter) drew 'K vs generator.porosity' with a legend entry
    'z (through-plane), generator.diameter = 6e-06 m' and no line: the reader could not tell a
    left-out series from a hidden one. Such an entry now ends ': no trusted value'; a line with
    values keeps its name."""
    from psdesign.report import decision

    eps, d = np.repeat([0.75, 0.85, 0.9], 2), np.tile([6e-6, 8e-6], 3)
    df = pd.DataFrame(
        {
            "case_id": [f"c{i}" for i in range(6)],
            "seed": 1,
            "generator.porosity": eps,
            "generator.diameter": d,
            "status": "ok",
            "porosity": eps,
            "k_z_m2": kc_truth(eps, d),
            "k_z_rel_error": 0.05,
            "k_z_status": np.where(d < 7e-6, "untrustworthy", "ok"),
        }
    )
    html = decision.parameter_plots(df, ["generator.porosity", "generator.diameter"])
    names = set(re.findall(r'"name":"([^"]*)"', html))
    assert "z (through-plane), generator.diameter = 6e-06 m: no trusted value" in names
    assert "z (through-plane), generator.diameter = 8e-06 m" in names
    assert sum(n.endswith(": no trusted value") for n in names) == 1


def _captured(monkeypatch, module, name: str) -> list:
    """Figures passed to ``module.name`` (``figure_html`` or ``_png``) by the code under
    test, the real function still called."""
    figs = []
    real = getattr(module, name)
    monkeypatch.setattr(
        module, name, lambda fig, *a, **k: (figs.append(fig), real(fig, *a, **k))[1]
    )
    return figs


def test_k_vs_parameter_frames_draw_every_untrusted_case_by_its_status(mixed_report, monkeypatch):
    """Session 45 looked at the report as pictures: the K-vs-parameter frames left out every
    case whose K was not ok, unmarked (an engineer saw a line end, not why). Each such K is
    now drawn at its case's design point with its own bar (rel_error x K: 30 % for the fake
    study's untrustworthy K_z, mixed_status_case), one open symbol per status, in a trace named
    for the direction and status, never in a line; failed cases (no K) are counted in a note."""
    from psdesign.report import decision

    df, _ = mixed_report
    figs = _captured(monkeypatch, decision, "figure_html")
    html = decision.parameter_plots(df, ["generator.porosity", "generator.diameter"], {})
    assert "4 failed or timed-out case(s) have no K: not drawn." in html
    fig = next(f for f in figs if f.layout.title.text.startswith("K vs generator.porosity"))
    traces = {t.name: t for t in fig.data}
    for d, status, n in (
        ("z", "untrustworthy", 2),
        ("z", "not_converged", 2),
        ("x", "not_converged", 2),
    ):
        name = f"{decision.K_DIRECTIONS[f'k_{d}_m2']}: {status} (not in the lines)"
        t = traces[name]
        assert t.mode == "markers" and len(t.x) == n and set(t.x) == {0.9}, name
        rows = df[(df["generator.porosity"] == 0.9) & (df["status"] != "failed")]
        rows = rows[(rows["status"] == "not_converged") == (status == "not_converged")]
        assert sorted(t.y) == pytest.approx(sorted(rows[f"k_{d}_m2"]), rel=1e-12)
        rel = 0.3 if status == "untrustworthy" else 0.02
        assert list(t.error_y.array) == pytest.approx([rel * y for y in t.y], rel=1e-12)
    assert traces["z (through-plane): untrustworthy (not in the lines)"].marker.symbol != (
        traces["z (through-plane): not_converged (not in the lines)"].marker.symbol
    )
    # the lines hold trusted values only: no line point at 0.9 carries the untrustworthy K_z
    bad = set(df.loc[df["k_z_status"] != "ok", "k_z_m2"].dropna())
    lines = [t for t in fig.data if "lines" in (t.mode or "")]
    assert lines and not any(y in bad for t in lines for y in t.y if y is not None)


def test_the_other_outputs_frames_draw_every_value_that_is_not_ok_by_its_status(monkeypatch):
    """Session 45: the porosity, anisotropy, D_eff/D and conductivity frames against a design
    parameter drew trusted means only (s45-looks2 marked the K frames); a D_eff/D = 0 that is
    ``blocked``, a not-converged case's values, an anisotropy over an untrustworthy K_z left
    no trace, and an output with no trusted value had no frame. Each is now drawn at its case's
    design point with its own bar (the table's rel error x value, or its absolute error), an
    open symbol per status, never in a line. Truth: the table below, written by hand."""
    from psdesign.report import decision

    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1", "c2", "c3"],
            "status": ["ok", "ok", "not_converged", "ok"],
            "generator.porosity": [0.7, 0.8, 0.9, 0.8],
            "porosity": [0.70, 0.79, 0.91, 0.81],
            "porosity_error": [0.01, 0.01, 0.02, 0.01],
            "k_x_m2": [1e-11, 2e-11, 3e-11, 2e-11],
            "k_z_m2": [2e-11, 8e-12, 5e-11, 4e-11],
            "k_z_rel_error": [0.02, 0.3, 0.02, 0.02],
            "k_z_status": ["ok", "untrustworthy", "ok", "ok"],
            "diffusivity_z": [0.5, 0.0, 0.6, 0.55],
            "diffusivity_z_rel_error": [0.02, 0.0, 0.05, 0.02],
            "diffusivity_z_status": ["ok", "blocked", "ok", "ok"],
            # every conductivity untrustworthy: no trusted mean, still a frame
            "conductivity_z": [0.1, 0.2, 0.3, 0.25],
            "conductivity_z_rel_error": [0.4, 0.4, 0.4, 0.4],
            "conductivity_z_status": "untrustworthy",
        }
    )
    figs = _captured(monkeypatch, decision, "figure_html")
    decision.parameter_plots(df, ["generator.porosity"], {})
    frames = {f.layout.title.text: f for f in figs}

    def traces(c):
        return {t.name: t for t in frames[f"{c} vs generator.porosity"].data}

    def marker(c, status):
        t = traces(c)[f"{c}: {status} (not in the lines)"]
        assert t.mode == "markers"
        return list(t.x), list(t.y), list(t.error_y.array) if t.error_y.array is not None else None

    assert marker("diffusivity_z", "blocked") == ([0.8], [0.0], [0.0])
    assert marker("diffusivity_z", "not_converged") == ([0.9], [0.6], [pytest.approx(0.03)])
    assert marker("porosity", "not_converged") == ([0.9], [0.91], [0.02])
    aniso_x, aniso_y, _ = marker("anisotropy", "untrustworthy")  # its K_z is untrustworthy
    assert aniso_x == [0.8] and aniso_y == [pytest.approx(2e-11 / 8e-12)]
    assert marker("anisotropy", "not_converged")[:2] == ([0.9], [pytest.approx(3e-11 / 5e-11)])
    x, y, e = marker("conductivity_z", "untrustworthy")
    assert sorted(x) == [0.7, 0.8, 0.8] and e == pytest.approx([0.4 * v for v in y])
    assert marker("conductivity_z", "not_converged")[:2] == ([0.9], [0.3])  # the case's status
    assert not [t for t in traces("conductivity_z").values() if "lines" in (t.mode or "")]
    symbols = {s: traces("diffusivity_z")[f"diffusivity_z: {s} (not in the lines)"].marker.symbol
               for s in ("blocked", "not_converged")}  # fmt: skip
    assert symbols == {s: status_style(s)[0] for s in symbols} and len(set(symbols.values())) == 2
    # the lines hold trusted values only: the blocked 0 and the not-converged 0.6 are in none
    for c, bad in (("diffusivity_z", {0.0, 0.6}), ("porosity", {0.91})):
        lines = [t for t in traces(c).values() if "lines" in (t.mode or "")]
        assert lines and not any(v in bad for t in lines for v in t.y if v is not None), c


def test_porosity_k_and_convergence_figures_tell_not_converged_from_untrustworthy(
    mixed_report, monkeypatch
):
    """Session 45: both statuses were one red open marker labelled "NOT ok (not converged /
    untrustworthy)", and the convergence plot's x axis was a case index while its table named
    case ids. Each status now has its own legend entry and colour; the convergence plot's x
    ticks are the table's case ids (their c0000 part)."""
    from psdesign.report import html as report_html

    df, _ = mixed_report
    figs = _captured(monkeypatch, report_html, "_png")
    report_html._perm_figure(df, {})
    ax = figs[0].axes[0]
    handles, labels = ax.get_legend_handles_labels()
    by = dict(zip(labels, handles, strict=True))
    nc, un = (
        "z (through-plane): not_converged (not in fits)",
        "z (through-plane): untrustworthy (not in fits)",
    )
    assert nc in by and un in by and "x (in-plane): not_converged (not in fits)" in by
    assert not any("NOT ok" in t for t in labels)
    colour = {k: by[k][0].get_markeredgecolor() for k in (nc, un)}
    assert colour[nc] != colour[un]
    figs.clear()
    table, uri, _ = report_html._convergence(df)
    assert uri
    ax = figs[0].axes[0]
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    assert ticks == [c.split("-")[0] for c in df["case_id"]]
    assert ax.get_xlabel() == "case id"
    labels = ax.get_legend_handles_labels()[1]
    assert (
        "flux_imbalance_z: not_converged" in labels and "flux_imbalance_z: untrustworthy" in labels
    )


def test_every_listed_reference_is_drawn_in_a_figure():
    """Session 45: the References list had a 3rd entry (Gostick et al. 2006, a measured Toray
    090 K) that no figure drew or cited. Every entry is now cited by a reference curve's
    label ("[n]") of the porosity-permeability figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from psdesign.report import html as report_html

    entries = re.findall(r"<li>(.*?)</li>", report_html._references(), flags=re.S)
    fig, ax = plt.subplots()
    report_html._reference_curves(ax, pd.Series([0.7, 0.9]), 3.5e-6, normalize=False)
    cited = {int(n) for t in ax.get_legend_handles_labels()[1] for n in re.findall(r"\[(\d)\]", t)}
    plt.close(fig)
    assert cited == set(range(1, len(entries) + 1)), (cited, len(entries))


def test_a_study_with_no_ok_case_says_so_not_that_it_varies_no_parameter():
    """review s45: a study varying porosity and diameter whose every case failed or did not
    converge read "No numeric design parameter to plot against." and "Main effects need a
    varying numeric parameter and K." (both false: two parameters varied), and the all-failed
    one had no "At a glance" section at all; now each says that no case is ok, with the
    counts of the table."""
    from psdesign.report.decision import effect_plots, parameter_plots
    from psdesign.report.glance import glance_section

    params = ["generator.porosity", "generator.diameter"]
    eps, d = [0.7, 0.8, 0.9, 0.7, 0.8, 0.9], [6e-6] * 3 + [8e-6] * 3
    nc = pd.DataFrame(
        {
            "case_id": [f"c{i}" for i in range(6)],
            "generator.porosity": eps,
            "generator.diameter": d,
            "seed": 1,
            "status": ["not_converged"] * 5 + ["failed"],
            "k_z_m2": [kc_truth(e, r) for e, r in zip(eps, d, strict=True)],
        }
    )
    nc.loc[5, "k_z_m2"] = np.nan
    words = "no case is ok: 1 failed, 5 not_converged of 6"
    for section in (parameter_plots(nc, params), effect_plots(nc, params)):
        assert "No numeric design parameter" not in section and "need a varying" not in section
        assert f"Not plotted against the design parameters, {words}" in section
    assert "no trusted K" in glance_section(nc, params)  # the K columns say it per direction
    failed = nc[["case_id", *params, "seed"]].assign(status="failed")  # no K column
    glance = glance_section(failed, params)
    assert 'id="psd-glance"' in glance and "No result: no case is ok: 6 failed of 6" in glance
    # one ok case: the sections are not told that no case is ok
    one_ok = nc.assign(status=["ok"] + ["not_converged"] * 5)
    assert "no case is ok" not in parameter_plots(one_ok, params) + glance_section(one_ok, params)


def test_a_case_with_no_status_is_highlighted_in_every_table_as_the_glance_leaves_it_out():
    """review s45: a results row with an empty status (a table the runner did not write) is
    failed by the exit rule (``case_masks``) and left out of the glance and the means
    (``trusted``), but the K and values tables printed it as ``ok``, unhighlighted, beside a
    glance that did not count it. Now both tables say ``unknown`` and highlight it."""
    from psdesign.cli.exit_status import case_counts
    from psdesign.report.glance import glance_section
    from psdesign.report.html import _k_table, _values_table

    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1"],
            "generator.porosity": [0.8, 0.9],
            "status": ["ok", np.nan],
            "porosity": [0.8, 0.9],
            "porosity_error": [1e-3, 1e-3],
            "k_z_m2": [kc_truth(0.8, 7e-6), kc_truth(0.9, 7e-6)],
            "k_z_rel_error": [0.02, 0.02],
            "k_z_status": ["ok", "ok"],
        }
    )
    assert case_counts(df).failed == 1
    assert value_status(df, "k_z_m2").tolist() == ["ok", "unknown"]  # its marker's legend
    assert "1 of 2" in glance_section(df, ["generator.porosity"])
    for table in (_k_table(df, "voxel"), _values_table(df)):
        rows = re.findall(r"<tr( class=\"flag\")?>\s*<td>(c\d)</td>", table)
        assert rows == [("", "c0"), (' class="flag"', "c1")], rows
        assert "unknown" in table.split(">c1<", 1)[1].split("</tr>", 1)[0]


def test_a_timed_out_case_is_counted_among_the_cases_with_no_k():
    """review s45: the K frames' and the porosity-K figure's "N failed case(s) have no K"
    counted ``failed`` only; a ``timeout`` case has no K either (the exit rule's
    ``NOT_FINISHED``) and went uncounted. Truth: 1 failed + 1 timeout = 2."""
    from psdesign.report.decision import parameter_plots

    eps = [0.7, 0.8, 0.9, 0.75]
    df = pd.DataFrame(
        {
            "case_id": [f"c{i}" for i in range(4)],
            "generator.porosity": eps,
            "seed": 1,
            "status": ["ok", "ok", "timeout", "failed"],
            "k_z_m2": [kc_truth(eps[0], 7e-6), kc_truth(eps[1], 7e-6), np.nan, np.nan],
        }
    )
    assert "2 failed or timed-out case(s) have no K: not drawn." in parameter_plots(
        df, ["generator.porosity"]
    )


@pytest.mark.parametrize("with_column", [False, True])
def test_a_porosity_with_a_27_percent_bar_is_marked_in_the_frames_not_in_their_means(with_column):
    """Session 46: the frames rated a porosity by its case's status only, while ``generate``
    and the values table rate it by its bar (``ok`` up to 20 %, ``analysis.columns.
    porosity_status``): a porosity of 0.09 +- 0.0243 (27 %) in an ok case was in the frame's
    mean, unmarked. Now the study row carries ``porosity_status`` (``with_column``) and a table
    written before session 46 is rated by the bar: the mean of the 0.1 level is the other
    seed's 0.11 alone (independent: the arithmetic mean of the trusted values), the point is
    an open ``untrustworthy`` marker, and the red box counts it."""
    from psdesign.analysis.columns import porosity_status, trusted
    from psdesign.analysis.replicates import replicate_summary
    from psdesign.report.decision import parameter_plots
    from psdesign.report.html import _status_banner

    eps, err = [0.09, 0.11, 0.80, 0.81], [0.0243, 1e-3, 1e-3, 1e-3]
    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1", "c2", "c3"],
            "generator.porosity": [0.1, 0.1, 0.8, 0.8],
            "seed": [1, 2, 1, 2],
            "status": ["ok"] * 4,
            "porosity": eps,
            "porosity_error": err,
            "k_z_m2": [kc_truth(e, 7e-6) for e in eps],
            "k_z_rel_error": [0.02] * 4,
            "k_z_status": ["ok"] * 4,
        }
    )
    if with_column:  # as run_case writes it
        df["porosity_status"] = [porosity_status(e, b) for e, b in zip(eps, err, strict=True)]
    t = trusted(df)
    assert t["porosity"].isna().tolist() == [True, False, False, False]
    assert t["porosity_error"].isna().tolist() == [True, False, False, False]  # its bar too
    means = replicate_summary(t, ["generator.porosity"])["porosity_mean"].tolist()
    assert means == pytest.approx([0.11, 0.805])
    marks = re.findall(
        r"porosity: ([a-z_]+) \(not in the lines\)", parameter_plots(df, ["generator.porosity"])
    )
    assert marks == ["untrustworthy"]
    assert "1 value(s) of ok cases not ok (porosity_status)" in _status_banner(df)


def test_the_red_box_words_the_porosity_rating_from_status_words(monkeypatch):
    """Session 48: the red box wrote the porosity's rating as "(above 20 %)", a copy of
    ``psdesign.status.STATUS_WORDS["porosity_status"]`` that an edit of the table would leave
    behind (as the values table's Omega note did until 216c428). The box reads the table: a
    changed entry shows in it, and the old hand-written words do not."""
    from psdesign import status
    from psdesign.report.html import _status_banner

    df = pd.DataFrame(
        {"case_id": ["c0"], "status": ["ok"], "porosity": [0.09], "porosity_error": [0.0243]}
    )
    box = _status_banner(df)
    assert "(porosity_status: untrustworthy = error bar above 20 %)" in box, box
    words = "untrustworthy = a bar over TEST_LIMIT & <more>"
    monkeypatch.setitem(status.STATUS_WORDS, "porosity_status", words)
    box = _status_banner(df)
    assert "untrustworthy = a bar over TEST_LIMIT &amp; &lt;more&gt;" in box, box  # escaped
    assert "20 %" not in box, box


def test_the_values_table_prints_omega_with_its_absolute_bar():
    """review s46: Omega (a fraction of the box) was printed with a relative bar, ``1e-05 ±
    2000.0 %``, and an exact zero count without any (its relative bar 0 / 0). Like the
    porosity, Omega is printed ± its absolute error: ``0 ± 0`` and ``1e-05 ± 2.0e-04``, the
    numbers of the row (truth: the row itself)."""
    from psdesign.report.html import _values_table

    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1"],
            "status": ["ok", "ok"],
            "porosity": [0.8, 0.9],
            "porosity_error": [4e-4, 4e-4],
            "intersection_volume_fraction": [0.0, 1e-5],
            "intersection_volume_fraction_error": [0.0, 2e-4],
            "intersection_volume_fraction_status": ["ok", "ok"],
        }
    )
    table = _values_table(df)
    cells = re.findall(r"<td>([^<]*±[^<]*)</td>", table)
    assert cells == ["0.8000 ± 4.0e-04", "0 ± 0", "0.9000 ± 4.0e-04", "1e-05 ± 2.0e-04"], cells
    assert "%" not in table.split("</p>", 1)[1]
    assert "± its absolute error" in table


def test_the_values_table_says_a_blocked_tortuosity_is_blocked():
    """Session 51: a blocked diffusivity's row has D_eff/D 0 and no tortuosity (an empty
    cell, the JSON's ``null``: porosity / 0), both rated by ``diffusivity_z_status =
    blocked``. The values table printed the diffusivity ``[blocked]`` and the tortuosity as a
    blank cell; it now says ``undefined [blocked]`` (truth: the row's status)."""
    from psdesign.report.html import _values_table

    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1"],
            "status": ["ok", "ok"],
            "diffusivity_z": [0.0, 0.5],
            "diffusivity_z_rel_error": [0.0, 0.01],
            "diffusivity_z_status": ["blocked", "ok"],
            "tortuosity_z": [None, 1.6],
        }
    )
    cells = re.findall(r"<td>([^<]*)</td>", _values_table(df))
    assert cells[2:4] == ["0 ± 0.0 % [blocked]", "undefined [blocked]"], cells


def test_parameter_plots_rate_each_output_once_not_once_per_parameter(monkeypatch):
    """Session 47: ``parameter_plots`` asked ``not_ok_status`` for an output's not-ok rows in
    every frame (parameters x outputs; on a 2000-row table without status columns each call
    rates every row by its bar) and K's once more to choose the directions. Each output is now
    rated once (K on its log axis, the others on their linear ones), whatever the number of
    parameters; the frames are the same (the frames tests above)."""
    from collections import Counter

    from psdesign.report import decision

    calls = Counter()
    real = decision.not_ok_status
    monkeypatch.setattr(
        decision,
        "not_ok_status",
        lambda df, c, log=True: (calls.update([(c, log)]), real(df, c, log))[1],
    )
    df = _random_kc_study()
    df["generator.fiber_length"] = np.linspace(1e-4, 2e-4, len(df))  # a third parameter
    df["porosity_error"] = 0.3 * df["porosity"]  # 30 %: every porosity untrustworthy
    params = ["generator.porosity", "generator.diameter", "generator.fiber_length"]
    html = decision.parameter_plots(df, params)
    assert "porosity: untrustworthy (not in the lines)" in html  # the rating drew its markers
    assert calls[("k_z_m2", True)] == 1 and calls[("porosity", False)] == 1, calls
    assert max(calls.values()) == 1, calls


@pytest.mark.parametrize("rated", ["own status", "bar alone"])
def test_a_trusted_k_at_an_untrustworthy_porosity_is_drawn_open_in_both_porosity_figures(
    monkeypatch, rated
):
    """Session 46 left it: the porosity-K figure drew a trusted K at a porosity with a 27 %
    bar (0.09 +- 0.0243, untrustworthy by the 20 % rule of ``columns.porosity_status``) as a
    filled point, an x no one trusts drawn as trusted; the D_eff/D figure likewise. A point
    is as trusted as the least trusted of its coordinates (``trust.point_status``): it is
    drawn open in the status's colour (as a not-ok K), with its own legend entry "porosity
    untrustworthy (value in fits)", counted in the caption, and in no filled series. Truth:
    the table below; only the porosity is flagged (a table with ``porosity_status`` and one
    written before it, rated by its bar)."""
    from psdesign.report import html as report_html
    from psdesign.report.transport import transport_figure

    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1", "c2"],
            "status": ["ok", "ok", "ok"],
            "porosity": [0.70, 0.09, 0.85],
            "porosity_error": [4e-4, 0.0243, 4e-4],
            "k_z_m2": [2e-12, 1e-14, 2e-11],
            "k_z_rel_error": [0.05, 0.05, 0.05],
            "k_z_status": ["ok", "ok", "ok"],
            "diffusivity_z": [0.45, 0.01, 0.7],
            "diffusivity_z_rel_error": [0.02, 0.02, 0.02],
            "diffusivity_z_status": ["ok", "ok", "ok"],
        }
    )
    if rated == "own status":
        df["porosity_status"] = ["ok", "untrustworthy", "ok"]
    purple = status_style("untrustworthy")[2]
    for draw, name in ((lambda: report_html._perm_figure(df, {}), "z (through-plane)"),
                       (lambda: transport_figure(df), "diffusivity_z")):  # fmt: skip
        calls = _errorbar_calls(monkeypatch)
        png, caption = draw()
        assert png
        filled = [x for x, _, kw in calls if kw.get("mfc") != "none"]
        assert filled == [[0.70, 0.85]], filled  # main: [0.70, 0.09, 0.85], no open marker
        ((ox, _, okw),) = [c for c in calls if c[2].get("mfc") == "none"]
        assert ox == [0.09] and okw["mec"] == purple
        assert okw["label"] == f"{name}: porosity untrustworthy (value in fits)"
        values = "K" if name.startswith("z") else "D_eff/D"
        assert f"1 trusted {values} value(s) at a porosity that is not ok are drawn open" in caption
        assert "not ok (open markers" not in caption  # no value of its own is not ok


@pytest.mark.parametrize(
    ("k_z", "ids", "diameter"),
    [
        ([9.4e-12, 2.2e-11], ["c0000-x", "c0001-x"], 7e-6),  # the quickstart's two cases
        ([3.0e-11, 4.5e-11], ["c0000", "c0001"], None),  # inside a decade, no curves
        ([1e-13, 3e-9], ["averyveryverylongcaseidentifier0000", "b1"], 8e-6),
    ],
    ids=["quickstart", "in_a_decade", "long_ids"],
)
def test_the_report_figures_are_drawn_once_with_every_label_inside(k_z, ids, diameter, monkeypatch):
    """Session 48: each of the report's two matplotlib PNGs was drawn twice
    (``bbox_inches="tight"`` draws to find the margins, then again to save; the convergence
    figure's ``tight_layout`` measured it a third time), about half their CPU. They are now
    drawn once, at fixed margins that hold labels of a known size (``log_tick_text``) and a
    bottom one measured from the rotated case ids. Truth: matplotlib's own extent of every
    artist of each axes (tick labels, axis labels, legend) lies inside the saved picture, and
    ``Figure.draw`` ran once per figure."""
    import matplotlib.figure
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from psdesign.report import html as report_html

    draws = []
    real_draw = matplotlib.figure.Figure.draw
    monkeypatch.setattr(
        matplotlib.figure.Figure, "draw", lambda self, r: (draws.append(self), real_draw(self, r))
    )
    figs = _captured(monkeypatch, report_html, "_png")
    df = pd.DataFrame(
        {
            "case_id": ids,
            "status": "ok",
            "porosity": [0.849, 0.904],
            "porosity_error": [4e-4, 4e-4],
            "k_z_m2": k_z,
            "k_z_rel_error": [0.05, 0.05],
            "k_z_status": "ok",
            "converged_z": [True, True],
            "flux_imbalance_z": [8e-7, 1.5e-6],
        }
    )
    study = {"base": {"generator": {"diameter": diameter}}} if diameter else {}
    assert report_html._perm_figure(df, study)[0] and report_html._convergence(df)[1]
    assert len(figs) == 2 and [draws.count(f) for f in figs] == [1, 1]
    for fig in figs:
        renderer = FigureCanvasAgg(fig).get_renderer()  # pyplot's was closed
        width, height = fig.bbox.width, fig.bbox.height
        for ax in fig.axes:
            box = ax.get_tightbbox(renderer)
            inside = box.x0 >= 0 and box.y0 >= 0 and box.x1 <= width and box.y1 <= height
            assert inside, (box, width, height)
            labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
            assert len(labels) == len(set(labels)) >= 2, labels  # no label twice


#: A study case's row with a preview picture ``p.png`` (the gallery tests).
PREVIEW_ROW = {
    "case_id": "c0000-ab",
    "seed": 1,
    "generator.porosity": 0.8,
    "porosity": 0.81234,
    "porosity_error": 0.00042,
    "n_fibers": 12,
    "preview_png": "p.png",
}


def test_the_study_previews_carry_generates_title(tmp_path):
    """Session 48 (the session-47 re-read): ``generate``'s preview is titled with the porosity
    and Omega, each with its bar and status, and the fibre count, while a study's previews
    were captioned with the design point only: an untrustworthy Omega looked like an ok one.
    The report's caption now ends with the one title (``report.preview.preview_title``, which
    ``generate`` calls too): the row's own numbers, Omega left out for an image's RVE (its 0/1
    count cannot see overlaps, docs/geometry.md)."""
    from study_cases import PNG_1PX

    from psdesign.report.html import _previews
    from psdesign.report.preview import preview_title

    (tmp_path / "p.png").write_bytes(PNG_1PX)
    row = {
        **PREVIEW_ROW,
        "intersection_volume_fraction": 0.00213,
        "intersection_volume_fraction_error": 0.0003,
        "intersection_volume_fraction_status": "untrustworthy",
    }
    df = pd.DataFrame([row])
    title = "porosity 0.8123 +- 4.2e-04 [ok], Omega 0.00213 +- 3.0e-04 [untrustworthy], 12 fibers"
    assert preview_title(row) == title
    html = _previews(df, tmp_path, ["generator.porosity"])
    assert f"<figcaption>c0000-ab: generator.porosity=0.8 seed=1; {title}</figcaption>" in html
    image = _previews(df, tmp_path, ["generator.porosity"], image=True)
    assert "seed=1; porosity 0.8123 +- 4.2e-04 [ok], 12 fibers</figcaption>" in image, image
    assert "Omega" not in image


def test_a_titled_preview_is_not_captioned_with_its_title_again(tmp_path):
    """Session 49: since session 48 a study case's preview.png carries generate's title, and
    the gallery's caption repeated it under the picture. The case's row now says what is
    drawn (``preview_title``, written by psdesign.study.case with the picture): such a
    picture is captioned with its design point only, while a row of a folder written before
    session 49 (no ``preview_title``; its picture drawn with the title since session 48)
    keeps the title in its caption; in one table (an old folder resumed) each row by its
    own."""
    from study_cases import PNG_1PX

    from psdesign.report.html import _previews

    (tmp_path / "p.png").write_bytes(PNG_1PX)
    title = "porosity 0.8123 +- 4.2e-04 [ok], 12 fibers"
    old = dict(PREVIEW_ROW)
    new = {**old, "case_id": "c0001-cd", "preview_title": title}
    for rows in ([old], [new], [old, new]):
        html = _previews(pd.DataFrame(rows), tmp_path, ["generator.porosity"], image=True)
        if old in rows:
            assert f"<figcaption>c0000-ab: generator.porosity=0.8 seed=1; {title}<" in html
        if new in rows:
            assert "<figcaption>c0001-cd: generator.porosity=0.8 seed=1</figcaption>" in html
        assert html.count(title) == 2 * (old in rows), html  # caption and alt text


def _log_axis_labels(values: list[float], inverted: bool = False):
    """The labels in view of a log y axis over ``values`` (2 % error bars) ticked by
    ``log_ticks``, with the axis' limits."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from psdesign.report.transport import log_ticks

    fig, ax = plt.subplots()
    ax.errorbar(range(len(values)), values, yerr=[0.02 * v for v in values], fmt="o")
    ax.set_yscale("log")
    if inverted:
        ax.invert_yaxis()
    log_ticks(ax.yaxis, [v for line in ax.lines for v in line.get_ydata()])
    fig.canvas.draw()
    limits = ax.get_ylim()
    lo, hi = sorted(limits)
    labels = [
        t.get_text()
        for t in ax.yaxis.get_majorticklabels()
        if t.get_text() and lo <= t.get_position()[1] <= hi
    ]
    plt.close(fig)
    return labels, limits


@pytest.mark.parametrize(
    ("values", "inverted"),
    [([9.40e-12, 9.45e-12], False), ([9.4e-12], False), ([1.8e-5, 2.3e-5], True)],
)
def test_a_narrow_log_axis_labels_each_value_once(values, inverted):
    """Session 48 review: K_z = 9.40e-12 and 9.45e-12 (or a one-case study) lie within one
    1-2-5 step, matplotlib's LogLocator falls back to linear ticks and the labels read
    ``9.4e-12`` over and over. The view now widens to the 1-2-5 values on either side
    (5e-12 and 1e-11): at least two labels, none twice, each at most 7 characters
    (FIG_MARGINS_IN), every point inside the view, an inverted axis (the intrusion curve's)
    still inverted. Truth: the 1-2-5 sequence around the values."""
    labels, (a, b) = _log_axis_labels(values, inverted)
    assert len(labels) >= 2 and len(set(labels)) == len(labels), labels
    assert max(map(len, labels)) <= 7, labels
    assert (a > b) == inverted
    assert all(min(a, b) < v < max(a, b) for v in values)
    if values[0] == 9.4e-12:
        assert labels == ["5e-12", "1e-11"]


@pytest.mark.parametrize(
    ("values", "inverted"),
    [([9.40e-12, 9.45e-12], False), ([9.4e-12], False), ([1.8e-5, 2.3e-5], True)],
)
def test_a_widened_log_axis_is_centred_on_its_data(values, inverted):
    """Session 49: the widened view of a narrow log axis ran from the 1-2-5 value below the
    data to the one above, so K_z = 9.4e-12 sat at 91 % of the height of [5e-12, 1e-11], by
    the top edge. The view is now centred on the data in log space: the geometric mean of
    the smallest and largest value lies half-way up, to 1e-3 of the log height, and the
    1-2-5 values either side stay in view. Truth: log10 of the limits and the values."""
    labels, limits = _log_axis_labels(values, inverted)
    a, b = np.log10(sorted(limits))
    centre = 0.5 * (math.log10(min(values)) + math.log10(max(values)))
    assert (centre - a) / (b - a) == pytest.approx(0.5, abs=1e-3), (limits, values)
    assert len(labels) >= 2, labels


def test_a_summary_number_is_read_by_one_helper():
    """Session 48 review: ``report.preview._given`` repeated ``analysis.columns._number`` (a
    cell as a float, None where missing, NaN or text). One public helper,
    ``columns.cell_number``, reads both; the preview's title reads a table row's NaN bar as
    none (``[unrated]``) and text as missing. Truth: the values as given."""
    from psdesign.analysis import columns
    from psdesign.report import preview

    assert not hasattr(preview, "_given") and not hasattr(columns, "_number")
    read = columns.cell_number
    assert (read("2.5e-05"), read(3), read(None), read(math.nan), read("x")) == (
        2.5e-05,
        3.0,
        None,
        None,
        None,
    )
    row = {"porosity": "0.8", "porosity_error": math.nan, "n_fibers": "many"}
    assert preview.preview_title(row) == "porosity 0.8000 [unrated]"


def test_the_diffusivity_figure_is_drawn_once_with_every_label_inside(monkeypatch):
    """Session 48 review: the report's diffusivity figure was still saved with
    ``bbox_inches="tight"``, drawn twice, beside the K and convergence figures drawn once at
    fixed margins. It now goes through the same encoder (``report.png.figure_png``). Truth:
    matplotlib's own extent of every artist of the axes (tick labels, axis labels, legend)
    lies inside the saved picture, and ``Figure.draw`` ran once."""
    import matplotlib.figure
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from psdesign.report.transport import transport_figure

    draws = []
    real_draw = matplotlib.figure.Figure.draw
    monkeypatch.setattr(
        matplotlib.figure.Figure, "draw", lambda self, r: (draws.append(self), real_draw(self, r))
    )
    eps = np.array([0.62, 0.75, 0.9])
    status = ["ok", "untrustworthy", "ok"]  # an open marker and its legend entry too
    df = pd.DataFrame(
        {
            "case_id": ["c0", "c1", "c2"],
            "status": "ok",
            "porosity": eps,
            "porosity_error": 4e-4,
            "diffusivity_z": eps**1.5,
            "diffusivity_z_rel_error": 0.03,
            "diffusivity_z_status": status,
            "diffusivity_x": eps**1.4,
            "diffusivity_x_rel_error": 0.03,
            "diffusivity_x_status": "ok",
        }
    )
    png, _ = transport_figure(df)
    assert png and len(set(draws)) == 1 and len(draws) == 1, len(draws)
    fig = draws[0]
    renderer = FigureCanvasAgg(fig).get_renderer()  # pyplot's was closed
    box = fig.axes[0].get_tightbbox(renderer)
    assert box.x0 >= 0 and box.y0 >= 0 and box.x1 <= fig.bbox.width, box
    assert box.y1 <= fig.bbox.height, (box, fig.bbox)


def test_unit_selector_converts_only_k_columns_and_names_its_unit(tmp_path):
    """Review s52 (walk-report 1): every column ending in ``_m2`` was marked for the unit
    selector, so the main effects' "mean log10 k_z_m2" (-11.33) became -1.148e+13 in darcy,
    and no header followed the selector. Truth: the converted cells are exactly the K values
    in m² of results.csv (a value times a unit factor is only meaningful for a K), each such
    column's header holds the ``psd-kunit`` span report.js rewrites, and a table whose K stays
    in m² says so."""
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    run_study(p, tmp_path / "out", workers=0, case_fn=fake_case, progress=False)
    page = (tmp_path / "out" / "report.html").read_text()
    df = pd.read_csv(tmp_path / "out" / "results.csv")
    marked = sorted(float(v) for v in re.findall(r'<td data-m2="([^"]+)"', page))
    truth = sorted(float(v) for c in ("k_x_m2", "k_z_m2") for v in df[c].dropna())
    assert marked == pytest.approx(truth, rel=1e-15)
    me = re.search(r"Main effects \(mean response per level\)</h3>(.*?)</table>", page, re.S)
    assert me is not None and "mean log10 k_z_m2" in me.group(1)
    assert "data-m2" not in me.group(1)
    for d in "xz":  # the Results table's K headers follow the selector
        assert f'k_{d} (<span class="psd-kunit">m²</span>)</th>' in page
    # the glance and main-effects tables (fake_case has no K table) stay in m² and say so
    glance = page.split('id="psd-glance"', 1)[1].split("</table>", 1)
    assert 'class="note psd-stays-m2"' in glance[0]
    assert page.split(me.group(0), 1)[1].startswith('</div><p class="note psd-stays-m2">')


def test_main_effects_count_the_values_behind_each_mean():
    """Review s52 (walk-report 5): tiny2's main effects showed porosity 0.8: n = 2 beside a
    mean log10 K of one value (the other K untrustworthy; summary.csv's k_z_m2_n said 1).
    Truth by hand: at a = 1 two cases, one with its K not trusted (NaN after ``trusted``):
    the mean log10 K is log10(2e-12) from 1 value, the mean porosity (0.5 + 0.7) / 2 from 2."""
    df = pd.DataFrame(
        {
            "a": [1.0, 1.0, 2.0, 2.0],
            "porosity": [0.5, 0.7, 0.6, 0.8],
            "k_z_m2": [2e-12, np.nan, 3e-12, 5e-12],
            "status": "ok",
        }
    )
    row = main_effects(df, ["a"]).set_index("level").loc["1.0"]
    assert row["mean log10 k_z_m2"] == pytest.approx(np.log10(2e-12), abs=1e-12)
    assert row["n log10 k_z_m2"] == 1
    assert row["mean porosity"] == pytest.approx(0.6, abs=1e-12) and row["n porosity"] == 2


def test_main_effects_plot_each_parameter_over_its_levels_in_its_unit(monkeypatch):
    """Review s52 (walk-report 5): the main-effects figure put every parameter on one axis of
    level ranks 0..1 ("level (low -> high)"), so no level could be read. Truth: each trace's
    x are its parameter's levels (here 0.7/0.8/0.9 and 6/8 um) on a panel whose axis names
    the parameter with its unit; y is the hand mean of log10 K per level."""
    from psdesign.report import decision

    a, b = np.repeat([0.7, 0.8, 0.9], 2), np.tile([6e-6, 8e-6], 3)
    k = 1e-12 * 10 ** (3 * a) * (b / 6e-6)
    df = pd.DataFrame({"generator.porosity": a, "generator.diameter": b, "k_z_m2": k})
    df["status"], df["seed"], df["case_id"] = "ok", 1, [f"c{i}" for i in range(6)]
    figs = []
    real = decision.figure_html
    monkeypatch.setattr(
        decision, "figure_html", lambda fig, *x, **kw: (figs.append(fig), real(fig, *x, **kw))[1]
    )
    decision.effect_plots(df, ["generator.porosity", "generator.diameter"])
    fig = figs[0]
    by = {t.name: t for t in fig.data}
    eps, dia = by["generator.porosity: k_z_m2"], by["generator.diameter: k_z_m2"]
    assert list(eps.x) == [0.7, 0.8, 0.9] and list(dia.x) == [6e-6, 8e-6]
    want = np.mean(np.log10(k[a == 0.8]))
    assert eps.y[1] == pytest.approx(want, abs=1e-12)
    assert fig.layout[eps.xaxis.replace("x", "xaxis")].title.text == "generator.porosity (-)"
    assert fig.layout[dia.xaxis.replace("x", "xaxis")].title.text == "generator.diameter (m)"


def test_the_1d_surrogate_axis_keeps_its_name_in_every_unit():
    """Review s52 (walk-report 1): in darcy the surrogate plot's axis read "k_z_m2 (darcy)"
    (a column name in m² beside another unit); it is "K (m²)" and the selector rewrites the
    unit alone: the label report.js puts before the unit is the axis title's "K"."""
    import json

    from psdesign.report.decision import surrogate_plots

    eps = np.repeat([0.7, 0.75, 0.8, 0.85, 0.9], 2)
    df = pd.DataFrame({"generator.porosity": eps, "k_z_m2": 2 * kc_truth(eps, 7e-6)})
    df["status"], df["seed"] = "ok", np.tile([1, 2], 5)
    df["case_id"] = [f"c{i}" for i in range(10)]
    text = surrogate_plots(df, ["generator.porosity"], {})
    push = r"window\.PSD_KFIGS = window\.PSD_KFIGS \|\| \[\]\)\.push\((.*?)\);</script>"
    reg = re.search(push, text)
    assert reg is not None and json.loads(reg.group(1))["label"] == "K"


def test_the_stays_in_m2_note_is_for_k_columns_only():
    """Review F (session 52): the "stays in m²" note went under any table with a column name
    holding ``_m2`` (a varied ``transport.bulk_diffusivity_m2_s``), so the Results table, whose
    K converts, said it stays in m². The note is for a K column that does not convert."""
    from psdesign.report.html import _table

    k = {"case_id": ["a"], "k_z_m2": [1e-11]}
    assert "psd-stays-m2" not in _table(pd.DataFrame(k | {"t.bulk_diffusivity_m2_s": [3e-9]}))
    assert "psd-stays-m2" in _table(pd.DataFrame({"case_id": ["a"], "mean log10 k_z_m2": [-11]}))


def test_a_main_effects_figure_of_eighteen_parameters_is_drawn():
    """Review F (session 52): one panel per parameter at a fixed 0.06 spacing; plotly refuses
    a spacing above 1 / (cols - 1), so 18 varied parameters lost the section."""
    from psdesign.report.decision import _main_effects_figure

    rng = np.random.default_rng(0)
    num = [f"p{i}" for i in range(18)]
    ok = pd.DataFrame(rng.uniform(1, 2, (6, 18)), columns=num)
    y = pd.DataFrame({"k_z_m2": rng.uniform(-12, -11, 6)})
    fig = _main_effects_figure(ok, y, ["k_z_m2"], num, set())
    assert len(fig.data) == 18


def test_a_damaged_study_json_is_one_line_for_the_optimize_outcome_too(tmp_path):
    """Review F (session 52): ``{"cases": 5}`` reached the optimize outcome's stale check
    (``report.outcome.stale_reason``) before the incomplete-study check, a TypeError
    traceback; every reader of the case list goes through ``readback.design_cases``."""
    from psdesign.report.outcome import stale_reason

    (tmp_path / "study.json").write_text('{"cases": 5}')
    with pytest.raises(ValueError, match="cases is a int, not a list"):
        stale_reason(tmp_path, {"n_points": 2, "best": {"case_id": "c0"}})
