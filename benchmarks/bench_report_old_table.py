"""The report's trust rules on an old study table: 2000 cases written before any status column
(porosity, K, D_eff/D, pore sizes, S_v rated by their bars, ``analysis.columns.own_status``).

Times ``trusted``, ``flagged_values``, ``report.decision.parameter_plots`` (best and median of
``--reps`` calls) and one whole ``build_html`` of a folder holding the table. Run it with
``PYTHONPATH`` at two trees, alternately, to compare them side by side (session 47: main's
row-by-row rating against the whole-column one; record ``uptime``'s load beside each run)::

    PYTHONPATH=. python benchmarks/bench_report_old_table.py --n 2000 --reps 7
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

PARAMS = {
    "generator.porosity": {"kind": "uniform", "low": 0.6, "high": 0.9},
    "generator.diameter": {"kind": "choice", "values": [8e-6, 10e-6, 12e-6]},
}


def old_table(n: int, seed: int = 0) -> pd.DataFrame:
    """``n`` ok cases of a 2-parameter study, 4 seeds, with the value and error columns of a
    voxel study with transport outputs and no status column (reproducible values: about 4 %
    of the porosities, a third of the K, D and S_v bars and a quarter of the pore bars above
    20 %)."""
    rng = np.random.default_rng(seed)
    eps = rng.uniform(0.6, 0.9, n)
    d = rng.choice([8e-6, 10e-6, 12e-6], n)
    df = pd.DataFrame(
        {
            "case_id": [f"c{i:05d}" for i in range(n)],
            "index": np.arange(n) // 4,
            "seed": np.arange(n) % 4 + 1,
            "status": "ok",
            "generator.porosity": np.round(eps, 2),
            "generator.diameter": d,
            "porosity": eps + rng.normal(0, 0.01, n),
            "porosity_error": rng.choice([4e-4, 2e-3, 0.2], n, p=[0.8, 0.15, 0.05]),
        }
    )
    for a in "xyz":
        df[f"k_{a}_m2"] = d**2 * eps**3 / (1 - eps) ** 2 / 80
        df[f"k_{a}_rel_error"] = rng.uniform(0.01, 0.3, n)
        df[f"converged_{a}"] = True
        df[f"iterations_{a}"] = rng.integers(50, 200, n)
        df[f"residual_{a}"] = 1e-7
        df[f"flux_imbalance_{a}"] = rng.uniform(0, 1e-3, n)
    df["diffusivity_z"] = eps**1.5
    df["diffusivity_z_rel_error"] = rng.uniform(0, 0.3, n)
    df["tortuosity_z"] = eps / df["diffusivity_z"]
    d50 = rng.uniform(8e-6, 40e-6, n)
    df["pore_d10_m"], df["pore_d50_m"], df["pore_d90_m"] = d50 / 2, d50, 2 * d50
    df["pore_diameter_error_m"] = rng.uniform(1e-6, 5e-6, n)
    df["specific_surface_m-1"] = 4 * (1 - eps) / d
    df["specific_surface_rel_error"] = rng.uniform(0, 0.4, n)
    df["intersection_volume_fraction"] = rng.uniform(0, 0.01, n)
    df["intersection_volume_fraction_error"] = rng.uniform(0, 0.003, n)
    return df


def write_folder(df: pd.DataFrame, out: Path) -> Path:
    """A study folder ``study report`` reads: results.csv and study.json."""
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "results.csv", index=False)
    study = {"name": "old-table", "design": "random", "solver": "voxel", "parameters": PARAMS}
    (out / "study.json").write_text(json.dumps({"study": study}))
    return out


def best_median(f, reps: int) -> tuple[float, float]:
    """Best and median wall time of ``reps`` calls of ``f()``, in ms."""
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        f()
        times.append(1e3 * (time.perf_counter() - t0))
    times.sort()
    return times[0], times[len(times) // 2]


def main() -> None:
    import psdesign
    from psdesign.analysis.columns import flagged_values, trusted
    from psdesign.report.decision import parameter_plots
    from psdesign.report.html import build_html

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000, help="cases in the table")
    ap.add_argument("--reps", type=int, default=7, help="calls timed per function")
    args = ap.parse_args()
    df = old_table(args.n)
    print(f"psdesign from {Path(psdesign.__file__).parent}; {args.n} rows")
    for name, f in (
        ("trusted", lambda: trusted(df)),
        ("flagged_values", lambda: flagged_values(df)),
        ("parameter_plots", lambda: parameter_plots(df, list(PARAMS), {"parameters": PARAMS})),
    ):
        reps = args.reps if name != "parameter_plots" else max(1, args.reps // 3)
        print(f"{name}: best {{:.1f}} ms, median {{:.1f}} ms".format(*best_median(f, reps)))
    with tempfile.TemporaryDirectory() as tmp:
        folder = write_folder(df, Path(tmp) / "study")
        t0 = time.perf_counter()
        build_html(folder)
        print(f"build_html: {time.perf_counter() - t0:.2f} s")


if __name__ == "__main__":
    main()
