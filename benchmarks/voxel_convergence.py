"""Two sections of ``docs/validation.md`` (written by ``benchmarks/validation_tables.py``): the
hexagonal cell width and the voxel route's convergence over several resolutions.

* ``width``: why the hexagonal rows used to cross the published value. ``sqrt(3) L`` is not a
  whole number of voxels; ``tests/arrays.array_spec`` rounds the cell width and stretches the
  lattice with it (the radius kept), a different array. The section solves the hexagonal array
  across at solid fraction 0.2 with the width deliberately one voxel narrower / wider, measures
  the slope ``d ln K / d ln width``, and compares the K at the rounded width of 40 voxels per
  spacing (69 for 69.28) with the K interpolated to the exact width.
* ``convergence``: ``bc = "periodic"``, sub-voxel walls, square arrays at 24-64 and hexagonal
  arrays at near-whole resolutions (``arrays.HEX_NEAR_WHOLE``), K error and MINRES iterations per
  resolution, with the staircase's iterations beside them (the iteration cost of the sub-voxel
  walls).

Both go through the product route (spec -> ``build_rve`` -> ``permeability``, no error estimate)
and the per-row cache of ``validation_tables.py`` (``--only width convergence``).
"""

from __future__ import annotations

import time
from collections.abc import Callable

from arrays import array_spec, hex_width_error

from psdesign.flow.permeability import permeability
from psdesign.packing.build import build_rve
from psdesign.schema.spec import validate_spec

#: (array, flow, solid fractions, voxels per spacing) of the convergence table. Hexagonal: the
#: resolutions whose cell width is within 0.02 % of sqrt(3) (15 is +0.074 %, the coarse start).
CONVERGENCE = [
    ("square", "across", (0.1, 0.3, 0.5), (24, 32, 40, 48, 64)),
    ("square", "along", (0.1, 0.3), (24, 32, 40, 48, 64)),
    ("hex", "across", (0.1, 0.2), (15, 41, 56, 82)),
    ("hex", "along", (0.1, 0.3), (15, 41, 56, 82)),
]
#: (voxels per spacing, cell width in voxels) of the width section, hexagonal across, phi 0.2.
WIDTH_CASES = [(40, 69), (40, 70), (41, 70), (41, 71), (41, 72), (30, 52), (52, 90)]
WIDTH_PHI = 0.2


def solve_array(spec: dict, flow: str, error_estimate: bool) -> tuple[dict, list[int], float]:
    """One voxel solve of a validated array spec through the product route, across (x) or along
    (z): the result, the grid's shape and the solve's wall time (s)."""
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    t0 = time.perf_counter()
    res = permeability(
        built.rve,
        fields,
        "x" if flow == "across" else "z",
        spec["flow"],
        "voxel",
        error_estimate=error_estimate,
    )
    return res, list(fields.grid.shape), time.perf_counter() - t0


def solve_periodic(kind: str, flow: str, phi: float, n: int, wall: str, width: int | None) -> dict:
    """K, iterations and wall time of one periodic voxel solve of the array (no error bar)."""
    spec = array_spec(kind, phi, n, width_voxels=width)
    spec["flow"] |= {"solver": "voxel", "bc": "periodic", "wall_treatment": wall}
    res, shape, seconds = solve_array(validate_spec(spec), flow, error_estimate=False)
    return {
        "k": res["permeability_m2"],
        "iterations": res["iterations"],
        "converged": res["converged"],
        "wall_time_s": seconds,
        "shape": res.get("grid_shape") or shape,
    }


def _pct(x: float) -> str:
    return f"{100 * x:+.3f} %"


def width_section(cached: Callable, reference_k: Callable, not_run: str) -> list[str]:
    """Markdown lines of the hexagonal-width section (rows from ``cached(key, compute)``)."""
    ref = reference_k("hex", "across", WIDTH_PHI)
    rows = {}
    for n, width in WIDTH_CASES:
        key = f"voxel periodic width hex across, phi {WIDTH_PHI:g}, {n} voxels/L, width {width}"
        got = cached(
            key, lambda n=n, w=width: solve_periodic("hex", "across", WIDTH_PHI, n, "subvoxel", w)
        )
        if got != not_run:
            rows[(n, width)] = got["k"] / ref - 1.0
    lines = [
        "",
        "## Hexagonal cell width (why the hexagonal rows crossed the published value)",
        "",
        "`sqrt(3) L` is not a whole number of voxels. The array builder (`tests/arrays.py`, "
        "`array_spec`) rounds the cell width and scales the cylinder centres with it (the radius "
        "kept): a lattice stretched along y by the rounding, a different array from the one "
        "published. Voxel route, bc = periodic, sub-voxel walls, hexagonal across at solid "
        f"fraction {WIDTH_PHI:g}, the width deliberately rounded either way:",
        "",
        "| voxels/L | cell width (voxels) | sqrt(3) x voxels/L | width error | true error |",
        "|---|---|---|---|---|",
    ]
    for (n, width), err in rows.items():
        lines.append(
            f"| {n} | {width} | {3**0.5 * n:.3f} | {_pct(hex_width_error(n, width))} | "
            f"{_pct(err)} |"
        )
    need = [(41, 70), (41, 72), (40, 69), (40, 70)]
    if not all(k in rows for k in need):
        return [*lines, "", f"(slope and interpolation: {not_run})"]
    slope = (rows[(41, 72)] - rows[(41, 70)]) / (hex_width_error(41, 72) - hex_width_error(41, 70))
    w69, w70 = hex_width_error(40, 69), hex_width_error(40, 70)
    exact40 = rows[(40, 69)] + (rows[(40, 70)] - rows[(40, 69)]) * (0 - w69) / (w70 - w69)
    lines += [
        "",
        f"Slope `d ln K / d ln width` (41 voxels, widths 70 and 72): {slope:.2f}. At 40 voxels "
        f"the rounded cell (69) is {_pct(w69)} narrow, which predicts {_pct(slope * w69)} "
        f"from the stretch alone; measured {_pct(rows[(40, 69)])}. Interpolated to the exact "
        f"width between 69 and 70 the error at 40 voxels is {_pct(exact40)}. So the -1.2 % at "
        "40 is the builder's stretched lattice, not the solver (a set-up artefact of the "
        "validation: the product refuses a box that is not a whole number of voxels, "
        "`flow/voxel.py`, and solves the stretched lattice it is given to the accuracy of the "
        "other rows). The former validation resolutions 30 and 52 are +0.074 % and -0.074 % "
        f"wide ({_pct(slope * hex_width_error(30))} and {_pct(slope * hex_width_error(52))} "
        "of K from the stretch at this slope, opposite signs): that made every hexagonal pair "
        "change sign. The hexagonal voxel rows now use 41 and 82 voxels per spacing (widths 71 "
        f"and 142, {_pct(hex_width_error(41))}, {_pct(hex_width_error(82))}). The FEM "
        "hexagonal rows stay at 52 (their lattice-mesher set-up; not re-solved): their cell "
        f"carries the -0.074 % stretch, about {_pct(slope * hex_width_error(52))} of K at this "
        "slope.",
    ]
    return lines


def convergence_section(
    cached: Callable, reference_k: Callable, not_run: str, settle: float = 0.0025
) -> list[str]:
    """Markdown lines of the multi-resolution convergence table; a refinement step whose two
    errors are both within ``settle`` counts as settled."""
    lines = [
        "",
        "## Convergence over resolutions (voxel, bc = periodic)",
        "",
        "Sub-voxel walls (the default) and, for the iteration cost, the staircase on the same "
        "grids. 'monotone': |true error| falls at every refinement. Hexagonal resolutions are "
        "the near-whole ones (`arrays.HEX_NEAR_WHOLE`; 15 is +0.074 % wide).",
        "",
        "| case | voxels/L | true error | iterations | staircase true error | staircase "
        "iterations |",
        "|---|---|---|---|---|---|",
    ]
    summary = []
    for kind, flow, phis, ns in CONVERGENCE:
        for phi in phis:
            ref = reference_k(kind, flow, phi)
            errs, its, its_st = [], [], []
            for n in ns:
                got = {}
                for wall in ("subvoxel", "staircase"):
                    name = f"{kind} {flow}, phi {phi:g}, {n} voxels/L, {wall}"
                    key = f"voxel periodic convergence {name}"
                    got[wall] = cached(
                        key,
                        lambda n=n, wall=wall, kind=kind, flow=flow, phi=phi: solve_periodic(
                            kind, flow, phi, n, wall, None
                        ),
                    )
                sub, st = got["subvoxel"], got["staircase"]
                if sub == not_run or st == not_run:
                    lines.append(f"| {kind} {flow}, phi {phi:g} | {n} | {not_run} | | | |")
                    continue
                e, es = sub["k"] / ref - 1.0, st["k"] / ref - 1.0
                errs.append(abs(e))
                its.append(sub["iterations"])
                its_st.append(st["iterations"])
                lines.append(
                    f"| {kind} {flow}, phi {phi:g} | {n} | {_pct(e)} | {sub['iterations']} | "
                    f"{_pct(es)} | {st['iterations']} |"
                )
            if len(errs) == len(ns):
                steps = list(zip(errs, errs[1:], strict=False))
                mono = all(b < a for a, b in steps)
                settled = all(b < a or max(a, b) <= settle for a, b in steps)
                summary.append((f"{kind} {flow}, phi {phi:g}", mono, settled, errs, its, its_st))
    if not summary:
        return lines
    n_mono = sum(s[1] for s in summary)
    n_settled = sum(s[2] for s in summary)
    lines += [
        "",
        "| case | monotone | monotone or settled | |true error| coarsest -> finest | "
        "iterations coarsest -> finest (staircase) |",
        "|---|---|---|---|---|",
    ]
    for case, mono, settled, errs, its, its_st in summary:
        lines.append(
            f"| {case} | {'yes' if mono else '**no**'} | {'yes' if settled else '**no**'} | "
            f"{' / '.join(f'{100 * e:.2f}' for e in errs)} % | "
            f"{' / '.join(map(str, its))} ({' / '.join(map(str, its_st))}) |"
        )
    ratio = [sum(s[4]) / sum(s[5]) for s in summary]
    lines += [
        "",
        f"Monotone in {n_mono} of {len(summary)} cases over {len(CONVERGENCE[0][3])} or "
        f"{len(CONVERGENCE[2][3])} resolutions; {n_settled} of {len(summary)} when a step "
        f"between two errors both within {100 * settle:g} % counts as settled (the alignment "
        "scatter of the sub-voxel walls, section above). Sub-voxel walls take "
        f"{min(ratio):.2f}-{max(ratio):.2f} times the staircase's MINRES iterations per case "
        "(summed over the resolutions).",
    ]
    return lines
