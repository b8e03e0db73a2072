"""Every ```python block of README.md and docs/*.md runs as written (from the repository root,
each in a fresh namespace). Blocks run with ``__name__ != "__main__"``, so the long calls a
script keeps under its main guard (a whole study) are compiled and their names resolved, but
not run; everything else executes. The image example (import, build from a TIFF, a voxel
solve that loads the cached kernels) runs in a fresh interpreter, end to end; the others run
in this process (a fresh interpreter per block cost 0.5-1.9 s of CPU for the start and the
re-import of numpy, scipy and the cached kernels; README's quick start, measured alone: 7.0 s
as a subprocess, 5.9 s in this process)."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest
from conftest import REPO_ROOT

DOCS = [REPO_ROOT / "README.md", *sorted((REPO_ROOT / "docs").glob("*.md"))]
BLOCKS = [
    pytest.param(f"{path.name}:{i}", code, id=f"{path.name}:{i}")
    for path in DOCS
    for i, code in enumerate(re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S))
]
FRESH_INTERPRETER = {"images.md:0"}
#: Blocks whose printed line the text quotes: the words that introduce the quote (the text in
#: backticks right after them is the start of what the block prints, spaces and line breaks
#: alike, up to a closing "..."). docs/transport.md quoted D_eff/D_z = 0.6100 +- 5.0 % for a
#: block that printed 0.8486 +- 3.0 % (walk-api, session 54).
QUOTED_OUTPUT = {"transport.md:0": "`print(r)` prints the command's line ("}


def test_docs_have_python_examples() -> None:
    assert len(BLOCKS) >= 2
    assert FRESH_INTERPRETER <= {p.values[0] for p in BLOCKS}
    assert set(QUOTED_OUTPUT) <= {p.values[0] for p in BLOCKS} - FRESH_INTERPRETER


def _quoted_output(name: str) -> str:
    """The start of a block's output as its page quotes it (:data:`QUOTED_OUTPUT`), spaces
    collapsed, the closing "..." cut."""
    file = name.split(":")[0]
    text = (REPO_ROOT / file if file == "README.md" else REPO_ROOT / "docs" / file).read_text()
    lead = QUOTED_OUTPUT[name]
    assert lead in text, f"{name}: the text no longer says {lead!r}"
    quote = re.match(r"`([^`]+)`", text.split(lead, 1)[1])
    assert quote, f"{name}: no `quote` after {lead!r}"
    return " ".join(quote.group(1).removesuffix("...").split())


@pytest.mark.parametrize("name, code", BLOCKS)
def test_python_block_runs(name, code, monkeypatch, capsys) -> None:
    if name not in FRESH_INTERPRETER:
        monkeypatch.chdir(REPO_ROOT)
        capsys.readouterr()
        exec(compile(code, name, "exec"), {"__name__": "__docs__"})
        if name in QUOTED_OUTPUT:  # the text's quote of the printed line is what it prints
            printed = " ".join(capsys.readouterr().out.split())
            assert printed.startswith(_quoted_output(name)), printed
        return
    script = (
        "import runpy, sys\n"
        f"src = {code!r}\n"
        "compile(src, 'doc', 'exec')\n"
        "exec(compile(src, 'doc', 'exec'), {'__name__': '__docs__'})\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", script], cwd=REPO_ROOT, capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_guarded_lines_name_only_what_psdesign_has() -> None:
    # the lines under a main guard are compiled, not run: check the names they take from
    # psdesign exist (a renamed function would otherwise pass here and fail for the reader)
    import psdesign

    used = {name for _, code in (p.values for p in BLOCKS) for name in _psdesign_names(code)}
    assert "run_study" in used and "write_report" in used
    assert not [n for n in used if not hasattr(psdesign, n)]


def _psdesign_names(code: str) -> set[str]:
    return set(re.findall(r"\bpsdesign\.(\w+)\(", code))


def test_package_docstring_example_names_exist() -> None:
    # the public-API example in psdesign/__init__.py's docstring is a literal block, not a
    # doctest (it would build, solve and run a study): its names and files must still exist
    import psdesign
    from psdesign.api import Material

    doc = psdesign.__doc__
    used = _psdesign_names(doc)
    assert {"load_spec", "build", "from_image", "run_study"} <= used
    assert not [n for n in used if not hasattr(psdesign, n)]
    methods = set(re.findall(r"\bm\.(\w+)\b", doc))
    assert "permeability" in methods
    assert not [n for n in methods if not hasattr(Material, n)]
    for path in re.findall(r'"(studies/[\w/.]+\.toml)"', doc):
        assert (REPO_ROOT / path).is_file(), path


def test_docstring_examples_run() -> None:
    # task api21: the docstring examples (>>> lines) of psdesign and solvers run and print what
    # they say they return (a guard: the default suite does not run --doctest-modules)
    import doctest
    import importlib

    files = [
        p
        for top in ("psdesign", "solvers")
        for p in sorted((REPO_ROOT / top).rglob("*.py"))
        if ">>> " in p.read_text()
    ]
    assert len(files) >= 10
    for path in files:
        name = ".".join(path.relative_to(REPO_ROOT).with_suffix("").parts)
        result = doctest.testmod(importlib.import_module(name), verbose=False)
        assert result.failed == 0, name


def _subparsers(parser) -> dict:
    import argparse

    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _synopsis(command: str, text: str) -> str:
    # the lines that show ``psdesign COMMAND ...`` and their continuation lines (indented,
    # starting with ``[``), as in README's "Commands" block and docs/study-files.md's synopsis
    lines, keep = [], False
    for line in text.splitlines():
        if f"psdesign {command} " in line:
            lines.append(line)
            keep = True
        elif keep and line.strip().startswith("["):
            lines.append(line)
        else:
            keep = False
    return "\n".join(lines)


def test_every_cli_option_is_in_its_command_synopsis() -> None:
    # docs walk (session 36): `--help` had options no page named (generate --no-preview,
    # study fit --outputs, study optimize --batch / --seed, study run --cluster-account, ...);
    # every option of every command must appear in a `psdesign COMMAND ...` synopsis line
    import argparse

    from psdesign.cli.main import build_parser

    text = "\n".join(p.read_text() for p in DOCS if p.name != "validation.md")
    commands = {}
    for name, sub in _subparsers(build_parser()).items():
        nested = _subparsers(sub)
        if nested:
            commands |= {f"{name} {n}": p for n, p in nested.items()}
        else:
            commands[name] = sub
    assert len(commands) >= 15
    missing = []
    for command, parser in sorted(commands.items()):
        synopsis = _synopsis(command, text)
        for action in parser._actions:
            if action.help == argparse.SUPPRESS:  # hidden (e.g. the tests' --case-fn)
                continue
            flags = [s for s in action.option_strings if s not in ("-h", "--help")]
            if flags and not any(re.search(rf"{re.escape(f)}\b", synopsis) for f in flags):
                missing.append(f"psdesign {command} {flags[-1]}")
    assert not missing, missing


def test_every_exit_status_is_in_help_and_readme() -> None:
    # session 37: 3 (finished, not converged / target missed) split from 1 (could not finish);
    # a script's author finds the table in `psdesign --help` and in README, each code named
    from psdesign.cli import exit_status
    from psdesign.cli.main import build_parser

    codes = {v for k, v in vars(exit_status).items() if k.isupper() and isinstance(v, int)}
    assert codes == {0, 1, 2, 3, 130, 143}
    help_text = " ".join(build_parser().format_help().split())
    readme = " ".join((REPO_ROOT / "README.md").read_text().split())
    for code in sorted(codes):
        assert re.search(rf"[:;] {code} \w", help_text), code
        assert f"**{code}**" in readme, code


def test_study_fit_default_outputs_are_named_in_help_and_readme() -> None:
    # session 40 (new user's walk): `study fit` on a transport study fitted diffusivity_z and
    # tortuosity_z as well, where its --help and README said "default: K, porosity"
    import argparse

    from psdesign.analysis.surrogate import default_fit_outputs
    from psdesign.cli.main import build_parser

    fitted = default_fit_outputs(
        ["porosity", "k_z_m2", "diffusivity_z", "tortuosity_z", "conductivity_z", "n_fibers"]
    )
    kinds = {c.split("_")[0] for c in fitted} - {"k"}  # porosity, diffusivity, ...
    assert kinds == {"porosity", "diffusivity", "tortuosity", "conductivity"}
    fit = _subparsers(_subparsers(build_parser())["study"])["fit"]
    (outputs,) = [a for a in fit._actions if "--outputs" in a.option_strings]
    assert outputs.help != argparse.SUPPRESS
    readme = _synopsis("study fit", (REPO_ROOT / "README.md").read_text())
    for text in (outputs.help, readme):
        assert "K" in text and all(k in text for k in kinds), text


#: Options that take a value but have no default to state: an extra output written only
#: when asked for, or a batch / TLS setting with nothing to fall back on.
NO_DEFAULT_OPTIONS = {
    "--fields",
    "--plot",
    "--format",  # generate: only tiff, added on request
    "--cluster",
    "--cluster-queue",
    "--cluster-account",
    "--tls-ca-file",
    "--tls-cert",
    "--tls-key",
}


def test_every_cli_option_says_what_it_is_and_its_default() -> None:
    # session 42 (a new user's walk of `--help`): 21 arguments printed no help at all
    # (`permeability --solver`, `diffusivity --direction`, `conductivity --bc`, every `spec`
    # positional but rev's, `study sensitivity --method/--seed`, ...) and 7 options with a
    # value named no default (`conductivity --solid`, `pores --axis`, `study run --timeout`, ...)
    import argparse

    from psdesign.cli.main import build_parser

    commands = {}
    for name, sub in _subparsers(build_parser()).items():
        nested = _subparsers(sub)
        commands |= {f"{name} {n}": p for n, p in nested.items()} if nested else {name: sub}
    silent, no_default, wrong_default = [], [], []
    for command, parser in sorted(commands.items()):
        for action in parser._actions:
            if isinstance(action, argparse._HelpAction) or action.help == argparse.SUPPRESS:
                continue
            flag = action.option_strings[-1] if action.option_strings else action.dest
            if not (action.help or "").strip():
                silent.append(f"{command} {flag}")
            elif _stated_default_differs(action):
                wrong_default.append(f"{command} {flag}: {action.default!r}")
            elif (
                action.option_strings
                and action.nargs != 0  # takes a value
                and not action.required
                and flag not in NO_DEFAULT_OPTIONS
                and "default" not in action.help
            ):
                no_default.append(f"{command} {flag}")
    assert not silent, silent
    assert not no_default, no_default
    assert not wrong_default, wrong_default


def _stated_default_differs(action) -> bool:
    """An option whose parser default is a number or a word, and whose help does not print
    that value (the help names a default, but not the one argparse uses)."""
    import argparse

    d = action.default
    if not action.option_strings or action.nargs == 0 or isinstance(d, bool):
        return False
    if d is None or d == argparse.SUPPRESS or not isinstance(d, int | float | str):
        return False
    forms = {str(d), f"{d:g}"} if isinstance(d, int | float) else {str(d)}
    return not any(f in action.help for f in forms)
