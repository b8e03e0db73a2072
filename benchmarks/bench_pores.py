"""Pore sizes (local thickness + intrusion) at ``n^3``: the cropped scan of
:mod:`psdesign.transport.pores` side by side with the reference scan it replaced (one
whole-grid distance transform per radius for the coverage and one more for the intrusion,
scipy's transform for the pore distance), on the image of ``bench_transport.py``.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/bench_pores.py --n 200

Both run in one process, one after the other (the reference first); prints one JSON object
with CPU and wall time of each, the 1-minute load, and whether the local-thickness map and the
intrusion curve are identical.  ``pore_sizes_*`` times the product's whole call, which since
session 31 scans a grid padded by ``r_max + 1`` wrapped layers (the scans above do not), since
session 54 along the axes the geometry repeats across only (this image: z), and since session
54 (mendpores) twice where a face does not (this image: x, y): the second scan with walls past
those faces gives the bar's lower side (``walled_axes``, ``diameter_error_below_m``).
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from scipy import ndimage

from psdesign.transport import pores


def _reference_pore_dt(distance: np.ndarray, h: float) -> np.ndarray:
    pore = distance > 0
    clip = float(distance.max())
    dt = ndimage.distance_transform_edt(pore).astype(np.float32)
    dt[pore] -= 0.5
    analytic = (distance / h).astype(np.float32)
    dt = np.where(distance >= clip, np.maximum(dt, analytic), analytic)
    dt[~pore] = 0.0
    return dt


def _reference_scan(dt, pore, radii, inlet_axis):
    """The scan before the crops: two whole-grid transforms per radius."""
    lt = np.full(dt.shape, -1, np.int16)
    sat = []
    npore = max(int(np.count_nonzero(pore)), 1)
    invaded = np.zeros(dt.shape, bool)
    for i, r in enumerate(radii):
        seeds = dt >= r
        if not seeds.any():
            sat.append(0.0)
            continue
        cov = pores.edt(~seeds) <= r
        lab, n = ndimage.label(seeds)
        inlet = np.unique(np.take(lab, 0, axis=inlet_axis))
        inlet = inlet[inlet > 0]
        if inlet.size == n:
            inv = cov
        elif inlet.size == 0:
            inv = None
        else:
            lut = np.zeros(n + 1, bool)
            lut[inlet] = True
            inv = pores.edt(~lut[lab]) <= r
        lt[cov & pore & (lt < 0)] = i
        if inv is not None:
            invaded |= inv & pore
        sat.append(float(np.count_nonzero(invaded)) / npore)
    lt[pore & (lt < 0)] = len(radii) - 1
    return lt, sat


def _run(pore_dt, scan, fields, n_radii):
    load = os.getloadavg()[0]
    c0, t0 = time.process_time(), time.perf_counter()
    h = float(fields.grid.spacing[0])
    pore = ~fields.solid
    dt = pore_dt(fields.distance, h)
    rmax = float(dt.max())
    radii = np.unique(np.linspace(max(rmax, 1.0), min(1.0, rmax), n_radii))[::-1]
    lt, sat = scan(dt, pore, radii, 2)
    diam = 2.0 * h * radii[lt[pore]]
    q = np.percentile(diam, [10, 50, 90], method="inverted_cdf").tolist()
    timing = {"cpu_s": time.process_time() - c0, "wall_s": time.perf_counter() - t0}
    return lt, sat, {"d10_d50_d90_m": q, **timing, "load_1min": load}


def main() -> None:
    from bench_transport import _image

    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--radii", type=int, default=16)
    args = ap.parse_args()
    fields = _image(args.n)
    lt0, sat0, ref = _run(_reference_pore_dt, _reference_scan, fields, args.radii)
    whole = tuple(slice(0, n) for n in fields.solid.shape)  # the scans on the grid itself

    def cropped(dt, pore, radii, axis):
        return pores._scan(dt, pore, radii, axis, whole)

    lt1, sat1, new = _run(pores._edt_pore, cropped, fields, args.radii)
    out = {
        "n": args.n,
        "n_radii": args.radii,
        "reference": ref,
        "cropped": new,
        "cpu_ratio": ref["cpu_s"] / new["cpu_s"],
        "voxels_with_other_thickness": int(np.count_nonzero(lt0 != lt1)),
        "max_saturation_difference": float(np.max(np.abs(np.subtract(sat0, sat1)))),
    }
    c0 = time.process_time()
    res = pores.pore_sizes(fields, n_radii=args.radii)
    out["pore_sizes_cpu_s"] = time.process_time() - c0
    out["pore_sizes_wall_s"] = res.wall_time_s
    out["pore_sizes_d10_d50_d90_m"] = [res.pore_d10_m, res.pore_d50_m, res.pore_d90_m]
    out["diameter_error_m"] = res.diameter_error_m
    out["walled_axes"] = getattr(res, "walled_axes", "")  # before session 54: none
    out["diameter_error_below_m"] = getattr(res, "diameter_error_below_m", 0.0)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
