"""Reproducibility audit: the same spec and seed run several ways, every output file compared.

Session 35 (``benchmarks/RESULTS.md``, "Session 35: reproducibility audit").  A tiny study (two
porosities x two seeds, 20 um cube, voxel route: seconds per case) is run once as the reference
(CLI, one worker, cwd = the repository, ``TZ=UTC``, ``PYTHONHASHSEED=0``, ``LC_ALL=C.UTF-8``) and
then once per *way* below; every file of each folder is compared with the reference's byte by
byte.  The single-RVE commands (``generate``, ``mesh --format ...``, ``permeability --fields``,
``rev``) and the study follow-ups (``study report``, ``fit``, ``predict``, ``optimize``) are run
three times: in the reference setting, again in it (``same``), and in a changed one (``other``:
another cwd, a longer output path, ``TZ``, ``PYTHONHASHSEED`` and ``LC_ALL`` changed, numba and
BLAS on one thread).  A command's ``--json`` stdout is compared too, without the keys that
describe the run (``RUN_KEYS``: wall times, peak memory, threads used).

Verdicts per file:

* ``identical``: the bytes agree;
* ``timing only``: they differ only in what docs/study-files.md documents as run metadata (the
  timing columns of the tables, a case record's ``started_at`` ... ``pid`` and ``time_*_s``,
  ``run.json``, ``*_timings.json``, and the report once those are put back to the reference's
  values and the report is rebuilt from them);
* ``DIFFERS (...)``: anything else, with the first difference.

Usage::

    python benchmarks/audit_reproducibility.py [--work /tmp/audit] [--only WAY ...]

Each run is a child process with ``PYTHONPATH`` set to this checkout.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from psdesign.study.store import TIMING_COLUMNS, is_timing_column  # noqa: E402

SPEC = """\
[rve]
size = [20e-6, 20e-6, 20e-6]
voxel = 1e-6

[generator]
kind = "straight"
porosity = 0.85
porosity_tolerance = 0.03
diameter = 4e-6
seed = 1
theta = { dist = "uniform", low = -5.0, high = 5.0 }
omega = { dist = "uniform", low = 0.0, high = 180.0 }

[intersections]
method = "fast"
min_gap = 0.5e-6

[flow]
solver = "voxel"
viscosity = 1.8e-5
"""

STUDY_TAIL = """
[study]
name = "tiny"
design = "full-factorial"
seeds = [1, 2]
outputs = ["porosity", "k_z"]
solver = "voxel"

[parameters]
"generator.porosity" = [0.85, 0.9]
"""

OPT_TAIL = """
[study]
name = "tiny-opt"
design = "latin-hypercube"
n_samples = 2
seeds = [1]
outputs = ["porosity", "k_z"]
solver = "voxel"

[parameters]
"generator.porosity" = { low = 0.82, high = 0.9 }
"""

BASE_ENV = {"TZ": "UTC", "PYTHONHASHSEED": "0", "LC_ALL": "C.UTF-8", "LANG": "C.UTF-8"}
OTHER_ENV = {"TZ": "Asia/Tokyo", "PYTHONHASHSEED": "1", "LC_ALL": "C", "LANG": "C"}
#: The single-RVE commands' changed setting also runs numba and BLAS on one thread (the
#: reference: the machine's default, all CPUs).
THREADS_1 = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
RECORD_TIMING = (*TIMING_COLUMNS,)


def study_text() -> str:
    """The tiny study: the spec's tables under ``base.`` plus the study tables."""
    base = SPEC.replace("[rve]", "[base.rve]").replace("[generator]", "[base.generator]")
    base = base.replace("[intersections]", "[base.intersections]").replace("[flow]", "[base.flow]")
    return base + STUDY_TAIL


def optimize_text() -> str:
    return study_text().split("[study]")[0] + OPT_TAIL


# ------------------------------------------------------------------------------ running


def env_of(extra: dict[str, str] | None = None) -> dict[str, str]:
    env = dict(os.environ)
    env.update(BASE_ENV)
    env["PYTHONPATH"] = str(REPO)
    env.update(extra or {})
    return env


def psd(
    args: list[str], *, env: dict | None = None, cwd: Path = REPO, check: bool = True
) -> subprocess.CompletedProcess:
    """Run ``python -m psdesign ARGS``; stdout kept, stderr kept for a failure."""
    proc = subprocess.run(
        [sys.executable, "-m", "psdesign", *args],
        cwd=cwd,
        env=env_of(env),
        capture_output=True,
        text=True,
        check=False,
    )
    if check and proc.returncode not in (0, 3):  # 3: complete, a result not converged
        raise RuntimeError(f"psdesign {' '.join(args)}: exit {proc.returncode}\n{proc.stderr}")
    return proc


def study_cli(out: Path, *extra: str, env: dict | None = None, cwd: Path = REPO, spec=None):
    spec = spec or WORK / "tiny.toml"
    return psd(["study", "run", str(spec), "-o", str(out), "--quiet", *extra], env=env, cwd=cwd)


def study_api(out: Path, **kw) -> None:
    code = (
        "import psdesign\n"
        "if __name__ == '__main__':\n"
        f"    psdesign.run_study({str(WORK / 'tiny.toml')!r}, {str(out)!r}, progress=False, "
        + ", ".join(f"{k}={v!r}" for k, v in kw.items())
        + ")\n"
    )
    script = WORK / f"api_{out.name}.py"
    script.write_text(code)
    subprocess.run([sys.executable, str(script)], cwd=REPO, env=env_of(), check=True)


def killed_then_resumed(out: Path) -> None:
    """SIGKILL the run's process group a seeded random delay after its first case record (so
    the kill lands mid-study at any load), then rerun the same command to resume."""
    delay = random.Random(35).uniform(0.0, 6.0)
    cmd = [sys.executable, "-m", "psdesign", "study", "run", str(WORK / "tiny.toml")]
    proc = subprocess.Popen(
        [*cmd, "-o", str(out), "--quiet"],
        cwd=REPO,
        env=env_of(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    t0 = time.monotonic()
    while not list((out / "cases").glob("*.json")) and time.monotonic() - t0 < 600:
        time.sleep(0.2)
    time.sleep(delay)
    done = len(list((out / "cases").glob("*.json"))) if (out / "cases").is_dir() else 0
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    msg = f"  killed {delay:.1f} s after the first record, {done} case record(s) written"
    print(msg, file=sys.stderr)
    study_cli(out)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def dask_cli(out: Path) -> None:
    """``--scheduler tcp://127.0.0.1:PORT``: a ``dask scheduler`` + ``dask worker`` started here."""
    dask = shutil.which("dask")
    if dask is None:
        raise RuntimeError("dask CLI not installed")
    port = free_port()
    env = env_of()
    logs = open(WORK / "dask.log", "w")  # noqa: SIM115 - closed below
    sched = subprocess.Popen(
        [dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
        env=env,
        stdout=logs,
        stderr=logs,
        start_new_session=True,
    )
    work = subprocess.Popen(
        [dask, "worker", f"tcp://127.0.0.1:{port}", "--nworkers", "1", "--nthreads", "1"]
        + ["--no-dashboard", "--host", "127.0.0.1"],
        env=env,
        cwd=WORK,
        stdout=logs,
        stderr=logs,
        start_new_session=True,
    )
    try:
        study_cli(out, "--scheduler", f"tcp://127.0.0.1:{port}")
    finally:
        for p in (work, sched):
            os.killpg(p.pid, signal.SIGTERM)
            p.wait()
        logs.close()


# ------------------------------------------------------------------------------ comparing


def files_of(folder: Path) -> dict[str, Path]:
    return {str(p.relative_to(folder)): p for p in sorted(folder.rglob("*")) if p.is_file()}


def _first_diff(a: bytes, b: bytes) -> str:
    try:
        ta, tb = a.decode(), b.decode()
    except UnicodeDecodeError:
        i = next(
            (i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y), min(len(a), len(b))
        )
        return f"binary, {len(a)} vs {len(b)} bytes, first at byte {i}"
    la, lb = ta.splitlines(), tb.splitlines()
    n = sum(1 for x, y in zip(la, lb, strict=False) if x != y) + abs(len(la) - len(lb))
    i = next((i for i, (x, y) in enumerate(zip(la, lb, strict=False)) if x != y), None)
    if i is None:
        return f"{n} line(s) differ (lengths {len(la)} vs {len(lb)})"
    x, y = la[i], lb[i]
    j = next((j for j, (c, d) in enumerate(zip(x, y, strict=False)) if c != d), 0)
    lo, hi = max(0, j - 30), j + 40
    return f"{n} line(s) differ; line {i + 1}: {x[lo:hi]!r} vs {y[lo:hi]!r}"


def _frame_diff(a: pd.DataFrame, b: pd.DataFrame) -> str | None:
    """None when the frames agree outside the timing columns, else the first difference."""
    ka = [c for c in a.columns if not is_timing_column(c)]
    kb = [c for c in b.columns if not is_timing_column(c)]
    if ka != kb:
        return f"columns {sorted(set(ka) ^ set(kb))}"
    for c in ka:
        x, y = a[c], b[c]
        for i, (u, v) in enumerate(zip(x, y, strict=True)):
            if not (u == v or (pd.isna(u) and pd.isna(v))):
                rel = ""
                try:
                    rel = f", rel {abs(float(u) - float(v)) / max(abs(float(u)), 1e-300):.1e}"
                except (TypeError, ValueError):
                    pass
                return f"{c} row {i}: {str(u)[:60]!r} vs {str(v)[:60]!r}{rel}"
    return None


def _strip_record(d: dict) -> dict:
    d = {k: v for k, v in d.items() if k not in RECORD_TIMING}
    if isinstance(d.get("results"), dict):
        d["results"] = {k: v for k, v in d["results"].items() if not is_timing_column(k)}
    return d


def _report_equalized(ref: Path, other: Path) -> bytes | None:
    """``other``'s report rebuilt with ``ref``'s timing columns and run history."""
    from psdesign.report.html import build_html

    tmp = WORK / "_equalize"
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(other, tmp)
    try:
        a = pd.read_csv(ref / "results.csv")
        b = pd.read_csv(tmp / "results.csv")
        if list(a["case_id"]) != list(b["case_id"]):
            return None
        # the reference's run metadata in its place; a metadata column only one run has (e.g.
        # ``thread_note_z``: the other ran on one thread) is metadata too
        b = b[[c for c in b.columns if not is_timing_column(c)]].copy()
        for c in a.columns:
            if is_timing_column(c):
                b[c] = a[c]
        b = b[[c for c in a.columns if c in b.columns] + [c for c in b.columns if c not in a]]
        (tmp / "results.csv").write_text(b.to_csv(index=False))
        shutil.copy(ref / "run.json", tmp / "run.json")
        return build_html(tmp).encode("utf-8")
    except Exception as exc:  # noqa: BLE001 - a verdict, not a crash
        return f"rebuild failed: {exc}".encode()


def verdict(rel: str, a: Path, b: Path, ref_dir: Path, other_dir: Path) -> str:
    x, y = a.read_bytes(), b.read_bytes()
    if x == y:
        return "identical"
    name = Path(rel).name
    if name == "run.json":
        return "timing only (run history)"
    if name.endswith("_timings.json"):  # psdesign/io/timings.py: wall times kept apart
        return "timing only (wall times)"
    if name.endswith(".csv") and rel.split("/")[-1] in ("results.csv", "summary.csv", "rev.csv"):
        d = _frame_diff(pd.read_csv(io.BytesIO(x)), pd.read_csv(io.BytesIO(y)))
        return "timing only" if d is None else f"DIFFERS ({d})"
    if name.endswith(".parquet"):
        d = _frame_diff(pd.read_parquet(a), pd.read_parquet(b))
        return "timing only" if d is None else f"DIFFERS ({d})"
    if rel.startswith("cases/") and name.endswith(".json"):
        if _strip_record(json.loads(x)) == _strip_record(json.loads(y)):
            return "timing only"
    if name == "report.html" and (ref_dir / "results.csv").is_file():
        eq = _report_equalized(ref_dir, other_dir)
        if eq == x:
            return "timing only"
        if eq is not None:
            return f"DIFFERS (after equalizing timings: {_first_diff(x, eq)})"
    return f"DIFFERS ({_first_diff(x, y)})"


def compare(ref: Path, other: Path) -> dict[str, str]:
    fa, fb = files_of(ref), files_of(other)
    out = {}
    for rel in sorted(set(fa) | set(fb)):
        if rel not in fb:
            out[rel] = "DIFFERS (missing)"
        elif rel not in fa and Path(rel).name == "case.log":
            out[rel] = "extra: case.log (documented; --timeout's child writes its progress lines)"
        elif rel not in fa:
            out[rel] = "DIFFERS (extra file)"
        else:
            out[rel] = verdict(rel, fa[rel], fb[rel], ref, other)
    return out


#: Keys of a command's ``--json`` line that describe the run, not the result: wall times, peak
#: memory, and the threads a solve ran on (``threads_used`` / ``thread_note``); and the timing
#: columns of a results row (``study optimize`` prints its best case's row).
RUN_KEYS = ("wall_time_s", "timings_s", "peak_memory_gb", "threads_used", "thread_note")


def _strip_run_keys(v):
    if isinstance(v, dict):
        return {
            k: _strip_run_keys(x)
            for k, x in v.items()
            if k not in RUN_KEYS and not is_timing_column(k)  # a results row's timing columns
        }
    if isinstance(v, list):
        return [_strip_run_keys(x) for x in v]
    return v


def compare_text(a: str, b: str) -> str:
    """Two stdout texts (or files read as text): identical, timing only, or the difference."""
    if a == b:
        return "identical"
    try:
        ja = [_strip_run_keys(json.loads(line)) for line in a.splitlines() if line.strip()]
        jb = [_strip_run_keys(json.loads(line)) for line in b.splitlines() if line.strip()]
    except ValueError:
        ja, jb = None, None
    if ja is not None and ja == jb:
        return "timing only"
    return f"DIFFERS ({_first_diff(a.encode(), b.encode())})"


# ------------------------------------------------------------------------------ the ways

WORK = Path("/tmp/psdesign-audit")


def study_ways() -> dict[str, Callable[[Path], None]]:
    other_cwd = WORK / "elsewhere"
    return {
        "repeat": lambda o: study_cli(o),
        "workers-2": lambda o: study_cli(o, "--workers", "2"),
        "timeout-child": lambda o: study_cli(o, "--timeout", "900"),  # a child per case
        "api": lambda o: study_api(o, workers=1),
        "api-dask-local": lambda o: study_api(o, workers=2, scheduler="local"),
        "dask-cli": dask_cli,
        "numba-1": lambda o: study_cli(o, env={"NUMBA_NUM_THREADS": "1"}),
        "numba-2": lambda o: study_cli(o, env={"NUMBA_NUM_THREADS": "2"}),
        "omp-active": lambda o: study_cli(o, env={"OMP_WAIT_POLICY": "ACTIVE"}),
        "killed-resumed": killed_then_resumed,
        "cwd+path": lambda o: study_cli(
            other_cwd / "a" / "much" / "longer" / o.name, cwd=other_cwd, spec=Path("copy/tiny.toml")
        ),
        "tz+hash+locale": lambda o: study_cli(o, env=OTHER_ENV),
    }


def run_study_ways(only: set[str] | None, rows: list[tuple[str, str, str]]) -> Path:
    ref = WORK / "study-ref"
    if not ref.is_dir():
        study_cli(ref)
    for way, fn in study_ways().items():
        if only and way not in only:
            continue
        out = WORK / f"study-{way}"
        t0 = time.time()
        try:
            fn(out)
        except Exception as exc:  # noqa: BLE001 - one row says why
            rows.append((way, "*", f"NOT RUN ({str(exc).splitlines()[0][:80]})"))
            continue
        if way == "cwd+path":
            out = WORK / "elsewhere" / "a" / "much" / "longer" / out.name
        print(f"  {way}: {time.time() - t0:.0f} s", file=sys.stderr)
        for rel, v in compare(ref, out).items():
            rows.append((f"study run {way}", rel, v))
    return ref


def run_followups(ref: Path, only: set[str] | None, rows: list[tuple[str, str, str]]) -> None:
    """study report / fit / predict / optimize, and the single-RVE commands, twice each."""
    spec = WORK / "spec.toml"
    big = WORK / "spec72.toml"
    other_cwd = WORK / "elsewhere"
    settings = {
        "same": ({}, REPO, WORK / "b"),
        "other": ({**OTHER_ENV, **THREADS_1}, other_cwd, other_cwd / "x" / "y"),
    }

    if not only or "report" in only:
        copy = WORK / "report-copy"
        shutil.rmtree(copy, ignore_errors=True)
        shutil.copytree(ref, copy)
        for s, (env, cwd, _root) in settings.items():
            psd(["study", "report", str(copy)], env=env, cwd=cwd)
            rows.append((f"study report ({s})", "report.html", compare(ref, copy)["report.html"]))

    if not only or "fit" in only:
        texts: dict[str, list[str]] = {}
        for s, (env, cwd, root) in {"ref": ({}, REPO, WORK / "a"), **settings}.items():
            folder = root / "fit"
            shutil.rmtree(folder, ignore_errors=True)
            shutil.copytree(ref, folder)
            fit = psd(["study", "fit", str(folder), "--json"], env=env, cwd=cwd)
            pred = psd(
                ["study", "predict", str(folder), "--at", "generator.porosity=0.87", "--json"],
                env=env,
                cwd=cwd,
            )
            texts[s] = [fit.stdout, pred.stdout, (folder / "surrogate.json").read_text()]
        for s in settings:
            for i, what in enumerate(
                ("study fit stdout", "study predict stdout", "surrogate.json")
            ):
                rows.append(
                    (f"study fit/predict ({s})", what, compare_text(texts["ref"][i], texts[s][i]))
                )

    # command lines (split on spaces); SPEC / OPT: the spec and optimize study files (an
    # absolute path in the reference setting, a relative one to a copy in the other), OUT
    single = {
        "generate": "generate SPEC -o OUT --format tiff --quiet",
        "mesh": "mesh SPEC -o OUT --format vtu msh fluent stl openfoam --quiet",
        "permeability": "permeability SPEC --direction z --solver voxel --json --fields OUT "
        "--quiet",
        "permeability-fem": "permeability SPEC --direction z --solver fem --json "
        "--no-error-estimate --fields OUT --quiet",
        # 72^3 = 373 k cells: above SOLVE_PARALLEL_MIN_CELLS, so the voxel solve runs on the
        # numba threads (2 here, 1 in 'other'; threads_used in the JSON says what it ran on)
        "permeability-72": "permeability BIG --direction z --solver voxel --json --fields OUT "
        "--quiet",
        "rev": "rev SPEC --sizes 15e-6 20e-6 --seeds 2 -o OUT --quiet --json",
        "optimize": "study optimize OPT -o OUT --target k_z_m2=1e-12+-20% --budget 4 --batch 2 "
        "--seed 3 --quiet --json",
    }
    files = {"ref": (spec, WORK / "opt.toml"), "same": (spec, WORK / "opt.toml")}
    files["other"] = (Path("copy/spec.toml"), Path("copy/opt.toml"))
    for name, line in single.items():
        if only and name not in only:
            continue
        outs = {}
        for s, (env, cwd, root) in {"ref": ({}, REPO, WORK / "a"), **settings}.items():
            o = root / name
            shutil.rmtree(o, ignore_errors=True)
            sp, op = files[s]
            argv = [
                {"SPEC": str(sp), "OPT": str(op), "OUT": str(o), "BIG": str(big)}.get(a, a)
                for a in line.split()
            ]
            proc = psd(argv, env=env, cwd=cwd)
            (WORK / f"{name}-{s}.stdout").write_text(proc.stdout)
            outs[s] = (o, proc.stdout)
        for s in settings:
            ra, rb = outs["ref"], outs[s]
            stdout = ra[1].replace(str(ra[0]), "OUT") if ra[1] else ""
            v = compare_text(stdout, rb[1].replace(str(rb[0]), "OUT"))
            rows.append((f"{name} ({s})", "stdout", v))
            for rel, v in compare(ra[0], rb[0]).items():
                rows.append((f"{name} ({s})", rel, v))


def summarize(rows: list[tuple[str, str, str]]) -> str:
    """One line per way: files identical / timing only / extra logs, and every other verdict."""
    ways: dict[str, dict] = {}
    for way, rel, v in rows:
        w = ways.setdefault(way, {"identical": 0, "timing only": 0, "extra": 0, "other": []})
        key = "timing only" if v.startswith("timing only") else v.split(":")[0]
        if key in w:
            w[key] += 1
        else:
            w["other"].append(f"{rel}: {v}")
    lines = [
        "| way | identical | timing only | extra log | differs |",
        "| --- | --- | --- | --- | --- |",
    ]
    for way, w in ways.items():
        other = "; ".join(w["other"]) or "-"
        lines.append(f"| {way} | {w['identical']} | {w['timing only']} | {w['extra']} | {other} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    global WORK
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=WORK, help="scratch folder (replaced)")
    ap.add_argument("--only", nargs="*", help="ways / commands to run (default all)")
    ap.add_argument("--keep", action="store_true", help="keep an existing scratch folder")
    ns = ap.parse_args(argv)
    WORK = ns.work.resolve()
    if not ns.keep:
        shutil.rmtree(WORK, ignore_errors=True)
    (WORK / "elsewhere").mkdir(parents=True, exist_ok=True)
    (WORK / "tiny.toml").write_text(study_text())
    (WORK / "elsewhere" / "copy").mkdir()
    (WORK / "elsewhere" / "copy" / "tiny.toml").write_text(study_text())  # the same, elsewhere
    (WORK / "spec.toml").write_text(SPEC)
    big = SPEC.replace("[20e-6, 20e-6, 20e-6]", "[36e-6, 36e-6, 36e-6]")
    (WORK / "spec72.toml").write_text(big.replace("voxel = 1e-6", "voxel = 0.5e-6"))
    (WORK / "opt.toml").write_text(optimize_text())
    (WORK / "elsewhere" / "copy" / "spec.toml").write_text(SPEC)
    (WORK / "elsewhere" / "copy" / "opt.toml").write_text(optimize_text())
    only = set(ns.only) if ns.only else None
    rows: list[tuple[str, str, str]] = []
    t0 = time.time()
    ref = run_study_ways(only, rows)
    run_followups(ref, only, rows)
    print(summarize(rows) + "\n")
    print("| way | file | verdict |\n| --- | --- | --- |")
    for way, rel, v in rows:
        print(f"| {way} | {rel} | {v} |")
    bad = [r for r in rows if r[2].startswith(("DIFFERS", "NOT RUN"))]
    print(f"\n{len(rows)} comparisons, {len(bad)} differ or not run; {time.time() - t0:.0f} s")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
