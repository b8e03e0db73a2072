"""Paper Table III with the paper's workflow (issue 17): GA placement, several seeds, voxel Stokes.

Usage::

    nice python benchmarks/paper_table3.py run --kind straight --method ga --seeds 1 2 3 4 5 \
        --directions z x --out benchmarks/table3_runs.jsonl
    python benchmarks/paper_table3.py summary benchmarks/table3_runs.jsonl

``run`` appends one JSON line per case (so a stopped run keeps what it finished): porosity,
Omega (voxel overlap fraction, Eq. 8), the pore-size distribution by local thickness, the
clustering of the solid (coefficient of variation of the solid fraction over sub-blocks) and
K along each direction with the periodic voxel route. ``summary`` prints the mean, the 95 %
confidence interval (Student t) and n per (kind, method, direction) as a markdown table;
``summary FEM.jsonl --beside VOXEL.jsonl`` the FEM permeameter runs beside the voxel periodic K of
the same seeds (docs/paper-reproduction.md section 2.1's table).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PAPER = {("straight", "z"): 8.07e-12, ("straight", "x"): 1.21e-11}
PAPER.update({("bent", "z"): 7.8e-12, ("bent", "x"): 1.11e-11, ("woven", "z"): 2.55e-12})


def clustering_cv(solid: np.ndarray, block: int) -> float:
    """Coefficient of variation of the solid fraction over cubic sub-blocks of ``block`` voxels."""
    n = [s // block for s in solid.shape]
    s = solid[: n[0] * block, : n[1] * block, : n[2] * block].astype(np.float64)
    frac = s.reshape(n[0], block, n[1], block, n[2], block).mean(axis=(1, 3, 5))
    return float(frac.std() / max(frac.mean(), 1e-12))


def pore_statistics(fields) -> dict:
    """Pore-size percentiles (the product's local thickness, :func:`psdesign.transport.pores.
    pore_sizes`: periodic, on the analytic distance, 32 radii) and solid clustering of an RVE's
    voxel fields. Until session 32 this module had its own voxel-EDT local thickness with open
    faces, a second definition of the same quantity; the records in
    ``paper_table3*_runs.jsonl`` / ``paper_table3_geometry.jsonl`` before then come from it."""
    from psdesign.transport.pores import pore_sizes

    ps = pore_sizes(fields, n_radii=32)
    voxel = float(fields.grid.spacing[0])
    return {
        "pore_d10_m": ps.pore_d10_m,
        "pore_d50_m": ps.pore_d50_m,
        "pore_d90_m": ps.pore_d90_m,
        "pore_mean_m": ps.mean_diameter_m,
        "pore_diameter_error_m": ps.diameter_error_m,
        "pore_hist_diameters_m": ps.diameters_m,
        "pore_hist_fraction": ps.volume_fraction,
        "clustering_cv_20um": clustering_cv(fields.solid, max(1, int(round(20e-6 / voxel)))),
    }


#: Folder of pickled built RVEs (same spec dict -> same RVE: every random choice is seeded), so
#: that the solver/BC variants of one seed do not re-run the GA. Unset: no cache.
CACHE_DIR = None


def _cached_build(spec: dict, build):
    import hashlib
    import pickle

    if CACHE_DIR is None:
        return build(spec)
    key = hashlib.sha1(json.dumps(spec, sort_keys=True, default=str).encode()).hexdigest()[:16]
    path = Path(CACHE_DIR) / f"rve_{key}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    built = build(spec)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_bytes(pickle.dumps(built))
    tmp.replace(path)
    return built


def run_case(
    spec_path: Path,
    method: str | None,
    seed: int,
    directions,
    voxel: float,
    solver: str = "voxel",
    bc: str = "periodic",
    error_estimate: bool = True,
    size: float | None = None,
    lattice_step: float | None = None,
) -> dict:
    """Generate one RVE and measure it; returns the JSON record.

    ``solver``/``bc``: the route (voxel periodic by default; ``fem`` + ``permeameter`` is the
    paper's setting: empty inlet/outlet zones of ``flow.aux_length``, slip sides, K from the
    windowed dissipation; the faces-drop and applied-drop readings are recorded beside it).
    ``size``: cube edge (m) instead of the spec's (RVE-size study). ``lattice_step``: the FEM
    mesher's lattice step (m), default the route's (L/30).
    """
    from psdesign.flow.permeability import permeability
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = load_spec(spec_path)
    if size is not None:
        spec["rve"] = {**spec["rve"], "size": [size, size, size]}
    if "generator" in spec:
        spec["generator"] = {**spec["generator"], "seed": seed}
    if method is not None:
        spec["intersections"] = {**spec.get("intersections", {}), "method": method}
        if method == "ga":
            spec["intersections"]["min_gap"] = 0.0
    t0 = time.perf_counter()
    built = _cached_build(spec, build_rve)
    t_gen = time.perf_counter() - t0
    fields = built.rve.voxelize(voxel)
    rec = {
        "spec": str(spec_path.relative_to(ROOT)),
        "method": spec.get("intersections", {}).get("method", "explicit"),
        "seed": seed,
        "voxel_m": voxel,
        "porosity": fields.porosity,
        "omega": fields.intersection_volume_fraction,
        "n_fibers": len(built.rve.fibers),
        "generation_s": t_gen,
        "generation": {
            k: built.report.get(k)
            for k in ("porosity", "omega_after", "center_z_m", "rotation_deg", "displacement_m")
        },
    }
    rec.update(pore_statistics(fields))
    rec["solver"], rec["bc"], rec["size_m"] = solver, bc, float(built.rve.size[0])
    flow = {**spec["flow"], "solver": solver, "bc": bc}
    if lattice_step is not None:
        flow["lattice_step"] = lattice_step
        rec["lattice_step_m"] = lattice_step
    for d in directions:
        r = permeability(built.rve, fields, d, flow, solver=solver, error_estimate=error_estimate)
        rec.update(k_record(r, d))
    return rec


def k_record(r: dict, d: str) -> dict:
    """The record's ``k_<d>_*`` fields of one :func:`psdesign.flow.permeability.permeability`
    result ``r`` along ``d``: K, converged, wall, bar, status; a permeameter's copies and, for
    ``permeameter_copies = "auto"``, why it stopped and the copies / window term of each solve
    (records before session 52's mend have none: straight z seed 3 of
    ``paper_table3_fem_runs_s52.jsonl`` took 3 copies, seen only in its dofs); the FEM
    permeameter's faces and applied-drop readings and dofs.
    """
    rec = {
        f"k_{d}_m2": r["permeability_m2"],
        f"k_{d}_converged": r["converged"],
        f"k_{d}_wall_s": r["wall_time_s"],
        f"k_{d}_rel_error": r.get("permeability_rel_error"),
        f"k_{d}_status": r.get("status"),
    }
    if r.get("permeameter_copies") is not None:
        rec[f"k_{d}_copies"] = r["permeameter_copies"]
    auto = r.get("permeameter_auto")
    if auto is not None:
        rec[f"k_{d}_auto_stopped"] = auto["stopped"]
        rec[f"k_{d}_auto_tries"] = [[t["copies"], t["window"]] for t in auto["tries"]]
    if "pressure_drop_faces_pa" in r:  # the FEM permeameter's other readings of dP
        kw = r["permeability_m2"]
        rec[f"k_{d}_faces_m2"] = kw * r["pressure_drop_rve_pa"] / r["pressure_drop_faces_pa"]
        frac = 1.0 + 2.0 * r["aux_length"]  # applied drop over the RVE + both zones
        rec[f"k_{d}_applied_m2"] = (
            kw * r["pressure_drop_rve_pa"] / r["pressure_drop_applied_pa"] * frac
        )
        rec[f"k_{d}_n_dofs"] = r.get("n_dofs")
    return rec


def mirrored_fields(fields, axis: int):
    """The voxel image followed by its mirror image along ``axis`` (twice as long).

    Periodic without face mismatch along ``axis``: every fiber cut by the two faces meets
    its own mirror image. For fibers with omega uniform in [0, 180) the mirror image has the
    same orientation statistics, so the doubled image is the same material.
    """
    from psdesign.geometry.rve import VoxelFields, VoxelGrid

    def both(a):
        return np.concatenate([a, np.flip(a, axis=axis)], axis=axis)

    size = np.array(fields.grid.size, float)
    size[axis] *= 2
    grid = VoxelGrid.from_voxel(size, float(fields.grid.spacing[0]))
    return VoxelFields(distance=both(fields.distance), count=both(fields.count), grid=grid)


def run_mirror(spec_path: Path, method: str, seed: int, direction: str, voxel: float) -> dict:
    """K along ``direction`` (voxel, periodic) of one RVE and of it + its mirror image."""
    from psdesign.flow.permeability import permeability
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = load_spec(spec_path)
    spec["generator"] = {**spec["generator"], "seed": seed}
    spec["intersections"] = {**spec.get("intersections", {}), "method": method}
    if method == "ga":
        spec["intersections"]["min_gap"] = 0.0
    built = _cached_build(spec, build_rve)
    fields = built.rve.voxelize(voxel)
    flow = {**spec["flow"], "solver": "voxel", "bc": "periodic"}
    ax = "xyz".index(direction)
    rec = {"spec": str(spec_path.relative_to(ROOT)), "method": method, "seed": seed}
    rec.update({"voxel_m": voxel, "direction": direction, "porosity": fields.porosity})
    first, last = np.take(fields.solid, 0, axis=ax), np.take(fields.solid, -1, axis=ax)
    rec["face_mismatch"] = float(np.mean(first != last))
    for name, f in (("plain", fields), ("mirrored", mirrored_fields(fields, ax))):
        r = permeability(built.rve, f, direction, flow, solver="voxel", error_estimate=False)
        rec[f"k_{name}_m2"] = r["permeability_m2"]
        rec[f"k_{name}_converged"] = r["converged"]
        rec[f"k_{name}_wall_s"] = r["wall_time_s"]
    return rec


def _ci95(x: np.ndarray) -> float:
    """Half-width of the 95 % CI of the mean (Student t, n - 1 dof; NaN for n < 2)."""
    from psdesign.analysis.replicates import t_quantile_975

    if len(x) < 2:
        return float("nan")
    return float(t_quantile_975(len(x) - 1) * np.std(x, ddof=1) / np.sqrt(len(x)))


def _key(r: dict) -> tuple:
    return (r["spec"], r["method"], r.get("solver", "voxel"), r.get("bc", "periodic"))


def _k_cell(rs: list, key: str, ref: float | None) -> list[str]:
    k = np.array([r[key] for r in rs if key in r])
    if len(k) == 0:
        return ["-", "-"]
    vs = f"{100 * (k.mean() / ref - 1):+.0f} %" if ref else "n/a"
    ci = f" +- {_ci95(k):.2e}" if len(k) > 1 else ""
    return [f"{k.mean():.3e}{ci} (n={len(k)})", vs]


class RunsError(ValueError):
    """Bad input to ``summary``: one line naming the file or option (``main`` exits 2)."""


def read_runs(path: Path) -> list[dict]:
    """The JSON records of a runs file, one per non-blank line; :class:`RunsError` naming the
    file (and line) when it is missing or a line is not a JSON object."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise RunsError(f"{path}: cannot read ({exc.strerror or exc})") from None
    rows = []
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            r = json.loads(line)
        except json.JSONDecodeError as exc:
            raise RunsError(f"{path}:{n}: not a JSON record ({exc.msg})") from None
        if not isinstance(r, dict):
            raise RunsError(f"{path}:{n}: not a JSON record (a {type(r).__name__})")
        rows.append(r)
    return rows


#: The fields ``summary`` reads of a ``run`` record and of a ``mirror`` record (one with
#: ``k_plain_m2``, :func:`run_mirror`).
RUN_FIELDS = (
    "spec",
    "method",
    "porosity",
    "omega",
    "pore_d50_m",
    "pore_d90_m",
    "clustering_cv_20um",
)
MIRROR_FIELDS = (
    "spec", "method", "seed", "voxel_m", "direction", "face_mismatch",
    "k_plain_m2", "k_plain_converged", "k_mirrored_m2", "k_mirrored_converged",
)  # fmt: skip


def _split_records(path: Path, rows: list[dict]) -> tuple[list[dict], list[dict]]:
    """The ``run`` and the ``mirror`` records of a runs file; :class:`RunsError` naming the
    record and the fields it lacks for one that is neither (until session 53 a KeyError
    traceback: ``summary`` read a mirror record as a run, its ``omega`` missing)."""
    runs, mirrors = [], []
    for n, r in enumerate(rows, 1):
        mirror = "k_plain_m2" in r
        missing = [f for f in (MIRROR_FIELDS if mirror else RUN_FIELDS) if f not in r]
        if missing:
            whose = " (paper_table3_voxel.py summary reads its records)" if "kind" in r else ""
            raise RunsError(
                f"{path}: record {n} is not a {'mirror' if mirror else 'run'} record of "
                f"paper_table3.py (no {', '.join(missing)}){whose}"
            )
        (mirrors if mirror else runs).append(r)
    return runs, mirrors


def summary(path: Path, reading: str = "") -> str:
    """Markdown table: mean +- 95 % CI per (spec, method, solver, bc, direction); the
    ``mirror`` records of the file in a second table (:func:`mirror_summary`).

    ``reading``: '' (the route's K; FEM permeameter: windowed dissipation), '_faces' (FEM
    permeameter, drop between the RVE faces) or '_applied' (FEM permeameter, applied drop over
    the RVE plus both auxiliary zones).
    """
    rows, mirrors = _split_records(path, read_runs(path))
    if mirrors and not rows:  # a mirror runs file
        if reading:  # as with --beside: a reading the table cannot show is refused, not ignored
            raise RunsError(f"{path}: --reading {reading}: mirror records have one K per solve")
        return mirror_summary(mirrors)
    groups: dict = {}
    for r in rows:
        groups.setdefault(_key(r), []).append(r)
    lines = [
        "| spec | method | solver, bc | porosity | Omega | K_z mean +- 95% CI (m^2) | vs paper | "
        "K_x mean +- 95% CI (m^2) | vs paper | pore d50 (um) | d90 (um) | clustering CV |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for (spec, method, solver, bc), rs in sorted(groups.items()):
        kind = Path(spec).stem
        cells = [spec, method, f"{solver}, {bc}"]
        cells.append(f"{np.mean([r['porosity'] for r in rs]):.4f}")
        cells.append(f"{np.mean([r['omega'] for r in rs]):.4f}")
        for d in ("z", "x"):
            cells += _k_cell(rs, f"k_{d}{reading}_m2", PAPER.get((kind, d)))
        cells.append(f"{1e6 * np.mean([r['pore_d50_m'] for r in rs]):.1f}")
        cells.append(f"{1e6 * np.mean([r['pore_d90_m'] for r in rs]):.1f}")
        cells.append(f"{np.mean([r['clustering_cv_20um'] for r in rs]):.3f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + (f"\n\n{mirror_summary(mirrors)}" if mirrors else "")


def mirror_summary(rows: list[dict]) -> str:
    """Markdown table of ``mirror`` records (:func:`run_mirror`) per (spec, method,
    direction): the seeds, the face mismatch, K of the RVE and of it + its mirror image (mean
    +- 95 % CI, Student t), the per-seed ratio mirrored / plain (docs/paper-reproduction.md's
    mirror test) and whether every solve converged (last record of a seed at one voxel size
    wins; each voxel size is its own row)."""
    groups: dict = {}
    for r in rows:
        key = (r["spec"], r["method"], r["direction"], r["voxel_m"])
        groups.setdefault(key, {})[r["seed"]] = r
    lines = [
        "| spec | method | direction | voxel (um) | n (seeds) | face mismatch "
        "| K plain mean +- 95% CI (m^2) | K mirrored mean +- 95% CI (m^2) "
        "| mirrored / plain (per seed) | converged |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for (spec, method, d, voxel), by_seed in sorted(groups.items()):
        seeds = sorted(by_seed)
        rs = [by_seed[s] for s in seeds]
        k = {n: np.array([r[f"k_{n}_m2"] for r in rs]) for n in ("plain", "mirrored")}
        ratio = k["mirrored"] / k["plain"]
        mism = [100 * r["face_mismatch"] for r in rs]
        bad = [  # a not-converged solve's K is in the means: the column says which seeds
            r["seed"]
            for r in rs
            if not (r["k_plain_converged"] is True and r["k_mirrored_converged"] is True)
        ]
        cells = [
            spec,
            method,
            d,
            f"{1e6 * voxel:g}",
            f"{len(seeds)} ({', '.join(map(str, seeds))})",
        ]
        cells.append(f"{min(mism):.0f}-{max(mism):.0f} %" if len(mism) > 1 else f"{mism[0]:.0f} %")
        cells += [_mean_cell(k["plain"], None), _mean_cell(k["mirrored"], None)]
        cells.append(f"{ratio.mean():.3f} ({', '.join(f'{x:.3f}' for x in ratio)})")
        cells.append(f"NO: seed {', '.join(map(str, bad))}" if bad else "yes")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _by_seed(path: Path, solver: str, bc: str) -> dict:
    """{(kind, method, direction): {seed: record}} of one route's runs (last record wins)."""
    out: dict = {}
    for r in read_runs(path):
        if (r.get("solver", "voxel"), r.get("bc", "periodic")) != (solver, bc):
            continue
        for d in ("z", "x", "y"):
            if f"k_{d}_m2" in r:
                out.setdefault((Path(r["spec"]).stem, r["method"], d), {})[r["seed"]] = r
    if not out:  # e.g. the two files swapped: a header-only table said nothing (session 52)
        raise RunsError(
            f"{path}: no {solver} {bc} runs (records with solver = '{solver}', bc = '{bc}' and "
            "a k_<d>_m2); summary FEM_RUNS --beside VOXEL_RUNS takes the FEM permeameter runs "
            "first"
        )
    return out


def _mean_cell(k: np.ndarray, ref: float | None) -> str:
    ci = f" +- {_ci95(k):.2e}" if len(k) > 1 else ""
    vs = f" ({100 * (k.mean() / ref - 1):+.0f} %)" if ref else ""
    return f"{k.mean():.3e}{ci}{vs}"


def _has_bar(r: dict, d: str) -> bool:
    return r.get(f"k_{d}_rel_error") is not None


def _bar_cell(bars: list, no_bar: list, status: list, conv: bool) -> str:
    """The FEM bars' range (%), the statuses, the seeds without a bar and a not-converged flag
    (a missing bar was a NaN that ``min`` / ``max`` kept or dropped by its place in the list)."""
    if bars:
        cell = f"{min(bars):.1f}" + (f"-{max(bars):.1f}" if max(bars) > min(bars) else "") + " %"
    else:
        cell = "no bar"
    cell += f", {'/'.join(status)}"
    if bars and no_bar:
        cell += f", no bar: seed {', '.join(map(str, no_bar))}"
    return cell + ("" if conv else ", NOT all converged")


def beside(fem_path: Path, voxel_path: Path) -> str:
    """Markdown table: the FEM permeameter K (three readings) beside the voxel periodic K of the
    same seeds, per (kind, direction); mean +- 95 % CI (Student t) and vs Table III, the
    per-seed FEM / voxel ratios, the FEM bars and statuses. Seeds without a voxel run are left
    out of the voxel mean and the ratio (the n column says which seeds each has). A file that
    cannot be read, or holds no FEM permeameter (resp. voxel periodic) runs: :class:`RunsError`.
    """
    fem = _by_seed(fem_path, "fem", "permeameter")
    vox = _by_seed(voxel_path, "voxel", "periodic")
    lines = [
        "| kind | direction | n (seeds) | FEM permeameter, windowed | voxel periodic, same seeds | "
        "FEM / voxel (per seed) | FEM, drop between RVE faces | FEM, applied drop over RVE + "
        "zones | FEM bar, status | paper |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for key, runs in sorted(fem.items(), key=lambda kv: (kv[0][0] != "straight", kv[0])):
        kind, d = key[0], key[2]
        seeds = sorted(runs)
        ref = PAPER.get((kind, d))
        k = {
            rd: np.array([runs[s][f"k_{d}{rd}_m2"] for s in seeds])
            for rd in ("", "_faces", "_applied")
        }
        both = [s for s in seeds if s in vox.get(key, {})]
        kv = np.array([vox[key][s][f"k_{d}_m2"] for s in both])
        ratio = [runs[s][f"k_{d}_m2"] / vox[key][s][f"k_{d}_m2"] for s in both]
        ratio_cell = (
            f"{np.mean(ratio):.3f} ({', '.join(f'{r:.3f}' for r in ratio)})" if both else "-"
        )
        bars = [100 * runs[s][f"k_{d}_rel_error"] for s in seeds if _has_bar(runs[s], d)]
        status = sorted({str(runs[s].get(f"k_{d}_status")) for s in seeds})
        conv = all(runs[s].get(f"k_{d}_converged") is True for s in seeds)
        cells = [kind, d, f"{len(seeds)} ({', '.join(map(str, seeds))})", _mean_cell(k[""], ref)]
        cells.append(
            _mean_cell(kv, ref) + (f" (n={len(both)})" if len(both) != len(seeds) else "")
            if both
            else "-"
        )
        cells += [ratio_cell, _mean_cell(k["_faces"], ref), _mean_cell(k["_applied"], ref)]
        cells.append(_bar_cell(bars, [s for s in seeds if not _has_bar(runs[s], d)], status, conv))
        cells.append(f"{ref:.3g}" if ref else "-")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _summary(a: argparse.Namespace) -> int:
    """``summary``: print the table, or one line on stderr and exit status 2 for bad input."""
    try:
        if a.beside and a.reading:  # beside has all three readings: one would be ignored
            raise RunsError(
                f"--reading {a.reading} with --beside: the beside table has every reading "
                "(windowed, faces, applied); drop --reading, or drop --beside for one reading"
            )
        table = (
            beside(Path(a.path), Path(a.beside)) if a.beside else summary(Path(a.path), a.reading)
        )
    except RunsError as exc:
        print(f"paper_table3 summary: {exc}", file=sys.stderr)
        return 2
    print(table)
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--kind", default="straight", help="studies/table3/<kind>.toml")
    r.add_argument("--spec", default=None, help="spec path instead of --kind")
    r.add_argument("--method", default=None, choices=("ga", "fast", "none"))
    r.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    r.add_argument("--directions", nargs="+", default=["z", "x"])
    r.add_argument("--voxel", type=float, default=1e-6)
    r.add_argument("--solver", default="voxel", choices=("voxel", "fem"))
    r.add_argument("--bc", default="periodic", choices=("periodic", "permeameter"))
    r.add_argument("--size", type=float, default=None, help="cube edge (m)")
    r.add_argument("--no-error-estimate", action="store_true")
    r.add_argument("--lattice-step", type=float, default=None, help="FEM lattice step (m)")
    r.add_argument("--cache", default=None, help="folder of built RVEs reused across runs")
    r.add_argument("--out", required=True)
    m = sub.add_parser("mirror", help="K of the RVE and of it + its mirror image (no mismatch)")
    m.add_argument("--kind", default="straight")
    m.add_argument("--method", default="ga")
    m.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    m.add_argument("--direction", default="x")
    m.add_argument("--voxel", type=float, default=1e-6)
    m.add_argument("--cache", default=None)
    m.add_argument("--out", required=True)
    s = sub.add_parser("summary")
    s.add_argument("path")
    s.add_argument("--reading", default="", choices=("", "_faces", "_applied"))
    s.add_argument("--beside", default=None, help="voxel periodic runs: the FEM vs voxel table")
    a = p.parse_args(argv)
    if a.cmd == "summary":
        return _summary(a)
    global CACHE_DIR
    CACHE_DIR = a.cache
    if a.cmd == "mirror":
        for seed in a.seeds:
            spec = (ROOT / "studies" / "table3" / f"{a.kind}.toml").resolve()
            rec = run_mirror(spec, a.method, seed, a.direction, a.voxel)
            with open(a.out, "a") as fh:
                fh.write(json.dumps(rec) + "\n")
            print(json.dumps(rec))
            sys.stdout.flush()
        return 0
    spec = Path(a.spec) if a.spec else ROOT / "studies" / "table3" / f"{a.kind}.toml"
    spec = spec.resolve()
    for seed in a.seeds:
        rec = run_case(
            spec, a.method, seed, a.directions, a.voxel, a.solver, a.bc,
            not a.no_error_estimate, a.size, a.lattice_step,
        )  # fmt: skip
        with open(a.out, "a") as fh:
            fh.write(json.dumps(rec) + "\n")
        print(json.dumps({k: v for k, v in rec.items() if not k.startswith("pore_hist")}))
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
