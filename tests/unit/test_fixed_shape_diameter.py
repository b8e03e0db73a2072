"""The measured diameter of a bent fixed shape (woven, compressed-bent) is smooth in its bend
moment u and is the width across the centre line (session 42, helper s42-fixes;
benchmarks/RESULTS.md "Session 42: noticed defects").

Before: ``_measure_fixed_shape`` took its chords from the cell centre in z = const planes, as for
a straight shape. The bent centre line leaves the cell centre, so the y chord ran off the axis
(shorter) and a height where the cell centre lies outside the fibre was dropped: the woven
diameter fell to 0.1302 at u = 0.46 and jumped to 0.1465 at u = 0.47 (0.1336 / 0.1436 at
u = 0.45 / 0.50, session 41), and the field scale jumped with it (12.21 -> 12.70).

Truths: (1) a tube of constant radius r around a bent centre line has the width 2r across its
centre line at every height (closed form); (2) for the woven fibre, whose centre line is known
in closed form (the x term's phase, ``x_c = 1/2 - u cos(2 pi f (z - 1/6)) / (2 pi)``,
``y_c = 1/2``), the widths across it sampled on a fine grid of points (step 2e-5, no root
finding, no minimisation).
"""

from __future__ import annotations

import numpy as np
import pytest

from psdesign.geometry.fibers import (
    WOVEN_EQ19,
    _fixed_canonical,
    _measure_fixed_shape,
    fixed_shape_scales,
    rod_diameter,
    rod_isovalue,
    rod_model,
)


class _Tube:
    """``|p - q(p)|^2 - r^2`` for the nearest point ``q`` of the centre line
    ``(1/2 + a cos(2 pi f z), 1/2, z)``: solid within r of the line (iso 0), a bend term."""

    n_minor = 1

    def __init__(self, r: float, a: float, f: float = 1.0) -> None:
        self.r, self.a, self.f = r, a, f

    def _line(self, s):
        w = 2 * np.pi * self.f
        x = 0.5 + self.a * np.cos(w * s)
        return x, -self.a * w * np.sin(w * s), -self.a * w * w * np.cos(w * s)

    def _nearest(self, p: np.ndarray) -> np.ndarray:
        s = p[:, 2].copy()
        grid = s[:, None] + np.linspace(-0.3, 0.3, 601)[None]  # coarse, then Newton
        x, _, _ = self._line(grid)
        d2 = (p[:, 0:1] - x) ** 2 + (p[:, 1:2] - 0.5) ** 2 + (p[:, 2:3] - grid) ** 2
        s = grid[np.arange(len(p)), np.argmin(d2, axis=1)]
        for _ in range(30):
            x, dx, ddx = self._line(s)
            g = -(p[:, 0] - x) * dx - (p[:, 2] - s)
            h = dx * dx - (p[:, 0] - x) * ddx + 1.0
            s = s - g / h
        x, _, _ = self._line(s)
        return np.column_stack([x, np.full(len(p), 0.5), s])

    def evaluate(self, p: np.ndarray) -> np.ndarray:
        q = self._nearest(np.atleast_2d(p))
        return np.sum((np.atleast_2d(p) - q) ** 2, axis=1) - self.r**2

    def gradient(self, p: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(p)
        return 2.0 * (p - self._nearest(p))


@pytest.mark.parametrize("a", [0.0, 0.03, 0.06, 0.1])
def test_a_bent_tube_measures_twice_its_radius(a):
    """Truth (1): 2r = 0.14 at any bend amplitude (the centre line's slope up to 0.63). The
    old chords gave 0.1373, 0.1274 and 0.1351 at a = 0.03, 0.06 and 0.1 (the y chord off the
    axis, the x chord along the slant, heights dropped); 0.14 at a = 0."""
    d, _, _ = _measure_fixed_shape(_Tube(0.07, a), 0.0)
    assert d == pytest.approx(0.14, abs=2e-6)


def _grid_widths(u: float) -> np.ndarray:
    """Truth (2): the woven fibre's widths across its closed-form centre line at the
    measurement's heights, by sampling psi on lines of points 2e-5 apart: one row per height,
    (through the fabric, i.e. across the tangent in the bend plane; across it along y)."""
    model = _fixed_canonical("woven", u)
    f = WOVEN_EQ19["f"]
    s = np.arange(-0.25, 0.25 + 1e-12, 2e-5)
    widths = []
    for z in np.linspace(0.0, 1.0, 7, endpoint=False):  # the measurement's 7 heights
        phase = 2 * np.pi * f * (z - 1 / 6)
        c = np.array([0.5 - u * np.cos(phase) / (2 * np.pi), 0.5, z])
        t = np.array([u * f * np.sin(phase), 0.0, 1.0])  # d x_c / dz = u f sin(phase)
        t /= np.linalg.norm(t)
        across = np.array([t[2], 0.0, -t[0]])
        row = []
        for e in (across, np.array([0.0, 1.0, 0.0])):
            inside = model.evaluate(c + s[:, None] * e) <= 0.0
            mid = len(s) // 2
            hi = mid + np.argmin(inside[mid:])  # first point outside on each side
            lo = mid - np.argmin(inside[mid::-1])
            row.append((hi - lo - 1) * 2e-5 + 2e-5)
        widths.append(row)
    return np.array(widths)


def _grid_width(u: float) -> float:
    """Truth (2): the mean of :func:`_grid_widths` (the diameter's definition)."""
    return float(np.mean(_grid_widths(u)))


@pytest.mark.parametrize("u", [0.0, 0.41, 0.45, 0.5, 0.65])
def test_the_woven_diameter_is_its_width_across_the_centre_line(u):
    """Truth (2) to two of the grid's steps (measured: within 2.3e-5). Old code: 0.1419 at
    the Eq. (19) u = 0.41, 0.1336 at 0.45, 0.1436 at 0.5, 0.1514 at 0.65 against the grid's
    0.1598, 0.1588, 0.1576, 0.1537 (the same 0.1660 at u = 0)."""
    d, _ = fixed_shape_scales("woven", u, 0.0)
    assert d == pytest.approx(_grid_width(u), abs=4e-5)


@pytest.mark.parametrize("shape", ["woven", "compressed-bent"])
def test_the_measured_diameter_and_field_scale_are_smooth_in_u(shape):
    """u = 0.30 ... 0.70 in steps of 0.01: no step of the diameter or of the field scale
    departs from the mean of its two neighbouring steps by more than 1e-5 of the largest value
    (measured after the fix: at most 6.6e-7, woven steps -2.6e-4 to -2.2e-4; before: 0.18 for
    the diameter, which stepped +0.0163 at 0.46 -> 0.47 and +0.0263 at 0.60 -> 0.61, and
    0.028 for the woven field scale)."""
    us = np.round(np.arange(0.30, 0.7001, 0.01), 2)
    m = [_measure_fixed_shape(_fixed_canonical(shape, float(u)), 0.0) for u in us]
    d, g, _ = np.array(m).T
    for values in (d, g):
        steps = np.diff(values)
        bend = steps[1:-1] - 0.5 * (steps[:-2] + steps[2:])
        assert np.max(np.abs(bend)) < 1e-5 * np.max(values), np.max(np.abs(bend))


def test_straight_shapes_keep_their_measurement():
    """The straight fixed shapes are measured as before (cell centre, x and y): the same
    numbers to round-off, e.g. compressed-straight 0.16598882813590618 (0.16598882813590624 on
    the session 43 machine, main's code too: the last digit is the platform's), and the bent
    shapes at u = 0 give it too (their centre line is then the cell's axis)."""
    straight = fixed_shape_scales("compressed-straight", None, 0.0)
    assert straight[0] == pytest.approx(0.16598882813590618, rel=1e-15)
    assert fixed_shape_scales("compressed-bent", 0.0, 0.0)[0] == pytest.approx(straight[0], 1e-9)


@pytest.mark.parametrize("shift", [(0.07, -0.04), (-0.1, 0.0)])
def test_a_straight_shape_off_the_axis_is_measured_across_its_own_centre(shift):
    """The rod surface Eq. (4) moved off the cell's axis by ``shift`` (x, y) is measured across
    its section's centre: its diameter is Eq. (5)'s ``1 - arccos((psi0 + 1) / 4) / pi`` (closed
    form; 0.3 here) whatever the shift. Measured from the cell centre (before session 43, as
    compressed-rod-a was, whose section centre lies near x = 0.44) the chords ran off the
    centre: 0.2741 at (0.07, -0.04), 0.2579 at (-0.1, 0) (measured on main's code)."""
    model = rod_model().translated(np.array([shift[0], shift[1], 0.0]))
    iso = rod_isovalue(0.3)
    d = _measure_fixed_shape(model, iso)[0]
    assert d == pytest.approx(rod_diameter(iso), abs=2e-7)
    assert d == pytest.approx(0.3, abs=2e-7)


def test_compressed_rod_a_is_measured_across_its_section_centre():
    """compressed-rod-a's y part ``4 cos(2 pi y) + cos(pi y / 6)`` is separable, so its section
    centre's y is that part's minimum near 1/2 (a 1-D root, independent of the measurement)
    and the width along y at each height is the interval where that part stays below minus
    the rest of psi at the centre; the measured y widths (``_section_widths`` across the
    centre) match those 1-D roots, and the diameter is 0.5471, not the cell-centre 0.5353."""
    from scipy.optimize import brentq, minimize_scalar

    from psdesign.geometry.fibers import (
        MEASURE_STATIONS,
        _centre_tangent,
        _section_centre,
        _section_widths,
    )

    model = _fixed_canonical("compressed-rod-a", None)

    def g(y):
        return 4 * np.cos(2 * np.pi * y) + np.cos(np.pi * y / 6)

    yc = minimize_scalar(g, bounds=(0.3, 0.7), method="bounded", options={"xatol": 1e-12}).x
    for z in np.linspace(0.0, 1.0, MEASURE_STATIONS, endpoint=False):
        c = _section_centre(model, z)
        assert c[1] == pytest.approx(yc, abs=1e-7)
        t = _centre_tangent(model, c)
        assert abs(t[1]) < 1e-6  # the centre line stays in its y plane
        rest = model.evaluate(c[None])[0] - g(c[1])
        lo = brentq(lambda y, r=rest: g(y) + r, 0.0, yc)
        hi = brentq(lambda y, r=rest: g(y) + r, yc, 1.0)
        (w,), _ = _section_widths(model, 0.0, c, (np.array([0.0, 1.0, 0.0]),))
        assert w == pytest.approx(hi - lo, abs=1e-9)
    assert fixed_shape_scales("compressed-rod-a", None, 0.0)[0] == pytest.approx(0.5471, abs=1e-4)
