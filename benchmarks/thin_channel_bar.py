"""The voxel permeability's bar on channels a few voxels across (staircase walls): the
thin-channel term (session 38, helper s38-bars).

Walls on the voxel faces make the voxel scheme's flow rate second-order high, with a large
constant: a slit of ``w`` voxels gives ``K (1 + 2 / w^2)``, a 2x2 square duct +78 %. The first
-order floor ``0.5 h / R`` and a second grid that loses or reshapes such a channel did not bound
it (session 37 edge audit: ``img_channel_2vox`` +78 % against a 71 % bar; here a 3-voxel slit
was ``ok`` at +22 % against 18.5 %). ``psdesign.flow.error.thin_channel_rel_error`` adds
``C_T x / (1 - C_T x)``, ``x = (h / R)^2``, to the floor of staircase results.

Sets (closed forms, images through the product's route ``permeability(..., "voxel")``):

* calibration: square ducts of 2, 3, 4, 6, 8 voxels (Shah & London 1978, Q = 0.0351443 a^4
  G / mu) and slits of 1-4 voxels (K = a^2 / 12 per channel), channel at two offsets;
* validation: rectangular ducts 2x3, 2x4, 3x5, 2x6, 4x6 (Shah & London's series), 1x1 duct;
* resolved media: square cylinder arrays across at solid fractions 0.3-0.6 and along at 0.3,
  10-32 voxels per spacing, ``wall_treatment = "staircase"`` (Sangani & Acrivos, Drummond &
  Tahir: ``tests/reference_values.py``), where the term must not widen the bar unless the
  error needs it.

Per case: the true error, the bar before (the same components without the term) and after.

    PYTHONPATH=. python benchmarks/thin_channel_bar.py > /tmp/thin_channel_bar.jsonl
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from arrays import array_spec, exact_k  # noqa: E402

from psdesign.flow import error as err  # noqa: E402
from psdesign.flow.permeability import permeability  # noqa: E402
from psdesign.packing.build import build_rve  # noqa: E402
from psdesign.schema.spec import validate_spec  # noqa: E402

H = 1e-6


def duct_q(a: float, b: float) -> float:
    """``Q mu / G`` of a rectangular duct ``a x b`` (a <= b; Shah & London 1978, White,
    Viscous Fluid Flow, Eq. 3-48)."""
    s = sum(math.tanh(n * math.pi * b / (2 * a)) / n**5 for n in range(1, 400, 2))
    return a**3 * b / 12 * (1 - 192 * a / (math.pi**5 * b) * s)


def channel(n: int, wy: int, wz: int | None, lo: int) -> np.ndarray:
    """Solid ``n^3`` with a channel along x: ``wy x wz`` voxels from ``lo``, a slit if ``wz``
    is None."""
    a = np.ones((n, n, n), np.uint8)
    if wz is None:
        a[:, lo : lo + wy, :] = 0
    else:
        a[:, lo : lo + wy, lo : lo + wz] = 0
    return a


def old_bar(res: dict, step: float) -> float:
    """The same result's bar without the thin-channel term (the components before session 38)."""
    est = res["error_estimate"]
    floor = err.resolution_floor(step, res["permeability_m2"], res["porosity"], 1)
    floor *= 2.0 if est["method"] == "resolution_only" else 1.0
    disc = max(floor, est["richardson"] or 0.0)
    return res["permeability_rel_error"] - est["discretization"] + disc


def record(name: str, group: str, res: dict, truth: float, step: float) -> dict:
    k = res["permeability_m2"]
    e = k / truth - 1.0
    before = old_bar(res, step)
    bar = res["permeability_rel_error"]
    hr = step / err.flow_length_scale(k, res["porosity"])
    return {
        "case": name, "set": group, "k": k, "truth": truth, "error": e, "h_over_R": hr,
        "bar_before": before, "bar": bar, "status": res["status"],
        "covered_before": abs(e) <= before, "covered": abs(e) <= bar,
    }  # fmt: skip


def image_case(name: str, group: str, img: np.ndarray, truth: float, tmp: Path) -> dict:
    path = tmp / f"{name}.npy"
    np.save(path, img)
    spec = validate_spec({"image": {"path": str(path), "voxel_size": H}})
    built = build_rve(spec)
    fields = built.voxelize(H)
    res = permeability(built.rve, fields, "x", spec["flow"], "voxel")
    return record(name, group, res, truth, H)


def channel_cases(tmp: Path):
    for w in (2, 3, 4, 6, 8):
        n = max(16, 2 * w + 8)
        truth = 0.0351443 * (w * H) ** 4 / (n * H) ** 2
        for lo in ((n - w) // 2, (n - w) // 2 + 1):
            yield image_case(
                f"duct {w}x{w} at {lo}", "calibration", channel(n, w, w, lo), truth, tmp
            )
    for w in (1, 2, 3, 4):
        truth = (w * H) ** 3 / 12 / (16 * H)
        for lo in (6, 7):
            yield image_case(
                f"slit {w} at {lo}", "calibration", channel(16, w, None, lo), truth, tmp
            )
    for a, b in ((2, 3), (2, 4), (3, 5), (2, 6), (4, 6), (1, 1)):
        truth = duct_q(a * H, b * H) / (16 * H) ** 2
        for lo in (6, 7):
            img = channel(16, a, b, lo)
            yield image_case(f"duct {a}x{b} at {lo}", "validation", img, truth, tmp)


def array_cases():
    for flow, phis in (("across", (0.3, 0.4, 0.5, 0.6)), ("along", (0.3,))):
        for phi in phis:
            for n in (10, 12, 16, 20, 24, 32):
                spec = array_spec("square", phi, n)
                spec["flow"] = {**spec.get("flow", {}), "wall_treatment": "staircase"}
                spec = validate_spec(spec)
                built = build_rve(spec)
                fields = built.voxelize(spec["rve"]["voxel"])
                d = "z" if flow == "along" else "x"
                res = permeability(built.rve, fields, d, spec["flow"], "voxel")
                truth = exact_k("square", flow, phi)
                step = float(fields.grid.spacing[0])
                yield record(f"square {flow} {phi:g} n {n}", "arrays", res, truth, step)


def main() -> int:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for row in (*channel_cases(Path(tmp)), *array_cases()):
            rows.append(row)
            print(json.dumps(row), flush=True)
    for group in ("calibration", "validation", "arrays"):
        sel = [r for r in rows if r["set"] == group]
        wider = [r for r in sel if r["bar"] > r["bar_before"] * (1 + 1e-9)]
        print(
            f"# {group}: {len(sel)} cases, covered {sum(r['covered'] for r in sel)} "
            f"(before {sum(r['covered_before'] for r in sel)}), bar widened in {len(wider)}"
            + "".join(
                f"; {r['case']} {100 * r['bar_before']:.1f} -> {100 * r['bar']:.1f} % "
                f"(error {100 * r['error']:+.1f} %, h/R {r['h_over_R']:.2f})"
                for r in wider
                if group == "arrays"
            ),
            file=sys.stderr,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
