"""Fake case functions and study-file helpers shared by the study and report tests.

The case functions are module-level so that they pickle to worker processes; the fake "solver"
is Kozeny-Carman (independent of psdesign).
"""

from __future__ import annotations

import base64
import errno
import os
import textwrap
import time
from pathlib import Path

import numpy as np

TESTS_DIR = Path(__file__).resolve().parent
PNG_1PX = base64.b64decode(
    "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNkYPhfDwAChwGA60e6kgAAAABJRU5ErkJggg=="
)


# ----------------------------------------------------------------------------- fake case functions
# Module-level so that they pickle to worker processes.


def kc_truth(eps: float, d: float) -> float:
    """Kozeny-Carman with k_K = 5: the 'solver' of the fake case (independent of psdesign)."""
    r = d / 2
    return r * r * eps**3 / (20.0 * (1 - eps) ** 2)


def fake_case(spec, outputs, solver, workdir):
    g = spec["generator"]
    eps = float(g["porosity"])
    k = kc_truth(eps, float(g["diameter"]))
    noise = 1.0 + 0.01 * np.random.default_rng(g["seed"]).standard_normal()
    out = {"porosity": eps, "n_fibers": 12, "solver_used": solver}
    for i, a in enumerate("xyz"):
        if f"k_{a}" in outputs:
            out[f"k_{a}_m2"] = k * (1 + 0.5 * i) * noise
            out[f"converged_{a}"] = True
            out[f"iterations_{a}"] = 40 + i
            out[f"flux_imbalance_{a}"] = 1e-5
    if "k_tensor" in outputs:
        out["k_tensor_m2"] = np.diag([k, k, 2 * k])
    (workdir / "preview.png").write_bytes(PNG_1PX)
    out["preview_png"] = workdir / "preview.png"
    with open(workdir / "calls.txt", "a") as fh:
        fh.write(f"{os.getpid()}\n")
    return out


def porosity_case(spec, outputs, solver, workdir):
    """A case function of the user's that writes the porosity and a diffusivity only, whatever
    the study's outputs (a target on K then has no column)."""
    return {"porosity": float(spec["generator"]["porosity"]), "diffusivity_x": 0.5}


def fields_case(spec, outputs, solver, workdir):
    """fake_case with the picture ``[study] fields = true`` adds (``fields/flow_z.png``), returned
    as run_case returns it: an absolute path into the case's folder."""
    out = fake_case(spec, outputs, solver, workdir)
    (workdir / "fields").mkdir(exist_ok=True)
    (workdir / "fields" / "flow_z.png").write_bytes(PNG_1PX)
    out["fields_png"] = str(workdir / "fields" / "flow_z.png")
    return out


def failing_case(spec, outputs, solver, workdir):
    if spec["generator"]["porosity"] == 0.8:
        raise RuntimeError("mesh failed\nsecond line")
    return fake_case(spec, outputs, solver, workdir)


def mixed_status_case(spec, outputs, solver, workdir):
    """A fake case with every status a real study shows: porosity 0.7 fails, 0.9 with seed 2 does
    not converge along z, and 0.9 with seed 1 gives an untrustworthy K_z (a 30 % error bar, the
    case itself stays ``ok``); the rest are ``ok`` with a 2 % bar."""
    g = spec["generator"]
    eps = float(g["porosity"])
    if eps == 0.7:
        raise RuntimeError("mesh failed")
    out = fake_case(spec, outputs, solver, workdir)
    out["fields_png"] = out["preview_png"]  # as with [study] fields = true
    for a in "xyz":
        if f"k_{a}_m2" in out:
            out[f"k_{a}_rel_error"] = 0.02
            out[f"k_{a}_status"] = "ok"
    if eps == 0.9 and "k_z_m2" in out:
        if g["seed"] == 2:
            out["converged_z"] = False
            out["k_z_status"] = "not_converged"
        else:
            out["k_z_rel_error"] = 0.3
            out["k_z_status"] = "untrustworthy"
    return out


def two_direction_case(spec, outputs, solver, workdir):
    """A voxel case as a two-direction study row holds it: each K with its bar, bc and cells per
    fiber diameter; porosity 0.9 at 5 voxels per diameter (untrustworthy, both directions, the
    reason the longest status cell a report shows) and with a 25 % bar along z."""
    out = fake_case(spec, outputs, solver, workdir)
    eps = float(spec["generator"]["porosity"])
    for a in "xyz":
        if f"k_{a}_m2" in out:
            out[f"k_{a}_rel_error"] = 0.04
            out[f"k_{a}_status"] = "untrustworthy" if eps >= 0.9 else "ok"
            out[f"bc_{a}"] = "permeameter"
            out[f"cells_per_diameter_{a}"] = 5.0 if eps >= 0.9 else 9.0
            out[f"permeameter_copies_{a}"] = 2
    if eps >= 0.9 and "k_z_m2" in out:
        out["k_z_rel_error"] = 0.25
    return out


def untrusted_case(spec, outputs, solver, workdir):
    """Every K untrustworthy (as a periodic solve of a non-periodic RVE is); the case is ok."""
    out = fake_case(spec, outputs, solver, workdir)
    for a in "xyz":
        if f"k_{a}_m2" in out:
            out[f"k_{a}_status"] = "untrustworthy"
            out[f"warnings_{a}"] = f"K_{a}: bc = 'periodic' on a geometry that is not periodic"
    return out


def kind_case(spec, outputs, solver, workdir):
    """Kozeny-Carman K, three times larger for a bent generator: a category that moves K."""
    out = fake_case(spec, outputs, solver, workdir)
    for a in "xyz":
        if f"k_{a}_m2" in out and spec["generator"]["kind"] == "bent":
            out[f"k_{a}_m2"] *= 3.0
    return out


def scattered_case(spec, outputs, solver, workdir):
    """Kozeny-Carman K with 10 % seed-to-seed scatter (a small RVE's), 2 % error bar."""
    g = spec["generator"]
    eps, d = float(g["porosity"]), float(g["diameter"])
    rng = np.random.default_rng([int(g["seed"]), int(round(eps * 1e6)), int(round(d * 1e12))])
    k = kc_truth(eps, d) * (1 + 0.10 * rng.standard_normal())
    return {"porosity": eps, "k_z_m2": k, "converged_z": True, "k_z_rel_error": 0.02}


def disk_full_case(spec, outputs, solver, workdir):
    """Every case meets a full disk (ENOSPC), as a case writing on a full tmpfs does."""
    raise OSError(errno.ENOSPC, "No space left on device")


def sleepy_case(spec, outputs, solver, workdir):
    (workdir / "pid.txt").write_text(str(os.getpid()))
    if spec["generator"]["porosity"] == 0.9:
        time.sleep(60)
    return fake_case(spec, outputs, solver, workdir)


def record_breaking_case(spec, outputs, solver, workdir):
    """Porosity 0.7: the case replaces its work folder by a file, so the runner's own write of
    its record fails (an error in the runner, not a case failure); the other cases sleep 60 s."""
    import shutil

    if spec["generator"]["porosity"] == 0.7:
        time.sleep(1.0)
        shutil.rmtree(workdir)
        workdir.write_text("x")
        return {}
    (workdir / "pid.txt").write_text(str(os.getpid()))
    time.sleep(60)
    return fake_case(spec, outputs, solver, workdir)


def crash_case(spec, outputs, solver, workdir):
    if spec["generator"]["porosity"] == 0.8:
        os._exit(3)  # the worker process dies, like a segfault or an OOM kill
    return fake_case(spec, outputs, solver, workdir)


def slow_counting_case(spec, outputs, solver, workdir):
    with open(workdir / "calls.txt", "a") as fh:
        fh.write("start\n")
    time.sleep(0.25)
    out = fake_case(spec, outputs, solver, workdir)
    return out


# ----------------------------------------------------------------------------- helpers

BASE = """
[base.rve]
size = [100e-6, 100e-6, 100e-6]
voxel = 1e-6
[base.generator]
kind = "straight"
porosity = 0.8
diameter = 7e-6
seed = 1
theta = { dist = "uniform", low = -5.0, high = 5.0 }
[base.flow]
solver = "voxel"
aux_length = 0.2
"""


def write_study(tmp_path: Path, study: str, params: str, name="s.toml") -> Path:
    p = tmp_path / name
    p.write_text(
        BASE + "\n[study]\n" + textwrap.dedent(study) + "\n[parameters]\n" + textwrap.dedent(params)
    )
    return p


def write_entangled_study(tmp_path: Path) -> Path:
    """A csv study whose two parameters move together (diameter = 1e-5 * porosity, 8 points
    on porosity 0.7-0.9): its cases cannot tell the two effects apart."""
    import numpy as np
    import pandas as pd

    eps = np.linspace(0.7, 0.9, 8)
    pd.DataFrame({"generator.porosity": eps, "generator.diameter": 1e-5 * eps}).to_csv(
        tmp_path / "pts.csv", index=False
    )
    return write_study(
        tmp_path,
        'design = "csv"\ncsv = "pts.csv"\nseeds = [1]\noutputs = ["porosity", "k_z"]\n'
        'solver = "voxel"',
        "",
    )


FACTORIAL = """
name = "fac"
design = "full-factorial"
seeds = [1, 2]
outputs = ["porosity", "k_x", "k_z"]
solver = "voxel"
"""
FAC_PARAMS = """
"generator.porosity" = [0.7, 0.8, 0.9]
generator.diameter = { start = 6e-6, stop = 8e-6, step = 2e-6 }
"""


def rev_porosity_case(spec, outputs, solver, workdir):
    """REV case with the real RVE's porosity (generated and voxelized as a study case does) and
    a constant K: the rev study's packing at each size, without a flow solve."""
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    spec = validate_spec(spec)
    built = build_rve(spec)
    out = {"porosity": built.voxelize(spec["rve"]["voxel"]).porosity}
    out["n_fibers"] = len(built.rve.fibers)
    for a in "xyz":
        if f"k_{a}" in outputs:
            out[f"k_{a}_m2"], out[f"converged_{a}"] = 5e-12, True
    return out


def rev_case(spec, outputs, solver, workdir):
    """Fake case for REV checks: K scatters like a volume average, std ~ (30 um / L)^1.5."""
    edge = float(spec["rve"]["size"][0])
    rng = np.random.default_rng([int(spec["generator"]["seed"]), int(round(edge * 1e9))])
    sigma = 0.3 * (30e-6 / edge) ** 1.5
    out = {"porosity": 0.8, "n_fibers": 10}
    for a in "xyz":
        if f"k_{a}" in outputs:
            out[f"k_{a}_m2"] = 5e-12 * (1.0 + sigma * rng.standard_normal())
            out[f"converged_{a}"] = True
    return out


def share_case(spec, outputs, solver, workdir):
    """The memory share the case runs in (:func:`psdesign.schema.budget.workers_at_once`)."""
    from psdesign.schema import budget

    return {"porosity": 0.5, "at_once": float(budget.workers_at_once()[0])}
