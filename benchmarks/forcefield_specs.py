"""``psdesign forcefield`` on every shipped spec that has fibers (issue 17 item 4).

Usage::

    nice python benchmarks/forcefield_specs.py --out ff_specs.jsonl [SPEC ...] [--voxel 1e-6]
        [--k z]

For each RVE spec under ``studies/`` (and the inline ``[base]`` of each study file) it runs
``psdesign forcefield SPEC -o TMP/`` (the spec's own ``[forcefield.relax]`` table, or the
defaults) and prints one JSON line: the route (rods: analytic centre lines; fields: woven /
compressed), fibers moved, the status (converged / at_bound / contact_left / not_converged),
the variables on a bound, evaluations and wall time, and, measured on the same voxel grid
before and after (``RVE.voxelize``, the spec's voxel): porosity, Omega (voxel fraction inside
two fibers) and the smallest gap between two fibers on that grid (Eq. 8's intersection field).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def shipped_specs() -> list[Path]:
    """Every ``studies/**/*.toml`` with fibers: RVE specs, and study files with an inline base."""
    out = []
    for p in sorted((ROOT / "studies").rglob("*.toml")):
        data = tomllib.loads(p.read_text())
        if "rve" in data and ("fibers" in data or "generator" in data):
            out.append(p)
        elif isinstance(data.get("base"), dict) and "rve" in data["base"]:
            out.append(p)
    return out


def shown(path: Path) -> str:
    """The path relative to the repository when it lies inside it."""
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


def spec_text(path: Path) -> str:
    """The RVE spec of ``path`` as TOML text (a study's inline ``[base]`` tables alone)."""
    text = path.read_text()
    if "rve" in tomllib.loads(text):
        return text
    keep, lines = False, []
    for line in text.splitlines():
        head = line.strip()
        if head.startswith("["):
            name = head.strip("[]").strip()
            keep = name.startswith("base.")
            if keep:
                line = line.replace("base.", "", 1)
        if keep:
            lines.append(line)
    return "\n".join(lines) + "\n"


def min_pair_gap(rve, points: np.ndarray, chunk: int = 200_000) -> float:
    """Smallest second-smallest fiber field (Eq. 8's intersection field) over the points,
    in chunks (a 0.5 um grid of a 100 um cube holds 8 M points)."""
    if len(rve.fibers) < 2:
        return float("inf")
    return min(
        float(rve.intersection_field(points[i : i + chunk]).min())
        for i in range(0, len(points), chunk)
    )


def voxel_state(rve, voxel: float) -> dict:
    """Porosity, Omega and the smallest pair gap (metres) on one voxel grid."""
    fields = rve.voxelize(voxel)
    g = fields.grid
    axes = [(np.arange(n) + 0.5) * s for n, s in zip(g.shape, g.spacing, strict=True)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return {
        "porosity": fields.porosity,
        "omega": fields.intersection_volume_fraction,
        "min_gap_m": min_pair_gap(rve, pts),
    }


def voxel_k(rve, voxel: float, direction: str = "z") -> dict:
    """Voxel-route K (periodic BC) of an RVE along ``direction``."""
    from psdesign.flow.voxel import permeability_voxel

    t0 = time.process_time()
    r = permeability_voxel(rve.voxelize(voxel), direction, {"viscosity": 1.8e-5})
    return {
        f"k_{direction}_m2": r["permeability_m2"],
        "converged": r["converged"],
        "cpu_s": time.process_time() - t0,
    }


def moves(summary: dict, period: float) -> dict:
    """Largest shift (metres) and bend change of the relaxed fibers, and how many bent."""
    v = summary.get("variables", {})
    shifts = [abs(x) for k, x in v.items() if k.startswith("t")]
    bends = [abs(x) for k, x in v.items() if k.startswith("u") or k == "|u|"]
    return {
        "max_shift_m": max(shifts, default=0.0) * period,
        "max_du": max(bends, default=0.0),
        "n_bent": sum(b > 0 for b in bends),
        "n_shifted": len({k.split("[")[1] for k, x in v.items() if k[0] == "t" and x}),
    }


def run_one(
    path: Path,
    tmp: Path,
    voxel: float | None = None,
    k_dir: str | None = None,
    max_evals: int | None = None,
) -> dict:
    """Relax one spec through the CLI and measure it before and after (on the spec's voxel
    grid, or ``voxel``; with ``k_dir`` also the voxel K along it, before and after).
    ``max_evals``: evaluation budget for a spec without its own ``[forcefield.relax]``."""
    from psdesign.cli import main
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = tmp / "spec.toml"
    text = spec_text(path)
    if max_evals and "[forcefield.relax]" not in text:  # the defaults, with a larger budget
        text += f"\n[forcefield.relax]\nmax_evals = {int(max_evals)}\nmax_iter = 100000\n"
    spec.write_text(text)
    data = tomllib.loads(spec.read_text())
    plain = tmp / "plain.toml"
    plain.write_text("\n".join(spec.read_text().split("[forcefield.relax]")[0].splitlines()) + "\n")
    voxel = float(voxel or data["rve"]["voxel"])
    t0 = time.perf_counter()
    before = build_rve(load_spec(plain)).rve
    gen_s = time.perf_counter() - t0
    out = tmp / "out"
    t0, c0 = time.perf_counter(), time.process_time()
    rc = main(["forcefield", str(spec), "-o", str(out), "--no-pictures"])
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    rec = {"spec": shown(path), "exit": rc, "n_fibers": len(before.fibers)}
    rec["generate_s"] = gen_s
    rec["voxel_m"] = voxel
    rec["before"] = voxel_state(before, voxel)
    if rc not in (0, 3):  # 3: finished, outputs complete, a search stopped on max_iter
        return rec
    s = json.loads((out / "summary.json").read_text())
    timings = out / "summary_timings.json"  # wall times left summary.json in 6f450a3
    if timings.exists():
        s |= json.loads(timings.read_text())
    after = build_rve(load_spec(out / "relaxed.toml")).rve
    rec.update(
        route=s.get("route", "rods"),
        n_moved=s["n_moved"],
        status=s["status"],
        converged=s["converged"],
        n_at_bound=len(s["at_bound"]),
        n_variables=len(s.get("variables", {})) or 3 * s.get("n_movable", s["n_moved"]),
        at_bound=s["at_bound"],
        message=s["message"],
        n_evals=s["n_evals"],
        relax_s=s["wall_time_s"],
        cli_s=wall,
        cli_cpu_s=cpu,
        n_contacts_before=s.get("n_contacts_before"),
        n_contacts_after=s.get("n_contacts_after"),
        omega_analytic=[s.get("omega_analytic_before"), s.get("omega_analytic_after")],
        # their bars and statuses (session 47; absent from the records before)
        omega_analytic_error=[s.get(f"omega_analytic_{t}_error") for t in ("before", "after")],
        omega_analytic_status=[s.get(f"omega_analytic_{t}_status") for t in ("before", "after")],
        moves=moves(s, float(after.period)),
        reloads=len(after.fibers) == len(before.fibers),
        after=voxel_state(after, voxel),
    )
    if k_dir:
        rec["k_before"] = voxel_k(before, voxel, k_dir)
        rec["k_after"] = voxel_k(after, voxel, k_dir)
    return rec


def eval_cost(path: Path, n: int = 300, seed: int = 0) -> dict:
    """CPU per energy evaluation of the rod relax on one spec's fiber set, side by side: the
    whole-set evaluation (every pair re-measured) and the incremental one of
    :class:`psdesign.forcefield.relax._RodEnergy`, on the same compass-search-like polls."""
    from psdesign.forcefield.relax import _RodEnergy, bending_area
    from psdesign.packing.build import build_rve
    from psdesign.packing.fiberset import FiberState, find_contacts
    from psdesign.packing.genetic import analytic_omega
    from psdesign.schema.spec import load_spec

    with tempfile.TemporaryDirectory() as tmp:
        plain = Path(tmp) / "spec.toml"
        plain.write_text(spec_text(path).split("[forcefield.relax]")[0])
        rve = build_rve(load_spec(plain)).rve
    st = FiberState.from_fibers(rve.fibers, fixed=False)
    st.f = np.where(st.u == 0.0, 1.0, st.f)  # as relax_fibers: straight fibers bend with f = 1
    lo, hi = rve.box_normalized
    c = find_contacts(st, lo, hi, 0.0)
    movable = np.unique(np.r_[c.i, c.j])
    ms, um = 0.5 * float(st.diameter.min()), 0.3  # the [forcefield.relax] defaults
    model = _RodEnergy(st, movable, lo, hi, 2 * (np.sqrt(2) * ms + um / (2 * np.pi)), 1e10, 1.0)
    rng = np.random.default_rng(seed)
    bound = np.tile([ms, ms, um], len(movable))
    x, polls = np.zeros(len(bound)), []
    for _ in range(n):
        y = x.copy()
        i = rng.integers(len(y))
        y[i] = np.clip(y[i] + rng.choice([-1, 1]) * 0.25 * 2 * bound[i], -bound[i], bound[i])
        polls.append(y)
        if rng.random() < 0.1:
            x = y
    t0 = time.process_time()
    inc = [model.energy(y) for y in polls]
    t_inc = (time.process_time() - t0) / n
    t0 = time.process_time()
    whole = []
    for y in polls:
        s = model.state_at(y)
        whole.append(1e10 * analytic_omega(s, lo, hi) + float(bending_area(s, lo, hi).sum()))
    t_whole = (time.process_time() - t0) / n
    err = np.abs(np.array(inc) - np.array(whole)) / np.abs(np.array(whole))
    return {
        "spec": shown(path),
        "n_fibers": len(st),
        "n_movable": len(movable),
        "n_polls": n,
        "cpu_per_eval_whole_s": t_whole,
        "cpu_per_eval_incremental_s": t_inc,
        "ratio": t_whole / t_inc,
        "max_rel_diff": float(err.max()),
        "load": os.getloadavg(),
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("specs", nargs="*", help="default: every shipped spec with fibers")
    p.add_argument("--out", help="append the JSON lines to this file")
    p.add_argument("--voxel", type=float, help="measuring grid (m); default: the spec's voxel")
    p.add_argument("--k", dest="k_dir", choices=("x", "y", "z"), help="also voxel K before/after")
    p.add_argument("--max-evals", type=int, help="budget for specs without [forcefield.relax]")
    p.add_argument("--eval-cost", action="store_true", help="CPU per evaluation, side by side")
    a = p.parse_args(argv)
    if a.eval_cost:
        for path in [Path(s).resolve() for s in a.specs]:
            print(json.dumps(eval_cost(path)), flush=True)
        return 0
    paths = [Path(s).resolve() for s in a.specs] or shipped_specs()
    for path in paths:
        with tempfile.TemporaryDirectory() as tmp:
            rec = run_one(path, Path(tmp), a.voxel, a.k_dir, a.max_evals)
        rec["max_evals"] = a.max_evals
        rec["load"] = os.getloadavg()
        line = json.dumps(rec)
        print(line, flush=True)
        if a.out:
            with open(a.out, "a") as fh:
                fh.write(line + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
