"""Regular cylinder arrays for the solver tests: RVE specs with their published permeability
(:func:`exact_k`, :func:`array_spec`), exact distance fields (:func:`array_distance`) and an
independent series solution for flow along the cylinders (:func:`along_array_k`).

Square array: one cylinder in an L x L cell. Hexagonal (equilateral triangular) array of
spacing L: a rectangular L x sqrt(3) L cell with a cylinder at the centre and a quarter at each
corner. Cylinders run along z; ``along`` = flow along z, ``across`` = flow along x.

Along the cylinders the Stokes problem is the 2-D Poisson problem ``lap w = -G / mu`` in the
cell with ``w = 0`` on the cylinder and ``dw/dn = 0`` on the edges of the Voronoi cell (mirror
lines of the lattice).  :func:`along_array_k` solves it by the collocation series of Sparrow &
Loeffler (AIChE J. 5 (1959) 325-330): ``w = (a^2 - r^2)/4 + A_0 ln(r/a) + sum_n A_n (r^m -
a^{2m} r^{-m}) cos(m theta)`` with ``m = k n`` (``k = 4`` square, ``6`` hexagonal), ``A_0`` from
the mass balance and ``A_n`` by least squares on the cell edge.  The series converges
exponentially below touching; at solid fraction 0.1 it agrees with Drummond & Tahir's dilute
expansion (``reference_values.drummond_tahir_along_square``) to 1e-4 (asserted in the tests).
"""

from __future__ import annotations

import math

import numpy as np
from reference_values import (
    SANGANI_ACRIVOS_SQUARE_TRANSVERSE,
    drummond_tahir_hex_parallel,
    drummond_tahir_hex_transverse,
    drummond_tahir_square_parallel,
)

L = 40e-6  # array spacing (m)


def exact_k(kind: str, flow: str, phi: float) -> float:
    """Published K (m^2) of the array ``kind`` ('square' | 'hex'), ``flow`` ('along' | 'across')
    at solid fraction ``phi``."""
    if kind == "square" and flow == "across":
        return L**2 / SANGANI_ACRIVOS_SQUARE_TRANSVERSE[phi]
    if kind == "square" and flow == "along":
        return L**2 * drummond_tahir_square_parallel(phi)
    if kind == "hex" and flow == "along":
        return L**2 * drummond_tahir_hex_parallel(phi)
    if kind == "hex" and flow == "across":
        return L**2 * drummond_tahir_hex_transverse(phi)
    raise ValueError(f"kind/flow: unknown array case {kind!r}/{flow!r}")


#: Voxels per spacing at which the hexagonal cell width ``sqrt(3) n`` is within 0.02 % of a whole
#: number of voxels (convergents and near-convergents of sqrt(3): 41/71, 56/97, 82/142, 97/168,
#: 112/194; 15/26 is +0.074 %). At other resolutions :func:`array_spec` rounds the width and
#: stretches the lattice with it, which is a different array (:func:`hex_width_error`).
HEX_NEAR_WHOLE = (41, 56, 82, 97, 112)


def hex_width_voxels(cells_per_spacing: int) -> int:
    """Whole voxels of the hexagonal cell width ``sqrt(3) L`` at ``cells_per_spacing``."""
    return round(math.sqrt(3.0) * cells_per_spacing)


def hex_width_error(cells_per_spacing: int, width_voxels: int | None = None) -> float:
    """Relative error of the hexagonal cell width on the grid (``width_voxels``, default
    :func:`hex_width_voxels`) against ``sqrt(3) L``: +0.074 % at 30, -0.407 % at 40, -0.020 %
    at 41, -0.074 % at 52. The lattice is stretched by it along y, and K moves by 1.8-3.0 times
    this (measured, ``docs/validation.md`` 'Hexagonal cell width'): at 40 voxels per spacing
    -0.7 to -1.2 %."""
    width = hex_width_voxels(cells_per_spacing) if width_voxels is None else width_voxels
    return width / (math.sqrt(3.0) * cells_per_spacing) - 1.0


def array_spec(
    kind: str,
    phi: float,
    cells_per_spacing: int,
    n_cells: int = 1,
    depth_voxels: int | None = None,
    width_voxels: int | None = None,
) -> dict:
    """Spec (unvalidated dict) of ``n_cells`` periods along x of the array at solid fraction
    ``phi``, voxel L / cells_per_spacing, ``depth_voxels`` voxels thick along z (default: the
    smallest even count thicker than the diameter, which the spec requires).

    Hexagonal: the cell width ``sqrt(3) L`` is not a whole number of voxels; it is rounded to
    ``width_voxels`` (default :func:`hex_width_voxels`) and the cylinder centres are scaled with
    it, so the array is stretched by :func:`hex_width_error` along y (the radius is kept). Use
    :data:`HEX_NEAR_WHOLE` resolutions to compare with the hexagonal array's published K."""
    voxel = L / cells_per_spacing
    if kind == "square":
        width = L
        radius = L * math.sqrt(phi / math.pi)
        centres = [(0.5 * L, 0.5 * L)]
    elif kind == "hex":
        width = math.sqrt(3.0) * L
        radius = L * math.sqrt(math.sqrt(3.0) * phi / (2 * math.pi))
        centres = [(0.5 * L, 0.5 * width), (0, 0), (L, 0), (0, width), (L, width)]
    else:
        raise ValueError(f"kind: 'square' or 'hex', got {kind!r}")
    # hex: sqrt(3) L is not a multiple of the voxel; round the cell width to whole voxels
    if kind == "hex" and width_voxels is not None:
        width = width_voxels * voxel
    else:
        width = round(width / voxel) * voxel
    if kind == "hex":
        centres = [(x, y * width / (math.sqrt(3.0) * L)) for x, y in centres]
    if depth_voxels is None:
        depth_voxels = 2 * (math.floor(2 * radius / voxel / 2) + 1)
    depth = depth_voxels * voxel
    fibers = [
        {
            "shape": "cylinder",
            "diameter": 2 * radius,
            "center": [x + i * L, y, depth / 2],
            "direction": [0, 0, 1],
        }
        for i in range(n_cells)
        for x, y in centres
    ]
    return {
        "rve": {"size": [n_cells * L, width, depth], "voxel": voxel},
        "fibers": fibers,
        "flow": {"viscosity": 1.8e-5},
    }


#: Cell area per cylinder for a lattice of nearest-neighbour spacing 1.
CELL_AREA = {"square": 1.0, "hexagonal": np.sqrt(3.0) / 2.0}
_SYMMETRY = {"square": 4, "hexagonal": 6}


def radius_of(solid_fraction: float, kind: str, spacing: float = 1.0) -> float:
    """Cylinder radius for a solid fraction in a lattice of nearest-neighbour ``spacing``."""
    return float(np.sqrt(solid_fraction * CELL_AREA[kind] / np.pi)) * spacing


def along_array_k(solid_fraction: float, kind: str, terms: int = 12) -> float:
    """``K / a^2`` for flow along a square or hexagonal array (``a`` the cylinder radius)."""
    k = _SYMMETRY[kind]
    a = radius_of(solid_fraction, kind)
    a0 = CELL_AREA[kind] / (2.0 * np.pi)
    wedge = np.pi / k  # the cell edge x = 1/2 spans theta in [0, pi / k]
    th = np.linspace(0.0, wedge, 400)
    r = 0.5 / np.cos(th)
    m = k * np.arange(1, terms + 1)[None, :]
    rr, tt = r[:, None], th[:, None]
    # d/dx = cos(t) d/dr - sin(t) / r d/dt on the edge; scale each column by its size at r = 1/2
    dr = m * (rr ** (m - 1) + a ** (2 * m) * rr ** (-m - 1)) * np.cos(m * tt)
    dt = -m * (rr**m - a ** (2 * m) * rr ** (-m)) * np.sin(m * tt)
    mat = np.cos(tt) * dr - np.sin(tt) / rr * dt
    rhs = -(np.cos(th) * (-r / 2.0 + a0 / r))
    scale = np.abs(mat).max(axis=0)
    coef = np.linalg.lstsq(mat / scale, rhs, rcond=None)[0] / scale

    def w(rad: np.ndarray, ang: np.ndarray) -> np.ndarray:
        out = (a * a - rad**2) / 4.0 + a0 * np.log(rad / a)
        for n, c in enumerate(coef, start=1):
            mm = k * n
            out = out + c * (rad**mm - a ** (2 * mm) * rad ** (-mm)) * np.cos(mm * ang)
        return out

    # mean of w over the cell (superficial velocity for G / mu = 1): 2k wedges
    xt, wt = np.polynomial.legendre.leggauss(64)
    xr, wr = np.polynomial.legendre.leggauss(64)
    ang = 0.5 * wedge * (xt + 1.0)
    total = 0.0
    for t, wtt in zip(ang, wt, strict=True):
        r_out = 0.5 / np.cos(t)
        rad = a + 0.5 * (r_out - a) * (xr + 1.0)
        total += 0.5 * wedge * wtt * 0.5 * (r_out - a) * float(np.sum(wr * w(rad, t) * rad))
    mean = 2 * k * total / CELL_AREA[kind]
    return mean / (a * a)


def array_distance(shape: tuple[int, int, int], kind: str, solid_fraction: float) -> np.ndarray:
    """Exact signed distance (voxels, > 0 in the fluid) of a periodic array of cylinders along z
    on a ``shape`` grid of unit voxels: square (one cylinder in the centre of an ``nx x ny``
    cell, ``nx == ny``) or hexagonal (cylinders at the centre and the corners of an ``nx x ny``
    box, ``ny / nx ~ sqrt(3)``)."""
    nx, ny, nz = shape
    x = np.arange(nx) + 0.5
    y = np.arange(ny) + 0.5
    xx, yy = np.meshgrid(x, y, indexing="ij")
    if kind == "square":
        centres = [(nx / 2, ny / 2)]
        a = radius_of(solid_fraction, kind, spacing=nx)
    else:
        centres = [(nx / 2, ny / 2), (0.0, 0.0)]
        a = radius_of(solid_fraction, kind, spacing=nx)
    best = np.full(xx.shape, np.inf)
    for cx, cy in centres:
        dx = xx - cx
        dy = yy - cy
        dx -= nx * np.round(dx / nx)
        dy -= ny * np.round(dy / ny)
        best = np.minimum(best, np.hypot(dx, dy))
    return np.repeat((best - a)[:, :, None], nz, axis=2)
