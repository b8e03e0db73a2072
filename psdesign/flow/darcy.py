"""Darcy's law: the one place where flow fields become a permeability (paper Sec. 7.2).

Every route turns its solve into K here, so the definition (superficial velocity, viscosity,
driving pressure gradient) is written once:

    K = mu * Q * L / (A * dP)          (flow rate Q through cross-section A over length L)
    K[:, j] = mu * <u> / G_j           (superficial mean velocity <u> for a mean gradient G_j)

The tensor is assembled from its columns by :func:`permeability_tensor`. The pressure drop
``dP`` of a permeameter (RVE between reservoirs) is defined here too, once for both solvers: the
windowed dissipation (:func:`windowed_drop_from_dissipation` for the tet route,
:func:`windowed_drop` for the voxel route; ``docs/permeability.md``).
"""

from __future__ import annotations

import numpy as np

AXES = {"x": 0, "y": 1, "z": 2}


def axis_of(direction: str | int) -> tuple[str, int]:
    """``('x', 0)`` etc. from ``'x' | 'y' | 'z' | 0 | 1 | 2``.

    >>> axis_of("y")
    ('y', 1)
    """
    if isinstance(direction, int | np.integer) and 0 <= int(direction) <= 2:
        return "xyz"[int(direction)], int(direction)
    if direction in AXES:
        return str(direction), AXES[direction]
    raise ValueError(f"direction must be 'x', 'y' or 'z', got {direction!r}")


def darcy_permeability(
    flow_rate: float, viscosity: float, length: float, area: float, pressure_drop: float
) -> float:
    """K (m^2) from a flow rate Q (m^3/s) driven by ``pressure_drop`` (Pa) over ``length`` (m).

    ``area`` is the full cross-section (m^2), so ``Q / area`` is the superficial velocity.

    >>> darcy_permeability(2.0, 0.5, 3.0, 1.0, 3.0)  # mu Q L / (A dP)
    1.0
    """
    if not pressure_drop:
        raise ValueError("pressure_drop: must be non-zero to define a permeability")
    return float(viscosity * flow_rate * length / (area * pressure_drop))


def darcy_column(
    mean_velocity: np.ndarray, viscosity: float, pressure_gradient: float
) -> np.ndarray:
    """Column ``K[:, j]`` (m^2) from the superficial mean velocity (m/s, shape (3,)) driven by a
    mean pressure gradient of magnitude ``pressure_gradient`` (Pa/m) along axis j.

    >>> darcy_column(np.array([0.0, 0.0, 2.0]), 1.0, 4.0).tolist()
    [0.0, 0.0, 0.5]
    """
    if not pressure_gradient:
        raise ValueError("pressure_gradient: must be non-zero to define a permeability")
    return viscosity * np.asarray(mean_velocity, dtype=float) / float(pressure_gradient)


def permeability_tensor(columns: list[np.ndarray] | np.ndarray) -> np.ndarray:
    """The 3x3 tensor (m^2) whose column j is the flow driven along axis j.

    >>> permeability_tensor([[1, 0, 0], [0, 2, 0], [0, 0, 3]]).diagonal().tolist()
    [1.0, 2.0, 3.0]
    """
    cols = np.asarray(columns, dtype=float)
    if cols.shape != (3, 3):
        raise ValueError(f"columns: need three columns of length 3, got shape {cols.shape}")
    return np.ascontiguousarray(cols.T)


# --- the pressure drop across an RVE between reservoirs (permeameter), both routes -------------
#
# One definition (derivation in docs/permeability.md, "Permeameter: definition of the pressure
# drop"): the drop is the RVE length times the windowed mean gradient of the mechanical energy
# flux per unit flow rate, with the window w(t) = sin^2(pi t), t = s / L on the RVE:
#
#     dp = L G_w,   G_w = int_0^L w(s) phi(s) ds / (Q int_0^L w ds),   int_0^L w ds = L / 2,
#
# phi(s) = -dE/ds the dissipation per unit length (E the energy flux through the plane s). The
# tet route integrates the windowed dissipation Phi_w = int w phi ds over its mesh
# (:func:`windowed_drop_from_dissipation`); the voxel route has E(s) / Q on the RVE's face planes
# and sums the windowed per-layer drops (:func:`windowed_drop`). In the periodic interior both are
# exactly G L for two or more periods; entrance and exit losses get the weight of w near the
# faces, O((delta / L)^2).

#: Mean of the window ``w = sin^2(pi t)`` over the RVE (``int_0^1 w dt``).
WINDOW_MEAN = 0.5


def window(t: np.ndarray | float) -> np.ndarray:
    """The RVE window ``w(t) = sin^2(pi t)`` at the fractional position ``t = s / L`` (0 outside
    ``[0, 1]``).

    >>> window(np.array([-0.1, 0.0, 0.5, 1.0])).round(12).tolist()
    [0.0, 0.0, 1.0, 0.0]
    """
    s = np.clip(np.asarray(t, dtype=float), 0.0, 1.0)
    return np.sin(np.pi * s) ** 2


def rve_window(axis: int, start: float, end: float):
    """Pointwise window on the RVE ``start <= x[axis] <= end`` (0 outside) for a solver's
    weighted dissipation: ``w(xyz)`` with ``xyz`` of shape ``(n, 3)``; its integral over the
    RVE length is ``WINDOW_MEAN * (end - start)``."""
    length = end - start

    def w(xyz: np.ndarray) -> np.ndarray:
        return window((xyz[:, axis] - start) / length)

    return w


def windowed_drop_from_dissipation(dissipation_w: float, flow_rate: float) -> float:
    """``dp = Phi_w / (Q int w dt)`` (Pa) from the windowed dissipation ``Phi_w`` (W) and the
    flow rate ``Q`` (m^3/s): the tet route's form of the definition.

    >>> windowed_drop_from_dissipation(1.5, 0.5)  # 2 Phi_w / Q
    6.0
    """
    if not flow_rate:
        raise ValueError("flow_rate: must be non-zero to define a pressure drop")
    return float(dissipation_w / (WINDOW_MEAN * flow_rate))


def windowed_drop(profile: np.ndarray) -> float:
    """The pressure drop (Pa) across an RVE from its energy-flux profile on ``n + 1`` equally
    spaced planes ``s_k = k L / n`` (``E(s_k) / Q`` in Pa, the energy flux per unit flow rate):
    ``dp = n sum_k w(t_k) (F_k - F_{k+1}) / sum_k w(t_k)`` with ``t_k = (k + 1/2) / n``, the
    layer midpoints.

    The discrete form of ``L G_w``: for a profile ``c - G s + F~(s)`` with ``F~`` periodic over
    ``m >= 2`` periods of the planes it is exactly ``G L`` (the window's samples have only the
    discrete Fourier modes 0 and +-1, the layer drops of ``F~`` only multiples of ``m`` and zero
    mean). One layer (``n = 1``) gives the drop between the end planes.

    >>> round(windowed_drop(np.array([3.0, 2.0, 1.0, 0.0])), 12)
    3.0
    >>> round(windowed_drop(np.array([4.0, 2.5, 2.0, 0.5, 0.0])), 12)  # two periods of 2 layers
    4.0
    """
    f = np.asarray(profile, dtype=float)
    if f.ndim != 1 or len(f) < 2:
        raise ValueError("profile: needs the values on at least the two end planes")
    n = len(f) - 1
    w = window((np.arange(n) + 0.5) / n)
    return float(n * np.sum(w * (f[:-1] - f[1:])) / np.sum(w))
