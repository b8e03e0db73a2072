"""pytetwild's default target edge length: a fraction of the thinnest fiber diameter (issue 12
item 5), the box-diagonal rule kept for ``flow.edge_length`` and for a plain field."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from psdesign.meshing.errors import MeshInputError
from psdesign.meshing.options import MeshOptions, thinnest_fiber_diameter
from psdesign.meshing.tetwild_mesher import (
    DEFAULT_EDGE_FAC,
    EDGE_PER_DIAMETER,
    ENVELOPE_PER_DIAMETER,
    ENVELOPE_PER_STEP,
    default_surface_step,
    envelope_rel,
    target_edge_length,
)

D = 7e-6


def _box(side: float) -> np.ndarray:
    return np.full(3, side)


@pytest.mark.parametrize("side", [60e-6, 100e-6, 200e-6])
def test_default_edge_is_a_fraction_of_the_fiber_diameter_whatever_the_box(side):
    opts = MeshOptions.from_flow({"mesher": "pytetwild"}, fiber_diameter=D)
    assert target_edge_length(_box(side), 2, opts) == pytest.approx(EDGE_PER_DIAMETER * D)
    opts = opts.replace(edge_per_diameter=0.5)
    assert target_edge_length(_box(side), 2, opts) == pytest.approx(3.5e-6)


def test_flow_edge_length_keeps_its_meaning_a_fraction_of_the_box_diagonal():
    # 100 um cube, aux zones 0.2 at both ends of z: box 100 x 100 x 140 um, diagonal 199 um
    opts = MeshOptions.from_flow({"mesher": "pytetwild", "edge_length": 0.03}, fiber_diameter=D)
    diag = np.sqrt(100.0**2 + 100.0**2 + 140.0**2) * 1e-6
    assert target_edge_length(_box(100e-6), 2, opts) == pytest.approx(0.03 * diag)
    # metres override both rules
    assert target_edge_length(_box(100e-6), 2, opts.replace(edge_length=4e-6)) == 4e-6


def test_plain_field_without_fibers_falls_back_to_the_box_rule():
    opts = MeshOptions(mesher="pytetwild", aux_length=0.0)
    diag = np.sqrt(3.0) * 60e-6
    assert target_edge_length(_box(60e-6), 0, opts) == pytest.approx(DEFAULT_EDGE_FAC * diag)
    assert DEFAULT_EDGE_FAC == 0.05  # the old default, unchanged for direct callers


def test_surface_step_follows_the_edge():
    # a fifth of the edge in voxels: 0.85 * 7 um / (5 * 0.5 um) = 2.38 -> 2
    opts = MeshOptions(mesher="pytetwild", fiber_diameter=D, edge_per_diameter=0.85)
    assert default_surface_step(0.5e-6, _box(100e-6), 2, opts) == 2
    assert default_surface_step(0.5e-6, _box(100e-6), 2, opts.replace(edge_per_diameter=2.0)) == 5


def test_default_envelope_is_a_fraction_of_the_fiber_diameter():
    """With the edge from the fiber diameter the envelope is D / 28 whatever the voxel and the
    marching-cubes step: 0.25 um at D = 7 um, 0.0012563 of the 100 x 100 x 140 um Table III
    box diagonal (the halved envelope measured on the five seeds, docs/meshers.md session 9).
    An explicit edge keeps the step rule (half a marching-cubes step), an explicit epsilon wins.
    """
    diag = float(np.linalg.norm([100e-6, 100e-6, 140e-6]))
    opts = MeshOptions.from_flow({"mesher": "pytetwild"}, fiber_diameter=D).replace(surface_step=2)
    assert ENVELOPE_PER_DIAMETER == pytest.approx(1.0 / 28.0)
    for voxel in (0.25e-6, 0.5e-6, 1e-6):
        assert envelope_rel(voxel, opts, diag) * diag == pytest.approx(0.25e-6, rel=1e-12, abs=0)
    assert envelope_rel(0.5e-6, opts, diag) == pytest.approx(0.0012563, rel=1e-4)
    # the old rule, half a marching-cubes step (2 x 0.5 um): twice the new envelope here
    coarse = opts.replace(edge_length_fac=0.03)
    assert ENVELOPE_PER_STEP == 0.5
    assert envelope_rel(0.5e-6, coarse, diag) * diag == pytest.approx(0.5e-6, rel=1e-12, abs=0)
    plain = MeshOptions(mesher="pytetwild", surface_step=3)
    assert envelope_rel(1e-6, plain, diag) * diag == pytest.approx(1.5e-6, rel=1e-12, abs=0)
    assert envelope_rel(0.5e-6, opts.replace(epsilon=0.004), diag) == 0.004


def test_fiber_diameter_envelope_changes_the_cache_key_only_where_it_applies():
    """The fiber diameter sets the envelope exactly where it sets the edge: a pytetwild mesh
    with an explicit edge and a stuffing mesh keep their keys."""
    tw = MeshOptions(mesher="pytetwild", fiber_diameter=D)
    assert tw.replace(fiber_diameter=1.1 * D).cache_params() != tw.cache_params()
    explicit = MeshOptions(mesher="pytetwild", edge_length=4e-6)
    assert explicit.replace(fiber_diameter=D).cache_params() == explicit.cache_params()


def test_thinnest_fiber_diameter_in_metres():
    fibers = [SimpleNamespace(diameter=d) for d in (0.07, 0.05, 0.09)]
    assert thinnest_fiber_diameter(SimpleNamespace(fibers=fibers, period=1e-4)) == 5e-6
    assert thinnest_fiber_diameter(SimpleNamespace(fibers=[], period=1e-4)) is None


@pytest.mark.parametrize(
    ("key", "value"),
    [("edge_per_diameter", 0.0), ("edge_per_diameter", 11.0), ("fiber_diameter", -1e-6)],
)
def test_bad_edge_options_name_the_key(key, value):
    with pytest.raises(MeshInputError, match=key):
        MeshOptions(mesher="pytetwild", **{key: value})


def test_fiber_diameter_leaves_other_cache_keys_alone():
    plain = MeshOptions().cache_params()
    assert MeshOptions(fiber_diameter=D).cache_params() == plain  # stuffing
    tw = MeshOptions(mesher="pytetwild", edge_length_fac=0.05)
    assert tw.replace(fiber_diameter=D).cache_params() == tw.cache_params()
    tw = MeshOptions(mesher="pytetwild", fiber_diameter=D)
    assert tw.replace(fiber_diameter=2 * D).cache_params() != tw.cache_params()


def test_fem_route_passes_the_thinnest_fiber_diameter(monkeypatch):
    import psdesign.meshing.pore_mesh as pore_mesh
    from psdesign.flow import fem

    seen = {}
    monkeypatch.setattr(pore_mesh, "mesh_pore_space", lambda *a: seen.setdefault("opts", a[-1]))
    rve = SimpleNamespace(fibers=[SimpleNamespace(diameter=0.07)] * 2, period=1e-4)
    grid = SimpleNamespace(spacing=np.full(3, 1e-6), size=_box(1e-4))
    fields = SimpleNamespace(grid=grid, distance=None, analytic_distance=True)
    fem._mesh(rve, fields, "z", {"mesher": "pytetwild"}, "permeameter")
    assert seen["opts"].fiber_diameter == pytest.approx(D)
