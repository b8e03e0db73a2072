"""`-o` safety (issue 11, item 4): psdesign never writes into `/` or the home folder, never
replaces a file or folder it did not write, and refuses with one line and exit status 2 before
any work starts."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from psdesign.cli import main
from psdesign.io.outputs import (
    MARKER,
    OutputError,
    check_output_dir,
    claim_output_dir,
    remove_owned_files,
    staged_output,
)

SPEC = """
[rve]
size = [40e-6, 40e-6, 40e-6]
voxel = 4e-6

[[fibers]]
shape = "rod"
diameter = 10e-6
center = [20e-6, 20.3e-6, 19.1e-6]
"""

STUDY = """
base = "spec.toml"
[study]
name = "s"
design = "full-factorial"
outputs = ["porosity", "k_z"]
[parameters]
"flow.viscosity" = [1e-5]
"""

FF_SPEC = """
[forcefield]
case = "nope"
"""


@pytest.fixture()
def spec(tmp_path) -> Path:
    p = tmp_path / "spec.toml"
    p.write_text(SPEC)
    return p


def snapshot(folder: Path) -> dict:
    return {
        str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None)
        for p in folder.rglob("*")
    }


def run_cli(args: list[str], capsys, home: Path | None = None, monkeypatch=None):
    """Run the CLI in this process; returns (exit status, stderr)."""
    if home is not None:
        monkeypatch.setenv("HOME", str(home))
    rc = main(args)
    return rc, capsys.readouterr().err


def assert_one_line_exit_2(result, *needles: str) -> None:
    rc, err = result
    assert rc == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("psdesign: error: -o: ")
    for n in needles:
        assert n in lines[0], lines[0]


def test_subprocess_one_line_exit_2(tmp_path, spec):
    proc = subprocess.run(
        [sys.executable, "-m", "psdesign.cli", "generate", str(spec), "-o", "/"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "psdesign: error: -o: refusing to write into the file-system root (/), even with "
        "--force; give a new folder name"
    ]


# ----------------------------------------------------------------------------- every command


def _commands(spec: Path, study: Path, out: str) -> list[list[str]]:
    return [
        ["generate", str(spec), "-o", out, "--no-preview"],
        ["mesh", str(spec), "-o", out],
        ["forcefield", str(spec.parent / "ff.toml"), "-o", out],
        ["study", "run", str(study), "-o", out, "--quiet"],
    ]


@pytest.mark.parametrize("force", [False, True])
def test_root_and_home_refused_by_every_command_even_with_force(
    tmp_path, spec, force, capsys, monkeypatch
):
    home = tmp_path / "home"
    home.mkdir()
    (home / "keep.txt").write_text("mine")
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    (tmp_path / "ff.toml").write_text(FF_SPEC)
    extra = ["--force"] if force else []
    for target, why in (("/", "file-system root"), ("~", "home folder"), (str(home), "home")):
        for cmd in _commands(spec, study, target):
            assert_one_line_exit_2(run_cli(cmd + extra, capsys, home, monkeypatch), why)
    assert sorted(p.name for p in home.iterdir()) == ["keep.txt"]


def test_existing_file_and_dangling_link_refused(tmp_path, spec, capsys):
    f = tmp_path / "file.txt"
    f.write_text("user data")
    link = tmp_path / "dangling"
    link.symlink_to(tmp_path / "nowhere")
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    (tmp_path / "ff.toml").write_text(FF_SPEC)
    for cmd in _commands(spec, study, str(f)):
        for extra in ([], ["--force"]):
            assert_one_line_exit_2(run_cli(cmd + extra, capsys), "existing file")
    for cmd in _commands(spec, study, str(link)):
        assert_one_line_exit_2(run_cli(cmd, capsys), "dangling symbolic link")
    assert f.read_text() == "user data"
    assert link.is_symlink() and not (tmp_path / "nowhere").exists()
    # a path below an existing file is refused too (was a NotADirectoryError traceback)
    assert_one_line_exit_2(
        run_cli(["generate", str(spec), "-o", str(f / "sub")], capsys), "inside the file"
    )


def test_non_empty_user_folder_refused_without_force(tmp_path, spec, capsys):
    user = tmp_path / "photos"
    user.mkdir()
    (user / "a.jpg").write_text("jpeg")
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    (tmp_path / "ff.toml").write_text(FF_SPEC)
    before = snapshot(user)
    for cmd in _commands(spec, study, str(user)):
        assert_one_line_exit_2(
            run_cli(cmd, capsys), "non-empty folder psdesign did not create", "a.jpg"
        )
    assert snapshot(user) == before


def test_generate_into_existing_user_folder_keeps_same_named_user_directory(tmp_path, spec):
    """Old behaviour: the staged move rmtree'd a user directory named like an output."""
    user = tmp_path / "work"
    (user / "field.vti").mkdir(parents=True)
    (user / "field.vti" / "thesis.tex").write_text("years of work")
    assert main(["generate", str(spec), "-o", str(user), "--no-preview"]) == 2
    assert main(["generate", str(spec), "-o", str(user), "--no-preview", "--force"]) == 2
    assert (user / "field.vti" / "thesis.tex").read_text() == "years of work"
    assert sorted(p.name for p in user.iterdir()) == ["field.vti"]


def test_force_adds_beside_user_files_and_rerun_replaces_only_psdesign_files(tmp_path, spec):
    user = tmp_path / "work"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    (user / ".x.tmp").write_text("my temp file")
    assert main(["generate", str(spec), "-o", str(user), "--no-preview", "--force"]) == 0
    marker = json.loads((user / MARKER).read_text())
    assert "rve.json" in marker["files"] and "notes.txt" not in marker["files"]
    assert (user / "notes.txt").read_text() == "mine"
    assert (user / ".x.tmp").read_text() == "my temp file"
    # psdesign's folder now: a rerun needs no --force and replaces psdesign's files only
    (user / "summary.json").write_text("stale")
    assert main(["generate", str(spec), "-o", str(user), "--no-preview"]) == 0
    assert json.loads((user / "summary.json").read_text())["n_fibers"] == 1
    assert (user / "notes.txt").read_text() == "mine"
    assert not [p for p in user.parent.iterdir() if p.name.startswith(".psdesign-")]


def test_new_and_empty_folders_get_a_marker(tmp_path, spec):
    empty = tmp_path / "empty"
    empty.mkdir()
    for out in (tmp_path / "new" / "deep", empty):
        assert main(["generate", str(spec), "-o", str(out), "--no-preview"]) == 0
        marker = json.loads((out / MARKER).read_text())
        written = sorted(p.name for p in out.iterdir() if p.name != MARKER)
        assert marker["files"] == written
        # no clock in it (audit s32: its updated_at made two identical runs differ)
        assert set(marker) == {"psdesign_output", "command", "files", "note"}


def test_refusal_happens_before_any_work(tmp_path, spec, monkeypatch):
    import psdesign.packing.build as build

    def boom(*a, **k):  # pragma: no cover - must not be reached
        raise AssertionError("work started")

    monkeypatch.setattr(build, "build_rve", boom)
    user = tmp_path / "u"
    user.mkdir()
    (user / "x").write_text("1")
    assert main(["generate", str(spec), "-o", str(user)]) == 2
    assert main(["mesh", str(spec), "-o", str(user)]) == 2


# ----------------------------------------------------------------------------- the helper


def test_helper_never_replaces_a_foreign_file_found_at_commit(tmp_path):
    out = tmp_path / "o"
    target = check_output_dir(out, command="t")
    claim_output_dir(target, [])  # psdesign's (empty) folder
    target = check_output_dir(out, command="t")
    (out / "b.txt").write_text("user wrote this while psdesign worked")
    with pytest.raises(OutputError, match="b.txt exists and was not written by psdesign"):
        with staged_output(target) as tmp:
            (tmp / "a.txt").write_text("new")
            (tmp / "b.txt").write_text("new")
    assert (out / "b.txt").read_text().startswith("user wrote")
    assert not (out / "a.txt").exists()  # nothing moved
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".psdesign-")]


def test_marker_keeps_the_command_that_made_the_folder(tmp_path):
    """A ``study run`` resuming a ``rev`` folder (or any command adding to another's folder)
    relabelled its marker with its own command (session 32's runner audit); the marker
    names the folder's maker, as ``study fit`` / ``report`` already kept ``study run``."""
    out = tmp_path / "o"
    claim_output_dir(check_output_dir(out, command="rev"), ["rev.json"])
    resumed = check_output_dir(out, force=True, command="study run")
    assert resumed.command == "rev"
    claim_output_dir(resumed, ["results.csv"])
    with staged_output(check_output_dir(out, force=True, command="study run")) as tmp:
        (tmp / "report.html").write_text("r")
    marker = json.loads((out / MARKER).read_text())
    assert marker["command"] == "rev"
    assert {"rev.json", "results.csv", "report.html"} <= set(marker["files"])


def test_helper_owns_subfolders_and_refuses_symlinks_in_the_way(tmp_path):
    out = tmp_path / "o"
    with staged_output(check_output_dir(out, command="t")) as tmp:
        (tmp / "sub").mkdir()
        (tmp / "sub" / "f.txt").write_text("1")
    t = check_output_dir(out)
    assert t.owns("sub/f.txt") and not t.owns("sub/g.txt") and not t.owns("other")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (out / "link").symlink_to(elsewhere)
    with pytest.raises(OutputError, match="in the way"):
        with staged_output(check_output_dir(out)) as tmp:
            (tmp / "link").mkdir()
            (tmp / "link" / "x").write_text("1")
    assert list(elsewhere.iterdir()) == []


def test_replaces_removes_a_previous_runs_files_in_subfolders_but_never_a_users(tmp_path):
    """Session 53: ``staged_output(replaces=...)`` removed stale plain names only, so ``mesh``
    kept a second mechanism for its ``openfoam/`` case. Truth by construction: a first run
    writes a.txt, case/0/p, case/sys/d and keep/k; the user adds case/notes.txt, a top-level
    mine.txt and a link; a second run writes keep/k only. The owned stale files go, the
    folders they leave empty go (case/0, case/sys), case/ stays for the user's file, the user's
    files and the link stay, the marker lists what is left, and a path out of the folder
    (``..``, absolute) is never touched, even when an edited marker lists it."""
    out = tmp_path / "o"
    possible = ["a.txt", "case/0/p", "case/sys/d", "keep/k"]
    with staged_output(check_output_dir(out, command="t"), replaces=possible) as tmp:
        for rel in ("a.txt", "case/0/p", "case/sys/d", "keep/k"):
            (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp / rel).write_text("1")
    (out / "case" / "notes.txt").write_text("mine")
    (out / "mine.txt").write_text("mine")
    (tmp_path / "outside.txt").write_text("mine")
    (out / "case" / "link").symlink_to(tmp_path / "outside.txt")
    with staged_output(check_output_dir(out, command="t"), replaces=possible) as tmp:
        (tmp / "keep").mkdir()
        (tmp / "keep" / "k").write_text("2")
    left = sorted(p.relative_to(out).as_posix() for p in out.rglob("*"))
    assert left == [MARKER, "case", "case/link", "case/notes.txt", "keep", "keep/k", "mine.txt"]
    marker = json.loads((out / MARKER).read_text())
    assert marker["files"] == ["keep/k"]
    escapes = ["../outside.txt", str(tmp_path / "outside.txt"), "case/../../outside.txt"]
    (out / MARKER).write_text(json.dumps(marker | {"files": ["keep/k", *escapes]}))  # edited
    assert remove_owned_files(out, escapes) == []
    assert (tmp_path / "outside.txt").read_text() == "mine"


def test_a_failed_write_names_the_output_file_not_the_staging_folder(tmp_path):
    """Failure audits s35-s36: `generate` on a full 200 kB tmpfs said 'psdesign: error:
    DIR/.psdesign-out.HOST-PID.xyz.tmp/field.vti: No space left on device', a path removed on
    the way out. The error names OUT/field.vti (where the file would have gone); an error about
    a file outside the staging folder (an input) is left as it was."""
    import errno

    out = tmp_path / "o"
    with pytest.raises(OSError) as info:
        with staged_output(check_output_dir(out, command="t")) as tmp:
            (tmp / "sub").mkdir()
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp / "sub" / "f.vti"))
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(out / "sub" / "f.vti")
    assert info.value.strerror == "No space left on device; nothing written"
    assert not out.exists() and [p.name for p in tmp_path.iterdir()] == []
    elsewhere = str(tmp_path / "input.toml")
    with pytest.raises(FileNotFoundError) as info:
        with staged_output(check_output_dir(out, command="t")):
            raise FileNotFoundError(errno.ENOENT, "No such file or directory", elsewhere)
    assert info.value.filename == elsewhere and info.value.strerror == "No such file or directory"


def test_corrupt_marker_is_not_trusted(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / MARKER).write_text('{"psdesign_output": 1, "files": "everything"}')
    (out / "data.csv").write_text("1")
    with pytest.raises(OutputError, match="non-empty folder"):
        check_output_dir(out)
    t = check_output_dir(out, force=True, expected=["x.csv"])
    with pytest.raises(OutputError, match="data.csv exists"):
        check_output_dir(out, force=True, expected=["data.csv"])
    assert not t.owns("data.csv")


# ----------------------------------------------------------------------------- SIGTERM

#: ``generate`` in a child process that stops inside the staged output (the staging folder
#: holds rve.json, field.vti, ... and the medial axes are never written) until signalled.
_HELD_GENERATE = """
import sys, time
import psdesign.packing.generators as g
g.write_medial_axes = lambda *a, **k: time.sleep(120)
from psdesign.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_sigterm_removes_the_staging_folder_and_exits_143(tmp_path, spec):
    """``kill PID`` (``timeout``, a batch system's cancel) during ``generate`` is handled like
    Ctrl-C: the hidden staging folder ``.psdesign-OUT.*.tmp`` is removed, no output folder
    appears, one line on stderr, exit 128 + 15.  It used to die at once (143, no message) and
    leave the staging folder behind for ever."""
    import signal
    import time

    out = tmp_path / "kill3"
    proc = subprocess.Popen(
        # --quiet: no progress lines (``writing kill3: ...``), the one line is all of stderr
        [sys.executable, "-c", _HELD_GENERATE, "generate", str(spec), "-o", str(out), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        deadline = time.monotonic() + 120
        staging: list[Path] = []
        while not any((s / "rve.json").exists() for s in staging):
            assert proc.poll() is None, proc.stderr.read().decode()
            assert time.monotonic() < deadline, "the staging folder did not appear"
            time.sleep(0.05)
            staging = list(tmp_path.glob(".psdesign-kill3.*.tmp"))
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    err = err.decode()
    assert proc.returncode == 143, err
    assert err.strip().splitlines() == ["psdesign: terminated"], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.toml"]


def test_sigterm_handler_is_restored_and_forked_children_keep_the_default(tmp_path):
    """In-process callers of ``main`` get their SIGTERM handler back; a process forked while
    the handler is installed (the force field's worker pool) dies on SIGTERM as before."""
    import os
    import signal

    from psdesign.study.interrupt import terminate_as_interrupt

    before = signal.getsignal(signal.SIGTERM)
    with terminate_as_interrupt():
        assert signal.getsignal(signal.SIGTERM) is not before
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the child
            try:
                ok = signal.getsignal(signal.SIGTERM) == signal.SIG_DFL
            finally:
                os._exit(0 if ok else 1)
        _, status = os.waitpid(pid, 0)
        assert os.waitstatus_to_exitcode(status) == 0
    assert signal.getsignal(signal.SIGTERM) is before


def test_ctrl_c_during_an_import_waits_for_the_import(tmp_path, monkeypatch):
    """Failure audit s36: a Ctrl-C half-way through importing VTK (pyvista's first import,
    ``diffusivity --fields`` interrupted at 5.0-5.5 s) ended the process with SIGSEGV: no line,
    exit -11, the staging folder left (2 of 8 trials).  Truth: a module that receives SIGINT
    during its own import runs to its last line, and the KeyboardInterrupt comes after; with
    Python's own handler (the previous code) the import stopped where the signal landed."""
    import importlib
    import signal
    import time

    from psdesign.study.interrupt import terminate_as_interrupt

    (tmp_path / "slow_import_s36.py").write_text(
        "import signal, time\n"
        "signal.raise_signal(signal.SIGINT)\n"
        "t = time.monotonic()\n"
        "while time.monotonic() - t < 0.2:\n"
        "    pass\n"
        "done = True\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    before = signal.getsignal(signal.SIGINT)
    finished = None
    with terminate_as_interrupt(), pytest.raises(KeyboardInterrupt):
        try:
            importlib.import_module("slow_import_s36")
        finally:
            finished = getattr(sys.modules.get("slow_import_s36"), "done", False)
        time.sleep(2)  # the deferred Ctrl-C arrives 50 ms after the import
    sys.modules.pop("slow_import_s36", None)
    assert finished is True
    assert signal.getsignal(signal.SIGINT) is before  # restored


def test_ctrl_c_inside_an_llvm_callback_is_not_lost(capfd):
    """Session 36: a Ctrl-C during a cold numba compile could land in llvmlite's object-cache
    callback, which LLVM calls from C through ctypes: ctypes printed the KeyboardInterrupt
    ("Exception ignored on calling ctypes callback function") and dropped it, and numba then
    failed with ``RuntimeError: no compiled object yet`` on its cache save (traceback, exit 1;
    5 of 12 trials at 3-50 s into a cold ``permeability --solver voxel``, 0 of 6 after).
    Truth: a SIGINT raised inside a ctypes callback whose code is llvmlite's reaches the caller
    as KeyboardInterrupt once the callback has returned, and ctypes reports nothing."""
    import ctypes
    import signal
    import time

    import llvmlite.binding.executionengine as llvm_ee

    from psdesign.study.interrupt import terminate_as_interrupt

    source = (
        "def notify():\n"
        "    signal.raise_signal(signal.SIGINT)\n"
        "    t = time.monotonic()\n"
        "    while time.monotonic() - t < 0.1:\n"
        "        pass\n"
        "    done.append(True)\n"
    )
    done: list[bool] = []
    scope = {"signal": signal, "time": time, "done": done}
    exec(compile(source, llvm_ee.__file__, "exec"), scope)  # llvmlite's file, as LLVM calls it
    callback = ctypes.CFUNCTYPE(None)(scope["notify"])
    with terminate_as_interrupt(), pytest.raises(KeyboardInterrupt):
        callback()  # through C, as LLVM calls llvmlite
        time.sleep(2)  # the deferred Ctrl-C arrives 50 ms after the callback
    assert done == [True]
    assert "Exception ignored" not in capfd.readouterr().err


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_a_signal_held_for_an_import_survives_the_next_handler(tmp_path, monkeypatch, signame):
    """Failure audit s36: the signal put off during an import was sent again only if the same
    handler was still installed; a study run (``stop_on_interrupt``) installs its own right
    after the imports, and the Ctrl-C / SIGTERM was dropped (``study optimize`` interrupted at
    1.5-2.5 s ran all its cases, exit 1).  Truth: the run that follows the import stops."""
    import importlib
    import time

    from psdesign.study.interrupt import stop_on_interrupt, terminate_as_interrupt

    name = f"signal_import_s36_{signame.lower()}"
    (tmp_path / f"{name}.py").write_text(
        f"import signal\nsignal.raise_signal(signal.{signame})\ndone = True\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    stopped = False
    with terminate_as_interrupt():
        try:
            importlib.import_module(name)
            with stop_on_interrupt():  # the study run's handler, installed within 50 ms
                t = time.monotonic()
                while time.monotonic() - t < 2:
                    time.sleep(0.01)
        except KeyboardInterrupt:
            stopped = True
    sys.modules.pop(name, None)
    assert stopped


_SOBOL_CHILD = """
import signal, sys
import numpy.lib._npyio_impl as npyio

read = npyio.NpzFile.__getitem__


def ctrl_c_while_reading(self, key):  # Ctrl-C while scipy reads its Sobol direction numbers
    signal.raise_signal(signal.SIGINT)
    return read(self, key)


npyio.NpzFile.__getitem__ = ctrl_c_while_reading
from psdesign.study.design import design_points
from psdesign.study.studyfile import load_study

try:
    design_points(load_study(sys.argv[1]))
except KeyboardInterrupt:
    sys.exit(3)
sys.exit(4)
"""


def test_ctrl_c_while_scipy_sets_up_sobol_is_not_lost(tmp_path):
    """Failure audit s36: `study optimize` interrupted at 1.5-4 s printed scipy's "Exception
    ignored in: 'scipy.stats._sobol._initialize_v'" traceback, ran all its cases and exited 1
    (not met): the KeyboardInterrupt raised inside scipy's Cython set-up of the Sobol
    direction numbers is swallowed there.  Truth: the Ctrl-C reaches the caller (exit 3 here);
    the previous code returned the design (exit 4)."""
    study = tmp_path / "s.toml"
    study.write_text(
        "[base.rve]\nsize = [20e-6, 20e-6, 20e-6]\nvoxel = 1e-6\n"
        '[base.generator]\nkind = "straight"\nporosity = 0.85\ndiameter = 4e-6\n'
        '[study]\nname = "s"\ndesign = "sobol"\nn_samples = 4\nseeds = [1]\n'
        'outputs = ["porosity"]\n'
        '[parameters]\n"generator.porosity" = {low = 0.8, high = 0.9}\n'
    )
    p = subprocess.run(
        [sys.executable, "-c", _SOBOL_CHILD, str(study)], capture_output=True, text=True
    )
    assert p.returncode == 3, p.stderr[-2000:]
    assert "Exception ignored" not in p.stderr


# ----------------------------------------------------------------------------- --force hint


def test_force_hint_only_for_commands_that_have_force(tmp_path, spec, capsys):
    """The refusal of a non-empty user folder names ``--force`` only where the command has
    the option (``generate``); ``permeability``/``diffusivity --fields`` and ``rev -o`` have
    none (``--force`` there is "unrecognized arguments")."""
    user = tmp_path / "user4"
    user.mkdir()
    (user / "mine.txt").write_text("mine")
    rc, err = run_cli(["generate", str(spec), "-o", str(user), "--no-preview"], capsys)
    assert rc == 2 and "or --force to add psdesign's files beside them" in err, err
    rev_spec = tmp_path / "gen.toml"
    rev_spec.write_text(
        '[rve]\nsize = [30e-6, 30e-6, 30e-6]\nvoxel = 3e-6\n[generator]\nkind = "straight"\n'
        "porosity = 0.8\ndiameter = 7e-6\nseed = 1\n"
    )
    commands = [
        ["permeability", str(spec), "--direction", "z", "--solver", "voxel", "--fields"],
        ["diffusivity", str(spec), "--direction", "z", "--fields"],
        ["rev", str(rev_spec), "--sizes", "30e-6", "--seeds", "2", "--quiet", "-o"],
    ]
    for cmd in commands:
        rc, err = run_cli([*cmd, str(user)], capsys)
        lines = err.strip().splitlines()
        assert rc == 2 and len(lines) == 1, (cmd, err)
        assert "non-empty folder psdesign did not create" in lines[0], (cmd, err)
        assert "give a new or empty folder" in lines[0] and "--force" not in lines[0], (cmd, err)
    assert sorted(p.name for p in user.iterdir()) == ["mine.txt"]


def test_staging_folder_of_a_killed_run_is_removed_by_the_next_run(tmp_path, spec):
    """SIGKILL (or a power cut) gives no chance to clean up: the next run for the same output
    removes the staging folder a dead process of this machine left, and nothing else (a live
    process's, another output's, another machine's, or an old one without a process id)."""
    from psdesign.io.outputs import _host_tag

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    host = _host_tag()
    names = {
        "orphan": f".psdesign-out.{host}-{dead.pid}.abcd_123.tmp",
        "live": f".psdesign-out.{host}-{os.getpid()}.efgh4567.tmp",
        "other output": f".psdesign-out2.{host}-{dead.pid}.abcd1234.tmp",
        "other host": f".psdesign-out.{'0' * 8 if host != '0' * 8 else '1' * 8}-{dead.pid}.x.tmp",
        "no pid": ".psdesign-out.abcd1234.tmp",
    }
    for n in names.values():
        (tmp_path / n).mkdir()
        (tmp_path / n / "field.vti").write_text("partial")
    assert main(["generate", str(spec), "-o", str(tmp_path / "out"), "--no-preview"]) == 0
    left = {p.name for p in tmp_path.iterdir() if p.name.startswith(".psdesign-")}
    assert left == set(names.values()) - {names["orphan"]}
    assert (tmp_path / "out" / "rve.json").exists()


def test_a_late_ctrl_c_while_python_shuts_down_is_ignored(tmp_path):
    """Session 35's failure audit: a SIGINT that landed after the command's work was done,
    while Python shut down, printed "Exception ignored in atexit callback ...
    KeyboardInterrupt" with a traceback, or ended the process by the signal (exit -2, no
    message), in 4 of ~90 late Ctrl-C.  The process the console script starts (read from
    pyproject.toml, so this is what ``psdesign`` runs) ignores Ctrl-C once its outputs are
    complete: the exit status and the one line are the command's."""
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    entry = tomllib.loads((root / "pyproject.toml").read_text())["project"]["scripts"]
    module, func = entry["psdesign"].split(":")
    _late_ctrl_c(tmp_path, f"from {module} import {func}\nsys.exit({func}())\n")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("module", ["psdesign", "psdesign.cli"])
def test_a_late_ctrl_c_is_ignored_by_every_python_m_entry(tmp_path, module):
    """``python -m psdesign`` and ``python -m psdesign.cli`` (docs/architecture.md lists
    both; benchmarks/RESULTS.md's commands use the second) are the ``psdesign`` process too:
    a SIGINT after the work, while Python shuts down, is ignored.  Session 36's docs walk:
    ``python -m psdesign.cli`` still called ``main`` and printed the atexit
    KeyboardInterrupt traceback the console script no longer does."""
    run = f"import runpy\nrunpy.run_module({module!r}, run_name='__main__', alter_sys=True)\n"
    _late_ctrl_c(tmp_path, run)


def _late_ctrl_c(tmp_path, launch: str) -> None:
    """Run ``launch`` (Python lines that start the psdesign command) on ``study run`` of a
    missing file, with a SIGINT sent from an atexit callback: exit 2, the one line, no
    traceback."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    script = tmp_path / "late_ctrl_c.py"
    script.write_text(
        "import atexit, os, signal, sys, time\n"
        "atexit.register(lambda: (os.kill(os.getpid(), signal.SIGINT), time.sleep(0.2)))\n"
        f"sys.argv = ['psdesign', 'study', 'run', {str(tmp_path / 'no.toml')!r}, '-o', "
        f"{str(tmp_path / 'out')!r}]\n" + launch
    )
    proc = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=root
    )
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "KeyboardInterrupt" not in proc.stderr
    assert proc.stderr.strip().splitlines() == [
        f"psdesign: error: study: file not found: {tmp_path / 'no.toml'}"
    ]
