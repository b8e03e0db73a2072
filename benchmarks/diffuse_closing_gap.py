"""Which open gaps does the diffuse wall close, and does the refusal's voxel open them (session 39,
helper s39-diffclose)?

Square arrays of cylinders across x (spacing ``L`` = 40 um, ``tests/arrays.py``), solid
fraction ``phi`` 0.4-0.78 (open below pi / 4: gap ``L (1 - 2 sqrt(phi / pi))``), 8-48 voxels per
spacing, the cylinders shifted by 0, 1/4, 1/2 voxel. No solve: per grid, whether the voxel grid
has a path along x (``distance > 0``, the sharp walls' fluid), whether the diffuse wall's cells
with fluid fraction >= 1/2 have one (the diffuse solver's refusal test,
:meth:`solvers.voxel.diffuse.DiffuseGrid.sample`), and the refusal line's branch
(:func:`psdesign.flow.no_path.no_path_message`: ``diffuse`` the layers closed an open grid,
``grid`` a gap under a voxel, ``rve`` no path at any voxel). Where the diffuse wall closed an
open grid: the gap the line reads (:func:`psdesign.flow.diffuse.half_gap`, parsed from the
line), the voxel it asks for, and whether the diffuse wall has a path at that voxel (same shift
in voxels).

    PYTHONPATH=. python benchmarks/diffuse_closing_gap.py > /tmp/closing.jsonl
    PYTHONPATH=. python benchmarks/diffuse_closing_gap.py --summary \
        benchmarks/diffuse_closing_gap_runs.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from arrays import L, array_spec, radius_of  # noqa: E402

from psdesign.flow.no_path import no_path_message  # noqa: E402
from psdesign.geometry.throat import percolates  # noqa: E402
from psdesign.geometry.walls import NearestWalls  # noqa: E402
from psdesign.packing.build import build_rve  # noqa: E402
from psdesign.schema.spec import validate_spec  # noqa: E402
from solvers.voxel.diffuse import DiffuseGrid  # noqa: E402
from solvers.voxel.diffuse_wall import REACH_VOXELS  # noqa: E402

PHIS = (0.4, 0.5, 0.55, 0.6, 0.65, 0.7, 0.72, 0.74, 0.76, 0.78)
NS = (8, 12, 16, 20, 24, 32, 40, 48)
SHIFTS = (0.0, 0.25, 0.5)
#: the asked-for grid is sampled only up to this many voxels per spacing (memory, time)
N_CHECK = 120


def build(phi: float, n: int, shift: float):
    """The array's RVE, voxel fields and voxel edge (cylinders shifted by ``shift`` voxel)."""
    spec = array_spec("square", phi, n)
    h = L / n
    for fb in spec["fibers"]:
        c = fb["center"]
        fb["center"] = [c[0] + shift * h, c[1] + shift * h, c[2]]
    spec["flow"] = {**spec["flow"], "wall_treatment": "diffuse"}
    spec = validate_spec(spec)
    built = build_rve(spec)
    return built.rve, built.voxelize(spec["rve"]["voxel"]), h


def diffuse_open(rve, fields, h: float) -> bool:
    """The diffuse solver's test: the cells with eps >= 1/2 percolate along x."""
    grid = DiffuseGrid.sample(fields.grid.shape, NearestWalls(rve, h, reach=REACH_VOXELS + 1.0))
    return percolates(grid.cell >= 0.5, 0)


def row(phi: float, n: int, shift: float) -> dict:
    t0 = time.perf_counter()
    rve, fields, h = build(phi, n, shift)
    out = {
        "phi": phi,
        "n": n,
        "shift": shift,
        "gap_exact_voxels": (1 - 2 * radius_of(phi, "square")) * n,
        "R_voxels": radius_of(phi, "square") * n,
        "grid_open": percolates(fields.distance > 0, 0),
        "diffuse_open": diffuse_open(rve, fields, h),
    }
    if not out["diffuse_open"]:
        line = no_path_message("x", h, fields.distance, 0, "diffuse", rve)
        out["branch"] = (
            "diffuse" if "diffuse wall" in line else "rve" if line.startswith("fibers") else "grid"
        )
    if out["grid_open"] and not out["diffuse_open"]:
        line = no_path_message("x", h, fields.distance, 0, "diffuse", rve)
        gap = float(re.search(r"gap is ([\d.e+-]+) voxels", line).group(1))
        voxel = float(re.search(r"rve\.voxel <= ([\d.e+-]+) m", line).group(1))
        n2 = math.ceil(L / voxel - 1e-9)
        out |= {"gap_read_voxels": gap, "n_asked": n2}
        out["gap_exact_at_asked"] = (1 - 2 * radius_of(phi, "square")) * n2
        if n2 <= N_CHECK:
            out["open_at_asked"] = diffuse_open(*build(phi, n2, shift))
    out["t_s"] = round(time.perf_counter() - t0, 2)
    return out


def summary(rows: list[dict]) -> None:
    closed = [r for r in rows if r["grid_open"] and not r["diffuse_open"]]
    opened = [r for r in rows if r["diffuse_open"]]
    grid_closed = [r for r in rows if not r["grid_open"]]
    err = [r["gap_read_voxels"] - r["gap_exact_voxels"] for r in closed]
    checked = [r for r in closed if "open_at_asked" in r]
    print(f"grids: {len(rows)}; voxel grid open: {len(rows) - len(grid_closed)}")
    print(
        f"diffuse closed an open grid: {len(closed)} (exact gap up to "
        f"{max(r['gap_exact_voxels'] for r in closed):.2f} voxels); diffuse open: {len(opened)} "
        f"(exact gap from {min(r['gap_exact_voxels'] for r in opened):.2f} voxels)"
    )
    print(f"gap read - exact: {min(err):+.3f} to {max(err):+.3f} voxels")
    print(
        f"asked-for grid sampled: {len(checked)} of {len(closed)}, open "
        f"{sum(r['open_at_asked'] for r in checked)}; asked {min(r['n_asked'] for r in closed)}-"
        f"{max(r['n_asked'] for r in closed)} voxels per spacing, exact gap there >= "
        f"{min(r['gap_exact_at_asked'] for r in closed):.2f} voxels"
    )
    branches: dict = {}
    for r in grid_closed:
        branches[r["branch"]] = branches.get(r["branch"], 0) + 1
    print(f"voxel grid closed (open RVE): {len(grid_closed)}, refusal branches {branches}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--summary", type=Path, help="summarise a rows file instead of running")
    args = ap.parse_args()
    if args.summary:
        summary([json.loads(x) for x in args.summary.read_text().splitlines() if x.strip()])
        return
    for phi in PHIS:
        for n in NS:
            for shift in SHIFTS:
                print(json.dumps(row(phi, n, shift)), flush=True)


if __name__ == "__main__":
    main()
