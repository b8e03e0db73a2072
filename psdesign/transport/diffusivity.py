"""Effective diffusivity of the pore space, tortuosity factor, Knudsen / transition regime.

Definitions (Fick's law on the pore space, solid impermeable, zero flux on the fibre walls):

* relative diffusivity ``D_eff / D_bulk = <J_a> / (D_bulk |grad c|)``, the superficial mean
  flux over the whole box per unit applied gradient, from one Laplace solve on the pore voxels
  (:func:`solvers.transport.solve_laplace`, conductivity 1 in pore, 0 in solid);
* tortuosity factor ``tau = porosity / (D_eff / D_bulk)`` (so ``D_eff = D_bulk eps / tau``; 1
  for straight channels along the gradient);
* transition regime (Bosanquet): ``1 / D_pore = 1 / D_bulk + 1 / D_Kn`` with the Knudsen
  diffusivity from kinetic theory, ``D_Kn = d_pore u / 3`` and ``D_bulk = lambda u / 3`` at the
  same mean molecular speed ``u``, hence ``D_Kn = D_bulk d_pore / lambda`` and
  ``D_pore = D_bulk / (1 + Kn)`` with ``Kn = lambda / d_pore``; ``d_pore = 4 eps / S_v`` (mean
  pore intercept from the specific surface of :func:`psdesign.transport.pores.specific_surface`)
  and ``lambda`` = ``transport.mean_free_path_m``.  The same ``Kn`` is used in every pore (a
  mean-pore-size model); ``D_eff = D_pore (D_eff / D_bulk)``.

Boundary conditions: ``periodic`` (homogenized tensor; three solves give it whole) or
``permeameter`` (fixed concentrations on the inlet and outlet faces, insulated sides).
A blocked direction gives 0 with ``blocked=True`` and a message; the tortuosity factor is then
None (porosity / 0: printed "undefined ... [blocked]", :func:`tortuosity_undefined`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from psdesign.fields.writer import HeldCapture
from psdesign.geometry.rve import DIAMETER_MEASURE, VoxelFields, checked_fields
from psdesign.schema.transport import transport_keyword, validate_transport
from psdesign.transport.effective import (
    Effective,
    Rated,
    solve_effective,
    tensor_parts,
    wiener_bounds,
    worst_status,
)


@dataclass(repr=False)  # Rated.__repr__: REPR_FIELDS and the status
class DiffusivityResult(Rated):
    """Pore diffusion along one axis (SI units; see module docstring)."""

    QUANTITY = "D_eff/D"
    REPR_FIELDS = (
        "direction",
        "relative_diffusivity",
        "effective_diffusivity_m2_s",
        "tortuosity_factor",
        "rel_error",
        "converged",
        "bc",
    )

    direction: str
    bc: str
    relative_diffusivity: float
    tortuosity_factor: float | None
    porosity: float
    porosity_error: float  # absolute, of the voxel count (psdesign.geometry.porosity)
    relative_diffusivity_column: list[float] = field(repr=False)
    converged: bool
    residual: float
    iterations: int
    flux_imbalance: float
    rel_error: float
    error_method: str
    blocked: bool
    message: str
    n_cells: int
    wall_time_s: float
    bulk_diffusivity_m2_s: float
    effective_diffusivity_m2_s: float
    mean_pore_diameter_m: float | None = None
    knudsen_number: float | None = None
    effective_diffusivity_transition_m2_s: float | None = None
    cells_per_diameter: float | None = None
    warnings: list[str] = field(default_factory=list)
    #: The warning of a conducting path through a neck narrower than about a voxel (None if
    #: none; :mod:`psdesign.transport.necks`), which makes the value ``untrustworthy``.
    unresolved_neck: str | None = None
    #: What ``cells_per_diameter`` counts voxels across (:func:`psdesign.geometry.rve.
    #: resolution_measure`: ``"fiber thin width"`` for a woven or compressed fiber).
    resolution_measure: str = DIAMETER_MEASURE

    def wiener(self) -> tuple[float, tuple[float, float]]:
        """The value and its Wiener bounds ``[0, porosity]`` (pore 1, solid 0;
        :meth:`Rated.wiener`)."""
        return self.relative_diffusivity, wiener_bounds(1.0, 0.0, 1.0 - self.porosity)

    def __str__(self) -> str:
        """The line ``psdesign diffusivity`` prints (:func:`result_line`): value, error bar,
        status, convergence, tortuosity, porosity."""
        return result_line(self.to_dict())

    def _repr_html_(self) -> str:
        from psdesign.notebook import plus_minus, porosity_html, result_html

        tau = self.tortuosity_factor
        rows = [
            ("direction", self.direction),
            (
                "D<sub>eff</sub> / D (-)",
                f"{self.relative_diffusivity:.4g} {plus_minus(self.rel_error)}",
            ),
            (
                "tortuosity factor (-)",
                tortuosity_undefined(self.to_dict())
                if tau is None
                else f"{tau:.4g} {plus_minus(self.rel_error)}",
            ),
            (
                "D<sub>eff</sub> (m<sup>2</sup>/s)",
                f"{self.effective_diffusivity_m2_s:.4e} {plus_minus(self.rel_error)}",
            ),
            ("converged", str(self.converged)),
            ("porosity (-)", porosity_html(self.porosity, self.porosity_error)),
            ("bc", self.bc),
        ]
        return result_html("DiffusivityResult", rows, self.status, [self.message, *self.warnings])


def result_line(r: dict) -> str:
    """The printed line of one diffusivity result dict (``to_dict()``): ``psdesign diffusivity``'s
    and :meth:`DiffusivityResult.__str__`'s (in ``psdesign.cli.diffusivity`` until session 52)."""
    from psdesign.geometry.porosity import porosity_text
    from psdesign.lines import error_bar, rating, value_text

    tau = r["tortuosity_factor"]  # porosity / D: a count over D, so D's relative bar
    tau_text = tortuosity_undefined(r) if tau is None else f"{tau:.4f}{error_bar(r['rel_error'])}"
    return (
        f"{value_text('diffusivity', r['direction'], r)}  {rating(r)}  tortuosity factor "
        f"{tau_text}  porosity {porosity_text(r['porosity'], r.get('porosity_error'))}"
    )


def tortuosity_undefined(r: dict) -> str:
    """The words for a tortuosity factor with no value (JSON ``null``, porosity / 0), with the
    status it shares with D_eff/D: the text line and the notebook printed a bare ``inf`` /
    ``n/a`` until session 51.

    >>> tortuosity_undefined({"blocked": True, "direction": "x", "status": "blocked"})
    'undefined (no pore path along x) [blocked]'
    >>> tortuosity_undefined({"blocked": False, "direction": "z", "status": "untrustworthy"})
    'undefined (D_eff/D = 0) [untrustworthy]'
    """
    why = f"no pore path along {r['direction']}" if r.get("blocked") else "D_eff/D = 0"
    return f"undefined ({why}) [{r['status']}]"


def knudsen_number(mean_free_path: float, pore_diameter: float) -> float:
    """``Kn = lambda / d``."""
    if pore_diameter <= 0:
        raise ValueError(f"pore_diameter must be > 0 m, got {pore_diameter:g}")
    return float(mean_free_path) / float(pore_diameter)


def bosanquet(bulk: float, knudsen: float) -> float:
    """Transition diffusivity ``1 / (1 / D_bulk + 1 / D_Kn)`` (``D_Kn = inf`` gives bulk)."""
    if not np.isfinite(knudsen):
        return float(bulk)
    return float(1.0 / (1.0 / bulk + 1.0 / knudsen))


def pore_diffusivity(bulk: float, mean_free_path: float, pore_diameter: float) -> float:
    """Bosanquet diffusivity in a pore of diameter ``d``: ``D_Kn = D_bulk d / lambda``."""
    if mean_free_path <= 0:
        return float(bulk)
    return bosanquet(bulk, bulk * pore_diameter / mean_free_path)


def _pore_sigma(solid: np.ndarray) -> np.ndarray:
    return (~solid).astype(np.float32)


def _result(
    eff: Effective,
    fields: VoxelFields,
    tr: dict,
    pore_d: float | None,
    cpd: float | None,
    measure: str = DIAMETER_MEASURE,
) -> DiffusivityResult:
    eps = fields.porosity
    rel = max(eff.value, 0.0)
    tau = eps / rel if rel > 0 else None
    bulk = float(tr["bulk_diffusivity_m2_s"])
    out = DiffusivityResult(
        direction=eff.direction,
        bc=eff.bc,
        relative_diffusivity=rel,
        tortuosity_factor=tau,
        porosity=eps,
        porosity_error=fields.porosity_error,
        relative_diffusivity_column=eff.column,
        converged=eff.converged,
        residual=eff.residual,
        iterations=eff.iterations,
        flux_imbalance=eff.flux_imbalance,
        rel_error=eff.rel_error,
        error_method=eff.error_method,
        blocked=eff.blocked,
        message=eff.message,
        n_cells=eff.n_cells,
        wall_time_s=eff.wall_time_s,
        bulk_diffusivity_m2_s=bulk,
        effective_diffusivity_m2_s=bulk * rel,
        cells_per_diameter=cpd,
        unresolved_neck=eff.neck,
        resolution_measure=measure,
    )
    out.warnings = out.rating_warnings()
    if pore_d is not None and pore_d > 0:
        lam = float(tr["mean_free_path_m"])
        out.mean_pore_diameter_m = float(pore_d)
        out.knudsen_number = knudsen_number(lam, pore_d)
        out.effective_diffusivity_transition_m2_s = pore_diffusivity(bulk, lam, pore_d) * rel
    return out


def mean_pore_diameter(fields: VoxelFields) -> float | None:
    """``4 eps / S_v`` from the marching-cubes surface (None without pore surface)."""
    from psdesign.transport.pores import specific_surface

    sv = specific_surface(fields).specific_surface_m_1
    return 4.0 * fields.porosity / sv if sv > 0 else None


def relative_diffusivity(
    fields: VoxelFields,
    direction: str | int = "z",
    transport: dict | None = None,
    progress: Callable[[int, float], None] | None = None,
    pore_diameter: float | None = None,
    capture: Callable[..., None] | None = None,
    cells_per_diameter: float | None = None,
    resolution_measure: str = DIAMETER_MEASURE,
) -> DiffusivityResult:
    """Relative diffusivity ``D_eff / D_bulk`` and tortuosity factor along one axis.

    Parameters
    ----------
    fields : VoxelFields
        Voxelized RVE (cubic voxels); pore where ``distance > 0``.
    direction : "x", "y", "z" or 0..2
    transport : dict, optional
        ``[transport]`` table (validated here; keys ``bc``, ``tol``, ``error_estimate``,
        ``bulk_diffusivity_m2_s``, ``mean_free_path_m``).
    progress : callable, optional
        ``progress(iteration, residual)``.
    pore_diameter : float, optional
        Mean pore diameter for the Knudsen number (default ``4 eps / S_v``).
    capture : callable, optional
        Receives the concentration field and the final result once it is rated:
        ``capture("diffusivity", solution=..., result=dict, ...)`` (e.g. a
        :class:`psdesign.fields.FieldWriter`).
    cells_per_diameter : float, optional
        Voxels across the thinnest fiber (:func:`psdesign.flow.error.cells_per_diameter`);
        below 8 the result is ``untrustworthy`` and says why in ``warnings``.
    resolution_measure : str, optional
        What ``cells_per_diameter`` counts across, named in that warning
        (:func:`psdesign.geometry.rve.resolution_measure`: a woven yarn's thin width).
    """
    fields = checked_fields(fields)  # a VoxelFields, else one line naming it
    tr = validate_transport({"transport": transport_keyword(transport)})
    held = None if capture is None else HeldCapture(partial(capture, "diffusivity"))
    eff = solve_effective(_pore_sigma, fields, direction, tr, progress=progress, capture=held)
    if pore_diameter is None and tr["mean_free_path_m"] > 0:
        pore_diameter = mean_pore_diameter(fields)
    out = _result(eff, fields, tr, pore_diameter, cells_per_diameter, resolution_measure)
    if held is not None:
        held.flush(result=out.to_dict())
    return out


def diffusivity_tensor(
    fields: VoxelFields,
    transport: dict | None = None,
    capture: Callable[..., None] | None = None,
    cells_per_diameter: float | None = None,
    resolution_measure: str = DIAMETER_MEASURE,
) -> dict:
    """Full relative-diffusivity tensor with periodic BC (three solves; ``capture`` as in
    :func:`relative_diffusivity`).

    Returns a dict with ``tensor`` (3x3, column ``a`` = mean flux for a unit gradient along
    ``a``), ``symmetric`` (its symmetric part), ``eigenvalues``, ``tortuosity_factor`` per
    axis, ``results`` (the three :class:`DiffusivityResult` dicts) and ``converged``.
    """
    fields = checked_fields(fields)  # a VoxelFields, else one line naming it
    tr = transport_keyword(transport)
    tr["bc"] = "periodic"
    tr = validate_transport({"transport": tr})
    pore_d = mean_pore_diameter(fields) if tr["mean_free_path_m"] > 0 else None
    results = [
        relative_diffusivity(
            fields,
            d,
            tr,
            pore_diameter=pore_d,
            capture=capture,
            cells_per_diameter=cells_per_diameter,
            resolution_measure=resolution_measure,
        )
        for d in "xyz"
    ]
    return {
        **tensor_parts([r.relative_diffusivity_column for r in results]),
        "tortuosity_factor": {r.direction: r.tortuosity_factor for r in results},
        "relative_diffusivity": {r.direction: r.relative_diffusivity for r in results},
        "porosity": fields.porosity,
        "porosity_error": fields.porosity_error,
        "results": [r.to_dict() for r in results],
        "converged": all(r.converged for r in results),
        "status": worst_status([r.status for r in results]),
        "warnings": [w for r in results for w in r.warnings],
    }
