"""The pytetwild route's error bar against truth (session 39, helper s39-tetwild).

The tet route (``--solver fem``, ``flow.mesher = "pytetwild"``, ``bc = "permeameter"``:
pytetwild refuses periodic) on one cell of cylinder arrays, one JSON line per solve: the
error against the reference, the bar and its terms (floor, Richardson, window, field), the
status, the ``h`` the bar used, the mesher's target edge (``mesh_quality.edge_length_m``) and
``n_tets``, and the coarse companion's K. ``flow.edge_length`` is set to ``fac`` times the
default edge (:data:`psdesign.meshing.options.EDGE_PER_DIAMETER` fibre diameters) as a
fraction of the meshed box diagonal. pytetwild is not deterministic: ``--repeat`` solves each
case again.

References: square across, Sangani & Acrivos (1982) Table 1 (``tests/reference_values.py``);
along, the Sparrow-Loeffler series (``tests/arrays.py``, ``along_array_k``); hexagonal across,
Drummond & Tahir (1984) (dilute series, 0.1-0.2 only).

Usage::

    PYTHONPATH=. python benchmarks/tetwild_bar.py --set calibration \
        >> benchmarks/tetwild_bar_runs.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from arrays import L, along_array_k, array_spec, exact_k, radius_of  # noqa: E402

from psdesign.flow.permeability import _fem_step, permeability  # noqa: E402
from psdesign.flow.stack import plan_copies, stacked_flow  # noqa: E402
from psdesign.meshing.options import EDGE_PER_DIAMETER, MeshOptions  # noqa: E402
from psdesign.packing.build import build_rve  # noqa: E402
from psdesign.schema.spec import validate_spec  # noqa: E402

#: (kind, flow, solid fraction, edge factor, voxels per spacing)
SETS = {
    "calibration": [
        ("square", "across", 0.3, 1.0, 48),
        ("square", "across", 0.3, 0.5, 48),
        ("square", "across", 0.1, 1.0, 48),
        ("square", "across", 0.1, 0.5, 48),
        ("square", "along", 0.3, 1.0, 48),
        ("square", "along", 0.3, 0.5, 48),
        ("square", "across", 0.5, 1.0, 48),
        ("square", "across", 0.5, 0.5, 48),
        ("square", "across", 0.3, 0.25, 48),
        ("square", "across", 0.1, 0.25, 48),
    ],
    "validation": [
        ("square", "across", 0.2, 1.0, 24),
        ("square", "across", 0.4, 1.0, 32),
        ("square", "along", 0.1, 1.0, 32),
        ("square", "across", 0.3, 1.0, 24),
        ("square", "along", 0.3, 0.25, 48),
        ("hex", "across", 0.2, 1.0, 41),
    ],
    # solved after C was chosen (none of these was used to fit it)
    "proposal": [
        ("square", "across", 0.2, 0.5, 48),
        ("square", "across", 0.4, 0.5, 48),
        ("square", "across", 0.05, 1.0, 40),
        ("square", "along", 0.2, 1.0, 40),
        ("square", "across", 0.6, 0.5, 48),
        ("hex", "across", 0.1, 1.0, 41),
        ("square", "across", 0.3, 1.0, 40),
    ],
}
KIND = {"square": "square", "hex": "hexagonal"}


def truth(kind: str, flow: str, phi: float) -> tuple[float, str]:
    """Reference K (m^2) and its source."""
    if flow == "along":
        a = radius_of(phi, KIND[kind]) * L
        return along_array_k(phi, KIND[kind]) * a * a, "Sparrow-Loeffler series"
    if kind == "square":
        return exact_k("square", "across", phi), "Sangani & Acrivos 1982"
    return exact_k("hex", "across", phi), "Drummond & Tahir 1984 (dilute series)"


def spec_of(kind: str, flow_dir: str, phi: float, n: int) -> dict:
    """Validated spec of one cell with pytetwild (default edge)."""
    spec = array_spec(kind, phi, n)
    spec["flow"] = {**spec["flow"], "mesher": "pytetwild", "bc": "permeameter"}
    return validate_spec(spec)


def with_edge(spec: dict, rve, fields, axis: int, fac: float) -> dict:
    """``spec``'s flow table with ``flow.edge_length`` at ``fac`` times the default edge, a
    fraction of the meshed box's diagonal (the permeameter's copies and reservoirs included)."""
    flow = dict(spec["flow"])
    if fac == 1.0:
        return flow
    copies = plan_copies(flow, rve, fields, axis).copies
    aux = MeshOptions.from_flow(stacked_flow(flow, copies)).aux_length
    size = [float(s) for s in spec["rve"]["size"]]
    size[axis] *= copies * (1.0 + 2.0 * aux)
    diag = math.sqrt(sum(s * s for s in size))
    d = min(fb["diameter"] for fb in spec["fibers"])
    flow["edge_length"] = fac * EDGE_PER_DIAMETER * d / diag
    return flow


def run(kind: str, flow_dir: str, phi: float, fac: float, n: int) -> dict:
    """One solve, as a JSON-able row."""
    row = {"kind": kind, "flow": flow_dir, "phi": phi, "fac": fac, "n": n}
    t0 = time.perf_counter()
    try:
        spec = spec_of(kind, flow_dir, phi, n)
        built = build_rve(spec)
        fields = built.voxelize(spec["rve"]["voxel"])
        d = "z" if flow_dir == "along" else "x"
        spec["flow"] = with_edge(spec, built.rve, fields, "xyz".index(d), fac)
        res = permeability(built.rve, fields, d, spec["flow"], "fem")
    except Exception as exc:  # noqa: BLE001 - the row records the refusal
        row.update(refused=f"{type(exc).__name__}: {exc}"[:400], t=time.perf_counter() - t0)
        row["trace"] = traceback.format_exc(limit=3)[-600:]
        return row
    k_true, source = truth(kind, flow_dir, phi)
    k = float(res["permeability_m2"])
    est = res["error_estimate"]
    q = res.get("mesh_quality") or {}
    diameter = min(fb["diameter"] for fb in spec["fibers"])
    row.update(
        k=k,
        truth=k_true,
        source=source,
        error=k / k_true - 1.0,
        bar=float(res["permeability_rel_error"]),
        status=res["status"],
        floor=est.get("floor"),
        richardson=est.get("richardson"),
        k_coarse=est.get("k_coarse"),
        ratio=est.get("ratio"),
        window=est.get("window"),
        field=est.get("field"),
        solver_term=est.get("solver"),
        method=est.get("method"),
        coarse_failure=est.get("coarse_failure"),
        h_bar_m=_fem_step(res, fields, built.rve, spec["flow"]),
        cells_per_diameter=res.get("cells_per_diameter"),
        edge_m=q.get("edge_length_m"),
        edge_fraction=q.get("edge_length_fraction"),
        edge_asked=spec["flow"].get("edge_length"),
        diameter_m=diameter,
        radius_flow_m=math.sqrt(8.0 * k / float(res["porosity"])),
        n_tets=res.get("n_tets"),
        porosity=float(res["porosity"]),
        t=time.perf_counter() - t0,
    )
    return row


def _others(r: dict) -> float:
    """The bar's terms other than the discretization's (window, solver, field)."""
    return float(r["window"] + r["solver_term"] + (r["field"] or 0.0))


def summary(path: Path, c: float) -> None:
    """Per set: the largest ``|error| / (h / R)^2`` with the other terms subtracted (the floor
    alone must cover it), and at floor ``c (h / R)^2`` the ``ok`` rows outside their bar
    (recomputed from the row's terms: ``max(floor, Richardson) + others``, the floor doubled for
    rows whose Richardson term is not a real second mesh, ``code`` "f7b018f") and the floor
    alone (doubled: no second mesh), the untrustworthy count and the median bar / |error|."""
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    for name in dict.fromkeys(r["set"] for r in rows):
        done = [r for r in rows if r["set"] == name and "refused" not in r]
        need, outside, ratios, unt = 0.0, [], [], 0
        for r in done:
            y = (r["edge_m"] / r["radius_flow_m"]) ** 2
            e = abs(r["error"])
            need = max(need, (e - _others(r)) / y)
            rich = None if r.get("code") == "f7b018f" else r["richardson"]
            floor = c * y * (2.0 if rich is None else 1.0)
            bar = max(floor, rich or 0.0) + _others(r)
            if bar > 0.2:
                unt += 1
                continue
            ratios.append(bar / e)
            if bar < e or 2.0 * c * y + _others(r) < e:
                outside.append(
                    (r["kind"], r["flow"], r["phi"], r["fac"], round(100 * r["error"], 2))
                )
        med = sorted(ratios)[len(ratios) // 2] if ratios else float("nan")
        print(
            f"{name}: {len(done)} rows, largest need {need:.4f}; at C = {c:g}: "
            f"{len(outside)} ok outside {outside}, {unt} untrustworthy, median bar/|error| "
            f"{med:.1f}"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", choices=sorted(SETS), default="calibration")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--only", type=int, nargs="*", help="indices into the set")
    ap.add_argument("--summary", type=Path, help="summarise a runs file instead of solving")
    ap.add_argument("--c", type=float, default=0.06, help="the floor constant to evaluate")
    a = ap.parse_args()
    if a.summary:
        summary(a.summary, a.c)
        return
    cases = SETS[a.set]
    idx = a.only if a.only else range(len(cases))
    for _ in range(a.repeat):
        for i in idx:
            row = run(*cases[i])
            row["set"] = a.set
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
