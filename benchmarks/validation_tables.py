"""Write ``docs/validation.md``: K and its error bar against published values.

Usage::

    python benchmarks/validation_tables.py            # default grid (about 10 min on 2 cores)
    python benchmarks/validation_tables.py --full     # more solid fractions and resolutions
    python benchmarks/validation_tables.py --out /tmp/validation.md

Tables: square and hexagonal cylinder arrays, flow along and across the cylinders, at several
solid fractions and resolutions, both solvers and both boundary-condition models (a model a
route cannot apply yet is recorded as ``n/a: <reason>``, so new models appear when they land),
with the reported error bar beside the true error against Sangani & Acrivos (1982, Table 1),
Drummond & Tahir (1984) and the Sparrow & Loeffler (1959) series for flow along the cylinders
(``tests/reference_values.py``, ``tests/arrays.py``); and a random Toray-like RVE family (seed
scatter) with the voxel route's bar beside its error against a solve at half the voxel size.

This is the VALIDATION set of the error bar: its resolutions (24/48 voxels per spacing square,
41/82 hexagonal: cell widths within 0.02 % of sqrt(3) L) and its hexagonal arrays are not in the
calibration set of ``benchmarks/calibrate_error_bar.py`` (square arrays at 20/32/40), so the
coverage reported here is out of sample. The voxel permeameter RVEs are two cells long along the
flow (the windowed drop is exact in the periodic interior for two or more cells,
``docs/permeability.md``).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from alignment_floor import alignment_section  # noqa: E402
from arrays import L, along_array_k, array_spec, exact_k, radius_of  # noqa: E402
from voxel_convergence import convergence_section, width_section  # noqa: E402

from psdesign.flow.permeability import BC_MODELS, permeability  # noqa: E402
from psdesign.packing.build import build_rve  # noqa: E402
from psdesign.schema.spec import validate_spec  # noqa: E402

#: (array, flow, solid fractions, voxels per spacing) of the voxel route.
VOXEL_GRID = {
    False: [
        ("square", "across", (0.1, 0.3, 0.5), (24, 48)),
        ("square", "along", (0.1, 0.3), (24, 48)),
        ("hex", "across", (0.1, 0.2), (41, 82)),
        ("hex", "along", (0.1, 0.3), (41, 82)),
    ],
    True: [
        ("square", "across", (0.1, 0.2, 0.3, 0.4, 0.5), (24, 32, 48, 64)),
        ("square", "along", (0.1, 0.2, 0.3, 0.4), (24, 32, 48, 64)),
        ("hex", "across", (0.1, 0.2, 0.3), (41, 56, 82, 112)),
        ("hex", "along", (0.1, 0.2, 0.3), (41, 56, 82, 112)),
    ],
}
#: (array, flow, solid fraction, voxels per spacing, cells along the flow, lattice step / L[,
#: cells across x for flow along]). The hexagonal array along the cylinders is 3 cells wide: one
#: or two cells wide, the lattice mesher's periodic y faces did not match (PeriodicMeshError,
#: in-plane mismatch 0.45-0.49, 2026-12-01), three cells wide they do.
FEM_GRID = {
    False: [
        ("square", "across", 0.2, 40, 3, 0.05),
        ("square", "along", 0.2, 40, 1, 0.05),
        ("hex", "across", 0.2, 52, 3, 0.05),
        ("hex", "along", 0.2, 52, 1, 0.05, 3),
    ],
    True: [("square", "across", phi, 40, 3, 0.05) for phi in (0.1, 0.2, 0.3, 0.5)]
    + [("square", "along", phi, 40, 1, 0.05) for phi in (0.1, 0.3)]
    + [("hex", "along", 0.2, 52, 1, 0.05)],
}
RANDOM_SEEDS = {False: (1, 2, 3), True: (1, 2, 3, 4, 5)}
#: Cells along the flow of the voxel permeameter RVEs.
PERMEAMETER_CELLS = 2


def reference_k(kind: str, flow: str, phi: float) -> float:
    """Published K (m^2): along the cylinders the Sparrow & Loeffler (1959) collocation series
    (``arrays.along_array_k``; it agrees with Drummond & Tahir's dilute expansion to 1e-4 at
    phi 0.1 and is exact where that expansion is 0.26 % off at phi 0.3), else ``exact_k``."""
    if flow == "along":
        lattice = "square" if kind == "square" else "hexagonal"
        return along_array_k(phi, lattice) * radius_of(phi, lattice, spacing=L) ** 2
    return exact_k(kind, flow, phi)


def _fmt_pct(x: float | None) -> str:
    return "" if x is None else f"{100 * x:+.2f} %"


#: Per-row cache directory (``--cache``; None: solve every row) and the sections to run.
CACHE: Path | None = None
ONLY: set[str] | None = None
#: ``--cache-only``: a row without a cache file is reported as not run instead of solved.
CACHE_ONLY = False
#: ``--reverse``: solve a section's rows last first (a second process fills the cache from the end).
REVERSE = False
NOT_RUN = "not run (no cached row: machine time)"


def _cached(key: str, compute):
    """``compute()`` (a JSON-able result), stored under ``CACHE`` by ``key`` so that an
    interrupted or split run (``--only``) is resumed instead of solved again."""
    if CACHE is None:
        return compute()
    import json
    import re

    from psdesign.io.atomic import write_json

    path = CACHE / (re.sub(r"[^A-Za-z0-9.]+", "_", key) + ".json")
    if path.exists():
        return json.loads(path.read_text())["value"]
    if CACHE_ONLY:
        return NOT_RUN
    value = compute()
    CACHE.mkdir(parents=True, exist_ok=True)
    write_json(path, {"key": key, "date": time.strftime("%Y-%m-%d %H:%M"), "value": value})
    return json.loads(path.read_text())["value"]


def _wanted(section: str) -> bool:
    return ONLY is None or section in ONLY


def _solve(spec: dict, direction: str, solver: str, bc: str) -> dict | str:
    # the solver in the spec too: its checks (e.g. the FEM memory budget of the permeameter
    # copies) are those of the route that solves it
    spec = validate_spec({**spec, "flow": {**spec["flow"], "solver": solver}})
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    flow = {**spec["flow"], "bc": bc}
    try:
        return permeability(built.rve, fields, direction, flow, solver)
    except (NotImplementedError, ValueError) as exc:
        return f"n/a: {exc}"


def _row(case: str, res: dict | str, exact: float | None) -> tuple[str, bool | None]:
    if isinstance(res, str):
        return f"| {case} | {res} | | | | | | |", None
    k = res["permeability_m2"]
    true = None if exact is None else k / exact - 1.0
    bar = res["permeability_rel_error"]
    covered = None if true is None else abs(true) <= bar
    cov = "" if covered is None else ("yes" if covered else "**no**")
    window = res["error_estimate"].get("window") or 0.0
    return (
        f"| {case} | {k:.4e} | {_fmt_pct(true)} | {100 * bar:.2f} % | "
        f"{100 * window:.2f} % | {cov} | {res['status']} | {res['iterations']} |",
        covered,
    )


HEADER = (
    "| case | K (m^2) | true error | error bar | of which window | covered | status | "
    "iterations |\n|---|---|---|---|---|---|---|---|"
)


def array_tables(full: bool) -> tuple[list[str], list[bool]]:
    """Markdown lines of the cylinder-array tables and the coverage flags."""
    lines, cover = [], []
    for solver in ("voxel", "fem"):
        for bc in BC_MODELS:
            lines += ["", f"### {solver}, bc = {bc}", "", HEADER]
            cases = []
            if solver == "voxel":
                cells = PERMEAMETER_CELLS if bc == "permeameter" else 1
                for kind, flow, phis, ns in VOXEL_GRID[full]:
                    cases += [(kind, flow, phi, n, cells, None, 1) for phi in phis for n in ns]
            else:
                cases = [(*c, 1) if len(c) == 6 else c for c in FEM_GRID[full]]
            if not _wanted(f"{solver}-{bc}"):
                continue
            for kind, flow, phi, n, cells, step, wide in cases[::-1] if REVERSE else cases:
                along = flow == "along"
                depth = cells * n if along and (solver == "fem" or cells > 1) else None
                spec = array_spec(
                    kind, phi, n, n_cells=wide if along else cells, depth_voxels=depth
                )
                if step is not None:
                    spec["flow"]["lattice_step"] = step * 40e-6
                name = f"{kind} {flow}, phi {phi:g}, {n} voxels/L" + (
                    f", {cells} cells" if cells > 1 or step else ""
                )
                name += f", lattice L/{1 / step:g}" if step else ""
                name += f", {wide} cells wide" if wide > 1 else ""
                t0 = time.perf_counter()
                direction = "x" if flow == "across" else "z"
                res = _cached(f"{solver} {bc} {name}", partial(_solve, spec, direction, solver, bc))
                line, ok = _row(name, res, reference_k(kind, flow, phi))
                print(f"{line}  ({time.perf_counter() - t0:.1f} s)", flush=True)
                lines.append(line)
                if ok is not None:
                    true = res["permeability_m2"] / reference_k(kind, flow, phi) - 1.0
                    meta = (solver, bc, f"{kind} {flow}, phi {phi:g}", n)
                    cover.append((f"{solver} {bc}: {name}", ok, true, res, meta))
                if isinstance(res, str) and res != NOT_RUN:  # the route cannot apply this model
                    break
    return lines, cover


#: Voxels per spacing from which a row counts as resolved (issue 12 item 3: within 1 % there).
RESOLVED_VOXELS = 40
#: A non-monotone pair whose two errors are both within this is counted as settled: the
#: sub-voxel walls' alignment scatter at 24-48 voxels per spacing (spread up to 0.4 % over
#: sub-voxel shifts, measured per resolution by ``benchmarks/alignment_floor.py``) decides the
#: sign of such a change.
SETTLED = 0.0025


def accuracy_summary(cover: list) -> list[str]:
    """Markdown lines: the worst |true error| of each solver at ``RESOLVED_VOXELS`` or more voxels
    per spacing, and for every voxel array case whether the error falls monotonically from the
    coarse to the fine resolution (same sign, smaller magnitude: K approaches the published
    value without crossing it)."""
    lines = ["", "## Accuracy at the resolved resolutions and convergence", ""]
    for solver in ("voxel", "fem"):
        rows = [c for c in cover if c[4][0] == solver and c[4][3] >= RESOLVED_VOXELS]
        if not rows:
            continue
        worst = max(rows, key=lambda c: abs(c[2]))
        within = sum(abs(c[2]) <= 0.01 for c in rows)
        lines.append(
            f"- {solver}: worst |true error| at >= {RESOLVED_VOXELS} voxels per spacing "
            f"{100 * abs(worst[2]):.2f} % ({worst[0]}); {within} of {len(rows)} rows within 1 %."
        )
    cases: dict[tuple, list] = {}
    for _, _, true, _, (solver, bc, case, n) in cover:
        if solver == "voxel":
            cases.setdefault((bc, case), []).append((n, true))
    lines += [
        "",
        "Voxel route between its two resolutions ('monotone': the finer grid's error has the "
        "same sign and a smaller magnitude, so K approaches the published value without "
        "crossing it):",
        "",
        "| bc | case | voxels/L | true error | voxels/L | true error | monotone |",
        "|---|---|---|---|---|---|---|",
    ]
    n_mono = n_settled = 0
    for (bc, case), pts in cases.items():
        if len(pts) < 2:
            continue
        (n0, e0), (n1, e1) = sorted(pts)[:2]
        mono = e0 * e1 > 0 and abs(e1) < abs(e0)
        settled = not mono and max(abs(e0), abs(e1)) <= SETTLED
        n_mono += mono
        n_settled += settled
        word = "yes" if mono else ("no (settled)" if settled else "**no**")
        lines.append(f"| {bc} | {case} | {n0} | {_fmt_pct(e0)} | {n1} | {_fmt_pct(e1)} | {word} |")
    total = sum(len(p) >= 2 for p in cases.values())
    lines += [
        "",
        f"Monotone in {n_mono} of {total} voxel array cases; of the others {n_settled} have "
        f"both errors within {100 * SETTLED:g} % (the sign of a change that small is set by "
        "the effects below, not by the resolution). The hexagonal rows are at near-whole "
        "resolutions since session 5 (section 'Hexagonal cell width': at the former 30 and 52 "
        "voxels per spacing the builder's rounded cell moved K by +-0.13-0.22 %, opposite "
        "signs, which alone made every hexagonal pair cross), and a cut cell with a single "
        "fluid face no longer pins that face to zero velocity (`solvers/voxel/boundary.py`, "
        "`pressure_cells`; square across at 0.3, 32 voxels per spacing: -0.38 % before, -0.16 % "
        "after). What makes the rest cross, measured (`benchmarks/voxel_alignment.py`, "
        "`benchmarks/voxel_scatter.py`, `benchmarks/RESULTS.md`): (1) the sub-voxel walls' "
        "alignment scatter: K depends on where the wall cuts the cells, by a standard "
        "deviation over sub-voxel shifts of the array of 0.03-0.09 % at 32 voxels per "
        "spacing and 0.01-0.03 % at 64 on the square arrays (section 'Alignment floor' below); "
        "taken apart on an assembled model of the operator, it is not the wall fractions "
        "theta (exact ones from the analytic distance: same scatter), the cut-volume weights "
        "(exact control-volume fractions or face apertures: 2-3x more), the lone-cell release "
        "(kept or merged instead: same or more) nor how K is read from the field; it is how "
        "the face-centred velocity nodes sample the wall, and no single change tried halved it "
        "at every solid fraction (along the cylinders a THETA_MIN of 0.005-0.01 cuts it 3-5x "
        "at 0.3 but not at 0.1, and makes it larger across); (2) "
        "the permeameter's window residual (hexagonal across at 0.1, two cells: -0.32 % at "
        "every resolution, docs/permeability.md), the one pair outside the 0.25 % band; (3) "
        "the published values' own accuracy: hexagonal across at 0.2 settles at +0.01 to "
        "-0.16 % of Drummond & Tahir's dilute series from 56 to 112 voxels per spacing (at "
        "0.1: -0.03 to +0.01 % from 82 to 112); (4) the hexagonal cell widths of the "
        "near-whole resolutions, still -0.020 % (41, 82) and +0.005 % (56) off: -0.04 to "
        "-0.06 % and +0.01 % of K at the measured slopes d ln K / d ln width of 1.8-2.9.",
    ]
    return lines


def _random_spec(seed: int) -> dict:
    return {
        "rve": {"size": [40e-6, 40e-6, 40e-6], "voxel": 1e-6},
        "generator": {
            "kind": "straight",
            "porosity": 0.85,
            "porosity_tolerance": RANDOM_POROSITY_TOLERANCE,
            "diameter": 7e-6,
            "seed": seed,
            "theta": {"dist": "uniform", "low": -5.0, "high": 5.0},
            "omega": {"dist": "uniform", "low": 0.0, "high": 180.0},
        },
        "intersections": {"method": "fast", "min_gap": 0.5e-6},
        "flow": {"viscosity": 1.8e-5, "solver": "voxel"},
    }


#: The bounded 'fast' placement reaches 0.850-0.857 on the voxel grid for seeds 1-5 (it cannot
#: reach 0.85 +- 0.005 for 4 of them: the closest is 0.857), so the family's tolerance is 0.01.
RANDOM_POROSITY_TOLERANCE = 0.01


def _random_pair(seed: int, bc: str) -> dict:
    """One seed of the random family: the result at 1 um and K at 0.5 um (the reference)."""
    spec = validate_spec(_random_spec(seed))
    try:
        built = build_rve(spec)
    except ValueError as exc:
        return {"error": " ".join(str(exc).split())}
    flow = {**spec["flow"], "bc": bc}
    res = permeability(built.rve, built.voxelize(1e-6), "z", flow, "voxel")
    ref = permeability(
        built.rve, built.rve.voxelize(0.5e-6), "z", flow, "voxel", error_estimate=False
    )
    return {"res": res, "k_ref": ref["permeability_m2"]}


def random_family(full: bool) -> list[str]:
    """Seed scatter of a small Toray-like RVE (quickstart base, 40 um) with the voxel route,
    both boundary-condition models."""
    lines = []
    for bc in BC_MODELS:
        lines += [
            "",
            f"### bc = {bc}",
            "",
            "| seed | porosity | K_z (m^2) | error bar | K_z at half the voxel | error vs it | "
            "covered | status |",
            "|---|---|---|---|---|---|---|---|",
        ]
        ks, bars, errs = [], [], []
        if not _wanted(f"random-{bc}"):
            continue
        for seed in RANDOM_SEEDS[full]:
            got = _cached(
                f"random {bc} seed {seed}", lambda seed=seed, bc=bc: _random_pair(seed, bc)
            )
            if got == NOT_RUN:
                got = {"error": NOT_RUN}
            if "error" in got:  # e.g. the porosity target not reached with bounded moves
                lines.append(f"| {seed} | n/a: {got['error']} | | | | | | |")
                print(lines[-1], flush=True)
                continue
            res, kr = got["res"], got["k_ref"]
            k = res["permeability_m2"]
            true = k / kr - 1.0
            ks.append(k)
            bars.append(res["permeability_rel_error"])
            errs.append(abs(true))
            cov = "yes" if abs(true) <= res["permeability_rel_error"] else "**no**"
            line = (
                f"| {seed} | {res['porosity']:.4f} | {k:.4e} | "
                f"{100 * res['permeability_rel_error']:.2f} % | {kr:.4e} | {_fmt_pct(true)} | "
                f"{cov} | {res['status']} |"
            )
            print(line, flush=True)
            lines.append(line)
        ks = np.array(ks)
        scatter = 100 * ks.std(ddof=1) / ks.mean() if len(ks) > 1 else float("nan")
        lines += [
            "",
            f"Seed scatter of K_z ({bc}): mean {ks.mean():.4e} m^2, standard deviation "
            + (f"{scatter:.1f} %" if len(ks) > 1 else "n/a")
            + f" of the mean over {len(ks)} seeds; median error bar "
            f"{100 * float(np.median(bars)):.2f} %, median |error vs half the voxel| "
            f"{100 * float(np.median(errs)):.2f} %.",
        ]
    lines += [
        "",
        "The error against half the voxel understates the true error (the reference has its own, "
        "about a quarter as large for the second-order sub-voxel walls). 7 voxels per fiber "
        "diameter is below the 8 the route asks for, so the status is 'untrustworthy' by that "
        "rule whatever the bar.",
    ]
    return lines


#: ``--load``: the machine load while the rows were solved (for the header).
LOAD = "not recorded"


def _how(seconds: float) -> str:
    """How the rows were solved: one run's wall time, or the cache's dates."""
    if CACHE is None or not CACHE.exists():
        return f"{seconds:.0f} s"
    import json

    dates = sorted(json.loads(f.read_text())["date"] for f in CACHE.glob("*.json"))
    span = f"{dates[0]} to {dates[-1]} UTC" if dates else "none"
    return (
        f"rows solved {span} into `--cache {CACHE.name}` by split `--only` runs under machine "
        f"load {LOAD} on 2 cores"
    )


RANDOM_HEADING = "## Random Toray-like RVE family (voxel route)"


def replace_random_section(out: Path, full: bool) -> int:
    """Re-render the random family's rows (from ``CACHE``, nothing solved) into ``out`` in
    place, keeping every other section, and say so under the file's first line."""
    global CACHE_ONLY
    CACHE_ONLY = True
    text = out.read_text()
    head, sep, tail = text.partition(RANDOM_HEADING)
    if not sep:
        raise SystemExit(f"{out}: no section {RANDOM_HEADING!r}")
    intro, _, _ = tail.partition("\n\n### bc = ")
    rnd = random_family(full)
    note = (
        f"The random family's rows were re-solved on their own into `--cache {CACHE.name}` "
        f"({_how(0.0).partition(' into')[0].removeprefix('rows solved ')}, load {LOAD}; "
        "`--only random-permeameter random-periodic`, then `--replace-random`)."
    )
    lines = head.split("\n")
    old = [i for i, ln in enumerate(lines) if ln.startswith("The random family's rows were")]
    if old:
        lines[old[0]] = note
    else:
        lines[3:3] = ["", note]  # under the "Generated by" line
    out.write_text("\n".join(lines) + sep + intro + "\n" + "\n".join(rnd) + "\n")
    print(f"wrote {out}: random family from {CACHE}")
    return 0


#: Why and when the FEM periodic rows were solved again on their own (session 37, s37-valid):
#: the header note of ``--replace-fem-periodic``. The run's dates come from the cache files.
FEM_PERIODIC_WHY = (
    "session 35 (a612f76, merged adc09bd 2026-12-05 12:54 UTC) let the stuffing mesher's "
    "periodic face vertices move within their face, and these rows were solved before it; "
    "the FEM permeameter meshes have no periodic faces and did not change (session 37), so "
    "those rows and every voxel row keep their solves. The cache of the other rows "
    "(`vcache15`, in /tmp) is gone, so the rest of the file is kept as it was, not "
    "re-rendered. K moved by at most +0.016 % (hex along: 5.4115e-11 -> 5.4123e-11; the "
    "others by +0.000 to +0.007 %, on the old rows' printed digits), no covered flag and no "
    "summary figure but the worst FEM error (0.37 -> 0.36 %) changed; the iterations are "
    "fewer than on 2026-12-03 (58 / 54 / 89 / 83 -> 46 / 41 / 49 / 40)"
)
FEM_PERIODIC_HEADING = "### fem, bc = periodic"


def _table_rows(lines: list[str], heading: str) -> tuple[int, int]:
    """``(first, end)`` line indices of the data rows of the table under ``heading``."""
    if heading not in lines:
        raise SystemExit(f"no section {heading!r}")
    first = lines.index(heading) + 4  # blank, header, separator
    end = first
    while end < len(lines) and lines[end].startswith("| "):
        end += 1
    return first, end


def _cells(row: str) -> list[str]:
    return [c.strip() for c in row.strip().strip("|").split("|")]


def _pct(cell: str) -> float:
    return float(cell.removesuffix("%").strip()) / 100.0


def _check_coverage_line(lines: list[str], old: list[str], new: list[str]) -> None:
    """Refuse (SystemExit) unless the coverage line stays true with ``new`` rows for ``old``:
    the same covered flags, and every replaced bar and |true error| on the same side of the
    printed medians (the medians of the other rows' unrounded values are then unchanged)."""
    import re

    cov = next(ln for ln in lines if ln.startswith("**Coverage: "))
    m = re.search(r"Median error bar ([0-9.]+) %, median \|true error\| ([0-9.]+) %", cov)
    if m is None:
        raise SystemExit("no medians in the coverage line")
    med_bar, med_true = (float(g) / 100.0 for g in m.groups())
    for a, b in zip(old, new, strict=True):
        ca, cb = _cells(a), _cells(b)
        if ca[0] != cb[0] or ca[5] != cb[5]:
            raise SystemExit(f"row {ca[0]!r} -> {cb[0]!r}, covered {ca[5]} -> {cb[5]}: run all")
        for col, med in ((3, med_bar), (2, med_true)):
            va, vb = abs(_pct(ca[col])), abs(_pct(cb[col]))
            if (va - med) * (vb - med) <= 0:
                raise SystemExit(f"{cb[0]}: {ca[col]} -> {cb[col]} crosses a median: run all")


def _fem_accuracy_line(lines: list[str]) -> str:
    """The ``- fem:`` line of :func:`accuracy_summary` from the FEM tables' printed rows."""
    rows = []
    for bc in BC_MODELS:
        first, end = _table_rows(lines, f"### fem, bc = {bc}")
        for row in lines[first:end]:
            c = _cells(row)
            n = int(c[0].split(" voxels/L")[0].rsplit(" ", 1)[1])
            if c[1].startswith(("n/a", "not run")) or n < RESOLVED_VOXELS:
                continue
            rows.append((f"fem {bc}: {c[0]}", _pct(c[2])))
    worst = max(rows, key=lambda r: abs(r[1]))
    within = sum(abs(t) <= 0.01 for _, t in rows)
    return (
        f"- fem: worst |true error| at >= {RESOLVED_VOXELS} voxels per spacing "
        f"{100 * abs(worst[1]):.2f} % ({worst[0]}); {within} of {len(rows)} rows within 1 %."
    )


def replace_fem_periodic(out: Path, full: bool) -> int:
    """Re-render only the ``fem, bc = periodic`` rows of ``out`` from ``CACHE`` (nothing solved;
    rows solved with ``--only fem-periodic``), the FEM accuracy line from the FEM tables, and a
    note under the file's first line (which rows, when, ``--load``, :data:`FEM_PERIODIC_WHY`);
    every other line is kept. Refuses if the coverage line would change (run the whole file)."""
    global CACHE_ONLY, ONLY
    CACHE_ONLY, ONLY = True, {"fem-periodic"}
    lines = out.read_text().split("\n")
    first, end = _table_rows(lines, FEM_PERIODIC_HEADING)
    fresh = "\n".join(array_tables(full)[0]).split("\n")  # HEADER is two lines
    new_first, new_end = _table_rows(fresh, FEM_PERIODIC_HEADING)
    new = fresh[new_first:new_end]
    if any(NOT_RUN in row for row in new):
        raise SystemExit(f"{CACHE}: a fem periodic row is not in the cache")
    _check_coverage_line(lines, lines[first:end], new)
    lines[first:end] = new
    i = next(i for i, ln in enumerate(lines) if ln.startswith("- fem: worst |true error|"))
    lines[i] = _fem_accuracy_line(lines)
    span = _how(0.0).partition(" into")[0].removeprefix("rows solved ")
    note = (
        f"The {len(new)} fem, bc = periodic rows were re-solved on their own into `--cache "
        f"{CACHE.name}` ({span}, load {LOAD}, one thread, `nice -n 19`; `--only fem-periodic`, "
        f"then `--replace-fem-periodic`): {FEM_PERIODIC_WHY}."
    )
    old = [i for i, ln in enumerate(lines) if ln.startswith("The 4 fem, bc = periodic rows")]
    if old:
        lines[old[0]] = note
    else:
        lines[3:3] = ["", note]  # under the "Generated by" line
    out.write_text("\n".join(lines))
    print(f"wrote {out}: fem periodic rows from {CACHE}")
    return 0


def _parser() -> argparse.ArgumentParser:
    """The command line of :func:`main`."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", action="store_true", help="more solid fractions and resolutions")
    ap.add_argument("--out", default=str(ROOT / "docs" / "validation.md"))
    ap.add_argument("--cache", default=None, help="per-row cache directory (resumable runs)")
    ap.add_argument(
        "--only",
        nargs="+",
        default=None,
        help="sections to solve into --cache without writing the file: voxel-permeameter "
        "voxel-periodic fem-permeameter fem-periodic random-permeameter random-periodic "
        "width convergence alignment",
    )
    ap.add_argument(
        "--cache-only", action="store_true", help="write the file from --cache without solving"
    )
    ap.add_argument("--reverse", action="store_true", help="rows of a section last first")
    ap.add_argument("--load", default=None, help="machine load during the runs (header text)")
    ap.add_argument(
        "--replace-random",
        action="store_true",
        help="re-render only the random family's section of --out from --cache (its rows "
        "solved with --only random-permeameter random-periodic); the rest of the file is kept",
    )
    ap.add_argument(
        "--replace-fem-periodic",
        action="store_true",
        help="re-render only the fem, bc = periodic rows of --out from --cache (solved with "
        "--only fem-periodic) and the FEM accuracy line; the rest of the file is kept",
    )
    return ap


def _coverage(cover: list) -> tuple[int, list[float], list[float], list[str]]:
    """Of the array results: how many the bar covers, the bars, the |true errors|, and one line
    per result the bar misses."""
    n_cov = sum(c[1] for c in cover)
    misses = [c for c in cover if not c[1]]
    bars = [c[3]["permeability_rel_error"] for c in cover]
    trues = [abs(c[2]) for c in cover]
    miss_lines = [
        f"- {name}: true error {_fmt_pct(true)}, bar {100 * res['permeability_rel_error']:.2f} % "
        f"(two-grid {_fmt_pct(res['error_estimate']['richardson'])}, floor "
        f"{100 * res['error_estimate']['floor']:.2f} %, window "
        f"{100 * (res['error_estimate'].get('window') or 0):.2f} %)"
        for name, _, true, res, _ in misses
    ]
    return n_cov, bars, trues, miss_lines


def main(argv: list[str] | None = None) -> int:
    """Run the tables and write the markdown file."""
    args = _parser().parse_args(argv)
    global CACHE, ONLY, CACHE_ONLY, REVERSE, LOAD
    LOAD = args.load or LOAD
    REVERSE = args.reverse
    CACHE_ONLY = args.cache_only
    CACHE = None if args.cache is None else Path(args.cache)
    ONLY = None if args.only is None else set(args.only)
    if args.replace_random:
        return replace_random_section(Path(args.out), args.full)
    if args.replace_fem_periodic:
        return replace_fem_periodic(Path(args.out), args.full)
    t0 = time.perf_counter()
    arrays, cover = array_tables(args.full)
    rnd = random_family(args.full)
    extra = []
    if _wanted("width"):
        extra += width_section(_cached, reference_k, NOT_RUN)
    if _wanted("convergence"):
        extra += convergence_section(_cached, reference_k, NOT_RUN, SETTLED)
    if _wanted("alignment"):
        extra += alignment_section(_cached, reference_k, NOT_RUN)
    if ONLY is not None:
        print(f"solved {sorted(ONLY)} into {CACHE}; run without --only to write the file")
        return 0
    n_cov, bars, trues, miss_lines = _coverage(cover)
    tight = float(np.median(bars) / max(np.median(trues), 1e-12))
    text = [
        "# Validation: permeability and its error bar against published values",
        "",
        f"Generated by `python benchmarks/validation_tables.py{' --full' if args.full else ''}` "
        f"({_how(time.perf_counter() - t0)}, {platform.node()}, {time.strftime('%Y-%m-%d')}). "
        "Do not edit by hand.",
        "",
        "References (`tests/reference_values.py`, `tests/arrays.py`): square array across the "
        "cylinders: Sangani & Acrivos (1982), Int. J. Multiphase Flow 8, 193-206, Table 1; "
        "hexagonal across (dilute series, phi <= 0.3): Drummond & Tahir (1984), Int. J. "
        "Multiphase Flow 10, 515-540; along the cylinders (square and hexagonal): the collocation "
        "series of Sparrow & Loeffler (1959), AIChE J. 5, 325-330 (it agrees with Drummond & "
        "Tahir's dilute expansion to 1e-4 at phi 0.1; that expansion is 0.26 % high at phi 0.3). "
        "Permeameter RVEs (voxel route) are 2 cells long along the flow; their pressure drop is "
        "the windowed dissipation with the flat-top window of whole periods "
        "(docs/permeability.md). Arrays: spacing "
        "L = 40 um; "
        "'voxels/L' voxels per spacing; the error bar is `permeability_rel_error` "
        "(docs/permeability.md); 'covered' = |true error| <= error bar; a boundary-condition "
        "model a route cannot apply yet is recorded as n/a with the reason.",
        "",
        f"**Coverage: {n_cov} of {len(cover)} array results "
        f"({100 * n_cov / max(1, len(cover)):.0f} %) have |true error| <= error bar.** "
        f"Median error bar {100 * float(np.median(bars)):.2f} %, median |true error| "
        f"{100 * float(np.median(trues)):.2f} % (ratio {tight:.1f}). The bar's constants were "
        "calibrated on a different set (`benchmarks/calibrate_error_bar.py`: square arrays at "
        "20, 32 and 40 voxels per spacing; `psdesign/flow/error.py`).",
        "",
        "FEM against voxel on the same RVE and boundary condition (arrays, periodic random "
        "straight / bent / woven RVEs, every shipped spec): "
        "[solver-agreement.md](solver-agreement.md) (`benchmarks/solver_agreement.py`).",
        "",
        'The diffuse-domain wall (`flow.wall_treatment = "diffuse"`: monotone convergence) '
        "against the same references, beside the default sub-voxel wall at every sub-voxel "
        "shift: [validation-diffuse.md](validation-diffuse.md) "
        "(`benchmarks/diffuse_validation.py`).",
        "",
        *(["Cases the bar misses:", "", *miss_lines, ""] if miss_lines else []),
        "## Cylinder arrays",
        *arrays,
        *accuracy_summary(cover),
        *extra,
        "",
        "## Random Toray-like RVE family (voxel route)",
        "",
        "40 um cube, straight 7 um fibers, target porosity 0.85 +- "
        f"{RANDOM_POROSITY_TOLERANCE:g}, 'fast' intersection removal, voxel 1 um (7 voxels per "
        "diameter); reference: the same RVE at 0.5 um. The permeameter takes "
        '`flow.permeameter_copies = "auto"` (the stacked permeameter, `psdesign/flow/stack.py`: '
        "two copies of these one-period RVEs along the flow); the arrays above need no stack "
        "(two cells already hold two periods).",
        *rnd,
        "",
    ]
    Path(args.out).write_text("\n".join(text))
    print(f"wrote {args.out}: coverage {n_cov}/{len(cover)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
