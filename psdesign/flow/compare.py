"""Both boundary-condition models on one RVE: ``bc_sensitivity`` (is the RVE large enough?).

    bc_sensitivity = |K_permeameter - K_periodic| / K_periodic

The permeameter (empty reservoirs, sides slip or no-slip) and the periodic (homogenized) models
differ only by what happens within about one pore size of the RVE's faces: entrance and exit
losses, fibers cut at the faces, walls. For an RVE much larger than the pore size they agree;
a large value means the boundary layers are a sizeable part of the RVE, i.e. the RVE is too
small to represent the material. :data:`BC_SENSITIVITY_WARN` is the threshold of the warning
(see ``docs/permeability.md``).
"""

from __future__ import annotations

from collections.abc import Callable

from psdesign.flow.permeability import (
    BC_MODELS,
    NATIVE_BC,
    SOLVERS,
    BoundaryConditionUnavailable,
    check_grid_voxels,
    checked_flow,
    permeability,
)
from psdesign.geometry.rve import RVE, VoxelFields, checked_fields

#: Warn when ``bc_sensitivity`` exceeds this plus the two results' error bars: beyond the
#: discretization, a face effect of 5 % is a systematic error comparable to the seed scatter
#: of K in a small RVE (17-19 % in a 40 um Toray-like cube, docs/validation.md), so the RVE size,
#: not the material, starts to set K (docs/permeability.md).
BC_SENSITIVITY_WARN = 0.05


def permeability_both_bc(
    rve: RVE,
    fields: VoxelFields,
    direction: str | int,
    flow: dict,
    solver: str | None = None,
    progress: Callable[[int, float], None] | None = None,
    error_estimate: bool | None = None,
    cross_solver: bool = True,
) -> dict:
    """Solve with ``bc = "permeameter"`` and ``bc = "periodic"`` and compare.

    Parameters
    ----------
    rve, fields, direction, flow, solver, progress, error_estimate
        As for :func:`~psdesign.flow.permeability.permeability`.
    cross_solver : bool
        When ``solver`` cannot apply one model (a route without it), solve that model with
        the other solver and say so in ``bc_results[bc]["solver"]`` and ``warnings``.

    Returns
    -------
    dict
        The result for ``flow["bc"]`` (or the solver's own model) with ``bc_results``
        (per model: ``permeability_m2``, ``permeability_rel_error``, ``converged``, ``solver``,
        ``status``, or ``"n/a: <reason>"``), ``bc_sensitivity`` (``None`` when a model is
        unavailable) and warnings.
    """
    # before its .get: permeability's one line naming flow, the table of the route's solver
    flow = checked_flow(flow, solver)
    check_grid_voxels(checked_fields(fields))  # its line, not "neither model could be solved"
    solver = flow["solver"]
    primary_bc = flow.get("bc") or NATIVE_BC[solver]
    results: dict[str, dict] = {}
    notes: dict[str, str] = {}
    warnings: list[str] = []
    for bc in BC_MODELS:
        f = {**flow, "bc": bc}
        try:
            results[bc] = permeability(rve, fields, direction, f, solver, progress, error_estimate)
        except (BoundaryConditionUnavailable, NotImplementedError, ValueError) as exc:
            other = next(s for s in SOLVERS if s != solver)
            if cross_solver and isinstance(exc, BoundaryConditionUnavailable):
                try:
                    results[bc] = permeability(
                        rve, fields, direction, f, other, None, error_estimate
                    )
                    warnings.append(
                        f"bc {bc!r}: not available with solver {solver!r}; solved with {other!r} "
                        "(bc_sensitivity then includes the solver difference)"
                    )
                    continue
                except (NotImplementedError, ValueError) as exc2:
                    exc = exc2
            notes[bc] = f"n/a: {exc}"
    main = dict(results.get(primary_bc) or next(iter(results.values()), {}))
    if not main:
        raise BoundaryConditionUnavailable(
            f"flow.bc: neither model could be solved ({'; '.join(notes.values())})"
        )
    summary = {bc: notes[bc] for bc in notes}
    for bc, r in results.items():
        summary[bc] = {
            k: r.get(k)
            for k in (
                "permeability_m2",
                "permeability_rel_error",
                "converged",
                "status",
                "solver",
                "bc",
            )
        }
    main["bc_results"] = summary
    for bc, r in results.items():
        if bc != main.get("bc"):
            warnings += [f"[bc {bc}] {w}" for w in r.get("warnings", [])]
    main["bc_sensitivity"] = None
    if len(results) == 2:
        kp, kq = results["permeameter"], results["periodic"]
        sens = abs(kp["permeability_m2"] - kq["permeability_m2"]) / abs(kq["permeability_m2"])
        main["bc_sensitivity"] = float(sens)
        allowed = BC_SENSITIVITY_WARN + kp["permeability_rel_error"] + kq["permeability_rel_error"]
        main["bc_sensitivity_threshold"] = float(allowed)
        if sens > allowed:
            warnings.append(
                f"K_{main['direction']}: permeameter and periodic differ by {100 * sens:.1f} % "
                f"(> {100 * allowed:.1f} % = 5 % + both error bars): the RVE is probably too "
                "small to represent the material"
            )
    else:
        warnings.append(f"bc_sensitivity: unavailable ({'; '.join(notes.values())})")
    main["warnings"] = list(main.get("warnings", [])) + warnings
    return main
