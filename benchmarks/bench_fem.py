"""K-vs-cost convergence of the Taylor-Hood Stokes solver (solvers.fem_stokes).

Cases
-----
cylinders
    Flow across a square array of cylinders (solid fraction 0.1), three half cells in a row,
    structured mesh with isotropic-ish elements in 3-D (several layers in z), slip sides.
    Reference: Sangani & Acrivos (1982) series (see tests/test_fem_stokes.py).
fibers
    Fiber-like geometry: a unit box minus 10 random straight cylinders lying in xy planes
    (radius 0.07, porosity ~0.8), surface by manifold3d, tetrahedra by pytetwild, box faces
    snapped flat, flow along z (through-plane), slip sides. Reference: the finest mesh.

toray
    The Toray-like through-plane permeameter solve of ``studies/table3/straight.toml``
    (size = voxel in um, default 0.5: the stuffing mesher's default mesh, 658 k unknowns),
    slip sides, tol 1e-6, K from the windowed dissipation as in ``permeability_fem``; the mesh
    is cached as a pickle. ``--krylov gmres minres`` runs the block-triangular GMRES and the
    block-diagonal MINRES one after the other (solve CPU seconds do not depend on the load).

Tet meshes of the fibers case are cached in $PSDESIGN_BENCH_CACHE (default
/tmp/psdesign_bench_cache); the reported mesh time is the pytetwild time only on a cache miss.
Each size runs in its own subprocess so that the peak resident memory (getrusage high-water
mark) belongs to that size alone.

Usage
-----
    python benchmarks/bench_fem.py                       # both cases, default sizes
    python benchmarks/bench_fem.py --case fibers --sizes 0.06 0.04
    python benchmarks/bench_fem.py --case fibers --sizes 0.07 --refine 1   # 1:8 refined mesh
    python benchmarks/bench_fem.py --one cylinders 8     # one run, prints one JSON line
    python benchmarks/bench_fem.py --case toray --krylov gmres minres   # new vs old, one run
    python benchmarks/bench_fem.py --case toray --lattice-step 3.333333   # issue 16's 657 k case
    python benchmarks/bench_fem.py --one array along/periodic/gmres  # array, either bc
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))  # tests/meshes.py

PHI = 0.1
SPACING = 1.0
RADIUS = float(np.sqrt(PHI / np.pi))
CACHE = os.environ.get("PSDESIGN_BENCH_CACHE", "/tmp/psdesign_bench_cache")
DEFAULT_SIZES = {
    "cylinders": [4, 8, 12, 16, 24],
    "fibers": [0.07, 0.05, 0.035, 0.025],
    "toray": [0.5],
}


def _rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e9


def k_transverse_sa(a: float, phi: float) -> float:
    return a * a / (8 * phi) * (-np.log(phi) - 1.476 + 2 * phi - 1.774 * phi**2 + 4.076 * phi**3)


def run_cylinders(n: int, tol: float = 1e-8) -> dict:
    from meshes import cylinder_transverse_row

    from solvers.fem_stokes import StokesOptions, solve_stokes

    t0 = time.perf_counter()
    n_z = max(1, n // 4)
    pts, tets, tags = cylinder_transverse_row(SPACING, RADIUS, 3, n, n, n_z=n_z)
    t_mesh = time.perf_counter() - t0
    depth = pts[:, 2].max()
    res = solve_stokes(
        pts,
        tets,
        tags,
        slip=("side_y0", "side_y1", "side_z0", "side_z1"),
        options=StokesOptions(tol=tol),
    )
    means = [res.plane_mean(0, xp, n=64)[0] for xp in (SPACING, 2 * SPACING)]
    grad = (means[0] - means[1]) / SPACING
    k = res.flux["outlet"] / (SPACING / 2 * depth) / grad
    k_ref = k_transverse_sa(RADIUS, PHI)
    return dict(
        case="cylinders",
        size=n,
        tol=tol,
        t_mesh=t_mesh,
        k=k,
        k_ref=k_ref,
        err_ref=k / k_ref - 1,
        **_summary(res),
    )


def fiber_surface(seed: int = 3, n_fibers: int = 10, radius: float = 0.07):
    import manifold3d as m3

    rng = np.random.default_rng(seed)
    box = m3.Manifold.cube([1.0, 1.0, 1.0])
    fibers = []
    for _ in range(n_fibers):
        ang = rng.uniform(0, 180)
        cx, cy = rng.uniform(0.2, 0.8, size=2)
        cz = rng.uniform(0.12, 0.88)
        cyl = m3.Manifold.cylinder(3.0, radius, radius, 48).translate([0, 0, -1.5])
        cyl = cyl.rotate([0, 90, 0]).rotate([0, 0, ang]).translate([cx, cy, cz])
        fibers.append(cyl)
    solid = box - m3.Manifold.batch_boolean(fibers, m3.OpType.Add)
    porosity = solid.volume()
    mesh = solid.to_mesh()
    v = np.array(mesh.vert_properties, dtype=np.float64)[:, :3].copy()
    f = np.array(mesh.tri_verts, dtype=np.int32).copy()
    return v, f, porosity


def run_fibers(fac: float, tol: float = 1e-8, refine: int = 0) -> dict:
    import pytetwild
    from meshes import snap_to_box, tag_box_boundary

    from solvers.fem_stokes import StokesOptions, solve_stokes

    t0 = time.perf_counter()
    v, f, porosity = fiber_surface()
    cache = os.path.join(CACHE, f"fibers_{fac}.npz")
    if os.path.exists(cache):  # pytetwild is slow (minutes); reuse meshes between runs
        d = np.load(cache)
        p, t = d["p"], d["t"]
    else:
        # pytetwild writes __tracked_surface.stl into the working directory: run it in a scratch one
        with tempfile.TemporaryDirectory() as scratch, contextlib.chdir(scratch):
            p, t = pytetwild.tetrahedralize(v, f, edge_length_fac=fac, num_threads=1)
        os.makedirs(CACHE, exist_ok=True)
        np.savez(cache, p=p, t=t)
    p = snap_to_box(p, (0, 0, 0), (1, 1, 1))
    t = t.astype(np.int64)
    if refine:  # uniform 1:8 refinement: same polyhedral geometry, h / 2**refine
        from skfem import MeshTet

        m = MeshTet(p.T, t.T).refined(refine)
        p, t = m.p.T.copy(), m.t.T.copy()
    tags = tag_box_boundary(p, t, (0, 0, 0), (1, 1, 1), 2)
    t_mesh = time.perf_counter() - t0
    rss_mesh = _rss_gb()
    res = solve_stokes(
        p,
        t,
        tags,
        slip=("side_x0", "side_x1", "side_y0", "side_y1"),
        options=StokesOptions(tol=tol),
    )
    k = res.flux["outlet"] * 1.0 / (1.0 * 1.0)  # K = mu Q L / (A dp), mu = dp = L = A = 1
    size = f"{fac}/r{refine}" if refine else fac
    return dict(
        case="fibers",
        size=size,
        tol=tol,
        t_mesh=t_mesh,
        k=k,
        porosity=porosity,
        rss_after_mesh_gb=rss_mesh,
        **_summary(res),
    )


def toray_mesh(
    voxel: float = 0.5e-6,
    direction: str = "z",
    size: float = 100e-6,
    lattice_step: float | None = None,
):
    """RVE, flow table and permeameter mesh of ``studies/table3/straight.toml`` at ``voxel`` (m)
    in a cube of side ``size`` (m), cached as a pickle in $PSDESIGN_BENCH_CACHE; the stuffing
    mesher's default step unless ``lattice_step`` (m) is given (``flow.lattice_step``)."""
    import pickle
    import tempfile
    from pathlib import Path

    step = "default" if lattice_step is None else f"{lattice_step:g}"
    cache = Path(CACHE) / f"toray_{voxel:g}_{direction}_{size:g}_{step}.pkl"
    if cache.exists():
        with cache.open("rb") as f:
            return pickle.load(f)
    from psdesign.flow.fem import _mesh
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    root = Path(__file__).resolve().parents[1]
    text = (root / "studies/table3/straight.toml").read_text()
    text = text.replace("voxel = 0.5e-6", f"voxel = {voxel!r}")
    text = text.replace("size = [100e-6, 100e-6, 100e-6]", f"size = [{size!r}, {size!r}, {size!r}]")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "straight.toml"
        path.write_text(text)
        spec = load_spec(path)
    built = build_rve(spec)
    fields = built.voxelize(voxel)
    flow = dict(spec["flow"])
    if lattice_step is not None:
        flow["lattice_step"] = lattice_step
    pm = _mesh(built.rve, fields, direction, flow, "permeameter")
    cache.parent.mkdir(parents=True, exist_ok=True)
    with cache.open("wb") as f:
        pickle.dump((built.rve, flow, pm), f)
    return built.rve, flow, pm


def run_toray(
    voxel: float, tol: float = 1e-6, krylov: str = "gmres", lattice_step: float | None = None
) -> dict:
    """The Toray-like through-plane permeameter solve (``permeability_fem``'s settings: slip
    sides, windowed-dissipation K) on the cached mesh of :func:`toray_mesh` (issue 16 item 5's
    657 k-unknown case: ``lattice_step`` 10 / 3 um, the default before session 7)."""
    from psdesign.flow.fem import rve_window
    from psdesign.meshing import tags as T
    from solvers.fem_stokes import StokesOptions, solve_stokes

    t0 = time.perf_counter()
    rve, flow, pm = toray_mesh(voxel, lattice_step=lattice_step)
    t_mesh = time.perf_counter() - t0
    rss_mesh = _rss_gb()
    sides = [t for t in pm.facet_tags if T.is_side(t)]
    mu = float(flow["viscosity"])
    res = solve_stokes(
        pm.points,
        pm.tets,
        pm.facet_tags,
        p_inlet=1.0,
        p_outlet=0.0,
        viscosity=mu,
        noslip=[T.WALL],
        slip=sides,
        options=StokesOptions(tol=tol, krylov=krylov),
    )
    start, end = pm.porous_region
    q = abs(res.flux[T.OUTLET])
    dp_rve = 2.0 * res.dissipation(rve_window(pm.axis, start, end)) / q
    area = float(np.prod(np.delete(rve.size, pm.axis)))
    k = mu * q * (end - start) / (area * dp_rve)
    return dict(
        case="toray",
        size=f"{voxel:g}/{krylov}" + ("" if lattice_step is None else f"/step {lattice_step:g}"),
        tol=tol,
        t_mesh=t_mesh,
        k=k,
        rss_after_mesh_gb=rss_mesh,
        **_summary(res),
    )


def run_array(kind: str, bc: str, krylov: str, phi: float = 0.3, cells: int = 3) -> dict:
    """A square cylinder array through ``permeability_fem`` (``tests/validation/fem_arrays``,
    lattice step 4 um, voxel 1 um) with the Krylov method ``krylov``: both boundary conditions
    use the same solver path."""
    import functools

    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests", "validation"))
    from fem_arrays import array_k

    import solvers.fem_stokes as fs

    for name in ("solve_stokes", "solve_stokes_periodic"):
        setattr(fs, name, functools.partial(getattr(fs, name), krylov=krylov))
    c0 = time.process_time()
    r = array_k(kind, phi, cells, bc, 4e-6)
    return dict(
        case="array",
        size=f"{kind}/{bc}/phi {phi}/{cells} cells/{krylov}",
        k=r["permeability_m2"],
        err_ref=r["permeability_m2"] / r["k_ref"] - 1,
        n_dofs=r["n_dofs"],
        iterations=r["iterations"],
        residual=r["residual"],
        cpu_total=time.process_time() - c0,
        load=os.getloadavg()[0],
    )


def _summary(res) -> dict:
    return dict(
        n_tets=res.n_tets,
        n_points=res.n_points,
        n_dofs=res.n_dofs,
        method=res.method,
        iterations=res.iterations,
        residual=res.residual,
        converged=res.converged,
        flux_imbalance=res.flux_imbalance,
        t_assembly=res.timings["assembly"],
        t_solve=res.timings["solve"],
        cpu_solve=res.timings["solve_cpu"],
        t_total_solver=res.wall_time_s,
        estimate_gb=res.memory_estimate_gb,
        peak_gb=_rss_gb(),
        load=os.getloadavg()[0],
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", choices=["cylinders", "fibers", "toray", "all"], default="all")
    ap.add_argument("--sizes", nargs="*", type=float)
    ap.add_argument("--one", nargs=2, metavar=("CASE", "SIZE"))
    ap.add_argument("--timeout", type=float, default=1800)
    ap.add_argument(
        "--tol", type=float, default=None, help="solver tolerance (default 1e-8; toray 1e-6)"
    )
    ap.add_argument(
        "--refine", type=int, default=0, help="fibers: uniform refinements of the pytetwild mesh"
    )
    ap.add_argument(
        "--krylov",
        nargs="*",
        default=["gmres"],
        choices=["gmres", "minres"],
        help="toray: Krylov method(s), each in its own subprocess, one after the other",
    )
    ap.add_argument(
        "--lattice-step",
        type=float,
        default=None,
        help="toray: stuffing lattice step in um (default: the mesher's; 3.333 = issue 16's case)",
    )
    args = ap.parse_args()
    if args.one:
        case, size = args.one
        if case == "cylinders":
            out = run_cylinders(int(size), args.tol or 1e-8)
        elif case == "array":
            kind, bc, kr = size.split("/")
            out = run_array(kind, bc, kr)
        elif case == "toray":
            step = None if args.lattice_step is None else args.lattice_step * 1e-6
            out = run_toray(float(size) * 1e-6, args.tol or 1e-6, args.krylov[0], step)
        else:
            out = run_fibers(float(size), args.tol or 1e-8, args.refine)
        print(json.dumps(out))
        return
    cases = ["cylinders", "fibers"] if args.case == "all" else [args.case]
    for case in cases:
        rows = []
        for s in args.sizes or DEFAULT_SIZES[case]:
            s = int(s) if case == "cylinders" else s
            for kr in args.krylov if case == "toray" else args.krylov[:1]:
                row = _run_one(case, s, args, kr)
                if row is None:
                    break
                rows.append(row)
                print(json.dumps(row), flush=True)
        _table(case, rows)


def _run_one(case: str, size, args, krylov: str) -> dict | None:
    cmd = [sys.executable, __file__, "--one", case, str(size), "--refine", str(args.refine)]
    cmd += ["--krylov", krylov] + ([] if args.tol is None else ["--tol", str(args.tol)])
    if args.lattice_step is not None:
        cmd += ["--lattice-step", str(args.lattice_step)]
    try:
        cp = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
    except subprocess.TimeoutExpired:
        print(f"{case} {size}: timed out after {args.timeout} s", flush=True)
        return None
    if cp.returncode != 0:
        print(f"{case} {size}: failed\n{cp.stderr[-2000:]}", flush=True)
        return None
    return json.loads(cp.stdout.strip().splitlines()[-1])


def _table(case: str, rows: list[dict]) -> None:
    if not rows:
        return
    k_fine = rows[-1]["k"]
    print(f"\n### {case}\n")
    print(
        "| size | tets | dofs | method | iters | residual | K | dK vs ref | dK vs finest "
        "| mesh s | assembly s | solve s | solve CPU s | load | peak GB | estimate GB |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        ref = f"{r['err_ref']:+.2e}" if "err_ref" in r else "-"
        print(
            f"| {r['size']} | {r['n_tets']} | {r['n_dofs']} | {r['method']} | {r['iterations']} "
            f"| {r['residual']:.1e} | {r['k']:.5e} | {ref} | {r['k'] / k_fine - 1:+.2e} "
            f"| {r['t_mesh']:.1f} | {r['t_assembly']:.1f} | {r['t_solve']:.1f} "
            f"| {r.get('cpu_solve', float('nan')):.1f} | {r.get('load', float('nan')):.1f} "
            f"| {r['peak_gb']:.2f} | {r['estimate_gb']:.2f} |"
        )
    print(flush=True)


if __name__ == "__main__":
    main()
