"""Permeability chain: spec -> RVE -> tet mesh -> Taylor-Hood Stokes -> Darcy."""

import json
import subprocess
import sys

import numpy as np
import pytest

SPEC = """
[rve]
size = [40e-6, 40e-6, 120e-6]
voxel = 0.5e-6
[[fibers]]
shape = "cylinder"
diameter = 10e-6
center = [20e-6, 20e-6, 60e-6]
direction = [0, 0, 1]
[flow]
edge_length = 0.04
viscosity = 1.8e-5
"""


def drummond_tahir_parallel(a, phi):
    """Flow along a square array of cylinders of radius a, solid fraction phi.

    Drummond & Tahir (1984), Int. J. Multiphase Flow 10, 515-540, Eq. (parallel flow):
    K / a^2 = (-ln phi - 1.476 + 2 phi - phi^2 / 2) / (4 phi).
    """
    return a**2 * (-np.log(phi) - 1.476 + 2 * phi - phi**2 / 2) / (4 * phi)


def test_flow_along_cylinder_array_through_cli_json(tmp_path):
    spec = tmp_path / "cyl.toml"
    spec.write_text(SPEC)
    proc = subprocess.run([sys.executable, "-m", "psdesign.cli", "permeability", str(spec),
                           "--direction", "z", "--json"], capture_output=True, text=True,
                          timeout=900)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    for key in ("permeability_m2", "direction", "porosity", "solver", "n_dofs", "wall_time_s",
                "flux_imbalance", "converged", "residual", "iterations", "sides"):
        assert key in out
    assert out["converged"] and out["flux_imbalance"] < 1e-4 and out["sides"] == "slip"
    a = 5e-6
    phi = np.pi * a**2 / (40e-6) ** 2
    exact = drummond_tahir_parallel(a, phi)
    # porosity on the voxel grid vs the exact solid fraction
    assert out["porosity"] == pytest.approx(1 - phi, abs=2e-3)
    # fully developed core of the RVE: slip sides = symmetry planes of the periodic array
    assert out["permeability_core_m2"] == pytest.approx(exact, rel=0.03)
    # whole-RVE value includes the flow development after the empty inlet zone: lower
    assert 0.85 * exact < out["permeability_m2"] < out["permeability_core_m2"]
