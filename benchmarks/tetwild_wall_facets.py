"""How finely each mesher facets one fiber: a D = 7 um cylinder through the centre of a 21 um
cube (0.5 um voxels, flow z, aux zones 0.2), meshed by pytetwild at the 0.85 D edge with the
envelope 0.5 um (the step rule on Table III) and 0.25 um (D / 28), and by the stuffing mesher
at D / 3. Per mesh: the circumferential length of the wall facet edges (component normal to
the fiber axis), the wall vertices' radius over R, and the wall area per axis length over
pi D, measured on the facets whose centroid lies within 0.18 L of the centre along the axis
(a rough number: facets cut by that window count whole). One JSON line per mesh.

Usage: ``python benchmarks/tetwild_wall_facets.py [--angle DEG | --along-z]`` (the axis in the
xy plane at DEG from x, default 90; or along z, the flow axis).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from psdesign.meshing import tags as T
from psdesign.meshing.pore_mesh import mesh_pore_space

L, V, D = 21e-6, 0.5e-6, 7e-6


def fiber_field(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(signed distance to the cylinder of axis ``u`` through the cube centre, the centre)."""
    c = (np.arange(int(round(L / V))) + 0.5) * V
    x = np.stack(np.meshgrid(c, c, c, indexing="ij"), -1) - 0.5 * L
    return np.linalg.norm(x - (x @ u)[..., None] * u, axis=-1) - 0.5 * D, np.full(3, 0.5 * L)


def facet_stats(pm, u: np.ndarray, c0: np.ndarray, half: float) -> dict:
    """Circumferential facet-edge lengths, vertex radii and wall area per axis length."""
    p, w = pm.points - c0, pm.facet_tags[T.WALL]
    a, b, c = p[w[:, 0]], p[w[:, 1]], p[w[:, 2]]
    mid = np.abs(((a + b + c) / 3.0) @ u) < half
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)[mid].sum()
    e = np.concatenate([b - a, c - b, a - c])[np.tile(mid, 3)]
    circ = np.linalg.norm(e - (e @ u)[:, None] * u, axis=1)
    circ = circ[circ > 0.05e-6]  # edges along the axis
    pv = p[np.unique(w[mid])]
    r = np.linalg.norm(pv - (pv @ u)[:, None] * u, axis=1) / (0.5 * D)
    return {
        "circ_edge_p50_um": float(np.median(circ)) * 1e6,
        "circ_edge_p90_um": float(np.percentile(circ, 90)) * 1e6,
        "vertex_r_over_R_min": float(r.min()),
        "vertex_r_over_R_max": float(r.max()),
        "wall_area_per_length_over_piD": area / (2.0 * half) / (np.pi * D),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--angle", type=float, default=90.0)
    ap.add_argument("--along-z", action="store_true")
    args = ap.parse_args()
    t = np.radians(args.angle)
    u = np.array([0.0, 0.0, 1.0]) if args.along_z else np.array([np.cos(t), np.sin(t), 0.0])
    d, c0 = fiber_field(u)
    diag = float(np.linalg.norm([L, L, 1.4 * L]))
    tw = {"mesher": "pytetwild", "edge_length": 0.85 * D, "surface_step": 2}
    cases = {
        "pytetwild envelope 0.5 um": {**tw, "epsilon": 0.5e-6 / diag},
        "pytetwild envelope 0.25 um": {**tw, "epsilon": 0.25e-6 / diag},
        "stuffing D/3": {"mesher": "stuffing", "lattice_step": D / 3.0},
    }
    for name, kw in cases.items():
        t0 = time.process_time()
        pm = mesh_pore_space(d, V, (L, L, L), "z", **kw)
        row = {"case": name, "axis": u.round(3).tolist(), "n_tets": len(pm.tets)}
        row.update(facet_stats(pm, u, c0, 0.18 * L))
        row["cpu_s"] = time.process_time() - t0
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
