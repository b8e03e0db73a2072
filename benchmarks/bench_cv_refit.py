"""Cost of refitting the kernel per cross-validation fold (session 53, menddesign).

Times :func:`psdesign.analysis.surrogate.fit_surrogate` on Kozeny-Carman tables of the sizes
a 1-D sweep (5 porosities; `studies/quickstart.toml`'s 2 cases are too few to fit) and
`studies/inverse_design.toml` (a 6-point latin
hypercube over porosity and diameter, growing by `study optimize`'s rounds) fits, with the
held-out fits refitted (now) and with the full fit's hyper-parameters (before), side by side
in one process: ``PYTHONPATH=$PWD python benchmarks/bench_cv_refit.py``.
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from psdesign.analysis import surrogate as sg

ORIGINAL = sg._held_out_errors


def _old_held_out_errors(s, test, refit=False):
    """The held-out fit with the full fit's hyper-parameters (main before session 53)."""
    x, y = np.asarray(s.x, float), np.asarray(s.y, float)
    args = (s.output, s.params, s.low, s.high, s.log_params, s.log_output, dict(s.kernel))
    sub = sg.Surrogate(*args, x[~test].tolist(), y[~test].tolist())
    m, _ = sub.predict(x[test])
    return s._target(m) - s._target(y[test])


def _table(n: int, dims: int, seed: int = 1) -> tuple[pd.DataFrame, list[str], dict]:
    rng = np.random.default_rng(seed)
    eps = 0.75 + 0.13 * (rng.permutation(n) + rng.random(n)) / n
    d = 6e-6 + 4e-6 * (rng.permutation(n) + rng.random(n)) / n
    k = (d / 2) ** 2 * eps**3 / (20 * (1 - eps) ** 2)
    df = pd.DataFrame({"generator.porosity": eps, "generator.diameter": d, "seed": 1})
    df["status"], df["k_z_m2"] = "ok", k
    params = ["generator.porosity", "generator.diameter"][:dims]
    return df, params, sg.parameter_bounds(df, params, {})


def _time(df, params, bounds, repeats: int = 3) -> tuple[float, float]:
    best, s = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        s = sg.fit_surrogate(df, "k_z_m2", params, bounds)
        best = min(best, time.perf_counter() - t0)
    return best, s.cv_rel_error


def main() -> None:
    import os

    print(f"load {os.getloadavg()}")
    print("case            points  before_s  after_s  ratio  cv_before  cv_after")
    for name, n, dims in [("sweep 1-D", 5, 1)] + [("inverse", n, 2) for n in (6, 10, 14, 22)]:
        df, params, bounds = _table(n, dims)
        sg._held_out_errors = _old_held_out_errors
        t_old, cv_old = _time(df, params, bounds)
        sg._held_out_errors = ORIGINAL
        t_new, cv_new = _time(df, params, bounds)
        print(
            f"{name:14s} {n:7d} {t_old:9.3f} {t_new:8.3f} {t_new / t_old:6.2f} "
            f"{100 * cv_old:8.3g}% {100 * cv_new:8.3g}%"
        )


if __name__ == "__main__":
    main()
