"""Command-line arguments argparse itself refuses (audit s45): the same one line as a bad spec
key, naming the option and what it takes.

Before session 45 a value that was not a number printed argparse's own line, without the
range (`psdesign: error: argument --n-radii: invalid int value: 'abc'`), while `--budget abc`
named its range; a mistyped option (`--sovler voxel`) printed "unrecognized arguments" with no
hint, where a mistyped spec key says "did you mean". Product rule: bad input exits 2 with ONE
line naming the key and the allowed range, before any work.
"""

from __future__ import annotations

import pytest

from psdesign.cli.main import main


def _refused(argv, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("psdesign: error: "), err
    return err


# every option parsed with a bare type=int / type=float, the range its help states
@pytest.mark.parametrize(
    "argv, head, allowed",
    [
        (
            ["pores", "s.toml", "--n-radii", "abc"],
            "--n-radii: must be an integer, got 'abc'",
            "4-200",
        ),
        (
            ["pores", "s.toml", "--n-radii", "2.5"],
            "--n-radii: must be an integer, got '2.5'",
            "4-200",
        ),
        (
            ["rev", "s.toml", "--sizes", "1e-4", "x", "-o", "o"],
            "--sizes: must be a number",
            "metres",
        ),
        (["rev", "s.toml", "--sizes", "1e-4", "--seeds", "two", "-o", "o"], "--seeds:", "2-1000"),
        (["rev", "s.toml", "--sizes", "1e-4", "--tol", "tenth", "-o", "o"], "--tol:", "(0, 0.2]"),
        (["conductivity", "s.toml", "--solid", "copper"], "--solid: must be a", "1e-300, 1e12)"),
        (["conductivity", "s.toml", "--fluid", "air"], "--fluid: must be a", "1e-300, 1e12)"),
        (["diffusivity", "s.toml", "--tol", "small"], "--tol: must be a number", "in (0, 1)"),
        (["warmup", "--jobs", "all"], "--jobs: must be an integer", "1-64"),
        (["study", "run", "s.toml", "-o", "o", "--workers", "many"], "--workers:", "0 to 64"),
    ],
)
def test_a_value_that_is_not_a_number_names_the_range(argv, head, allowed, capsys):
    err = _refused(argv, capsys)
    assert f"psdesign: error: {head}" in err
    assert "(allowed: " in err and allowed in err
    assert "invalid" not in err  # argparse's "invalid int value" line is gone


def test_the_workers_range_is_its_first_clause(capsys):
    # the help goes on about Dask schedulers; the line keeps the range only
    err = _refused(["rev", "s.toml", "--sizes", "1e-4", "--workers", "x", "-o", "o"], capsys)
    assert err.endswith(
        "(allowed: worker processes on this machine, 0 to 64 or 4 per CPU, whichever is more)"
    )


@pytest.mark.parametrize(
    "argv, hint, command",
    [
        (["permeability", "s.toml", "--sovler", "voxel"], "did you mean --solver?", "permeability"),
        (["permeability", "s.toml", "--dirction=x"], "did you mean --direction?", "permeability"),
        (
            ["generate", "s.toml", "-o", "o", "--no-preveiw"],
            "did you mean --no-preview?",
            "generate",
        ),
        (
            ["study", "run", "s.toml", "-o", "o", "--wrkers", "2", "--tiemout", "3"],
            "did you mean --workers or --timeout?",
            "study run",
        ),
    ],
)
def test_a_mistyped_option_names_the_closest(argv, hint, command, capsys):
    err = _refused(argv, capsys)
    assert "unrecognized arguments: " in err and hint in err
    assert f"(psdesign {command} --help lists the options)" in err


def test_a_stray_word_has_no_guess(capsys):
    err = _refused(["generate", "s.toml", "-o", "o", "extra"], capsys)
    assert err == (
        "psdesign: error: unrecognized arguments: extra "
        "(psdesign generate --help lists the options)"
    )


def _leaves(parser, prefix=""):
    import argparse

    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _leaves(sub, f"{prefix} {name}".strip())
            return
    yield prefix, parser


def test_quiet_reads_the_same_on_every_command():
    # audit s45: `study run` and `study optimize` said "no progress output", the other commands
    # "no progress lines on stderr" for the same switch (warmup prints messages, not progress)
    from psdesign.cli.main import build_parser

    helps = {
        name: a.help
        for name, p in _leaves(build_parser())
        for a in p._actions
        if "--quiet" in a.option_strings and name != "warmup"
    }
    assert {"study run", "study optimize", "generate", "rev"} <= set(helps)
    assert all(h.startswith("no progress lines on stderr") for h in helps.values()), helps


@pytest.mark.parametrize(
    ("argv", "why"),
    [
        (["study", "report"], "no results.csv in {d}; run the study first"),
        (["study", "fit"], "no study.json in {d}; is this a study output folder?"),
        (["study", "predict", "--at", "a=1"], "no surrogate.json in {d}; run `psdesign study fit`"),
        (["study", "sensitivity"], "no surrogate.json in {d}; run `psdesign study fit` first"),
    ],
)
def test_a_study_folder_is_named_as_help_shows_it(argv, why, tmp_path, capsys):
    """Session 49 note: ``study report nodir`` named ``out_dir`` (the Python parameter of
    ``write_report``), which the user never typed; ``fit``, ``predict`` and ``sensitivity``
    named the folder's path as the key. Each names the argument as its ``--help`` shows it,
    ``OUT`` (``study report`` writes OUT/report.html), and then the folder; exit 2, one line."""
    folder = tmp_path / "nodir"
    head = argv[:2]
    with pytest.raises(SystemExit):
        main([*head, "--help"])
    usage = capsys.readouterr().out
    assert f"usage: psdesign {' '.join(head)} [-h]" in usage and usage.split("\n\n")[0].endswith(
        " OUT"
    ), usage
    assert main([*argv, str(folder)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"psdesign: error: OUT: {why.format(d=folder)}"), err
