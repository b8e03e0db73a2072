"""Benchmark of the Sec. 6 force field: both paper cases, refinement of the optimum, and the
surface-term alternatives.

Run:  python benchmarks/bench_forcefield.py [--only two|thin|six] [--workers N] [--no-variants]

Prints a markdown report (paste into benchmarks/RESULTS.md). For each case it
solves at the default quadrature of the study spec, re-solves at a refined quadrature
(grid step halved, tube nodes doubled) and reports how far the optimum moved, the wall
time, U at the optimum and U at the paper's reported optimum evaluated with the same
code, and the optimum with the area and bending-energy surface terms instead of the
printed Gaussian curvature.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import time

import numpy as np

from psdesign.forcefield.cases import six_fiber_problem, two_fiber_problem


def _fmt(x) -> str:
    return "(" + ", ".join(f"{v:.4f}" for v in x) + ")"


WORKERS = 2


def _solve(prob, **kw):
    prob.objective(prob.x0)  # compile numba kernels outside the timing
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    res = prob.solve(workers=WORKERS, **kw)
    dt = time.perf_counter() - t0
    res.load = (load, os.getloadavg()[0])
    return res, dt


def _load(res) -> str:
    return f"load {res.load[0]:.1f} -> {res.load[1]:.1f}"


def _move(prob, a, b) -> tuple[float, float]:
    """Largest change of a free variable: relative to its value, and to its range width."""
    a, b = np.asarray(a), np.asarray(b)
    rel = np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-12))
    rng = np.max(np.abs(a - b) / (prob.upper - prob.lower))
    return float(rel), float(rng)


def case_report(
    name: str,
    make,
    coarse: dict,
    fine: dict,
    warm_step: float | None,
    surfaces: tuple[str, ...],
    max_iter: int,
) -> list[str]:
    lines = [f"### {name}", ""]
    prob = make(**coarse)
    res, dt = _solve(prob, max_iter=max_iter)
    pot = prob.potential(res.x)
    paper_x = prob.free_of(prob.paper)
    pp = prob.potential(paper_x)
    lines += [
        f"- free variables {prob.param.free}, bounds {_fmt(prob.lower)} .. {_fmt(prob.upper)}",
        f"- start {_fmt(prob.x0)}: U = {prob.objective(prob.x0):.6g}",
        f"- **optimum** (quadrature {coarse}): x = {_fmt(res.x)}, U = {res.fun:.6g} "
        f"(I^V = {pot.volume:.4g}, sum I^S = {pot.surface_interaction:.6g}, "
        f"sum S = {pot.surface:.4g}, area = {pot.area:.5g}); {res.n_iter} polls, "
        f"{res.n_evals} evaluations (+{res.n_speculative} speculative), converged = "
        f"{res.converged}; **wall {dt:.1f} s** "
        f"({WORKERS} workers, {_load(res)})",
        f"- paper's optimum {_fmt(paper_x)}: U = {pp.U:.6g} (I^V = {pp.volume:.4g}, "
        f"sum I^S = {pp.surface_interaction:.6g}, sum S = {pp.surface:.4g}) -> "
        f"{'higher' if pp.U > res.fun else 'LOWER'} than ours",
    ]
    fprob = make(**fine)
    if warm_step is None:
        fres, fdt = _solve(fprob, max_iter=max_iter)
        how = "from the same start"
    else:
        fprob.x0 = res.x.copy()
        fres, fdt = _solve(fprob, max_iter=max_iter, step=warm_step)
        how = f"warm-started at the coarse optimum, initial mesh {warm_step}"
    rel, rng = _move(prob, res.x, fres.x)
    lines += [
        f"- refined quadrature {fine} ({how}): x = {_fmt(fres.x)}, U = {fres.fun:.6g}, "
        f"wall {fdt:.1f} s ({_load(fres)}); optimum moved by {100 * rel:.2f} % of the value "
        f"({100 * rng:.2f} % of the range); coarse-optimum U re-evaluated on the fine "
        f"quadrature: {fprob.objective(res.x):.6g}"
    ]
    for s in surfaces:
        sprob = make(**coarse, surface=s)
        sres, sdt = _solve(sprob, max_iter=max_iter)
        sp = sprob.potential(sres.x)
        lines.append(
            f"- surface term `{s}`: x = {_fmt(sres.x)}, U = {sres.fun:.6g} "
            f"(I^V = {sp.volume:.4g}, sum S = {sp.surface:.5g}), wall {sdt:.1f} s "
            f"({sres.n_evals} evaluations, {_load(sres)})"
        )
    return lines + [""]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--only",
        choices=("two", "thin", "six"),
        action="append",
        help="run only these cases (repeatable; default all)",
    )
    ap.add_argument(
        "--workers",
        type=int,
        default=2,
        help="processes polling in parallel (default 2; results do not change)",
    )
    ap.add_argument(
        "--no-variants", action="store_true", help="skip the area / bending surface-term runs"
    )
    args = ap.parse_args()
    global WORKERS
    WORKERS = args.workers
    variants = () if args.no_variants else ("area", "bending")
    t_all = time.perf_counter()
    cpu = platform.processor() or platform.machine()
    out = [
        "## Force field (Sec. 6) benchmark",
        "",
        f"`python benchmarks/bench_forcefield.py`; {cpu}, {os.cpu_count()} cores, "
        f"load average at start {os.getloadavg()[0]:.1f}",
        "",
    ]
    only = set(args.only or ("two", "thin", "six"))
    if "two" in only:
        out += case_report(
            "Two-fiber assembly (Sec. 6.1), isovalue -8.82, mu = 4.5",
            lambda **k: two_fiber_problem(seed=5, **k),
            dict(h=0.005, n_s=64, n_theta=32),
            dict(h=0.0025, n_s=128, n_theta=64),
            None,
            variants,
            200,
        )
    if "thin" in only:
        out += case_report(
            "Two-fiber, thin variant (isovalue -8.95, D = 0.048: separable)",
            lambda **k: two_fiber_problem(seed=5, isovalue=-8.95, **k),
            dict(h=0.005, n_s=64, n_theta=32),
            dict(h=0.0025, n_s=128, n_theta=64),
            None,
            variants,
            200,
        )
    if "six" in only:
        out += case_report(
            "Six-fiber woven assembly (Sec. 6.2), isovalue -6.65",
            six_fiber_problem,
            dict(h=0.005, n_s=48, n_theta=24),
            dict(h=0.0025, n_s=96, n_theta=48),
            0.0625,
            variants,
            200,
        )
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    out += [
        f"Total {time.perf_counter() - t_all:.0f} s, peak RSS {peak:.0f} MB, "
        f"load average at end {os.getloadavg()[0]:.1f}."
    ]
    print("\n".join(out))


if __name__ == "__main__":
    main()
