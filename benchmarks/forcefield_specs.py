"""``psdesign forcefield`` on every shipped spec that has fibers (issue 17 item 4).

Usage::

    nice python benchmarks/forcefield_specs.py --out ff_specs.jsonl [SPEC ...]

For each RVE spec under ``studies/`` (and the inline ``[base]`` of each study file) it runs
``psdesign forcefield SPEC -o TMP/`` (the spec's own ``[forcefield.relax]`` table, or the
defaults) and prints one JSON line: the route (rods: analytic centre lines; fields: woven /
compressed), fibers moved, the status (converged / at_bound / contact_left / not_converged),
the variables on a bound, evaluations and wall time, and, measured on the same voxel grid
before and after (``RVE.voxelize``, the spec's voxel): porosity, Omega (voxel fraction inside
two fibers) and the smallest gap between two fibers on that grid (Eq. 8's intersection field).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def shipped_specs() -> list[Path]:
    """Every ``studies/**/*.toml`` with fibers: RVE specs, and study files with an inline base."""
    out = []
    for p in sorted((ROOT / "studies").rglob("*.toml")):
        data = tomllib.loads(p.read_text())
        if "rve" in data and ("fibers" in data or "generator" in data):
            out.append(p)
        elif isinstance(data.get("base"), dict) and "rve" in data["base"]:
            out.append(p)
    return out


def spec_text(path: Path) -> str:
    """The RVE spec of ``path`` as TOML text (a study's inline ``[base]`` tables alone)."""
    text = path.read_text()
    if "rve" in tomllib.loads(text):
        return text
    keep, lines = False, []
    for line in text.splitlines():
        head = line.strip()
        if head.startswith("["):
            name = head.strip("[]").strip()
            keep = name.startswith("base.")
            if keep:
                line = line.replace("base.", "", 1)
        if keep:
            lines.append(line)
    return "\n".join(lines) + "\n"


def voxel_state(rve, voxel: float) -> dict:
    """Porosity, Omega and the smallest pair gap (metres) on one voxel grid."""
    fields = rve.voxelize(voxel)
    g = fields.grid
    axes = [(np.arange(n) + 0.5) * s for n, s in zip(g.shape, g.spacing, strict=True)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    gap = float(rve.intersection_field(pts).min()) if len(rve.fibers) > 1 else float("inf")
    return {
        "porosity": fields.porosity,
        "omega": fields.intersection_volume_fraction,
        "min_gap_m": gap,
    }


def run_one(path: Path, tmp: Path) -> dict:
    """Relax one spec through the CLI and measure it before and after."""
    from psdesign.cli import main
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = tmp / "spec.toml"
    spec.write_text(spec_text(path))
    data = tomllib.loads(spec.read_text())
    plain = tmp / "plain.toml"
    plain.write_text("\n".join(spec.read_text().split("[forcefield.relax]")[0].splitlines()) + "\n")
    voxel = float(data["rve"]["voxel"])
    t0 = time.perf_counter()
    before = build_rve(load_spec(plain)).rve
    gen_s = time.perf_counter() - t0
    out = tmp / "out"
    t0 = time.perf_counter()
    rc = main(["forcefield", str(spec), "-o", str(out), "--no-pictures"])
    wall = time.perf_counter() - t0
    rec = {"spec": str(path.relative_to(ROOT)), "exit": rc, "n_fibers": len(before.fibers)}
    rec["generate_s"] = gen_s
    rec["before"] = voxel_state(before, voxel)
    if rc != 0:
        return rec
    s = json.loads((out / "summary.json").read_text())
    after = build_rve(load_spec(out / "relaxed.toml")).rve
    rec.update(
        route=s.get("route", "rods"),
        n_moved=s["n_moved"],
        status=s["status"],
        converged=s["converged"],
        n_at_bound=len(s["at_bound"]),
        n_variables=len(s.get("variables", {})) or 3 * s["n_moved"],
        at_bound=s["at_bound"],
        message=s["message"],
        n_evals=s["n_evals"],
        relax_s=s["wall_time_s"],
        cli_s=wall,
        after=voxel_state(after, voxel),
    )
    return rec


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("specs", nargs="*", help="default: every shipped spec with fibers")
    p.add_argument("--out", help="append the JSON lines to this file")
    a = p.parse_args(argv)
    paths = [Path(s).resolve() for s in a.specs] or shipped_specs()
    for path in paths:
        with tempfile.TemporaryDirectory() as tmp:
            rec = run_one(path, Path(tmp))
        line = json.dumps(rec)
        print(line, flush=True)
        if a.out:
            with open(a.out, "a") as fh:
                fh.write(line + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
