"""OpenFOAM turnkey export: the spec's nu and rho, sampling function objects, ``Allrun``.

The OpenFOAM run itself (``test_allrun_k_matches_square_duct``) needs Debian's ``openfoam``
package (``simpleFoam`` on the PATH) and is skipped without it.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest
from meshes import box_mesh, tag_box_boundary

from psdesign.meshing.exports import export_mesh
from psdesign.meshing.exports.openfoam import case_constants, openfoam_permeability
from psdesign.meshing.result import PoreMesh

A = 20e-6  # duct side (m)


def _duct(n: int = 8, length: float = 2 * A) -> PoreMesh:
    """Square duct along z: lateral faces are no-slip walls (tagged ``wall``), no aux zones."""
    lo, hi = (0.0, 0.0, 0.0), (A, A, length)
    pts, tets = box_mesh(lo, hi, (n, n, 2 * n))
    tags = tag_box_boundary(pts, tets, lo, hi, flow_axis=2)
    walls = [tags.pop(k) for k in list(tags) if k.startswith("side_")]
    tags["wall"] = np.concatenate([tags["wall"], *walls])
    return PoreMesh(
        points=pts,
        tets=tets,
        facet_tags=tags,
        direction="z",
        porous_region=(0.25 * length, 0.75 * length),
        bounds=np.array([lo, hi]),
    )


def _value(text: str, key: str) -> float:
    return float(re.search(rf"^{key}\s+([-+0-9.eE]+);", text, re.M).group(1))


def test_case_uses_spec_viscosity_and_density(tmp_path):
    flow = {"viscosity": 2.0e-3, "density": 800.0, "pressure_drop": 40.0}
    case = export_mesh(_duct(4), tmp_path, formats=("openfoam",), flow=flow)["openfoam"]
    nu = _value((case / "constant" / "transportProperties").read_text(), "nu")
    assert nu == pytest.approx(2.0e-3 / 800.0, rel=1e-9, abs=0)
    p = (case / "0" / "p").read_text()
    inlet = float(re.search(r"inlet\s*\{[^}]*uniform ([-+0-9.eE]+);", p).group(1))
    assert inlet == pytest.approx(40.0 / 800.0, rel=1e-9)  # kinematic pressure p / rho
    readme = (case / "README.txt").read_text()
    assert "rho = 800" in readme


def test_case_default_density_keeps_air(tmp_path):
    case = export_mesh(_duct(4), tmp_path, formats=("openfoam",), flow={"viscosity": 1.8e-5})[
        "openfoam"
    ]
    nu = _value((case / "constant" / "transportProperties").read_text(), "nu")
    assert nu == pytest.approx(1.8e-5 / 1.2, rel=1e-9, abs=0)


def test_function_objects_sample_patches_and_rve_planes(tmp_path):
    pm = _duct(4)
    case = export_mesh(pm, tmp_path, formats=("openfoam",))["openfoam"]
    ctrl = (case / "system" / "controlDict").read_text()
    for name in ("pInlet", "pOutlet", "flux", "fluxInlet", "pRveStart", "pRveEnd"):
        assert re.search(rf"^\s+{name}\s*$", ctrl, re.M), name
    pts = re.findall(r"point \(([^)]*)\); normal \(0 0 1\)", ctrl)
    zs = sorted(float(p.split()[2]) for p in pts)
    assert zs == pytest.approx(list(pm.porous_region), rel=1e-12, abs=0)
    allrun = case / "Allrun"
    assert allrun.stat().st_mode & 0o111
    text = allrun.read_text()
    assert "simpleFoam" in text and "checkMesh" in text and "gmshToFoam" in text
    change = (case / "system" / "changeDictionaryDict").read_text()
    assert re.search(r"wall\s*\{\s*type wall;", change)  # the gmsh route's wall patch


def test_permeability_formula_is_darcy():
    pm = _duct(4)
    c = case_constants(pm, {"viscosity": 1.8e-5, "density": 1.2})
    # Darcy: K = mu Q L / (A dp) with dp = rho * kinematic drop
    q, ps, pe = 3e-12, 0.7, 0.1
    k = openfoam_permeability(c, q, ps, pe)
    assert k == pytest.approx(
        1.8e-5 * q * (0.5 * 2 * A) / (A * A * 1.2 * (ps - pe)), rel=1e-12, abs=0
    )


@pytest.mark.slow
@pytest.mark.skipif(
    shutil.which("simpleFoam") is None, reason="OpenFOAM (simpleFoam) not installed"
)
def test_allrun_k_matches_square_duct(tmp_path):
    """Square duct: K = 0.0351443 a^2 (Shah & London 1978, fully developed laminar flow); the
    Allrun's K (RVE-plane definition) on a 10 x 10 x 40 hex-split mesh within 5 %."""
    case = export_mesh(_duct(10, length=4 * A), tmp_path, formats=("openfoam",))["openfoam"]
    out = subprocess.run(
        ["sh", str(case / "Allrun")], capture_output=True, text=True, timeout=1800, check=True
    ).stdout
    k = float(re.search(r"K_rve_planes = ([-+0-9.eE]+)", out).group(1))
    assert k == pytest.approx(0.0351443 * A * A, rel=0.05)
