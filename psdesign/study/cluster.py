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

from dataclasses import dataclass, field

CLUSTERS = ("slurm", "pbs")


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
    """

    kind: str
    cores: int = 2
    memory: str = "8GB"
    walltime: str = "01:00:00"
    queue: str | None = None
    account: str | None = None
    job_extra: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        if self.kind not in CLUSTERS:
            raise ValueError(f"--cluster: must be one of {', '.join(CLUSTERS)}, got {self.kind!r}")
        if not isinstance(self.cores, int) or self.cores < 1:
            raise ValueError(f"--cluster-cores: must be an integer >= 1, got {self.cores!r}")
        parts = self.walltime.split(":")
        if len(parts) != 3 or not all(p.isdigit() for p in parts):
            raise ValueError(f"--cluster-walltime: expected HH:MM:SS, got {self.walltime!r}")


def make_cluster(opts: ClusterOptions):
    """A dask-jobqueue cluster (not yet scaled) for ``opts``."""
    from dask_jobqueue import PBSCluster, SLURMCluster

    threads = {
        k: str(opts.cores)
        for k in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    }
    prologue = [f"export {k}={v}" for k, v in threads.items()]
    cls = SLURMCluster if opts.kind == "slurm" else PBSCluster
    extra = {"job_extra_directives": list(opts.job_extra)}
    return cls(
        cores=opts.cores,
        processes=1,
        memory=opts.memory,
        walltime=opts.walltime,
        queue=opts.queue,
        account=opts.account,
        job_script_prologue=prologue,
        scheduler_options={"dashboard_address": None},
        **extra,
    )


def job_script(opts: ClusterOptions) -> str:
    """The batch script one worker job would be submitted with (nothing is submitted)."""
    cluster = make_cluster(opts)
    try:
        return cluster.job_script()
    finally:
        cluster.close()
