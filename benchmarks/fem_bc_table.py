"""Accuracy table of the FEM boundary conditions on square cylinder arrays (issue 12).

For each solid fraction, cell count and flow orientation: K of the permeameter (windowed
dissipation definition) and of the periodic solve, relative to the published series
(``tests/reference_values.py``) and to each other.

Usage
-----
    python benchmarks/fem_bc_table.py --kind along --phi 0.3 --cells 2 3 4 5 --step 4e-6
    python benchmarks/fem_bc_table.py --kind across --phi 0.2 --cells 2 3 4 5 --step 2e-6
"""

from __future__ import annotations

import argparse
import os
import sys

HERE = os.path.dirname(__file__)
sys.path.insert(0, os.path.join(HERE, ".."))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "validation"))


def main() -> None:
    from fem_arrays import array_k

    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--kind", choices=("along", "across"), required=True)
    ap.add_argument("--phi", type=float, nargs="+", default=[0.3])
    ap.add_argument("--cells", type=int, nargs="+", default=[2, 3, 4, 5])
    ap.add_argument("--step", type=float, default=4e-6, help="lattice step (m)")
    ap.add_argument("--voxel", type=float, default=1e-6)
    a = ap.parse_args()
    print(
        "| kind | phi | cells | step um | K periodic / ref - 1 | K permeameter / ref - 1 | "
        "perm / periodic - 1 | old faces-drop K / ref - 1 | iters per, perm |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for phi in a.phi:
        per = array_k(a.kind, phi, 1, "periodic", a.step, a.voxel)
        for n in a.cells:
            r = array_k(a.kind, phi, n, "permeameter", a.step, a.voxel)
            ref = r["k_ref"]
            k = r["permeability_m2"]
            kp = per["permeability_m2"]
            k_faces = k * r["pressure_drop_rve_pa"] / r["pressure_drop_faces_pa"]
            cols = [kp / ref - 1, k / ref - 1, k / kp - 1, k_faces / ref - 1]
            print(
                f"| {a.kind} | {phi} | {n} | {a.step * 1e6:g} | "
                + " | ".join(f"{c:+.4f}" for c in cols)
                + f" | {per['iterations']}, {r['iterations']} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
