"""Lattice ("isosurface stuffing") mesher vs pytetwild: K accuracy, tets, mesh and solve time.

Cases
-----
``parallel``
    Flow along a square array of cylinders (solid fraction 0.1), quarter cell with slip sides,
    voxel field of the exact distance (20 voxels per half spacing), K vs Drummond & Tahir (1984).
``transverse``
    Flow across the same array: a row of three cells, K from the mean-pressure drop over the
    middle cell, vs Sangani & Acrivos (1982).
``rve``
    Toray-like RVE from ``studies/table3/straight.toml`` with voxel 1 um (generator seed 1),
    ``psdesign.flow.permeability.permeability_fem`` with ``mesher`` = stuffing | pytetwild.

Each configuration runs in a fresh subprocess (peak RSS is its own).

Usage::

    python benchmarks/bench_stuffing.py parallel --steps 4 3 2 1.5 1
    python benchmarks/bench_stuffing.py transverse --steps 4 3 2
    python benchmarks/bench_stuffing.py rve --direction z --steps 4 3 2.5 2 [--pytetwild]
    python benchmarks/bench_stuffing.py --single '{"case": "rve", "mesher": "stuffing", "step": 3}'
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

PHI = 0.1
SPACING = 1.0
RADIUS = float(np.sqrt(PHI / np.pi))
ROOT = Path(__file__).resolve().parents[1]


def k_parallel_dt(a: float, phi: float) -> float:
    """Drummond & Tahir (1984), flow along a square array."""
    return a * a / (4 * phi) * (-np.log(phi) - 1.476 + 2 * phi - 0.5 * phi**2)


def k_transverse_sa(a: float, phi: float) -> float:
    """Sangani & Acrivos (1982), flow across a square array."""
    return a * a / (8 * phi) * (-np.log(phi) - 1.476 + 2 * phi - 1.774 * phi**2 + 4.076 * phi**3)


def _grid(n: tuple[int, int, int], v: float):
    c = [(np.arange(k) + 0.5) * v for k in n]
    return np.meshgrid(*c, indexing="ij")


def run_parallel(cfg: dict) -> dict:
    from psdesign.meshing.pore_mesh import mesh_pore_space
    from solvers.fem_stokes import solve_stokes

    n = cfg.get("n", 20)
    half = SPACING / 2
    v = half / n
    nz = max(2, n // 4)
    x, y, _ = _grid((n, n, nz), v)
    d = np.sqrt(x**2 + y**2) - RADIUS
    t0 = time.perf_counter()
    pm = mesh_pore_space(
        d,
        v,
        (half, half, nz * v),
        "z",
        aux_length=0.0,
        mesher="stuffing",
        lattice_step=cfg["step"] * v,
        min_gap_voxels=0,
        match_volume=cfg.get("match_volume", False),
    )
    t_mesh = time.perf_counter() - t0
    sides = [k for k in pm.facet_tags if k.startswith("side")]
    t0 = time.perf_counter()
    res = solve_stokes(pm.points, pm.tets, pm.facet_tags, slip=sides, noslip=("wall",))
    t_solve = time.perf_counter() - t0
    k = res.flux["outlet"] * nz * v / half**2
    return {
        "k": k,
        "k_ref": k_parallel_dt(RADIUS, PHI),
        "rel_err": k / k_parallel_dt(RADIUS, PHI) - 1,
        "n_tets": pm.quality["n_tets"],
        "n_dofs": res.n_dofs,
        "mesh_s": t_mesh,
        "solve_s": t_solve,
        "converged": res.converged,
        "min_dihedral_deg": pm.quality["min_dihedral_deg"],
    }


def run_transverse(cfg: dict) -> dict:
    from psdesign.meshing.pore_mesh import mesh_pore_space
    from solvers.fem_stokes import solve_stokes

    n = cfg.get("n", 20)  # voxels per half spacing
    half = SPACING / 2
    v = half / n
    nx, ny, nz = 6 * n, n, max(2, n // 4)
    x, y, _ = _grid((nx, ny, nz), v)
    centres = (np.arange(3) + 0.5) * SPACING
    d = np.min([np.sqrt((x - c) ** 2 + y**2) for c in centres], axis=0) - RADIUS
    t0 = time.perf_counter()
    pm = mesh_pore_space(
        d,
        v,
        (nx * v, ny * v, nz * v),
        "x",
        aux_length=0.0,
        mesher="stuffing",
        lattice_step=cfg["step"] * v,
        min_gap_voxels=0,
        match_volume=cfg.get("match_volume", False),
    )
    t_mesh = time.perf_counter() - t0
    sides = [k for k in pm.facet_tags if k.startswith("side")]
    t0 = time.perf_counter()
    res = solve_stokes(pm.points, pm.tets, pm.facet_tags, slip=sides, noslip=("wall",))
    t_solve = time.perf_counter() - t0
    means = [res.plane_mean(0, xp, n=48)[0] for xp in (SPACING, 2 * SPACING)]
    grad = (means[0] - means[1]) / SPACING
    k = res.flux["outlet"] / (ny * v * nz * v) / grad
    kref = k_transverse_sa(RADIUS, PHI)
    return {
        "k": k,
        "k_ref": kref,
        "rel_err": k / kref - 1,
        "n_tets": pm.quality["n_tets"],
        "n_dofs": res.n_dofs,
        "mesh_s": t_mesh,
        "solve_s": t_solve,
        "converged": res.converged,
        "min_dihedral_deg": pm.quality["min_dihedral_deg"],
    }


def _toray_fields(voxel: float):
    """RVE of studies/table3/straight.toml at ``voxel`` (cached in /tmp, fibers + fields)."""
    import pickle

    cache = Path(tempfile.gettempdir()) / f"psdesign_stuffing_straight_{voxel:g}.pkl"
    if cache.exists():
        with cache.open("rb") as f:
            return pickle.load(f)
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    text = (
        (ROOT / "studies/table3/straight.toml")
        .read_text()
        .replace("voxel = 0.5e-6", f"voxel = {voxel!r}")
    )
    tmp = Path(tempfile.gettempdir()) / f"psdesign_stuffing_straight_{voxel:g}.toml"
    tmp.write_text(text)
    spec = load_spec(tmp)
    built = build_rve(spec)
    fields = built.voxelize(voxel)
    with cache.open("wb") as f:
        pickle.dump((built.rve, fields, spec["flow"]), f)
    return built.rve, fields, spec["flow"]


def run_rve(cfg: dict) -> dict:
    from psdesign.flow.permeability import permeability_fem
    from psdesign.meshing.pore_mesh import mesh_pore_space

    voxel = cfg.get("voxel", 1e-6)
    rve, fields, flow = _toray_fields(voxel)
    flow = dict(flow)
    t0 = time.perf_counter()
    if cfg["mesher"] == "stuffing":
        pm = mesh_pore_space(
            fields.distance,
            voxel,
            rve.size,
            cfg["direction"],
            aux_length=float(flow["aux_length"]),
            mesher="stuffing",
            lattice_step=cfg["step"] * 1e-6,
            match_volume=cfg.get("match_volume", False),
            stuffing_slab_factor=cfg.get("slab_factor", 1.0),
            volume_tol=cfg.get("volume_tol", 0.02),
            min_pore_fraction=cfg.get("min_pore_fraction", 0.97),
        )
    else:
        pm = mesh_pore_space(
            fields.distance,
            voxel,
            rve.size,
            cfg["direction"],
            aux_length=float(flow["aux_length"]),
            mesher="pytetwild",
            edge_length_fac=cfg.get("edge_fac", 0.05),
            surface_step=cfg.get("surface_step", 2),
            tetwild_options=cfg.get("tetwild"),
        )
    t_mesh = time.perf_counter() - t0
    r = permeability_fem(rve, fields, cfg["direction"], flow, mesh=pm)
    q = pm.quality
    return {
        "k": r["permeability_m2"],
        "n_tets": q["n_tets"],
        "n_dofs": r["n_dofs"],
        "mesh_s": t_mesh,
        "solve_s": r["wall_time_s"],
        "converged": r["converged"],
        "iterations": r["iterations"],
        "flux_imbalance": r["flux_imbalance"],
        "porosity_voxel": q["porosity_voxel"],
        "porosity_mesh": q["porosity_mesh"],
        "min_dihedral_deg": q["min_dihedral_deg"],
        "p01_min_dihedral_deg": q["p01_min_dihedral_deg"],
        "pore_centroid_fraction": q["pore_centroid_fraction"],
        "solver_peak_gb": r["peak_memory_gb"],
    }


def run_single(cfg: dict) -> dict:
    fn = {"parallel": run_parallel, "transverse": run_transverse, "rve": run_rve}[cfg["case"]]
    t0 = time.perf_counter()
    out = {"config": cfg, **fn(cfg)}
    out["total_s"] = time.perf_counter() - t0
    out["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case", nargs="?", choices=("parallel", "transverse", "rve"))
    ap.add_argument("--steps", type=float, nargs="+", default=[3.0, 2.0])
    ap.add_argument("--direction", default="z")
    ap.add_argument("--n", type=int, default=20, help="voxels per half spacing (arrays)")
    ap.add_argument("--pytetwild", action="store_true", help="rve: also the pytetwild route")
    ap.add_argument("--match-volume", action="store_true", help="stuffing: match_volume=True")
    ap.add_argument("--slab-factor", type=float, default=1.0, help="stuffing_slab_factor")
    ap.add_argument(
        "--edge-fac",
        type=float,
        nargs="*",
        default=[0.05],
        help="rve --pytetwild: edge_length_fac values",
    )
    ap.add_argument("--single", help="one configuration as JSON (runs in this process)")
    ap.add_argument("--timeout", type=float, default=1800)
    args = ap.parse_args()
    if args.single:
        print(json.dumps(run_single(json.loads(args.single))))
        return
    cfgs = []
    for s in args.steps:
        c = {"case": args.case, "step": s, "n": args.n, "match_volume": args.match_volume}
        if args.case == "rve":
            c = {
                "case": "rve",
                "mesher": "stuffing",
                "step": s,
                "direction": args.direction,
                "match_volume": args.match_volume,
                "slab_factor": args.slab_factor,
                "volume_tol": 0.2,
                "min_pore_fraction": 0,
            }
        cfgs.append(c)
    if args.case == "rve" and args.pytetwild:
        for ef in args.edge_fac:
            cfgs.append(
                {
                    "case": "rve",
                    "mesher": "pytetwild",
                    "direction": args.direction,
                    "edge_fac": ef,
                    "surface_step": 2,
                    "tetwild": {"stop_energy": 30},
                }
            )
    print(
        "| config | tets | dofs | mesh s | solve s | K (m^2) | rel. err | min dihedral | peak GB |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for c in cfgs:
        p = subprocess.run(
            [sys.executable, __file__, "--single", json.dumps(c)],
            capture_output=True,
            text=True,
            timeout=args.timeout,
            cwd=ROOT,
        )
        if p.returncode:
            print(f"| {json.dumps(c)} | failed: {p.stderr.strip().splitlines()[-1]} |")
            continue
        r = json.loads(p.stdout.strip().splitlines()[-1])
        err = f"{100 * r['rel_err']:+.2f} %" if "rel_err" in r else "-"
        print(
            f"| {json.dumps(c)} | {r['n_tets']} | {r['n_dofs']} | {r['mesh_s']:.2f} | "
            f"{r['solve_s']:.1f} | {r['k']:.4g} | {err} | {r['min_dihedral_deg']:.1f} | "
            f"{r['peak_rss_gb']:.2f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
