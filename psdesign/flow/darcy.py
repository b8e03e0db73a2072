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

import math

import numpy as np

AXES = {"x": 0, "y": 1, "z": 2}


def axis_of(direction: str | int) -> tuple[str, int]:
    """``('x', 0)`` etc. from ``'x' | 'y' | 'z' | 0 | 1 | 2``.

    >>> axis_of("y")
    ('y', 1)
    """
    # a bool is an int (True == 1) but no axis
    if isinstance(direction, int | np.integer) and not isinstance(direction, bool):
        if 0 <= int(direction) <= 2:
            return "xyz"[int(direction)], int(direction)
    elif direction in AXES:
        return str(direction), AXES[direction]
    raise ValueError(f"direction must be 'x', 'y' or 'z', got {direction!r}")


def checked_axis(value: object, key: str) -> tuple[str, int]:
    """:func:`axis_of` of a user's value, else one :class:`~psdesign.errors.SpecError` line
    naming ``key`` (``direction`` of a material's methods, ``transport.thickness_axis`` of
    :func:`psdesign.transport.pores.pore_sizes`: one message for both since session 47).

    >>> checked_axis(2, "direction")
    ('z', 2)
    >>> checked_axis("w", "direction")
    Traceback (most recent call last):
    ...
    psdesign.errors.SpecError: direction: must be 'x', 'y' or 'z' (or 0-2), got 'w'
    """
    from psdesign.errors import SpecError, short

    try:
        return axis_of(value)
    except (ValueError, TypeError):  # TypeError: an unhashable value (a list)
        raise SpecError(key, f"must be 'x', 'y' or 'z' (or 0-2), got {short(value)}") from None


def flow_direction(given: str | int | None, flow: dict) -> str | int:
    """The flow direction of a solve: ``given`` (a command's ``--direction``, a method's
    keyword) or else the spec's ``flow.direction``, else ``"z"``.

    >>> flow_direction(None, {"direction": "x"}), flow_direction("y", {"direction": "x"})
    ('x', 'y')
    >>> flow_direction(None, {})
    'z'
    """
    if given is not None:  # not `given or ...`: the axis index 0 ('x') is falsy
        return given
    return flow.get("direction") or "z"


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


def periodic_gradient(flow: dict, length: float) -> float:
    """The mean pressure gradient ``G`` (Pa/m) of a periodic solve: ``flow.pressure_drop``
    (Pa, default 1) over the RVE's ``length`` (m) along the flow, one rule for the FEM and
    voxel routes (the voxel route ran at 1 Pa/m until session 50: the same K, velocities
    ``L / pressure_drop`` times the FEM's).

    >>> periodic_gradient({"pressure_drop": 2.0}, 4e-6)
    500000.0
    """
    return float(flow.get("pressure_drop", 1.0)) / float(length)


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
# drop"): the drop is the sample length times the windowed mean gradient of the mechanical energy
# flux per unit flow rate,
#
#     dp = L G_w,   G_w = int_0^L w(s) phi(s) ds / (Q int_0^L w ds),
#
# phi(s) = -dE/ds the dissipation per unit length (E the energy flux through the plane s). The
# window depends on the periods ``m`` of the structure in the sample (``periods``: the stack's
# copies times the periods per copy, psdesign.flow.stack):
#
# * ``m >= 2``: the flat-top window, ``j = ceil(m / 4)`` whole periods ``P = L / m`` wide in the
#   middle of the sample, with sin^2 ramps ``b = j P / 4`` wide (the box of ``j P`` convolved with
#   a sin^2 bump of width ``b``). A box of whole periods annihilates any P-periodic part of phi,
#   whatever the bump, so the drop is exactly ``G L`` in the periodic interior; the window is 0
#   within ``(L - j P - b) / 2`` (at least 3/16 of the sample) of each face, where the entrance
#   and exit perturbations live.
# * ``m < 2`` (one period, a structure not periodic along the flow): ``w(t) = sin^2(pi t)``,
#   ``t = s / L`` (no window is exact there; it discounts the end layers).
#
# The tet route integrates the windowed dissipation Phi_w = int w phi ds over its mesh
# (:func:`windowed_drop_from_dissipation`); the voxel route has E(s) / Q on the RVE's face planes
# and sums the windowed per-layer drops (:func:`windowed_drop`), exact on the grid as well when a
# period is a whole number of layers (an interval of ``j P`` holds ``j P / h`` layer midpoints).

#: Mean of the one-period window ``w = sin^2(pi t)`` over the sample (``int_0^1 w dt``).
WINDOW_MEAN = 0.5
#: The flat-top window spans the fewest whole periods that cover this fraction of the sample.
WINDOW_SPAN = 0.25
#: Width of each of the flat-top window's ramps, as a fraction of its span.
WINDOW_RAMP = 0.25


def window_shape(periods: int = 1) -> tuple[float, float] | None:
    """``(span, ramp)`` of the flat-top window as fractions of the sample for ``periods`` periods
    (``None`` below two periods: the sin^2 window).

    >>> window_shape(2), window_shape(5), window_shape(1)
    ((0.5, 0.125), (0.4, 0.1), None)
    """
    m = int(periods)
    if m < 2:
        return None
    span = math.ceil(WINDOW_SPAN * m - 1e-9) / m
    return span, WINDOW_RAMP * span


def _ramp(x: np.ndarray) -> np.ndarray:
    """``int_0^x 2 sin^2(pi u) du`` clipped to ``[0, 1]``: 0 below 0, 1 above 1."""
    x = np.clip(x, 0.0, 1.0)
    return x - np.sin(2.0 * np.pi * x) / (2.0 * np.pi)


def window(t: np.ndarray | float, periods: int = 1) -> np.ndarray:
    """The sample window at the fractional position ``t = s / L`` (0 outside ``[0, 1]``): the
    flat-top window of :func:`window_shape` for ``periods >= 2``, else ``sin^2(pi t)``.

    >>> window(np.array([-0.1, 0.0, 0.5, 1.0])).round(12).tolist()
    [0.0, 0.0, 1.0, 0.0]
    >>> window(np.array([0.1, 0.1875, 0.25, 0.5, 0.8125, 0.9]), periods=2).round(12).tolist()
    [0.0, 0.0, 0.5, 1.0, 0.0, 0.0]
    """
    shape = window_shape(periods)
    t = np.asarray(t, dtype=float)
    if shape is None:
        return np.sin(np.pi * np.clip(t, 0.0, 1.0)) ** 2
    span, ramp = shape
    a = 0.5 * (1.0 - span - ramp)
    return _ramp((t - a) / ramp) - _ramp((t - a - span) / ramp)


def window_mean(periods: int = 1) -> float:
    """``int_0^1 w dt`` of :func:`window`: the span of the flat-top window, 1/2 for sin^2.

    >>> window_mean(1), window_mean(3)
    (0.5, 0.3333333333333333)
    """
    shape = window_shape(periods)
    return WINDOW_MEAN if shape is None else shape[0]


def rve_window(axis: int, start: float, end: float, periods: int = 1):
    """Pointwise window on the sample ``start <= x[axis] <= end`` (0 outside) for a solver's
    weighted dissipation: ``w(xyz)`` with ``xyz`` of shape ``(n, 3)``; its integral over the
    sample length is ``window_mean(periods) * (end - start)``."""
    length = end - start

    def w(xyz: np.ndarray) -> np.ndarray:
        return window((xyz[:, axis] - start) / length, periods)

    return w


def windowed_drop_from_dissipation(
    dissipation_w: float, flow_rate: float, periods: int = 1
) -> float:
    """``dp = Phi_w / (Q int w dt)`` (Pa) from the windowed dissipation ``Phi_w`` (W) of
    ``rve_window(..., periods)`` and the flow rate ``Q`` (m^3/s): the tet route's form of the
    definition.

    >>> windowed_drop_from_dissipation(1.5, 0.5)  # 2 Phi_w / Q
    6.0
    """
    if not flow_rate:
        raise ValueError("flow_rate: must be non-zero to define a pressure drop")
    return float(dissipation_w / (window_mean(periods) * flow_rate))


def windowed_drop(profile: np.ndarray, periods: int = 1) -> float:
    """The pressure drop (Pa) across a sample from its energy-flux profile on ``n + 1`` equally
    spaced planes ``s_k = k L / n`` (``E(s_k) / Q`` in Pa, the energy flux per unit flow rate):
    ``dp = n sum_k w(t_k) (F_k - F_{k+1}) / sum_k w(t_k)`` with ``t_k = (k + 1/2) / n``, the
    layer midpoints, and ``w`` the :func:`window` for ``periods`` periods in the sample.

    The discrete form of ``L G_w``: for a profile ``c - G s + F~(s)`` with ``F~`` periodic over
    ``periods >= 2`` periods of whole layers it is exactly ``G L`` (the flat-top window is a box
    of whole periods convolved with a bump, and any interval of one period holds the same number
    of layer midpoints: each shifted box sums the layer drops of ``F~`` over whole periods, zero).
    With ``periods = 1`` the sin^2 window's samples have only the discrete Fourier modes 0 and
    +-1, so it is exact too for a profile of two or more periods. One layer (``n = 1``) gives the
    drop between the end planes.

    >>> round(windowed_drop(np.array([3.0, 2.0, 1.0, 0.0])), 12)
    3.0
    >>> round(windowed_drop(np.array([4.0, 2.5, 2.0, 0.5, 0.0])), 12)  # two periods of 2 layers
    4.0
    >>> round(windowed_drop(np.array([4.0, 2.5, 2.0, 0.5, 0.0]), periods=2), 12)
    4.0
    """
    f = np.asarray(profile, dtype=float)
    if f.ndim != 1 or len(f) < 2:
        raise ValueError("profile: needs the values on at least the two end planes")
    n = len(f) - 1
    w = window((np.arange(n) + 0.5) / n, periods)
    if not np.any(w > 0):  # fewer layers than the flat-top window can hold
        w = window((np.arange(n) + 0.5) / n)
    return float(n * np.sum(w * (f[:-1] - f[1:])) / np.sum(w))
