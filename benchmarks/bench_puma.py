"""NASA PuMA (pumapy, built from its source) and psdesign side by side in one run.

For each grid, in this order and in one command: the geometry (PuMA's ``fibres_32`` /
``fibres_64`` from ``tests/data``, else :func:`ten_rods` rasterised at that size), psdesign's
periodic voxel Stokes solve (:func:`solvers.voxel_stokes.solve_voxel_stokes`, product default
``tol``, driven along z) and PuMA's ``compute_permeability`` on the same voxels, each in its own
process under ``/usr/bin/time -v`` (its peak RSS), PuMA niced with one BLAS/OpenMP thread.  It
prints one table: K_zz of both, their times and iterations, the speed ratio, both peak RSS, and
the physical limit of psdesign's solve (its iterations x bytes one iteration must stream /
STREAM-triad bandwidth measured in this run, :func:`bench_voxel.iteration_bytes` and
:func:`bench_voxel.triad_bandwidth`).  K is in unit-cube lengths squared (voxel length 1/N,
unit viscosity and body force, as PuMA was run for ``tests/data/README-puma.md``).

Above ``--puma-full-max`` voxels per side PuMA runs only ``--puma-capped-iters`` MINRES
iterations: its set-up time, its time per iteration and its peak memory are measured, and its
full time is estimated from the iteration growth of the full runs (printed as an estimate).
A grid whose PuMA memory, extrapolated from the two largest grids measured, exceeds
``--puma-mem-limit-gb`` is refused (printed as such).

Usage (the run recorded in ``benchmarks/RESULTS.md``, issue 16 item 7)::

    NUMBA_NUM_THREADS=1 PYTHONPATH=$PWD nice -n 19 python benchmarks/bench_puma.py \\
        --puma-python /work/venv-puma/bin/python 32 64 96 128 160 200 --out /tmp/puma_runs.jsonl

The 32/64 rows alone (about 7 min on this machine, PuMA's 64^3 solve most of it)::

    NUMBA_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/bench_puma.py \\
        --puma-python /work/venv-puma/bin/python 32 64

Building pumapy 3.2.2 from NASA's source into its own venv (never a psdesign dependency; the
PyPI name ``pumapy`` is an unrelated package)::

    git clone https://github.com/nasa/puma /tmp/puma-src      # commit 65a05d7 was used
    python3.11 -m venv /work/venv-puma
    /work/venv-puma/bin/pip install Cython "numpy<2" "scipy~=1.11.0" "scikit-image<0.25" \\
        matplotlib pyvista setuptools wheel
    /work/venv-puma/bin/pip install --no-build-isolation --no-deps /tmp/puma-src
    /work/venv-puma/bin/python -c "import pumapy; print(pumapy.__version__)"   # 3.2.2

(The four Cython extensions compile in about 1 min; the TexGen warning on import is harmless.)
This file runs in that venv for the ``_puma`` child, so its module level imports only the
standard library and numpy.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
DATA = HERE.parents[1] / "tests" / "data"  # PuMA's vendored geometries
PUMA_TOL = 1e-7  # PuMA's recommended MINRES tolerance (tests/data/README-puma.md)
TEN_RODS_SEED = 8  # seed 0-39 whose 64^3 porosity (0.9608) is nearest fibres_64's 0.9613


def ten_rods(
    n: int, seed: int = TEN_RODS_SEED, count: int = 10, diameter: float = 0.07
) -> np.ndarray:
    """Ten random straight rods in the unit cube, ``n^3`` voxels (True = solid), the family of
    PuMA's ``fibres_32`` / ``fibres_64`` (whose generator is not in the repository).

    Each rod is the infinite line through a uniformly random point with an isotropic random
    direction, clipped by the box (not periodic, as those grids), diameter ``diameter`` box
    lengths; a voxel is solid when its centre is within ``diameter / 2`` of a rod axis.  The
    same ``seed`` gives the same rods at every ``n``, so sizes are refinements of one geometry.
    """
    rng = np.random.default_rng(seed)
    points = rng.random((count, 3))
    dirs = rng.normal(size=(count, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    g = (np.arange(n) + 0.5) / n
    y, z = np.meshgrid(g, g, indexing="ij")
    out = np.zeros((n, n, n), dtype=bool)
    for i, x in enumerate(g):  # one x-slab at a time: memory O(n^2)
        p = np.stack([np.full_like(y, x), y, z], axis=-1)
        for f in range(count):
            r = p - points[f]
            t = r @ dirs[f]
            out[i] |= ((r - t[..., None] * dirs[f]) ** 2).sum(axis=-1) < (0.5 * diameter) ** 2
    return out


def geometry(n: int) -> tuple[np.ndarray, str]:
    """PuMA's own grid at 32 and 64, else :func:`ten_rods` (uint8, 1 = solid, [x, y, z])."""
    path = DATA / f"fibres_{n}.npz"
    if path.exists():
        return np.load(path)["solid"].astype(np.uint8), f"fibres_{n}"
    return ten_rods(n).astype(np.uint8), f"ten_rods(seed {TEN_RODS_SEED})"


def _time_v(cmd: list[str], env: dict[str, str], cwd: str) -> tuple[dict, float]:
    """Run ``cmd`` in ``cwd`` (pumapy writes a ``logs/`` folder there) under
    ``/usr/bin/time -v``: its last stdout line (JSON) and peak RSS (MB)."""
    out = subprocess.run(
        ["/usr/bin/time", "-v", *cmd],
        env=env,
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
    )
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", out.stderr)
    lines = out.stdout.strip().splitlines()
    if out.returncode != 0 or not lines:
        sys.stderr.write(out.stderr[-3000:])
        raise RuntimeError(f"{cmd[:3]} failed with exit code {out.returncode}")
    return json.loads(lines[-1]), int(rss.group(1)) / 1024.0 if rss else float("nan")


def puma_child(path: str, maxiter: int) -> None:
    """Run in PuMA's venv: one z solve of the grid in ``path``; print one JSON line."""
    import pumapy as puma

    solid = np.load(path)
    n = solid.shape[0]
    ws = puma.Workspace.from_array(solid)
    ws.voxel_length = 1.0 / n
    buf = io.StringIO()
    error = None
    keff = None
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(buf):
        try:
            keff, _ = puma.compute_permeability(
                ws, (1, 1), direction="z", tol=PUMA_TOL, maxiter=maxiter,
                solver_type="minres", output_fields=False,
            )  # fmt: skip
        except Exception as exc:  # noqa: BLE001 - PuMA raises Exception when maxiter is hit
            error = str(exc)
    wall = time.perf_counter() - t0
    log = buf.getvalue()
    its = [int(m) for m in re.findall(r"Iteration: (\d+)", log)]
    setup = re.search(r"Time to setup system: ([0-9.eE+-]+)", log)
    mem = re.search(r"Approximate memory requirement for simulation: ([^\n]+)", log)
    row = {
        "keff": None if keff is None else np.asarray(keff).tolist(),
        "iterations": max(its) if its else None,
        "converged": error is None,
        "error": error,
        "wall": wall,
        "setup": float(setup.group(1)) if setup else None,
        "memory_estimate": mem.group(1).strip() if mem else None,
        "version": puma.__version__,
    }
    print(json.dumps(row))


def psdesign_child(path: str) -> None:
    """One psdesign z solve of the grid in ``path`` after warm-up solves (every kernel it uses
    compiled or loaded from numba's cache first); bytes one iteration must stream on that grid;
    print one JSON line."""
    sys.path.insert(0, str(HERE.parent))
    import numba
    from bench_voxel import _warm_parallel, iteration_bytes

    from psdesign.flow.voxel import column_of
    from solvers import voxel_stokes as vs

    solid = np.load(path).astype(bool)
    n = solid.shape[0]
    _warm_parallel()
    warm = np.zeros((16, 16, 16), dtype=bool)  # a full small solve: the refinement kernels too
    warm[:, :2, :] = True
    vs.solve_voxel_stokes(warm, 1.0, "z")
    # and a few iterations on this grid: its multigrid levels may need kernel specialisations
    # the small grids did not (measured: 96^3 compiled serial Galerkin / Jacobi variants inside
    # the timed solve, CPU 28.3 s against 4.0-4.2 s with the cache warm)
    vs.solve_voxel_stokes(solid, 1.0 / n, "z", max_iter=3)
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    res = vs.solve_voxel_stokes(solid, 1.0 / n, "z")  # the product default tol
    wall = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    with vs._threads(solid.size):
        need = iteration_bytes(vs._Stokes.build(solid), lo_bytes=1, w_bytes=3)  # tol 1e-6
    row = {
        "k": [float(v) for v in column_of(res)],
        "iterations": int(res.iterations),
        "converged": bool(res.converged),
        "residual": float(res.residual),
        "wall": wall,
        "cpu": cpu,
        "peak_mb_solver": float(res.peak_memory_mb),
        "bytes_per_iteration": need,
        "threads": numba.get_num_threads(),
    }
    print(json.dumps(row))


def _power_fit(xs: list[float], ys: list[float]) -> tuple[float, float]:
    """Least-squares ``y = a x^b`` through the points: ``(a, b)``."""
    b, loga = np.polyfit(np.log(xs), np.log(ys), 1)
    return float(np.exp(loga)), float(b)


PUMA_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _puma_plan(n: int, args: argparse.Namespace, done: list[dict]) -> tuple[int, str | None]:
    """PuMA's ``maxiter`` at ``n`` (full or capped), or a refusal when the peak RSS extrapolated
    from the two largest grids already measured exceeds ``--puma-mem-limit-gb``.

    Only the two largest: the interpreter's ~150 MB dominates the small grids, and a fit
    through all of them (N^0.61 over 32-160) predicted 5.0 GB for 200^3 where the last two
    (N^0.94) predict 7.7 GB."""
    pts = sorted((r["n"] ** 3, r["puma"]["rss_mb"]) for r in done if "rss_mb" in r["puma"])[-2:]
    if len(pts) >= 2:
        a, b = _power_fit(*zip(*pts, strict=True))
        need = a * (n**3) ** b / 1024.0
        if need > args.puma_mem_limit_gb:
            return 0, (
                f"refused: peak RSS extrapolated from {pts[0][0]:.0f} and {pts[1][0]:.0f} "
                f"voxels (N^{b:.2f}) "
                f"{need:.1f} GB > --puma-mem-limit-gb {args.puma_mem_limit_gb}"
            )
    return (10000 if n <= args.puma_full_max else args.puma_capped_iters), None


def run_grid(n: int, args: argparse.Namespace, done: list[dict], bw: float) -> dict:
    """psdesign, then PuMA, on the same ``n^3`` grid, each in its own process."""
    solid, source = geometry(n)
    row: dict = {"n": n, "source": source, "porosity": float(1.0 - solid.mean())}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"grid_{n}.npy"
        np.save(path, solid)
        del solid
        row["load_before"] = os.getloadavg()[0]
        row["triad_GBs"] = bw / 1e9
        child = [sys.executable, str(HERE), "_psdesign", str(path)]
        ps, rss = _time_v(child, dict(os.environ), tmp)
        row["psdesign"] = {**ps, "rss_mb": rss}
        maxiter, refusal = _puma_plan(n, args, done)
        if refusal:
            row["puma"] = {"refused": refusal}
        else:
            cmd = ["nice", "-n", "19", args.puma_python, str(HERE), "_puma", str(path)]
            env = {**os.environ, **PUMA_ENV}
            env.pop("PYTHONPATH", None)  # PuMA's venv sees neither psdesign nor numba
            row["load_before_puma"] = os.getloadavg()[0]
            try:
                pm, rss = _time_v([*cmd, str(maxiter)], env, tmp)
                row["puma"] = {**pm, "rss_mb": rss, "maxiter": maxiter}
            except RuntimeError as exc:  # e.g. killed for memory: keep the other rows
                row["puma"] = {"error": str(exc), "maxiter": maxiter}
        row["load_after"] = os.getloadavg()[0]
    return row


def estimate_capped(rows: list[dict]) -> None:
    """PuMA's full time at capped grids: its set-up + (iterations extrapolated from the full
    runs as a power of n) x its measured time per iteration (in place, key ``estimate``)."""
    full = [r for r in rows if r["puma"].get("converged")]
    if len(full) < 2:
        return
    a, b = _power_fit([r["n"] for r in full], [r["puma"]["iterations"] for r in full])
    for r in rows:
        pm = r["puma"]
        if pm.get("converged") or not pm.get("iterations"):
            continue
        per_it = (pm["wall"] - pm["setup"]) / pm["iterations"]
        its = a * r["n"] ** b
        pm["estimate"] = {
            "iterations": its,
            "iterations_exponent_n": b,
            "per_iteration_s": per_it,
            "wall": pm["setup"] + its * per_it,
        }


def _fmt_k(k: float | None) -> str:
    return "-" if k is None else f"{k:.6f}"


def table(rows: list[dict]) -> str:
    """Markdown table of the run (K in unit-cube lengths squared, times in s, RSS in MB)."""
    bw = max(r["triad_GBs"] for r in rows) * 1e9  # the best triad of the run: the limit
    head = (
        "| grid | geometry, porosity | K_zz psdesign | K_zz PuMA | psdesign / PuMA K | "
        "psdesign solve (its) | PuMA (its) | PuMA / psdesign time | peak RSS psdesign / PuMA | "
        "limit | psdesign / limit | load |\n" + "|---" * 12 + "|"
    )
    out = [head]
    for r in rows:
        ps, pm = r["psdesign"], r["puma"]
        kp = pm["keff"][2][2] if pm.get("keff") else None
        limit = ps["iterations"] * ps["bytes_per_iteration"] / bw
        if pm.get("converged"):
            t_pm, t_txt = pm["wall"], f"{pm['wall']:.1f} s ({pm['iterations']})"
        elif "estimate" in pm:
            e = pm["estimate"]
            t_pm = e["wall"]
            t_txt = (
                f"~{e['wall']:.0f} s est. (~{e['iterations']:.0f} its x "
                f"{e['per_iteration_s']:.2f} s + set-up {pm['setup']:.0f} s; ran "
                f"{pm['iterations']})"
            )
        else:
            t_pm, t_txt = None, pm.get("refused", pm.get("error", "-"))
        ratio = "-" if t_pm is None else f"{t_pm / ps['wall']:.0f}x"
        kr = "-" if kp is None else f"{ps['k'][2] / kp:.3f}"
        rss_pm = f"{pm['rss_mb']:.0f}" if "rss_mb" in pm else "-"
        out.append(
            f"| {r['n']}^3 | {r['source']}, {r['porosity']:.5f} | {_fmt_k(ps['k'][2])} | "
            f"{_fmt_k(kp)} | {kr} | {ps['wall']:.2f} s ({ps['iterations']}) | {t_txt} | "
            f"{ratio} | {ps['rss_mb']:.0f} / {rss_pm} MB | {limit:.3f} s | "
            f"{ps['wall'] / limit:.2f}x | {r['load_before']:.1f}-{r['load_after']:.1f} |"
        )
    return "\n".join(out)


def main(argv: list[str]) -> None:
    if argv[1:2] == ["_puma"]:
        puma_child(argv[2], int(argv[3]))
        return
    if argv[1:2] == ["_psdesign"]:
        psdesign_child(argv[2])
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sizes", nargs="*", type=int, default=[32, 64])
    ap.add_argument("--puma-python", required=True, help="python of the venv with pumapy")
    ap.add_argument("--puma-full-max", type=int, default=64, help="largest full PuMA solve")
    ap.add_argument("--puma-capped-iters", type=int, default=20)
    ap.add_argument("--puma-mem-limit-gb", type=float, default=6.0)
    ap.add_argument("--out", type=Path, help="append one JSON line per grid")
    args = ap.parse_args(argv[1:])
    sys.path.insert(0, str(HERE.parent))
    from bench_voxel import triad_bandwidth

    rows: list[dict] = []
    for n in args.sizes:
        row = run_grid(n, args, rows, triad_bandwidth())
        rows.append(row)
        print(json.dumps(row), flush=True)
        if args.out:
            with args.out.open("a") as fh:
                fh.write(json.dumps(row) + "\n")
    estimate_capped(rows)
    if args.out:
        with args.out.open("a") as fh:
            fh.write(json.dumps({"final": rows}) + "\n")
    print(table(rows))


if __name__ == "__main__":
    main(sys.argv)
