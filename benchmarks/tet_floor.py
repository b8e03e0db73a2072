"""The tet route's resolution floor ``C (h / R)^2`` calibrated (session 39, helper s39-tetfloor).

The tet-mesh + Taylor-Hood route (``--solver fem``, stuffing mesher; ``bc = "periodic"`` on the
arrays, the quickstart's stacked permeameter on the RVEs) on cases with independent truth, one
JSON line per solve: the error against the reference, ``h / R`` (``h`` the lattice step, ``R =
sqrt(8 K / eps)`` from the computed K), the floor, the Richardson term, the other terms, the bar
and the status. :func:`needed` gives the smallest ``C`` that covers a row; :func:`table`
re-evaluates the bar and status of every row at a trial ``C`` (the bar is ``max(C x, rich) +
solver + window + field + seam``, ``x = (h / R)^2``, the floor doubled where there is no second
lattice).

References:

* square across: Sangani & Acrivos (1982) Table 1 (``tests/reference_values.py``);
* square and hexagonal along: the Sparrow-Loeffler series (``tests/arrays.py``,
  ``along_array_k``), exponentially convergent below touching;
* hexagonal across: Drummond & Tahir (1984) (dilute series, used at 0.1-0.2 only), at
  :data:`arrays.HEX_NEAR_WHOLE` voxels per spacing (cell width within 0.02 % of sqrt(3) L);
* random fibre RVEs (``--set rve``): no published value; the reference is the same RVE at the
  two finer lattice steps extrapolated at second order, its uncertainty the gap to the
  first-order extrapolation (printed by ``--summary``); only the coarsest step (the default
  rule's ``D / 3``) is a validation row.

The field is at 2 voxels per lattice step (the default lattice step's relation,
:func:`psdesign.meshing.options.default_lattice_step`). Sets: ``calibration`` (:data:`CALIBRATION`),
``validation`` and ``dilute`` (disjoint from it), ``rve``. ``--summary`` prints, per set, the
smallest ``C`` that leaves no ``ok`` row outside its bar (with the two lattices, and alone: the
doubled floor of ``flow.error_estimate = false`` or of a coarse lattice that fails to mesh), the
largest ``|error| / (h / R)^2`` (the floor alone), and a table; it also reads the rows of
``narrow_gap_bar.py --set fem / fem2 / fem_hex`` (session 38).

    PYTHONPATH=. python benchmarks/tet_floor.py --set calibration >> benchmarks/tet_floor_runs.jsonl
    PYTHONPATH=. python benchmarks/tet_floor.py --summary benchmarks/tet_floor_runs.jsonl \
        benchmarks/narrow_gap_fem_runs.jsonl
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from arrays import L, along_array_k, array_spec, exact_k, radius_of  # noqa: E402
from narrow_gap_bar import fem_solve  # noqa: E402

from psdesign.flow import error as err  # noqa: E402
from psdesign.flow.permeability import permeability  # noqa: E402
from psdesign.packing.build import build_rve  # noqa: E402
from psdesign.schema.spec import validate_spec  # noqa: E402

#: (kind, flow, solid fractions, lattice cells per spacing); the field at twice the cells
CALIBRATION = [
    ("square", "across", (0.1, 0.2, 0.4, 0.6), (8, 12, 20, 32), (0.0,)),
    ("square", "along", (0.1, 0.3, 0.5), (8, 12, 20, 32), (0.0,)),
]
#: disjoint: other solid fractions and lattices, the array shifted by a fraction of the lattice
#: step (x and y: the cylinders cut the lattice differently), hexagonal arrays at near-whole
#: cell widths
VALIDATION = [
    ("square", "across", (0.05, 0.3, 0.5), (6, 10, 16, 24), (0.0, 0.37)),
    ("square", "along", (0.2, 0.4), (6, 10, 16, 24), (0.0, 0.37)),
    ("hex", "along", (0.2, 0.4), (20.5, 28), (0.0,)),
    ("hex", "across", (0.1, 0.2), (20.5, 28), (0.0,)),
]
#: dilute arrays at other lattice shifts (where ``R`` is several fibre diameters), validation
DILUTE = [
    ("square", "across", (0.05, 0.1), (12, 20, 28), (0.25, 0.5)),
    ("square", "along", (0.05, 0.1), (12, 20, 28), (0.25, 0.5)),
]
#: disjoint from all the above, for :func:`what_if`'s proposal: other fractions, lattices, shift
PROPOSAL = [
    ("square", "along", (0.075, 0.15, 0.25), (7, 9, 14), (0.15,)),
    ("square", "across", (0.05, 0.1, 0.2), (9, 14), (0.15,)),
    ("hex", "along", (0.05, 0.1), (20.5, 28), (0.0,)),
    ("hex", "across", (0.05, 0.15), (20.5, 28), (0.0,)),
]
SETS = {
    "calibration": CALIBRATION,
    "validation": VALIDATION,
    "dilute": DILUTE,
    "proposal": PROPOSAL,
}
#: hexagonal lattices (cells per spacing) -> field voxels per spacing (near-whole widths)
HEX_VOXELS = {20.5: 41, 28: 56}
KIND = {"square": "square", "hex": "hexagonal"}
#: random fibre RVEs (the quickstart's Toray-like paper, 7 um straight fibres, in a 35 um cube,
#: stacked permeameter of 2 copies as the quickstart, through-plane; the generators do not build
#: periodic RVEs): porosity, seed; lattice steps D / 3 (the default rule), D / 4, D / 5 on one
#: field
RVE_CASES = [(0.85, 1), (0.9, 1), (0.85, 2), (0.8, 1), (0.9, 2), (0.8, 2)]
RVE_STEPS = (7e-6 / 3, 7e-6 / 4, 7e-6 / 5)
RVE_VOXEL = 0.5e-6


def rve_spec(porosity: float, seed: int, step: float) -> dict:
    """The quickstart's base spec (``studies/quickstart.toml``) in a 35 um cube, 2 copies."""
    return {
        "rve": {"size": [35e-6] * 3, "voxel": RVE_VOXEL},
        "generator": {
            "kind": "straight", "porosity": porosity, "diameter": 7e-6, "seed": seed,
            "porosity_tolerance": 0.02,
            "theta": {"dist": "uniform", "low": -5.0, "high": 5.0},
            "omega": {"dist": "uniform", "low": 0.0, "high": 180.0},
        },
        "intersections": {"method": "fast", "min_gap": 0.5e-6},
        "flow": {"solver": "fem", "viscosity": 1.8e-5, "bc": "permeameter", "aux_length": 0.2,
                 "permeameter_copies": 2, "lattice_step": step},
    }  # fmt: skip


def rve_rows():
    """The tet route on :data:`RVE_CASES` at :data:`RVE_STEPS`; no truth here (it is the
    extrapolation over the steps, :func:`rve_reference`)."""
    for porosity, seed in RVE_CASES:
        for step in RVE_STEPS:
            t0 = time.perf_counter()
            case = {"set": "rve", "kind": "straight", "flow": "z", "phi": porosity,
                    "seed": seed, "lattice_cells": 35e-6 / step, "step_m": step}  # fmt: skip
            try:
                res = fem_solve(rve_spec(porosity, seed, step), "z")
            except Exception as exc:  # noqa: BLE001 - a failed mesh is a row too
                yield {**case, "refused": f"{type(exc).__name__}: {exc}"[:200]}
                continue
            k, est = res["permeability_m2"], res["error_estimate"]
            r = err.flow_length_scale(k, res["porosity"])
            yield {
                **case, "k": k, "bar": res["permeability_rel_error"], "status": res["status"],
                "richardson": est["richardson"], "floor": est["floor"], "window": est["window"],
                "solver": est["solver"], "field": est["field"], "seam": est["seam"],
                "method": est["method"], "coarse_failure": est["coarse_failure"],
                "R_m": r, "h_over_R": step / r, "porosity": res["porosity"],
                "n_tets": (res.get("mesh_quality") or {}).get("n_tets"),
                "cells_per_diameter": res.get("cells_per_diameter"),
                "t_s": time.perf_counter() - t0, "load_1min": os.getloadavg()[0],
            }  # fmt: skip


def rve_reference(rows: list[dict]) -> list[dict]:
    """The coarsest ``rve`` row of each RVE with ``truth``: ``K0`` of ``K = K0 + c h^2`` through
    the two finest steps, and ``error``; ``truth_uncertainty``: the gap to ``K0`` at ``p = 1``
    (relative), the reference's own uncertainty. The finer rows make the reference and are not
    validation rows."""
    out = []
    groups: dict = {}
    for r in rows:
        if r.get("set") == "rve" and "refused" not in r:
            groups.setdefault((r["phi"], r["seed"]), []).append(r)
    for sel in groups.values():
        sel = sorted(sel, key=lambda r: r["step_m"])
        if len(sel) < 2:
            continue
        (h1, k1), (h2, k2) = [(r["step_m"], r["k"]) for r in sel[:2]]
        k0 = {p: k1 + (k1 - k2) / ((h2 / h1) ** p - 1.0) for p in (1, 2)}
        r = sel[-1]
        out.append({**r, "truth": k0[2], "error": r["k"] / k0[2] - 1.0,
                    "truth_uncertainty": abs(k0[1] / k0[2] - 1.0)})  # fmt: skip
    return out


def truth(kind: str, flow: str, phi: float) -> tuple[float, str]:
    """The reference K (m^2) and its source."""
    if flow == "along":
        a = radius_of(phi, KIND[kind], L)
        return along_array_k(phi, KIND[kind]) * a * a, "Sparrow & Loeffler 1959 series"
    if kind == "square":
        return exact_k("square", "across", phi), "Sangani & Acrivos 1982 Table 1"
    return exact_k("hex", "across", phi), "Drummond & Tahir 1984 (dilute series)"


def cases(sets):
    for kind, flow, phis, ms, shifts in sets:
        for phi in phis:
            for m in ms:
                for shift in shifts:
                    yield kind, flow, phi, m, shift


def run(kind: str, flow: str, phi: float, m: float, shift: float, group: str) -> dict:
    """One tet-route solve of the array at ``m`` lattice cells per spacing, its cylinders
    shifted by ``shift`` lattice steps along x and y."""
    t0 = time.perf_counter()
    n = HEX_VOXELS[m] if kind == "hex" else int(round(2 * m))
    spec = array_spec(kind, phi, n)
    for fb in spec["fibers"]:
        c = fb["center"]
        fb["center"] = [c[0] + shift * L / m, c[1] + shift * L / m, c[2]]
    spec["flow"] = {**spec["flow"], "bc": "periodic", "lattice_step": L / m}
    case = {"set": group, "kind": kind, "flow": flow, "phi": phi, "lattice_cells": m,
            "shift": shift, "voxels": n}  # fmt: skip
    k_true, ref = truth(kind, flow, phi)
    try:
        spec = validate_spec(spec)
        built = build_rve(spec)
        fields = built.voxelize(spec["rve"]["voxel"])
        res = permeability(built.rve, fields, "z" if flow == "along" else "x", spec["flow"], "fem")
    except Exception as exc:  # noqa: BLE001 - a failed mesh is a row too
        return {**case, "refused": f"{type(exc).__name__}: {exc}"[:200]}
    k, est = res["permeability_m2"], res["error_estimate"]
    step = float(res["mesh_quality"]["lattice_step_m"])
    r = err.flow_length_scale(k, res["porosity"])
    return {
        **case, "k": k, "truth": k_true, "reference": ref, "error": k / k_true - 1.0,
        "bar": res["permeability_rel_error"], "status": res["status"],
        "richardson": est["richardson"], "floor": est["floor"], "window": est["window"],
        "solver": est["solver"], "field": est["field"], "seam": est["seam"],
        "method": est["method"], "coarse_failure": est["coarse_failure"], "step_m": step,
        "R_m": r, "h_over_R": step / r, "floor_constant": err.FLOOR["tet"][1],
        "cells_per_diameter": res.get("cells_per_diameter"), "t_s": time.perf_counter() - t0,
        "load_1min": os.getloadavg()[0],
    }  # fmt: skip


def bar_at(row: dict, c: float, alone: bool = False) -> float:
    """The row's bar with floor constant ``c``; ``alone``: as without a second lattice
    (``flow.error_estimate = false`` or a coarse lattice that fails to mesh): the floor doubled,
    no Richardson term."""
    x = row["h_over_R"] ** 2
    alone = alone or row["method"] == "resolution_only"
    disc = 2.0 * c * x if alone else max(c * x, row["richardson"] or 0.0)
    return disc + row["solver"] + row["window"] + row["field"] + row["seam"]


def status_at(row: dict, c: float, alone: bool = False) -> str:
    """The row's status with floor constant ``c`` (only the bar's threshold moves)."""
    return err.status_of(True, bar_at(row, c, alone), None)  # the tet route passes no cpd


def needed(row: dict, alone: bool = False) -> float:
    """The smallest ``C`` whose bar covers the row (0 if the other terms already do)."""
    rest = row["solver"] + row["window"] + row["field"] + row["seam"]
    alone = alone or row["method"] == "resolution_only"
    if not alone and abs(row["error"]) <= (row["richardson"] or 0.0) + rest:
        return 0.0
    x = row["h_over_R"] ** 2 * (2.0 if alone else 1.0)
    return max(0.0, abs(row["error"]) - rest) / x


def outside(rows: list[dict], c: float, alone: bool = False) -> list[dict]:
    """The ``ok`` rows outside their bar at ``c``."""
    return [
        r
        for r in rows
        if status_at(r, c, alone) == "ok" and abs(r["error"]) > bar_at(r, c, alone) * (1 + 1e-12)
    ]


def smallest_c(rows: list[dict], alone: bool = False) -> float:
    """The smallest ``C`` leaving no ``ok`` row outside its bar (a row whose bar passes the
    untrustworthy threshold at that ``C`` is not ``ok``): scan the rows' own needs."""
    for c in sorted({0.0, *(needed(r, alone) for r in rows)}):
        if not outside(rows, c, alone):
            return c
    return float("inf")


def diameter(row: dict) -> float:
    """The row's fibre diameter ``D`` (m)."""
    if row["set"] == "rve":
        return 7e-6
    return 2.0 * radius_of(row["phi"], KIND[row["kind"]], L)


def what_if(rows: list[dict], c_r: float, c_d: float) -> None:
    """A floor ``max(C_R (h / R)^2, C_D (h / D)^2)`` (not the product's; a proposal): the ``ok``
    rows outside their bar with two lattices and alone, and the median bar / ``|error|``."""
    counts, ratios = [0, 0], []
    for r in rows:
        fl = max(c_r * r["h_over_R"] ** 2, c_d * (r["step_m"] / diameter(r)) ** 2)
        rest = r["solver"] + r["window"] + r["field"] + r["seam"]
        for i, alone in enumerate((False, True)):
            alone = alone or r["method"] == "resolution_only"
            b = (2.0 * fl if alone else max(fl, r["richardson"] or 0.0)) + rest
            ok = err.status_of(True, b, None) == "ok"
            counts[i] += ok and abs(r["error"]) > b * (1 + 1e-12)
            if i == 0 and ok:
                ratios.append(b / max(abs(r["error"]), 1e-4))
    med = sorted(ratios)[len(ratios) // 2] if ratios else float("nan")
    print(f"# max({c_r:g} (h/R)^2, {c_d:g} (h/D)^2): ok rows outside their bar: {counts[0]} (two "
          f"lattices), {counts[1]} (alone); median bar / abs(error) of {len(ratios)} ok rows "
          f"{med:.1f}")  # fmt: skip


def table(rows: list[dict], c: float) -> None:
    """One line per row at floor constant ``c``: the bar with two lattices and alone (doubled
    floor, no Richardson term), the ``C`` each needs to cover the row, and ``|error| / (h /
    R)^2``, the constant the floor alone would need."""
    print(
        "| set | case | cells per spacing (shift) | h/R | error | Richardson | floor | bar | "
        "status | bar alone | C needed: two lattices (alone) | abs(error) / (h/R)^2 |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        head = f"| {r['set']} | {r['kind']} {r['flow']} {r['phi']}{_seed(r)} | {_cells(r)} |"
        if "refused" in r:
            print(f"{head} refused: {r['refused'][:70]} | | | | | | | | |")
            continue
        x = r["h_over_R"] ** 2
        print(
            f"{head} {r['h_over_R']:.3f} | {100 * r['error']:+.2f} % | "
            f"{100 * (r['richardson'] or 0):.2f} % | {100 * c * x:.2f} % | "
            f"{100 * bar_at(r, c):.2f} % | {status_at(r, c)} | {100 * bar_at(r, c, True):.2f} % "
            f"({status_at(r, c, True)}) | {needed(r):.3f} ({needed(r, True):.3f}) | "
            f"{abs(r['error']) / x:.3f} |"
        )


def _normal(r: dict) -> dict:
    """A row of ``narrow_gap_bar.py --set fem / fem2 / fem_hex`` (arrays across near
    touching, session 38) in this script's form."""
    if "kind" in r:
        return r
    kind = "hex" if r["set"] == "fem_hex" else "square"
    r = {**r, "set": f"s38 {r['set']} {r['bc']}", "kind": kind, "flow": "across"}
    return r if "refused" in r else {**r, "h_over_R": r["step_m"] / r["R_m"]}


def _seed(r: dict) -> str:
    return f" seed {r['seed']}" if "seed" in r else ""


def _cells(r: dict) -> str:
    cells = f"{r['lattice_cells']:.3g}"
    return f"{cells} ({r['shift']:g})" if r.get("shift") else cells


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--set", choices=(*SETS, "rve"), default="calibration")
    ap.add_argument("--summary", nargs="+", help="print the table of these JSON-lines files")
    ap.add_argument("--what-if", type=float, nargs=2, action="append", metavar=("C_R", "C_D"),
                    help="with --summary: a floor max(C_R (h/R)^2, C_D (h/D)^2)")  # fmt: skip
    ap.add_argument("--lattice", type=float, nargs="+", help="only these cells per spacing")
    ap.add_argument("--c-new", type=float, default=None, help="trial floor constant")
    args = ap.parse_args()
    if args.summary:
        rows = [
            json.loads(x)
            for f in args.summary
            for x in Path(f).read_text().splitlines()
            if x.startswith("{")
        ]
        rows = [_normal(r) for r in rows if r.get("set") not in ("rve", "diffuse")] + (
            rve_reference(rows)
        )
        done = [r for r in rows if "refused" not in r]
        for group in sorted({r["set"] for r in done}):
            sel = [r for r in done if r["set"] == group]
            if sel:
                print(f"# {group}: {len(sel)} solved, smallest C covering every ok row: "
                      f"{smallest_c(sel):.3f} (two lattices), {smallest_c(sel, True):.3f} "
                      "(floor alone, doubled)")  # fmt: skip
                ok = [r for r in sel if r["status"] == "ok"]
                if ok:
                    top = max(ok, key=lambda r: abs(r["error"]) / r["h_over_R"] ** 2)
                    print(f"#   largest abs(error) / (h/R)^2 of its ok rows (the floor alone): "
                          f"{abs(top['error']) / top['h_over_R'] ** 2:.3f} ({top['kind']} "
                          f"{top['flow']} {top['phi']}{_seed(top)}, {_cells(top)} cells, "
                          f"{100 * top['error']:+.2f} %)")  # fmt: skip
                for r in sel:
                    if "truth_uncertainty" in r:
                        print(
                            f"#   {r['phi']}{_seed(r)}: reference K {r['truth']:.5e} m^2, "
                            f"its uncertainty {100 * r['truth_uncertainty']:.2f} %"
                        )
        # the table and the C / 2 lines evaluate the one-term law C (h / R)^2 (before session
        # 39's fibre floor: C = 0.5); the product's two-term law is the first what-if line above
        c_new = args.c_new if args.c_new is not None else 0.5
        table(rows, c_new)
        # the product's law (session 39 lead: FLOOR["tet"] with FIBER_FLOOR["tet"]) first
        what_if(done, err.FLOOR["tet"][1], err.FIBER_FLOOR["tet"])
        for c_r, c_d in args.what_if or []:
            what_if(done, c_r, c_d)
        for c in (c_new, c_new / 2):
            print(f"# C = {c:g}: ok rows outside their bar: {len(outside(done, c))} (two "
                  f"lattices), {len(outside(done, c, True))} (floor alone, doubled)")  # fmt: skip
        return 0
    if args.set == "rve":
        for row in rve_rows():
            print(json.dumps(row), flush=True)
        return 0
    for kind, flow, phi, m, shift in cases(SETS[args.set]):
        if args.lattice and m not in args.lattice:
            continue
        print(json.dumps(run(kind, flow, phi, m, shift, args.set)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
