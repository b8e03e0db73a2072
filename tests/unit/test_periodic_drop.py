"""``flow.pressure_drop`` drives the voxel route's periodic solve as it drives the FEM's
(session 50's walk): the mean gradient is ``G = pressure_drop / L`` over the RVE's length along
the flow, so the velocity, the flow rate and the fields of one spec are those of the drop the
spec names on either solver and bc. Until session 50 the voxel periodic solve ran at
``G = 1 Pa/m`` whatever the spec said: K was right, but its velocities (``mean_velocity_m_s``,
``flow_rate_m3_s``, the ``--fields`` VTI) were ``L / pressure_drop`` times too small (12 500 x
for an 80 um filter RVE at the default 1 Pa) beside the FEM periodic solve of the same spec.

Truth: plane Poiseuille flow between periodic plates (gap ``h``, period ``H``): the superficial
velocity is ``h^3 G / (12 mu H)`` (e.g. Bird, Stewart & Lightfoot, *Transport Phenomena*, 2nd
ed., Sec. 2.2, per unit width); the MAC grid's staircase plates on voxel faces give it +0.78 %
at 16 voxels across the gap (the slit of tests/cli/test_cli_image_slices.py)."""

from __future__ import annotations

import numpy as np
import pytest

from psdesign.flow.voxel import permeability_voxel
from psdesign.image.fields import image_fields

MU = 1.8e-5
VOXEL = 1e-6
GAP, PERIOD, LENGTH = 16e-6, 24e-6, 8e-6  # plates normal to z, flow along x


def _slit():
    solid = np.zeros((8, 6, 24), dtype=bool)  # x y z voxels: 8 um along the flow
    solid[:, :, :4] = solid[:, :, 20:] = True  # 16 um gap in a 24 um period
    return image_fields(solid, VOXEL)


@pytest.mark.parametrize("drop", [1.0, 5.0])
def test_the_periodic_voxel_solve_runs_at_the_spec_pressure_drop(drop) -> None:
    flow = {"viscosity": MU, "bc": "periodic", "pressure_drop": drop}
    res = permeability_voxel(_slit(), "x", flow)
    grad = drop / LENGTH
    assert res["pressure_gradient_pa_m"] == pytest.approx(grad, rel=1e-12)
    u_closed = GAP**3 * grad / (12 * MU * PERIOD)  # plane Poiseuille, superficial
    # 1.5 %: the MAC grid's +0.78 %; at 1 Pa/m the velocity was drop / L = 1.25e5 x off
    assert res["mean_velocity_m_s"][0] == pytest.approx(u_closed, rel=0.015)
    assert res["flow_rate_m3_s"] == pytest.approx(u_closed * 6e-6 * PERIOD, rel=0.015)
    assert res["permeability_m2"] == pytest.approx(GAP**3 / (12 * PERIOD), rel=0.015)


def test_the_diffuse_wall_route_runs_at_the_spec_pressure_drop() -> None:
    """The diffuse wall's periodic solve takes the same ``G`` (it ran at 1 Pa/m too): along
    a square array of cylinders (spacing 24 um, solid fraction 0.3, 24 voxels per spacing) two
    drops give one K and velocities in the drops' ratio (Stokes flow is linear in ``G``)."""
    from arrays import L, radius_of

    from psdesign.flow.permeability import permeability
    from psdesign.geometry.fibers import make_fiber
    from psdesign.geometry.rve import RVE

    n, depth = 24, 2
    h = L / n
    d = 2 * radius_of(0.3, "square", spacing=L) / L
    fb = make_fiber("cylinder", d, center=[0.5, 0.5, 0.5 * depth * h / L], direction=[0, 0, 1])
    rve = RVE([L, L, depth * h], [fb], period=L)
    flow = {"solver": "voxel", "bc": "periodic", "wall_treatment": "diffuse", "viscosity": MU}
    out = []
    for drop in (1.0, 4.0):
        f = flow | {"pressure_drop": drop}
        res = permeability(rve, rve.voxelize(h), "z", f, "voxel", error_estimate=False)
        assert res["pressure_gradient_pa_m"] == pytest.approx(drop / (depth * h), rel=1e-12)
        out.append(res)
    assert out[1]["permeability_m2"] == pytest.approx(out[0]["permeability_m2"], rel=1e-6)
    u0, u1 = (r["mean_velocity_m_s"][2] for r in out)
    assert u1 == pytest.approx(4.0 * u0, rel=1e-6)
    # and the velocity is the K of the drop the spec names: u = K G / mu
    assert u0 == pytest.approx(out[0]["permeability_m2"] * 1.0 / (depth * h) / MU, rel=1e-9)
