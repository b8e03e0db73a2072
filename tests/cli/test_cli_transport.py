"""``psdesign diffusivity | conductivity | pores`` and the transport study outputs."""

from __future__ import annotations

import json
import re
from types import SimpleNamespace

import numpy as np
import pytest
from cylinder_spec import CYLINDER_SPEC as SPEC

from psdesign.cli.main import main


@pytest.fixture()
def spec(tmp_path):
    p = tmp_path / "spec.toml"
    p.write_text(SPEC)
    return p


def test_diffusivity_json_along_and_across_a_cylinder(spec, capsys):
    assert main(["diffusivity", str(spec), "--direction", "all", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    eps = out["porosity"]
    assert out["relative_diffusivity"]["z"] == pytest.approx(eps, rel=1e-6)  # straight pore
    assert 0 < out["relative_diffusivity"]["x"] < eps
    assert out["tortuosity_factor"]["z"] == pytest.approx(1.0, rel=1e-6)
    assert out["converged"] is True


def test_conductivity_json_and_bad_value(spec, capsys):
    args = ["conductivity", str(spec), "--direction", "z", "--solid", "10", "--fluid", "1"]
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    fs = out["solid_fraction"]
    assert out["effective_conductivity"] == pytest.approx(10 * fs + (1 - fs), rel=1e-6)  # parallel
    assert main(["conductivity", str(spec), "--solid", "0"]) == 2
    err = capsys.readouterr().err  # the CLI's way to a zero phase, not the spec key (session 31)
    assert "--solid" in err and "use --insulating for 0" in err


def test_conductivity_names_its_unit(spec, capsys):
    """The effective conductivity is in the unit of the phase conductivities: the JSON, the
    text line and the notebook table say which (rule: SI units named in every output)."""
    from psdesign.transport.conductivity import effective_conductivity
    from psdesign.transport.load import load_case

    assert main(["conductivity", str(spec), "--direction", "all", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["conductivity_unit"] == "W/(m K)"  # the thermal defaults (fibre 120, air 0.026)
    assert {r["conductivity_unit"] for r in out["results"]} == {"W/(m K)"}
    # --direction all: the tensor, its symmetric part and eigenvalues, as docs/transport.md says
    # and diffusivity gives (conductivity gave the tensor alone until session 53); along the
    # cylinder (z) the parallel mean of the phases, an eigenvalue of the diagonal tensor
    sym = np.array(out["symmetric"])
    np.testing.assert_allclose(sym, 0.5 * (np.array(out["tensor"]) + np.array(out["tensor"]).T))
    fs = out["results"][2]["solid_fraction"]
    assert sym[2, 2] == pytest.approx(120 * fs + 0.026 * (1 - fs), rel=1e-6)
    np.testing.assert_allclose(out["eigenvalues"], np.sort(np.diag(sym)), rtol=1e-6)
    assert main(["conductivity", str(spec), "--solid", "1e4", "--fluid", "1", "--unit", "S/m"]) == 0
    line = capsys.readouterr().out
    assert line.startswith("sigma_eff_z = ") and " S/m +- " in line
    assert "(solid 10000, fluid 1 S/m)" in line
    with pytest.raises(SystemExit) as bad:  # argparse: one usage line, exit 2
        main(["conductivity", str(spec), "--unit", "K"])
    assert bad.value.code == 2
    case = load_case(str(spec), {})
    res = effective_conductivity(case.fields, "z", 10.0, 1.0, {"conductivity_unit": "S/m"})
    assert res.conductivity_unit == "S/m" and "effective conductivity (S/m)" in res._repr_html_()


def test_bad_transport_key_exits_2(tmp_path, capsys):
    p = tmp_path / "bad.toml"
    p.write_text(SPEC.replace('error_estimate = "residual"', "fluid_conductivity = -1"))
    assert main(["diffusivity", str(p)]) == 2
    assert "transport.fluid_conductivity" in capsys.readouterr().err


def test_pores_json(spec, capsys):
    assert main(["pores", str(spec), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("pore_d10_m", "pore_d50_m", "pore_d90_m", "specific_surface_m-1"):
        assert out[key] > 0
    # a cylinder of diameter 8 um in a 20 um periodic cell: S_v = pi d L / L^3
    assert out["specific_surface_m-1"] == pytest.approx(3.14159265 * 8e-6 / (20e-6) ** 2, rel=0.02)
    assert out["orientation_tensor"]["tensor"][2][2] == pytest.approx(1.0)


def test_study_outputs_row(spec):
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec
    from psdesign.transport.study_outputs import transport_outputs

    s = load_spec(spec)
    built = build_rve(s)
    fields = built.voxelize(s["rve"]["voxel"])
    row = transport_outputs(
        built.rve,
        fields,
        ["diffusivity_z", "tortuosity_x", "conductivity_z", "pore_d50_m", "specific_surface_m-1"],
        s,
    )
    assert row["diffusivity_z"] == pytest.approx(fields.porosity, rel=1e-6)
    assert row["tortuosity_x"] > 1.0
    assert row["conductivity_z"] > 0 and row["pore_d50_m"] > 0
    assert row["specific_surface_m-1"] > 0


def test_study_file_accepts_transport_outputs_and_run_case_fills_them(tmp_path):
    import tomllib

    from psdesign.study.case import run_case
    from psdesign.study.studyfile import parse_study

    base = tomllib.loads(SPEC)
    study = parse_study(
        {
            "base": base,
            "study": {
                "name": "t",
                "design": "full-factorial",
                "seeds": [1],
                "outputs": ["porosity", "diffusivity_z", "tortuosity_x", "specific_surface_m-1"],
                "solver": "voxel",
            },
            "parameters": {"transport.fluid_conductivity": [0.026, 0.05]},
        }
    )
    assert "diffusivity_z" in study.outputs
    row = run_case(base, study.outputs, "voxel", tmp_path)
    assert row["diffusivity_z"] == pytest.approx(row["porosity"], rel=1e-6)
    assert row["tortuosity_x"] > 1.0 and row["specific_surface_m-1"] > 0


def test_the_conductivitys_unit_is_a_column_of_results_and_summary(tmp_path, capsys):
    """walk-cli finding 4 (session 52): ``conductivity_z`` in results.csv / summary.csv named no
    unit, and ``transport.conductivity_unit`` may be W/(m K) or S/m (SI rule: units named).
    Each row now says it in ``conductivity_unit``; the value is the closed form of a straight
    cylinder along z, the parallel mean sigma_s f_s + sigma_f (1 - f_s), and the report,
    which reads the columns by their old names, still exits 0."""
    from psdesign.study import run_study

    base = SPEC.replace("[transport]", '[transport]\nconductivity_unit = "S/m"')
    base = re.sub(r"^\[(\[?)", r"[\1base.", base, flags=re.M)  # [rve] -> [base.rve]
    study = tmp_path / "st.toml"
    study.write_text(
        base + '\n[study]\nname = "u"\ndesign = "full-factorial"\nseeds = [1, 2]\n'
        'outputs = ["conductivity_z"]\nsolver = "voxel"\n'
        '[parameters]\n"transport.solid_conductivity" = [10.0, 20.0]\n'
    )
    out = tmp_path / "out"
    run_study(study, out, workers=0, progress=False)
    import pandas as pd

    res = pd.read_csv(out / "results.csv")
    assert list(res["conductivity_unit"]) == ["S/m"] * 4
    fs = 1 - res["porosity"]
    truth = res["transport.solid_conductivity"] * fs + 0.026 * (1 - fs)
    np.testing.assert_allclose(res["conductivity_z"], truth, rtol=1e-6)
    summ = pd.read_csv(out / "summary.csv")
    assert list(summ["conductivity_unit"]) == ["S/m", "S/m"]
    capsys.readouterr()
    assert main(["study", "report", str(out)]) == 0
    assert "conductivity_z (S/m)" in (out / "report.html").read_text()


def test_under_resolved_transport_values_are_untrustworthy(tmp_path, capsys):
    """Product rule: a value that is not trustworthy says so in its status. The permeability's
    rule (:func:`psdesign.flow.error.status_of`: fewer than 8 cells across the thinnest fiber
    or an error bar above 20 %) applies to D_eff/D and sigma_eff too; session 22 found the
    transport results rated only blocked / not_converged. The cylinder at 2 um voxels has 4
    voxels across its 8 um diameter; at 1 um it has 8, the threshold (ok). Exit status
    (psdesign/cli/exit_status.py, session 45): 3 for the untrustworthy values, written and
    complete (it was 0: a script took them), 0 for the ok one; fails on main's files."""
    coarse = tmp_path / "coarse.toml"
    coarse.write_text(SPEC.replace("voxel = 1e-6", "voxel = 2e-6"))
    assert main(["diffusivity", str(coarse), "--direction", "x", "--json"]) == 3
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert out["status"] == "untrustworthy" and out["cells_per_diameter"] == pytest.approx(4.0)
    line = "D_eff/D_x: only 4.0 voxels across the thinnest fiber diameter (< 8); refine rve.voxel"
    assert out["warnings"][0] == line and f"psdesign: warning: {line}" in cap.err
    assert out["rel_error"] > 0.2 and out["warnings"][1].endswith("exceeds 20 %")
    assert main(["conductivity", str(coarse), "--direction", "all"]) == 3  # converged, not ok
    cap = capsys.readouterr()
    assert cap.out.count("[untrustworthy]") == 3 and cap.err.count("sigma_eff_") == 3
    fine = tmp_path / "fine.toml"
    fine.write_text(SPEC)
    assert main(["diffusivity", str(fine), "--direction", "x", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["cells_per_diameter"] == pytest.approx(8.0)
    assert (out["status"], out["warnings"]) == ("ok", []) and out["rel_error"] < 0.2


def test_pores_carry_a_status_and_warnings(tmp_path, capsys):
    """docs/transport.md: every value carries ``[status]``, each reason a line in ``warnings``
    and on stderr. The session-31 audit found ``pores`` printing neither (a 5-voxel fiber and a
    26 % bar, rc 0, no word). The cylinder at 2 um voxels: 4 voxels across its 8 um diameter,
    so both the pore sizes and S_v are untrustworthy; at 1 um (8 across) they are rated by their
    bars alone. Exit 3 for the untrustworthy scan (0 until session 45: the exit rule, fails on
    main's pores.py), 0 at 1 um where both are ok."""
    coarse = tmp_path / "coarse.toml"
    coarse.write_text(SPEC.replace("voxel = 1e-6", "voxel = 2e-6"))
    assert main(["pores", str(coarse), "--json"]) == 3
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert out["status"] == out["pore_sizes_status"] == "untrustworthy"
    assert out["specific_surface_status"] == "untrustworthy"
    line = "pore sizes and S_v: only 4.0 voxels across the thinnest fiber diameter (< 8); "
    assert out["warnings"][0].startswith(line) and f"psdesign: warning: {line}" in cap.err
    assert main(["pores", str(coarse)]) == 3
    assert capsys.readouterr().out.count("[untrustworthy]") == 2
    fine = tmp_path / "fine.toml"
    fine.write_text(SPEC)
    assert main(["pores", str(fine), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    bars = {"pore_sizes_status": out["rel_error"], "specific_surface_status": None}
    bars["specific_surface_status"] = out["specific_surface_rel_error"]
    for key, bar in bars.items():
        assert out[key] == ("ok" if bar <= 0.2 else "untrustworthy")
    assert not any("voxels across" in w for w in out["warnings"])


def test_rating_flags_a_large_bar_and_no_convergence():
    from psdesign.transport.effective import rating

    status, warnings = rating("sigma_eff", "y", False, True, 0.25, 12.0)
    assert status == "untrustworthy" and warnings == [
        "sigma_eff_y: estimated error 25.0 % exceeds 20 %"
    ]
    status, warnings = rating("D_eff/D", "z", False, False, 0.01, None)
    assert status == "not_converged" and warnings == ["D_eff/D_z: solver did not converge"]
    # blocked wins; on an analytic RVE (a fiber diameter) the block may be the grid's: said
    status, warnings = rating("D_eff/D", "z", True, False, float("nan"), 3.0)
    assert status == "blocked" and len(warnings) == 1 and "refine rve.voxel" in warnings[0]
    assert rating("D_eff/D", "z", True, True, 0.0, None) == ("blocked", [])  # an image: exact
    assert rating("D_eff/D", "z", False, True, float("nan"), None)[0] == "untrustworthy"


def test_trusted_masks_untrustworthy_transport_values():
    """Summaries, fits and the optimizer leave out a transport value whose own status is not
    ok, as they do for K (``psdesign.analysis.columns.trusted``)."""
    import pandas as pd

    from psdesign.analysis.columns import trusted
    from psdesign.cli.exit_status import case_counts

    df = pd.DataFrame(
        {
            "status": ["ok", "ok"],
            "diffusivity_z": [0.5, 0.6],
            "tortuosity_z": [1.6, 1.5],
            "diffusivity_z_status": ["ok", "untrustworthy"],
            "conductivity_x": [2.0, 3.0],
            "conductivity_x_status": ["untrustworthy", "ok"],
        }
    )
    t = trusted(df)
    assert t["diffusivity_z"].tolist()[0] == 0.5 and pd.isna(t["diffusivity_z"].iloc[1])
    assert pd.isna(t["tortuosity_z"].iloc[1]) and pd.isna(t["conductivity_x"].iloc[0])
    assert case_counts(df).flagged == 2  # two ok cases, each with one value not ok: exit 3


# The session-31 audit: the transport lines printed `rel. error 1.0e-01  [ok]` but not the
# convergence flag the permeability lines carry (`K_z = ... m^2 +- e %  [status]  bc B
# converged true|false`; rule: every printed number carries its convergence flag).
LINE = re.compile(r" \+- (\d+\.\d) %  \[(\w+)\]  bc (\w+)  converged (true|false)  ")


@pytest.mark.parametrize("command", ["diffusivity", "conductivity"])
def test_transport_lines_carry_bar_status_and_converged(spec, tmp_path, capsys, command):
    assert main([command, str(spec), "--direction", "all", "--json", "--quiet"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert js["converged"] is True and [r["converged"] for r in js["results"]] == [True] * 3
    assert main([command, str(spec), "--direction", "all", "--quiet"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3
    for line, r in zip(lines, js["results"], strict=True):
        bar, status, bc, conv = LINE.search(line).groups()
        assert (bar, status, bc, conv) == (f"{100 * r['rel_error']:.1f}", "ok", "periodic", "true")
    # D_z of the straight pore is the porosity, sigma_z the parallel mean (closed forms)
    eps = js["porosity"]
    z = f"{eps:.4f}" if command == "diffusivity" else f"{120 * (1 - eps) + 0.026 * eps:.5g}"
    assert lines[2].split(" = ")[1].startswith(z + " ")
    # the porosity they share, with its error estimate (psdesign.geometry.porosity)
    assert 0 < js["porosity_error"] < 0.01
    if command == "diffusivity":
        assert lines[0].endswith(f"porosity {eps:.4f} +- {js['porosity_error']:.1e}")
        # the tortuosity factor (porosity / D, a count over D) with D's relative bar
        r = js["results"][0]
        tau = f"tortuosity factor {r['tortuosity_factor']:.4f} +- {100 * r['rel_error']:.1f} %"
        assert tau in lines[0]
    # a solve stopped after one CG iteration: `converged false`, status not_converged, exit 3
    stopped = tmp_path / "stopped.toml"
    stopped.write_text(SPEC.replace("[transport]", "[transport]\nmax_iter = 1"))
    assert main([command, str(stopped), "--direction", "x", "--json", "--quiet"]) == 3
    js = json.loads(capsys.readouterr().out)
    assert js["converged"] is False and js["status"] == "not_converged"
    assert main([command, str(stopped), "--direction", "x", "--quiet"]) == 3
    line = capsys.readouterr().out
    assert LINE.search(line).groups()[1:] == ("not_converged", "periodic", "false")


def _outside_wiener(monkeypatch, module, factor):
    """``module.solve_effective`` returning ``factor`` times the upper Wiener bound of the
    cylinder cell (pores at 1, fibre at the solid's value) with a 5 % bar."""
    import psdesign.transport.effective as effective

    real = effective.solve_effective

    def fake(sigma_of, fields, *args, **kwargs):
        eff = real(sigma_of, fields, *args, **kwargs)
        ks, kf = (float(v) for v in sigma_of(np.array([True, False])))
        eps = fields.porosity
        eff.value, eff.rel_error = factor * (eps * kf + (1 - eps) * ks), 0.05
        return eff

    monkeypatch.setattr(module, "solve_effective", fake)


def test_a_value_outside_the_wiener_bounds_is_untrustworthy(spec, monkeypatch, capsys):
    """The Wiener bounds (series / parallel means) bind any direction of any medium: a value
    beyond them by more than its bar is a wrong answer, rated ``untrustworthy`` with a warning
    (it was ``ok``). Within its bar of a bound it stays ``ok``."""
    import psdesign.transport.conductivity as conductivity
    import psdesign.transport.diffusivity as diffusivity

    _outside_wiener(monkeypatch, conductivity, 1.3)  # 30 % above, bar 5 %: written, exit 3
    assert main(["conductivity", str(spec), "--solid", "10", "--fluid", "1", "--json"]) == 3
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    lo, hi = out["wiener_bounds"]
    assert hi == pytest.approx(10 * out["solid_fraction"] + out["porosity"], rel=1e-12)
    assert out["effective_conductivity"] == pytest.approx(1.3 * hi)
    assert out["status"] == "untrustworthy" and "outside the Wiener bounds" in out["warnings"][0]
    assert "psdesign: warning: sigma_eff_z: " in cap.err
    _outside_wiener(monkeypatch, diffusivity, 1.3)  # D_eff/D above the porosity
    assert main(["diffusivity", str(spec), "--quiet"]) == 3
    assert "[untrustworthy]" in capsys.readouterr().out
    _outside_wiener(monkeypatch, conductivity, 1.04)  # 4 % above, within the 5 % bar
    assert main(["conductivity", str(spec), "--solid", "10", "--fluid", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["status"], out["warnings"]) == ("ok", [])


def test_a_real_value_below_hashin_shtrikman_but_inside_wiener_is_ok(spec, capsys):
    """Across the cylinder (air 0.026, fibre 120 W/(m K)) the value is below the isotropic 3-D
    Hashin-Shtrikman lower bound, which does not bind this anisotropic cell, and inside the
    Wiener bounds (computed here from the porosity): ``ok``, no warning. The HS bounds are
    labelled isotropic-only where they are shown."""
    from psdesign.transport.conductivity import effective_conductivity
    from psdesign.transport.load import load_case

    case = load_case(str(spec), {})
    r = effective_conductivity(case.fields, "x", cells_per_diameter=case.cells_per_diameter)
    eps, ks, kf = case.fields.porosity, 120.0, 0.026
    lo, hi = 1 / (eps / kf + (1 - eps) / ks), eps * kf + (1 - eps) * ks
    assert r.wiener_bounds == pytest.approx([lo, hi], rel=1e-12)
    assert lo < r.effective_conductivity < r.hashin_shtrikman_bounds[0]
    assert (r.status, r.warnings) == ("ok", [])
    assert "Hashin-Shtrikman bounds, isotropic media only" in r._repr_html_()


def _closed_square_array(tmp_path):
    """A square array across at solid fraction 0.75 in a 20 um box: a gap L - D = 0.46 um
    (the closed form: a path), closed on 0.5 um voxels (the spec's path)."""
    l, phi = 20e-6, 0.75
    d = float(2 * l * np.sqrt(phi / np.pi))
    assert 0 < l - d < 0.5e-6
    path = tmp_path / "s.toml"
    path.write_text(
        f"[rve]\nsize = [{l!r}, {l!r}, {l!r}]\nvoxel = 5e-7\n[[fibers]]\n"
        f'shape = "cylinder"\ndiameter = {d!r}\ncenter = [1e-5, 1e-5, 1e-5]\n'
        "direction = [0, 0, 1]\n"
    )
    return path


def test_a_block_of_the_grid_on_an_analytic_rve_is_said(tmp_path, capsys):
    """Session 37 edge audit: a square array across at solid fraction 0.75 has a gap L - D =
    0.46 um per 20 um (the closed form: a path), closed on 0.5 um voxels. Its D_eff/D_x was
    0 +- 0 % [blocked] with no warning, as if the RVE had no path; an image's block is exact.
    Exit 3 (the rule: a status other than ok; 0 until session 45)."""
    path = _closed_square_array(tmp_path)
    assert main(["diffusivity", str(path), "--direction", "x", "--json", "--quiet"]) == 3
    res = json.loads(capsys.readouterr().out)
    assert res["blocked"] and res["relative_diffusivity"] == 0.0 and res["status"] == "blocked"
    assert len(res["warnings"]) == 1 and "refine rve.voxel" in res["warnings"][0]


def test_a_blocked_tortuosity_says_undefined_in_the_text_as_null_in_the_json(tmp_path, capsys):
    """Session 51: a blocked D_eff/D (0, no pore path across the closed square array above)
    has no tortuosity factor (porosity / 0): the JSON said ``null`` and the text line a bare
    ``tortuosity factor inf``. The text now says it in words with its status, as the JSON's
    ``null`` with ``status: blocked``; the notebook's table says the same words."""
    from psdesign.transport.diffusivity import relative_diffusivity
    from psdesign.transport.load import load_case

    path = _closed_square_array(tmp_path)
    assert main(["diffusivity", str(path), "--direction", "x", "--quiet", "--json"]) == 3
    res = json.loads(capsys.readouterr().out)
    assert (res["tortuosity_factor"], res["status"]) == (None, "blocked")
    assert main(["diffusivity", str(path), "--direction", "x", "--quiet"]) == 3
    line = capsys.readouterr().out
    assert "tortuosity factor undefined (no pore path along x) [blocked]" in line, line
    assert "inf" not in line
    case = load_case(path, {}, {})
    r = relative_diffusivity(case.fields, "x", dict(case.transport))
    assert "undefined (no pore path along x) [blocked]" in r._repr_html_()


def test_a_study_row_says_why_a_transport_value_is_not_ok(tmp_path):
    """A study row carried ``diffusivity_z_status = untrustworthy`` but not the reason the
    ``psdesign diffusivity`` command prints (K's rows carry theirs in ``warnings_z``). The
    cylinder at 2 um voxels has 4 voxels across its 8 um diameter (under 8): the row now says
    so, naming the key to refine; at 1 um the value is ok and has no warnings column."""
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec
    from psdesign.transport.study_outputs import transport_outputs

    coarse = tmp_path / "coarse.toml"
    coarse.write_text(SPEC.replace("voxel = 1e-6", "voxel = 2e-6"))
    for path, voxel in ((coarse, 2e-6), (tmp_path / "fine.toml", 1e-6)):
        if voxel == 1e-6:
            path.write_text(SPEC)
        s = load_spec(path)
        built = build_rve(s)
        row = transport_outputs(
            built.rve, built.voxelize(voxel), ["diffusivity_z", "conductivity_z"], s
        )
        if voxel == 2e-6:
            assert row["diffusivity_z_status"] == "untrustworthy"
            assert row["diffusivity_z_warnings"].startswith(
                "D_eff/D_z: only 4.0 voxels across the thinnest fiber diameter (< 8); refine "
                "rve.voxel"
            )
            assert "rve.voxel" in row["conductivity_z_warnings"]
        else:
            assert row["diffusivity_z_status"] == "ok" and "diffusivity_z_warnings" not in row


def _refuse(token):
    raise ValueError(f"not JSON: {token}")


NAN_PATCHES = {  # the command's compute step -> a result with a NaN (numpy's, as the solvers')
    "permeability": (
        "psdesign.cli.permeability._solve",
        lambda *a, **k: {
            "direction": "z",
            "permeability_m2": 1e-12,
            "permeability_rel_error": np.float64("nan"),  # e.g. no error estimate
            "converged": True,
            "status": "ok",
            "warnings": [],
        },
    ),
    "diffusivity": (
        "psdesign.cli.diffusivity._solve",
        lambda *a, **k: ({"relative_diffusivity": {"x": float("nan")}, "converged": True}, []),
    ),
    "conductivity": (  # the directions' solve, which the command combines
        "psdesign.transport.conductivity.effective_conductivity",
        lambda *a, **k: SimpleNamespace(
            to_dict=lambda: {
                "direction": "z",
                "effective_conductivity": np.float64("nan"),
                "conductivity_unit": "W/(m K)",
                "blocked": False,
                "converged": True,
                "status": "ok",
            }
        ),
    ),
    "pores": (
        "psdesign.transport.study_outputs.pore_report",
        lambda *a, **k: {"mean_pore_diameter_m": float("nan"), "warnings": [], "status": "ok"},
    ),
}


@pytest.mark.parametrize("command", sorted(NAN_PATCHES))
def test_every_json_output_is_strict_json_with_a_nan(command, spec, monkeypatch, capsys):
    """Session 43 (s43-loop2): ``permeability``, ``pores`` and the Laplace commands printed
    ``--json`` with ``json.dumps(..., default=float)``: a value that does not exist (a NaN: no
    error estimate, a missing direction) came out as the ``NaN`` token, which JSON has not (RFC
    8259 Sec. 6; ``jq`` and JavaScript refuse the whole object). Rule (docs/study-files.md):
    strict JSON, a missing value is null, through the one printer ``cli/lines.print_json``."""
    target, fake = NAN_PATCHES[command]
    monkeypatch.setattr(target, fake)
    where = [] if command == "pores" else ["--direction", "z"]  # pores scans the whole RVE
    assert main([command, str(spec), *where, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out, parse_constant=_refuse)
    assert None in [v for v in doc.values() if not isinstance(v, dict)] + [
        x for v in doc.values() if isinstance(v, dict) for x in v.values()
    ]


def test_print_json_turns_numpys_nan_into_null(capsys):
    """``jsonable`` returned ``np.float64('nan').item()``, a NaN float, so the strict printer
    raised ValueError (a traceback) on the solvers' own NaN instead of printing null."""
    from psdesign.cli.lines import print_json

    print_json({"k": np.float64("nan"), "e": np.float32("inf"), "n": np.int64(3)})
    assert json.loads(capsys.readouterr().out, parse_constant=_refuse) == {
        "k": None,
        "e": "inf",
        "n": 3,
    }


def test_the_json_printers_print_strict_json(capsys):
    """Review (session 43): s43-loop made ``study fit / predict / sensitivity / optimize`` and
    ``rev`` print strict JSON through one printer (cli.lines.print_json), while
    ``permeability``, ``pores``, ``diffusivity`` and ``conductivity`` kept their own
    ``json.dumps(out, default=float)``, which prints a NaN (a value without an estimate) as
    Python's ``NaN`` token: no JSON, ``jq`` and JavaScript refuse the whole object. They print
    through the one printer now; a finite value prints as before."""
    from psdesign.cli.laplace_report import emit

    def refuse(token):
        raise ValueError(f"not JSON: {token}")

    out = {"converged": True, "rel_error": float("nan"), "value": 0.25, "warnings": []}
    assert emit("diffusivity", out, [], True, str) == 0
    assert json.loads(capsys.readouterr().out, parse_constant=refuse) == {
        "converged": True,
        "rel_error": None,
        "value": 0.25,
        "warnings": [],
    }


def test_a_conducting_solid_blocked_on_the_grid_is_told_about_contacts(spec, capsys):
    """``conductivity --insulating fluid`` along x of the one 8 um cylinder along z in a 20 um
    cell: the solid does not span x (closed form: 8 < 20 um, no contact), so sigma_eff_x = 0,
    blocked, exit 3. The warning said the grid 'closes any gap of the fibers' surface ... the
    RVE itself may have a path', the pore phase's words (session 45 audit); the solid conducts
    here, and the grid breaks contacts, it does not close gaps. Fails on main (the pore words).
    The pore phase's own block (diffusivity) keeps its words."""
    args = ["conductivity", str(spec), "--direction", "x", "--insulating", "fluid"]
    assert main([*args, "--solid", "10", "--json", "--quiet"]) == 3
    out = json.loads(capsys.readouterr().out)
    assert out["blocked"] and out["effective_conductivity"] == 0.0 and out["status"] == "blocked"
    assert len(out["warnings"]) == 1, out["warnings"]
    assert "breaks any contact between the fibers" in out["warnings"][0]
    assert "gap of the fibers' surface" not in out["warnings"][0]
    assert "refine rve.voxel" in out["warnings"][0]


def test_docs_transport_example_lines_are_the_commands_output(spec, capsys):
    """docs/transport.md shows a D_eff/D and a sigma_eff line "of the one-cylinder cell of
    tests/cylinder_spec.py"; a walkthrough (session 53) read +- 5.1 % / 6.9 % for them from the
    cell without its ``error_estimate = "residual"`` and took the page's 10.1 % for stale. Truth:
    the commands' own lines, here, must stand verbatim in the page's example block."""
    from conftest import REPO_ROOT

    doc = (REPO_ROOT / "docs" / "transport.md").read_text()
    block = re.search(r"```\n(D_eff/D_x = .*?)```", doc, flags=re.S).group(1).splitlines()
    lines = []
    for command in ("diffusivity", "conductivity"):
        assert main([command, str(spec), "--direction", "x"]) == 0
        lines += capsys.readouterr().out.splitlines()
    assert lines == block


def _walls_image_spec(tmp_path, name: str, solid: np.ndarray):
    """An image spec of ``solid`` (1 = solid) at 1 um voxels, written as NAME.npy / NAME.toml."""
    np.save(tmp_path / f"{name}.npy", solid)
    spec = tmp_path / f"{name}.toml"
    spec.write_text(f'[image]\npath = "{name}.npy"\nvoxel_size = 1e-6\nsolid_label = 1\n')
    return spec


def test_pores_without_a_path_across_prints_no_breakthrough_and_exits_3(tmp_path, capsys):
    """Walls (solid slab x in [0, 8) of 32 voxels, an image): along x no intrusion path
    crosses, so the breakthrough is JSON null, the sizes line says 'none (...: blocked)' and
    '[blocked]', and the exit status is 3 (as diffusivity across the walls). Session 53
    (walk-transport finding 1): '0.000e+00 m ... [ok]', exit 0."""
    solid = np.zeros((32, 8, 8), np.uint8)
    solid[:8] = 1
    spec = _walls_image_spec(tmp_path, "walls", solid)
    assert main(["pores", str(spec), "--axis", "x", "--json", "--quiet"]) == 3
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert out["breakthrough_diameter_m"] is None and out["breakthrough_status"] == "blocked"
    assert "breakthrough: no intrusion path along x" in cap.err
    assert main(["pores", str(spec), "--axis", "x", "--quiet"]) == 3
    sizes = capsys.readouterr().out.splitlines()[0]
    assert "breakthrough none (no intrusion path along x: blocked), each " in sizes
    assert "[blocked]  converged true" in sizes
    assert main(["pores", str(spec), "--axis", "y", "--quiet"]) == 0  # along the walls: ok


def test_pores_print_the_walled_breakthrough_with_its_own_lower_side(tmp_path, capsys):
    """Session 54 review (/tmp/rr-mendpores/bt.py): a sphere pore (radius 19 um) in a
    40x48x48 um image, reached along x by a staircase slot on the y = 0 face (z widths 12, 10,
    8, 6 um at y = 0..3 um), y not repeating. Walled at y = 0 the slot is 4 um high, so the
    walled breakthrough is at most 4 um (closed form: no ball wider than the slot's height);
    the open scan's breakthrough (6.7 um at the default 16 radii) lies further above it than
    d10-d90's shared lower side (their gap: 0 here, 3.0 um at 24 radii), so "breakthrough
    ..., each +4.1e-06/-0 m" was false of it. The line
    prints the breakthrough with its own lower side, bt - walled bt, and says the shared bar
    of d10-d90; the walled suffix prints the JSON's walled values."""
    from psdesign.transport.pores import diameter_bar_text

    x, y, z = np.meshgrid(*(np.arange(n) for n in (40, 48, 48)), indexing="ij")
    pore = (x - 20) ** 2 + (y - 24) ** 2 + (z - 24) ** 2 < 19**2
    for k, (a, b) in enumerate(((18, 30), (19, 29), (20, 28), (21, 27))):
        pore |= (y == k) & (z >= a) & (z < b)
    spec = _walls_image_spec(tmp_path, "slot", (~pore).astype(np.uint8))
    main(["pores", str(spec), "--axis", "x", "--json", "--quiet"])
    out = json.loads(capsys.readouterr().out)
    bt, low, err = (
        out[k]
        for k in ("breakthrough_diameter_m", "breakthrough_diameter_walled_m", "diameter_error_m")
    )
    below = out["diameter_error_below_m"]
    assert out["walled_axes"] == "y"
    assert low <= 4e-6 < bt - below, out  # the shared lower side does not reach the walled one
    main(["pores", str(spec), "--axis", "x", "--quiet"])
    sizes = capsys.readouterr().out.splitlines()[0]
    shared, own = diameter_bar_text(err, below), diameter_bar_text(err, bt - low)
    assert f"breakthrough {bt:.3e} m {own} m, d10-d90 each {shared} m  [" in sizes, sizes
    d10, d50, d90 = (f"{v:.3e}" for v in out["walled_d10_d50_d90_m"])
    walled = f"(walled at y: d10 {d10} m  d50 {d50} m  d90 {d90} m  breakthrough {low:.3e} m)"
    assert sizes.endswith(walled), sizes


def test_pores_through_a_hole_narrower_than_the_scan_prints_an_unresolved_breakthrough(
    tmp_path, capsys
):
    """The walls above pierced by a 2 x 2 voxel hole (session 53 review, hole.npy): a path
    crosses (D_eff/D 0.048 through it) but no scanned ball passes, so the breakthrough is null
    with ``pore_space_crosses`` true, the line says '< 2.000e-06 m (unresolved)' and
    '[untrustworthy]', the warning asks for finer voxels (exit 3). It said 'none (no intrusion
    path along x: blocked)', as if no path existed."""
    solid = np.zeros((32, 16, 16), np.uint8)
    solid[:8] = 1
    solid[:8, 7:9, 7:9] = 0
    spec = _walls_image_spec(tmp_path, "hole", solid)
    assert main(["pores", str(spec), "--axis", "x", "--json", "--quiet"]) == 3
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert out["breakthrough_diameter_m"] is None and out["pore_space_crosses"] is True
    assert out["breakthrough_status"] == "untrustworthy"
    assert "breakthrough: unresolved: the pore space crosses the sample along x" in cap.err
    assert "use a finer image" in cap.err
    assert main(["pores", str(spec), "--axis", "x", "--quiet"]) == 3
    sizes = capsys.readouterr().out.splitlines()[0]
    assert "breakthrough < 2.000e-06 m (unresolved), each " in sizes
    assert "[untrustworthy]  converged true" in sizes


def test_every_text_of_the_conductivity_range_is_the_schema_range(capsys):
    """The phase conductivities are accepted in [1e-300, 1e12) (schema.transport
    MIN_CONDUCTIVITY / MAX_CONDUCTIVITY, session 53); the flags' help, the keys' descriptions
    and the API docstrings say that range, not '> 0' (session 53 review: 1e-310 is > 0 and
    refused), and the refusal names it from the same constants."""
    from psdesign.schema.transport import (
        CONDUCTIVITY_RANGE,
        MAX_CONDUCTIVITY,
        MIN_CONDUCTIVITY,
        TransportSpec,
        check_conductivity,
    )
    from psdesign.transport.conductivity import effective_conductivity, transport_table

    assert CONDUCTIVITY_RANGE == "[1e-300, 1e12)"
    assert (MIN_CONDUCTIVITY, MAX_CONDUCTIVITY) == (1e-300, 1e12)
    with pytest.raises(SystemExit):
        main(["conductivity", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for flag in ("--solid SOLID", "--fluid FLUID"):
        assert f"{flag} " in text
        assert f"conductivity in --unit, in {CONDUCTIVITY_RANGE} (default" in text
        assert f"{flag.split()[0]} conductivity in --unit, > 0" not in text
    for key in ("solid_conductivity", "fluid_conductivity"):
        assert CONDUCTIVITY_RANGE in TransportSpec.model_fields[key].description
    for doc in (effective_conductivity.__doc__, transport_table.__doc__):
        assert "> 0" not in doc and "<= 0" not in doc and "[1e-300, 1e12)" in doc
    with pytest.raises(Exception, match=r"must be >= 1e-300 and < 1e12 \(use --insulating"):
        check_conductivity(1e12, "--solid")
    assert check_conductivity(MIN_CONDUCTIVITY, "--fluid") == 1e-300
