"""The pytetwild route's error bar (session 39, helper s39-tetwild, ``benchmarks/tetwild_bar.py``).

Before: the bar's ``h`` was the box-relative lattice step (1.67 um on one 40 um cell of a square
array) while the mesh's edge was 21 um, and the "coarse" companion set ``flow.lattice_step``,
which pytetwild ignores: a second mesh as fine as the first was read as one twice as coarse. Three
``ok`` results were outside their bar (square across at 0.3: -3.5 % in 1.2 %).

Truth for the slow test: Sangani & Acrivos (1982), Int. J. Multiphase Flow 8, 193-206, Table 1
(square array, flow across; ``tests/reference_values.py``).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from arrays import array_spec, exact_k

from psdesign.flow import permeability as P
from psdesign.flow.error import FLOOR, resolution_floor


class _Grid:
    spacing = np.array([0.5e-6] * 3)
    size = np.array([40e-6, 40e-6, 26e-6])


class _Fields:
    grid = _Grid()


class _RVE:
    size = np.array([40e-6, 40e-6, 26e-6])


def _tetwild_result() -> dict:
    return {
        "permeability_m2": 1.5e-11,
        "porosity": 0.7,
        "direction": "x",
        "mesh_quality": {"edge_length_m": 21e-6, "edge_length_fraction": 0.1},
    }


def test_h_is_the_pytetwild_edge_and_the_coarse_mesh_doubles_it(monkeypatch):
    res = _tetwild_result()
    assert P._fem_step(res, _Fields(), _RVE(), {}) == pytest.approx(21e-6)
    asked = []

    def fake_route(rve, fields, direction, flow, solver, *a, **k):
        asked.append(flow)
        return {"permeability_m2": 1.4e-11}

    monkeypatch.setattr(P, "route_result", fake_route)
    run = P._coarse_fn(_RVE(), _Fields(), "x", {"mesher": "pytetwild"}, "fem", res)
    k, ratio = run()
    assert (k, ratio) == (1.4e-11, 2.0)
    assert asked[0]["edge_length"] == pytest.approx(0.2)
    assert "lattice_step" not in asked[0]


def test_coarse_edge_past_the_box_diagonal_is_not_asked_for(monkeypatch):
    res = _tetwild_result()
    res["mesh_quality"]["edge_length_fraction"] = 0.7  # x2 and x1.5 exceed 1
    monkeypatch.setattr(P, "route_result", lambda *a, **k: pytest.fail("no coarse solve"))
    run = P._coarse_fn(_RVE(), _Fields(), "x", {"mesher": "pytetwild"}, "fem", res)
    with pytest.raises(ValueError, match="box diagonal"):
        run()


def test_floor_law_of_the_pytetwild_scheme():
    # 0.06 (h / R)^2, R = sqrt(8 K / eps): the largest measured need 0.046 plus 30 %
    k, eps, h = 1.5e-11, 0.7, 21e-6
    r = math.sqrt(8 * k / eps)
    assert resolution_floor(h, k, eps, 2, FLOOR["tetwild"]) == pytest.approx(0.06 * (h / r) ** 2)


@pytest.mark.slow
def test_square_across_0p3_error_within_bar():
    """Sangani & Acrivos (1982) Table 1, square array across at solid fraction 0.3: the
    pytetwild route's K (one cell, default edge) lies within its bar or is untrustworthy."""
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_spec

    spec = array_spec("square", 0.3, 48)
    spec["flow"] = {**spec["flow"], "mesher": "pytetwild", "bc": "permeameter"}
    spec = validate_spec(spec)
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = P.permeability(built.rve, fields, "x", spec["flow"], "fem")
    err = res["permeability_m2"] / exact_k("square", "across", 0.3) - 1.0
    assert res["error_estimate"]["method"] == "two_grid"
    assert res["status"] == "untrustworthy" or abs(err) <= res["permeability_rel_error"]
    # h is the mesh's edge (0.85 D = 21 um), not the 1.67 um box-relative lattice step
    assert res["mesh_quality"]["edge_length_m"] == pytest.approx(21.0e-6, rel=0.01)
    assert res["error_estimate"]["floor"] > 0.1
    # the under-resolution line names the key that refines this mesh
    lines = [w for w in res["warnings"] if "mesh cells across" in w]
    assert lines and all("flow.edge_length" in w for w in lines)
    assert not any("flow.lattice_step" in w for w in res["warnings"])


def test_a_mesh_without_its_edge_fraction_says_so(monkeypatch):
    """A pytetwild mesh cached before session 39 has no ``edge_length_fraction``: the coarse
    solve is skipped with that reason (the bar falls back to the doubled floor)."""
    res = _tetwild_result()
    del res["mesh_quality"]["edge_length_fraction"]
    monkeypatch.setattr(P, "route_result", lambda *a, **k: pytest.fail("no coarse solve"))
    run = P._coarse_fn(_RVE(), _Fields(), "x", {"mesher": "pytetwild"}, "fem", res)
    with pytest.raises(ValueError, match="does not report its edge fraction"):
        run()
