"""HPC batch clusters for the study runner (dask-jobqueue): ``--cluster slurm|pbs``.

Each batch job runs one Dask worker process with ``cores`` threads budgeted to the solver
(numba/BLAS thread variables set in the job's environment) and ``memory`` of RAM; the runner
scales the cluster to ``workers`` jobs and submits the cases to it like to any Dask scheduler.
``job_script`` shows what would be submitted, without submitting.

Example (from a login node)::

    psdesign study run studies/table3.toml -o out/t3 --cluster slurm --workers 8 \\
        --cluster-cores 4 --cluster-memory 16GB --cluster-walltime 02:00:00 --cluster-queue short
"""

from __future__ import annotations

import math
import numbers
import re
import shutil
import time
from dataclasses import dataclass, field

from psdesign.errors import short

CLUSTERS = ("slurm", "pbs")
SUBMIT_COMMANDS = {"slurm": "sbatch", "pbs": "qsub"}  # what dask-jobqueue runs per job
#: ``--cluster-walltime``: ``HH:MM:SS`` in ASCII digits (minutes and seconds 0-59: checked).
_WALLTIME = re.compile(r"([0-9]+):([0-9]+):([0-9]+)")
DEFAULT_WAIT_S = 600.0
#: The schedulers psdesign starts (local Dask, Slurm/PBS) show no dashboard, but dask always
#: serves its HTTP routes (health, metrics) and, given no address, takes port 8787 or prints
#: "Port 8787 is already in use" on stderr when another dask holds it (session 53: a second
#: line under a one-line refusal). A free loopback port: no clash, nothing on other interfaces.
SCHEDULER_HTTP = {"dashboard": False, "dashboard_address": "127.0.0.1:0"}
"""Default ``--cluster-wait``: seconds a Dask run (``--cluster`` or ``--scheduler``) waits
for a worker (the first batch job to connect, or any worker once all have left)."""


def check_wait_s(value, what: str = "--cluster-wait") -> float:
    """``value`` as ``--cluster-wait`` seconds.

    Parameters
    ----------
    value : float
        Seconds; a finite number > 0.
    what : str
        How the error names the value: the command line's ``"--cluster-wait"``, the Python
        API's keyword (``"worker_wait_s"`` of :class:`~psdesign.study.options.RunOptions`).

    Returns
    -------
    float

    Raises
    ------
    ValueError
        One line naming ``what`` and its range.
    """
    # numbers.Real: NumPy's numbers too (np.int64(60) was refused as not seconds > 0)
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0 < value < math.inf:
        raise ValueError(f"{what}: expected seconds > 0 (finite), got {short(value)}")
    return float(value)


@dataclass(frozen=True)
class ClusterOptions:
    """Batch-job resources of one Dask worker job.

    Attributes
    ----------
    kind : {"slurm", "pbs"}
    cores : int
        CPU cores per job (one worker process using them all).
    memory : str
        Memory per job, e.g. ``"16GB"``.
    walltime : str
        ``HH:MM:SS``.
    queue, account : str or None
        Partition/queue and project account.
    job_extra : tuple of str
        Extra scheduler directives (e.g. ``"--constraint=ib"``).
    wait_s : float
        ``--cluster-wait``: seconds to wait for the first worker to connect before the run
        stops (a job still queued after that is cancelled); ``run_study``'s
        ``worker_wait_s`` defaults to it.

    Raises
    ------
    StudyError
        On creation, one line naming the field (``cores: ...``; ``psdesign study run`` names
        its flag, ``--cluster-cores: ...``) and what it allows (a
        :class:`psdesign.errors.SpecError`, a ``ValueError``).
    """

    kind: str
    cores: int = 2
    memory: str = "8GB"
    walltime: str = "01:00:00"
    queue: str | None = None
    account: str | None = None
    job_extra: tuple[str, ...] = field(default_factory=tuple)
    wait_s: float = DEFAULT_WAIT_S

    def __post_init__(self) -> None:
        _check_cluster_fields(self)
        object.__setattr__(self, "cores", int(self.cores))  # a NumPy integer as int
        object.__setattr__(self, "job_extra", tuple(self.job_extra))  # a list as given
        object.__setattr__(self, "wait_s", float(self.wait_s))

    @property
    def submit_command(self) -> str:
        """The batch system's submit command (``sbatch`` or ``qsub``)."""
        return SUBMIT_COMMANDS[self.kind]


#: ``--cluster`` flags by :class:`ClusterOptions` field (the others are ``--cluster-<field>``).
CLUSTER_FLAGS = {"kind": "--cluster", "wait_s": "--cluster-wait"}


def cluster_flag(field_name: str) -> str:
    """The command line's flag of a :class:`ClusterOptions` field.

    >>> cluster_flag("kind"), cluster_flag("cores"), cluster_flag("wait_s")
    ('--cluster', '--cluster-cores', '--cluster-wait')
    """
    return CLUSTER_FLAGS.get(field_name, f"--cluster-{field_name}")


def _check_cluster_fields(opts: ClusterOptions) -> None:
    """Each field of ``opts`` of its type and range, else a one-line
    :class:`~psdesign.errors.StudyError` whose key is the field (``psdesign study run`` spells
    it as its flag, :func:`cluster_flag`).

    Until session 47 the errors named the flags from Python too, and ``queue=3``,
    ``account=3``, ``cores=True`` and ``job_extra=3`` were taken (a text queue with a newline
    wrote a directive of its own into the job script; ``job_extra="--x"`` one per character).
    """
    from psdesign.errors import StudyError

    if opts.kind not in CLUSTERS:
        raise StudyError(f"kind: must be one of {', '.join(CLUSTERS)}, got {short(opts.kind)}")
    cores = opts.cores
    if isinstance(cores, bool) or not isinstance(cores, numbers.Integral) or cores < 1:
        raise StudyError(f"cores: must be an integer >= 1, got {short(cores)}")
    # ASCII digits only: str.isdigit took '0²' (then int() raised a bare ValueError naming no
    # field) and other scripts' digits, which the batch system would read as no walltime
    hms = _WALLTIME.fullmatch(opts.walltime) if isinstance(opts.walltime, str) else None
    h, m, sec = (int(p) for p in hms.groups()) if hms else (0, 60, 60)
    if m > 59 or sec > 59 or not h + m + sec:
        raise StudyError(
            "walltime: expected HH:MM:SS (minutes and seconds 0-59, above 00:00:00), "
            f"got {short(opts.walltime)}"
        )
    if memory_bytes(opts.memory) is None:
        raise StudyError(
            f"memory: expected a size > 0 such as 16GB or 500MB, got {short(opts.memory)}"
        )
    try:
        check_wait_s(opts.wait_s, "wait_s")
    except ValueError as exc:  # the StudyError (a SpecError) of every bad field
        raise StudyError(str(exc)) from None
    for key in ("queue", "account"):
        value = getattr(opts, key)
        if value is not None and not _directive_word(value):
            raise StudyError(
                f"{key}: must be a name without spaces (the batch system's {key}; none: "
                f"its default), got {short(value)}"
            )
    extra = opts.job_extra
    if isinstance(extra, str) or not isinstance(extra, tuple | list):
        raise StudyError(
            "job_extra: must be a tuple of directives such as ('--constraint=ib',), got "
            f"{short(extra)}"
        )
    for item in extra:
        if not isinstance(item, str) or not item.strip() or "\n" in item or "\r" in item:
            raise StudyError(
                f"job_extra: each must be one line of text (a directive such as "
                f"'--constraint=ib'), got {short(item)}"
            )


def _directive_word(value: object) -> bool:
    """A queue or account name: non-empty text with no white space (it is written into a
    job-script directive line)."""
    return isinstance(value, str) and bool(value) and not any(c.isspace() for c in value)


def memory_bytes(text) -> int | None:
    """``text`` (``"16GB"``, ``"500 MB"``) in bytes, or None if it is not a size > 0."""
    from dask.utils import parse_bytes

    if not isinstance(text, str):
        return None
    try:
        n = parse_bytes(text)
    except (ValueError, TypeError, OverflowError):  # '1e400GB': int(inf) raised OverflowError
        return None
    return n if n > 0 else None


def check_submit_command(opts: ClusterOptions) -> None:
    """Raise ValueError if the batch system's submit command is not on ``PATH``.

    Without it dask-jobqueue only logs each failed submission and the study would wait
    forever for workers that never come.
    """
    cmd = opts.submit_command
    if shutil.which(cmd) is None:
        raise ValueError(
            f"--cluster {opts.kind}: the submit command {cmd!r} is not on PATH; run from a "
            f"login node of the {opts.kind.upper()} cluster (psdesign.study.cluster.job_script "
            "shows the job script each worker would be submitted with); nothing was run or "
            "changed"
        )


def _import_jobqueue():
    """``dask_jobqueue``, imported with the process's SIGINT handler kept.

    Its ``runner`` module replaces the handler on import with ``lambda *_: sys.exit()``: a
    Ctrl-C in ``study run --cluster`` then left as a bare ``SystemExit`` (exit 0, no
    "interrupted" line, the tables not flushed) instead of psdesign's ``KeyboardInterrupt``.
    """
    import signal
    import threading

    main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGINT) if main else None
    try:
        import dask_jobqueue
    finally:
        if main and before is not None:
            signal.signal(signal.SIGINT, before)
    return dask_jobqueue


def make_cluster(opts: ClusterOptions):
    """A dask-jobqueue cluster (not yet scaled) for ``opts``."""
    jobqueue = _import_jobqueue()
    PBSCluster, SLURMCluster = jobqueue.PBSCluster, jobqueue.SLURMCluster  # noqa: N806

    threads = {
        k: str(opts.cores)
        for k in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    }
    prologue = [f"export {k}={v}" for k, v in threads.items()]
    cls = SLURMCluster if opts.kind == "slurm" else PBSCluster
    extra = {"job_extra_directives": list(opts.job_extra), "job_cls": _watched_job(cls.job_cls)}
    # one case at a time per job, its solver threads on all the job's cores: dask-jobqueue
    # gives a worker cores / processes threads (cases at once), so the worker takes one core's
    # thread and the batch system reserves opts.cores
    if opts.kind == "slurm":
        extra["job_cpu"] = opts.cores
    else:
        from dask.utils import parse_bytes
        from dask_jobqueue.pbs import pbs_format_bytes_ceil

        mem = pbs_format_bytes_ceil(parse_bytes(opts.memory))
        extra["resource_spec"] = f"select=1:ncpus={opts.cores}:mem={mem}"
    return cls(
        cores=1,
        processes=1,
        memory=opts.memory,
        walltime=opts.walltime,
        queue=opts.queue,
        account=opts.account,
        job_script_prologue=prologue,
        scheduler_options=dict(SCHEDULER_HTTP),
        **extra,
    )


def job_script(opts: ClusterOptions) -> str:
    """The batch script one worker job would be submitted with (nothing is submitted)."""
    cluster = make_cluster(opts)
    try:
        return cluster.job_script()
    finally:
        cluster.close()


def _watched_job(job_cls: type) -> type:
    """``job_cls`` whose failed submission is recorded (``submit_error``) instead of raised.

    dask-jobqueue only logs a failed ``sbatch``/``qsub`` (a traceback on stderr) and leaves
    the job half-made, so the cluster cannot even be closed; recorded, the runner can stop
    with the batch system's own words (:func:`wait_for_first_worker`).
    """
    from distributed.core import Status

    class WatchedJob(job_cls):
        submit_error: str | None = None

        async def start(self) -> None:
            try:
                await super().start()
            except Exception as exc:  # noqa: BLE001 - any refusal: say it, do not hang
                self.submit_error = submit_error_text(str(exc))
                self.status = Status.running  # a job that never ran: nothing to cancel

        async def close(self) -> None:
            if self.submit_error is None:
                await super().close()
            self.status = Status.closed

    WatchedJob.__name__ = WatchedJob.__qualname__ = f"Watched{job_cls.__name__}"
    return WatchedJob


def submit_error_text(message: str, limit: int = 300) -> str:
    """One line from dask-jobqueue's failed-command message: exit code and the stderr text."""
    code = re.search(r"Exit code:\s*(-?\d+)", message)
    _, sep, err = message.partition("stderr:")
    text = " ".join((err if sep else message).split()) or "no error text"
    text = text if len(text) <= limit else text[: limit - 3] + "..."
    return f"exit {code.group(1)}: {text}" if code else text


def submit_errors(cluster) -> list[str]:
    """The recorded submission errors of ``cluster``'s jobs (see :func:`make_cluster`)."""
    jobs = list(getattr(cluster, "workers", {}).values())
    return [e for e in (getattr(j, "submit_error", None) for j in jobs) if e]


def has_worker(client) -> bool:
    """Whether the Dask scheduler of ``client`` has a worker now (asks for one worker's
    record only): the one check of the first-worker wait and of the runner's watch for a run
    whose workers all left."""
    return bool(client.scheduler_info(n_workers=1).get("workers"))


def wait_for_first_worker(client, cluster, opts: ClusterOptions, poll_s: float = 0.2) -> None:
    """Return once a worker has connected; raise ValueError (one line) if none can come.

    Stops at once when every job's submission failed, else after ``opts.wait_s`` seconds.
    """
    deadline = time.monotonic() + opts.wait_s
    n_jobs = max(1, len(getattr(cluster, "worker_spec", {}) or {}))
    cmd = opts.submit_command
    while not has_worker(client):
        errors = submit_errors(cluster)
        if len(errors) >= n_jobs:
            raise ValueError(
                f"--cluster {opts.kind}: {cmd} refused the job(s) ({errors[0]}); check "
                "--cluster-queue/--cluster-account/--cluster-* options; nothing was run or changed"
            )
        if time.monotonic() >= deadline:
            why = f"; {cmd} said: {errors[0]}" if errors else ""
            raise ValueError(
                f"--cluster-wait: no worker connected within {opts.wait_s:g} s of submitting "
                f"{n_jobs} {cmd} job(s){why}; queued jobs are cancelled; allow longer with "
                "--cluster-wait SECONDS; nothing was run or changed"
            )
        time.sleep(poll_s)
