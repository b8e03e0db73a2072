"""OpenFOAM (simpleFoam, Debian's openfoam package) vs psdesign's FEM on the same mesh.

    python benchmarks/bench_openfoam.py [SPEC] [--voxel 2e-6]

Meshes the RVE of ``SPEC`` (default the shipped ``studies/examples/three_rods.toml``, sampled
at ``--voxel``), exports the OpenFOAM case, runs its ``Allrun`` and solves the same mesh with
psdesign's FEM permeameter. Both K use the plain RVE-plane definition
``K = mu Q L / (A (p_start - p_end))`` (psdesign: ``pressure_drop_faces_pa``); psdesign's
reported K (windowed dissipation) is printed beside them.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("spec", nargs="?", default=str(ROOT / "studies/examples/three_rods.toml"))
    ap.add_argument("--voxel", type=float, default=2e-6)
    args = ap.parse_args()

    from psdesign.flow.fem import permeability_fem
    from psdesign.meshing.exports import export_mesh
    from psdesign.meshing.options import MeshOptions
    from psdesign.meshing.pore_mesh import mesh_pore_space
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = load_spec(args.spec)
    spec["rve"]["voxel"] = args.voxel
    flow = dict(spec["flow"])
    built = build_rve(spec)
    fields = built.voxelize(args.voxel)
    h = float(fields.grid.spacing[0])
    pm = mesh_pore_space(fields.distance, h, built.rve.size, "z", MeshOptions.from_flow(flow))
    with tempfile.TemporaryDirectory() as tmp:
        case = export_mesh(pm, tmp, formats=("openfoam",), flow=flow)["openfoam"]
        t0 = time.perf_counter()
        out = subprocess.run(
            ["sh", str(case / "Allrun")], capture_output=True, text=True, check=True
        ).stdout
        t_of = time.perf_counter() - t0
    k_of = float(re.search(r"K_rve_planes = ([-+0-9.eE]+)", out).group(1))
    q_of = float(re.search(r"Q = ([-+0-9.eE]+)", out).group(1))
    t0 = time.perf_counter()
    res = permeability_fem(built.rve, fields, "z", flow)
    t_fem = time.perf_counter() - t0
    assert res["n_tets"] == len(pm.tets), "psdesign meshed a different mesh"
    mu = float(flow["viscosity"])
    area = float(np.prod(built.rve.size[:2]))
    length = float(built.rve.size[2])
    q = res["flow_rate_m3_s"]
    k_plain = mu * q * length / (area * res["pressure_drop_faces_pa"])
    print(f"{Path(args.spec).name} voxel {args.voxel:g}: {len(pm.tets)} tets")
    print(
        f"  OpenFOAM simpleFoam: Q = {q_of:.4e} m^3/s, "
        f"K (RVE planes) = {k_of:.4e} m^2 ({t_of:.0f} s)"
    )
    print(
        f"  psdesign FEM:        Q = {q:.4e} m^3/s, K (RVE planes) = {k_plain:.4e} m^2, "
        f"K reported (windowed dissipation) = {res['permeability_m2']:.4e} m^2 ({t_fem:.0f} s)"
    )
    print(
        f"  ratio OpenFOAM / psdesign (plain definition): {k_of / k_plain:.4f}; "
        f"flux ratio {q_of / q:.4f}"
    )


if __name__ == "__main__":
    main()
