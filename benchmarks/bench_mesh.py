"""Benchmark of the pore-space mesher on a Toray-like RVE (tet count, time, peak memory).

Geometry: 100 um cube, straight cylinders D = 7 um lying nearly in the x-y plane (random in-plane
angle, tilt within +-5 deg), added until the voxel porosity reaches ~0.8 (about 40 fibers);
analytic signed distance min_i(|r - axis_i| - R). Each configuration runs in a fresh subprocess
so that the peak RSS (ru_maxrss) is its own.

Usage::

    python benchmarks/bench_mesh.py                         # default sweep, prints a markdown table
    python benchmarks/bench_mesh.py --voxel 1e-6 --edge-fac 0.05 0.03 --direction z
    python benchmarks/bench_mesh.py --single '{"voxel": 1e-6, "edge_fac": 0.05}'   # one run, JSON
    # a spec's RVE (e.g. the Table III Toray-like RVE) with another seed, one mesher, JSON:
    python benchmarks/bench_mesh.py --spec studies/table3/straight.toml --seed 2 --mesher pytetwild
    # both meshers + FEM K on a smaller RVE of the same spec (50 um cube):
    python benchmarks/bench_mesh.py --spec studies/table3/straight.toml --seed 1 --size 50e-6 \
        --mesher stuffing pytetwild --permeability
    # the stuffing mesh at a finer lattice step (m) than its default (refinement check):
    python benchmarks/bench_mesh.py --spec studies/table3/straight.toml --seed 1 --size 100e-6 \
        --mesher stuffing --lattice-step 2.5e-6 --permeability
    # pytetwild at an edge of 0.6 thinnest-fiber diameters (default: EDGE_PER_DIAMETER):
    python benchmarks/bench_mesh.py --spec studies/table3/straight.toml --seed 1 \
        --mesher pytetwild --edge-diam 0.6 --permeability
    # the voxel route's K on the same RVE and BC only (no mesh), a reference for the FEM's:
    python benchmarks/bench_mesh.py --spec studies/table3/straight.toml --seed 1 --mesher \
        --voxel-route
    # the 5-seed table (issue 12 item 5): K of both meshers per seed, one subprocess per
    # (seed, mesher) appended to a resumable runs file; a re-run only prints the table
    python benchmarks/bench_mesh.py --table --spec studies/table3/straight.toml \
        --seeds 1 2 3 4 5 --out benchmarks/bench_mesh_tetwild_runs.jsonl
    # the same with the pytetwild walls projected onto the field (session 6)
    python benchmarks/bench_mesh.py --table --spec studies/table3/straight.toml --seeds 1 2 3 \
        --project-walls --out benchmarks/bench_mesh_tetwild_runs_s6.jsonl
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

SIZE = 100e-6
DIAM = 7e-6


def toray_like_distance(
    voxel: float, porosity: float = 0.8, seed: int = 1
) -> tuple[np.ndarray, int]:
    """Signed distance (metres) of random straight cylinders; returns (field, n_fibers)."""
    rng = np.random.default_rng(seed)
    n = int(round(SIZE / voxel))
    c = (np.arange(n) + 0.5) * voxel
    pts = np.stack(np.meshgrid(c, c, c, indexing="ij"), axis=-1).reshape(-1, 3)
    p2 = np.einsum("ij,ij->i", pts, pts)
    d2 = np.full(len(pts), np.inf)  # squared distance to the nearest axis
    r = 0.5 * DIAM
    n_fib = 0
    while True:
        omega = rng.uniform(0, np.pi)
        theta = np.radians(rng.uniform(-5, 5))
        u = np.array([np.cos(omega) * np.cos(theta), np.sin(omega) * np.cos(theta), np.sin(theta)])
        p0 = rng.uniform(0, SIZE, 3)
        pu = pts @ np.stack([u, p0], axis=1)  # (N, 2): r.u, r.p0
        t = pu[:, 0] - p0 @ u
        # |r - p0|^2 - ((r - p0).u)^2
        np.minimum(d2, p2 - 2 * pu[:, 1] + p0 @ p0 - t * t, out=d2)
        n_fib += 1
        if float((d2 > r * r).mean()) <= porosity:
            break
    d = np.sqrt(np.maximum(d2, 0.0)) - r
    return d.reshape(n, n, n), n_fib


def run_single(cfg: dict) -> dict:
    from psdesign.meshing.pore_mesh import mesh_pore_space

    t0 = time.perf_counter()
    name = f"psdesign_toray_{cfg['voxel']:g}_{cfg.get('seed', 1)}.npz"
    cache = Path(tempfile.gettempdir()) / name
    if cache.exists():  # the geometry is not part of the mesh benchmark: reuse it
        with np.load(cache) as z:
            d, n_fib = z["d"], int(z["n_fib"])
    else:
        d, n_fib = toray_like_distance(cfg["voxel"], seed=cfg.get("seed", 1))
        np.savez(cache, d=d, n_fib=n_fib)
    t_geom = time.perf_counter() - t0
    t0 = time.perf_counter()
    out = {
        "config": cfg,
        "n_fibers": n_fib,
        "porosity_voxel": float((d > 0).mean()),
        "geometry_s": t_geom,
    }
    try:
        pm = mesh_pore_space(
            d,
            cfg["voxel"],
            (SIZE,) * 3,
            cfg.get("direction", "z"),
            mesher="pytetwild",
            aux_length=cfg.get("aux", 0.2),
            edge_length=cfg.get("edge_abs"),
            edge_length_fac=cfg.get("edge_fac", 0.05),
            epsilon=cfg.get("epsilon"),
            surface_step=cfg.get("step"),
            simplify_tol=cfg.get("simplify", 0.0) * cfg["voxel"],
            num_threads=cfg.get("threads", 1),
            tetwild_options=cfg.get("tetwild"),
        )
        q = pm.quality
        keys = [
            "n_tets",
            "n_points",
            "n_surface_triangles",
            "edge_length_m",
            "epsilon_rel",
            "min_dihedral_deg",
            "p01_min_dihedral_deg",
            "mean_radius_ratio",
            "volume_rel_error",
            "volume_rel_error_vs_voxel",
            "porosity_mesh",
            "pore_centroid_fraction",
            "n_closed_gap_voxels",
            "n_removed_components",
            "surface_s",
            "tetwild_s",
            "tagging_s",
            "checks_s",
            "wall_time_s",
        ]
        out.update({k: q[k] for k in keys})
        out["ok"] = True
    except ValueError as e:
        out["ok"] = False
        out["error"] = f"{type(e).__name__}: {e}"
    out["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    out["total_s"] = time.perf_counter() - t0
    return out


SPEC_KEYS = [
    "n_tets",
    "n_points",
    "porosity_voxel",
    "porosity_analytic",
    "porosity_mesh",
    "pore_volume_m3",
    "analytic_pore_volume_m3",
    "pore_volume_rel_diff",
    "pore_volume_rel_diff_vs_voxel",
    "volume_rel_error",
    "pore_centroid_fraction",
    "min_dihedral_deg",
    "n_closed_gap_voxels",
    "n_removed_components",
    "wall_shift_m",
    "surface_step",
    "lattice_step_m",
    "edge_length_m",
    "edge_length_per_diameter",
    "epsilon_rel",
    "n_wall_vertices_frozen",
    "n_dropped_inverted_tets",
    "p01_min_dihedral_deg",
    "tetwild_s",
    "wall_time_s",
    "wall_projection",
    "n_wall_projected",
    "n_wall_projection_withdrawn",
    "wall_phi_p99_before_m",
    "wall_phi_dev_p99_m",
    "wall_phi_dev_mean_m",
    "wall_projection_s",
]


def run_spec(path: str, seed: int, meshers: list[str], size: float | None, args) -> list[dict]:
    """Mesh one spec's RVE (generator seed, optional smaller cube) with each mesher; K if asked."""
    from psdesign.meshing.options import MeshOptions, thinnest_fiber_diameter
    from psdesign.meshing.pore_mesh import mesh_pore_space
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = load_spec(path)
    spec["generator"]["seed"] = seed
    if size is not None:
        spec["rve"]["size"] = [size] * 3
    t0 = time.perf_counter()
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    t_geom = time.perf_counter() - t0
    flow = dict(spec["flow"])
    rows = []
    if args.voxel_route:  # the voxel route's K on the same RVE and BC (a reference for the FEM)
        rows.append(_voxel_row(path, seed, spec, built, fields, flow, args, t_geom))
    for mesher in meshers:
        extra = {"mesher": mesher, "num_threads": args.threads}
        tw = json.loads(args.tetwild) if args.tetwild else {}
        if args.stop_energy is not None:
            tw["stop_energy"] = args.stop_energy
        if tw and mesher == "pytetwild":
            extra["tetwild_options"] = tw
        if args.epsilon is not None and mesher == "pytetwild":
            extra["epsilon"] = args.epsilon
        if args.edge_fac is not None and mesher == "pytetwild":
            extra["edge_length_fac"] = args.edge_fac[0]
        if args.edge_diam is not None and mesher == "pytetwild":
            extra["edge_per_diameter"] = args.edge_diam
        if args.step is not None and mesher == "pytetwild":
            extra["surface_step"] = args.step
        if args.project_walls and mesher == "pytetwild":
            extra["project_walls"] = True
        if args.lattice_step is not None and mesher == "stuffing":
            extra["lattice_step"] = args.lattice_step
        opts = MeshOptions.from_flow(
            flow, fiber_diameter=thinnest_fiber_diameter(built.rve), **extra
        )
        row = {"spec": path, "seed": seed, "size_m": spec["rve"]["size"][0], "mesher": mesher}
        row["options"] = {k: v for k, v in extra.items() if k != "mesher"}
        row["key"] = run_key(path, seed, spec["rve"]["size"][0], mesher, row["options"])
        row["geometry_s"] = t_geom
        t1 = time.perf_counter()
        cpu1 = resource.getrusage(resource.RUSAGE_SELF).ru_utime
        try:
            pm = mesh_pore_space(
                fields.distance, float(fields.grid.spacing[0]), built.rve.size, args.direction, opts
            )
            row.update({k: pm.quality.get(k) for k in SPEC_KEYS}, ok=True)
            row["mesh_only_cpu_s"] = resource.getrusage(resource.RUSAGE_SELF).ru_utime - cpu1
            if args.permeability:
                from psdesign.flow.fem import permeability_fem

                res = permeability_fem(built.rve, fields, args.direction, flow, mesh=pm)
                row.update(
                    permeability_m2=res["permeability_m2"],
                    converged=res["converged"],
                    fem_s=res["wall_time_s"],
                    # the two windowed drops' gap: the FEM error bar's window term
                    window_rel_gap=res["pressure_drop_plane_window_pa"]
                    / res["pressure_drop_rve_pa"]
                    - 1.0,
                )
        except ValueError as e:
            row.update(ok=False, error=f"{type(e).__name__}: {e}")
        row["mesh_s"] = time.perf_counter() - t1  # mesh (+ FEM with --permeability), wall
        # CPU time of the same span: comparable across machine loads (the host is shared)
        row["mesh_cpu_s"] = resource.getrusage(resource.RUSAGE_SELF).ru_utime - cpu1
        row["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
        row["cpu_total_s"] = resource.getrusage(resource.RUSAGE_SELF).ru_utime
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


def _voxel_row(path, seed, spec, built, fields, flow, args, t_geom) -> dict:
    """K of the voxel route (``flow.solver = "voxel"``, the FEM's BC) on the spec's grid."""
    from psdesign.flow.voxel import permeability_voxel

    vflow = {**flow, "solver": "voxel", "bc": flow.get("bc") or "permeameter"}
    cpu1 = resource.getrusage(resource.RUSAGE_SELF).ru_utime
    res = permeability_voxel(fields, args.direction, vflow, rve=built.rve)
    row = {"spec": path, "seed": seed, "size_m": spec["rve"]["size"][0], "mesher": "voxel"}
    row.update(
        geometry_s=t_geom,
        voxel_m=spec["rve"]["voxel"],
        permeability_m2=res["permeability_m2"],
        converged=res["converged"],
        iterations=res.get("iterations"),
        cells_per_diameter=res.get("cells_per_diameter"),
        copies=res.get("copies"),
        voxel_s=res["wall_time_s"],
        voxel_cpu_s=resource.getrusage(resource.RUSAGE_SELF).ru_utime - cpu1,
        peak_rss_gb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2,
        ok=True,
    )
    print(json.dumps(row), flush=True)
    return row


def run_key(spec: str, seed: int, size: float, mesher: str, options: dict) -> str:
    """Identity of one (spec, seed, size, mesher, options) run in a runs file."""
    opts = {k: v for k, v in sorted(options.items()) if k != "num_threads" or v != 1}
    return json.dumps([Path(spec).name, seed, size, mesher, opts], sort_keys=True)


def _spec_cmd(args, seed: int, mesher: str) -> list[str]:
    """The ``--spec`` command line of one (seed, mesher) run of :func:`run_table`."""
    cmd = [sys.executable, __file__, "--spec", args.spec, "--seed", str(seed), "--mesher", mesher]
    cmd += ["--direction", args.direction, "--threads", str(args.threads), "--permeability"]
    if args.size is not None:
        cmd += ["--size", repr(args.size)]
    if mesher == "pytetwild":
        for flag, value in (("--edge-diam", args.edge_diam), ("--stop-energy", args.stop_energy)):
            if value is not None:
                cmd += [flag, repr(value)]
        if args.tetwild:
            cmd += ["--tetwild", args.tetwild]
        if args.project_walls:
            cmd += ["--project-walls"]
    if mesher == "stuffing" and args.lattice_step is not None:
        cmd += ["--lattice-step", repr(args.lattice_step)]
    return cmd


def run_table(args) -> None:
    """Both meshers' FEM K per seed; missing runs go to ``args.out`` (resumable), then the table."""
    from psdesign.meshing.tetwild_mesher import EDGE_PER_DIAMETER

    out = Path(args.out)
    rows = {}
    if out.exists():
        for line in out.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                rows[r["key"]] = r
    table = []
    for seed in args.seeds:
        pair = {}
        for mesher in ("pytetwild", "stuffing"):
            cmd = _spec_cmd(args, seed, mesher)
            opts = {}
            if mesher == "pytetwild":
                tw = json.loads(args.tetwild) if args.tetwild else {}
                if args.stop_energy is not None:
                    tw["stop_energy"] = args.stop_energy
                opts = {"tetwild_options": tw} if tw else {}
                # the default edge is part of the key: a later default change re-runs
                opts["edge_per_diameter"] = args.edge_diam or EDGE_PER_DIAMETER
                if args.project_walls:  # walls projected onto the field (opt-in, session 6)
                    opts["project_walls"] = True
            elif args.lattice_step is not None:
                opts = {"lattice_step": args.lattice_step}
            size = args.size if args.size is not None else _spec_size(args.spec)
            key = run_key(args.spec, seed, size, mesher, opts)
            if key not in rows:
                print("running:", " ".join(cmd), file=sys.stderr, flush=True)
                t0 = time.perf_counter()
                res = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
                line = [s for s in res.stdout.splitlines() if s.startswith("{")]
                r = json.loads(line[-1]) if line else {"key": key, "ok": False}
                r.setdefault("error", res.stderr[-300:] if not line else None)
                r["key"] = key  # as asked (a row's own key may differ by default options)
                r["wall_s"] = time.perf_counter() - t0
                r["load"] = Path("/proc/loadavg").read_text().split()[:3]
                rows[key] = r
                with out.open("a") as fh:
                    fh.write(json.dumps(r) + "\n")
            pair[mesher] = rows[key]
        table.append((seed, pair))
    print(_table_md(table))


def _spec_size(spec: str) -> float:
    from psdesign.schema.spec import load_spec

    return float(load_spec(spec)["rve"]["size"][0])


def _table_md(table) -> str:
    """Markdown table of :func:`run_table`'s rows."""
    lines = [
        "| seed | mesher | edge / D | tets | pore volume vs analytic | K (m^2) | pytetwild vs "
        "stuffing | mesh CPU s | mesh wall s | mesh+FEM CPU s | run wall s | peak RSS GB | load |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for seed, pair in table:
        k = {m: r.get("permeability_m2") for m, r in pair.items()}
        for mesher, r in pair.items():
            if not r.get("ok"):
                lines.append(f"| {seed} | {mesher} | failed: {str(r.get('error'))[:80]} |")
                continue
            diff = ""
            if mesher == "pytetwild" and k.get("stuffing") and k.get("pytetwild"):
                diff = f"**{100 * (k['pytetwild'] / k['stuffing'] - 1):+.2f} %**"
            epd = r.get("edge_length_per_diameter")
            lines.append(
                f"| {seed} | {mesher} | {f'{epd:.2f}' if epd else '-'} | {r['n_tets']} | "
                f"{r['pore_volume_rel_diff']:+.1e} | {r.get('permeability_m2', 0):.4e} | {diff} | "
                f"{r['mesh_only_cpu_s']:.0f} | {r['wall_time_s']:.0f} | {r['mesh_cpu_s']:.0f} | "
                f"{r.get('wall_s', 0):.0f} | "
                f"{r['peak_rss_gb']:.2f} | {' '.join(r.get('load', []))} |"
            )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--single", help="JSON config: run one case in this process")
    ap.add_argument("--spec", help="mesh this spec's RVE instead of the built-in geometry")
    ap.add_argument("--seed", type=int, default=1, help="generator.seed for --spec")
    ap.add_argument("--size", type=float, default=None, help="cube side for --spec (m)")
    ap.add_argument("--mesher", nargs="*", default=["pytetwild"], help="meshers for --spec")
    ap.add_argument("--stop-energy", type=float, default=None, help="pytetwild stop_energy")
    ap.add_argument("--tetwild", default=None, help="JSON of pytetwild options (--spec)")
    ap.add_argument("--permeability", action="store_true", help="FEM K per mesh (--spec)")
    ap.add_argument(
        "--voxel-route", action="store_true", help="also the voxel route's K, same BC (--spec)"
    )
    ap.add_argument("--voxel", type=float, nargs="+", default=[1e-6, 0.5e-6])
    ap.add_argument("--edge-fac", type=float, nargs="+", default=None)
    ap.add_argument(
        "--edge-diam", type=float, default=None, help="pytetwild edge in fiber diameters (--spec)"
    )
    ap.add_argument("--table", action="store_true", help="5-seed table of both meshers (--spec)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5], help="--table seeds")
    ap.add_argument(
        "--out", default=str(Path(__file__).with_name("bench_mesh_tetwild_runs.jsonl")),
        help="--table runs file (resumable)",
    )  # fmt: skip
    ap.add_argument("--direction", default="z")
    ap.add_argument("--step", type=int, default=None, help="surface step (default: auto)")
    ap.add_argument("--epsilon", type=float, default=None)
    ap.add_argument(
        "--lattice-step", type=float, default=None, help="stuffing lattice step (m; --spec)"
    )
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument(
        "--project-walls", action="store_true", help="pytetwild: walls projected onto the field"
    )
    ap.add_argument("--timeout", type=float, default=1800)
    args = ap.parse_args()
    if args.single:
        print(json.dumps(run_single(json.loads(args.single))))
        return
    if args.table:
        run_table(args)
        return
    if args.spec:
        run_spec(args.spec, args.seed, args.mesher, args.size, args)
        return
    args.edge_fac = args.edge_fac or [0.05, 0.03]
    rows = []
    for vox in args.voxel:
        for fac in args.edge_fac:
            cfg = {
                "voxel": vox,
                "edge_fac": fac,
                "direction": args.direction,
                "step": args.step,
                "epsilon": args.epsilon,
                "threads": args.threads,
            }
            try:
                res = subprocess.run(
                    [sys.executable, __file__, "--single", json.dumps(cfg)],
                    capture_output=True,
                    text=True,
                    timeout=args.timeout,
                )
                line = [s for s in res.stdout.splitlines() if s.startswith("{")]
                r = (
                    json.loads(line[-1])
                    if line
                    else {"config": cfg, "ok": False, "error": res.stderr[-500:]}
                )
            except subprocess.TimeoutExpired:
                r = {"config": cfg, "ok": False, "error": f"timeout {args.timeout} s"}
            rows.append(r)
            print(json.dumps(r), file=sys.stderr, flush=True)
    print(
        "| voxel um | step | edge_fac | edge um | surf tris | tets | tetwild s | total mesh s |"
        " peak GB | vol err % | pore centroid % | min dihedral | porosity mesh |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        c = r["config"]
        if not r.get("ok"):
            print(
                f"| {c['voxel'] * 1e6:g} | {c['step']} | {c['edge_fac']} | failed: "
                f"{r.get('error', '')[:80]} |"
            )
            continue
        print(
            f"| {c['voxel'] * 1e6:g} | {c['step']} | {c['edge_fac']} | "
            f"{r['edge_length_m'] * 1e6:.2f} | {r['n_surface_triangles']} | {r['n_tets']} | "
            f"{r['tetwild_s']:.1f} | {r['wall_time_s']:.1f} | {r['peak_rss_gb']:.2f} | "
            f"{100 * r['volume_rel_error']:.2f} | {100 * r['pore_centroid_fraction']:.2f} | "
            f"{r['min_dihedral_deg']:.1f} | {r['porosity_mesh']:.4f} |"
        )


if __name__ == "__main__":
    main()
