"""A study folder holding another study's results is refused, the same study edited resumes.

Truth: the walkthrough of session 42 (benchmarks/RESULTS.md, "a new user's walkthrough"):
``study run`` of ``gdl80`` into the folder of ``quickstart`` replaced quickstart's
results.csv, summary, study.json and report.html with gdl80's, exit 0.
"""

from __future__ import annotations

from study_cases import FAC_PARAMS, FACTORIAL, fake_case, write_study

from psdesign.cli.main import main
from psdesign.study import run_study

KW = {"workers": 0, "case_fn": fake_case, "progress": False, "report": False}
OTHER_BASE = ("porosity = 0.8\n", "porosity = 0.75\n")


def _files(out) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def test_another_study_s_folder_is_refused_in_one_line_and_left_as_it_was(tmp_path, capsys):
    a = write_study(tmp_path, FACTORIAL, FAC_PARAMS, name="a.toml")
    out = tmp_path / "out"
    run_study(a, out, **KW)
    before = _files(out)
    b = write_study(tmp_path, FACTORIAL.replace('"fac"', '"gdl80"'), FAC_PARAMS, name="b.toml")
    b.write_text(b.read_text().replace(*OTHER_BASE))
    code = main(["study", "run", str(b), "-o", str(out), "--case-fn", "study_cases:fake_case"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].count("-o") >= 2
    assert "holds the results of study 'fac'" in err[0] and 'name = "fac"' in err[0]
    assert _files(out) == before  # nothing replaced, nothing added


def test_the_python_api_names_out_dir(tmp_path):
    import pytest

    from psdesign import SpecError

    a = write_study(tmp_path, FACTORIAL, FAC_PARAMS, name="a.toml")
    run_study(a, tmp_path / "out", **KW)
    b = write_study(tmp_path, FACTORIAL.replace('"fac"', '"other"'), FAC_PARAMS, name="b.toml")
    b.write_text(b.read_text().replace(*OTHER_BASE))
    with pytest.raises(SpecError, match=r"^out_dir: .* holds the results of study 'fac'"):
        run_study(b, tmp_path / "out", out_option=("out_dir", "force=True"), **KW)


def test_the_same_study_renamed_or_edited_still_resumes(tmp_path):
    """A renamed file without ``name`` (the name is the file's stem), more levels and seeds,
    an edited base under the same name: each resumes the folder (the documented workflows)."""
    study = FACTORIAL.replace('name = "fac"\n', "")
    a = write_study(tmp_path, study, FAC_PARAMS, name="a.toml")
    out = tmp_path / "out"
    n0 = len(run_study(a, out, **KW))
    renamed = write_study(tmp_path, study, FAC_PARAMS, name="renamed.toml")
    assert len(run_study(renamed, out, **KW)) == n0
    more = write_study(
        tmp_path, study.replace("[1, 2]", "[1, 2, 3]"), FAC_PARAMS, name="renamed.toml"
    )
    assert len(run_study(more, out, **KW)) == n0 * 3 // 2
    edited = write_study(tmp_path, study, FAC_PARAMS, name="renamed.toml")
    edited.write_text(edited.read_text().replace(*OTHER_BASE))
    assert len(run_study(edited, out, **KW)) == n0


def test_renamed_and_rebased_in_one_edit_is_refused_and_its_advice_resumes(tmp_path, capsys):
    """Session 43's decision (benchmarks/RESULTS.md): a study renamed and re-based in one edit
    cannot be told from another study, so the folder stays refused; the one line says both
    ways on (another -o, or keep the stored name), and the second one resumes the folder."""
    a = write_study(tmp_path, FACTORIAL, FAC_PARAMS, name="a.toml")
    out = tmp_path / "out"
    n0 = len(run_study(a, out, **KW))
    b = write_study(tmp_path, FACTORIAL.replace('"fac"', '"fac2"'), FAC_PARAMS, name="a.toml")
    b.write_text(b.read_text().replace(*OTHER_BASE))
    code = main(["study", "run", str(b), "-o", str(out), "--case-fn", "study_cases:fake_case"])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "give another -o folder" in line
    assert line.endswith('keep its name: name = "fac" in [study]'), line
    b.write_text(b.read_text().replace('"fac2"', '"fac"'))  # the line's advice
    assert len(run_study(b, out, **KW)) == n0
