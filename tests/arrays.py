"""Regular cylinder arrays as RVE specs, with their exact permeability (published values).

Square array: one cylinder in an L x L cell. Hexagonal (equilateral triangular) array of
spacing L: a rectangular L x sqrt(3) L cell with a cylinder at the centre and a quarter at each
corner. Cylinders run along z; ``along`` = flow along z, ``across`` = flow along x.
"""

from __future__ import annotations

import math

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


def array_spec(
    kind: str, phi: float, cells_per_spacing: int, n_cells: int = 1, depth_voxels: int | None = None
) -> dict:
    """Spec (unvalidated dict) of ``n_cells`` periods along x of the array at solid fraction
    ``phi``, voxel L / cells_per_spacing, ``depth_voxels`` voxels thick along z (default: the
    smallest even count thicker than the diameter, which the spec requires)."""
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
