"""Write ``docs/validation-diffuse.md``: the diffuse-domain wall against published array values.

Usage::

    python benchmarks/diffuse_validation.py                 # solve missing rows, write the page
    python benchmarks/diffuse_validation.py --only square   # solve one kind's rows only
    python benchmarks/diffuse_validation.py --cache-only    # write the page from the rows file

Issue 12 item 3: the voxel solver within 1 % of the published values at >= 40 voxels per
spacing for solid fractions 0.1-0.5, converging monotonically. Every row goes through the
product route (spec -> ``build_rve`` -> ``permeability``, ``flow.solver = "voxel"``, ``bc =
"periodic"``) with ``flow.wall_treatment = "diffuse"`` and, beside it, the default sub-voxel
(cut-face) wall on the same grid. The cylinders are moved off the cell centre by a sub-voxel
shift (a fraction of a voxel, the same at every resolution) so that the grid cuts them at a
different place at each resolution, as an arbitrary fibre would be cut; 'monotone' = |true
error| falls at every refinement. The error bar (``permeability_rel_error``, two grids) is
solved at two resolutions per case and set beside the true error.

References as ``docs/validation.md`` (``benchmarks/validation_tables.reference_k``): Sangani &
Acrivos (1982) square across, Drummond & Tahir (1984) hexagonal across, the Sparrow & Loeffler
(1959) series along. The hexagonal cell is L x sqrt(3) L wide (rounded to whole voxels at
these near-whole resolutions, ``arrays.HEX_NEAR_WHOLE``) and held by five cylinders whose
own copies do not repeat with the box: the walls are those of the box's content tiled
(``psdesign.geometry.walls.box_shifts``). Rows are stored in :data:`RUNS` (one JSON line per
row, keyed) and reused.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "benchmarks"), str(ROOT)]

from arrays import L, array_spec  # noqa: E402
from validation_tables import reference_k  # noqa: E402
from voxel_convergence import solve_array  # noqa: E402

from psdesign.schema.spec import validate_spec  # noqa: E402

RUNS = ROOT / "benchmarks" / "diffuse_validation_runs.jsonl"
#: (array, flow, solid fractions, voxels per spacing). Hexagonal: the near-whole resolutions
#: (``arrays.HEX_NEAR_WHOLE``; the cell width within 0.02 % of sqrt(3) L).
CASES = [
    ("square", "across", (0.1, 0.3, 0.5), (24, 32, 40, 48, 64)),
    ("square", "along", (0.1, 0.3, 0.5), (24, 32, 40, 48, 64)),
    ("hex", "across", (0.1, 0.3), (41, 56, 82)),
    ("hex", "along", (0.1, 0.3), (41, 56, 82)),
]
#: Sub-voxel shifts of every cylinder centre (fractions of a voxel along x and y).
SHIFTS = ((0.0, 0.0), (0.37, 0.21))
#: Resolutions whose row is solved with the error bar (two grids), per array kind.
BAR_AT = {"square": (24, 48), "hex": (41, 82)}
WALLS = ("diffuse", "subvoxel")
#: Resolutions over which 'monotone' is judged. Hexagonal: 41 and 82 voxels per spacing hold the
#: identical cell (71 and 142 voxels wide, -0.020 % of sqrt(3) L); at 56 it is 97 voxels wide,
#: +0.005 %, and K moves by 3.9 times the width error (measured, diffuse, across at 0.3: 71 ->
#: 72 voxels at 41, +1.41 % width, +5.5 % K), +0.1 % against 41 and 82: more than a refinement
#: step changes the error there, so 56 is shown but not judged.
MONOTONE_OVER = {"square": (24, 32, 40, 48, 64), "hex": (41, 82)}


def case_spec(kind: str, phi: float, n: int, shift: tuple[float, float], wall: str) -> dict:
    """The validated array spec with every centre moved by ``shift`` voxels."""
    spec = array_spec(kind, phi, n)
    h = L / n
    for fb in spec["fibers"]:
        c = list(fb["center"])
        fb["center"] = [c[0] + shift[0] * h, c[1] + shift[1] * h, *c[2:]]
    spec["flow"] |= {"solver": "voxel", "bc": "periodic", "wall_treatment": wall}
    return validate_spec(spec)


def solve(kind: str, flow: str, phi: float, n: int, shift, wall: str, bar: bool) -> dict:
    """One row: K, its error bar (when ``bar``), iterations, time."""
    res, shape, seconds = solve_array(case_spec(kind, phi, n, shift, wall), flow, bar)
    return {
        "k": res["permeability_m2"],
        "bar": res.get("permeability_rel_error") if bar else None,
        "status": res.get("status"),
        "iterations": res["iterations"],
        "converged": res["converged"],
        "wall_time_s": round(seconds, 2),
        "shape": shape,
    }


def _load() -> dict:
    if not RUNS.exists():
        return {}
    rows = [json.loads(line) for line in RUNS.read_text().splitlines() if line.strip()]
    return {r["key"]: r for r in rows}


def rows(only: str | None, cache_only: bool) -> dict:
    """Every row of :data:`CASES` x :data:`SHIFTS` x :data:`WALLS`, solving the missing ones
    (appended to :data:`RUNS` as they finish)."""
    done = _load()
    for kind, flow, phis, ns in CASES:
        for phi in phis:
            for n in ns:
                for shift in SHIFTS:
                    for wall in WALLS:
                        key = f"{kind} {flow} {phi:g} {n} {shift[0]:g},{shift[1]:g} {wall}"
                        if key in done or cache_only or (only and only != kind):
                            continue
                        bar = n in BAR_AT[kind]
                        value = solve(kind, flow, phi, n, shift, wall, bar)
                        row = {"key": key, "date": time.strftime("%Y-%m-%d %H:%M"), **value}
                        with RUNS.open("a") as f:
                            f.write(json.dumps(row) + "\n")
                        done[key] = row
                        print(key, f"{value['k']:.6e}", value["wall_time_s"], "s", flush=True)
    return done


def _pct(x: float) -> str:
    return f"{100 * x:+.3f} %"


def _case_lines(done: dict, kind, flow, phi, ns, summary) -> list[str]:
    ref = reference_k(kind, flow, phi)
    lines = []
    for shift in SHIFTS:
        errs = {w: [] for w in WALLS}
        for n in ns:
            got = {
                w: done.get(f"{kind} {flow} {phi:g} {n} {shift[0]:g},{shift[1]:g} {w}")
                for w in WALLS
            }
            if any(g is None for g in got.values()):
                lines.append(f"| {kind} {flow}, phi {phi:g} | {shift} | {n} | not run | | | | |")
                continue
            e = {w: got[w]["k"] / ref - 1.0 for w in WALLS}
            for w in WALLS:
                errs[w].append(abs(e[w]))
            d = got["diffuse"]
            bar = "" if d["bar"] is None else f"{100 * d['bar']:.2f} %"
            cov = "" if d["bar"] is None else ("yes" if abs(e["diffuse"]) <= d["bar"] else "**no**")
            lines.append(
                f"| {kind} {flow}, phi {phi:g} | {shift[0]:g}, {shift[1]:g} | {n} | "
                f"{_pct(e['diffuse'])} | {bar} | {cov} | {d['iterations']} | "
                f"{_pct(e['subvoxel'])} |"
            )
            if d["bar"] is not None:
                summary["bars"].append(abs(e["diffuse"]) <= d["bar"])
        if all(len(v) == len(ns) for v in errs.values()):
            for w in WALLS:
                seq = [x for n, x in zip(ns, errs[w], strict=True) if n in MONOTONE_OVER[kind]]
                mono = all(b < a for a, b in zip(seq, seq[1:], strict=False))
                summary[w].append(mono)
            at40 = [x for n, x in zip(ns, errs["diffuse"], strict=True) if n >= 40]
            summary["within1"].append(max(at40) <= 0.01)
    return lines


def page(done: dict) -> str:
    """The markdown page from the rows."""
    summary = {"diffuse": [], "subvoxel": [], "bars": [], "within1": []}
    table = []
    for kind, flow, phis, ns in CASES:
        for phi in phis:
            table += _case_lines(done, kind, flow, phi, ns, summary)
    dates = sorted(r["date"] for r in done.values())
    span = f"{dates[0]} to {dates[-1]} UTC" if dates else "none"
    mono_d, mono_s = summary["diffuse"], summary["subvoxel"]
    head = [
        '# Validation: the diffuse-domain wall (`flow.wall_treatment = "diffuse"`)',
        "",
        f"Generated by `python benchmarks/diffuse_validation.py` (rows solved {span} on "
        f"{platform.machine()}, 2 cores; `{RUNS.relative_to(ROOT)}`). Do not edit by hand.",
        "",
        "\n\n".join(
            q.replace("\n", " ") for q in __doc__.split("\n\n") if q.startswith(("Issue", "Ref"))
        ),
        "",
        f"**Monotone convergence: diffuse wall {sum(mono_d)} of {len(mono_d)} case-shifts, "
        f"sub-voxel (cut-face) wall {sum(mono_s)} of {len(mono_s)}.** Diffuse within 1 % at every "
        f"resolution >= 40 voxels per spacing: {sum(summary['within1'])} of "
        f"{len(summary['within1'])}. Diffuse error bar covers the true error: "
        f"{sum(summary['bars'])} of {len(summary['bars'])}.",
        "",
        "Hexagonal cells: 'monotone' is judged from 41 to 82 voxels per spacing, which hold the "
        "identical cell (71 and 142 voxels wide, -0.020 % of sqrt(3) L); at 56 the cell is 97 "
        "voxels wide (+0.005 %) and K moves by 3.9 times the width error (measured), about "
        "+0.1 % against the other two, more than a refinement step changes the error there.",
        "",
        "| case | shift (voxels) | voxels/L | diffuse true error | diffuse error bar | covered | "
        "diffuse iterations | sub-voxel true error |",
        "|---|---|---|---|---|---|---|---|",
    ]
    return "\n".join(head + table) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", choices=("square", "hex"), default=None)
    ap.add_argument("--cache-only", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "docs" / "validation-diffuse.md"))
    args = ap.parse_args(argv)
    done = rows(args.only, args.cache_only)
    if args.only is None:
        Path(args.out).write_text(page(done))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
