"""Audit "nothing lost or overwritten on failure" against a real full disk, real kills and
refused folders (session 35).

Every scenario runs one psdesign command that writes.  Three modes:

* ``enospc``: the output goes to a small tmpfs (``mount -t tmpfs -o size=S``; root only) of
  each size in ``--sizes``; optionally over a prior good output (``--prior``).  Checked: a
  non-zero exit with one stderr line and no traceback, or a clean success; no psdesign
  temporary left; every file under its final name is a complete one (byte-equal to the clean
  run's, or a parseable JSON / CSV for the files that carry times); the prior output intact.
  Then the tmpfs is grown (``remount,size=64m``), the command is run again, and its outputs
  must equal the clean run's.
* ``kill``: the command starts in its own process group, a seeded random time later the group
  gets SIGKILL or SIGINT.  Checked: SIGINT gives one line and a non-zero exit (no traceback);
  afterwards the folder is absent, or a valid psdesign folder, with no user-visible partial
  file; a re-run completes and equals the clean run.
* ``refuse``: a read-only output folder, an output path that is a regular file, an output
  folder holding a user's files: exit 2, one line, nothing touched.

    sudo python benchmarks/audit_failures.py --spec SPEC.toml --study STUDY.toml \
        --modes enospc kill refuse --scenarios generate study_run --trials 20 --seed 35

Session 36 added the other writing commands: ``mesh_all`` (every export format),
``forcefield_paper`` / ``forcefield_relax`` (``--ffspec``: a paper case, ``--relaxspec``: an
RVE spec with ``[forcefield.relax]``), ``diffusivity_fields`` / ``conductivity_fields``,
``permeability_json`` (stdout into a file on the full disk: the disk is filled first),
``study_optimize`` (``--optstudy``: a study of ``{low, high}`` ranges; exit 3 = target not
met is a complete run).  ``*_timings.json`` files carry wall times (whole, not equal).

Prints one row per trial and a summary table per scenario and mode.  The clean run of each
scenario is the reference (run once, in a plain folder).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

MOUNT = Path("/tmp/full_diskfull")
WORK = Path("/tmp/audit_failures_work")
#: Files whose bytes carry times or run history: checked for being whole (parse), not equal.
VOLATILE = {
    ".psdesign-output.json",
    "run.json",
    "summary_timings.json",
    "mesh_timings.json",
    "report.html",
    "results.parquet",
    "summary.parquet",
    "surrogate.json",
    "optimize.json",
}


def volatile(rel: str) -> bool:
    """A file whose bytes carry times: ``VOLATILE`` or any ``*_timings.json``."""
    name = Path(rel).name
    return name in VOLATILE or name.endswith("_timings.json")


@dataclass
class Scenario:
    """One command: ``argv`` with ``{out}``, ``{spec}``, ``{study}`` placeholders."""

    name: str
    argv: list[str]
    setup: str = ""  # "study": OUT starts as a copy of the clean study_run output
    target: str = "dir"  # "file": {out} names a single new file; "stdout": stdout goes there
    # exit statuses of a complete run: 3 is "finished, outputs complete, a result not ok" (a
    # target missed, an untrustworthy K or pore scan: psdesign/cli/exit_status.py, session 45)
    clean_rc: tuple[int, ...] = (0, 3)
    ref: Path | None = None
    ref_time: float = 0.0


SCENARIOS = {
    "generate": Scenario("generate", ["generate", "{spec}", "-o", "{out}", "--quiet"]),
    "mesh": Scenario(
        "mesh",
        ["mesh", "{spec}", "-o", "{out}", "--format", "msh", "fluent", "openfoam", "--quiet"],
    ),
    "permeability_fields": Scenario(
        "permeability_fields",
        ["permeability", "{spec}", "--direction", "z", "--fields", "{out}", "--quiet"],
    ),
    "pores_plot": Scenario(
        "pores_plot", ["pores", "{spec}", "--plot", "{out}", "--quiet"], target="file"
    ),
    # session 36: the writing commands session 35 did not drive
    "mesh_all": Scenario(
        "mesh_all",
        ["mesh", "{spec}", "-o", "{out}", "--format", "vtu", "msh", "fluent", "stl", "openfoam"]
        + ["--quiet"],
    ),
    "permeability_json": Scenario(
        "permeability_json",
        ["permeability", "{spec}", "--solver", "voxel", "--json", "--quiet"],
        target="stdout",
    ),
    "diffusivity_fields": Scenario(
        "diffusivity_fields",
        ["diffusivity", "{spec}", "--fields", "{out}", "--json", "--quiet"],
    ),
    "conductivity_fields": Scenario(
        "conductivity_fields",
        ["conductivity", "{spec}", "--solid", "1", "--fluid", "0.1", "--fields", "{out}"]
        + ["--json", "--quiet"],
    ),
    "forcefield_paper": Scenario(
        "forcefield_paper", ["forcefield", "{ffspec}", "-o", "{out}", "--quiet"]
    ),
    "forcefield_relax": Scenario(
        "forcefield_relax", ["forcefield", "{relaxspec}", "-o", "{out}", "--quiet"]
    ),
    "study_optimize": Scenario(
        "study_optimize",
        ["study", "optimize", "{optstudy}", "-o", "{out}", "--target", "k_z_m2>=1e-14"]
        + ["--budget", "3", "--workers", "0", "--quiet"],
    ),
    "study_run": Scenario("study_run", ["study", "run", "{study}", "-o", "{out}", "--quiet"]),
    "study_report": Scenario("study_report", ["study", "report", "{out}"], setup="study"),
    "study_fit": Scenario("study_fit", ["study", "fit", "{out}"], setup="study"),
    "rev": Scenario(
        "rev",
        ["rev", "{spec}", "--sizes", "12e-6", "16e-6", "--seeds", "2", "-o", "{out}", "--quiet"],
    ),
}


@dataclass
class Row:
    scenario: str
    mode: str
    param: str
    rc: int
    lines: int
    traceback: bool
    leftovers: list[str] = field(default_factory=list)
    partial: list[str] = field(default_factory=list)
    prior_lost: list[str] = field(default_factory=list)
    rerun_ok: bool | None = None
    note: str = ""
    clean_rc: tuple[int, ...] = (0, 3)

    @property
    def ok(self) -> bool:
        if self.mode == "refuse":
            return self.rc == 2 and self.lines == 1 and not self.traceback and not self.prior_lost
        return (
            not self.traceback
            and not self.leftovers
            and not self.partial
            and not self.prior_lost
            and self.rerun_ok is not False
            and (self.rc in self.clean_rc or self.lines == 1)
        )


def _sh(*cmd: str) -> None:
    subprocess.run(cmd, check=True)


def mount(size: str) -> None:
    MOUNT.mkdir(parents=True, exist_ok=True)
    if os.path.ismount(MOUNT):
        _sh("umount", str(MOUNT))
    _sh("mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(MOUNT))


def umount() -> None:
    if os.path.ismount(MOUNT):
        _sh("umount", str(MOUNT))


def argv_for(sc: Scenario, out: Path, args: argparse.Namespace) -> list[str]:
    subs = {"{out}": str(out), "{spec}": str(args.spec), "{study}": str(args.study)}
    subs |= {f"{{{k}}}": str(getattr(args, k)) for k in ("ffspec", "relaxspec", "optstudy")}
    return [sys.executable, "-m", "psdesign", *[subs.get(a, a) for a in sc.argv]]


def out_name(sc: Scenario) -> str:
    return {"file": "out.png", "stdout": "out.json"}.get(sc.target, "out")


def run(
    cmd: list[str], timeout: float = 1800, stdout: Path | None = None
) -> subprocess.CompletedProcess:
    """Run ``cmd``; ``stdout``: a file its standard output goes to (the shell's ``>``)."""
    if stdout is None:
        return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    with open(stdout, "w") as fh:
        return subprocess.run(cmd, stdout=fh, stderr=subprocess.PIPE, text=True, timeout=timeout)


def run_sc(sc: Scenario, out: Path, args: argparse.Namespace) -> subprocess.CompletedProcess:
    return run(argv_for(sc, out, args), stdout=out if sc.target == "stdout" else None)


def files_of(root: Path) -> dict[str, str]:
    """Relative path -> sha256 of every regular file under ``root`` (or ``root`` itself)."""
    if root.is_file():
        return {".": hashlib.sha256(root.read_bytes()).hexdigest()}
    out = {}
    for dirpath, _d, names in os.walk(root):
        for n in names:
            p = Path(dirpath) / n
            out[p.relative_to(root).as_posix()] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def temps_under(root: Path) -> list[str]:
    found = []
    for dirpath, dirs, names in os.walk(root):
        for n in [*dirs, *names]:
            if n.startswith(".psdesign-") and n.endswith(".tmp"):
                found.append((Path(dirpath) / n).relative_to(root).as_posix())
    return sorted(found)


def _csv_equal(a: Path, b: Path) -> bool:
    da, db = pd.read_csv(a), pd.read_csv(b)
    from psdesign.study.store import is_timing_column

    drop = [c for c in da.columns if is_timing_column(c)]
    da = da.drop(columns=drop, errors="ignore")
    db = db.drop(columns=[c for c in drop if c in db.columns], errors="ignore")
    return da.equals(db)


#: Scenarios whose output is a study folder: a stopped run holds a subset of the rows.
STUDIES = ("study_run", "rev", "study_optimize")

#: psdesign's working files in a study folder: a killed run may leave them; whole if parseable.
WORKING = {".lock", "stage.txt", "stage.tmp", "error.txt"}


def _rows_in_ref(p: Path, ref: Path) -> bool:
    """Every row of the CSV ``p`` (timing columns aside) is a row of ``ref``: a table of a
    run stopped early holds fewer rows, each as in the finished table."""
    from psdesign.study.store import is_timing_column

    a, b = pd.read_csv(p), pd.read_csv(ref)
    if list(a.columns) != list(b.columns):
        return False
    keep = [c for c in a.columns if not is_timing_column(c)]
    rows = {tuple(map(str, r)) for r in b[keep].itertuples(index=False)}
    return all(tuple(map(str, r)) in rows for r in a[keep].itertuples(index=False))


def whole(p: Path, ref: Path | None, early: bool = False) -> bool:
    """``p`` is a complete file: equal to the clean run's, or (volatile) parseable.

    ``early``: the run may have stopped before its end (a kill), so a table may hold a
    subset of the clean run's rows and psdesign's working files may remain."""
    if ref is not None and ref.is_file() and p.read_bytes() == ref.read_bytes():
        return True
    name = p.name
    try:
        if name.endswith(".json") or name == ".lock":
            json.loads(p.read_text())
            return True
        if name.endswith(".csv"):
            if ref is not None and ref.is_file():
                if early and (name == "summary.csv" or pd.read_csv(p).empty):
                    return True  # statistics over the seeds done so far; no case done yet
                return _rows_in_ref(p, ref) if early else _csv_equal(p, ref)
            pd.read_csv(p)
            return True
        if name.endswith(".parquet"):
            pd.read_parquet(p)
            return True
        if name.endswith(".html"):
            return p.read_text().rstrip().endswith("</html>")
    except Exception:  # noqa: BLE001 - any parse failure is a partial file
        return False
    # a working file of a stopped case (an error.txt the full disk left empty): removed when
    # the case runs again
    return volatile(name) or (early and name in WORKING)


def partial_files(out: Path, ref: Path, early: bool = False) -> list[str]:
    """Files under their final names in ``out`` that are not complete."""
    if not out.exists():
        return []
    if out.is_file():
        return [] if whole(out, ref) else ["."]
    bad = []
    for rel in files_of(out):
        if Path(rel).name.startswith(".psdesign-") and rel.endswith(".tmp"):
            continue
        r = ref / rel
        if not whole(out / rel, r if r.exists() else None, early):
            bad.append(rel)
    return bad


def _untimed(obj: object) -> object:
    """A JSON value without its run-metadata keys (wall times, threads)."""
    if isinstance(obj, dict):
        return {k: _untimed(v) for k, v in obj.items() if "time" not in k and "thread" not in k}
    if isinstance(obj, list):
        return [_untimed(v) for v in obj]
    return obj


def same_as_ref(out: Path, ref: Path) -> bool:
    """The re-run's outputs equal the clean run's (volatile files: present and whole)."""
    if ref.is_file():
        if out.is_file() and out.suffix == ".json":  # a command's --json stdout
            try:
                a, b = json.loads(out.read_text()), json.loads(ref.read_text())
            except ValueError:
                return False
            return _untimed(a) == _untimed(b)
        return out.is_file() and out.read_bytes() == ref.read_bytes()
    a, b = files_of(out), files_of(ref)
    if set(a) != set(b):
        return False
    for rel in a:
        if a[rel] == b[rel]:
            continue
        if rel.endswith(".csv") and _csv_equal(out / rel, ref / rel):
            continue
        if volatile(rel) or rel.startswith("cases/"):
            if whole(out / rel, None) or volatile(rel):
                continue
        return False
    return True


def make_reference(sc: Scenario, args: argparse.Namespace, refs: dict[str, Scenario]) -> None:
    base = WORK / "ref" / sc.name
    shutil.rmtree(base, ignore_errors=True)
    base.mkdir(parents=True)
    out = base / out_name(sc)
    if sc.setup == "study":
        shutil.copytree(refs["study_run"].ref, out, symlinks=True)
    t0 = time.perf_counter()
    p = run_sc(sc, out, args)
    sc.ref_time = time.perf_counter() - t0
    if p.returncode not in sc.clean_rc:
        raise SystemExit(f"reference run of {sc.name} failed: {p.stderr.strip()[-400:]}")
    sc.ref = out
    print(f"# reference {sc.name}: {sc.ref_time:.1f} s, {len(files_of(out))} files", flush=True)


def _prepare(sc: Scenario, out: Path, refs: dict[str, Scenario], prior: bool) -> None:
    if sc.setup == "study":
        shutil.copytree(refs["study_run"].ref, out, symlinks=True)
    elif prior:
        if sc.target == "file":
            return  # a single new file is never written over
        shutil.copytree(sc.ref, out, symlinks=True)


def _lines(stderr: str) -> tuple[int, bool]:
    """Lines of stderr that are not psdesign's one-line warnings, and whether a traceback."""
    lines = [
        ln
        for ln in stderr.strip().splitlines()
        if ln.strip() and not ln.startswith("psdesign: warning:")
    ]
    return len(lines), "Traceback" in stderr


def _du_k(root: Path) -> int:
    """KiB a copy of ``root`` takes on tmpfs (4 KiB pages per file)."""
    if root.is_file():
        return -(-root.stat().st_size // 4096) * 4
    total = 0
    for dirpath, dirs, names in os.walk(root):
        total += 4 * (1 + len(dirs))
        total += sum(-(-(Path(dirpath) / n).stat().st_size // 4096) * 4 for n in names)
    return total


def audit_enospc(sc: Scenario, args, refs, size: str, prior: bool) -> Row:
    """``size`` is the free space: added to what the prior state takes."""
    start = refs["study_run"].ref if sc.setup == "study" else (sc.ref if prior else None)
    extra = _du_k(start) + 8 if start is not None and start.exists() else 0
    num = int(float(size[:-1]) * {"k": 1, "m": 1024}[size[-1]])
    mount(f"{num + extra}k")
    try:
        out = MOUNT / out_name(sc)
        try:
            _prepare(sc, out, refs, prior)
        except OSError:
            return Row(
                sc.name,
                "enospc",
                f"{size}{' prior' if prior else ''}",
                -1,
                0,
                False,
                note="prior state does not fit",
            )
        if sc.target == "stdout":  # a JSON line fits any size: the disk is filled first
            with open(MOUNT / "filler", "wb", buffering=0) as fh, contextlib.suppress(OSError):
                while True:
                    fh.write(b"\0" * 4096)
        before = files_of(out) if out.exists() else {}
        p = run_sc(sc, out, args)
        n, tb = _lines(p.stderr)
        row = Row(sc.name, "enospc", f"{size}{' prior' if prior else ''}", p.returncode, n, tb)
        row.clean_rc = sc.clean_rc
        if p.returncode not in sc.clean_rc or "psdesign: error" in p.stderr:
            row.note = (p.stderr.strip().splitlines() or [""])[-1][:110]
        row.leftovers = temps_under(MOUNT)
        row.partial = partial_files(out, sc.ref, early=sc.name in STUDIES)
        if sc.target == "stdout" and p.returncode not in sc.clean_rc:
            row.partial = []  # the shell's file: a failed command's output is cut, by design
        if before and p.returncode not in sc.clean_rc:
            now = files_of(out) if out.exists() else {}
            row.prior_lost = [
                r
                for r, h in before.items()
                if now.get(r) != h and not volatile(r) and not r.endswith(".csv")
            ]
            row.prior_lost += [r for r in before if r not in now]
        if row.partial or row.prior_lost or row.leftovers:  # keep the evidence
            keep = WORK / "failed" / f"{sc.name}-{size}{'-prior' if prior else ''}"
            shutil.rmtree(keep, ignore_errors=True)
            shutil.copytree(MOUNT, keep, symlinks=True)
        _sh("mount", "-o", "remount,size=64m", str(MOUNT))
        (MOUNT / "filler").unlink(missing_ok=True)
        p2 = run_sc(sc, out, args)
        if sc.target == "file" and p.returncode in sc.clean_rc:  # done; a rerun refuses the file
            row.rerun_ok = p2.returncode == 2 and same_as_ref(out, sc.ref)
        else:
            row.rerun_ok = p2.returncode in sc.clean_rc and same_as_ref(out, sc.ref)
        if not row.rerun_ok:
            row.note += f" | rerun rc={p2.returncode} {p2.stderr.strip()[-200:]}"
        return row
    finally:
        umount()


def audit_kill(sc: Scenario, args, refs, trial: int, rng: random.Random) -> Row:
    sig = signal.SIGINT if trial % 2 else signal.SIGKILL
    base = WORK / "kill" / sc.name / f"t{trial:03d}"
    shutil.rmtree(base, ignore_errors=True)
    base.mkdir(parents=True)
    out = base / out_name(sc)
    _prepare(sc, out, refs, prior=False)
    delay = rng.uniform(0.3, max(1.0, sc.ref_time * args.kill_within))
    sink = open(out, "w") if sc.target == "stdout" else subprocess.PIPE  # noqa: SIM115
    proc = subprocess.Popen(
        argv_for(sc, out, args),
        stdout=sink,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    sent = False
    try:
        proc.wait(timeout=delay)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, sig)
        sent = True
    _o, err = proc.communicate(timeout=600)
    if sink is not subprocess.PIPE:
        sink.close()
    with_sig = f"{signal.Signals(sig).name} at {delay:.1f}s"
    n, tb = _lines(err)
    if sig == signal.SIGINT and proc.returncode not in (0,):
        # the progress lines are suppressed (--quiet): the last line must be the message
        pass
    row = Row(sc.name, "kill", with_sig, proc.returncode, n, tb, clean_rc=sc.clean_rc)
    if proc.returncode < 0 and sig == signal.SIGKILL:
        row.lines = 1  # a SIGKILL prints nothing, by construction
    if proc.returncode not in sc.clean_rc:
        row.note = (err.strip().splitlines() or [""])[-1][:110]
    if not sent:
        row.note = "(ended before the signal) " + row.note
    elif sig == signal.SIGINT and proc.returncode in sc.clean_rc:
        # lost, or landed after main returned (ignored by design): check by hand
        row.note = "SIGINT without effect (lost, or after main returned) " + row.note
        row.lines = 0  # not the one line of an interrupt
        row.rc = -1000  # fails the check: the interrupt was ignored
    if sc.target == "stdout" and proc.returncode not in sc.clean_rc:
        row.partial = []  # the shell's file: a killed command's output is cut, by design
    time.sleep(0.2)  # let children of the killed group go
    # a re-run must complete and equal the clean run (temporaries of the killed run are the
    # re-run's to remove)
    p2 = run_sc(sc, out, args)
    if sc.target == "file" and p2.returncode == 2 and out.exists() and whole(out, sc.ref):
        row.rerun_ok = True  # the file was finished before the kill; a new run refuses it
    else:
        row.rerun_ok = p2.returncode in sc.clean_rc and same_as_ref(out, sc.ref)
    row.leftovers = temps_under(base)
    if not row.rerun_ok:
        row.note += f" | rerun rc={p2.returncode} {p2.stderr.strip()[-300:]}"
    return row


def audit_refuse(sc: Scenario, args, refs, case: str) -> Row:
    base = WORK / "refuse" / sc.name / case
    shutil.rmtree(base, ignore_errors=True)
    base.mkdir(parents=True)
    out = base / out_name(sc)
    if case == "readonly":  # a read-only file system (root ignores permission bits)
        mount("64m")
        base = MOUNT
        out = base / out.name
        if sc.target != "file":
            _prepare(sc, out, refs, prior=False)
            out.mkdir(exist_ok=True)
        _sh("mount", "-o", "remount,ro", str(MOUNT))
    elif case == "file":
        if sc.setup == "study":
            out.write_text("user file\n")
        else:
            out.write_text("user file\n")
    elif case == "user_files":
        if sc.target == "file":
            out.write_text("user png\n")
        elif sc.setup == "study":  # the user's own file under the name the command writes
            _prepare(sc, out, refs, prior=False)
            name = {"study_report": "report.html", "study_fit": "surrogate.json"}[sc.name]
            marker = json.loads((out / ".psdesign-output.json").read_text())
            marker["files"] = [f for f in marker["files"] if f != name]
            (out / ".psdesign-output.json").write_text(json.dumps(marker))
            (out / name).write_text("user's own\n")
        else:
            out.mkdir()
            (out / "user_notes.txt").write_text("mine\n")
    before = files_of(out) if out.exists() else {}
    p = run_sc(sc, out, args)
    n, tb = _lines(p.stderr)
    row = Row(sc.name, "refuse", case, p.returncode, n, tb)
    row.note = (p.stderr.strip().splitlines() or [""])[-1][:110]
    after = files_of(out) if out.exists() else {}
    row.prior_lost = sorted(r for r in set(before) | set(after) if before.get(r) != after.get(r))
    row.leftovers = temps_under(base)
    row.rerun_ok = None
    if p.returncode != 2:
        row.note = f"expected exit 2: {row.note}"
        row.lines = 99
    if case == "readonly":
        umount()
    return row


def main() -> int:
    global MOUNT, WORK
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spec", type=Path, required=True)
    ap.add_argument("--study", type=Path, required=True)
    ap.add_argument("--ffspec", type=Path, help="forcefield spec of a paper case (two-fiber)")
    ap.add_argument("--relaxspec", type=Path, help="RVE spec with [forcefield.relax]")
    ap.add_argument("--optstudy", type=Path, help="study of {low, high} ranges (optimize)")
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS), choices=list(SCENARIOS))
    ap.add_argument("--modes", nargs="+", default=["refuse", "enospc", "kill"])
    ap.add_argument("--sizes", nargs="+", default=["40k", "120k", "300k", "1m", "3m"])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seed", type=int, default=35)
    ap.add_argument(
        "--kill-within",
        type=float,
        default=0.8,
        help="kill times uniform in [0.3 s, this fraction of the clean run's time]",
    )
    ap.add_argument("--prior", action="store_true", help="also ENOSPC over a prior good output")
    ap.add_argument("--mount", type=Path, default=MOUNT, help="tmpfs mount point (created)")
    ap.add_argument("--work", type=Path, default=WORK, help="folder of the clean and killed runs")
    args = ap.parse_args()
    MOUNT, WORK = args.mount, args.work
    for k in ("spec", "study", "ffspec", "relaxspec", "optstudy"):
        if getattr(args, k) is not None:
            setattr(args, k, getattr(args, k).resolve())
    rng = random.Random(args.seed)
    WORK.mkdir(parents=True, exist_ok=True)
    refs: dict[str, Scenario] = {}
    names = list(args.scenarios)
    if any(SCENARIOS[n].setup == "study" for n in names) and "study_run" not in names:
        names.insert(0, "study_run")
    rows: list[Row] = []
    try:
        for name in names:
            sc = SCENARIOS[name]
            make_reference(sc, args, refs)
            refs[name] = sc
            if name not in args.scenarios:
                continue
            todo = []
            if "refuse" in args.modes and sc.target != "stdout":  # the shell opens stdout
                todo += [("refuse", c) for c in ("readonly", "file", "user_files")]
            if "enospc" in args.modes:
                todo += [("enospc", (s, False)) for s in args.sizes]
                if args.prior and sc.target == "dir":  # nothing is ever written over a file
                    todo += [("enospc", (s, True)) for s in args.sizes]
            if "kill" in args.modes:
                todo += [("kill", t) for t in range(args.trials)]
            for mode, p in todo:
                if mode == "refuse":
                    row = audit_refuse(sc, args, refs, p)
                elif mode == "enospc":
                    row = audit_enospc(sc, args, refs, *p)
                else:
                    row = audit_kill(sc, args, refs, p, rng)
                rows.append(row)
                print(
                    f"{row.scenario:20s} {row.mode:7s} {row.param:18s} rc={row.rc:<4d} "
                    f"lines={row.lines} tb={int(row.traceback)} temps={len(row.leftovers)} "
                    f"partial={row.partial[:3]} lost={row.prior_lost[:3]} rerun={row.rerun_ok} "
                    f"{'OK ' if row.ok else 'BAD'} {row.note}",
                    flush=True,
                )
    finally:
        umount()
    print("\n| scenario | mode | trials | ok | failures |")
    print("|---|---|---|---|---|")
    for (scn, mode), grp in pd.DataFrame([r.__dict__ | {"ok": r.ok} for r in rows]).groupby(
        ["scenario", "mode"], sort=False
    ):
        bad = grp[~grp["ok"]]
        print(
            f"| {scn} | {mode} | {len(grp)} | {int(grp['ok'].sum())} | "
            f"{'; '.join(bad['param'].astype(str))[:120]} |"
        )
    return 0 if all(r.ok for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
