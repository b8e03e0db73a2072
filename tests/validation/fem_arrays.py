"""Square cylinder arrays as RVEs for the FEM boundary-condition checks (issue 12).

``array_rve("along", phi, n)``: one cell of side ``S`` across, ``n`` cells long in z, the cylinder
on the z axis of the cell (flow along z). ``array_rve("across", phi, n, depth)``: ``n`` cells in a
row along x, cylinders along z (flow along x), ``depth`` thick in z. The slip sides of the
permeameter are symmetry planes of the infinite array, so both BCs target the same K.
"""

from __future__ import annotations

import numpy as np
from reference_values import k_square_across, k_square_along

from psdesign.geometry.fibers import make_fiber
from psdesign.geometry.rve import RVE

S = 40e-6  #: array spacing (m)
MU = 1.8e-5


def array_rve(kind: str, phi: float, n: int, depth: float | None = None) -> tuple[RVE, float]:
    """The RVE and the exact (published) K of a square array at solid fraction ``phi`` (NaN
    across above phi = 0.3 where no published value is stored)."""
    a = S * np.sqrt(phi / np.pi)
    if kind == "across":
        size = np.array([n * S, S, depth])
        centers = [[S / 2 + i * S, S / 2, depth / 2] for i in range(n)]
        try:
            k_ref = k_square_across(a, phi)
        except ValueError:  # no published value in reference_values at this phi
            k_ref = float("nan")
    elif kind == "along":
        size = np.array([S, S, n * S])
        centers = [[S / 2, S / 2, n * S / 2]]
        k_ref = k_square_along(a, phi)
    else:
        raise ValueError(f"kind must be 'along' or 'across', got {kind!r}")
    ref = float(size.max())
    fibers = [
        make_fiber(
            "cylinder",
            diameter=2 * a / ref,
            center=np.asarray(c) / ref,
            theta=None,
            omega=None,
            direction=[0, 0, 1],
            u=0.0,
            f=1.0,
            isovalue=None,
        )
        for c in centers
    ]
    return RVE(size=size, fibers=fibers, period=None), k_ref


def array_k(kind, phi, n, bc, step, voxel=1e-6, depth=None) -> dict:
    """``permeability_fem`` result for the array (flow along z for 'along', x for 'across')."""
    from psdesign.flow.fem import permeability_fem

    rve, k_ref = array_rve(kind, phi, n, depth if depth is not None else 2 * step)
    flow = {
        "viscosity": MU,
        "aux_length": 0.2,
        "sides": "slip",
        "pressure_drop": 1.0,
        "mesher": "stuffing",
        "lattice_step": step,
        "bc": bc,
    }
    res = permeability_fem(rve, rve.voxelize(voxel), "z" if kind == "along" else "x", flow)
    res["k_ref"] = k_ref
    return res
