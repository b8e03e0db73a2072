"""Transport benchmark (issue 13): psdesign vs PoreSpy and TauFactor on the same voxel image.

Run with an environment that has the peers (benchmark-only, never runtime or test deps)::

    python -m venv --system-site-packages /tmp/venv-bench && /tmp/venv-bench/bin/pip install \
        porespy taufactor
    PYTHONPATH=$PWD /tmp/venv-bench/bin/python benchmarks/bench_transport.py --n 200

Run with ``NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1`` to compare single-thread CPU times
(``cpu_s``; the machine is shared, wall times depend on its load).

Image: Toray-like carbon paper, 7 um straight fibres, porosity 0.8, fast zero-overlap
placement, seed 1, ``n^3`` voxels over a 100 um cube.  Each tool is timed once, one after the
other in one process (the machine is shared: the 1-minute load average is printed with each
timing so ratios are compared side by side).  Prints one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np


def _image(n: int):
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    spec = validate_spec(
        {
            "rve": {"size": [100e-6] * 3, "voxel": 100e-6 / n},
            "generator": {
                "kind": "straight",
                "porosity": 0.8,
                "diameter": 7e-6,
                "seed": 1,
                "theta": {"dist": "uniform", "low": -5.0, "high": 5.0},
                "omega": {"dist": "uniform", "low": 0.0, "high": 180.0},
            },
            "intersections": {"method": "fast", "min_gap": 0.5e-6},
        }
    )
    return build_rve(spec).voxelize(spec["rve"]["voxel"])


def _timed(fn):
    """Wall time, process CPU time (all threads) and the 1-minute load when it started; on a
    shared machine ``cpu_s`` with one thread is the load-independent figure."""
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    c0 = time.process_time()
    out = fn()
    return out, {
        "wall_s": time.perf_counter() - t0,
        "cpu_s": time.process_time() - c0,
        "load_1min": load,
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--radii", type=int, default=16)
    ap.add_argument("--skip-peers", action="store_true")
    args = ap.parse_args()
    fields = _image(args.n)
    pore = ~fields.solid
    res: dict = {"n": args.n, "porosity": fields.porosity, "cpus": os.cpu_count()}

    from psdesign.transport.diffusivity import relative_diffusivity
    from psdesign.transport.pores import pore_sizes
    from solvers.transport import solve_laplace

    solve_laplace(pore[:32, :32, :32].astype(float), 2, "fixed")  # compile the kernels
    for bc in ("permeameter", "periodic"):
        r, t = _timed(
            lambda bc=bc: relative_diffusivity(
                fields, "z", {"bc": bc, "error_estimate": "residual", "mean_free_path_m": 0.0}
            )
        )
        res[f"psdesign_diffusivity_z_{bc}"] = {
            "relative_diffusivity": r.relative_diffusivity,
            "tortuosity_factor": r.tortuosity_factor,
            "iterations": r.iterations,
            "flux_imbalance": r.flux_imbalance,
            **t,
        }
    p, t = _timed(lambda: pore_sizes(fields, n_radii=args.radii))
    sat = np.asarray(p.intrusion_saturation)
    dia = np.asarray(p.intrusion_diameter_m)
    res["psdesign_pores"] = {
        "d_at_half_saturation_m": float(np.interp(0.5, sat, dia)),
        "d10_m": p.pore_d10_m,
        "d50_m": p.pore_d50_m,
        "d90_m": p.pore_d90_m,
        "max_m": p.max_diameter_m,
        "breakthrough_m": p.breakthrough_diameter_m,
        **t,
    }
    if not args.skip_peers:
        _peers(fields, pore, args, res)
    print(json.dumps(res, indent=1, default=float))


def _peers(fields, pore, args, res) -> None:
    h = float(fields.grid.spacing[0])
    try:
        import taufactor
        import torch

        torch.set_num_threads(int(os.environ.get("NUMBA_NUM_THREADS", "1")))
        img = np.moveaxis(pore, 2, 0).astype(np.float32)  # TauFactor drives along axis 0
        solver = taufactor.Solver(img, device="cpu")
        _, t = _timed(lambda: solver.solve(verbose=False, conv_crit=1e-3))
        res["taufactor_z"] = {
            "tau": float(np.ravel(np.asarray(solver.tau))[0]),
            "relative_diffusivity": float(np.ravel(np.asarray(solver.D_eff))[0]),
            **t,
        }
    except Exception as exc:  # a peer must not stop the benchmark
        res["taufactor_error"] = repr(exc)
    try:
        import porespy as ps

        lt, t = _timed(lambda: ps.filters.local_thickness(pore, sizes=args.radii))
        d = 2.0 * h * lt[pore]
        res["porespy_local_thickness"] = {
            "d10_m": float(np.percentile(d, 10)),
            "d50_m": float(np.percentile(d, 50)),
            "d90_m": float(np.percentile(d, 90)),
            "max_m": float(d.max()),
            **t,
        }
        inlets = np.zeros_like(pore)
        inlets[:, :, 0] = True
        mip, t = _timed(lambda: ps.filters.porosimetry(pore, sizes=args.radii, inlets=inlets))
        radii = np.unique(mip[pore & (mip > 0)])[::-1]
        sat = np.array([np.count_nonzero(mip[pore] >= r) for r in radii]) / pore.sum()
        res["porespy_porosimetry"] = {
            "breakthrough_m": float(2.0 * h * radii[0]),
            "d_at_half_saturation_m": float(2.0 * h * np.interp(0.5, sat, radii)),
            **t,
        }
    except Exception as exc:
        res["porespy_error"] = repr(exc)
    try:
        import porespy as ps

        tort, t = _timed(lambda: ps.simulations.tortuosity_fd(pore, axis=2))
        res["porespy_tortuosity_fd_z"] = {
            "tortuosity": float(tort.tortuosity),
            "formation_factor": float(getattr(tort, "formation_factor", np.nan)),
            **t,
        }
    except Exception as exc:
        res["porespy_tortuosity_error"] = repr(exc)


if __name__ == "__main__":
    main()
