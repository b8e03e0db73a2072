"""Is the transport error bar honest?  Cylinder and sphere arrays against closed forms.

Square and hexagonal arrays of cylinders (through the product path: spec -> RVE ->
rasterizer) across (Rayleigh / Perrins, McKenzie & McPhedran 1979) and along (the parallel
rule, exact), simple cubic sphere arrays (analytic signed distance; Rayleigh 1892 with
McKenzie, McPhedran & Derrick 1978), each insulating (pore diffusion) and conducting at
contrasts 10 and 1000, at 16-96 voxels per spacing.  One JSON line per case (truth, value,
error, bar, covered) and a coverage summary; the calibration set of
``psdesign.transport.effective.STAIRCASE_FLOOR`` is the square arrays at solid fractions 0.2,
0.4 and 0.5, the rest is validation.

    python benchmarks/transport_error_bar.py > benchmarks/transport_error_bar_runs.jsonl
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from reference_values import (  # noqa: E402
    rayleigh_hexagonal,
    rayleigh_simple_cubic,
    rayleigh_square,
)

from psdesign.geometry.rve import VoxelFields, VoxelGrid  # noqa: E402
from psdesign.packing.build import build_rve  # noqa: E402
from psdesign.schema.spec import validate_spec  # noqa: E402
from psdesign.transport.conductivity import effective_conductivity  # noqa: E402
from psdesign.transport.diffusivity import relative_diffusivity  # noqa: E402

L = 20e-6  # spacing (m)
RATIOS = (0.0, 10.0, 1000.0)  # solid / fluid conductivity; 0 = pore diffusion
#: (kind, solid fractions, voxels per spacing)
SWEEP = (
    ("square", (0.2, 0.4, 0.5), (16, 24, 32, 48, 64, 96)),
    ("square", (0.3, 0.6), (20, 40, 80)),
    ("hex", (0.2, 0.4, 0.5), (16, 24, 32, 48, 64)),
    ("sphere", (0.1, 0.2, 0.3), (16, 24, 32, 48, 64)),
)


def cylinder_fields(kind: str, f: float, n: int) -> VoxelFields:
    """Square (one cylinder) or hexagonal (centre + corners, ny = round(n sqrt 3)) cell, n
    voxels per spacing and n layers along the cylinders (z)."""
    h = L / n
    ly = L if kind == "square" else round(n * np.sqrt(3)) * h
    per_cell = 1 if kind == "square" else 2
    d = 2 * np.sqrt(f * L * ly / (per_cell * np.pi))
    centres = [(L / 2, ly / 2)] + ([] if kind == "square" else [(0, 0), (L, 0), (0, ly), (L, ly)])
    fibers = [
        {"shape": "cylinder", "diameter": d, "center": [x, y, L / 2], "direction": [0, 0, 1]}
        for x, y in centres
    ]
    spec = validate_spec({"rve": {"size": [L, ly, L], "voxel": h}, "fibers": fibers})
    return build_rve(spec).voxelize(h)


def sphere_fields(f: float, n: int) -> VoxelFields:
    """One sphere of volume fraction f in a periodic cube (analytic signed distance)."""
    h = L / n
    x = (np.arange(n) + 0.5) * h - L / 2
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    radius = (3 * f / (4 * np.pi)) ** (1 / 3) * L
    d = (np.sqrt(X**2 + Y**2 + Z**2) - radius).astype(np.float32)
    grid = VoxelGrid(size=np.full(3, L), shape=d.shape, spacing=np.full(3, h))
    return VoxelFields(distance=d, count=(d <= 0).astype(np.uint8), grid=grid)


def truth(kind: str, f: float, ratio: float, direction: str) -> float:
    """Closed form: across (Rayleigh-type) or along the cylinders (parallel rule)."""
    if direction == "z" and kind != "sphere":
        return 1 - f + f * ratio
    form = {"square": rayleigh_square, "hex": rayleigh_hexagonal, "sphere": rayleigh_simple_cubic}
    return form[kind](f, ratio)


def cases():
    """Yield one dict per (kind, f, n, ratio, direction)."""
    for kind, fractions, resolutions in SWEEP:
        for f in fractions:
            for n in resolutions:
                fields = sphere_fields(f, n) if kind == "sphere" else cylinder_fields(kind, f, n)
                for ratio in RATIOS:
                    if f == 0.6 and ratio == 1000.0:  # Perrins' truncated form: not a truth there
                        continue
                    for d in ("x",) if kind == "sphere" else ("x", "z"):
                        if ratio == 0.0:
                            r = relative_diffusivity(fields, d, {"mean_free_path_m": 0.0})
                            value = r.relative_diffusivity
                        else:
                            r = effective_conductivity(fields, d, ratio, 1.0, {})
                            value = r.effective_conductivity
                        t = truth(kind, f, ratio, d)
                        err = value / t - 1
                        yield {
                            "kind": kind, "f": f, "n": n, "ratio": ratio, "direction": d,
                            "set": "calibration" if kind == "square" and f in (0.2, 0.4, 0.5)
                            else "validation",
                            "truth": t, "value": value, "error": err, "bar": r.rel_error,
                            "covered": bool(abs(err) <= r.rel_error), "converged": r.converged,
                        }  # fmt: skip


def collect(rows_of) -> list[dict]:
    """The rows of the generator ``rows_of``, each printed as a JSON line as it comes."""
    rows = []
    for row in rows_of:
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows


def main() -> None:
    rows = collect(cases())
    for name in ("calibration", "validation"):
        sel = [r for r in rows if r["set"] == name]
        ratio = np.median([r["bar"] / max(abs(r["error"]), 1e-12) for r in sel])
        print(
            f"# {name}: covered {sum(r['covered'] for r in sel)} of {len(sel)}, "
            f"median bar / |error| {ratio:.1f}",
            file=sys.stderr,
        )


if __name__ == "__main__":
    main()
