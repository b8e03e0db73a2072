"""Darcy's law: the one place where flow fields become a permeability (paper Sec. 7.2).

Every route turns its solve into K here, so the definition (superficial velocity, viscosity,
driving pressure gradient) is written once:

    K = mu * Q * L / (A * dP)          (flow rate Q through cross-section A over length L)
    K[:, j] = mu * <u> / G_j           (superficial mean velocity <u> for a mean gradient G_j)

The tensor is assembled from its columns by :func:`permeability_tensor`.
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
