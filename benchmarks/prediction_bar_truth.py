"""Coverage and width of ``study predict``'s bar against closed-form truth (session 44).

Usage::

    python benchmarks/prediction_bar_truth.py [--n 41] [--lhs-sweep]

Fits K = 2 truth(eps, d) on small designs (full factorials with fake_case's one 1 % noise factor
per seed, 1-D porosity sweeps, 12- and 20-point latin hypercubes with 1 % noise per case), then
predicts through ``psdesign.cli.study_analysis._predict_one`` (the printed bar and status) on an
n x n grid of the fitted box and compares with the noise-free truth: Kozeny-Carman with
k_K = 5 (Carman 1937; ``tests/study_cases.kc_truth``) and Gebart's square array across the
fibers (J. Compos. Mater. 26 (1992) 1100). One markdown row per design: the fit's hold-out
figures, the true relative error (RMS / max), the share of points within 2 bars, the median bar
and true error and their ratio, and the statuses printed. ``--lhs-sweep`` adds 96 latin
hypercubes (8, 12, 20, 30 points x design seeds 1-8 x Kozeny-Carman, Gebart and a linear,
porosity-like truth with 0.01 % noise) on a 31 x 31 grid: how many hold the truth within 2 bars
at under 95 % of the box, the least share, and the median of median bar / median true error
(session 45).
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy.stats import qmc  # noqa: E402
from study_cases import kc_truth  # noqa: E402

from psdesign.analysis.surrogate import fit_surrogate  # noqa: E402
from psdesign.cli.study_analysis import _predict_one  # noqa: E402

D_1D = 7e-6
GRIDS = (
    ("3 x 2, 2 seeds", [0.7, 0.8, 0.9], [6e-6, 8e-6], [1, 2]),
    ("5 x 3, 1 seed", [0.7, 0.75, 0.8, 0.85, 0.9], [6e-6, 7e-6, 8e-6], [1]),
    ("3 x 3, 3 seeds", [0.7, 0.8, 0.9], [6e-6, 7e-6, 8e-6], [1, 2, 3]),
    ("4 x 2, 2 seeds", [0.6, 0.7, 0.8, 0.9], [6e-6, 8e-6], [1, 2]),
    ("1-D 5, 1 seed", [0.7, 0.75, 0.8, 0.85, 0.9], None, [1]),
    ("1-D 3, 2 seeds", [0.7, 0.8, 0.9], None, [1, 2]),
)


def gebart(eps, d):
    """Gebart (1992), square array, flow across the fibers."""
    c1 = 16.0 / (9.0 * math.pi * math.sqrt(2.0))
    return c1 * (np.sqrt((math.pi / 4.0) / (1.0 - eps)) - 1.0) ** 2.5 * (d / 2.0) ** 2


def _fit(x: np.ndarray, y: np.ndarray, params: list[str]):
    df = pd.DataFrame(x, columns=params).assign(k=y, status="ok")
    return fit_surrogate(df, "k", params, {p: (df[p].min(), df[p].max(), False) for p in params})


def grid_fit(truth, eps, diam, seeds):
    params = ["e"] if diam is None else ["e", "d"]
    x = np.array([(e, d)[: len(params)] for e in eps for d in (diam or [D_1D]) for _ in seeds])
    noise = [1 + 0.01 * np.random.default_rng(s).standard_normal() for s in seeds]
    d = x[:, 1] if diam else D_1D
    return _fit(x, 2.0 * truth(x[:, 0], d) * np.tile(noise, len(x) // len(seeds)), params)


def linear(eps, d):
    """A porosity-like output: linear in porosity, independent of the diameter."""
    return 0.5 * eps + 0.0 * d


def lhs_fit(truth, n_points, seed=4, noise=0.01):
    u = qmc.LatinHypercube(d=2, seed=seed).random(n_points)
    x = np.c_[0.7 + 0.2 * u[:, 0], 6e-6 + 2e-6 * u[:, 1]]
    noise = 1 + noise * np.random.default_rng(seed + 1).standard_normal(n_points)
    return _fit(x, 2.0 * truth(x[:, 0], x[:, 1]) * noise, ["e", "d"])


def _on_grid(s, truth, n: int) -> tuple[np.ndarray, np.ndarray, set[str]]:
    """The fit's prediction on an n x n grid of its box (n points of a 1-D fit, at the diameter
    ``D_1D``): the true relative errors, the bars relative to the truth, the statuses."""
    one = len(s.params) == 1
    ds = [D_1D] if one else np.linspace(s.low[1], s.high[1], n)
    err, bar, status = [], [], set()
    for e in np.linspace(s.low[0], s.high[0], n):
        for d in ds:
            r, _ = _predict_one(s, f"e={e}" if one else f"e={e},d={d}")
            k = 2.0 * truth(e, d)
            err.append(abs(r["mean"] - k) / k)
            bar.append(r["std"] / k)
            status.add(r["status"])
    return np.array(err), np.array(bar), status


def coverage(s, truth, n: int) -> tuple[float, float]:
    """Share of an n x n grid of the box with the truth within 2 bars, and median bar /
    median true error."""
    err, bar, _ = _on_grid(s, truth, n)
    return float(np.mean(err <= 2 * bar)), float(np.median(bar) / np.median(err))


def lhs_sweep(n: int = 31) -> None:
    """One line per truth and size: designs under 95 %, the least share, the median ratio."""
    print("\n| LHS truth | points | designs rated ok | under 95 % | least share | median ratio |")
    print("| --- " * 6 + "|")
    for truth, tname, noise in (
        (kc_truth, "KC", 0.01),
        (gebart, "Gebart", 0.01),
        (linear, "linear", 1e-4),
    ):
        for n_points in (8, 12, 20, 30):
            fits = [lhs_fit(truth, n_points, seed, noise) for seed in range(1, 9)]
            got = [coverage(s, truth, n) for s in fits if s.rating()[0] == "ok"]
            print(f"| {tname} | {n_points} | {len(got)} / 8 | {_sweep_cells(got)} |")


def _sweep_cells(got: list[tuple[float, float]]) -> str:
    """The last three cells of an LHS sweep line from the (share, ratio) of the designs
    rated ok; with none rated ok there is nothing to measure, and the line says so (the
    least share of no design raised ValueError and ended the sweep)."""
    if not got:
        return "no design rated ok | - | -"
    share = np.array([c for c, _ in got])
    return (
        f"{int(np.sum(share < 0.95))} | {100 * share.min():.3g} % | "
        f"{np.median([r for _, r in got]):.3g}"
    )


def row(name: str, s, truth, n: int) -> str:
    err, bar, status = _on_grid(s, truth, n)
    between = getattr(s, "cv_between_rel_error", math.nan)  # absent before session 44

    def pct(v):
        return f"{100 * v:.3g} %"

    return (
        f"| {name} | {pct(s.cv_rel_error)} | {pct(s.cv_level_rel_error)} | {pct(between)} | "
        f"{pct(np.sqrt(np.mean(err**2)))} / {pct(err.max())} | {pct(np.mean(err <= 2 * bar))} | "
        f"{pct(np.median(bar))} | {pct(np.median(err))} | {np.median(bar) / np.median(err):.3g} "
        f"| {', '.join(sorted(status))} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=41, help="grid points per parameter")
    ap.add_argument("--lhs-sweep", action="store_true", help="add 96 latin hypercubes")
    args = ap.parse_args()
    n = args.n
    warnings.simplefilter("ignore")
    print(
        "| design | CV error | inner-level error | between-points error | true error RMS / max "
        "| within 2 bars | median bar | median true error | ratio | status |"
    )
    print("| --- " * 10 + "|")
    for truth, tname in ((kc_truth, "KC"), (gebart, "Gebart")):
        for name, eps, diam, seeds in GRIDS:
            print(row(f"{tname} {name}", grid_fit(truth, eps, diam, seeds), truth, n))
        for n_points in (12, 20):
            print(row(f"{tname} LHS {n_points}", lhs_fit(truth, n_points), truth, n))
    if args.lhs_sweep:
        lhs_sweep()


if __name__ == "__main__":
    main()
