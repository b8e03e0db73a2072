"""dask-jobqueue clusters for the runner: the job scripts a Slurm or PBS site would receive."""

from __future__ import annotations

import pytest

from psdesign.study.cluster import ClusterOptions, job_script

pytest.importorskip("dask_jobqueue")


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
    assert "export NUMBA_NUM_THREADS=4" in s and "--nthreads 4" in s.replace("=", " ")


def test_pbs_job_script() -> None:
    s = job_script(ClusterOptions("pbs", cores=2, memory="8GB", walltime="00:30:00", queue="q"))
    assert "#PBS -q q" in s and "#PBS -l walltime=00:30:00" in s and "ncpus=2" in s


@pytest.mark.parametrize(
    ("kw", "key"),
    [
        ({"kind": "lsf"}, "--cluster"),
        ({"kind": "slurm", "cores": 0}, "--cluster-cores"),
        ({"kind": "pbs", "walltime": "2h"}, "--cluster-walltime"),
    ],
)
def test_bad_cluster_options_name_the_flag(kw, key) -> None:
    with pytest.raises(ValueError, match=key):
        ClusterOptions(**kw)
