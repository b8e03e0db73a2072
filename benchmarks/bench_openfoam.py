"""OpenFOAM (simpleFoam, Debian's openfoam package) vs psdesign's FEM on the same mesh.

    python benchmarks/bench_openfoam.py [SPEC] [--voxel 2e-6] [--lattice-step H] [--tets]
    python benchmarks/bench_openfoam.py --periodic [--lattice-step H] [--tets]

``--periodic``: the periodic case instead (cyclic patches and a pressure jump,
:mod:`psdesign.meshing.exports.openfoam_periodic`) on one cylinder along z in a 40 um cell
(radius 8 um, 2.5 um voxels, 4 um lattice unless ``--lattice-step``), against psdesign's
periodic FEM on the same mesh and Drummond & Tahir (1984)'s K along a square array; OpenFOAM
on the polyhedral dual (the periodic Allrun's default since session 36) or, with ``--tets``,
on the tets.

Meshes the RVE of ``SPEC`` (default the shipped ``studies/examples/three_rods.toml``, sampled
at ``--voxel``), exports the OpenFOAM case, runs its ``Allrun`` and solves the same mesh with
psdesign's FEM permeameter. Two K each: the windowed one (OpenFOAM: the Allrun's
``K_windowed``, the sin^2-windowed drop of the pressure on 61 planes across the RVE; psdesign:
its reported K, windowed dissipation, and its plane-pressure window estimator
``pressure_drop_plane_window_pa``, the same formula as the Allrun's) and the plain RVE-plane
one ``K = mu Q L / (A (p_start - p_end))`` (psdesign: ``pressure_drop_faces_pa``), which jumps
with the side of the RVE plane its cut samples where fibres end on the plane. OpenFOAM solves
on the polyhedral dual of the tets (the Allrun's default since session 35); ``--tets`` on the
tets themselves (``./Allrun tets``), where its K moves away from the analytic value on
refinement (docs/meshers.md). ``--lattice-step`` sets ``flow.lattice_step`` (the refinement).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("spec", nargs="?", default=str(ROOT / "studies/examples/three_rods.toml"))
    ap.add_argument("--voxel", type=float, default=2e-6)
    ap.add_argument("--periodic", action="store_true", help="the periodic cylinder cell")
    ap.add_argument("--tets", action="store_true", help="OpenFOAM on the tets (./Allrun tets)")
    ap.add_argument("--lattice-step", type=float, help="flow.lattice_step (m)")
    args = ap.parse_args()
    if args.periodic:
        periodic_cell(args.lattice_step or 4e-6, args.tets)
        return

    from psdesign.flow.fem import permeability_fem
    from psdesign.meshing.exports import export_mesh
    from psdesign.meshing.options import MeshOptions
    from psdesign.meshing.pore_mesh import mesh_pore_space
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = load_spec(args.spec)
    spec["rve"]["voxel"] = args.voxel
    if args.lattice_step:
        spec["flow"]["lattice_step"] = args.lattice_step
    flow = dict(spec["flow"])
    built = build_rve(spec)
    fields = built.voxelize(args.voxel)
    h = float(fields.grid.spacing[0])
    pm = mesh_pore_space(fields.distance, h, built.rve.size, "z", MeshOptions.from_flow(flow))
    with tempfile.TemporaryDirectory() as tmp:
        case = export_mesh(pm, tmp, formats=("openfoam",), flow=flow)["openfoam"]
        t0 = time.perf_counter()
        out = subprocess.run(
            ["sh", str(case / "Allrun"), *(["tets"] if args.tets else [])],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        t_of = time.perf_counter() - t0
    print(next(line for line in out.splitlines() if line.startswith("converged: ")))
    k_of = float(re.search(r"K_rve_planes = ([-+0-9.eE]+)", out).group(1))
    kw_of = float(re.search(r"K_windowed = ([-+0-9.eE]+)", out).group(1))
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
    k_pw = mu * q * length / (area * res["pressure_drop_plane_window_pa"])
    k_rep = res["permeability_m2"]
    cells = "tets" if args.tets else "polyhedral dual"
    print(f"{Path(args.spec).name} voxel {args.voxel:g}: {len(pm.tets)} tets (OpenFOAM: {cells})")
    print(
        f"  OpenFOAM simpleFoam: Q = {q_of:.4e} m^3/s, "
        f"K windowed = {kw_of:.4e} m^2, K (RVE planes) = {k_of:.4e} m^2 ({t_of:.0f} s)"
    )
    print(
        f"  psdesign FEM:        Q = {q:.4e} m^3/s, K reported (windowed dissipation) = "
        f"{k_rep:.4e} m^2, K plane window = {k_pw:.4e} m^2, K (RVE planes) = {k_plain:.4e} m^2 "
        f"({t_fem:.0f} s)"
    )
    print(
        f"  ratio OpenFOAM / psdesign: K windowed / reported {kw_of / k_rep:.4f}, "
        f"/ plane window {kw_of / k_pw:.4f}; plain {k_of / k_plain:.4f}; flux {q_of / q:.4f}"
    )


def periodic_cell(step: float, tets: bool) -> None:
    """The periodic case of one cylinder cell at lattice step ``step`` (m): OpenFOAM (on the
    tets with ``tets``, else on their polyhedral dual) vs the FEM on the same mesh vs Drummond
    & Tahir (printed)."""
    import math

    from psdesign.flow.fem import permeability_fem
    from psdesign.flow.fem_field import fem_field
    from psdesign.meshing.exports import export_mesh
    from psdesign.meshing.options import MeshOptions
    from psdesign.meshing.pore_mesh import mesh_pore_space
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    size, radius = 40e-6, 8e-6
    spec = validate_spec(
        {
            "rve": {"size": [size] * 3, "voxel": 2.5e-6},
            "fibers": [
                {
                    "shape": "cylinder",
                    "diameter": 2 * radius,
                    "center": [size / 2] * 3,
                    "direction": [0, 0, 1],
                }
            ],
            "flow": {"bc": "periodic", "lattice_step": step, "solver": "fem"},
        }
    )
    flow = dict(spec["flow"])
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    own = fem_field(built.rve, fields, "stuffing")  # the field the FEM route meshes
    opts = MeshOptions.from_flow(flow)
    pm = mesh_pore_space(own.fields.distance, own.voxel, built.rve.size, "z", opts)
    with tempfile.TemporaryDirectory() as tmp:
        case = export_mesh(pm, tmp, formats=("openfoam",), flow=flow)["openfoam"]
        t0 = time.perf_counter()
        out = subprocess.run(
            [str(case / "Allrun"), *(["tets"] if tets else [])],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        t_of = time.perf_counter() - t0
        n_cells = re.search(r"^\s+cells:\s+(\d+)", (case / "log.checkMesh").read_text(), re.M)
    print(next(line for line in out.splitlines() if line.startswith("converged: ")))
    k_of = float(re.search(r"K_periodic = ([-+0-9.eE]+)", out).group(1))
    t0 = time.perf_counter()
    res = permeability_fem(built.rve, fields, "z", flow)
    t_fem = time.perf_counter() - t0
    assert res["n_tets"] == len(pm.tets), "psdesign meshed a different mesh"
    phi = math.pi * radius**2 / size**2
    sys.path.insert(0, str(ROOT / "tests"))
    from reference_values import drummond_tahir_along_square

    k_dt = drummond_tahir_along_square(phi) * radius**2
    k_fem = res["permeability_m2"]
    cells = "tets" if tets else f"polyhedral dual, {n_cells.group(1)} cells"
    print(
        f"periodic cylinder cell (solid fraction {phi:.4f}, lattice step {step:g} m): "
        f"{len(pm.tets)} tets (OpenFOAM: {cells})"
    )
    print(f"  Drummond & Tahir: K = {k_dt:.4e} m^2")
    print(f"  OpenFOAM simpleFoam: K = {k_of:.4e} m^2 ({k_of / k_dt - 1:+.1%}, {t_of:.0f} s)")
    print(f"  psdesign FEM:        K = {k_fem:.4e} m^2 ({k_fem / k_dt - 1:+.1%}, {t_fem:.0f} s)")
    print(f"  ratio OpenFOAM / psdesign: {k_of / k_fem:.4f}")


if __name__ == "__main__":
    main()
