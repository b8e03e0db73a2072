"""The voxel permeability's bar at narrow gaps (near-touching fibres; session 38, helper s38-gaps).

Cylinder arrays across at solid fractions 0.5-0.85, where the permeability is set by the gap
``g`` between neighbouring cylinders (lubrication, ``K ~ g^2.5``), so a wall error ``delta`` in
the gap moves ``K`` by about ``2.5 delta / g`` and the two-grid term can agree by chance (the
coarse grid rounds the gap differently). Both wall treatments (``subvoxel``, the default, and
``staircase``), 8-48 voxels per spacing, sub-voxel shifts of the lattice.

References:

* square across: Sangani & Acrivos (1982) Table 1 (``tests/reference_values.py``), tabulated at
  0.5, 0.6, 0.7, 0.75 (their multipole solution, converged to near touching, pi / 4 = 0.785);
* hexagonal across: Drummond & Tahir's series is dilute (phi <= 0.3) and not used; the
  reference is the same (identically stretched) array solved with sub-voxel walls at 4 times
  finer voxels, Richardson-extrapolated with the 2 times finer solve at second order; its own
  uncertainty (|K_4 - K_2| / 3) is printed;
* square along: the Sparrow-Loeffler series (``tests/arrays.py``, ``along_array_k``).

``--set fem`` / ``fem2`` / ``diffuse`` (session 38, helper s38-femgap): the tet route (its
stuffing mesher, ``flow.lattice_step`` 12-48 cells per spacing, the field at 72 voxels per spacing
or 2 voxels per lattice step; periodic and permeameter) and the diffuse wall (12-48 voxels, shifts
0 and 1/4) on square arrays across at 0.5-0.75, rows with the bar's components (no gap term: these
schemes have none), summarised by :func:`route_summary`.

Each line: the case, K, reference, true error, the bar and its components, status, the throat
``g`` (voxels: twice the percolation radius, :mod:`psdesign.geometry.throat`) and ``R / h``.

    PYTHONPATH=. python benchmarks/narrow_gap_bar.py > /tmp/narrow_gap.jsonl
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from arrays import L, along_array_k, array_spec, exact_k, hex_width_voxels, radius_of  # noqa: E402

from psdesign.flow import error as err  # noqa: E402
from psdesign.flow.permeability import permeability  # noqa: E402
from psdesign.geometry.throat import percolation_radius, wall_distance_voxels  # noqa: E402
from psdesign.packing.build import build_rve  # noqa: E402
from psdesign.schema.spec import validate_spec  # noqa: E402

#: square across, calibration set (disjoint from the validation set below)
CALIBRATION = [("square", "across", (0.5, 0.6, 0.7, 0.75), (10, 14, 20, 28, 40), (0.0, 0.5))]
VALIDATION = [
    ("square", "across", (0.5, 0.6, 0.7, 0.75), (8, 12, 16, 24, 32, 48), (0.0, 0.25)),
    ("hex", "across", (0.5, 0.6, 0.7, 0.8, 0.85), (8, 12, 16), (0.0, 0.25)),
    ("square", "along", (0.5, 0.6, 0.7), (12, 24), (0.0,)),
]
#: hexagonal arrays near touching at finer grids; the reference is the 2 times finer solve only
#: (4 times would be 11M voxels), its uncertainty not estimated
DENSE = [("hex", "across", (0.8,), (32, 48), (0.0,))]
#: resolved arrays (the session-5 validation grid of ``docs/validation.md``): the term must not
#: widen these bars much
#: the tet route (``--solver fem``, stuffing mesher) on square arrays across, near touching: the
#: field at ``FEM_VOXELS`` voxels per spacing, the lattice at these cells per spacing, and the bc
#: (session 38, helper s38-femgap); rows hold the bar's components
FEM = [(0.5, 0.6, 0.7), (12, 18, 24), ("periodic",)]
FEM_PERMEAMETER = [(0.5, 0.6, 0.7), (18,), ("permeameter",)]
FEM_VOXELS = 72
#: the same with the field at 2 voxels per lattice step (the default lattice step's relation,
#: :func:`psdesign.meshing.options.default_lattice_step`), finer lattices and 0.75
FEM_DEFAULT_FIELD = [(0.5, 0.6, 0.7, 0.75), (16, 24, 32, 48), ("periodic",)]
FEM_DEFAULT_PERMEAMETER = [(0.6, 0.7, 0.75), (32,), ("permeameter",)]
#: the diffuse wall (voxel route, periodic) on square arrays across near touching
DIFFUSE = [("square", "across", (0.5, 0.6, 0.7), (12, 16, 24, 32, 48), (0.0, 0.25))]
RESOLVED = [
    ("square", "across", (0.1, 0.2, 0.3, 0.4), (24, 48), (0.0,)),
    ("square", "along", (0.1, 0.2, 0.3, 0.4), (24, 48), (0.0,)),
]


KIND = {"square": "square", "hex": "hexagonal"}


def solve(kind, flow, phi, n, wall, shift, width_voxels=None, gap=True):
    spec = array_spec(kind, phi, n, width_voxels=width_voxels)
    h = L / n
    for fb in spec["fibers"]:
        fb["center"] = [fb["center"][0] + shift * h, fb["center"][1] + shift * h, fb["center"][2]]
    spec["flow"] = {**spec["flow"], "wall_treatment": wall}
    spec = validate_spec(spec)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    d = "z" if flow == "along" else "x"
    saved = dict(err.GAP)
    if not gap:  # the bar before session 38's gap term
        err.GAP.clear()
    try:
        res = permeability(built.rve, fields, d, spec["flow"], "voxel")
    finally:
        err.GAP.update(saved)
    step = float(fields.grid.spacing[0])
    t0 = time.perf_counter()
    wd = wall_distance_voxels(fields.distance, step, fields.analytic_distance)
    r = percolation_radius(wd, "xyz".index(d))
    return res, step, 2.0 * r, time.perf_counter() - t0


def fem_solve(spec: dict, direction: str) -> dict:
    """The tet route's result on ``spec`` (validated, built and voxelized here) along
    ``direction``; raises what the route raises (a failed mesh is a row of its own)."""
    spec = validate_spec(spec)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    return permeability(built.rve, fields, direction, spec["flow"], "fem")


_HEX_REF: dict = {}
CACHE = Path("/tmp/narrow_gap_hex_reference.json")


def hex_reference(phi: float, n: int, shift: float) -> tuple[float, float]:
    """The hexagonal array at ``n`` voxels per spacing (its stretched width) solved at 2n and 4n
    with sub-voxel walls: (extrapolated K, its uncertainty); for :data:`DENSE` the 2n solve and
    an uncertainty of nan."""
    key = f"{phi} {n} {shift}"
    if n >= 32:
        w = hex_width_voxels(n)
        k2 = solve("hex", "across", phi, 2 * n, "subvoxel", 2 * shift, 2 * w)[0]["permeability_m2"]
        return k2, float("nan")
    if not _HEX_REF and CACHE.exists():
        _HEX_REF.update(json.loads(CACHE.read_text()))
    if key not in _HEX_REF:
        w = hex_width_voxels(n)
        k2 = solve("hex", "across", phi, 2 * n, "subvoxel", 2 * shift, 2 * w)[0]["permeability_m2"]
        k4 = solve("hex", "across", phi, 4 * n, "subvoxel", 4 * shift, 4 * w)[0]["permeability_m2"]
        _HEX_REF[key] = (k4 + (k4 - k2) / 3.0, abs(k4 - k2) / 3.0 / k4)
        CACHE.write_text(json.dumps(_HEX_REF))
    return _HEX_REF[key]


def truth(kind, flow, phi, n, shift) -> tuple[float, float, str]:
    if kind == "square" and flow == "across":
        return exact_k(kind, flow, phi), 0.0, "Sangani & Acrivos 1982 Table 1"
    if flow == "along":
        a = radius_of(phi, KIND[kind]) * L
        return along_array_k(phi, KIND[kind]) * a * a, 0.0, "Sparrow & Loeffler series"
    k, u = hex_reference(phi, n, shift)
    if n >= 32:
        return k, u, "same array, sub-voxel, 2n"
    return k, u, "same array, sub-voxel, 2n and 4n, extrapolated"


def rows(sets, group, walls):
    for kind, flow, phis, ns, shifts in sets:
        for phi in phis:
            for n in ns:
                for shift in shifts:
                    for wall in walls:
                        t0 = time.perf_counter()
                        case = {"set": group, "kind": kind, "flow": flow, "phi": phi, "n": n,
                                "shift": shift, "wall": wall}  # fmt: skip
                        try:
                            old = solve(kind, flow, phi, n, wall, shift, gap=False)[0]
                            res, step, g, t_g = solve(kind, flow, phi, n, wall, shift)
                            k_true, u, ref = truth(kind, flow, phi, n, shift)
                        except Exception as exc:  # noqa: BLE001 - a closed gap is a row too
                            yield {**case, "refused": f"{type(exc).__name__}: {exc}"[:160]}
                            continue
                        k = res["permeability_m2"]
                        est = res["error_estimate"]
                        yield {
                            **case, "k": k, "truth": k_true,
                            "truth_unc": u, "reference": ref, "error": k / k_true - 1.0,
                            "bar": res["permeability_rel_error"], "status": res["status"],
                            "bar_before": old["permeability_rel_error"],
                            "status_before": old["status"], "gap_term": est["gap"],
                            "throat_m": est["throat_m"],
                            "richardson": est["richardson"], "floor": est["floor"],
                            "gap": est.get("gap"), "throat_voxels": g,
                            "R_over_h": err.flow_length_scale(k, res["porosity"]) / step,
                            "gap_exact_voxels": (1 - 2 * radius_of(phi, KIND[kind])) * n,
                            "t_throat_s": t_g, "t_s": time.perf_counter() - t0,
                        }  # fmt: skip


def route_rows(group: str):
    """The tet route (``group`` "fem") or the diffuse wall ("diffuse") on square arrays across,
    each row with the bar's components, the step, throat (m, the route's own voxel field) and
    ``R``; no gap term is applied by these routes (session 38)."""
    if group in ("fem", "fem2"):
        sets = (
            (FEM, FEM_PERMEAMETER)
            if group == "fem"
            else (FEM_DEFAULT_FIELD, FEM_DEFAULT_PERMEAMETER)
        )
        cases = [
            (phi, FEM_VOXELS if group == "fem" else 2 * m, m, bc)
            for phis, ms, bcs in sets
            for phi in phis
            for m in ms
            for bc in bcs
        ]
    else:
        cases = [
            (phi, n, shift, "periodic")
            for _, _, phis, ns, shifts in DIFFUSE
            for phi in phis
            for n in ns
            for shift in shifts
        ]
    for phi, n, extra, bc in cases:
        t0 = time.perf_counter()
        spec = array_spec("square", phi, n)
        h = L / n
        flow = {**spec["flow"], "bc": bc}
        if group != "diffuse":
            flow["lattice_step"] = L / extra
            case = {"set": group, "phi": phi, "voxels": n, "lattice_cells": extra, "bc": bc}
        else:
            for fb in spec["fibers"]:
                c = fb["center"]
                fb["center"] = [c[0] + extra * h, c[1] + extra * h, c[2]]
            flow["wall_treatment"] = "diffuse"
            case = {"set": "diffuse", "phi": phi, "n": n, "shift": extra, "bc": bc}
        spec["flow"] = flow
        try:
            spec = validate_spec(spec)
            built = build_rve(spec)
            fields = built.voxelize(spec["rve"]["voxel"])
            solver = "voxel" if group == "diffuse" else "fem"
            res = permeability(built.rve, fields, "x", spec["flow"], solver)
        except Exception as exc:  # noqa: BLE001 - a closed gap or a failed mesh is a row too
            yield {**case, "refused": f"{type(exc).__name__}: {exc}"[:200]}
            continue
        step_v = float(fields.grid.spacing[0])
        wd = wall_distance_voxels(fields.distance, step_v, fields.analytic_distance)
        g = err.throat_width_voxels(percolation_radius(wd, 0)) * step_v
        k, est = res["permeability_m2"], res["error_estimate"]
        step = float((res.get("mesh_quality") or {}).get("lattice_step_m") or step_v)
        k_true = exact_k("square", "across", phi)
        yield {
            **case, "k": k, "truth": k_true, "reference": "Sangani & Acrivos 1982 Table 1",
            "error": k / k_true - 1.0, "bar": res["permeability_rel_error"],
            "status": res["status"], "richardson": est["richardson"], "floor": est["floor"],
            "window": est["window"], "solver": est["solver"], "field": est["field"],
            "seam": est["seam"], "gap_term": est["gap"], "method": est["method"],
            "coarse_failure": est["coarse_failure"], "step_m": step, "throat_m": g,
            "R_m": err.flow_length_scale(k, res["porosity"]),
            "gap_exact_m": (1 - 2 * radius_of(phi, "square")) * L,
            "cells_per_diameter": res.get("cells_per_diameter"), "t_s": time.perf_counter() - t0,
        }  # fmt: skip


def three_grid(phi: float = 0.8, n: int = 32) -> float:
    """The hexagonal array at ``n``, ``2n`` and ``3n`` voxels per spacing (one stretched
    geometry, sub-voxel walls): K, bar and status of each, the observed order ``p`` from the three
    and each one's error against the value extrapolated with it; returns that value."""
    w = hex_width_voxels(n)
    ks = []
    for f in (1, 2, 3):
        res = solve("hex", "across", phi, f * n, "subvoxel", 0.0, f * w)[0]
        ks.append(res["permeability_m2"])
        print(f"# {f * n} voxels: K {ks[-1]:.5e} bar {100 * res['permeability_rel_error']:.2f} % "
              f"{res['status']}")  # fmt: skip
    ratio = (ks[1] - ks[0]) / (ks[2] - ks[1])
    lo, hi = 0.1, 4.0  # (1 - 2^-p) / (2^-p - 3^-p) rises with p
    for _ in range(60):
        p = 0.5 * (lo + hi)
        lo, hi = (p, hi) if (1 - 2**-p) / (2**-p - 3**-p) < ratio else (lo, p)
    k = ks[0] + (ks[1] - ks[0]) / (1 - 2**-p)
    errs = ", ".join(f"{100 * (x / k - 1):+.1f} %" for x in ks)
    print(f"# observed order {p:.2f}, extrapolated K {k:.5e}; errors {errs}")
    return k


#: the tet route on hexagonal arrays across near touching: solid fractions, lattice cells per
#: spacing; the field at 64 voxels per spacing, the geometry :func:`three_grid`'s at 32 voxels
#: per spacing (its stretched width, 55 voxels of 32 per spacing: 110 of 64) and the reference
#: its three-grid extrapolation
FEM_HEX = [(0.7, 0.8), (24, 32)]  # 48: over the memory budget (1.1M tets, 15 GiB)


def fem_hex_rows():
    """Rows of the tet route on :data:`FEM_HEX` against the sub-voxel three-grid extrapolation
    of the same (identically stretched) array."""
    n0 = 32
    w = hex_width_voxels(n0)
    phis, ms = FEM_HEX
    for phi in phis:
        k_true = three_grid(phi, n0)
        for m in ms:
            t0 = time.perf_counter()
            case = {"set": "fem_hex", "phi": phi, "voxels": 2 * n0, "lattice_cells": m,
                    "bc": "periodic"}  # fmt: skip
            spec = array_spec("hex", phi, 2 * n0, width_voxels=2 * w)
            spec["flow"] = {**spec["flow"], "bc": "periodic", "lattice_step": L / m}
            try:
                res = fem_solve(spec, "x")
            except Exception as exc:  # noqa: BLE001 - a failed mesh is a row too
                yield {**case, "refused": f"{type(exc).__name__}: {exc}"[:200]}
                continue
            k, est = res["permeability_m2"], res["error_estimate"]
            yield {
                **case, "k": k, "truth": k_true,
                "reference": "same array, sub-voxel, 32/64/96 voxels, extrapolated",
                "error": k / k_true - 1.0, "bar": res["permeability_rel_error"],
                "status": res["status"], "richardson": est["richardson"], "floor": est["floor"],
                "window": est["window"], "solver": est["solver"], "field": est["field"],
                "seam": est["seam"], "gap_term": est["gap"], "method": est["method"],
                "coarse_failure": est["coarse_failure"],
                "step_m": float(res["mesh_quality"]["lattice_step_m"]),
                "throat_m": float("nan"), "R_m": err.flow_length_scale(k, res["porosity"]),
                "t_s": time.perf_counter() - t0,
            }  # fmt: skip


def route_summary(rows: list[dict]) -> None:
    """The fem / diffuse rows (:func:`route_rows`): per set and bc, cases solved (refused),
    ``ok`` ones, ``ok`` ones outside their bar, the smallest and median bar / |error| of the
    ``ok`` ones and their error range; untrustworthy ones with their error and bar."""
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["set"], r["bc"]), []).append(r)
    print("| set | bc | solved (refused) | ok | ok outside the bar | ok: bar / abs(error) min, "
          "median | ok: error range | untrustworthy: error range |")  # fmt: skip
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for (group, bc), sel in groups.items():
        done = [r for r in sel if "refused" not in r]
        ok = [r for r in done if r["status"] == "ok"]
        bad = [r for r in done if r["status"] != "ok"]
        miss = [r for r in ok if abs(r["error"]) > r["bar"]]
        q = [r["bar"] / max(abs(r["error"]), 1e-4) for r in ok] or [float("nan")]
        e = [100 * r["error"] for r in ok] or [float("nan")]
        eb = [100 * r["error"] for r in bad] or [float("nan")]
        print(
            f"| {group} | {bc} | {len(done)} ({len(sel) - len(done)}) | {len(ok)} | {len(miss)} | "
            f"{min(q):.1f}, {statistics.median(q):.1f} | {min(e):+.2f} to {max(e):+.2f} % | "
            f"{min(eb):+.2f} to {max(eb):+.2f} % |"
        )


def summary(rows: list[dict]) -> None:
    """Per set, family and wall: ``ok`` results, ``ok`` ones outside their bar, and the median
    bar / |error| of the ``ok`` ones, before and after the gap term; each ``ok`` miss."""
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["set"], r["kind"], r["flow"], r["wall"]), []).append(r)
    print(
        "| set | array, flow | wall | cases (closed) | ok before / after | ok outside the bar "
        "before / after | median bar / abs(error), ok, before / after | bar widened |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for (group, kind, flow, wall), sel in groups.items():
        done = [r for r in sel if "refused" not in r]
        cols = []
        for bar, status in (("bar_before", "status_before"), ("bar", "status")):
            ok = [r for r in done if r[status] == "ok"]
            miss = [r for r in ok if abs(r["error"]) > r[bar]]
            med = statistics.median([r[bar] / max(abs(r["error"]), 1e-4) for r in ok] or [0])
            cols.append((len(ok), len(miss), med))
        wider = sum(r["bar"] > r["bar_before"] * (1 + 1e-9) for r in done)
        print(
            f"| {group} | {kind} {flow} | {wall} | {len(done)} ({len(sel) - len(done)}) | "
            f"{cols[0][0]} / {cols[1][0]} | {cols[0][1]} / {cols[1][1]} | "
            f"{cols[0][2]:.2f} / {cols[1][2]:.2f} | {wider} |"
        )
    for r in rows:
        for bar, status, when in (
            ("bar_before", "status_before", "before"),
            ("bar", "status", "after"),
        ):
            if "refused" not in r and r[status] == "ok" and abs(r["error"]) > r[bar]:
                print(
                    f"ok outside ({when}): {r['kind']} {r['flow']} {r['phi']} n {r['n']} shift "
                    f"{r['shift']} {r['wall']}: {100 * r['error']:+.1f} % in {100 * r[bar]:.1f} %"
                )


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument(
        "--set",
        choices=(
            "calibration",
            "validation",
            "resolved",
            "dense",
            "three_grid",
            "fem",
            "fem2",
            "fem_hex",
            "diffuse",
            "both",
        ),
        default="both",
    )
    ap.add_argument("--summary", nargs="+", help="print the tables of these JSON-lines files")
    args = ap.parse_args()
    if args.summary:
        lines = [x for f in args.summary for x in Path(f).read_text().splitlines()]
        got = [json.loads(x) for x in lines if not x.startswith("#")]  # three_grid's notes
        for show, sel in ((summary, [r for r in got if "kind" in r]),
                          (route_summary, [r for r in got if "kind" not in r])):  # fmt: skip
            if sel:
                show(sel)
        return 0
    sets = []
    if args.set in ("calibration", "both"):
        sets.append((CALIBRATION, "calibration"))
    if args.set in ("validation", "both"):
        sets.append((VALIDATION, "validation"))
    if args.set == "fem_hex":
        for row in fem_hex_rows():
            print(json.dumps(row), flush=True)
        return 0
    if args.set in ("fem", "fem2", "diffuse"):
        for row in route_rows(args.set):
            print(json.dumps(row), flush=True)
        return 0
    if args.set == "three_grid":
        three_grid()
        return 0
    if args.set == "resolved":
        sets.append((RESOLVED, "resolved"))
    if args.set == "dense":
        sets.append((DENSE, "dense"))
    for s, group in sets:
        for row in rows(s, group, ("subvoxel", "staircase")):
            print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
