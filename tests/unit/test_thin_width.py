"""A non-round fiber's resolution measure is its thin width, not its nominal (mean) diameter
(session 43, helper s43-thin; benchmarks/RESULTS.md "Session 43: ... (helper s43-thin)").

Before: :func:`psdesign.geometry.rve.thinnest_fiber_diameter` read each fiber's nominal
diameter, the mean of its widths across the centre line. The Eq. (19) woven yarn at a 100 um
period is 14.0 um thick through the fabric and 18.0 um across (diameter 16.0 um), so a grid
counted 16.0 / 14.0 = 1.14 times more cells across the yarn than its thickness has: 7.3 voxels
through it passed the 8 voxels per diameter of ``flow.error``'s status as 8.3.

Truths: (1) an elliptic tube (a section with semi-axes ``a`` in the bend plane and ``b`` across
it, around a bent or straight centre line) has the thin width ``2 min(a, b)`` and the diameter
``a + b`` (closed form); (2) the compressed straight fibre Eq. (17) has closed-form chords
through the cell's axis (its y terms sum to ``(3 + cos 2 pi z) cos 2 pi y``); (3) the woven
yarn's widths across its closed-form centre line on a 2e-5 grid
(tests/unit/test_fixed_shape_diameter.py, ``_grid_widths``).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from test_fixed_shape_diameter import _grid_widths, _Tube

from psdesign.flow.error import cells_per_diameter, status_of, untrustworthy_reasons
from psdesign.geometry.fibers import _measure_fixed_shape, make_fiber, woven_cell
from psdesign.geometry.rve import RVE, resolution_measure, thinnest_fiber_diameter


class _EllipticTube(_Tube):
    """``(n / a)^2 + ((y - 1/2) / b)^2 - 1``, ``n`` the distance in the x-z plane to the bent
    centre line ``(1/2 + amp cos(2 pi z), 1/2, z)``: across the centre line the section is the
    ellipse of semi-axes ``a`` (in the bend plane) and ``b`` (along y)."""

    def __init__(self, a: float, b: float, amp: float) -> None:
        super().__init__(a, amp)
        self.b = b

    def evaluate(self, p: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(p)
        q = self._nearest(p)
        n2 = (p[:, 0] - q[:, 0]) ** 2 + (p[:, 2] - q[:, 2]) ** 2
        return n2 / self.r**2 + (p[:, 1] - 0.5) ** 2 / self.b**2 - 1.0

    def gradient(self, p: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(p)
        d = p - self._nearest(p)  # the nearest point is stationary (envelope theorem)
        return 2.0 * d / np.array([self.r**2, self.b**2, self.r**2])


@pytest.mark.parametrize("a, b", [(0.05, 0.08), (0.08, 0.05)])
@pytest.mark.parametrize("amp", [0.0, 0.05])
def test_an_elliptic_section_gives_its_minor_width(a, b, amp):
    """Truth (1) to 2e-6 (the bisection's and the centre line's tolerances): thin width
    2 min(a, b), diameter a + b, at any bend (slope up to 0.31 at amp 0.05)."""
    d, _, thin = _measure_fixed_shape(_EllipticTube(a, b, amp), 0.0)
    assert thin == pytest.approx(2 * min(a, b), abs=2e-6)
    assert d == pytest.approx(a + b, abs=2e-6)


def _compressed_straight_thin_width() -> float:
    """Truth (2): Eq. (17) ``4 cos 2pi x + 3 cos 2pi y + 0.95 cos 2pi z + 0.5 cos 2pi(y + z)
    + 0.5 cos 2pi(y - z) + 6.55 <= 0``; through the axis (x = y = 1/2 at the centre) the chord
    along x solves ``cos 2pi x <= (0.05 cos 2pi z - 3.55) / 4`` and the one along y
    ``cos 2pi y <= -(2.55 + 0.95 cos 2pi z) / (3 + cos 2pi z)``; a chord ``cos 2 pi s <= c``
    about 1/2 is ``1 - arccos(c) / pi`` long. The mean over the 7 heights of the narrower."""
    z = np.arange(7) / 7
    cz = np.cos(2 * np.pi * z)
    wx = 1 - np.arccos((0.05 * cz - 3.55) / 4) / np.pi
    wy = 1 - np.arccos(-(2.55 + 0.95 * cz) / (3 + cz)) / np.pi
    return float(np.mean(np.minimum(wx, wy)))


def test_the_resolution_measure_of_a_compressed_fiber_is_its_closed_form_thin_width():
    """Truth (2): 0.152327 of a period (its diameter 0.165989); main read the diameter (9 %
    more)."""
    rve = SimpleNamespace(fibers=[make_fiber("compressed-straight")], period=1e-4)
    assert thinnest_fiber_diameter(rve) == pytest.approx(
        1e-4 * _compressed_straight_thin_width(), rel=1e-9
    )
    assert resolution_measure(rve) == "fiber thin width"


def test_the_woven_yarn_measures_its_thickness():
    """Truth (3): the thin width of the Table I cell's yarns (u = +-0.41) is the mean of the
    grid's narrower widths, 13.99 um at 100 um, to two grid steps (main: 15.98 um, the mean of
    both widths)."""
    truth = float(np.mean(np.min(_grid_widths(0.41), axis=1)))
    rve = SimpleNamespace(fibers=woven_cell(), period=1e-4)
    assert thinnest_fiber_diameter(rve) == pytest.approx(1e-4 * truth, abs=1e-4 * 4e-5)
    assert truth == pytest.approx(0.1399, abs=1e-4)


def test_round_fibers_keep_their_diameter():
    """A rod's resolution measure is its diameter and its words "fiber diameter" (no change)."""
    rods = [
        make_fiber("rod", 0.07),
        make_fiber("cylinder", 0.05),
        make_fiber("bent-rod", 0.06, u=0.3),
    ]
    rve = SimpleNamespace(fibers=rods, period=1e-4)
    assert thinnest_fiber_diameter(rve) == 0.05 * 1e-4
    assert resolution_measure(rve) == "fiber diameter"
    assert all(fb.thin_width is None for fb in rods)


def test_a_woven_grid_with_8_voxels_per_diameter_but_7_through_the_yarn_is_untrustworthy():
    """52 voxels across the 100 um woven cell (1.92 um): 8.31 voxels per nominal diameter (ok
    on main), 7.28 through the yarn's 13.99 um: untrustworthy, and the reason says which
    measure."""
    rve = RVE([1e-4] * 3, woven_cell())
    h = 1e-4 / 52
    cpd = cells_per_diameter(rve, h)
    assert cpd == pytest.approx(7.277, abs=2e-3)
    assert rve.fibers[0].diameter * 1e-4 / h == pytest.approx(8.309, abs=2e-3)
    assert status_of(True, 0.05, cpd) == "untrustworthy"
    why = untrustworthy_reasons(0.05, cpd, measure=resolution_measure(rve))
    assert why == ["7.3 voxels per fiber thin width, need 8"]


def test_the_voxel_route_rates_a_woven_grid_by_the_yarn_thickness():
    """End to end (voxel route, periodic, with its error bar): the one-layer woven cell on the
    52^3 grid is ``untrustworthy`` by resolution alone, and its warning and its
    ``resolution_measure`` name the thin width (main: ``ok``, 8.3 voxels per fiber diameter)."""
    from psdesign.flow.permeability import permeability

    rve = RVE([1e-4] * 3, woven_cell())
    flow = {"viscosity": 1.8e-5, "bc": "periodic"}
    with pytest.warns(UserWarning, match="voxels across the thinnest fiber thin width"):
        res = permeability(rve, rve.voxelize(1e-4 / 52), "z", flow, "voxel")
    assert res["converged"] and res["permeability_rel_error"] < 0.2
    assert res["status"] == "untrustworthy"
    assert res["cells_per_diameter"] == pytest.approx(7.277, abs=2e-3)
    assert res["resolution_measure"] == "fiber thin width"
    assert any("7.3 voxels across the thinnest fiber thin width" in w for w in res["warnings"])


def test_the_pore_report_names_the_thin_width_it_counts():
    """Review (session 43): the pore report's resolution line counted voxels across the woven
    yarn's thin width (since s43-thin) but still called it "the thinnest fiber diameter": on a
    40^3 grid of the 100 um cell it read "only 5.6 voxels across the thinnest fiber diameter",
    where the yarn's diameter has 0.1598 x 40 = 6.4 voxels and its thickness 0.1399 x 40 =
    5.6 (truth (3) above). The line now says which width it counts, as K's does."""
    from psdesign.schema.transport import validate_transport
    from psdesign.transport.study_outputs import pore_report

    rve = RVE([1e-4] * 3, woven_cell())
    out = pore_report(rve, rve.voxelize(1e-4 / 40), validate_transport({}))
    line = "pore sizes and S_v: only 5.6 voxels across the thinnest fiber thin width (< 8)"
    assert [w for w in out["warnings"] if "voxels across" in w] == [f"{line}; refine rve.voxel"]


WOVEN_40 = """[rve]
size = [100e-6, 100e-6, 100e-6]
voxel = 2.5e-6

[[fibers]]
shape = "woven-cell"
thickness_axis = "z"
layers = 1
"""


@pytest.mark.parametrize("route", ["cli diffusivity", "api conductivity", "study row"])
def test_the_transport_values_name_the_thin_width_they_count(tmp_path, capsys, route):
    """Review (session 43): D_eff/D's and sigma_eff's resolution warnings counted voxels across
    the woven yarn's thin width (since s43-thin) but called it "the thinnest fiber diameter":
    the one-layer Table I cell at 2.5 um voxels read "only 5.6 voxels across the thinnest
    fiber diameter", where the yarn's diameter has 0.1598 x 40 = 6.4 voxels and its thickness
    0.1399 x 40 = 5.6 (truth (3) above). Each route (command, Python API, study row) now
    names the thin width, as K's line does; a round fiber's result keeps its keys."""
    import dataclasses
    import json

    import psdesign
    from psdesign.cli.main import main
    from psdesign.geometry.rve import DIAMETER_MEASURE

    line = "only 5.6 voxels across the thinnest fiber thin width (< 8); refine rve.voxel"
    spec = tmp_path / "w.toml"
    spec.write_text(WOVEN_40)
    if route == "cli diffusivity":
        # under 8 voxels across: untrustworthy, written, exit 3 (exit_status, session 45)
        assert main(["diffusivity", str(spec), "--direction", "z", "--json"]) == 3
        out = json.loads(capsys.readouterr().out)
        assert out["warnings"] == [f"D_eff/D_z: {line}"]
        assert out["resolution_measure"] == "fiber thin width"
        return
    m = psdesign.build(psdesign.load_spec(spec))
    if route == "api conductivity":
        res = m.conductivity("z")
        assert res.warnings == [f"sigma_eff_z: {line}"]
        kept = dataclasses.replace(res, resolution_measure=DIAMETER_MEASURE).to_dict()
        assert "resolution_measure" not in kept and res.to_dict()["resolution_measure"]
        return
    from psdesign.transport.study_outputs import transport_outputs

    row = transport_outputs(m.rve, m.fields, ["diffusivity_z"], m.spec)
    assert row["diffusivity_z_warnings"] == f"D_eff/D_z: {line}"


@pytest.mark.parametrize(
    "rod, thinnest, measure",
    [
        (0.12, 0.12, "fiber diameter"),  # the rod is thinner than the yarn's thickness
        (0.15, 0.14, "fiber thin width"),  # thinner than the yarn's 0.16 diameter, not 0.14
        (0.14, 0.14, "fiber diameter"),  # a tie: the round fiber's words
    ],
)
def test_round_and_non_round_fibers_mixed(rod, thinnest, measure):
    """Review (session 43): an RVE of rods (thin_width None) beside a yarn (diameter 0.16,
    thin width 0.14 of the period) is measured by its thinnest width whichever kind it is,
    and the words follow the fiber that sets it."""
    fibers = [
        SimpleNamespace(diameter=rod, thin_width=None),
        SimpleNamespace(diameter=0.16, thin_width=0.14),
    ]
    rve = SimpleNamespace(fibers=fibers, period=1e-4)
    assert thinnest_fiber_diameter(rve) == pytest.approx(thinnest * 1e-4, rel=1e-12)
    assert resolution_measure(rve) == measure


@pytest.mark.parametrize(("cap", "planned"), [(2.0, True), (10.0, False)])
def test_explicit_fibers_are_built_once_per_validation(monkeypatch, cap, planned):
    """Review (session 43): the "auto" copies plan and the FEM budget's thin width each built
    a spec's explicit fibers, the budget on every memory check: a woven cell in a 100 um cube
    (FEM, "auto" permeameter along z) was built 4 times at a cap of 2 GB (one copy fits, two
    do not: the plan runs) and 2 times at 10 GB. Now once, and the thin width the budget
    reads is the built RVE's (psdesign.geometry.rve.thinnest_fiber_diameter of
    packing.build_rve: the run's own measure)."""
    import psdesign.flow.stack as stack
    import psdesign.schema.spec as spec_mod
    from psdesign.errors import SpecError
    from psdesign.geometry.rve import thinnest_fiber_diameter
    from psdesign.packing.build import build_rve
    from psdesign.schema.spec import validate_document, validate_spec

    flow = {"solver": "fem", "bc": "permeameter", "direction": "z", "max_memory_gb": cap}
    spec = {"rve": {"size": [1e-4] * 3, "voxel": 2e-6}, "fibers": [{"shape": "woven-cell"}]}
    spec["flow"] = flow
    calls = {"build": 0, "plan": 0}
    real_build, real_plan = spec_mod.explicit_fibers, stack.spec_auto_copies

    def counted(name, real):
        def call(*a, **k):
            calls[name] += 1
            return real(*a, **k)

        return call

    monkeypatch.setattr(spec_mod, "explicit_fibers", counted("build", real_build))
    monkeypatch.setattr(stack, "spec_auto_copies", counted("plan", real_plan))
    if planned:  # refused at 2 GB counted at porosity 1; main's review2 counts the stack at
        try:  # the RVE's sampled porosity and accepts it, planning each direction it
            validate_document(spec)  # checks: either way one build for every plan
        except SpecError as exc:
            assert exc.key == "flow.max_memory_gb", exc
        assert calls["build"] == 1 and calls["plan"] >= 1, calls
        return
    doc = validate_document(spec)
    assert calls == {"build": 1, "plan": 0}
    monkeypatch.setattr(spec_mod, "explicit_fibers", real_build)
    run = thinnest_fiber_diameter(build_rve(validate_spec(spec)).rve)
    assert doc._thinnest_diameter() == pytest.approx(run, rel=1e-12)
