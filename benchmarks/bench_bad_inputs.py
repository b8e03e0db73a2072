"""Time the CLI on the malformed inputs of issue 11 and session 40's input audit: each must
exit 2 with one line, write nothing, and finish well within 10 s (the time is mostly Python
start-up and imports).

    python benchmarks/bench_bad_inputs.py          # one row per input, then a summary
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

RVE = "[rve]\nsize = [25e-6, 25e-6, 25e-6]\nvoxel = 1e-6\n"
GEN = "[generator]\nporosity = 0.8\ndiameter = 7e-6\n"
BASE = (
    "[base.rve]\nsize = [100e-6, 100e-6, 100e-6]\nvoxel = 1e-6\n"
    "[base.generator]\nporosity = 0.8\ndiameter = 7e-6\n"
)
SPECS = {
    "period_1m": RVE + "period = 1.0\n" + GEN,
    "grid_1200": "[rve]\nsize = [1.2e-3, 1.2e-3, 1.2e-3]\nvoxel = 1e-6\n" + GEN,
    "size_1e300": "[rve]\nsize = [1e300, 1e-4, 1e-4]\n" + GEN,
    "porosity_0.999": RVE + "[generator]\nporosity = 0.999\ndiameter = 7e-6\n",
    "theta_1e18": RVE + "[[fibers]]\ndiameter = 7e-6\ntheta = 1e18\n",
    "max_memory_x": RVE + GEN + '[flow]\nmax_memory_gb = "x"\n',
    "max_memory_0": RVE + GEN + "[flow]\nmax_memory_gb = 0\n",
    "mesh_table": RVE + GEN + "[mesh]\nx = 1\n",
    "output_table": RVE + GEN + "[output]\nx = 1\n",
    "forcefield_garbage": RVE + GEN + "[forcefield]\ngarbage = 1\n",
    "direction_w": RVE + GEN + '[flow]\ndirection = "w"\n',
    "tol_list": RVE + GEN + "[flow]\ntol = [1]\n",
    "layers": RVE + GEN + "layers = 3\n",
    "n_fibers_1e6": RVE + "[generator]\nn_fibers = 1e6\ndiameter = 7e-6\n",
    "population_1e7": RVE + GEN + '[intersections]\nmethod = "ga"\npopulation = 10000000\n',
    "generations_1e9": RVE + GEN + '[intersections]\nmethod = "ga"\ngenerations = 1000000000\n',
    "nesting_5000": "x = " + "[" * 5000 + "]" * 5000 + "\n",
    "fibers_20000": "[rve]\nsize = [1e-4, 1e-4, 1e-4]\nvoxel = 4e-7\n"
    + "[[fibers]]\ndiameter = 1e-6\n" * 20000,
    # session 40 (s40-fuzz)
    "max_memory_1e-300": RVE + GEN + "[flow]\nmax_memory_gb = 1e-300\n",
    # session 41 (s41-routes): the cap on the pytetwild and voxel routes (was: meshed / solved)
    "max_memory_1e-6_tetwild": RVE + GEN + '[flow]\nmesher = "pytetwild"\nmax_memory_gb = 1e-6\n',
    "max_memory_1e-6_voxel": RVE + GEN + '[flow]\nsolver = "voxel"\nmax_memory_gb = 1e-6\n',
}
#: Force-field specs (``psdesign forcefield``); session 40: the other case's table was ignored.
FORCEFIELD = {
    "six_fiber_table_two_case": '[forcefield]\ncase = "two-fiber"\n[forcefield.six_fiber]\n'
    "t_range = 0.3\n",
}
STUDIES = {
    "levels_1e9": BASE + '[study]\n[parameters]\n"generator.porosity" = '
    "{low = 0.7, high = 0.9, levels = 1e9}\n",
    "replicates_1e5": BASE
    + '[study]\nreplicates = 100000\n[parameters]\n"generator.porosity" = [0.8]\n',
    "n_samples_factorial": BASE
    + '[study]\nn_samples = 10\n[parameters]\n"generator.porosity" = [0.8]\n',
    "vary_layers": BASE + '[study]\n[parameters]\n"generator.layers" = [1, 2]\n',
    "level_0.999": BASE + '[study]\n[parameters]\n"generator.porosity" = [0.8, 0.999]\n',
    "range_1e12": BASE + '[study]\n[parameters]\n"generator.porosity" = '
    "{start = 0.0, stop = 1.0, step = 1e-12}\n",
    # session 40 (s40-fuzz): a level under 2 of the base's voxels (was blamed on base.rve.voxel)
    "diameter_1um": BASE + '[study]\ndesign = "latin-hypercube"\nn_samples = 4\n'
    '[parameters]\n"generator.diameter" = {low = 1e-6, high = 7e-6}\n',
}


def run(args: list[str], out: Path) -> tuple[int, int, float, bool, str]:
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "psdesign", *args], capture_output=True, text=True)
    dt = time.perf_counter() - t0
    lines = p.stderr.strip().splitlines()
    return p.returncode, len(lines), dt, out.exists(), (lines[0] if lines else "")


def main() -> int:
    rows = []
    with tempfile.TemporaryDirectory() as d:
        inputs = {
            **SPECS,
            **{f"study:{k}": v for k, v in STUDIES.items()},
            **{f"forcefield:{k}": v for k, v in FORCEFIELD.items()},
        }
        for name, text in inputs.items():
            f = Path(d) / f"{name.replace(':', '_')}.toml"
            out = Path(d) / "out"
            f.write_text(text)
            cmd = ["study", "run", str(f), "-o", str(out), "--quiet"]
            if name.startswith("forcefield:"):
                cmd = ["forcefield", str(f), "-o", str(out), "--no-pictures"]
            elif not name.startswith("study:"):
                cmd = ["generate", str(f), "-o", str(out)]
            rc, n, dt, wrote, first = run(cmd, out)
            rows.append((name, rc, n, dt, wrote))
            print(f"{name:22s} rc={rc} lines={n} {dt:5.2f} s wrote={wrote}  {first[:110]}")
    ok = all(rc == 2 and n == 1 and not w and dt < 10 for _, rc, n, dt, w in rows)
    print(
        f"{len(rows)} inputs, all exit 2 / one line / nothing written / < 10 s: {ok}; "
        f"max {max(r[3] for r in rows):.2f} s"
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
