"""Tests of the study report and its reference permeability models."""

from __future__ import annotations

import base64
import re

import numpy as np
import pandas as pd
import pytest
from study_cases import FAC_PARAMS, FACTORIAL, failing_case, write_study

from psdesign.report import (
    ReportError,
    kozeny_carman,
    tomadakis_sotirchos,
    write_report,
)
from psdesign.report.sensitivity import main_effects, sensitivity_table
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
    assert row["n"] == 3
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
    # figures decode as PNG; the fake previews are embedded (paged: data-src)
    uris = re.findall(r'src="data:image/png;base64,([^"]+)"', markup)
    assert len(uris) >= 3
    assert all(base64.b64decode(u)[:8] == b"\x89PNG\r\n\x1a\n" for u in uris)
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
