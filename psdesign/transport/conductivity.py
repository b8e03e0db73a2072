"""Effective conductivity of the two-phase fibre / pore medium (thermal or electrical).

``sigma_eff = <J_a> / |grad T|`` from one Laplace solve with the solid voxels at
``solid_conductivity`` and the pore voxels at ``fluid_conductivity`` (harmonic-mean face
conductances, flux-conservative; contrasts up to 1e6 and beyond), or with one phase a perfect
insulator (``insulating_phase``).  Through-plane is ``direction = thickness_axis`` (z by
default), in-plane the other two.  Each result carries the rigorous per-direction Wiener
bounds (arithmetic / harmonic means), which bind any direction of any medium: a value outside
them by more than its error bar is ``untrustworthy`` with a warning (a wrong answer,
:func:`psdesign.transport.effective.outside_wiener`).  For reference only it also carries the
isotropic 3-D Hashin-Shtrikman bounds (Hashin & Shtrikman, J. Appl. Phys. 33, 3125, 1962),
which bind only an isotropic medium: a fibrous medium is anisotropic (a straight fibre's axis
reaches the parallel mean, above them), so they rate nothing.

The phase map is float64; the solver divides it by the better phase and then casts it to
float32 (:func:`solvers.transport.laplace.solve_laplace`), so equal phases are exact (a
float32 map read 3.7 as 3.700000047683716) but a ratio under float32's range does not
survive the solver's cast (120 and 1e-46 passed straight to it: the fluid flushes to 0,
``blocked``). Any two phases in the accepted ``[1e-300, 1e12)`` are still solved right,
because such a contrast never reaches the solver alone: where the better phase spans, the
weaker one's share is below float32's resolution anyway; where it does not, the first solve is
blocked (a flux under ``BLOCKED_FRACTION`` of the Wiener upper bound, from a contrast of about
1e8) and is repeated at :data:`RESOLVED_CONTRAST`, with the better phase lowered in this
float64 map, a ratio the cast keeps (walls across x, 120 against 1e-3 ... 1e-300: the series
mean within 2e-7; a float32 map flushed 1e-46 to 0 before the repeat, session 53). The
float64 map costs about 4 B per voxel more at the peak (113.2 against 109.2 B per voxel
traced on a 96^3 image), the solver copying the map to float64 either way.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from psdesign.fields.writer import HeldCapture
from psdesign.geometry.rve import DIAMETER_MEASURE, VoxelFields, checked_fields
from psdesign.schema.transport import check_conductivity, transport_keyword, validate_transport
from psdesign.transport.effective import Rated, solve_effective, wiener_bounds

#: The contrast a blocked two-phase solve is repeated at (:func:`effective_conductivity`): the
#: periodic solve calls a flux under 1e-7 of the Wiener upper bound blocked
#: (``solvers.transport.laplace.BLOCKED_FRACTION``), which a contrast above about 1e8 with the
#: better phase not spanning reaches (20 um cube, a 6 um rod across: 1.174 up to a contrast of
#: 1e8, then 0 at 1e9). Isolated inclusions 1e6 times the matrix are perfect conductors to
#: about 1e-6 relative (Maxwell: (1 + f) / (1 - f) times the matrix at an infinite contrast).
RESOLVED_CONTRAST = 1e6


@dataclass(repr=False)  # Rated.__repr__: REPR_FIELDS and the status
class ConductivityResult(Rated):
    """Effective conductivity along one axis (units of the phase conductivities)."""

    QUANTITY = "sigma_eff"
    REPR_FIELDS = (
        "direction",
        "effective_conductivity",
        "conductivity_unit",
        "rel_error",
        "converged",
        "bc",
    )

    direction: str
    bc: str
    effective_conductivity: float
    conductivity_column: list[float] = field(repr=False)
    solid_conductivity: float
    fluid_conductivity: float
    insulating_phase: str
    solid_fraction: float
    porosity: float
    porosity_error: float  # absolute, of the voxel count (psdesign.geometry.porosity)
    wiener_bounds: list[float]
    hashin_shtrikman_bounds: list[float]
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
    conductivity_unit: str = "W/(m K)"

    cells_per_diameter: float | None = None
    warnings: list[str] = field(default_factory=list)
    #: The warning of a conducting path through a neck narrower than about a voxel (None if
    #: none; :mod:`psdesign.transport.necks`), which makes the value ``untrustworthy``.
    unresolved_neck: str | None = None
    #: What ``cells_per_diameter`` counts voxels across (:func:`psdesign.geometry.rve.
    #: resolution_measure`: ``"fiber thin width"`` for a woven or compressed fiber).
    resolution_measure: str = DIAMETER_MEASURE

    def wiener(self) -> tuple[float, tuple[float, float]]:
        """The value and its Wiener bounds (:meth:`Rated.wiener`)."""
        lo, hi = self.wiener_bounds
        return self.effective_conductivity, (lo, hi)

    def conducting(self) -> str:
        """``"solid"`` with an insulating fluid, else ``"pore"`` (:meth:`Rated.conducting`): a
        block on the grid is then a contact the grid broke, not a pore gap it closed."""
        return "solid" if self.insulating_phase == "fluid" else "pore"

    def __str__(self) -> str:
        """The line ``psdesign conductivity`` prints (:func:`result_line`): value with its
        unit, error bar, status, convergence, phases."""
        return result_line(self.to_dict())

    def _repr_html_(self) -> str:
        from psdesign.notebook import plus_minus, porosity_html, result_html

        lo, hi = self.hashin_shtrikman_bounds
        w_lo, w_hi = self.wiener_bounds
        u = self.conductivity_unit
        rows = [
            ("direction", self.direction),
            (
                f"effective conductivity ({u})",
                f"{self.effective_conductivity:.4g} {plus_minus(self.rel_error)}",
            ),
            ("converged", str(self.converged)),
            (
                f"solid / fluid conductivity ({u})",
                f"{self.solid_conductivity:.4g} / {self.fluid_conductivity:.4g}",
            ),
            (f"Wiener bounds, any direction ({u})", f"[{w_lo:.4g}, {w_hi:.4g}]"),
            (f"Hashin-Shtrikman bounds, isotropic media only ({u})", f"[{lo:.4g}, {hi:.4g}]"),
            ("porosity (-)", porosity_html(self.porosity, self.porosity_error)),
            ("bc", self.bc),
        ]
        return result_html("ConductivityResult", rows, self.status, [self.message, *self.warnings])


def result_line(r: dict) -> str:
    """The printed line of one conductivity result dict (``to_dict()``): ``psdesign
    conductivity``'s and :meth:`ConductivityResult.__str__`'s (in ``psdesign.cli.conductivity``
    until session 52)."""
    from psdesign.lines import rating, value_text

    return (
        f"{value_text('conductivity', r['direction'], r)}  {rating(r)}  (solid "
        f"{r['solid_conductivity']:g}, fluid {r['fluid_conductivity']:g} "
        f"{r['conductivity_unit']})"
    )


def hashin_shtrikman(s1: float, s2: float, f2: float, dim: int = 3) -> tuple[float, float]:
    """Hashin-Shtrikman bounds of an isotropic two-phase medium in ``dim`` dimensions.

    Phase 1 (conductivity ``s1``, fraction ``1 - f2``) and phase 2 (``s2``, ``f2``); returns
    ``(lower, upper)``.  For ``dim = 2`` these bound the transverse conductivity of parallel
    cylinders (square and hexagonal arrays are transversely isotropic).
    """
    lo, hi = sorted((float(s1), float(s2)))
    f_hi = float(f2) if s2 >= s1 else 1.0 - float(f2)
    f_lo = 1.0 - f_hi
    if hi == lo:
        return lo, hi
    d = float(dim)
    lower = lo + f_hi / (1.0 / (hi - lo) + f_lo / (d * lo)) if lo > 0 else 0.0
    upper = hi + f_lo / (1.0 / (lo - hi) + f_hi / (d * hi))
    return float(lower), float(upper)


def transport_table(
    solid: float | None = None, fluid: float | None = None, transport: dict | None = None
) -> dict:
    """The validated ``[transport]`` table of a conductivity solve: ``transport`` with the
    phase conductivities ``solid`` / ``fluid`` (keywords, in
    :data:`~psdesign.schema.transport.CONDUCTIVITY_RANGE`, ``[1e-300, 1e12)``) in it.

    Raises
    ------
    SpecError
        A conductivity outside ``[1e-300, 1e12)`` (naming its key); a bad ``[transport]``
        key; a ``solid`` (or ``fluid``) for the phase ``insulating_phase`` makes a perfect
        insulator (conductivity 0: the value would be ignored), naming the keyword.

    Examples
    --------
    >>> transport_table(fluid=2.0, transport={"insulating_phase": "solid"})["fluid_conductivity"]
    2.0
    """
    from psdesign.errors import SpecError

    tr = transport_keyword(transport)  # not a table: the schema's one line
    if solid is not None:
        tr["solid_conductivity"] = check_conductivity(solid, "transport.solid_conductivity")
    if fluid is not None:
        tr["fluid_conductivity"] = check_conductivity(fluid, "transport.fluid_conductivity")
    tr = validate_transport({"transport": tr})
    phase = tr["insulating_phase"]
    value = {"solid": solid, "fluid": fluid}.get(phase)
    if value is not None:
        raise SpecError(
            phase,
            f'insulating_phase = "{phase}" makes the {phase} a perfect insulator (conductivity '
            f"0), so {phase} = {value!r} would be ignored; give one of them "
            f'(insulating_phase = "none" to use {phase})',
        )
    return tr


def effective_conductivity(
    fields: VoxelFields,
    direction: str | int = "z",
    solid: float | None = None,
    fluid: float | None = None,
    transport: dict | None = None,
    *,
    progress: Callable[[int, float], None] | None = None,
    capture: Callable[..., None] | None = None,
    cells_per_diameter: float | None = None,
    resolution_measure: str = DIAMETER_MEASURE,
) -> ConductivityResult:
    """Effective conductivity of the voxelized RVE along one axis.

    (Nine parameters: the field, axis and phases, then how the solve reports, keyword-only.)

    Parameters
    ----------
    fields : VoxelFields
    direction : "x", "y", "z" or 0..2
    solid, fluid : float, optional
        In ``[1e-300, 1e12)``, overriding ``transport.solid_conductivity`` /
        ``fluid_conductivity``.
    transport : dict, optional
        ``[transport]`` table (``bc``, ``tol``, ``error_estimate``, ``insulating_phase``).
    progress : callable, optional
    capture : callable, optional
        Receives the potential field and the final result once it is rated:
        ``capture("conductivity", solution=..., result=dict, ...)`` (e.g. a
        :class:`psdesign.fields.FieldWriter`).
    cells_per_diameter : float, optional
        Voxels across the thinnest fiber (:func:`psdesign.flow.error.cells_per_diameter`);
        below 8 ``untrustworthy``, saying why in ``warnings`` (not if solid = fluid: exact).
    resolution_measure : str, optional
        What ``cells_per_diameter`` counts across, named in that warning
        (:func:`psdesign.geometry.rve.resolution_measure`: a woven yarn's thin width).

    Raises
    ------
    SpecError
        A conductivity outside ``[1e-300, 1e12)`` (naming the key), or a ``solid`` /
        ``fluid`` for the ``insulating_phase`` (:func:`transport_table`).
    """
    fields = checked_fields(fields)  # a VoxelFields, else one line naming it
    tr = transport_table(solid, fluid, transport)
    ks = 0.0 if tr["insulating_phase"] == "solid" else tr["solid_conductivity"]
    kf = 0.0 if tr["insulating_phase"] == "fluid" else tr["fluid_conductivity"]

    # float64: a float32 map made 1e-46 a zero before the repeat below (module docstring)
    def sigma_of(mask: np.ndarray) -> np.ndarray:
        return np.where(mask, np.float64(ks), np.float64(kf))

    held = None if capture is None else HeldCapture(partial(capture, "conductivity"))
    eff = solve_effective(sigma_of, fields, direction, tr, progress=progress, capture=held)
    if eff.blocked and ks > 0 and kf > 0:
        # both phases conduct, so nothing blocks: the better phase does not span and the
        # contrast put the flux under the solver's cut-off ("0 [blocked]", a warning to refine
        # the voxel). The better phase at RESOLVED_CONTRAST x the other gives the same value.
        top = min(ks, kf) * RESOLVED_CONTRAST
        ks_c, kf_c = min(ks, top), min(kf, top)

        def sigma_of(mask: np.ndarray) -> np.ndarray:  # noqa: F811 - the repeated solve's
            return np.where(mask, np.float64(ks_c), np.float64(kf_c))

        if held is not None:
            held.drop()
        eff = solve_effective(sigma_of, fields, direction, tr, progress=progress, capture=held)
    fs = 1.0 - fields.porosity
    out = ConductivityResult(
        direction=eff.direction,
        bc=eff.bc,
        effective_conductivity=max(eff.value, 0.0),
        conductivity_column=eff.column,
        solid_conductivity=ks,
        fluid_conductivity=kf,
        insulating_phase=tr["insulating_phase"],
        solid_fraction=fs,
        porosity=fields.porosity,
        porosity_error=fields.porosity_error,
        wiener_bounds=list(wiener_bounds(kf, ks, fs)),
        hashin_shtrikman_bounds=list(hashin_shtrikman(kf, ks, fs, 3)),
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
        conductivity_unit=tr["conductivity_unit"],
        cells_per_diameter=None if ks == kf else cells_per_diameter,  # ks = kf: exact, any grid
        unresolved_neck=eff.neck,
        resolution_measure=resolution_measure,
    )
    out.warnings = out.rating_warnings()
    if held is not None:
        held.flush(result=out.to_dict())
    return out
