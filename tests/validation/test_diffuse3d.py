"""The diffuse-domain wall in an assembled 3-D staggered Stokes model (issue 12 item 3, the port's
first step, ``benchmarks/diffuse3d.py``).

Independent truths: the 2-D diffuse-domain model of ``benchmarks/penalty_scatter.py`` (a
separate 2-D assembly, solved directly) for cylinders extruded along z, where the 3-D flow is
independent of z and the two models must agree to round-off; Zick & Homsy (1982), J. Fluid Mech.
115, 13-26, Table 2 (simple cubic array of spheres) and refinement for a genuinely 3-D flow.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from diffuse3d import SHIFTS3, Spheres, extruded_check, solve  # noqa: E402
from penalty_scatter import parse_wall  # noqa: E402

#: The wall that converges monotonically on the 2-D square arrays (RESULTS.md, wall22).
WALL = parse_wall("logistic,0.75,-0.08385500,-0.00674740,-0.09675771,-0.01476628,2.55")


@pytest.mark.parametrize("nz", [1, 2])
def test_extruded_cylinders_give_the_2d_model(nz: int) -> None:
    # along (force along z: the w faces, their x / y fluxes on the z edges) and across (force
    # along x: u, v and p, their cross fluxes on the z edges) at phi 0.3, 12 voxels per spacing;
    # measured 1e-15 both ways
    along, across = extruded_check(WALL, 0.3, 12, nz)
    assert abs(along) < 1e-10
    assert abs(across) < 1e-10


@pytest.mark.slow
def test_spheres_converge_to_zick_and_homsy() -> None:
    # simple cubic c 0.125, one shift: -8.26 % at 16 voxels per box, -2.81 % at 24 (measured;
    # the MINRES solve agrees with a direct factorisation to 1e-11 at 16)
    errs = []
    for n in (16, 24):
        geo = Spheres(0.125, n, SHIFTS3[0], WALL)
        k, _ = solve((n, n, n), geo, 0)
        errs.append(k / geo.exact_k() - 1.0)
    assert -0.09 < errs[0] < -0.075
    assert -0.031 < errs[1] < -0.025
    assert abs(errs[1]) < 0.4 * abs(errs[0])
