"""dask-jobqueue clusters for the runner: the job scripts a Slurm or PBS site would receive."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from psdesign.study.cluster import ClusterOptions, job_script

_sigint = signal.getsignal(signal.SIGINT)
pytest.importorskip("dask_jobqueue")
# dask_jobqueue's import replaces the SIGINT handler with sys.exit(): the other test files of
# this worker process keep Python's (psdesign.study.cluster._import_jobqueue keeps it too)
signal.signal(signal.SIGINT, _sigint)


def test_importing_jobqueue_keeps_the_sigint_handler() -> None:
    """``dask_jobqueue.runner`` installs ``lambda *_: sys.exit()`` for SIGINT on import, so a
    Ctrl-C in ``study run --cluster`` became a bare SystemExit (exit 0, no "interrupted"
    line); psdesign imports it with the handler kept (a fresh interpreter: the import
    happens once)."""
    code = (
        "import signal\n"
        "from psdesign.study.cluster import _import_jobqueue\n"
        "_import_jobqueue()\n"
        "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True", out.stderr


def test_slurm_job_script_carries_the_resources() -> None:
    s = job_script(
        ClusterOptions(
            "slurm",
            cores=4,
            memory="16GB",
            walltime="02:00:00",
            queue="short",
            account="proj",
            job_extra=("--constraint=ib",),
        )
    )
    assert "#SBATCH -p short" in s and "#SBATCH -A proj" in s
    assert "#SBATCH -t 02:00:00" in s and "#SBATCH --cpus-per-task=4" in s
    assert "#SBATCH --constraint=ib" in s
    # one case at a time on the job's 4 cores: a worker of 4 threads ran 4 cases at once, each
    # with 4 solver threads (16 on 4 cores, session 42)
    assert "export NUMBA_NUM_THREADS=4" in s and "--nthreads 1 " in s.replace("=", " ")


def test_pbs_job_script() -> None:
    s = job_script(ClusterOptions("pbs", cores=2, memory="8GB", walltime="00:30:00", queue="q"))
    assert "#PBS -q q" in s and "#PBS -l walltime=00:30:00" in s and "ncpus=2" in s
    assert "ncpus=2:mem=7630MB" in s and "--nthreads 1 " in s.replace("=", " ")


@pytest.mark.parametrize(
    ("kw", "key"),
    [
        ({"kind": "lsf"}, "kind"),
        ({"kind": 3}, "kind"),
        ({"kind": "slurm", "cores": 0}, "cores"),
        ({"kind": "slurm", "cores": True}, "cores"),  # taken as 1 core until session 47
        ({"kind": "pbs", "walltime": "2h"}, "walltime"),
        ({"kind": "pbs", "walltime": "01:75:00"}, "walltime"),
        ({"kind": "pbs", "walltime": "00:00:00"}, "walltime"),
        ({"kind": "slurm", "memory": "banana"}, "memory"),
        ({"kind": "slurm", "memory": "-5GB"}, "memory"),
        ({"kind": "slurm", "memory": "0"}, "memory"),
        ({"kind": "slurm", "wait_s": 0}, "wait_s"),
        ({"kind": "slurm", "wait_s": float("inf")}, "wait_s"),
        ({"kind": "slurm", "wait_s": "soon"}, "wait_s"),
        # taken until session 47: an int queue or account reached dask-jobqueue, a text with
        # a newline wrote a directive of its own, job_extra=3 / "--x" (one per character)
        ({"kind": "slurm", "queue": 3}, "queue"),
        ({"kind": "slurm", "queue": ""}, "queue"),
        ({"kind": "slurm", "queue": "short\n#SBATCH --exclusive"}, "queue"),
        ({"kind": "pbs", "account": 3}, "account"),
        ({"kind": "slurm", "job_extra": 3}, "job_extra"),
        ({"kind": "slurm", "job_extra": "--constraint=ib"}, "job_extra"),
        ({"kind": "slurm", "job_extra": (3,)}, "job_extra"),
        ({"kind": "slurm", "job_extra": ("a\nb",)}, "job_extra"),
        # session 47 review: '0²' passed str.isdigit, then int() raised a bare ValueError; the
        # Arabic-Indic digits were taken into the job script; '1e400GB' was an OverflowError
        # traceback; an array's repr made the refusal several lines
        ({"kind": "slurm", "walltime": "01:00:0\u00b2"}, "walltime"),
        ({"kind": "slurm", "walltime": "\u0660\u0661:\u0660\u0660:\u0660\u0660"}, "walltime"),
        ({"kind": "slurm", "memory": "1e400GB"}, "memory"),
        ({"kind": "slurm", "job_extra": np.array(["--a"] * 40)}, "job_extra"),
        ({"kind": "slurm", "cores": np.ones((3, 3), int)}, "cores"),
    ],
)
def test_bad_cluster_options_name_the_field(kw, key) -> None:
    """From Python each refusal is one StudyError line naming the field (main named the
    command line's ``--cluster-*`` flags, and took the wrong types marked above); the
    command spells the field as its flag (``test_cli_bad_cluster_resources_exit_2_...``)."""
    from psdesign.errors import StudyError

    with pytest.raises(StudyError) as info:
        ClusterOptions(**kw)
    assert info.value.key == key and str(info.value).startswith(f"{key}: "), info.value
    assert "\n" not in str(info.value)


def test_cluster_options_take_numpy_cores_and_a_list_of_directives() -> None:
    # np.int64(4) was refused "--cluster-cores: must be an integer >= 1, got np.int64(4)"
    opts = ClusterOptions("slurm", cores=np.int64(4), job_extra=["--constraint=ib"])
    assert opts.cores == 4 and type(opts.cores) is int
    assert opts.job_extra == ("--constraint=ib",) and hash(opts)


def test_study_runs_through_a_cluster_option(tmp_path, monkeypatch) -> None:
    # no batch system here: stand a LocalCluster in for the Slurm one and check the wiring
    # (ClusterOptions -> make_cluster -> scale(jobs=workers) -> cases run on its workers)
    from distributed import LocalCluster
    from study_cases import FACTORIAL, fake_case, write_study

    from psdesign.study import cluster as cluster_mod
    from psdesign.study import run_study

    scaled = []

    class FakeSlurm(LocalCluster):
        def scale(self, n=None, jobs=0, **kw):
            scaled.append(jobs)
            return super().scale(jobs)

    def fake_make(opts):
        assert opts.kind == "slurm" and opts.cores == 1
        return FakeSlurm(n_workers=0, threads_per_worker=1, processes=True, dashboard_address=None)

    monkeypatch.setattr(cluster_mod, "make_cluster", fake_make)
    _fake_sbatch_on_path(tmp_path, monkeypatch)
    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    df = run_study(
        p,
        tmp_path / "o",
        workers=2,
        scheduler=ClusterOptions("slurm", cores=1),
        case_fn=fake_case,
        progress=False,
        report=False,
    )
    assert scaled[0] == 2 and len(df) == 4 and set(df["status"]) == {"ok"}


def _fake_sbatch_on_path(tmp_path, monkeypatch, **scripts: str) -> Path:
    """Fake batch commands (``sbatch`` exits 1 unless given) first on PATH; returns the folder."""
    bindir = tmp_path / "bin"
    bindir.mkdir()
    for name, body in {"sbatch": "exit 1\n", **scripts}.items():
        (bindir / name).write_text("#!/bin/sh\n" + body)
        (bindir / name).chmod(0o755)
    monkeypatch.setenv("PATH", f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}")
    return bindir


def _folder_state(out: Path) -> dict[str, bytes]:
    return {str(f.relative_to(out)): f.read_bytes() for f in sorted(out.rglob("*")) if f.is_file()}


@pytest.fixture
def dask_port_taken():
    """Port 8787 (dask's default HTTP port) held, as by another dask on the machine: the
    refusal test below failed in session 53 while a walker's `dask scheduler` held it."""
    import socket

    sock = socket.socket()
    try:
        sock.bind(("0.0.0.0", 8787))
        sock.listen(1)
    except OSError:
        pass  # already held by someone else: the condition under test holds anyway
    yield
    sock.close()


def test_schedulers_psdesign_starts_take_no_fixed_http_port(dask_port_taken) -> None:
    """dask serves HTTP routes even without a dashboard and, given no address, takes port 8787
    or warns "Port 8787 is already in use" (a stray stderr line under psdesign's one-line
    messages). Truth: the local Dask cluster and the Slurm/PBS scheduler bind a loopback port
    the OS picks, with port 8787 held, and no warning is logged."""
    import logging

    from psdesign.study.cluster import make_cluster
    from psdesign.study.runner import connect_scheduler

    records: list[logging.LogRecord] = []
    handler = logging.Handler()
    handler.emit = records.append
    logging.getLogger("distributed").addHandler(handler)
    try:
        client, cluster = connect_scheduler("local", 1)
        try:
            host, port = cluster.scheduler.http_server.address, cluster.scheduler.http_server.port
        finally:
            client.close()
            cluster.close()
        batch = make_cluster(ClusterOptions(kind="slurm"))
        try:
            batch_http = batch.scheduler.http_server
            batch_host, batch_port = batch_http.address, batch_http.port
        finally:
            batch.close()
    finally:
        logging.getLogger("distributed").removeHandler(handler)
    assert (host, batch_host) == ("127.0.0.1", "127.0.0.1")
    assert 8787 not in (port, batch_port)
    assert not [r.getMessage() for r in records if "8787" in r.getMessage()]


def test_refused_submission_stops_with_sbatchs_words_and_keeps_the_study(
    tmp_path, monkeypatch, dask_port_taken
) -> None:
    """A refused sbatch (bad partition) was only logged by dask-jobqueue and the runner waited
    for workers forever (here: the subprocess timeout); now one line with sbatch's error text,
    exit 2, at once (well before the 600 s default wait), and the resumable folder untouched."""
    from study_cases import FACTORIAL, TESTS_DIR, fake_case, write_study

    from psdesign.study import run_study

    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "o"
    df = run_study(p, out, workers=0, case_fn=fake_case, progress=False, report=False)
    (out / "cases" / f"{df['case_id'][1]}.json").unlink()  # one case left to run
    before = _folder_state(out)
    _fake_sbatch_on_path(
        tmp_path,
        monkeypatch,
        sbatch="echo 'sbatch: error: invalid partition specified: nosuch' >&2\nexit 1\n",
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS_DIR.parent), str(TESTS_DIR)])}
    cmd = [sys.executable, "-m", "psdesign", "study", "run", str(p), "-o", str(out)]
    cmd += ["--cluster", "slurm", "--cluster-queue", "nosuch", "--quiet", "--no-report"]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    # the streams in every message: this test failed once in a full run at load ~6 (session
    # 34) and passed in every rerun; the next failure must say which line was extra
    said = f"stdout {proc.stdout!r} stderr {proc.stderr!r}"
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, said
    assert "sbatch" in proc.stderr and "invalid partition specified: nosuch" in proc.stderr, said
    assert _folder_state(out) == before, said


def test_no_worker_within_cluster_wait_stops_and_cancels_the_job(
    tmp_path, monkeypatch, capsys
) -> None:
    """sbatch accepts the job but no worker ever connects (queue stuck): the runner waited
    forever; now it stops after --cluster-wait seconds, cancels the job (scancel 4242), exits 2
    with one line naming --cluster-wait, and creates no output folder."""
    from study_cases import FACTORIAL, write_study

    from psdesign.cli.study import main

    bindir = _fake_sbatch_on_path(
        tmp_path,
        monkeypatch,
        sbatch="echo 'Submitted batch job 4242'\n",
        scancel=f'echo "$@" >> "{tmp_path}/scancel.txt"\n',
    )
    assert bindir.is_dir()
    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "o"
    argv = ["study", "run", str(p), "-o", str(out), "--cluster", "slurm", "--quiet"]
    rc = main([*argv, "--cluster-wait", "1.5"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("psdesign: error: --cluster-wait: no worker connected within 1.5 s")
    assert (tmp_path / "scancel.txt").read_text().split() == ["4242"]
    assert not out.exists()


@pytest.mark.parametrize(("kind", "cmd"), [("slurm", "sbatch"), ("pbs", "qsub")])
def test_cluster_without_its_submit_command_is_refused_before_any_work(
    tmp_path, monkeypatch, capsys, kind, cmd
) -> None:
    # no sbatch/qsub: dask-jobqueue only logged each failed submission (tracebacks) and the
    # runner waited forever for workers, after writing study.json into the output folder
    from study_cases import FACTORIAL, write_study

    from psdesign.cli.study import main
    from psdesign.study import cluster as cluster_mod

    def must_not_submit(opts):
        raise AssertionError("a batch cluster was started without its submit command")

    monkeypatch.setattr(cluster_mod, "make_cluster", must_not_submit)
    empty = tmp_path / "empty-bin"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))
    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "o"
    rc = main(["study", "run", str(p), "-o", str(out), "--cluster", kind, "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and f"--cluster {kind}" in err and repr(cmd) in err
    assert "Traceback" not in err
    assert not out.exists()


def test_cluster_without_its_submit_command_says_one_line_also_with_progress(
    tmp_path, monkeypatch, capsys
) -> None:
    # without --quiet the runner printed "[study] submitting 1 sbatch job(s); waiting up to
    # 600 s for the first worker" before finding that sbatch is not on PATH: nothing was
    # submitted, and the refusal was two lines (docs/study-files.md: one line)
    from study_cases import FACTORIAL, write_study

    from psdesign.cli.study import main

    empty = tmp_path / "empty-bin"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))
    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "o"
    rc = main(["study", "run", str(p), "-o", str(out), "--cluster", "slurm"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1, err
    assert err.startswith("psdesign: error: --cluster slurm: the submit command 'sbatch'")
    assert not out.exists()


@pytest.mark.parametrize(
    ("flag", "value"),
    [
        ("--cluster-memory", "banana"),
        ("--cluster-memory=-5GB", None),
        ("--cluster-walltime", "1:99:00"),
        ("--cluster-walltime", "01:00:0\u00b2"),  # 'psdesign: error: invalid literal for int()'
        ("--cluster-memory", "1e400GB"),  # 'psdesign: error: input: OverflowError (...)'
        ("--cluster-wait", "0"),
        ("--cluster-wait", "soon"),
        ("--cluster-wait", "nan"),
    ],
)
def test_cli_bad_cluster_resources_exit_2_naming_the_flag(tmp_path, capsys, flag, value) -> None:
    from study_cases import FACTORIAL, write_study

    from psdesign.cli.study import main

    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "o"
    extra = [flag] if value is None else [flag, value]
    rc = main(["study", "run", str(p), "-o", str(out), "--cluster", "slurm", *extra])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1
    assert err.startswith(f"psdesign: error: {flag.split('=')[0]}:")
    assert not out.exists()


def test_cli_names_the_queue_flag_for_a_queue_with_spaces(tmp_path, capsys) -> None:
    # session 47: `--cluster-queue "a b"` went into the job script's "#SBATCH -p a b"; now the
    # field's refusal spelled as the flag, exit 2, one line, no folder
    from study_cases import FACTORIAL, write_study

    from psdesign.cli.study import main

    p = write_study(tmp_path, FACTORIAL, '"generator.porosity" = [0.7, 0.8]')
    out = tmp_path / "o"
    rc = main(
        ["study", "run", str(p), "-o", str(out), "--cluster", "slurm", "--cluster-queue", "a b"]
    )
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1, err
    assert err.startswith("psdesign: error: --cluster-queue: must be a name without spaces")
    assert not out.exists()
