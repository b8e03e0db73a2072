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
