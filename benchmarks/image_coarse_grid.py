"""The transport error bar's coarse grid of a segmented image: block vote or block columns?

Session 38 (helper s38-bars). An image's coarse grid (the two-grid term of ``rel_error``,
``docs/transport.md``) was the sign of the block-mean distance, which ties at half a block and
goes solid, so every wall on an odd voxel face thins the pore by a voxel: a straight 2x2
channel off the blocks vanished on the coarse grid and its exact ``D_eff/D = porosity`` got a
300 % bar. Since session 38 each coarse voxel is its block's four columns of two voxels along
the drive in series, the columns in parallel (Cardwell & Parsons' lower bound;
:func:`psdesign.transport.effective.coarsen_conductivity`). This driver calibrates that rule
on cases other than the straight channels of the tests: binary images of the square,
hexagonal and simple cubic arrays of ``benchmarks/transport_error_bar.py`` (the rasterized
RVE's solid mask, given as an image: EDT distance, staircase walls), rolled by 0 or 1 voxel
(the blocks' phase against the walls), insulating and conducting at contrasts 10 and 1000,
across and along, against the closed forms (Rayleigh / Perrins et al. 1979, Rayleigh 1892,
the parallel rule). One JSON line per case with the bar of both rules, and a summary:

    PYTHONPATH=. python benchmarks/image_coarse_grid.py > /tmp/image_coarse_grid.jsonl
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT))

from transport_error_bar import collect, cylinder_fields, sphere_fields, truth  # noqa: E402

from psdesign.geometry.rve import VoxelFields  # noqa: E402
from psdesign.image.fields import image_fields  # noqa: E402
from psdesign.transport.conductivity import effective_conductivity  # noqa: E402
from psdesign.transport.diffusivity import relative_diffusivity  # noqa: E402

RATIOS = (0.0, 10.0, 1000.0)
SWEEP = (
    ("square", (0.2, 0.4, 0.5), (16, 24, 32, 48)),
    ("hex", (0.2, 0.4), (16, 24, 32)),
    ("sphere", (0.1, 0.2, 0.3), (16, 24, 32)),
)


def as_image(fields: VoxelFields, roll: int) -> tuple[VoxelFields, VoxelFields]:
    """The solid mask as a segmented image rolled by ``roll`` voxels on every axis: the image
    (new rule, block columns) and the same fields read as analytic (old rule, block vote)."""
    solid = np.roll(fields.solid, roll, axis=(0, 1, 2))
    img = image_fields(solid, float(fields.grid.spacing[0]))
    old = VoxelFields(distance=img.distance, count=img.count, grid=img.grid)
    return img, old


def value_and_bar(fields: VoxelFields, ratio: float, d: str) -> tuple[float, float]:
    if ratio == 0.0:
        r = relative_diffusivity(fields, d, {"mean_free_path_m": 0.0})
        return r.relative_diffusivity, r.rel_error
    r = effective_conductivity(fields, d, ratio, 1.0, {})
    return r.effective_conductivity, r.rel_error


def cases():
    for kind, fractions, resolutions in SWEEP:
        for f in fractions:
            for n in resolutions:
                base = sphere_fields(f, n) if kind == "sphere" else cylinder_fields(kind, f, n)
                for roll in (0, 1):
                    img, old = as_image(base, roll)
                    for ratio in RATIOS:
                        for d in ("x",) if kind == "sphere" else ("x", "z"):
                            t = truth(kind, f, ratio, d)
                            v, bar = value_and_bar(img, ratio, d)
                            _, bar_old = value_and_bar(old, ratio, d)
                            err = v / t - 1
                            yield {
                                "kind": kind, "f": f, "n": n, "roll": roll, "ratio": ratio,
                                "direction": d, "truth": t, "value": v, "error": err,
                                "bar": bar, "bar_old": bar_old,
                                "covered": bool(abs(err) <= bar),
                                "covered_old": bool(abs(err) <= bar_old),
                            }  # fmt: skip


def main() -> None:
    rows = collect(cases())
    for key in ("", "_old"):
        cov = sum(r["covered" + key] for r in rows)
        ratio = np.median([r["bar" + key] / max(abs(r["error"]), 1e-12) for r in rows])
        worst = min(rows, key=lambda r: r["bar" + key] - abs(r["error"]))
        print(
            f"# rule{key or '_new'}: covered {cov} of {len(rows)}, median bar / |error| "
            f"{ratio:.1f}, tightest {worst['kind']} f={worst['f']} n={worst['n']} "
            f"roll={worst['roll']} ratio={worst['ratio']} {worst['direction']}: error "
            f"{worst['error']:+.4f} bar {worst['bar' + key]:.4f}",
            file=sys.stderr,
        )


if __name__ == "__main__":
    main()
