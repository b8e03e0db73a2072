"""FEM vs voxel on the same RVE and boundary condition; the FEM's accuracy at default settings.

Two parts, each appending one JSON line per solve to ``benchmarks/solver_agreement_runs.jsonl``
(a partial run is kept), and ``render``, which writes ``docs/solver-agreement.md`` from it:

* ``arrays``: square and hexagonal cylinder arrays along and across at solid fractions
  0.1-0.5 (thin periodic slabs, one cell, spacing 40 um), both routes with ``bc = "periodic"``
  and their default settings (FEM: stuffing lattice step ``default_lattice_step``, 2 voxels on
  these thin slabs, mesh volume matched to the analytic pore volume; voxel: sub-voxel walls),
  against the published values (issue 12, item 3);
* ``specs``: every shipped spec in ``studies/`` (a study: its first case), both routes, both BCs,
  with the error bars (issue 12, item 1). ``--size`` / ``--voxel`` shrink the RVE when the
  full one does not fit the machine; the table says so.

Usage::

    python benchmarks/solver_agreement.py arrays [--phi 0.1 0.3 0.5] [--kind square hex]
    python benchmarks/solver_agreement.py specs [--size 40e-6] [--voxel 1e-6] [--only table3]
    python benchmarks/solver_agreement.py hexwindow
    python benchmarks/solver_agreement.py probe studies/examples/three_rods.toml --solver fem \
        --voxel 1e-6 [--copies 3] [--lattice-step 2.5e-6] [--bc periodic] [--aux-length 0.5] \
        [--seam-tol 1]
    python benchmarks/solver_agreement.py render
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
import traceback
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

# the solvers and flow.bc models: the product's one list each (a copy here until session 48)
from psdesign.schema.flow import BC_MODELS, SOLVERS  # noqa: E402

RUNS = ROOT / "benchmarks" / "solver_agreement_runs.jsonl"
DOC = ROOT / "docs" / "solver-agreement.md"
MU = 1.8e-5
S = 40e-6  #: array spacing (m)
AGREE = 0.02
#: Row labels of the specs part: the permeameter with one RVE between the reservoirs
#: (``permeameter_copies = 1``, the definition before the stack), with ``"auto"`` copies
#: (engineer stack's stacked permeameter, ``psdesign/flow/stack.py``) and, where the stacked row
#: flags its entrance residual, one copy longer (:func:`_longer_copies`), and the stacked row of a
#: spec in :data:`REFINED` at the finer resolution named there.
SPEC_BCS = (
    "periodic",
    "permeameter",
    "permeameter-stacked",
    "permeameter-longer",
    "permeameter-refined",
)
#: 'permeameter-refined' rows: the stacked row's RVE (same build, same ``"auto"`` plan) with the
#: voxel route on a finer grid (``voxel_m``) and the FEM at a finer lattice step
#: (``lattice_step_m``) on the row's own field, for a row above 2 % whose refinement table shows
#: the miss is discretisation (docs/solver-agreement.md, the spec's section; the stacked row
#: stays in the table with its verdict). rev_toray: the table's 0.833 um grid (8.4 voxels per
#: diameter) puts the voxel route +1.8 % above its extrapolated limit, the FEM's 2 um step
#: (2.9 cells per diameter) -0.66 % below its 1.25 um value; at 0.5 um (14 voxels per diameter)
#: the voxel K is +0.6 % above its limit, at 60 / 42 um (4.9 cells per diameter) the FEM K is
#: 0.15 % below its 1.25 um value (the finer step costs 1.5 x the CPU and 4.7 GB). Session 19
#: (seam19): ``"auto"`` stacks this RVE (two copies: the end-plane tolerance is 2 % of L, not half
#: a voxel), and the 60 / 42 um step on two copies would need about 6.4 GB: the FEM takes 60 / 36
#: um (1.67 um, 0.05 % from 1.43 um on one copy; about 4 GB).
REFINED = {"studies/rev_toray.toml": {"voxel_m": 5e-7, "lattice_step_m": 60e-6 / 36}}


def _append(row: dict) -> None:
    row = {"date": time.strftime("%Y-%m-%d %H:%M"), "host": platform.node(), **row}
    with RUNS.open("a") as fh:
        fh.write(json.dumps(row) + "\n")
    print(json.dumps(row), flush=True)


def _load() -> float:
    return os.getloadavg()[0]


# ------------------------------------------------------------------------------- arrays


def array_rve(kind: str, phi: float, n_per_spacing: int, depth_voxels: int = 4):
    """One cell of a square or hexagonal array (cylinders along z) as a thin periodic slab.

    Hexagonal: the L x sqrt(3) L rectangle with a cylinder at the centre and at the corners,
    its width rounded to whole voxels (56 voxels per spacing: 97, 0.005 % off sqrt(3))."""
    from psdesign.geometry.fibers import make_fiber
    from psdesign.geometry.rve import RVE

    h = S / n_per_spacing
    if kind == "square":
        width = S
        a = S * math.sqrt(phi / math.pi)
        centres = [(S / 2, S / 2)]
    else:
        width = round(math.sqrt(3.0) * S / h) * h
        a = S * math.sqrt(math.sqrt(3.0) * phi / (2 * math.pi))
        centres = [(S / 2, width / 2), (0, 0), (S, 0), (0, width), (S, width)]
    depth = depth_voxels * h
    size = np.array([S, width, depth])
    ref = float(size.max())
    fibers = [
        make_fiber(
            "cylinder",
            diameter=2 * a / ref,
            center=np.array([x, y, depth / 2]) / ref,
            theta=None,
            omega=None,
            direction=[0, 0, 1],
            u=0.0,
            f=1.0,
            isovalue=None,
        )
        for x, y in centres
    ]
    return RVE(size=size, fibers=fibers, period=None), a, h


def array_reference(kind: str, flow: str, phi: float, a: float) -> tuple[float | None, str]:
    """Published K (m^2) and its source; None where no published value is stored."""
    from arrays import along_array_k
    from reference_values import SANGANI_ACRIVOS_SQUARE_TRANSVERSE, drummond_tahir_hex_transverse

    if flow == "along":
        lattice = "square" if kind == "square" else "hexagonal"
        return a * a * along_array_k(phi, lattice), "Sparrow & Loeffler 1959 series"
    if kind == "square":
        return S**2 / SANGANI_ACRIVOS_SQUARE_TRANSVERSE[phi], "Sangani & Acrivos 1982 Table 1"
    if phi <= 0.3:
        return S**2 * drummond_tahir_hex_transverse(phi), "Drummond & Tahir 1984 (dilute)"
    return None, "none stored (dilute series invalid above 0.3)"


def run_arrays(args) -> None:
    from psdesign.flow.permeability import permeability

    for kind in args.kind:
        n = 40 if kind == "square" else 56
        for phi in args.phi:
            rve, a, h = array_rve(kind, phi, n)
            fields = rve.voxelize(h)
            for flow_dir in ("along", "across"):
                k_ref, source = array_reference(kind, flow_dir, phi, a)
                direction = "z" if flow_dir == "along" else "x"
                for solver in args.solvers:
                    row = {
                        "part": "arrays",
                        "case": f"{kind} {flow_dir}",
                        "phi": phi,
                        "voxels_per_spacing": n,
                        "solver": solver,
                        "bc": "periodic",
                        "k_ref_m2": k_ref,
                        "reference": source,
                        "load_1min": _load(),
                    }
                    t0 = time.perf_counter()
                    try:
                        res = permeability(
                            rve, fields, direction, {"viscosity": MU, "bc": "periodic"}, solver
                        )
                        row |= _summary(res)
                    except (ValueError, NotImplementedError) as exc:
                        row["error"] = f"{type(exc).__name__}: {exc}"
                    row["wall_s"] = time.perf_counter() - t0
                    _append(row)


def window_name(res: dict) -> str | None:
    """The permeameter window a result's K was defined with (``psdesign.flow.darcy.window``):
    ``"flat-top"`` for a sample of two or more periods, ``"sin^2"`` for one; None off the
    permeameter. Rows solved before the flat-top window (abb0702) have no such key."""
    from psdesign.flow.darcy import window_shape
    from psdesign.flow.error import periods_in_sample

    if res.get("bc") != "permeameter":
        return None
    return "sin^2" if window_shape(periods_in_sample(res)) is None else "flat-top"


def _summary(res: dict) -> dict:
    mq = res.get("mesh_quality") or {}
    return {
        "permeameter_window": window_name(res),
        "k_m2": res["permeability_m2"],
        "rel_error": res.get("permeability_rel_error"),
        "status": res.get("status"),
        "converged": res.get("converged"),
        "iterations": res.get("iterations"),
        "porosity": res.get("porosity"),
        "lattice_step_m": mq.get("lattice_step_m"),
        "n_tets": res.get("n_tets"),
        "mesh_volume_rel_error": mq.get("volume_rel_error"),
        "porosity_mesh": mq.get("porosity_mesh"),
        "porosity_analytic": mq.get("porosity_analytic"),
        "cells_per_diameter": res.get("cells_per_diameter"),
        "route_wall_s": res.get("wall_time_s"),
        "window_rel_error": (res.get("error_estimate") or {}).get("window"),
        "seam_gap_fraction": res.get("seam_gap_fraction"),
        "seam_rel_error": (res.get("error_estimate") or {}).get("seam"),
        "pressure_drop_rve_pa": res.get("pressure_drop_rve_pa"),
        "pressure_drop_plane_window_pa": res.get("pressure_drop_plane_window_pa"),
        "pressure_drop_faces_pa": res.get("pressure_drop_faces_pa"),
    }


# -------------------------------------------------------------------------------- specs


def shipped_specs() -> list[Path]:
    return sorted(ROOT.glob("studies/*.toml")) + sorted(ROOT.glob("studies/*/*.toml"))


def first_case(path: Path) -> tuple[dict, str]:
    """The spec of a single-RVE file, or of a study's first case (with its label)."""
    from psdesign.schema.spec import load_spec, read_toml

    data = read_toml(path)
    if "study" in data:
        from psdesign.study.design import expand_design
        from psdesign.study.studyfile import load_study

        case = expand_design(load_study(path))[0]
        return case.spec, f"first case {case.params}, seed {case.seed}"
    return load_spec(path), "single RVE"


CACHE = ROOT / "benchmarks" / "solver_agreement_cache"  #: one JSON file per spec row (kept)
BUILDS = ROOT / "out" / "solver_agreement_builds"  #: pickled built RVEs (not kept)
VOXELS_PER_DIAMETER = 8  #: the voxel grid resolves the thinnest fiber with at least this
MAX_VOXELS_PER_DIAMETER = 10  #: a finer spec voxel is coarsened to d / 8 (machine time)


def _slug(rel: str) -> str:
    return rel.removeprefix("studies/").removesuffix(".toml").replace("/", "-")


def _cache(rel: str, *parts: str) -> Path:
    return CACHE / ("__".join([_slug(rel), *parts]) + ".json")


def _write_cache(path: Path, row: dict) -> None:
    from psdesign.io.atomic import json_default, write_json

    CACHE.mkdir(parents=True, exist_ok=True)
    row = {"date": time.strftime("%Y-%m-%d %H:%M"), "host": platform.node(), **row}
    write_json(path, row)
    print(json.dumps(row, default=json_default), flush=True)


def _thinnest(spec: dict) -> float | None:
    """The smallest fiber diameter a spec names (generator or explicit fibers), or None."""
    ds = [f["diameter"] for f in spec.get("fibers") or [] if f.get("diameter")]
    if spec.get("generator", {}).get("diameter"):
        ds.append(spec["generator"]["diameter"])
    return min(ds) if ds else None


def _dividing(size: list[float], target: float, fallback: float) -> float:
    """The largest voxel <= ``target`` that divides every edge of ``size`` (and of the trial
    cubes, which are whole micrometres), else ``fallback``."""
    for n in range(math.ceil(min(size) / target - 1e-9), 20 * math.ceil(min(size) / target)):
        v = min(size) / n
        if all(abs(x / v - round(x / v)) < 1e-6 for x in [*size, 50e-6, 60e-6, 80e-6]):
            return v
    return fallback


def _candidates(spec: dict, sizes: list[float]) -> list[tuple[dict, str]]:
    """The spec at each trial size (smallest first, its own size last) with the resolution
    rule applied, each with what was changed and why.

    Only a porosity target is shrunk (a fixed fiber count, explicit fibers or a woven cell in
    a smaller box is another material). The voxel gives the thinnest fiber at least 8 voxels: a
    coarser spec voxel is refined to d / 8; one giving more than 10 is coarsened to d / 8
    (machine time); both rounded down to a voxel dividing the box."""
    own = list(spec["rve"]["size"])
    d = _thinnest(spec)
    voxel = spec["rve"]["voxel"]
    why = []
    if d is not None and d / voxel < VOXELS_PER_DIAMETER - 1e-9:
        voxel = _dividing(own, d / VOXELS_PER_DIAMETER, voxel)
    elif d is not None and d / voxel > MAX_VOXELS_PER_DIAMETER + 1e-9:
        voxel = _dividing(own, d / VOXELS_PER_DIAMETER, voxel)
    if voxel != spec["rve"]["voxel"]:
        why.append(f"voxel {voxel * 1e6:.4g} um (spec {spec['rve']['voxel'] * 1e6:g})")
    gen = spec.get("generator") or {}
    shrink = gen.get("porosity") is not None
    trial = [s for s in sorted(sizes) if s < min(own) - 1e-12] if shrink else []
    out = []
    for s in trial:
        rve = {**spec["rve"], "size": [s] * 3, "voxel": voxel}
        out.append(({**spec, "rve": rve}, ", ".join([*why, f"{s * 1e6:g} um cube"])))
    note = "own size" if shrink or trial else "own size (not a porosity target: not shrunk)"
    out.append(({**spec, "rve": {**spec["rve"], "voxel": voxel}}, ", ".join([*why, note])))
    return out


def _recorded(info_path: Path, spec: dict) -> list[tuple[dict, str]]:
    """The size and voxel a build record chose (the rows solved on it stay comparable when the
    pickle is gone or the resolution rule changed), or [] without a record."""
    if not info_path.exists():
        return []
    base = json.loads(info_path.read_text()).get("base")
    if not base:
        return []
    rve = {**spec["rve"], "size": list(base["size_m"]), "voxel": base["voxel_m"]}
    return [({**spec, "rve": rve}, base["changed"])]


def _build(rel: str, spec: dict, sizes: list[float]):
    """Build the spec at the smallest trial size that generates (cached: the choice in
    ``CACHE``, the built RVE in ``BUILDS``); returns (built, fields, base row) or None."""
    import pickle

    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    info_path, pkl = _cache(rel, "build"), BUILDS / (_slug(rel) + ".pkl")
    if info_path.exists():
        info = json.loads(info_path.read_text())
        if "error" in info:
            return None
        if pkl.exists():
            built, fields = pickle.loads(pkl.read_bytes())
            return built, fields, info["base"]
    tried: list[str] = []
    recorded = _recorded(info_path, spec)
    old_tried = json.loads(info_path.read_text())["base"].get("tried", []) if recorded else []
    for cand, changed in recorded or _candidates(spec, sizes):
        t0 = time.perf_counter()
        try:
            cand = validate_spec(cand)
            built = build_rve(cand)
            fields = built.voxelize(cand["rve"]["voxel"])
        except Exception as exc:  # noqa: BLE001 (recorded: a size that does not generate)
            msg = f"{type(exc).__name__}: {exc}".splitlines()[0]
            tried.append(f"{changed}: {msg[:160]} ({time.perf_counter() - t0:.0f} s)")
            continue
        base = {
            "changed": changed,
            "tried": tried or old_tried,
            "size_m": [float(x) for x in cand["rve"]["size"]],
            "voxel_m": float(cand["rve"]["voxel"]),
            "voxels_per_diameter": (
                None if _thinnest(cand) is None else _thinnest(cand) / cand["rve"]["voxel"]
            ),
            "porosity": float(fields.porosity),
            "build_s": time.perf_counter() - t0,
            "flow": {k: v for k, v in cand["flow"].items() if isinstance(v, (int, float, str))},
        }
        base["fingerprint"] = _fingerprint(fields, base)
        BUILDS.mkdir(parents=True, exist_ok=True)
        pkl.write_bytes(pickle.dumps((built, fields)))
        _write_cache(info_path, {"spec": rel, "base": base})
        return built, fields, base
    _write_cache(info_path, {"spec": rel, "error": "; ".join(tried) or "no candidate"})
    return None


#: When the error bar gained its seam term (``psdesign.flow.error.seam_rel_error``): the
#: stacked permeameter at 6cb7147, the periodic BC's wrap at 85b488e (UTC, this host's clock).
#: Rows solved before carry a bar without it; :func:`run_seam` adds it from the rebuilt RVE.
SEAM_TERM_SINCE = {"periodic": "2026-12-03 18:17", "permeameter": "2026-12-03 17:43"}


def _rebuild(rel: str, info: dict):
    """The built RVE and fields of a build record, rebuilt at the recorded size and voxel
    (without touching the cache); None when the fingerprint differs from the record's."""
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    spec, _ = first_case(ROOT / rel)
    ((cand, _),) = _recorded(_cache(rel, "build"), spec)
    cand = validate_spec(cand)
    built = build_rve(cand)
    fields = built.voxelize(cand["rve"]["voxel"])
    if _fingerprint(fields, info["base"]) != info["base"].get("fingerprint"):
        return None
    return built, fields


def _refresh_refusal(rel: str, row: dict | None, rve, fields, args) -> None:
    """A cached periodic-FEM refusal re-worded by the product's check as it is now (its seam
    tolerance is a length since session 19; the rows quoted voxels); a geometry the check
    now accepts is reported for a new solve (``specs --force``) and left as it is."""
    from psdesign.flow.fem import check_periodic_geometry
    from psdesign.io.atomic import write_json
    from solvers.fem.periodic import PeriodicMeshError

    if not row or "not periodic" not in row.get("error", ""):
        return
    try:
        check_periodic_geometry(rve, fields)
    except PeriodicMeshError as exc:
        msg = f"PeriodicMeshError: {exc}"
        if msg != row["error"]:
            row = {**row, "error": msg, "error_reworded": time.strftime("%Y-%m-%d %H:%M")}
            write_json(_cache(rel, args.direction, "periodic", "fem"), row)
            print(f"{rel} periodic fem: refusal re-worded", flush=True)
        return
    print(f"{rel} periodic fem: now accepted (re-solve: specs --force --bc periodic)", flush=True)


def run_seam(args) -> None:
    """Add the seam term to the bars of spec rows solved before it existed.

    The bar is a sum of terms (``psdesign.flow.error.estimate_with``), so a row's bar with the
    seam term is its recorded bar plus ``SEAM_SLOPE g / L``: ``g / L`` from the end planes of
    the rebuilt RVE along the flow (:func:`psdesign.flow.stack.periodicity`), 0 where they do
    not match within ``SEAM_TOL_LENGTH`` (the periodic route warns instead) and for one copy.
    Each updated row keeps ``rel_error_before_seam``; rows solved since carry the term."""
    from psdesign.flow.error import seam_rel_error, status_of
    from psdesign.flow.stack import periodicity
    from psdesign.io.atomic import write_json

    builds, solves = _spec_rows()
    for rel, info in sorted(builds.items()):
        rows = {k: r for k, r in solves.items() if k[0] == rel and "k_m2" in r}
        refused = "not periodic" in (solves.get((rel, "periodic", "fem")) or {}).get("error", "")
        wanted = not args.only or any(o in rel for o in args.only)
        if "error" in info or not (rows or refused) or not wanted:
            continue
        got = _rebuild(rel, info)
        if got is None:
            print(f"{rel}: the rebuilt RVE differs from the record; not updated", flush=True)
            continue
        built, fields = got
        _refresh_refusal(rel, solves.get((rel, "periodic", "fem")), built.rve, fields, args)
        periodic, _, _, gap = periodicity(built.rve, fields, 2)
        for (_, bc, solver), row in sorted(rows.items()):
            if "rel_error_before_seam" in row or "seam_rel_error" in row:
                continue
            stacked = bc != "periodic" and (row.get("permeameter_copies") or 1) > 1
            g = gap if periodic and (bc == "periodic" or stacked) else 0.0
            term = seam_rel_error({"seam_gap_fraction": g})
            since = SEAM_TERM_SINCE["periodic" if bc == "periodic" else "permeameter"]
            row = {**row, "seam_gap_fraction": g, "seam_rel_error": term}
            if row["date"] < since:
                row |= {"rel_error_before_seam": row["rel_error"], "seam_added": True}
                row["rel_error"] = row["rel_error"] + term
                # the product's rating (psdesign.flow.permeability): below 8 cells per
                # diameter only the voxel route is untrustworthy; the FEM's status follows its bar
                cpd = row.get("cells_per_diameter") if solver == "voxel" else None
                row["status"] = status_of(bool(row.get("converged")), row["rel_error"], cpd)
            write_json(_cache(rel, args.direction, bc, solver), row)
            print(f"{rel} {bc} {solver}: g/L {g:.4g}, seam term {100 * term:.2f} %", flush=True)


def _fingerprint(fields, base: dict) -> str:
    """Hash of the voxelized RVE (distance field, grid) and the ``[flow]`` table: two specs
    with one fingerprint are one solve (e.g. the studies whose first case is the same
    straight Toray-like generator and seed)."""
    import hashlib

    h = hashlib.sha256(np.ascontiguousarray(fields.distance, dtype=np.float64).tobytes())
    h.update(json.dumps([base["size_m"], base["voxel_m"], base["flow"]], sort_keys=True).encode())
    return h.hexdigest()[:16]


def _reuse_same_rve(rel: str, label: str, base: dict, direction: str, bc: str, solver: str) -> bool:
    """A row of a spec whose built RVE and ``[flow]`` table equal another spec's (same
    fingerprint) that has this row solved: copy that row (marked) instead of solving again."""
    fp = base.get("fingerprint")
    if fp is None:
        return False
    for info_path in sorted(CACHE.glob("*__build.json")):
        info = json.loads(info_path.read_text())
        if info.get("spec") == rel or info.get("base", {}).get("fingerprint") != fp:
            continue
        src = _cache(info["spec"], direction, bc, solver)
        if not src.exists():
            continue
        row = json.loads(src.read_text())
        if "k_m2" not in row or "reused_from" in row:
            continue
        row |= {"spec": rel, "case": label, "reused_from": info["spec"], "fingerprint": fp}
        _write_cache(_cache(rel, direction, bc, solver), row)
        return True
    return False


def _not_an_rve(path: Path) -> str | None:
    """Why a force-field spec has no row of its own, or None."""
    from psdesign.schema.spec import read_toml

    data = read_toml(path)
    if "forcefield" not in data:
        return None
    if "rve" not in data:
        return "a force-field problem (no [rve]): no RVE to solve"
    twin = ROOT / "studies" / "table3" / "woven.toml"
    same = {k: v for k, v in data.items() if k != "forcefield"} == read_toml(twin)
    return (
        "relaxes an RVE with `psdesign forcefield` (its relaxed RVE is that command's "
        "output, not run here); its input RVE"
        + (" is studies/table3/woven.toml's (same [rve], [[fibers]], [flow])" if same else "")
    )


def _flow_of(flow: dict, label: str, copies: int | None = None) -> dict:
    """The ``[flow]`` table of a row label of :data:`SPEC_BCS` (``copies``: the
    ``permeameter-longer`` row's, :func:`_longer_copies`)."""
    if label == "periodic":
        return {**flow, "bc": "periodic"}
    n = {"permeameter": 1, "permeameter-longer": copies}.get(label) or "auto"
    return {**flow, "bc": "permeameter", "permeameter_copies": n}


def _longer_copies(rel: str, direction: str) -> int | None:
    """Copies of a spec's ``permeameter-longer`` row: one more than its stacked rows' when those
    stacked (two or more copies, both routes alike), the two routes differ by more than
    :data:`AGREE` and either route's window term (the entrance/exit residual of the windowed
    drop, ``error_estimate.window``) is above the product's
    :data:`psdesign.flow.error.WINDOW_WARN`; else None (no such row). The same RVE and boundary
    condition is then compared on a sample where the entrance disturbance, which each route's
    reservoirs shape differently, has decayed further before the window: is the miss the
    sample length? (The stacked row stays in the table with its verdict.)"""
    from psdesign.flow.error import WINDOW_WARN

    rows = []
    for solver in SOLVERS:
        path = _cache(rel, direction, "permeameter-stacked", solver)
        if not path.exists():
            return None
        rows.append(json.loads(path.read_text()))
    if not all("k_m2" in r for r in rows):
        return None
    copies = {r.get("permeameter_copies") for r in rows}
    if len(copies) != 1 or (c := copies.pop()) is None or c < 2:
        return None
    if abs(rows[0]["k_m2"] / rows[1]["k_m2"] - 1) <= AGREE:
        return None
    if not any((r.get("window_rel_error") or 0.0) > WINDOW_WARN for r in rows):
        return None
    return c + 1


def _reuse_single_copy(rel: str, built, fields, direction: str, bc: str, solver: str) -> bool:
    """A permeameter row whose ``"auto"`` plan is one copy is the same solve as the other
    permeameter label's: copy that row (marked) instead of solving again."""
    if not bc.startswith("permeameter"):
        return False
    from psdesign.flow.darcy import axis_of
    from psdesign.flow.stack import plan_copies

    plan = plan_copies({"permeameter_copies": "auto"}, built.rve, fields, axis_of(direction)[1])
    other = "permeameter" if bc == "permeameter-stacked" else "permeameter-stacked"
    src = _cache(rel, direction, other, solver)
    if plan.copies != 1 or not src.exists():
        return False
    row = json.loads(src.read_text())
    row |= {"bc": bc, "reused_from": other, "auto_plan": plan.as_dict()}
    _write_cache(_cache(rel, direction, bc, solver), row)
    return True


def run_specs(args) -> None:
    """Every shipped spec, rows in the order bc x solver given, one cache file per row:
    a row whose file exists is not solved again (``--force`` to redo)."""
    from psdesign.flow.permeability import permeability

    paths = shipped_specs()
    if args.only:  # in the order given
        paths = [p for s in args.only for p in paths if s in str(p.relative_to(ROOT))]
    for path in dict.fromkeys(paths):
        rel = str(path.relative_to(ROOT))
        try:
            spec, label = first_case(path)
        except Exception as exc:  # noqa: BLE001 (recorded: not an RVE spec)
            msg = _not_an_rve(path) or f"{type(exc).__name__}: {exc}".splitlines()[0]
            if not _cache(rel, "build").exists():
                _write_cache(_cache(rel, "build"), {"spec": rel, "error": msg})
            continue
        todo = [
            (bc, solver)
            for bc in args.bc
            for solver in args.solvers
            if args.force or not _cache(rel, args.direction, bc, solver).exists()
            if bc != "permeameter-refined" or rel in REFINED
        ]
        if not todo:
            continue
        got = _build(rel, dict(spec), args.sizes)
        if got is None:
            continue
        built, fields, base = got
        for bc, solver in todo:
            longer = _longer_copies(rel, args.direction) if bc == "permeameter-longer" else None
            if bc == "permeameter-longer" and longer is None:
                continue  # the stacked rows do not flag their entrance residual
            refined = REFINED.get(rel) if bc == "permeameter-refined" else None
            if refined is None and _reuse_single_copy(
                rel, built, fields, args.direction, bc, solver
            ):
                continue
            if not args.force and _reuse_same_rve(rel, label, base, args.direction, bc, solver):
                continue
            row = {
                "part": "specs",
                "spec": rel,
                "case": label,
                "direction": args.direction,
                **base,
                "solver": solver,
                "bc": bc,
                "load_1min": _load(),
            }
            flow = _flow_of(base["flow"], bc, longer)
            solve_fields = fields
            if refined is not None:  # the same RVE, finer: the voxel grid, or the FEM's lattice
                row["refined"] = refined
                if solver == "voxel":
                    solve_fields = built.rve.voxelize(refined["voxel_m"])
                else:
                    flow["lattice_step"] = refined["lattice_step_m"]
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                res = permeability(built.rve, solve_fields, args.direction, flow, solver)
                row |= _summary(res)
                row["definition_spread"] = res.get("definition_spread")
                row["permeameter_copies"] = res.get("permeameter_copies")
                row["permeameter_auto"] = res.get("permeameter_auto")  # "auto": each solve
                row["warnings"] = [str(w)[:200] for w in res.get("warnings") or []]
            except (ValueError, NotImplementedError, MemoryError) as exc:
                row["error"] = f"{type(exc).__name__}: {exc}".splitlines()[0]
            except Exception as exc:  # noqa: BLE001
                row["error"] = f"{type(exc).__name__}: {exc}".splitlines()[0]
                traceback.print_exc()
            row["wall_s"] = time.perf_counter() - t0
            row["cpu_s"] = time.process_time() - c0  # this process, all threads
            row["load_1min_end"] = _load()
            _write_cache(_cache(rel, args.direction, bc, solver), row)


# ------------------------------------------------------------------------------ probe


def _probe_cache(args) -> Path:
    step = "default" if args.lattice_step is None else f"{args.lattice_step * 1e6:g}"
    copies = "auto" if args.copies is None else str(args.copies)
    parts = [_slug(args.spec), args.solver, args.bc, f"v{args.voxel * 1e6:g}"]
    parts += [f"c{copies}", f"s{step}"]
    if args.aux_length is not None:  # absent from older probes' names: the [flow] default
        parts.append(f"a{args.aux_length:g}")
    if args.seam_tol is not None:  # a fraction of L since session 19 (voxels before: "seam1")
        parts.append(f"seamL{args.seam_tol:g}")
    return CACHE / ("probe__" + "__".join(parts) + ".json")


def run_probe(args) -> None:
    """One spec's RVE (z) at a given voxel, permeameter copies and FEM lattice step, with its
    error bar: which route moves with resolution and sample length? One cache file per probe
    (``probe__...json``, kept; ``--force`` to redo)."""
    import resource

    from psdesign.flow.permeability import permeability
    from psdesign.packing.build import build_rve

    path = _probe_cache(args)
    if path.exists() and not args.force:
        print(f"cached: {path}")
        return
    spec, _ = first_case(ROOT / args.spec)
    got = _build(args.spec, dict(spec), [])  # the table's RVE: its recorded size and voxel
    if got is None:  # no build record: the spec as it is
        built = build_rve(spec)
    else:
        built, _, base = got
        spec = {**spec, "flow": {**spec["flow"], **base["flow"]}}
    fields = built.voxelize(args.voxel)
    flow = {k: v for k, v in spec["flow"].items() if isinstance(v, (int, float, str))}
    flow = _flow_of(flow, "permeameter-stacked" if args.bc == "permeameter" else "periodic")
    if args.bc == "mirrored":
        from psdesign.flow.stack import mirror_sides

        fields = mirror_sides(fields, 2)
    if args.copies is not None:
        flow["permeameter_copies"] = args.copies
    if args.lattice_step is not None:
        flow["lattice_step"] = args.lattice_step
    if args.aux_length is not None:
        flow["aux_length"] = args.aux_length
    if args.seam_tol is not None:  # diagnostic: stack across a seam the product refuses
        from psdesign.flow import stack

        stack.SEAM_TOL_LENGTH = args.seam_tol
    row = {"part": "probe", "spec": args.spec, "solver": args.solver, "bc": args.bc}
    row |= {"aux_length": flow.get("aux_length"), "seam_tol_length": args.seam_tol}
    row |= {"voxel_m": args.voxel, "copies_asked": args.copies or "auto"}
    row |= {"lattice_step_asked_m": args.lattice_step, "load_1min": _load()}
    mirrored = args.bc == "mirrored"
    cpu0, t0 = time.process_time(), time.perf_counter()
    # mirrored: the voxel route's coarse grid would be the RVE's own, not the mirrored one (the
    # FEM's coarse solve is a coarser lattice on the same field: kept)
    bar = not (mirrored and args.solver == "voxel")
    res = permeability(built.rve, fields, "z", flow, args.solver, error_estimate=bar)
    row |= _summary(res) | {"permeameter_copies": res.get("permeameter_copies")}
    row["definition_spread"] = res.get("definition_spread")
    row |= {"error_estimate": res.get("error_estimate"), "fem_field": res.get("fem_field")}
    row["warnings"] = [str(w)[:200] for w in res.get("warnings") or []]
    row |= {"wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - cpu0}
    row["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    row["load_1min_end"] = _load()
    _write_cache(path, row)


def render_probes(spec: str) -> list[str]:
    """Table of one spec's probes (:func:`run_probe`), each against its route's mirrored K on the
    same grid and lattice step (the limit of the slip-sided stack,
    :func:`psdesign.flow.stack.mirror_sides`)."""
    rows = probe_rows(spec)
    key = lambda r: (r["solver"], r["voxel_m"], r.get("lattice_step_m"))  # noqa: E731
    limit = {key(r): r["k_m2"] for r in rows if r["bc"] == "mirrored"}
    order = {"permeameter": 0, "mirrored": 1, "periodic": 2}
    rows.sort(
        key=lambda r: (r["solver"], order[r["bc"]], -r["voxel_m"], r.get("lattice_step_m") or 0)
    )
    lines = [
        "| route | bc | voxel (um) | copies | FEM step (um) | tets | K (m^2) | bar | window term | "
        "vs mirrored, same grid | CPU s | peak RSS (GB) | load |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        step = r.get("lattice_step_m")
        lim = limit.get(key(r))
        vs = _pct(r["k_m2"] / lim - 1) if lim and r["bc"] == "permeameter" else ""
        win = (r.get("error_estimate") or {}).get("window") if r["bc"] == "permeameter" else None
        bar = (
            ""
            if r["bc"] == "mirrored" and r["solver"] == "voxel"
            else f"{100 * r['rel_error']:.1f} %"
        )
        lines.append(
            f"| {r['solver']} | {r['bc']} | {r['voxel_m'] * 1e6:g} | "
            f"{r.get('permeameter_copies') or ''} | "
            f"{'' if step is None else f'{step * 1e6:.3g}'} | "
            f"{r.get('n_tets') or ''} | {r['k_m2']:.4e} | {bar} | "
            f"{'' if win is None else f'{100 * win:.1f} %'} | {vs} | {r['cpu_s']:.0f} | "
            f"{r['peak_rss_gb']:.2f} | {r['load_1min']:.0f}-{r['load_1min_end']:.0f} |"
        )
    return lines


def render_refinement(spec: str) -> list[str]:
    """Table of one spec's permeameter probes by route and resolution (:func:`run_probe`), with
    the two terms of each bar (discretisation: two grids; window: the entrance/exit residual),
    the reservoir length and, for a stack the product refuses, the seam tolerance it was
    forced with (``--seam-tol``)."""
    rows = [r for r in probe_rows(spec) if r["bc"] == "permeameter"]
    rows.sort(
        key=lambda r: (
            r["solver"],
            r.get("permeameter_copies") or 1,
            r.get("aux_length") or 0.2,
            -r["voxel_m"],
            -(r.get("lattice_step_m") or 0),
        )
    )
    lines = [
        "| route | voxel (um) | copies | aux_length | seam allowed | FEM step (um) | tets "
        "| K (m^2) | bar | discretisation term | window term | iterations | CPU s | peak RSS (GB) "
        "| load | solved (UTC) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        est = r.get("error_estimate") or {}
        step = r.get("lattice_step_m")
        seam = r.get("seam_tol_voxels")  # the probes of session 18: in voxels of the grid
        seam = f"{seam:g} voxel" if seam is not None else r.get("seam_tol_length")
        seam = f"{100 * seam:g} % of L" if isinstance(seam, float) else seam
        lines.append(
            f"| {r['solver']} | {r['voxel_m'] * 1e6:.4g} | {r.get('permeameter_copies') or 1} | "
            f"{r.get('aux_length') or 0.2:g} | {'' if seam is None else seam} | "
            f"{'' if step is None else f'{step * 1e6:.3g}'} | {r.get('n_tets') or ''} | "
            f"{r['k_m2']:.4e} | {100 * r['rel_error']:.1f} % | "
            f"{100 * est.get('discretization', 0.0):.2f} % | "
            f"{100 * est.get('window', 0.0):.1f} % | "
            f"{r.get('iterations') or ''} | {r['cpu_s']:.0f} | {r['peak_rss_gb']:.2f} | "
            f"{r['load_1min']:.1f}-{r['load_1min_end']:.1f} | {r['date']} |"
        )
    return lines


def probe_rows(spec: str) -> list[dict]:
    """The cached probes of one spec (``studies/...toml``)."""
    rows = [json.loads(f.read_text()) for f in sorted(CACHE.glob(f"probe__{_slug(spec)}__*.json"))]
    return [r for r in rows if r.get("spec") == spec]


# --------------------------------------------------------------------------- hex window

#: (solid fraction, voxels per spacing, cells along the flow) of the window-length probe.
HEX_WINDOW = [(0.1, 26, 2), (0.1, 40, 2), (0.1, 40, 3), (0.1, 40, 4), (0.2, 40, 2)]


def _hex_cache(phi: float, n: int, cells: int) -> Path:
    return CACHE / f"hexwindow__phi{phi:g}__n{n}__cells{cells}.json"


def run_hexwindow(args) -> None:
    """Hexagonal array across, voxel permeameter vs periodic K on the same grid, by
    resolution and cell count (``benchmarks/calibrate_error_bar.solve``): is the -1 % of two
    cells at phi 0.1 resolution or window length?"""
    from calibrate_error_bar import solve

    for phi, n, cells in HEX_WINDOW:
        path = _hex_cache(phi, n, cells)
        if path.exists() and not args.force:
            continue
        t0, load = time.perf_counter(), _load()
        rec = solve("hex", "across", phi, n, "permeameter", cells)
        rec |= {"phi": phi, "n": n, "cells": cells, "wall_s": time.perf_counter() - t0}
        rec |= {"load_1min": load, "load_1min_end": _load()}
        rec["perm_vs_periodic"] = rec["k"] / rec["k_periodic"] - 1
        _write_cache(path, rec)


def render_hexwindow() -> list[str]:
    lines = [
        "| phi | voxels per spacing | cells | K permeameter (m^2) | K periodic (m^2) | "
        "permeameter / periodic - 1 | periodic vs published | permeameter bar |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for phi, n, cells in HEX_WINDOW:
        path = _hex_cache(phi, n, cells)
        if not path.exists():
            lines.append(f"| {phi:g} | {n} | {cells} | not run ||||||")
            continue
        r = json.loads(path.read_text())
        lines.append(
            f"| {phi:g} | {n} | {cells} | {r['k']:.4e} | {r['k_periodic']:.4e} | "
            f"{_pct(r['perm_vs_periodic'])} | {_pct(r['k_periodic'] / r['exact'] - 1)} | "
            f"{100 * r['bar']:.2f} % |"
        )
    recs = [json.loads(_hex_cache(*k).read_text()) for k in HEX_WINDOW if _hex_cache(*k).exists()]
    blocks = solve_blocks([r | {"route": "voxel"} for r in recs], key="route")
    return [*lines, "", "Solved (UTC): " + "; ".join(blocks) + "."]


# ------------------------------------------------------------------------------- render


def _pct(x: float | None, digits: int = 2) -> str:
    return "" if x is None else f"{100 * x:+.{digits}f} %"


def _latest(rows: list[dict], key) -> dict:
    out: dict = {}
    for r in rows:  # later runs replace earlier ones
        out[key(r)] = r
    return out


def render_arrays(rows: list[dict]) -> list[str]:
    rows = _latest(
        [r for r in rows if r["part"] == "arrays"],
        lambda r: (r["case"], r["phi"], r["solver"]),
    )
    keys = sorted({(c, p) for c, p, _ in rows}, key=lambda t: (t[0].split()[0], t[0], t[1]))
    lines = [
        "| case | phi | reference K (m^2) | FEM K | FEM vs ref | FEM bar | voxel K | voxel vs "
        "ref | voxel bar | FEM / voxel - 1 | FEM lattice step | FEM mesh volume vs analytic |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    worst = 0.0
    for case, phi in keys:
        fem, vox = rows.get((case, phi, "fem"), {}), rows.get((case, phi, "voxel"), {})
        ref = fem.get("k_ref_m2") or vox.get("k_ref_m2")

        def cells(r: dict, ref: float | None = ref) -> tuple[str, str, str]:
            if "k_m2" not in r:
                return (r.get("error", "not run")[:60], "", "")
            err = None if ref is None else r["k_m2"] / ref - 1
            return f"{r['k_m2']:.4e}", _pct(err), f"{100 * r['rel_error']:.2f} %"

        f, v = cells(fem), cells(vox)
        if ref is not None and "k_m2" in fem:
            worst = max(worst, abs(fem["k_m2"] / ref - 1))
        diff = _pct(fem["k_m2"] / vox["k_m2"] - 1) if "k_m2" in fem and "k_m2" in vox else ""
        step = f"{fem['lattice_step_m'] * 1e6:.2f} um" if fem.get("lattice_step_m") else ""
        lines.append(
            f"| {case} | {phi:g} | {'' if ref is None else f'{ref:.4e}'} | {f[0]} | {f[1]} | "
            f"{f[2]} | {v[0]} | {v[1]} | {v[2]} | {diff} | {step} | "
            f"{_pct(fem.get('mesh_volume_rel_error'), 3)} |"
        )
    lines += ["", f"Largest |FEM vs reference| where a reference exists: {100 * worst:.2f} %."]
    return lines


def _spec_rows() -> tuple[dict, dict]:
    """The cache: build records by spec, solve rows by (spec, bc, solver)."""
    builds, solves = {}, {}
    for f in sorted(CACHE.glob("*.json")):
        if f.stem.startswith(("hexwindow__", "probe__")):
            continue
        r = json.loads(f.read_text())
        if f.stem.endswith("__build"):
            builds[r["spec"]] = r
        else:
            solves[(r["spec"], r["bc"], r["solver"])] = r
    return builds, solves


def _k_cell(r: dict) -> tuple[str, str]:
    if "k_m2" in r:
        return f"{r['k_m2']:.4e} ({r.get('status')})", f"{100 * r['rel_error']:.1f} %"
    return ("n/a: " + r.get("error", "not run"))[:220], ""


def _verdict(fem: dict, vox: dict) -> tuple[str, str, str]:
    """(FEM / voxel - 1, combined bar, verdict) of one row pair."""
    if "k_m2" not in fem or "k_m2" not in vox:
        return "", "", "n/a"
    d = fem["k_m2"] / vox["k_m2"] - 1
    bars = fem["rel_error"] + vox["rel_error"]
    if abs(d) <= AGREE:
        verdict = "agree (<= 2 %)"
    else:
        verdict = "inside combined bar" if abs(d) <= bars else "**outside combined bar**"
    return _pct(d), f"{100 * bars:.1f} %", verdict


def _when(r: dict) -> str:
    """When a row was solved (a reused row: when its source was), or '-'."""
    return r.get("date", "-") if r and ("k_m2" in r or "error" in r) else "-"


def _load_range(rows: list[dict]) -> str:
    """Range of the 1-minute load averages recorded at the start and end of ``rows``."""
    x = [r[k] for r in rows for k in ("load_1min", "load_1min_end") if r.get(k) is not None]
    return f"{min(x):.1f}-{max(x):.1f}" if x else "not recorded"


def solve_blocks(rows: list[dict], key: str = "solver") -> list[str]:
    """One line per (``key``, day) block of solved rows: time span, row count, load range."""
    blocks: dict = {}
    for r in rows:
        if "date" in r and "reused_from" not in r:
            blocks.setdefault((str(r.get(key)), r["date"][:10]), []).append(r)
    out = []
    for (k, day), rs in sorted(blocks.items()):
        t = sorted(r["date"][11:] for r in rs)
        out.append(f"{k} {day} {t[0]}-{t[-1]} ({len(rs)} rows, load {_load_range(rs)} on 2 cores)")
    return out


def _copies(r: dict) -> str:
    """The permeameter definition a row used: copies of the RVE between the reservoirs."""
    if not r or "k_m2" not in r:
        return "-"
    c = r.get("permeameter_copies") or 1  # absent: one copy (code before the stack)
    return f"{c} cop{'y' if c == 1 else 'ies'}"


def render_specs() -> list[str]:
    builds, solves = _spec_rows()
    lines = [
        "| spec | case | box (um) / voxel (um) / voxels per d | changed (why) | bc | K FEM (m^2) "
        "| FEM bar | K voxel (m^2) | voxel bar | FEM / voxel - 1 | combined bar | verdict | "
        "solved (UTC) FEM / voxel |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    counts = {"agree (<= 2 %)": 0, "inside combined bar": 0, "**outside combined bar**": 0}
    copied = 0  #: rows with both K that repeat another spec's solve (same RVE and [flow])
    for spec in sorted({str(q.relative_to(ROOT)) for q in shipped_specs()} | set(builds)):
        if spec not in builds:
            lines.append(f"| {spec} | not run (machine time: not built) |||||||||||")
            continue
        b = builds[spec]
        if "error" in b:
            lines.append(f"| {spec} | n/a: {b['error'][:400]} |||||||||||")
            continue
        base = b["base"]
        box = " x ".join(f"{x * 1e6:g}" for x in base["size_m"])
        vpd = base.get("voxels_per_diameter")
        geo = f"{box} / {base['voxel_m'] * 1e6:.3g} / {'' if vpd is None else f'{vpd:.1f}'}"
        changed = base["changed"] + (
            "; smaller boxes failed: " + "; ".join(base["tried"]) if base.get("tried") else ""
        )
        solved = any((spec, bc, r) in solves for bc in SPEC_BCS for r in SOLVERS)
        if not solved:
            lines.append(f"| {spec} | built ({geo}), not solved (machine time) |||||||||||")
        for bc in SPEC_BCS:
            fem, vox = solves.get((spec, bc, "fem"), {}), solves.get((spec, bc, "voxel"), {})
            if not fem and not vox and (bc != "periodic" or not solved):
                continue  # one copy: dropped for the stack (PERMEAMETER_NOTE); longer: not needed
            (kf, bf), (kv, bv) = _k_cell(fem), _k_cell(vox)
            diff, bars, verdict = _verdict(fem, vox)
            if bc != "periodic" and _copies(fem) != _copies(vox) and diff:
                verdict = "n/a (the routes stacked differently)"
            counts[verdict] = counts.get(verdict, 0) + 1
            if diff and any("/" in r.get("reused_from", "") for r in (fem, vox)):
                copied += 1
            if bc == "permeameter-stacked":
                per = solves.get((spec, "periodic", "voxel"), {})
                if "k_m2" in vox and "k_m2" in per:
                    verdict += f"; voxel vs voxel periodic {_pct(vox['k_m2'] / per['k_m2'] - 1)}"
            any_row = next((r for (sp, _, _), r in solves.items() if sp == spec), {})
            case = (fem or vox or any_row).get("case", "")
            same = sorted({r["reused_from"] for r in (fem, vox) if "/" in r.get("reused_from", "")})
            if same:  # the solve of another spec with the same built RVE and [flow]
                case += f" (same RVE and [flow] as {', '.join(same)}: its solve)"
            bc_cell = bc if bc == "periodic" else f"{bc} ({_copies(fem)} / {_copies(vox)})"
            if bc == "permeameter-refined" and spec in REFINED:
                ref = REFINED[spec]
                bc_cell += (
                    f": voxel {ref['voxel_m'] * 1e6:.3g} um, FEM step "
                    f"{ref['lattice_step_m'] * 1e6:.3g} um on the row's field"
                )
            lines.append(
                f"| {spec} | {case} | {geo} | {changed} | {bc_cell} | {kf} | {bf} | {kv} | {bv} | "
                f"{diff} | {bars} | {verdict} | {_when(fem)} / {_when(vox)} |"
            )
    lines += [
        "",
        "Rows with both K: "
        + ", ".join(f"{v} {k.strip('*')}" for k, v in counts.items() if not k.startswith("n/a"))
        + f" ({copied} of them repeat another spec's solve: same RVE and [flow])"
        + ". 'not run' = not solved in the sessions' machine time (load 6-38 on 2 cores).",
        "",
        "Solved (UTC, by route and day; reused rows not counted): "
        + "; ".join(solve_blocks(list(solves.values())))
        + ". "
        + RESOLVED_NOTE,
    ]
    return lines


#: How the permeameter rows' pressure drop is defined (set when the rows were run).
PERMEAMETER_NOTE = (
    "Permeameter rows (empty reservoirs, slip sides, windowed-dissipation drop) are "
    "'permeameter-stacked': `permeameter_copies = \"auto\"`, engineer stack's stacked "
    "permeameter (`psdesign/flow/stack.py`, merged at 58d7951 'STACK-READY voxel' and 254421a "
    "'STACK-READY fem'): 2 copies along the flow when the geometry is periodic along it and one "
    "copy holds one period, else 1 (the bc cell names each route's copies, FEM / voxel); since "
    "session 8 (branch perm8) `auto` then solves again with one copy more, up to 4, while the "
    "solve's window term (`error_estimate.window`) is above 1 % (`psdesign.flow.stack."
    "next_auto_copies`; the rows solved since record each attempt in `permeameter_auto`). Rows "
    "re-solved under that rule (2026-12-02 06:17-06:58 UTC): three_rods (2 -> 4 copies), "
    "inverse_design (2 -> 3), quickstart and table3 (2: window "
    "terms 0.2-0.75 %; the specs sharing table3's RVE keep the copy of its earlier solve, the "
    "same plan and K), table3-woven voxel (1: 0.1 %); arrays (one copy holds two or more "
    "periods, e.g. validation_cylinders) are not lengthened; the other rows are the earlier "
    "plan's, "
    "with a window term of at most 1 % where recorded (porosity_sweep 0.3 / 0.2 %) and none "
    "recorded on the rest (solved before the term was kept; the one-copy rows there are not "
    "periodic along z, where `auto` cannot stack). Rows "
    "labelled 'permeameter' (one copy, the definition of d560a79) were dropped for machine "
    "time once the stack was in; where the auto plan is one copy the two are the same solve. "
    "The permeameter's slip side walls are another boundary condition than the periodic "
    "sides: on a random RVE the stacked K can differ from the periodic K by far more than "
    "the definition (the 'voxel vs voxel periodic' figure; it is `bc_sensitivity`, a sign "
    "that the box is small), while the two routes are compared on the same model. The "
    "window is the product's (`psdesign.flow.darcy.window`: flat-top of whole periods for two "
    "or more periods in the sample, sin^2 for one; rows record it as `permeameter_window`): "
    "the stacked rows of 2026-12-01 with two or more periods predated the flat-top window "
    "(abb0702, by the git ancestry of their cache commits; the woven rows aside) and were "
    "solved again on 2026-12-02. 'permeameter-longer' rows (`_longer_copies`): where the two "
    "routes' stacked rows differ by more than 2 % and either route's window term (the "
    "entrance/exit residual of the windowed drop, `error_estimate.window`) is above the "
    "product's `WINDOW_WARN` (1 %), the same RVE one copy longer: the entrance disturbance, "
    "which the two routes' reservoirs shape differently, then decays further before the window "
    "(none qualifies since `auto` lengthens the stack itself; three_rods' 3-copy row of session "
    "7, -0.45 %, was removed when its stacked row took 4 copies). 'permeameter-refined' rows "
    "(`REFINED`, session 18): a stacked row above 2 % whose refinement table shows the miss is "
    "discretisation, solved again on the same build with the voxel route on a finer grid and "
    "the FEM at a finer lattice step on the row's field, the `auto` plan unchanged (rev_toray; "
    "the stacked row stays with its verdict; since session 19 both are two copies and the "
    "stacked row is within 2 % too, the refined row is kept as the resolved pair)."
)


#: Which FEM rows were solved again on the mesher of session 35, and what moved (session 37).
MESHER_NOTE = (
    "**FEM rows solved again on the current stuffing mesher (session 37, helper s37-agree, "
    "2026-12-05 16:31-17:06 UTC, load 0.8-6.6 on 2 cores shared with two other helpers and the "
    "lead (`uptime` at each row's start and end); one thread, `nice -n 19`, one row per "
    "command: `python benchmarks/solver_agreement.py specs --solvers fem --force --only S --bc "
    "B`).** Why: session 35 (a612f76, merged adc09bd "
    "2026-12-05 12:54 UTC) let the stuffing mesher's periodic face vertices move within their "
    "face, and every FEM row of this table was solved before it (2026-12-01..03). Which: every "
    "FEM row with a K, i.e. the periodic rows of three_rods, validation_cylinders and "
    "inverse_design and the stacked rows of every spec, with rev_toray's refined row; the specs "
    "sharing table3's RVE copy its new solve (`specs` without `--force` once their FEM cache "
    "files were removed). The voxel rows keep their solves (their code did not change); the "
    "periodic FEM rows of the random specs and the woven cell hold a refusal made before "
    "meshing, not a K, and were not solved again. What "
    "moved: nothing by more than 0.004 %, and no verdict by difference. The permeameter meshes "
    "have no periodic faces: the same tets, mesh volume and iterations on every stacked row, K "
    "within 5e-7 relative (round-off of the solver). Of the two periodic meshes, "
    "three_rods' changed (the same 87 532 tets, mesh volume error 3.51e-5 -> 3.58e-5; K "
    "1.8090e-10 -> 1.8089e-10, -0.003 %, FEM / voxel - 1 -0.98 % both times) and "
    "validation_cylinders' did not (K the same to 3e-12). One verdict changed for another "
    "reason: inverse_design periodic (FEM 2.1780e-11, +0.98 %, 'agree', solved 2026-12-01 15:08) "
    "predated the FEM's refusal of a non-periodic geometry (1264ae8, 18:03 that day) and had "
    "not been solved since: its random RVE's faces normal to x and y differ by 36 % and 55 % of "
    "L, the FEM now refuses it like the other random specs, and the row is n/a (rows with both "
    "K: 19 -> 18). The K cells read 'ok' where they read 'untrustworthy': the `seam` subcommand "
    "had re-rated the rows it touched with the voxel route's cells-per-diameter rule, where the "
    "product rates the FEM by its bar (fixed in session 37, `tests/unit/"
    "test_solver_agreement_seam.py`); K and bars are unchanged. The sections below quote the "
    "earlier solves, which equal the table's to the digits shown (three_rods' periodic K aside, "
    "above)."
)


#: Which rows were solved again after the sub-voxel fix, and why (session 17, agree17).
#: How the bars of rows solved before the seam term got it (session 20).
SEAM_NOTE = (
    "Every bar includes the seam term `1.9 g / L` (`psdesign.flow.error.seam_rel_error`, session "
    "19): the end planes along the flow differ by `g` where two copies meet or the periodic wrap "
    "joins the RVE to itself (tilted fibres repeat along z only every L / cos(theta)). Rows "
    "solved before it (before 2026-12-03 17:43 UTC stacked, 18:17 periodic) had it added on "
    "2026-12-03 by `python benchmarks/solver_agreement.py seam` from the rebuilt RVE's end "
    "planes (same fingerprint as the solve's; the bar is a sum of terms, so no solve was "
    "repeated; each such cache row keeps `rel_error_before_seam`): g / L 0.78 % on rev_toray "
    "(+1.48 points), 0.48-0.49 % on quickstart, porosity_sweep and fig17_beta_z (+0.85-0.92), "
    "0.19 % on table3 and the specs sharing its RVE (+0.37), 0.10 % on inverse_design (+0.19), 0 "
    "on the exactly periodic ones and on one copy. K and verdicts by difference are unchanged; "
    "the periodic-FEM refusals were re-worded by the product's check as it is now (its "
    "tolerance is 2 % of L; they quoted half a voxel)."
)


RESOLVED_NOTE = (
    "The voxel rows solved before 6fe9f8d (2026-12-01 21:05 UTC, 'voxel sub-voxel walls: release "
    "a cut cell with a single weighted face', a voxel-route change: the FEM rows are not "
    "touched) were solved again on 2026-12-03 by agree17 (one thread, `nice -n 19`; `python "
    "benchmarks/solver_agreement.py specs --only S --bc B --solvers voxel --force`): every "
    "periodic voxel row and the stacked voxel rows of fig15_bent, fig17_beta_z, "
    "fig18_exponential, rev_toray and table3/bent; the specs sharing table3's RVE reuse its "
    "new periodic solve. The other voxel rows (stacked, 2026-12-02 and 2026-12-03) were "
    "solved on trees that contain 6fe9f8d (git ancestry of their cache commits). The voxel K "
    "rose by 0.10-0.26 % on the random specs (0.01 % on three_rods, 0.00 % on "
    "validation_cylinders); one verdict changed: rev_toray stacked, -1.91 % -> **-2.08 %**, now "
    "inside the combined bar rather than within 2 %: the voxel route's discretisation at 8.4 "
    "voxels per diameter, +1.8 % above its limit on this RVE (session 18, agree18: section "
    "'rev_toray' below; refined, the 'permeameter-refined' row, -0.38 %), not its one copy. In "
    "session 18 the stacked voxel rows of rev_toray and fig17_beta_z (one copy, z end planes "
    "within one voxel) were solved again for the error bar's coarse solve, now pinned to the "
    "fine solve's copies (rev_toray's bar 16.6 -> 19.4 %, fig17_beta_z's unchanged; K "
    "unchanged). Its FEM row is current: solved again as a "
    "probe (`... probe studies/rev_toray.toml --solver fem --voxel 8.333333333333333e-07`, "
    "2026-12-03 11:13-11:15 UTC, load 4.3-4.6, 52 s CPU) it gives 5.9823e-12 again (same 166 697 "
    "tets, same bar 16.3 %)." + " " + SEAM_NOTE
)


def _spec_loads() -> str:
    loads = [
        x
        for f in CACHE.glob("*__z__*.json")
        for x in (json.loads(f.read_text()).get("load_1min"),)
        if x is not None
    ]
    return f"{min(loads):.1f}-{max(loads):.1f}" if loads else "?"


def render(_args=None) -> None:
    rows = [json.loads(s) for s in RUNS.read_text().splitlines() if s.strip()]
    arrays = _latest(
        [r for r in rows if r["part"] == "arrays"], lambda r: (r["case"], r["phi"], r["solver"])
    )
    text = [
        "# Solver agreement: FEM vs voxel on the same RVE and boundary condition",
        "",
        "Generated by `python benchmarks/solver_agreement.py render` from "
        "`benchmarks/solver_agreement_runs.jsonl` (`... arrays`) and the per-row cache "
        "`benchmarks/solver_agreement_cache/` (`... specs`, `... hexwindow`; a row with a cache "
        "file is not solved again). Do not edit by hand. Linked from `docs/validation.md`; "
        "tests: `tests/validation/test_solver_agreement.py`.",
        "",
        "Both routes solve the same voxelized analytic RVE: the FEM meshes its distance field "
        "(stuffing lattice mesher, mesh pore volume matched to the analytic pore volume), the "
        "voxel route uses it for sub-voxel walls. 'bar' is `permeability_rel_error` "
        "(docs/permeability.md); 'combined bar' is the sum of the two routes' bars.",
        "",
        "## Cylinder arrays at default settings (bc = periodic)",
        "",
        "Solved (UTC): " + "; ".join(solve_blocks(list(arrays.values()))) + ". Periodic rows, "
        "so the later permeameter changes do not touch them; the voxel rows were solved again "
        "after the sub-voxel fix 6fe9f8d (2026-12-01 21:05 UTC), which moved them (`python "
        "benchmarks/solver_agreement.py arrays --solvers voxel`, one thread, `nice -n 19`; "
        "the FEM rows were solved again in session 36 after the stuffing mesher's periodic "
        "face vertices became movable (s35): the hex 0.4 rows moved by +0.02 / +0.03 %, the rest "
        "by at most 0.001 %, "
        "`... arrays --solvers fem`; and again in session 39 for the tet route's two-term floor "
        "`max(0.2 (h / R)^2, 0.27 (h / D)^2)`, which moved only their bars, K to 1e-8). One "
        "cell of spacing 40 um as a thin periodic slab "
        "(4 voxels thick; both "
        "flows are two-dimensional), cylinders along z; 'along' = flow along z, 'across' = "
        "along x. Square: 40 voxels per spacing; hexagonal: 56 (cell 56 x 97 voxels). Default "
        "settings: FEM lattice step `max(2 voxel, min(min(size) / 30, D / 3))` = 2 voxels (the "
        "slab is 4 voxels thick), analytic volume "
        "target; voxel: sub-voxel walls. References: Sangani & Acrivos (1982) Int. J. "
        "Multiphase Flow 8, 193-206, Table 1 (square across); Sparrow & Loeffler (1959) AIChE "
        "J. 5, 325-330 collocation series (`tests/arrays.py`, along); Drummond & Tahir (1984) "
        "Int. J. Multiphase Flow 10, 515-540 (hexagonal across, dilute, phi <= 0.3).",
        "",
        *render_arrays(rows),
        "",
        "## Shipped specs (first case of each study)",
        "",
        "The FEM rows were solved again in session 39 for the tet route's two-term floor "
        "`max(0.2 (h / R)^2, 0.27 (h / D)^2)` (docs/permeability.md 'Tet floor'; `python "
        "benchmarks/solver_agreement.py specs --solvers fem --force`, one thread, `nice -n 5`): "
        "their K as before, their bars moved (e.g. table3's stacked row 3.05 -> 2.11 %).",
        "",
        "Through-plane (z) K of every spec in `studies/` (a study: its first case) with both "
        f"routes and both models (machine load average {_spec_loads()} on 2 cores during the "
        "runs). Size: a porosity target is generated in the smallest of 50, 60, 80 um cubes "
        "that reaches it, else at the spec's own size (the failures are listed); a fixed fiber "
        "count, explicit fibers or a woven cell keep their own box (in a smaller one they are "
        "another material). Voxel: the thinnest fiber gets at least 8 voxels (a coarser spec "
        "voxel is refined to d / 8; one giving more than 10 is coarsened to d / 8 for machine "
        "time; rounded down to divide the box). The FEM uses the spec's `flow.lattice_step` "
        "where it sets one, else its default. Periodic FEM needs a periodic geometry: since "
        "the stuffing fix 1264ae8 (engineer wovstack: matching faces by construction) the FEM "
        "refuses a geometry whose opposite faces differ, with the measured gap "
        "(`psdesign.flow.stack.end_planes`), before meshing. The random generators do not "
        "build periodic RVEs, so their periodic rows have the voxel K only: the voxel route "
        "solves the wrapped grid as it is (the seams are part of that material; "
        "`face_mismatch` in its JSON), which is no FEM-comparable number. "
        "Rows with 'same RVE and [flow] as' reuse the solve of a spec whose built RVE and "
        "`[flow]` hash equal (`_fingerprint`). " + PERMEAMETER_NOTE,
        "",
        MESHER_NOTE,
        "",
        *render_specs(),
        "",
        "Studies whose first case is the same straight Toray-like generator and seed (table3, "
        "bent_vs_straight, table3/straight, fig13_straight at 50 um) build the same RVE: their "
        "porosity and K are equal, as they should be.",
        "",
        "## Residual misses",
        "",
        "**Hexagonal array across, phi 0.1, voxel permeameter two cells long** (fixed: "
        "-1.00 % / -1.04 % vs periodic at 26 / 40 voxels per spacing with the former sin^2 "
        "window; issue 12 asks 1 %). The same grid's periodic K is the reference, so the voxel "
        "discretization cancels. With the flat-top window of whole periods "
        "(`docs/permeability.md`, `psdesign.flow.darcy.window_shape`):",
        "",
        *render_hexwindow(),
        "",
        "The sin^2 window's gap did not move with resolution and fell with the cell count as "
        "m^-3: the entrance disturbance reaching into the window's ends, where its weight grows "
        "as t^2. The flat-top window is zero within 3/16 of the sample at each face and exact "
        "in the periodic interior (a box of whole periods convolved with a bump), so two cells "
        "now give -0.32 % and three or more within 0.04 %. ",
        "Reproduce: `python benchmarks/solver_agreement.py hexwindow --force`.",
        "",
        *_spec_misses(),
    ]
    DOC.write_text("\n".join(text))
    print(f"wrote {DOC}")


def _spec_misses() -> list[str]:
    """The page's sections on the RVEs and spec rows that missed 2 % at some point."""
    return [
        WOVEN_AND_RANDOM,
        "",
        WOVEN_STACK,
        "",
        THREE_RODS,
        "",
        *render_probes("studies/examples/three_rods.toml"),
        "",
        THREE_RODS_FINDINGS,
        "",
        QUICKSTART,
        "",
        FIG15,
        "",
        REV_TORAY_SEAM19,
        "",
        REV_TORAY,
        "",
        *render_refinement("studies/rev_toray.toml"),
        "",
        REV_TORAY_FINDINGS,
        "",
        PYTETWILD_100,
        "",
    ]


#: three_rods, the stacked row above 2 % (session 4 measured it with the sin^2 window; session 7,
#: 2026-12-02, re-measured it and found the cause: the sample length, not a grid).
THREE_RODS = (
    "**three_rods, stacked permeameter: FEM / voxel - 1 = -1.11 % with the `auto` plan of "
    "session 8, 4 copies on both routes** (K FEM 1.6199e-10, bar 1.0 %; voxel 1.6382e-10, bar "
    "3.7 %): both solved 2, 3 and 4 copies, window terms FEM 10.0 / 1.9 / 0.4 %, voxel 5.5 / "
    "1.2 / 0.3 % (`permeameter_auto` of the rows; `python benchmarks/solver_agreement.py specs "
    "--only three_rods --bc permeameter-stacked --solvers S --force`, 2026-12-02 06:17-06:34 "
    "UTC, load 4.4-8.3, one thread, `nice -n 5`; FEM 212 s CPU, 2.46 GiB max RSS, 16:21 wall; "
    "voxel 10.1 s CPU, 1:06 wall; the explicit 4-copy probes below, bar included: FEM 132 s, "
    "voxel 5.7 s). Before (2 copies): **-3.74 %** (K FEM 1.5182e-10, voxel 1.5771e-10; inside "
    "the combined bar, 20.7 %); 3 copies: -0.45 % (FEM 1.6492e-10, voxel 1.6566e-10). The "
    "-2.44 % recorded "
    "before (FEM 1.5794e-10, voxel 1.6189e-10) was solved with the sin^2 window: the commits of "
    "both cache files predate the flat-top window (abb0702), as did those of every stacked row of "
    "2026-12-01 but the woven spec's; they were solved again on 2026-12-02 (rows now record "
    "`permeameter_window`). Measured (session 7, 2026-12-02 03:52-05:10 UTC, load 4-11 on 2 cores "
    "shared with other jobs, one thread, `nice -n 5`; `python benchmarks/solver_agreement.py probe "
    "studies/examples/three_rods.toml --solver S --voxel V [--copies N] [--lattice-step H] [--bc "
    "periodic | mirrored]`, one cache file each, `probe__*.json`; 'vs mirrored' is against the "
    "same route on the same grid; CPU and peak RSS of the whole process, error-bar solve "
    "included):"
)

#: After the probe table.
THREE_RODS_FINDINGS = (
    "**Neither grid is the cause.** The voxel route moves -0.6 % from 2 to 1 um at 2 and at 3 "
    "copies alike (1.5771 -> 1.5678e-10, 1.6566 -> 1.6471e-10) and -0.17 % more to 0.5 um (2 "
    "copies 1.5651e-10, 131 iterations, 3.3 GB; 3 copies 1.6443e-10, 4.6 GB; mirrored limit "
    "1.6294e-10, 116 iterations, 5.0 GB: the FEM's 4-copy K on the 1 um field is -0.57 % from it, "
    "its 3-copy K +0.30 % from the voxel route's 3 copies at 0.5 um); the FEM's K at 2 copies is "
    "the same on the 2 um field at its 4 um step and on the spec's 1 um field at 3.33 um "
    "(1.5182e-10 / 1.5180e-10, and 1.5189e-10 at a 2.86 um step: 506 818 tets, 214 s CPU, 3.0 GB; "
    "3 copies 1.6492e-10 / 1.6493e-10), and so is its periodic K (1.8090e-10 / 1.8104e-10, -0.33 % "
    "against the voxel route's 1.8164e-10 at 1 um). So the table's resolution rule stays. **The "
    "sample length is.** From 2 to 3 copies the voxel K moves +5.1 % and the FEM's +8.7 %, and at "
    "3 copies the routes agree (1 um: FEM 1.6493e-10, voxel 1.6471e-10, +0.13 %; the table's grid: "
    "-0.45 %). The independent limit is the periodic K of the RVE mirrored across its side faces "
    "(`psdesign.flow.stack.mirror_sides`: a slip wall is a mirror plane, so that grid is the "
    "endless slip-sided column): 1.6322e-10 at 1 um, 1.6417e-10 at 2 um. The voxel stack converges "
    "to it, not monotonically: -3.94 %, +0.91 %, -0.21 %, +0.03 % with 2, 3, 4, 6 copies at 1 um "
    "(the same at 2 um; slow test `test_three_rods_stack_converges_to_the_slip_column`); the FEM "
    "from further below and with a larger swing: -7.0 % at 2 copies and +1.05 % at 3 (1 um field) "
    "against the voxel route's 1 um limit, -0.74 % at 4 (1 um field: 1.6201e-10, 643 002 tets, 268 "
    "s CPU, 3.9 GB, window term 0.4 %; 2 um field at 4 um: 1.6199e-10). FEM / voxel - 1 with 2, 3, "
    "4 copies: -3.18 %, +0.13 %, -0.53 % on the 1 um grid and field, -3.74 %, -0.45 %, -1.12 % on "
    "the table's 2 um grid. The FEM reaches the same limit: its periodic K on the mirrored grid "
    "is 1.6256e-10 (2 um field, 4 um step, 351 010 tets) and 1.6258e-10 (1 um field, 3.33 um, "
    "622 260 tets, 123 s CPU, 2.8 GB), -0.98 % and -0.39 % from the voxel route's on the same "
    "grids (it first failed with 'periodic: 68 edges of face x1 have no partner edge on face x0': "
    "scikit-fem's int32 edge numbers wrapped in the edge key above 46 341 vertices, so every "
    "periodic FEM mesh that large failed; fixed in `solvers/fem/periodic.py`). The cause is the "
    "entrance disturbance: with 2 copies the flat-top window is zero only within 37.5 um (3/16 of "
    "the 200 um sample) of each face, and in this open structure (porosity 0.91, 20 um rods in a "
    "100 um cube, flow length scale `R = sqrt(8 K / eps)` = 38 um; the slip sides make the lateral "
    "period 200 um, whose disturbance decays as exp(-pi s / 100 um) in free fluid) it still "
    "reaches into the window. Each route's reservoirs shape it differently (FEM: prescribed "
    "pressures at the ends of 20 um reservoirs; voxel: the reservoirs joined across the periodic "
    "face of its grid, 40 um of free fluid from exit to entrance), so the two windowed K differ at "
    "2 copies and agree once it has decayed. The product flags it: the window term (2.5 x the gap "
    "between the windowed dissipation and the windowed plane pressure) is 5.5, 1.2, 0.3, 0.1 % "
    "(voxel; 2, 3, 4, 6 copies), each above the voxel stack's miss against its own limit, and "
    "10.0, 1.9, 0.4 % (FEM; 2, 3, 4 copies) against misses of 7.0, 1.05, 0.74 % from the voxel "
    "route's limit (at 4 copies the FEM's whole bar, 1.8 %, covers it); the result warns "
    "'entrance/exit residual ... lengthen it along the flow'. So no defect in either solver or in "
    "the window's placement: `auto` stacks 2 copies, enough on the dense random RVEs (the windowed "
    "K moves <= 0.6 % from 2 to 3 copies there, `docs/permeability.md`) and not on this open one. "
    "Changed in session 8: `auto` adds copies while the window term is above `WINDOW_WARN` "
    "(1 %), up to 4, each longer stack checked against the memory budget before it is solved "
    "(`docs/permeability.md`, 'Longer samples where the window term asks for them'); three_rods "
    "takes 4 on both routes (row above)."
)

#: The stacked row that crossed 2 % when re-solved with the flat-top window (session 7).
QUICKSTART = (
    "**quickstart, stacked permeameter (2 copies): FEM / voxel - 1 = -1.70 %** since session 8 "
    "(K FEM 9.4890e-12, bar 3.7 % then, 4.6 % in the table with session 39's tet floor; voxel "
    "9.6535e-12, bar 6.4 % then, 7.4 % in the table with session 19's seam term): the spec's "
    "`flow.lattice_step` "
    "went from 3e-6 to 2.33e-6 (3 lattice cells per fiber diameter, the default rule's D / 3). "
    "At 3e-6 (2.0 cells per D; 58 856 tets, bar 5.5 %) it was **-2.01 %**. Not the sample length "
    "(window terms 0.4-0.7 % FEM, 0.75 % voxel: `auto` keeps 2 copies). The FEM at finer steps "
    "on the row's RVE (`python benchmarks/solver_agreement.py probe studies/quickstart.toml "
    "--solver fem --voxel 8.333333333333333e-07 --lattice-step H`, 2026-12-02 06:17-06:34 UTC, "
    "load 4.4-8.3, one thread; CPU of the whole process, error-bar solve included): 3 / 2.33 / 2 "
    "/ 1.67 um give -2.01 / -1.70 / -1.46 / -1.38 % (58 856 / 112 664 / 189 041 / 319 276 tets, "
    "23 / 37 / 56 / 99 s CPU, 0.78 / 1.00 / 1.33 / 2.09 GB peak RSS); a fit `K0 + c h^p` through "
    "the four puts the converged FEM at -1.09 % (p = 2) or -0.54 % (p = 1) from the voxel route "
    "at 0.833 um: about 1 point of the -2.01 % was the spec's coarse step, the rest is not the "
    "FEM's lattice (the voxel route's own bar is 6.4 %). The quickstart study's cost: "
    "`psdesign study run studies/quickstart.toml` (one thread, `nice -n 5`, with the `auto` "
    "lengthening: its porosity-0.90 case now takes 3 copies) 62 s user at 3 um (load 4.4-5.9), "
    "101 s user at 2.33 um (load 5.6-6.3); 44-52 s before the lengthening (`benchmarks/"
    "RESULTS.md`). **The rest is the voxel route's grid** (session 18, agree18, as on rev_toray "
    "below): on the row's RVE and plan (2 copies) its K is 9.6535e-12 / 9.5833e-12 / "
    "9.5519e-12 at 0.833 / 0.625 / 0.5 um (`... probe studies/quickstart.toml --solver voxel "
    "--voxel V`, 2026-12-03 14:40-14:43 UTC, load 6.7-7.9, one thread, 15 / 27 s CPU): observed "
    "order 2.1, limit about 9.500e-12, so the row's voxel K is +1.6 % above its limit, the FEM "
    "at its 2.33 um step -0.12 % below it, and FEM 1.67 um / voxel 0.5 um is -0.33 %."
)

#: The second row above 2 % (session 4, 19:11-19:15 UTC, load 6-7); re-run at the fiber-relative
#: default step (session 7).
FIG15 = (
    "**fig15_bent, permeameter (one copy: not periodic along z): FEM / voxel - 1 = -1.40 %** "
    "at the fiber-relative default lattice step (K FEM 4.0258e-11, voxel 4.0831e-11; FEM bar "
    "3.7 %; the voxel K solved again after the sub-voxel fix 6fe9f8d, 2026-12-03 11:02 UTC, "
    "agree17; before it 4.0789e-11, -1.30 %; the figures below up to 'Every other' are "
    "against that earlier voxel K). The default step is now "
    "`max(2 voxel, min(min(size) / 30, D / 3))` "
    "(`psdesign.meshing.options.default_lattice_step`), 2.33 um here: 528 315 tets, 2.4 cells "
    "per D, 208 s user, 3.51 GiB max RSS, 11:06 wall at load 5.7-8.8 (2026-12-02 04:22-04:33 "
    "UTC; `python benchmarks/solver_agreement.py specs --only fig15_bent --bc "
    "permeameter-stacked --solvers fem --force` on the row's cached build). Before, the "
    "box-relative default `max(2 voxel, min(size) / 30)` was 3.33 um in this 100 um box (D = 7 "
    "um, 1.7 cells per D): K FEM 3.9729e-11, **-2.60 %** (bar 8.3 %), and 2.5 um gave "
    "4.0197e-11, -1.45 % (session 4, 431 231 tets, 138 s CPU, 2.9 GB). The same generator "
    "family in a 50 um box (table3, bent rows: 1.67 um step, 3.4 cells per D) agrees within "
    "0.6 %. The two other rows whose step the new rule changes (100 um, D = 7 um) were re-run "
    "the same way: fig17_beta_z -0.26 % (-0.36 % against the voxel K after 6fe9f8d; K FEM "
    "2.5319e-11, 524 563 tets, bar 6.5 %, status "
    "ok; at 3.33 um -0.18 %, bar 28.3 %, untrustworthy; 232 s user, 3.57 GiB, 04:55-05:05 UTC "
    "at load 5.9 -> 4.6) and fig18_exponential -1.17 % (-1.28 % after 6fe9f8d; K FEM "
    "3.9639e-11, 527 235 tets, bar "
    "8.2 %; at 3.33 um -1.29 %, bar 10.6 %; 200 s user, 3.19 GiB, 05:05-05:11 at load 4.5 "
    "-> 3.2). Every other FEM row's step is unchanged by the new rule (50 um cubes, or D / 3 "
    "above min(size) / 30)."
)

#: Session 19 (seam19): the end-plane tolerance is 2 % of L, so rev_toray stacks on every grid.
REV_TORAY_SEAM19 = (
    "**rev_toray since session 19 (seam19): two copies, FEM / voxel - 1 = -1.67 % at the "
    "table's resolution, -0.15 % refined.** The stack's end-plane test allowed half a voxel of "
    "the grid until session 19, so `auto` stacked this RVE (z end planes 0.46 um apart near the"
    " fibre surfaces, 0.77 % of L) at 1 um and not at 0.9 um and finer, and its K jumped by 10 "
    "% with `rve.voxel`; the tolerance is now 2 % of the RVE's length along the flow "
    "(`psdesign.flow.stack.SEAM_TOL_LENGTH`, `docs/permeability.md` 'How periodic is periodic "
    "enough'), and the plan is two copies at every grid. The rows were solved again "
    "(2026-12-03, one thread, `nice -n 19`; `python benchmarks/solver_agreement.py specs "
    "--force --only studies/rev_toray.toml --bc B --solvers S`): stacked voxel 5.5040e-12 (bar "
    "6.7 %; 17:09-17:10 UTC, load 6.9-6.4), stacked FEM 5.4121e-12 (311 572 tets, bar 3.9 %; "
    "17:16-17:23, load 6.3-7.7, 169 s CPU, 2.3 GB), refined voxel (0.5 um) 5.4384e-12 (bar 2.2 "
    "%; 17:10-17:13, load 6.4-5.8), refined FEM (1.67 um step on the 0.833 um field, see "
    "`REFINED`) 5.4304e-12 (524 329 tets, bar 2.8 %; 17:23-17:37, load 7.6-6.5, 348 s CPU, 3.9 "
    "GB). The voxel and stacked FEM values are agree18's with the stack forced across the seam "
    "(`--seam-tol 1`, the probe table below). The sections below are session 18's one-copy "
    "analysis (the resolution pattern is the same on both samples); the one-copy rows and "
    "probes stay in the probe table. fig17_beta_z (z end planes 0.45 um apart, 0.45 % of L, one"
    " copy at the table's 0.833 um and two at 0.9 um under the old rule) now stacks too: its "
    "voxel row would be 3.7266e-11 (two copies, bar 4.3 %; 2026-12-03 17:13-17:16 UTC, load "
    "5.8-6.3, 60 s CPU) against 2.5410e-11 for one copy (+47 %: its fibres are denser at "
    "mid-height, where the one-copy window weighs most; its periodic voxel K is 3.3253e-11). "
    "Both of its stacked rows were solved again at two copies by the lead (2026-12-03 18:51-18:58 "
    "UTC, idle, load 0.5-1.1, two threads; `python benchmarks/solver_agreement.py specs --force "
    "--only fig17_beta_z --bc permeameter-stacked --solvers voxel fem`): voxel 3.7266e-11 (bar "
    "5.1 %, the seam term included), FEM 3.7164e-11 (749 046 tets, bar 2.6 %, 393 s, 5.45 GB "
    "peak): FEM / voxel - 1 = -0.27 %."
)

#: rev_toray, the row that crossed 2 % with the sub-voxel fix (session 17); measured in session 18
#: (agree18): the voxel route's discretisation at 8.4 voxels per diameter.
REV_TORAY = (
    "**rev_toray in session 18, permeameter (one copy: not periodic along z at 0.833 um by the "
    "half-voxel rule of then): FEM / voxel - 1 = "
    "-2.08 % at the table's resolution, -0.38 % refined** (row 'permeameter-refined' of then: the "
    "same build, voxel route at 0.5 um, FEM at a 60 / 42 um step on the row's 0.833 um field; "
    "`python benchmarks/solver_agreement.py specs --only studies/rev_toray.toml --bc "
    "permeameter-refined`, 2026-12-03 14:16-14:31 UTC, load 7.4-7.8; FEM 217 s CPU, 3.2 GB). "
    "Measured 2026-12-03 13:44-14:26 UTC (agree18, one thread, `nice -n 19`, load 2.8-8.9 on 2 "
    "cores shared with two other helpers and the lead; the FEM at 2 um: agree17's probe of "
    "11:15; `python benchmarks/"
    "solver_agreement.py probe studies/rev_toray.toml --solver S --voxel V --copies N "
    "[--lattice-step H] [--aux-length A] [--seam-tol T]`, one cache file each; CPU and peak RSS "
    "of the whole process, error-bar solve included; the first voxel probe's CPU includes "
    "compiling the kernels into an empty numba cache):"
)

#: After the rev_toray probe table.
REV_TORAY_FINDINGS = (
    "**What the -2.08 % is: the voxel route's discretisation at 8.4 voxels per diameter, with"
    " the FEM's lattice and field errors nearly cancelling.** Voxel route (one copy, "
    "sub-voxel walls): 6.1094e-12 / 6.0580e-12 / 6.0354e-12 at 0.833 / 0.625 / 0.5 um (8.4 / "
    "11.2 / 14 voxels per diameter; -0.84 %, then -0.37 %): observed order 2.2 (sub-voxel "
    "walls: 2), limit about 5.9997e-12 (three-point fit; 5.993e-12 with p = 2 through the "
    "three), so the row's voxel K is +1.8 % above its limit and the 0.5 um K +0.6 %. FEM on "
    "the row's 0.833 um field: 5.9823e-12 / 6.0099e-12 / 6.0127e-12 / 6.0218e-12 at a 2 (the "
    "default, D / 3.5) / 1.67 / 1.43 / 1.25 um step (166 697 / 277 846 / 450 602 / 654 419 "
    "tets; +0.46, +0.05, +0.15 %: converged to about 0.2 %, not monotonely); on a 0.625 um "
    "field at 1.67 um 5.9896e-12, -0.34 % from the 0.833 um field at the same step (the field"
    " term of the FEM bar is 0 at 8.4 voxels per diameter, `docs/permeability.md` 'Field'). "
    "So against the voxel limit the FEM is -0.29 % at the row's 2 um step, +0.37 % at 1.25 um"
    " on the row's field and -0.17 % at 1.67 um on the 0.625 um field: the converged routes "
    "agree within about 0.4 %, and the -2.08 % is the voxel route's +1.8 % plus the FEM's "
    "-0.66 % lattice error less its +0.34 % field error. Both bars cover their route's error "
    "(voxel: discretisation term 6.7 % against +1.8 %; FEM: 3.3 % against -0.66 %); the "
    "window terms (12.6 / 13.0 %: the windowed dissipation and the windowed plane pressure of"
    " this one-copy, non-periodic sample are 5 % apart in both routes alike) are the one-copy"
    " definition's spread, not a difference between the routes (next paragraph). Refined "
    "pairs: FEM 1.43 um / voxel 0.5 um -0.38 % (the 'permeameter-refined' row), FEM 1.25 um /"
    " voxel 0.5 um -0.23 %, FEM 1.67 um / voxel 0.5 um -0.42 % (slow test "
    "`test_rev_toray_one_copy_fem_and_voxel_agree_resolved`)."
    "\n\n"
    "**Not the reservoirs, not the copies, not the geometry.** Reservoirs 2.5 times longer "
    "(`aux_length` 0.5 instead of 0.2): voxel 6.1083e-12 (-0.02 %), FEM (2 um step) "
    "5.9857e-12 (+0.06 %): the one-copy entrance is the same in both routes. **Copies**: the "
    "RVE's z end planes differ by 0.46 um near the fibre surfaces "
    "(`psdesign.flow.stack.end_planes`; 0.553 voxel at 0.833 um, 0.48 at the spec's 1 um, "
    "0.70 at 0.625, 0.83 at 0.5 um; the largest on the fibre tilted by 6.0 deg; likely "
    "because a PS fibre's copies repeat one period apart perpendicular to its axis, so a "
    "tilted fibre repeats along z every L / cos(theta), 0.33 um more than L here; not "
    "examined further), against the product's half a voxel: at the table's 0.833 um `auto` "
    "solves one copy, at the spec's own 1 um it would stack two. Stacked two copies anyway (a"
    " diagnostic: `--seam-tol 1` lets the stack join across that seam, the product refuses "
    "it), the K is another definition of this sample, 10 % lower: voxel 5.5040e-12 (0.833 um)"
    " / 5.4384e-12 (0.5 um), FEM (2 um step, 311 572 tets) 5.4121e-12: FEM / voxel - 1 = "
    "-1.67 % against the voxel route at 0.833 um and -0.48 % against it at 0.5 um, the same "
    "pattern as one copy (-2.08 / -0.88 %). The row keeps the product's plan (one copy). "
    "**Geometry**: porosity of the analytic RVE 0.80052 (10.1 M points, one per cell of a "
    "jittered 216^3 grid, `RVE.union_field`), of the FEM's volume target (the sub-voxel pore "
    "volume of the 0.833 um field) 0.80047, of the meshes 0.80046 / 0.80039 / 0.80017 / "
    "0.80026 at 2 / 1.67 / 1.43 / 1.25 um (mesh volume within 2e-4 of the target), of the "
    "voxel grids (cell count; the voxel route's sub-voxel walls use the distance) 0.80021 / "
    "0.80055 / 0.80057 at 0.833 / 0.625 / 0.5 um: within 0.0004, about 0.5 % in K "
    "(Kozeny-Carman, `d ln K / d porosity = 3 / eps + 2 / (1 - eps)` = 13.7)."
    "\n\n"
    '**A bar defect found on the way (fixed):** with `permeameter_copies = "auto"` and no '
    "lengthening, the error bar's coarse solve re-planned the stack on its own grid, and the "
    "end-plane test is in voxels of that grid: the voxel row's coarse solve (1.67 um, where "
    "the 0.46 um seam is 0.32 voxel) stacked two copies under a one-copy fine solve, so its "
    "discretisation term compared two samples (the row's bar 16.6 %; with both solves one "
    "copy 19.4 %). `psdesign.flow.permeability.auto_lengthen` now pins the final solve's "
    "copies for the second resolution, as it already did after lengthening "
    "(`tests/unit/test_auto_copies.py`). The one-copy voxel rows whose end planes are within "
    "one voxel were solved again (K unchanged): rev_toray stacked voxel 16.6 -> 19.4 %, "
    "fig17_beta_z stacked voxel (z end planes 0.539 voxel apart) 9.32 % again, its coarse "
    "grid also plans one copy; the FEM's coarse solve is a coarser lattice on the same field,"
    " whose plan does not change."
)

#: The pytetwild check at the Table III size (docs/meshers.md, benchmarks/RESULTS.md).
PYTETWILD_100 = (
    "**pytetwild at 100 um** (issue 12 item 5; `docs/meshers.md`): on the Table III straight "
    "RVE (seeds 1, 2; one-copy permeameter, z) the FEM K on the pytetwild mesh is -3.80 % and "
    "-3.34 % of the stuffing mesh's (goal 2 %: missed; -1.40 +- 0.34 % at 60 um). Refining "
    "the stuffing mesh (3.33 -> 2.5 um) moves its K by -1.23 %, so the gap is both meshes' "
    "box-relative default resolution, pytetwild's the larger share (-2.61 % against the finer "
    "stuffing mesh). Since session 7 both defaults are fiber-relative (pytetwild's edge 0.85 D, "
    "the stuffing step D / 3): default pytetwild / default stuffing - 1 is -2.04 / -1.80 / "
    "-1.55 / -1.56 / -1.49 % on seeds 1-5 (4 of 5 within 2 %)."
)

#: Engineer fieldres (session 6): the FEM samples its own field (psdesign/flow/fem_field.py).
FEM_FIELD = (
    "**Since the FEM samples its own field** (`psdesign/flow/fem_field.py`, "
    "`docs/permeability.md` 'FEM geometry': the analytic geometry at `rve.voxel / r` with at "
    "least 8 voxels across the thinnest fiber) those woven figures were a cancellation: the 1 "
    "um field's volume target under-counted the yarns (mesh solid fraction 0.1076 against "
    "0.1103 on the 0.5 um field, Monte Carlo 0.1104), K +5.9 % (1.5674e-12 on main at "
    "7a43228), while the 2 um lattice is unresolved (-4.3 % on the 0.5 um field against the "
    "voxel route's 1.5474e-12). A 1 um spec grid now meshes the 0.5 um field: periodic K "
    "1.4802e-12 at 2 um on both the 1 and the 0.5 um grid (0.25 um grid: 1.4725e-12, "
    "-0.52 %), error bar 15.0 % (two-grid, covers the -4.3 %; these 2 um figures measured "
    "before 0d49c9d, not re-run). The slow test therefore runs "
    "the woven cell at a 1.5 um step: FEM 1.5490e-12 vs "
    "voxel 1.5474e-12 through-plane (**+0.10 %**), 4.0535e-11 vs 4.0469e-11 in x (**+0.16 "
    "%**; the voxel figures of main at 7a43228, the earlier 1.5593e-12 / 4.0412e-11 give "
    "-0.66 % / +0.30 %), FEM 180 593 tets, 1.0-1.1 GB peak RSS, 80 / 95 s wall at load "
    "6.3-6.7 (2026-12-06 05:37-05:40 UTC, helper s42-paper, one thread, `nice -n 19`; "
    "`python benchmarks/fem_field.py woven --voxel 1e-6 --step 1.5e-6 --direction z "
    "--no-error-estimate`, and `--direction x`). They moved with 0d49c9d (the woven fibres' "
    "nominal diameter is now measured across the bent centre line, 4.26 -> 4.79 um on this "
    "cell, and the stuffing pore-volume target reads the distance rescaled by it): before, "
    "FEM 1.5480e-12 (+0.04 %) and 4.0533e-11 (+0.16 %), 181 823 tets (2026-12-01 "
    "23:37-23:55, load 3-4). The same-field stack (slow test, which hands the FEM a mesh of "
    "the 1 um field): FEM 1.6802e-12, voxel 1.7089e-12, **-1.68 %** (helper s42-fixes, "
    "2026-12-06 05:28-05:32 UTC, load 3.3-5.0, `nice -n 5`; FEM 1.6983e-12, -0.62 %, before "
    "0d49c9d). The rows of the specs table are unchanged by it: the table gives "
    "every FEM field 8-10 voxels per diameter, so the FEM meshes them as before (refinement "
    "1, the same mesh bit for bit); in particular fig15_bent (8.4 voxels per D) kept -2.60 % "
    "and three_rods (10) -2.44 % (since re-solved with the flat-top window: -3.74 %), whose "
    "causes (the lattice step and the permeameter's sample length, below) are not the field."
)

#: The slow tests' measurements (``tests/validation/test_solver_agreement.py``).
WOVEN_AND_RANDOM = (
    "**Periodic random RVEs and the woven cell** (slow tests, `python -m pytest -m slow -s "
    "tests/validation/test_solver_agreement.py -k random_periodic`; FEM on the 1 um field at "
    "its default step of 2 um, voxel route at 0.5 um). Seed 1, solved again after the "
    "sub-voxel fix 6fe9f8d (2026-12-03 10:51-11:01 UTC, agree17: `_random_pair` of the test "
    "module, one thread, `nice -n 19`, load 5.4-7.0 on 2 cores): through-plane straight "
    "**-1.23 %** (K FEM 6.5895e-12, voxel 6.6718e-12), bent **-1.30 %** (7.6627e-12, "
    "7.7635e-12); in x straight **-0.49 %** (1.8071e-11, 1.8161e-11), bent **-0.58 %** "
    "(1.8423e-11, 1.8531e-11). Before the fix (load 11, 2026-12-01 15:01) through-plane "
    "-1.13 % / -1.31 %, in x -0.46 % (K FEM 1.8069e-11, voxel 1.8153e-11) / -0.67 % "
    "(1.8403e-11, 1.8526e-11): the voxel K rose 0.05-0.15 % with the fix, the FEM K moved "
    "0.01-0.11 % with the FEM's own-field change (`psdesign/flow/fem_field.py`). Woven cell "
    "(period 30 um, yarns of nominal diameter 4.3 um then, 8.6 voxels at 0.5 um; 4.8 um, 9.6 "
    "voxels, since 0d49c9d; 4.2 um thick, 8.4 voxels through it, the count the status rule "
    "reads since session 43, `docs/geometry.md`; its FEM field is refined 2x and its default "
    "step is 2 um either way): +1.30 % through-plane (K FEM 1.5796e-12, voxel "
    "1.5593e-12), "
    "+1.83 % in x (4.1151e-11, 4.0412e-11), load 11-21, 15:01-15:14 (both xpassed: the xfail "
    "is removed, the test stays slow, 712 s for the two). The earlier -2.94 % had the voxel "
    "route on the 1 um grid (4.3 voxels across a yarn). The in-plane +1.83 % is near the 2 % "
    "bound; the FEM there has about 2 lattice steps across a yarn. " + FEM_FIELD
)


#: Engineer woven3's woven stacked permeameter (session 5); engineer wovstack's measurements of
#: the periodic woven cell stacked (with woven3's lattice and field checks) and of periodic FEM.
WOVEN_STACK = (
    "**Woven, stacked permeameter (issue 12 item 1, engineer woven3): FEM / voxel - 1 = "
    "+1.79 %** on the shipped woven spec (`studies/table3/woven.toml`: the Eq. (19) cell at "
    "period 100 um, yarns 14 um thick, 3 layers, 100 um cube), through the thickness, two "
    "copies (6 layers), slip sides, both routes on the spec's 1 um field, the FEM at its "
    "default step of 3.33 um (4.2 steps across a yarn's thickness; 254 880 tets, 2.1 GB, 194 s "
    "wall, before 0d49c9d): K FEM 5.9802e-12, voxel 5.8750e-12 (136 iterations; slow test "
    "`test_woven_stack_fem_and_voxel_agree`, helper s42-fixes, 2026-12-06 05:28-05:32 UTC, load "
    "3.3-5.0, `nice -n 5`). Before 0d49c9d (2026-12-06: the woven fibres' nominal diameter, "
    "now measured across the bent centre line, 14.2 -> 16.0 um, and their field scale 11.91 -> "
    "11.29; the stuffing pore-volume target reads the distance rescaled by it) the FEM gave "
    "5.9745e-12, +1.69 %; the voxel K is unchanged (to 3e-9 on the periodic cell, s42-fixes). "
    "Both routes are resolved (measured on one copy, whose K equals the two "
    "copies' to 0.05 %): the FEM moves -0.28 % from a 3.33 to a 2.5 um step (5.9773e-12 -> "
    "5.9605e-12; 329 582 tets, 2.3 GB peak RSS; 2026-12-06 05:43-05:47 UTC, load 5.9-8.1) and "
    "-0.48 % from the 1 um to a 0.5 um field at 3.33 um (5.9773e-12 -> 5.9489e-12, 138 204 "
    "tets, 1.1 GB peak RSS, its coarse solve at 6.67 um 5.6449e-12: bar 5.2 %; 05:40-05:43 "
    "UTC, load 6.6-8.1; both one thread, `nice -n 19`, `python "
    "benchmarks/solver_agreement.py probe "
    "studies/table3/woven.toml --solver fem --voxel V --copies 1 [--lattice-step H] --force`; "
    "before 0d49c9d -0.13 %, 5.9718e-12 -> 5.9641e-12, 329 578 tets, 2.3 GB, and -0.32 %, "
    "5.9525e-12); the voxel route gives 6.0101e-12 / 5.8750e-12 / "
    "5.8532e-12 at 2 / 1 / 0.5 um (115 / 132 / 172 iterations; observed order 2.6, limit about "
    "5.849e-12; 0.5 um: 1.28 GB peak RSS with its error-bar solve). So the converged pair is "
    "+1.6 % apart (FEM on the 0.5 um field vs voxel at 0.5 um: +1.63 %; +1.70 % before "
    "0d49c9d). The product's FEM bar (a 6.67 um step on the same field) is 4.95 %, "
    "conservative here. (Session 43, the resolution measure now the yarns' 13.99 um thickness "
    "instead of their 16.0 um diameter: one copy, the same mesh, K 5.9773e-12 and bar 4.95 % "
    "to the last digit; cells per diameter 3.97 -> 3.48 and the fibre floor 1.17 -> 1.53 %, "
    "under the two-grid term 4.82 %; the default step stays the box's 3.33 um, D / 3 being "
    "4.66 um; `/tmp` script of helper s43-thin, `benchmarks/RESULTS.md` session 43.) "
    "One copy (the `auto` plan, the sample holding 3 layer periods; the "
    "table's row): FEM 5.9773e-12, voxel 5.8750e-12, +1.74 % (2026-12-06 05:35-05:37 UTC, "
    "load 4.5-6.3, one thread, `nice -n 19`, `python benchmarks/solver_agreement.py specs "
    "--solvers fem --force --only studies/table3/woven.toml --bc permeameter-stacked`, 89 s "
    "wall; before 0d49c9d 5.9718e-12, +1.65 %). Earlier FEM figures (woven3): load 4-6, "
    "2026-12-01 20:41-21:08. Voxel figures re-measured 2026-12-03 08:04-08:16 UTC on "
    "main 8ab1e27 (slow16: one thread, `nice -n 19`, load 3.5-5.0 on 2 cores shared with other "
    "jobs; `python benchmarks/solver_agreement.py probe studies/table3/woven.toml --solver "
    "voxel --voxel V --copies N --force`, V = 2e-6, 1e-6, 5e-7 with N = 1 and 1e-6 with N = 2, "
    "cache files `probe__table3-woven__voxel__*`; two copies: `python -m pytest -m slow -s "
    "tests/validation/test_solver_agreement.py -k woven_stack`). Recorded before (2026-12-01, "
    "woven3): 5.9975e-12 / 5.8664e-12 / 5.8481e-12 (0.5 um: 182 iterations, 2.0 GB), two copies "
    "5.8661e-12 (+1.85 %), one copy +1.80 %. The voxel K moved +0.21 / +0.15 / +0.09 % at "
    "2 / 1 / 0.5 um through 6fe9f8d (sub-voxel walls release a cut cell with a single weighted "
    "face, a discretisation fix merged with vmem3 after woven3 measured; bisected on this "
    "spec's periodic voxel row, 5.7142e-12 at fd109ab and 422b433, 5.7213e-12 from 6fe9f8d "
    "on; the one-copy 1 um row was 5.8664e-12 at fd109ab; the 2 and 0.5 um probes were not "
    "re-run there), not through the solver changes of sessions 10-15: the periodic row is "
    "5.72129329e-12 "
    "at 7e62e42 (session 9) and at 8ab1e27 (and at tol 1e-8), the one-copy row 5.8749673e-12 "
    "at 29c81bf (2026-12-02) and at 8ab1e27 (1.3e-8 apart). Iterations moved: periodic row "
    "113 (fd109ab) -> 93, one copy 125 (fd109ab) / 117 (29c81bf) -> 132, 0.5 um 182 -> 172. "
    "The one-copy count rose at aa21e6c (session 11: 109 -> 132, bisected; 117 at 29c81bf, "
    "109 at f322b9b): its coarse-term weight `solvers.voxel.schur.WEIGHT` 0.6 (tuned on the "
    "Toray-like RVEs) costs this stack 132 iterations against 113 with 1.0 (periodic row 93 "
    "against 86; measured on main by setting the weight, K the same to 5e-9), while the "
    "first-cycle floor `INNER_RTOL_FLOOR` 1e-5 of the same commit does not (133 with 1e-4).\n\n"
    "**The periodic woven cell stacked (period 30 um, 60 x 60 x 30 um, one layer: "
    "`periodic_spec('woven')`, engineer wovstack): within 1 % only at the finest FEM step the "
    "6 GB cap allows, not converged, so not asserted.** Its yarns are 4.2 um thick (nominal "
    "diameter 4.3 um before 0d49c9d, 4.8 um since). FEM on "
    "the 1 um field (2 um step) 1.6982e-12 vs voxel at 0.5 um 1.5597e-12: +8.9 %. FEM on "
    "the 0.5 um field (woven3): 1.5015e-12 at a 2 um step (-3.7 %), 1.5876e-12 at 1.5 um (+1.79 %; "
    "379 716 tets, 2.4 GB), 1.5745e-12 at 1.25 um (**+0.95 %**; 666 950 tets, 4.4 GB peak, "
    "620 s wall at load 5): +5.7 % then -0.83 %, not yet monotone; the periodic FEM on that "
    "field: 1.4802e-12 at 2 um, 1.5480e-12 at 1.5 um (-0.72 % against the voxel route's "
    "periodic 1.5593e-12; 181 823 tets, 1.2 GB). A 1 um step needs about 1.3 M tets stacked "
    "(budget estimate 19.7 GB, refused; about 8.5 GB at the measured 6.6 kB per tet, "
    "over the 6 GB cap). The field is a second error source here that the FEM bar (a coarser "
    "lattice on the same field) does not see: at the same 2 um step the periodic FEM gives "
    "1.5796e-12 on the 1 um field and 1.4802e-12 on the 0.5 um field (-6.3 %), because the "
    "mesh's volume target (`psdesign/meshing/pore_volume.py`, a smoothed step two voxels wide) "
    "puts the solid fraction at 0.1075 on the 1 um field against 0.1102 on the 0.5 and "
    "0.25 um fields (-2.4 %; a one-voxel kernel gives 0.1103, but it is 0.6-1 % off on "
    "resolved rods of 3-5 voxels radius, so it is no default). So the periodic cell's +1.30 % "
    "through-plane (`test_random_periodic_fem_and_voxel_agree[woven-through]`, FEM on the 1 um "
    "field) is within 2 % by a cancellation of the field's and the lattice's errors: on the "
    "0.5 um field the same 2 um step gives -5.1 % against the voxel route's 1.5593e-12. On the "
    "stacked 1 um field the "
    "bar happens to cover: FEM at a 4 um step 1.8646e-12, bar 9.8 % against the +8.9 %. Not "
    "the stack: the two copies join without a seam (porosity profile of the FEM mesh in 2 um "
    "slabs identical in both copies and equal to the periodic mesh's; mesh pore volume -0.02 % "
    "of analytic), and not the drop: the windowed, plane-window and face drops agree to 1e-4 "
    "of the applied drop. The slip walls add to it in both routes: voxel slip / periodic K = "
    "+5.7 % at 1 um (1.7041e-12 / 1.6117e-12; staircase +5.9 %), +0.02 % at 0.5 um "
    "(1.5597e-12 / 1.5593e-12), FEM +7.5 % on the 1 um field; on the same 1 um field the two "
    "routes agree (-0.35 %, slow test `test_woven_stack_same_field_agrees`). The cell is not "
    "mirror-symmetric about its faces (fiber surfaces 6-7 um apart under x -> -x), and a yarn "
    "cut at a grazing angle by x = 0 puts 9.3 % solid in the first 1 um at 0.5 um voxels, "
    "7.6 % at 1 um. Load 8-10, 2026-12-01 18:10-18:30 (wovstack) and 4-6, 20:33-21:09 "
    "(woven3); reproduce with `route_result` on `periodic_spec('woven', flow={'bc': "
    "'permeameter'})`. Voxel figures re-measured 2026-12-03 08:29-08:30 UTC (slow16, main "
    "8ab1e27, one thread, `nice -n 19`, load 3.8-4.7; `route_result` on `periodic_spec('woven')` "
    "with bc periodic and with the slip-sided permeameter, 2 copies): periodic 1.6161e-12 at "
    "1 um / 1.5474e-12 at 0.5 um (77 / 94 iterations), stacked 1.7089e-12 / 1.5630e-12 (107 / "
    "112 iterations): slip / periodic +5.7 % at 1 um, **+1.0 % at 0.5 um (was +0.02 %)**; "
    "against the stacked 0.5 um voxel K the FEM on the 0.5 um field is -3.9 / +1.57 / **+0.74 %** "
    "at 2 / 1.5 / 1.25 um, on the 1 um field +8.6 % (these FEM figures measured before "
    "0d49c9d). Re-measured after 0d49c9d (2026-12-06, helper s42-paper, one thread, `nice -n "
    "19`; `route_result` on `periodic_spec('woven', flow={'bc': 'permeameter', 'sides': "
    "'slip', 'lattice_step': H})` at the 1 um spec grid, whose FEM samples the 0.5 um field; "
    "script /tmp/s42paper/cell_stack.py): 1.5882e-12 at 1.5 um (**+1.61 %**; 379 696 tets, "
    "2.4 GB peak RSS, 216 s wall, 05:47-05:51 UTC, load 5.9-6.0), 1.5714e-12 at 1.25 um "
    "(**+0.54 %**; 666 748 tets, 4.3 GB peak RSS, 442 s wall, 05:51-05:58 UTC, load 5.4-6.3): "
    "-1.06 % from 1.5 to 1.25 um, still not monotone against the 2 um figure, so the verdict "
    "stands; on the 1 um field "
    "(the same-field slow test, 2 um step) 1.6802e-12, +7.5 %; the 2 um step on the 0.5 um "
    "field not re-run. The voxel K moved by the discretisation "
    "changes of 2026-12-01 (the 0.5 um periodic K was already 1.5474e-12 at 7a43228, after "
    "6fe9f8d), not by the solver changes since (the slow tests give the 7a43228 figures "
    "again).\n\n**Peri"
    "odic FEM on the random specs.** Their tilted fibers are not periodic in x and y (studies"
    "/table3/straight.toml at 50 um: fiber surfaces 12.7 um and 17.1 um apart between opposit"
    "e faces; voxel face_mismatch 24 % / 32 %), so FEM periodic now refuses them up front and"
    " says so (`psdesign.flow.stack.end_planes`); the old 'triangles differ' and '957 vs 958 "
    "vertices' errors were a mesher asymmetry (flat tets next to a face dropped on one face o"
    "f a pair only), now fixed by construction: a periodic bent RVE (seed 3) that failed that"
    " way meshes and agrees with the voxel route, **-1.57 %** through-plane (K FEM 6.6785e-12, "
    "voxel 6.7849e-12; 2026-12-03 10:51-10:55 UTC, agree17, one thread, load 5.4-5.9; before "
    "the sub-voxel fix 6fe9f8d: voxel 6.7755e-12, -1.43 %; the FEM K is the same to 5 digits). "
    "The table3 straight RVE solved wrapped as it is (before the refusal, and before 6fe9f8d) "
    "gave FEM 5.5350e-12 vs voxel (0.5 um) 5.4406e-12, +1.73 % (not solved again: the FEM now "
    "refuses that geometry)."
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("arrays")
    a.add_argument("--kind", nargs="+", default=["square", "hex"])
    a.add_argument("--phi", type=float, nargs="+", default=[0.1, 0.2, 0.3, 0.4, 0.5])
    a.add_argument("--solvers", nargs="+", default=list(SOLVERS))
    s = sub.add_parser("specs")
    s.add_argument(
        "--sizes",
        type=float,
        nargs="+",
        default=[50e-6, 60e-6, 80e-6],
        help="cube sizes (m) tried smallest first before the spec's own (porosity targets only)",
    )
    s.add_argument("--bc", nargs="+", default=list(SPEC_BCS), choices=SPEC_BCS)
    s.add_argument("--solvers", nargs="+", default=list(SOLVERS))
    s.add_argument("--force", action="store_true", help="solve rows that have a cache file")
    s.add_argument("--direction", default="z")
    s.add_argument("--only", nargs="+", default=None, help="substrings of the spec paths")
    v = sub.add_parser("probe")
    v.add_argument("spec", help="path of a shipped spec, e.g. studies/examples/three_rods.toml")
    v.add_argument("--solver", choices=SOLVERS, required=True)
    v.add_argument(
        "--bc",
        choices=[*BC_MODELS, "mirrored"],
        default="permeameter",
        help="mirrored: periodic K of the RVE mirrored across its side faces (mirror_sides)",
    )
    v.add_argument("--voxel", type=float, required=True, help="voxel size (m)")
    v.add_argument("--copies", type=int, default=None, help="permeameter copies (default auto)")
    v.add_argument("--lattice-step", type=float, default=None, help="FEM lattice step (m)")
    v.add_argument(
        "--aux-length",
        type=float,
        default=None,
        help="reservoir length / RVE length (default: the spec's)",
    )
    v.add_argument(
        "--seam-tol",
        type=float,
        default=None,
        help="diagnostic: end planes within this fraction of the RVE's length count as periodic "
        "(product: psdesign.flow.stack.SEAM_TOL_LENGTH), so --copies 2 stacks across a seam it "
        "refuses",
    )
    v.add_argument("--force", action="store_true")
    h = sub.add_parser("hexwindow")
    h.add_argument("--force", action="store_true")
    m = sub.add_parser("seam", help="add the seam term to the bars of rows solved before it")
    m.add_argument("--only", nargs="+", default=None, help="substrings of the spec paths")
    m.add_argument("--direction", default="z")
    sub.add_parser("render")
    args = ap.parse_args(argv)
    cmds = {"arrays": run_arrays, "specs": run_specs, "hexwindow": run_hexwindow}
    cmds |= {"probe": run_probe, "render": render, "seam": run_seam}
    cmds[args.cmd](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
