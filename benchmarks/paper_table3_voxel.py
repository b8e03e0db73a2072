"""Paper Table III on the voxel route: GA RVEs, 5 seeds, K_x, K_y, K_z, periodic and permeameter BC.

Usage::

    nice -n 5 python benchmarks/paper_table3_voxel.py run --kinds straight bent --seeds 1 2 3 4 5 \
        --bcs periodic --directions z x y --cache /tmp/table3 \
        --out benchmarks/paper_table3_voxel_runs.jsonl
    python benchmarks/paper_table3_voxel.py summary benchmarks/paper_table3_voxel_runs.jsonl
    nice -n 5 python benchmarks/paper_table3_voxel.py geometry --kinds straight --methods ga fast \
        --seeds 1 2 3 --cache /tmp/table3 --out benchmarks/paper_table3_geometry.jsonl

``run``: one RVE generation per (kind, method, seed, size), pickled in ``--cache`` and reused by
every BC and direction; every solve is cached as its own JSON file (``--cache``/solves), so a
stopped run resumes where it stopped, and is appended to ``--out`` once. ``--bc-tag`` names the
permeameter definition in the record (the definition may change between code versions).
``geometry``: what the generator actually produced (orientation, overlap, clustering by
nearest-neighbour fibre-axis distances, pore sizes by local thickness), no solve.
``summary``: mean +- 95 % CI (Student t, n - 1 dof) per (kind, method, size, bc, direction).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import paper_table3 as t3  # noqa: E402  (the shared helpers: cache, pore statistics, CI)

ROOT = t3.ROOT


def _spec(kind: str, method: str, seed: int, size: float | None) -> dict:
    from psdesign.schema.spec import load_spec

    spec = load_spec(ROOT / "studies" / "table3" / f"{kind}.toml")
    if size is not None:
        spec["rve"] = {**spec["rve"], "size": [size, size, size]}
    spec["generator"] = {**spec["generator"], "seed": seed}
    spec["intersections"] = {**spec.get("intersections", {}), "method": method}
    if method == "ga":
        spec["intersections"]["min_gap"] = 0.0
    return spec


#: Controlled placements derived from the GA RVE of one seed (section 2.4 of the doc): the same
#: drawn fibres (the first n of the seed's draw, n = the GA's count), moved by none, some or all
#: of the GA's adjustments. Names: which centre-z and which (x, y, angles, u, f) each keeps.
DERIVED = {
    "drawn": "the GA's drawn fibres, no removal (same fibres and count as the GA)",
    "ga-zdrawn": "the GA result with every centre z put back to the drawn one",
    "drawn-zga": "the drawn fibres with only the GA's centre-z moves",
    "ga-single": "the GA result exported as the paper's Fluent input reads (Sec. 7.1: centre and "
    "axis per fibre): one straight cylinder per fibre, no periodic copies, same fibre count",
    "ga-single-eps": "ga-single with the next fibres of the seed's draw added (unmoved, also "
    "one cylinder each) until the porosity is back at the spec's target",
}
#: Period of the ``ga-single`` cylinders, in RVE edges: long enough that no copy enters the box.
SINGLE_PERIOD = 3.0
METHODS = ("ga", "fast", "none", *DERIVED)


def drawn_state(spec: dict, n: int):
    """The first ``n`` fibres of the seed's draw (what every placement starts from)."""
    from psdesign.packing.generators import draw_fibers, parse_generator, parse_rve

    size, _, period = parse_rve(spec)
    return draw_fibers(parse_generator(spec, size, period), spec["generator"]["seed"], n, size)


def derive(built, spec: dict, method: str):
    """One of the :data:`DERIVED` placements from the GA RVE ``built`` of ``spec``'s seed.

    Fibre i of the GA result is fibre i of the draw (``psdesign.packing.generators._ga`` keeps
    the order), so the GA's adjustments are ``ga - drawn`` per fibre; the check below fails if
    a move exceeds the Sec. 7.1 ranges (+-1 deg, +-0.1 of the edge) times the number of GA
    rounds (a fibre kept from round 1 is adjusted again in round 2), i.e. if the order broke.
    """
    from psdesign.geometry.rve import RVE
    from psdesign.packing.build import BuiltRVE
    from psdesign.packing.fiberset import FiberState

    ga = FiberState.from_fibers(list(built.rve.fibers), fixed=False)
    drawn = drawn_state(spec, len(ga))
    size = np.asarray(built.rve.size, float)
    period = float(built.rve.period)
    shift = np.abs(ga.center - drawn.center) * period / size
    turn = np.maximum(np.abs(ga.theta - drawn.theta), np.abs(ga.omega - drawn.omega))
    rounds = max(1, len(built.report.get("ga", [])))
    if shift.max() > 0.1 * rounds + 1e-9 or turn.max() > 1.0 * rounds + 1e-9:
        raise RuntimeError(f"GA fibres do not match the draw (shift {shift.max():.3f} L)")
    out = drawn.copy() if method in ("drawn", "drawn-zga") else ga.copy()
    if method == "ga-single-eps":
        return _single_at_target(ga, spec, size, period, report_of=DERIVED[method])
    if method == "ga-single":  # exact cylinders on a lattice 3 edges wide: one copy in the box
        fibers, period = _single_cylinders(out, period)
        report = {"derived_from": "ga", "n_fibers": len(out), "derivation": DERIVED[method]}
        return BuiltRVE(rve=RVE(size, fibers, period=period), report=report)
    if method == "drawn-zga":
        out.center[:, 2] = ga.center[:, 2]
    elif method == "ga-zdrawn":
        out.center[:, 2] = drawn.center[:, 2]
    out.refresh_frames(np.ones(len(out), bool))
    rve = RVE(size, out.to_fibers(), period=period)
    report = {"derived_from": "ga", "n_fibers": len(out), "derivation": DERIVED[method]}
    report["center_z_std_m"] = float(np.std(out.center[:, 2]) * period)
    return BuiltRVE(rve=rve, report=report)


def _single_cylinders(st, period: float):
    """``st`` as exact cylinders on a lattice ``SINGLE_PERIOD`` edges wide (one copy each)."""
    out = st.copy()
    if any(sh != "rod" for sh in out.shape):
        raise ValueError("the single-cylinder export is defined for straight rods only")
    out.shape = ["cylinder"] * len(out)
    out.center /= SINGLE_PERIOD
    out.diameter /= SINGLE_PERIOD
    out.refresh_frames(np.ones(len(out), bool))
    return out.to_fibers(), period * SINGLE_PERIOD


def _single_at_target(ga, spec: dict, size: np.ndarray, period: float, report_of: str):
    """The GA fibres plus the next drawn ones, single cylinders, at the target porosity."""
    from psdesign.geometry.rve import RVE
    from psdesign.packing.build import BuiltRVE
    from psdesign.packing.fiberset import FiberState

    target = float(spec["generator"]["porosity"])
    tol = float(spec["generator"].get("porosity_tolerance", 0.005))
    voxel = 1e-6  # the search grid (the table's solves are on it)
    n = len(ga)
    pool = drawn_state(spec, 3 * n)
    for m in range(0, 2 * n):
        st = FiberState.concat(ga, pool.subset(np.arange(n, n + m)))
        fibers, per = _single_cylinders(st, period)
        rve = RVE(size, fibers, period=per)
        eps = rve.voxelize(voxel).porosity
        if eps <= target + tol:
            report = {"derived_from": "ga", "n_fibers": len(st), "added_fibers": m}
            report.update(derivation=report_of, porosity_1um=eps)
            return BuiltRVE(rve=rve, report=report)
    raise RuntimeError("target porosity not reached with single cylinders")


def build(kind: str, method: str, seed: int, size: float | None, cache: str):
    """The built RVE of one seed (GA, fast, none or a :data:`DERIVED` one), pickled in
    ``cache`` (the derived ones are rebuilt from the cached GA RVE, no optimisation)."""
    from psdesign.packing.build import build_rve

    t3.CACHE_DIR = cache
    t0 = time.perf_counter()
    base = "ga" if method in DERIVED else method
    spec = _spec(kind, base, seed, size)
    built = t3._cached_build(spec, build_rve)
    if method in DERIVED:
        built = derive(built, spec, method)
    return built, time.perf_counter() - t0


def _solve_path(cache: str, key: dict) -> Path:
    name = "_".join(f"{k}-{key[k]}" for k in sorted(key))
    return Path(cache) / "solves" / f"{name}.json"


def solve_one(built, fields, direction: str, bc: str, tol: float, copies="auto") -> dict:
    """One voxel solve: K along ``direction`` with ``bc`` to relative residual ``tol``.

    ``copies``: ``flow.permeameter_copies`` of the permeameter (1: one sample between the two
    reservoirs, as the paper's Fluent domain; "auto": stacked where the geometry is periodic).
    """
    from psdesign.flow.permeability import permeability
    from psdesign.schema.spec import load_spec

    flow = {**load_spec(ROOT / "studies" / "table3" / "straight.toml")["flow"]}
    flow.update(solver="voxel", bc=bc, tol=tol)
    if bc == "permeameter":
        flow["permeameter_copies"] = copies
    r = permeability(built.rve, fields, direction, flow, solver="voxel", error_estimate=False)
    keep = (
        "permeability_m2",
        "converged",
        "iterations",
        "residual",
        "wall_time_s",
        "face_mismatch",
        "cells_per_diameter",
        "n_cells",
        "permeability_column_m2",
        "pressure_drop_rve_pa",
        "pressure_drop_faces_pa",
        "pressure_drop_applied_pa",
        "pressure_drop_plane_window_pa",
        "pressure_drop_definition",
        "aux_length",
        "sides",
        "permeameter_copies",
        "geometry_periodic_along_flow",
        "warnings",
    )
    return {k: r[k] for k in keep if k in r}


def run(a) -> int:
    """Every (kind, seed, bc, direction) solve not yet cached; one generation per seed."""
    for kind in a.kinds:
        for seed in a.seeds:
            built, t_gen = build(kind, a.method, seed, a.size, a.cache)
            fields = None
            size = float(built.rve.size[0])
            for bc in a.bcs:
                tag = a.bc_tag if bc == "permeameter" else "periodic"
                for d in a.directions:
                    key = {"kind": kind, "method": a.method, "seed": seed, "size": f"{size:.3g}"}
                    key.update(voxel=f"{a.voxel:.3g}", bc=tag, dir=d)
                    path = _solve_path(a.cache, key)
                    if path.exists():
                        continue
                    if fields is None:
                        fields = built.rve.voxelize(a.voxel)
                    rec = {**key, "size_m": size, "voxel_m": a.voxel, "bc_model": bc}
                    rec.update(porosity=fields.porosity, omega=fields.intersection_volume_fraction)
                    rec.update(n_fibers=len(built.rve.fibers), generation_s=t_gen)
                    rec["tol"] = a.tol
                    rec.update(layering_stats(fields))
                    if bc == "permeameter":
                        rec["copies_requested"] = a.copies
                    rec.update(solve_one(built, fields, d, bc, a.tol, a.copies))
                    path.parent.mkdir(parents=True, exist_ok=True)
                    path.write_text(json.dumps(rec))
                    _append(a.out, rec)
                    print(json.dumps({k: rec[k] for k in ("kind", "seed", "bc", "dir")}), end=" ")
                    print(f"K = {rec['permeability_m2']:.4e} ({rec['wall_time_s']:.0f} s)")
                    sys.stdout.flush()
    return 0


# ---------------------------------------------------------------- geometry of the generator
def axis_points(rve, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``step`` (m) along every fibre's medial axis inside the box, and labels."""
    pts, lab = [], []
    for i, lines in enumerate(rve.medial_axes_m()):
        for line in lines:
            for p, q in zip(line[:-1], line[1:], strict=True):
                n = max(1, int(np.ceil(np.linalg.norm(q - p) / step)))
                s = (np.arange(n) + 0.5) / n
                pts.append(p + np.outer(s, q - p))
                lab.append(np.full(n, i))
    return np.concatenate(pts), np.concatenate(lab)


def orientation_stats(rve, step: float = 0.5e-6) -> dict:
    """Length-weighted orientation of the axes inside the box: tensor, tilt, in-plane angle.

    The axis segments inside the box weigh by their length (what the flow sees); tilt is the
    angle out of the x-y plane, ``phi`` the in-plane angle in [0, 180) deg from x.
    """
    seg_d, seg_w = [], []
    for lines in rve.medial_axes_m():
        for line in lines:
            d = np.diff(line, axis=0)
            seg_d.append(d)
            seg_w.append(np.linalg.norm(d, axis=1))
    d = np.concatenate(seg_d)
    w = np.concatenate(seg_w)
    p = d / w[:, None]
    a = np.einsum("n,ni,nj->ij", w, p, p) / w.sum()
    tilt = np.degrees(np.arcsin(np.clip(np.abs(p[:, 2]), 0.0, 1.0)))
    phi = np.degrees(np.arctan2(p[:, 1], p[:, 0])) % 180.0
    hist, _ = np.histogram(phi, bins=np.arange(0.0, 181.0, 15.0), weights=w)
    # circular (doubled-angle) in-plane order: 0 = isotropic in plane, 1 = aligned
    c = np.sum(w * np.cos(np.radians(2 * phi))) / w.sum()
    s = np.sum(w * np.sin(np.radians(2 * phi))) / w.sum()
    return {
        "a_tensor": a.tolist(),
        "a_xx": float(a[0, 0]),
        "a_yy": float(a[1, 1]),
        "a_zz": float(a[2, 2]),
        "tilt_mean_deg": float(np.sum(w * tilt) / w.sum()),
        "tilt_rms_deg": float(np.sqrt(np.sum(w * tilt**2) / w.sum())),
        "tilt_max_deg": float(tilt.max()),
        "phi_hist_15deg": (hist / hist.sum()).tolist(),
        "phi_order": float(np.hypot(c, s)),
        "phi_mean_deg": float(np.degrees(np.arctan2(s, c)) / 2 % 180.0),
        "axis_length_m": float(w.sum()),
    }


def clustering_stats(rve, step: float = 0.5e-6) -> dict:
    """Nearest-neighbour distances between fibre axes (clustering of the solid).

    For each axis point the distance to the nearest axis point of *another* fibre (m); per
    fibre the smallest of those (its nearest neighbour). Axis distance minus D < 0 means the
    two fibres overlap there; ``contact_fraction``: share of axis length within D of another
    axis (overlapping or touching).
    """
    from scipy.spatial import cKDTree

    pts, lab = axis_points(rve, step)
    dia = float(min(fb.diameter for fb in rve.fibers)) * float(rve.period)
    near = np.empty(len(pts))
    for i in np.unique(lab):
        mine = lab == i
        near[mine] = cKDTree(pts[~mine]).query(pts[mine], k=1)[0]
    per_fibre = np.array([near[lab == i].min() for i in np.unique(lab)])
    return {
        "nn_axis_mean_m": float(per_fibre.mean()),
        "nn_axis_median_m": float(np.median(per_fibre)),
        "nn_axis_gap_min_m": float(per_fibre.min() - dia),
        "point_nn_median_m": float(np.median(near)),
        "point_nn_p10_m": float(np.percentile(near, 10)),
        "point_nn_p90_m": float(np.percentile(near, 90)),
        "contact_fraction": float(np.mean(near <= dia)),
        "overlap_axis_fraction": float(np.mean(near < dia * (1 - 1e-3))),
    }


def layering_stats(fields) -> dict:
    """The solid's layering along z: porosity of each voxel layer (what in-plane flow sees).

    ``layer_porosity_std``: standard deviation of the layer porosities; ``open_layer_fraction``:
    share of layers with porosity above 0.9 (in-plane channels).
    """
    prof = (~fields.solid).mean(axis=(0, 1))
    return {
        "layer_porosity_std": float(prof.std()),
        "layer_porosity_max": float(prof.max()),
        "layer_porosity_min": float(prof.min()),
        "open_layer_fraction": float(np.mean(prof > 0.9)),
    }


def _append(path, rec: dict) -> None:
    """One JSON line appended to a runs file (the runs files are resumable logs)."""
    with open(path, "a") as fh:
        fh.write(json.dumps(rec) + "\n")


def _each_rve(a):
    """``(kind, method, seed, built, generation_s, fields)`` of every requested RVE, voxelized
    at ``a.voxel`` (built or read from the cache by :func:`build`)."""
    for kind in a.kinds:
        for method in a.methods:
            for seed in a.seeds:
                built, t_gen = build(kind, method, seed, a.size, a.cache)
                yield kind, method, seed, built, t_gen, built.rve.voxelize(a.voxel)


def geometry(a) -> int:
    """Generator statistics per (kind, method, seed): orientation, overlap, clustering, pores."""
    for kind, method, seed, built, t_gen, fields in _each_rve(a):
        rec = {"kind": kind, "method": method, "seed": seed, "voxel_m": a.voxel}
        rec.update(size_m=float(built.rve.size[0]), n_fibers=len(built.rve.fibers))
        rec.update(porosity=fields.porosity, omega=fields.intersection_volume_fraction)
        rec["generation_s"] = t_gen
        rec["generation"] = {
            k: built.report.get(k)
            for k in ("omega_after", "center_z_m", "rotation_deg", "displacement_m")
        }
        rec.update(orientation_stats(built.rve))
        rec.update(clustering_stats(built.rve))
        rec.update(layering_stats(fields))
        rec.update(t3.pore_statistics(fields))
        rec["clustering_cv_10um"] = t3.clustering_cv(
            fields.solid, max(1, int(round(10e-6 / a.voxel)))
        )
        _append(a.out, rec)
        print(
            kind,
            method,
            seed,
            f"eps={rec['porosity']:.4f} Omega={rec['omega']:.4f}",
            f"a_xx={rec['a_xx']:.3f} a_yy={rec['a_yy']:.3f} a_zz={rec['a_zz']:.4f}",
            f"nn={1e6 * rec['nn_axis_mean_m']:.2f}um d50={1e6 * rec['pore_d50_m']:.1f}",
        )
        sys.stdout.flush()
    return 0


def subcube_fields(fields, start: float, edge: float):
    """The cube ``[start, start + edge)^3`` (m) of a voxel image, as its own (periodic) image."""
    from psdesign.geometry.rve import VoxelFields, VoxelGrid

    h = float(fields.grid.spacing[0])
    i0, n = int(round(start / h)), int(round(edge / h))
    cut = (slice(i0, i0 + n),) * 3
    grid = VoxelGrid.from_voxel(np.full(3, n * h), h)
    return VoxelFields(distance=fields.distance[cut], count=fields.count[cut], grid=grid)


def resolution(a) -> int:
    """K of one sub-cube of each RVE at several voxel sizes (the grid's share of K).

    The same sub-cube (``--start``, ``--edge``) at every voxel size, periodic BC: its face
    mismatch and sample scatter are the same at every size, so K(h) / K(h_finest) is the
    resolution error of the wall representation alone (checked against a full-cube 0.5 um
    solve in the doc).
    """
    for kind in a.kinds:
        for seed in a.seeds:
            built, _ = build(kind, a.method, seed, None, a.cache)
            for h in a.voxels:
                fields = None
                for d in a.directions:
                    key = {"kind": kind, "method": a.method, "seed": seed, "sub": f"{a.edge:.3g}"}
                    key.update(start=f"{a.start:.3g}", voxel=f"{h:.3g}", bc="periodic", dir=d)
                    path = _solve_path(a.cache, key)
                    if path.exists():
                        continue
                    if fields is None:
                        fields = subcube_fields(built.voxelize(h), a.start, a.edge)
                    rec = {**key, "voxel_m": h, "porosity": fields.porosity, "tol": a.tol}
                    rec.update(solve_one(built, fields, d, "periodic", a.tol))
                    path.parent.mkdir(parents=True, exist_ok=True)
                    path.write_text(json.dumps(rec))
                    _append(a.out, rec)
                    print(kind, seed, h, d, f"K = {rec['permeability_m2']:.4e}", flush=True)
    return 0


def layering(a) -> int:
    """Porosity, Omega and z layering of each (kind, method, seed) RVE, one JSON line each."""
    for kind, method, seed, built, _, fields in _each_rve(a):
        rec = {"kind": kind, "method": method, "seed": seed, "size": a.size}
        rec.update(omega=fields.intersection_volume_fraction, porosity=fields.porosity)
        rec.update(layering_stats(fields))
        rec["n_fibers"] = len(built.rve.fibers)
        rec["center_z_std_m"] = float(np.std([fb.center[2] for fb in built.rve.fibers]))
        rec["center_z_std_m"] *= float(built.rve.period)
        _append(a.out, rec)
        print(json.dumps(rec))
    return 0


# ---------------------------------------------------------------- summary
def _rows(path: Path) -> list[dict]:
    return [json.loads(s) for s in path.read_text().splitlines() if s.strip()]


def _cell(k: np.ndarray, ref: float | None, fmt: str = ".3e") -> str:
    """``mean +- 95 % CI (vs ref)``; the CI is Student's t with n - 1 dof."""
    ci = f" +- {format(t3._ci95(k), fmt)}" if len(k) > 1 else ""
    vs = f" ({100 * (k.mean() / ref - 1):+.0f} %)" if ref else ""
    return f"{format(k.mean(), fmt)}{ci}{vs}"


def summary(path: Path) -> str:
    """Markdown: per (kind, method, size, voxel, bc) the mean +- 95 % CI of K_z, K_x, K_y."""
    rows = _rows(path)
    groups: dict = {}
    for r in rows:
        key = (r["kind"], r["method"], r["size"], r["voxel"], r["bc"])
        groups.setdefault(key, {}).setdefault(r["dir"], {})[r["seed"]] = r["permeability_m2"]
    out = [
        "| kind | method | size (um) | voxel (um) | bc | n | K_z (m^2) | K_x (m^2) | K_y (m^2) "
        "| (K_x+K_y)/2 (m^2) | K_in / K_z |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for (kind, method, size, voxel, bc), by_dir in sorted(groups.items()):
        cells = [kind, method, f"{1e6 * float(size):.0f}", f"{1e6 * float(voxel):.2g}", bc]
        seeds = sorted(set().union(*[set(v) for v in by_dir.values()]))
        cells.append(str(len(seeds)))
        for d in ("z", "x", "y"):
            k = np.array([by_dir.get(d, {})[s] for s in seeds if s in by_dir.get(d, {})])
            ref = t3.PAPER.get((kind, d if d != "y" else "x"))
            cells.append(_cell(k, ref) + f" n={len(k)}" if len(k) else "-")
        both = [s for s in seeds if s in by_dir.get("x", {}) and s in by_dir.get("y", {})]
        kin = np.array([(by_dir["x"][s] + by_dir["y"][s]) / 2 for s in both])
        cells.append(_cell(kin, t3.PAPER.get((kind, "x"))) if len(kin) else "-")
        rat = [kin[i] / by_dir["z"][s] for i, s in enumerate(both) if s in by_dir.get("z", {})]
        paper = (  # Table III's in-plane / through-plane; none printed for the woven sample
            t3.PAPER[(kind, "x")] / t3.PAPER[(kind, "z")] if (kind, "x") in t3.PAPER else None
        )
        cells.append(_cell(np.array(rat), paper, ".3f") if rat else "-")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def per_seed(path: Path) -> str:
    """Markdown: K per seed, direction and bc, with K_x / K_y."""
    rows = _rows(path)
    tab: dict = {}
    for r in rows:
        key = (r["kind"], r["method"], r["size"], r["voxel"], r["seed"])
        tab.setdefault(key, {})[(r["bc"], r["dir"])] = r["permeability_m2"]
    bcs = sorted({r["bc"] for r in rows})
    head = [f"{bc} K_{d}" for bc in bcs for d in "zxy"] + [f"{bc} K_x/K_y" for bc in bcs]
    out = ["| kind | method | size | voxel | seed | " + " | ".join(head) + " |"]
    out.append("| " + " | ".join(["---"] * (5 + len(head))) + " |")
    for (kind, method, size, voxel, seed), v in sorted(tab.items()):
        cells = [kind, method, f"{1e6 * float(size):.0f}", f"{1e6 * float(voxel):.2g}", str(seed)]
        cells += [f"{v[(bc, d)]:.3e}" if (bc, d) in v else "-" for bc in bcs for d in "zxy"]
        for bc in bcs:
            ok = (bc, "x") in v and (bc, "y") in v
            cells.append(f"{v[(bc, 'x')] / v[(bc, 'y')]:.3f}" if ok else "-")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def bc_table(path: Path, perm_tag: str = "permeameter-main") -> str:
    """Markdown: Table III side by side, periodic and permeameter BC, K_z, K_x, K_y, K_in.

    GA RVEs, 100 um, 1 um voxels; mean +- 95 % CI over the seeds (vs Table III) and, seed by
    seed, permeameter / periodic (mean +- 95 % CI). K_in = (K_x + K_y) / 2 per seed.
    """
    k: dict = {}
    for r in _rows(path):
        if r["method"] == "ga" and float(r["size"]) == 1e-4 and float(r["voxel"]) == 1e-6:
            k.setdefault((r["kind"], r["bc"]), {}).setdefault(r["dir"], {})[r["seed"]] = r[
                "permeability_m2"
            ]
    for by_dir in k.values():
        both = set(by_dir.get("x", {})) & set(by_dir.get("y", {}))
        by_dir["in"] = {s: 0.5 * (by_dir["x"][s] + by_dir["y"][s]) for s in both}
    head = "| kind | K | periodic | n | permeameter | n | permeameter / periodic (same seeds) |"
    out = [head, "| " + " | ".join(["---"] * 7) + " |"]
    for kind in ("straight", "bent"):
        for d in ("z", "x", "y", "in"):
            ref = t3.PAPER[(kind, "x" if d != "z" else "z")]
            cells = [kind, {"in": "(K_x + K_y) / 2"}.get(d, f"K_{d}")]
            per = k.get((kind, "periodic"), {}).get(d, {})
            prm = k.get((kind, perm_tag), {}).get(d, {})
            for v in (per, prm):
                cells += [_cell(np.array(list(v.values())), ref), str(len(v))] if v else ["-", "0"]
            common = sorted(set(per) & set(prm))
            rat = np.array([prm[s] / per[s] for s in common])
            cells.append(_cell(rat, None, ".3f") + f" (n={len(rat)})" if len(rat) else "-")
            out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def resolution_table(runs: Path, sub: Path) -> str:
    """Markdown: K at 2, 1 and 0.5 um voxels, full cube (runs) and 50 um sub-cube (sub).

    Per (kind, seed, direction, domain): K at each voxel size and the ratios K(2) / K(1) and
    K(1) / K(0.5) (the share of K the 1 um grid adds over the 0.5 um one).
    """
    tab: dict = {}
    for r in _rows(runs):
        if r["method"] == "ga" and r["bc"] == "periodic" and float(r["size"]) == 1e-4:
            key = (r["kind"], r["seed"], r["dir"], "100 um cube")
            tab.setdefault(key, {})[float(r["voxel"])] = r["permeability_m2"]
    for r in _rows(sub):
        key = (r["kind"], r["seed"], r["dir"], f"{1e6 * float(r['sub']):.0f} um sub-cube")
        tab.setdefault(key, {})[float(r["voxel"])] = r["permeability_m2"]
    out = ["| kind | seed | K | domain | 2 um | 1 um | 0.5 um | K(2) / K(1) | K(1) / K(0.5) |"]
    out.append("| " + " | ".join(["---"] * 9) + " |")
    for (kind, seed, d, dom), v in sorted(tab.items()):
        if 0.5e-6 not in v and 2e-6 not in v:
            continue
        cells = [kind, str(seed), f"K_{d}", dom]
        cells += [f"{v[h]:.3e}" if h in v else "-" for h in (2e-6, 1e-6, 0.5e-6)]
        for a, b in ((2e-6, 1e-6), (1e-6, 0.5e-6)):
            cells.append(f"{v[a] / v[b]:.3f}" if a in v and b in v else "-")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


#: Row order of the controlled-placement table (section 2.4 of the doc).
CONTROLLED_ORDER = (
    "none", "drawn", "ga-zdrawn", "drawn-zga", "ga", "fast", "ga-single", "ga-single-eps",
)  # fmt: skip


def controlled_per_seed(path: Path, layering_path: Path, kind: str) -> str:
    """Markdown: the rows of :func:`controlled` seed by seed (K in m^2)."""
    runs: dict = {}
    for r in _rows(path):
        ok = r["kind"] == kind and r["bc"] == "periodic" and float(r["size"]) == 1e-4
        if ok and float(r["voxel"]) == 1e-6 and r["method"] in CONTROLLED_ORDER:
            runs.setdefault((r["method"], r["seed"]), {})[r["dir"]] = r["permeability_m2"]
    geo = {
        (g["method"], g["seed"]): g
        for g in _rows(layering_path)
        if g["kind"] == kind and g.get("size") is None
    }
    head = "| placement | seed | porosity | Omega (%) | layer porosity std | K_z | K_x | K_y "
    out = [head + "| K_in / K_z |", "| " + " | ".join(["---"] * 9) + " |"]
    order = {m: i for i, m in enumerate(CONTROLLED_ORDER)}
    for (m, seed), k in sorted(runs.items(), key=lambda t: (order[t[0][0]], t[0][1])):
        if not all(d in k for d in "zxy"):
            continue
        g = geo.get((m, seed), {})
        cells = [m, str(seed)]
        cells.append(f"{g['porosity']:.4f}" if g else "-")
        cells.append(f"{100 * g['omega']:.2f}" if g else "-")
        cells.append(f"{g['layer_porosity_std']:.3f}" if g else "-")
        cells += [f"{k[d]:.3e}" for d in "zxy"]
        cells.append(f"{0.5 * (k['x'] + k['y']) / k['z']:.3f}")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def controlled(path: Path, layering_path: Path, kind: str) -> str:
    """Markdown: the placements of one drawn fibre set side by side (periodic, 100 um, 1 um).

    Per placement, means over the seeds it has (K_in = (K_x + K_y) / 2; ratio K_in / K_z with
    its 95 % CI) and, paired seed by seed, K_in / K_z over the GA's of the same seed.
    """
    runs: dict = {}
    for r in _rows(path):
        ok = r["kind"] == kind and r["bc"] == "periodic" and float(r["size"]) == 1e-4
        if ok and float(r["voxel"]) == 1e-6:
            runs.setdefault((r["method"], r["seed"]), {})[r["dir"]] = r["permeability_m2"]
    geo = {
        (g["method"], g["seed"]): g
        for g in _rows(layering_path)
        if g["kind"] == kind and g.get("size") is None
    }

    def ratio(k: dict) -> float:
        return 0.5 * (k["x"] + k["y"]) / k["z"]

    full = {key: k for key, k in runs.items() if all(d in k for d in "zxy")}
    head = "| placement | seeds | porosity | Omega (%) | layer porosity std | K_z | K_in | "
    head += "K_in / K_z | K_in / K_z over the GA's (same seed) |"
    out = [head, "| " + " | ".join(["---"] * 9) + " |"]
    for m in CONTROLLED_ORDER:
        seeds = sorted(s for (mm, s) in full if mm == m)
        if not seeds:
            continue
        ks = [full[(m, s)] for s in seeds]
        g = [geo[(m, s)] for s in seeds if (m, s) in geo]
        cells = [m, " ".join(map(str, seeds))]
        for name, scale, fmt in (("porosity", 1, ".4f"), ("omega", 100, ".2f")):
            cells.append(format(scale * np.mean([x[name] for x in g]), fmt) if g else "-")
        std = [x["layer_porosity_std"] for x in g]
        cells.append(f"{np.mean(std):.3f}" if std else "-")
        cells.append(_cell(np.array([k["z"] for k in ks]), t3.PAPER[(kind, "z")]))
        kin = np.array([0.5 * (k["x"] + k["y"]) for k in ks])
        cells.append(_cell(kin, t3.PAPER[(kind, "x")]))
        cells.append(_cell(np.array([ratio(k) for k in ks]), None, ".3f"))
        paired = [ratio(full[(m, s)]) / ratio(full[("ga", s)]) for s in seeds if ("ga", s) in full]
        cells.append(_cell(np.array(paired), None, ".3f") if paired and m != "ga" else "-")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


GEOMETRY_COLUMNS = (
    ("porosity", "porosity", 1.0, ".4f"),
    ("Omega (%)", "omega", 100.0, ".2f"),
    ("n fibres", "n_fibers", 1.0, ".0f"),
    ("pore d10 / d50 / d90 (um)", ("pore_d10_m", "pore_d50_m", "pore_d90_m"), 1e6, ".1f"),
    ("pore mean (um)", "pore_mean_m", 1e6, ".2f"),
    ("solid CV 10 / 20 um", ("clustering_cv_10um", "clustering_cv_20um"), 1.0, ".3f"),
    ("NN axis distance mean / median (um)", ("nn_axis_mean_m", "nn_axis_median_m"), 1e6, ".2f"),
    ("axis point NN p10 / p50 / p90 (um)", ("point_nn_p10_m", "point_nn_median_m",
                                           "point_nn_p90_m"), 1e6, ".2f"),
    ("axis length in contact (%)", "contact_fraction", 100.0, ".1f"),
    ("a_xx / a_yy / a_zz", ("a_xx", "a_yy", "a_zz"), 1.0, ".3f"),
    ("tilt rms / max (deg)", ("tilt_rms_deg", "tilt_max_deg"), 1.0, ".2f"),
    ("in-plane order", "phi_order", 1.0, ".3f"),
    ("z-layer porosity std / max", ("layer_porosity_std", "layer_porosity_max"), 1.0, ".3f"),
)  # fmt: skip


def geometry_summary(path: Path, per_seed: bool = False) -> str:
    """Markdown: the generator statistics, mean over seeds per (kind, method) or per seed."""
    rows = _rows(path)
    groups: dict = {}
    for r in rows:
        key = (r["kind"], r["method"]) + ((r["seed"],) if per_seed else ())
        groups.setdefault(key, []).append(r)
    head = ["kind", "method", "seed" if per_seed else "n"] + [c[0] for c in GEOMETRY_COLUMNS]
    out = ["| " + " | ".join(head) + " |", "| " + " | ".join(["---"] * len(head)) + " |"]
    for key, rs in sorted(groups.items()):
        cells = [key[0], key[1], str(key[2]) if per_seed else str(len(rs))]
        for _, names, scale, fmt in GEOMETRY_COLUMNS:
            names = names if isinstance(names, tuple) else (names,)
            vals = [[r[n] for r in rs if n in r] for n in names]
            ok = all(vals)
            cells.append(" / ".join(format(scale * np.mean(v), fmt) for v in vals) if ok else "-")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def _rve_arguments(p: argparse.ArgumentParser, methods: list[str]) -> None:
    """The RVE-set arguments of the sub-commands that walk :func:`_each_rve` (``geometry``,
    ``layering``); ``methods`` is the default placement list."""
    p.add_argument("--kinds", nargs="+", default=["straight"])
    p.add_argument("--methods", nargs="+", default=methods, choices=METHODS)
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    p.add_argument("--voxel", type=float, default=1e-6)
    p.add_argument("--size", type=float, default=None)
    p.add_argument("--cache", required=True)
    p.add_argument("--out", required=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--kinds", nargs="+", default=["straight", "bent"])
    r.add_argument("--method", default="ga", choices=METHODS)
    r.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    r.add_argument("--bcs", nargs="+", default=["periodic"], choices=("periodic", "permeameter"))
    r.add_argument("--bc-tag", default="permeameter", help="name of the permeameter definition")
    r.add_argument(
        "--copies",
        default="auto",
        type=lambda v: v if v == "auto" else int(v),
        help="flow.permeameter_copies of the permeameter ('auto' or 1, 2, ...)",
    )
    r.add_argument("--directions", nargs="+", default=["z", "x", "y"])
    r.add_argument("--voxel", type=float, default=0.5e-6)
    r.add_argument("--tol", type=float, default=1e-4, help="solver relative residual")
    r.add_argument("--size", type=float, default=None, help="cube edge (m), default the spec's")
    r.add_argument("--cache", required=True)
    r.add_argument("--out", required=True)
    _rve_arguments(sub.add_parser("geometry"), ["ga", "fast"])
    _rve_arguments(
        sub.add_parser("layering", help="porosity, Omega, z layering per RVE (no solve)"),
        list(CONTROLLED_ORDER),
    )
    res = sub.add_parser("resolution", help="K of one sub-cube at several voxel sizes")
    res.add_argument("--kinds", nargs="+", default=["straight", "bent"])
    res.add_argument("--method", default="ga", choices=METHODS)
    res.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    res.add_argument("--voxels", type=float, nargs="+", default=[2e-6, 1e-6, 0.5e-6])
    res.add_argument("--directions", nargs="+", default=["z", "x"])
    res.add_argument("--start", type=float, default=25e-6, help="sub-cube corner (m)")
    res.add_argument("--edge", type=float, default=50e-6, help="sub-cube edge (m)")
    res.add_argument("--tol", type=float, default=1e-4)
    res.add_argument("--cache", required=True)
    res.add_argument("--out", required=True)
    c = sub.add_parser("controlled", help="table of the placements of one drawn fibre set")
    c.add_argument("path")
    c.add_argument("--layering", default=str(ROOT / "benchmarks" / "paper_table3_layering.jsonl"))
    c.add_argument("--kind", default="straight", choices=("straight", "bent"))
    c.add_argument("--per-seed", action="store_true")
    s = sub.add_parser("summary")
    s.add_argument("path")
    s.add_argument("--per-seed", action="store_true")
    s.add_argument("--geometry", action="store_true", help="PATH is a geometry jsonl")
    s.add_argument("--bcs", action="store_true", help="Table III with both BCs side by side")
    s.add_argument("--resolution", default=None, help="resolution jsonl: the grid table")
    a = p.parse_args(argv)
    if a.cmd == "summary":
        if a.resolution:
            print(resolution_table(Path(a.path), Path(a.resolution)))
        elif a.bcs:
            print(bc_table(Path(a.path)))
        elif a.geometry:
            print(geometry_summary(Path(a.path), a.per_seed))
        else:
            print(per_seed(Path(a.path)) if a.per_seed else summary(Path(a.path)))
        return 0
    if a.cmd == "controlled":
        table = controlled_per_seed if a.per_seed else controlled
        print(table(Path(a.path), Path(a.layering), a.kind))
        return 0
    cmds = {"run": run, "geometry": geometry, "layering": layering, "resolution": resolution}
    return cmds[a.cmd](a)


if __name__ == "__main__":
    sys.exit(main())
