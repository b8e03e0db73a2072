"""The diffuse wall on hexagonal arrays and the Gaussian-curvature term for spheres
(``benchmarks/curvature_term.py``, issue 12 item 3).

Independent truths: wall22's square-array model (``penalty_scatter.wall_along`` /
``wall_across``, a separate assembly) for the rectangular-grid generalisation; Sparrow &
Loeffler's collocation series along a hexagonal array (AIChE J. 5 (1959) 325-330,
``arrays.along_array_k``); Stokes' drag on a sphere, ``F = 6 pi mu a U`` (Stokes 1851), for the
1-D reduction of the 3-D diffuse model.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

import curvature_term as ct  # noqa: E402
from penalty_scatter import parse_wall, wall_across, wall_along  # noqa: E402

WALL = parse_wall(ct.W22)
SHIFT = (0.13, 0.41)


@pytest.fixture(autouse=True)
def _no_cache(monkeypatch):
    monkeypatch.setattr(ct, "CACHE", None)


@pytest.mark.parametrize("phi", [0.3, 0.5])
def test_rectangular_models_are_wall22s_on_a_square_cell(phi: float) -> None:
    # one cylinder in an n x n cell: the generalised assembly is wall22's to round-off
    # (measured 0 and 1e-16); a Gaussian-curvature wall on cylinders (K_G = 0) is the same
    # wall bit for bit
    from arrays import L, radius_of
    from validation_tables import reference_k

    n = 20
    centre = [(n / 2 + SHIFT[0], n / 2 + SHIFT[1])]
    fluxes = []
    for wall in (WALL, ct.GaussWall(WALL, 25.0)):
        field = ct.HexField(phi, n, n, SHIFT, wall, 2, centre, radius_of(phi, "square", n))
        fluxes.append((ct.along_flux(n, n, field), ct.mac_flux(n, n, field)))
    assert fluxes[0] == fluxes[1]
    scale = (L / n) ** 2
    along = fluxes[0][0] * scale / reference_k("square", "along", phi) - 1.0
    across = fluxes[0][1] * scale / reference_k("square", "across", phi) - 1.0
    assert along == pytest.approx(wall_along(phi, n, SHIFT, WALL, "pair"), rel=1e-10, abs=0)
    assert across == pytest.approx(wall_across(phi, n, SHIFT, WALL, "pair"), rel=1e-10, abs=0)


def test_hexagonal_along_limit_is_sparrow_and_loeffler() -> None:
    # the model on the exact hexagonal cell (interpolated in the cell height, extrapolated in
    # n from 64 / 96 / 128) against the collocation series: measured -0.0004 % at phi 0.1
    limit, ks = ct.model_limit(0.1, "along", WALL)
    ref = ct.published_hex(0.1, "along")
    assert abs(limit / ref - 1.0) < 2e-5
    assert -6e-4 < ks[0] / ref - 1.0 < -3e-4  # 64 voxels per spacing: -0.044 %


def test_hexagonal_along_converges_monotonically_at_phi_05() -> None:
    # true error against the series times the stretched lattice's factor (round(n sqrt 3)
    # rows): measured -2.736 / -1.338 / -0.717 % at 24 / 32 / 40 (8 shifts, sd < 0.006 %)
    errs = [ct.hex_error(0.5, n, SHIFT, WALL, "along")[0] for n in (24, 32, 40)]
    assert errs[0] == pytest.approx(-0.02736, abs=3e-4)
    assert errs[2] == pytest.approx(-0.00717, abs=1e-4)
    assert abs(errs[0]) > abs(errs[1]) > abs(errs[2])


def test_stokes_reduction_gives_stokes_drag() -> None:
    # the 1-D reduction of the 3-D diffuse model, a sphere of 200 LAM, the exact solution at
    # 8 radii: the drag is Stokes' within 0.01 % (measured -0.003 % with h = LAM / 16)
    const = ct._continuum_constants()
    err = ct.stokes_sphere_error(200.0, ct.continuum_wall(2.55, 0.0, const), outer=8.0)
    assert abs(err) < 1e-4


def test_gaussian_term_zeroes_the_isolated_sphere() -> None:
    # a sphere of 16.67 LAM (c 0.125 at 40 voxels per box), exact solution at 16 radii:
    # +0.144 % drag error with the mean-curvature term alone; the whole profile (fluid
    # fraction and drag) moved by D LAM^3 K_G zeroes it at D = -5.76 (Richardson in h); the
    # fluid fraction alone needs D = +25.2
    const = ct._continuum_constants()

    def err(d_eps, d_drag):
        wall = ct.continuum_wall(2.55, d_eps, const, d_drag)
        fine = ct.stokes_sphere_error(16.67, wall, 16.0, 1 / 32)
        return 2 * fine - ct.stokes_sphere_error(16.67, wall, 16.0, 1 / 16)

    plain = err(0.0, 0.0)  # deterministic: solved once for both checks below
    assert plain == pytest.approx(1.44e-3, abs=1e-4)
    assert abs(err(-5.8, -5.8)) < 1e-4
    assert err(-8.0, -8.0) < -3e-4
    assert abs(err(25.0, 0.0)) < 1e-4
    assert plain > 0 > err(35.0, 0.0)


@pytest.mark.parametrize(("size", "before"), [(10.0, 5.67e-3), (20.0, 8.7e-4)])
def test_fitted_offset_holds_from_8_to_40_lam(size: float, before: float) -> None:
    # the whole-profile offset (D + E LAM / a) LAM^3 / a^2, D = -7.0, E = 20.3 (fitted on the
    # zeroing D at 8-40 LAM, exact solution at 16 radii): the isolated sphere's drag error
    # falls from +0.567 / +0.087 % to below 0.01 % (measured +0.007 % at 8, < 0.004 % at 13-40)
    const = ct._continuum_constants()

    def err(wall):
        fine = ct.stokes_sphere_error(size, wall, 16.0, 1 / 32)
        return 2 * fine - ct.stokes_sphere_error(size, wall, 16.0, 1 / 16)

    assert err(ct.continuum_wall(2.55, 0.0, const)) == pytest.approx(before, rel=0.05)
    assert abs(err(ct.continuum_wall(2.55, -7.0, const, -7.0, 20.3))) < 1e-4


@pytest.mark.slow
def test_offset_makes_spheres_converge_faster_and_monotonically() -> None:
    # simple cubic c 0.125, one shift, the proposed wall W22,-7.0,-7.0,20.3 against Zick &
    # Homsy: -3.90 / -1.12 / -0.47 % at 16 / 24 / 32 voxels per box (wall22's wall: -8.26 /
    # -2.81 / -1.27 %; measured 4 shifts, sd < 0.007 %)
    from diffuse3d import SHIFTS3

    wall = ct.parse_gauss_wall(ct.W22 + ",-7.0,-7.0,20.3")
    errs = [ct.sphere_error(0.125, n, SHIFTS3[0], wall)[0] for n in (16, 24, 32)]
    assert errs == pytest.approx([-0.0390, -0.0112, -0.0047], abs=2e-4)
    assert abs(errs[0]) > abs(errs[1]) > abs(errs[2])
