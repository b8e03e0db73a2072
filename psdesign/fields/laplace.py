"""Laplace (diffusion / conduction) solutions as VTK ``ImageData`` (cell data on the voxel grid).

Arrays (dimensionless: the solves are linear, so the fields are given per unit applied drop):

* ``concentration_relative`` (diffusivity) or ``potential_relative`` (conductivity): the
  potential scaled to 1 at the inlet face and 0 at the outlet face of the box (periodic: the
  mean gradient ``-1 / L`` plus the periodic fluctuation; NaN in non-conducting cells);
* ``flux_per_unit_gradient``: the flux density (3-vector) per unit applied gradient, in the
  units of the conductivity map (1 in the pore for diffusion: ``J / (D_bulk |grad c|)``). Its
  box mean along the driving axis is the reported ``relative_diffusivity`` /
  ``effective_conductivity``. Face fluxes use the solver's harmonic-mean face conductances
  (:mod:`solvers.transport.laplace`); the cell value is the mean of its two faces.
* ``solid`` (1 = fibre) and ``conductivity``.
"""

from __future__ import annotations

import numpy as np

from psdesign.fields.flow import _flat, add_rating
from psdesign.fields.tables import add_tables


def _harmonic(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    s = a + b
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(s > 0, 2.0 * a * b / np.where(s > 0, s, 1.0), 0.0)


def _face_flux(t: np.ndarray, sigma: np.ndarray, axis: int, b: int, fixed: bool) -> np.ndarray:
    """Flux (voxel units) through the low face of every cell normal to ``b`` (face ``i``
    between cells ``i - 1`` and ``i``); for the fixed BC along the driving axis also the
    outlet face, as an extra last layer."""
    g = _harmonic(sigma, np.roll(sigma, 1, axis=b))
    dt = t - np.roll(t, 1, axis=b)
    if not fixed:
        if b == axis:
            dt = dt - 1.0  # T = phi - x_a: one voxel of the unit mean gradient per face
        return -g * dt
    flux = -g * dt
    first = [slice(None)] * 3
    first[b] = 0
    if b != axis:
        flux[tuple(first)] = 0.0  # insulated lateral faces
        return flux
    flux[tuple(first)] = -2.0 * np.take(sigma, 0, axis=b) * (np.take(t, 0, axis=b) - 1.0)
    out = 2.0 * np.take(sigma, -1, axis=b) * np.take(t, -1, axis=b)
    return np.concatenate([flux, np.expand_dims(out, b)], axis=b)


def conductivity_unit(kind: str, result: dict | None) -> str:
    """The unit of the ``conductivity``, ``flux_per_unit_gradient`` and
    ``effective_conductivity`` arrays of a Laplace field file: ``"1"`` for diffusivity (relative
    to the bulk diffusivity, 1 in the pore), else the result's ``conductivity_unit`` (SI,
    ``W/(m K)`` or ``S/m``: the unit the phase conductivities were given in).

    >>> conductivity_unit("diffusivity", None)
    '1'
    >>> conductivity_unit("conductivity", {"conductivity_unit": "S/m"})
    'S/m'
    """
    if kind == "diffusivity":
        return "1"
    return str((result or {}).get("conductivity_unit", "W/(m K)"))


def laplace_grid(solution, conductivity: np.ndarray, fields, kind: str, result: dict | None):
    """``pyvista.ImageData`` of a :func:`solvers.transport.solve_laplace` solution.

    ``kind`` is ``"diffusivity"`` or ``"conductivity"`` (names the potential array);
    ``result`` (the effective-property dict) adds its value as field data.
    """
    import pyvista as pv

    sigma = np.asarray(conductivity, np.float64)
    a = int(solution.axis)
    n = sigma.shape[a]
    fixed = solution.bc != "periodic"
    t = np.asarray(solution.potential, np.float64)
    flux = np.empty((3, *sigma.shape), np.float64)
    for b in range(3):
        f = _face_flux(t, sigma, a, b, fixed)
        if fixed and b == a:
            lo = np.take(f, np.arange(n), axis=b)
            hi = np.take(f, np.arange(1, n + 1), axis=b)
        else:
            lo, hi = f, np.roll(f, -1, axis=b)
        flux[b] = 0.5 * (lo + hi) / float(solution.gradient)
    if fixed:
        rel = t
    else:
        x = (np.arange(n) + 0.5).reshape([-1 if b == a else 1 for b in range(3)])
        rel = 1.0 - x / n + t / n
    rel = np.where(sigma > 0, rel, np.nan)
    h = float(fields.grid.spacing[0])
    grid = pv.ImageData(dimensions=np.array(sigma.shape) + 1, spacing=(h, h, h))
    name = "concentration_relative" if kind == "diffusivity" else "potential_relative"
    grid.cell_data[name] = _flat(rel.astype(np.float32))
    grid.cell_data["flux_per_unit_gradient"] = np.column_stack(
        [_flat(c.astype(np.float32)) for c in flux]
    )
    grid.cell_data["solid"] = _flat(np.asarray(fields.solid, np.uint8))
    grid.cell_data["conductivity"] = _flat(sigma.astype(np.float32))
    add_tables(grid)
    grid.field_data["direction_axis"] = np.array([a], np.int32)
    grid.field_data["periodic"] = np.array([int(not fixed)], np.int32)
    grid.field_data["mean_flux_per_unit_gradient"] = np.asarray(
        solution.mean_flux / solution.gradient, float
    )
    grid.field_data["conductivity_unit"] = np.array([conductivity_unit(kind, result)])
    if result:
        key = "relative_diffusivity" if kind == "diffusivity" else "effective_conductivity"
        if key in result:
            grid.field_data[key] = np.array([float(result[key])])
        add_rating(grid, result, "rel_error")
    return grid
