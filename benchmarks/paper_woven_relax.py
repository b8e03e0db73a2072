"""Woven Table III sample before and after the force field (issue 17): porosity, Omega, K_z.

Usage::

    psdesign forcefield studies/forcefield_woven.toml -o OUT/
    nice python benchmarks/paper_woven_relax.py studies/table3/woven.toml OUT/relaxed.toml \
        --voxel 2e-6

prints one JSON line per spec: porosity and Omega on the voxel grid, the smallest gap between
two yarns (Eq. 8's intersection field, metres) and K_z (voxel route, periodic BC) with its
relative error bar, the bar's method (``two_grid``: a second, coarser grid is solved; with
``--no-error-estimate`` the resolution floor alone), the route's status and warnings.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def measure(path: str, voxel: float, error_estimate: bool = True) -> dict:
    """Porosity, Omega, smallest yarn gap and K_z with its error bar of one spec on a ``voxel``
    grid (``error_estimate``: solve a second, coarser grid for the bar)."""
    from psdesign.flow.permeability import permeability
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import load_spec

    spec = load_spec(path)
    rve = build_rve(spec).rve
    fields = rve.voxelize(voxel)
    g = fields.grid
    axes = [(np.arange(n) + 0.5) * s for n, s in zip(g.shape, g.spacing, strict=True)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    gap = float(rve.intersection_field(pts).min())
    flow = {**spec["flow"], "solver": "voxel", "bc": "periodic"}
    t0 = time.perf_counter()
    r = permeability(rve, fields, "z", flow, solver="voxel", error_estimate=error_estimate)
    return {
        "spec": path,
        "voxel_m": voxel,
        "n_fibers": len(rve.fibers),
        "porosity": fields.porosity,
        "omega": fields.intersection_volume_fraction,
        "min_gap_m": gap,
        "k_z_m2": r["permeability_m2"],
        "k_z_rel_error": r["permeability_rel_error"],
        "error_method": r["error_estimate"]["method"],
        "converged": r["converged"],
        "status": r["status"],
        "warnings": r["warnings"],
        "wall_s": time.perf_counter() - t0,
    }


def render_side_by_side(paths: list[str], titles: list[str], out: str, voxel: float) -> None:
    """One PNG with the yarn surfaces of each spec side by side (off-screen pyvista)."""
    import pyvista as pv

    from psdesign.packing.build import build_rve
    from psdesign.report.preview import _quiet_vtk, fiber_surface
    from psdesign.schema.spec import load_spec

    _quiet_vtk()
    plotter = pv.Plotter(
        off_screen=True, shape=(1, len(paths)), window_size=(400 * len(paths), 340)
    )
    for i, (path, title) in enumerate(zip(paths, titles, strict=True)):
        fields = build_rve(load_spec(path)).rve.voxelize(voxel)
        surf = fiber_surface(fields.distance, fields.grid.spacing).scale(1e6, inplace=False)
        plotter.subplot(0, i)
        plotter.set_background("white")
        plotter.add_mesh(surf, color="#4a7ab5", smooth_shading=True, specular=0.3)
        plotter.add_mesh(pv.Box(bounds=(0, 100, 0, 100, 0, 100)), style="wireframe", color="black")
        plotter.add_text(title, font_size=9, color="black")
        plotter.camera_position = "iso"
    plotter.screenshot(out)
    plotter.close()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("specs", nargs="+")
    p.add_argument("--voxel", type=float, default=2e-6)
    p.add_argument("--picture", default=None, help="PNG of the specs side by side")
    p.add_argument("--titles", nargs="*", default=None)
    p.add_argument(
        "--no-error-estimate",
        action="store_true",
        help="K_z's bar from the resolution floor alone (no second, coarser grid)",
    )
    a = p.parse_args(argv)
    if a.picture:
        render_side_by_side(a.specs, a.titles or a.specs, a.picture, a.voxel)
        return 0
    for path in a.specs:
        print(json.dumps(measure(path, a.voxel, not a.no_error_estimate)))
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
