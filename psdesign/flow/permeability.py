"""Permeability by Darcy's law from a built-in Stokes solve (paper Sec. 7.2).

Two routes, both geometry-agnostic below this module:

* ``fem``: pore-space tet mesh with empty auxiliary inlet/outlet zones
  (:func:`psdesign.meshing.pore_mesh.mesh_pore_space`), Taylor-Hood Stokes with prescribed
  pressures (:func:`solvers.fem_stokes.solve_stokes`), and

      K = mu Q L / (A dP_rve)

  with Q the outlet flow rate, L and A the RVE length and full cross-section (so
  Q/A is the superficial velocity), and dP_rve the drop of the cross-section-averaged
  pressure between the RVE's own inlet and outlet planes. The auxiliary zones carry
  part of the applied drop (entrance and exit losses where the flow enters and leaves
  the pores); measuring across the porous RVE alone removes that, so K does not
  depend on ``aux_length``.
* ``voxel``: periodic body-force Stokes on the voxel grid
  (:func:`solvers.voxel_stokes.solve_voxel_stokes`), K from the mean velocity.

The dispatcher :func:`permeability` adds what every route's result needs to be trusted
(``docs/permeability.md``): ``bc`` (the boundary-condition model, ``flow.bc``), an error bar
``permeability_rel_error`` from a second, cheaper resolution (:mod:`psdesign.flow.error`),
``cells_per_diameter``, ``warnings`` and ``status`` ("ok" | "not_converged" | "untrustworthy").
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable

import numpy as np

from psdesign.errors import SpecError, short
from psdesign.fields.writer import HeldCapture
from psdesign.flow import error as err
from psdesign.flow.darcy import axis_of
from psdesign.flow.fem import mesher_options, permeability_fem, plane_average_pressure
from psdesign.flow.stack import end_planes
from psdesign.flow.voxel import ResolutionWarning, face_mismatch, permeability_voxel
from psdesign.geometry.rve import (
    DIAMETER_MEASURE,
    RVE,
    VoxelFields,
    checked_fields,
    checked_rve,
    resolution_measure,
    thinnest_fiber_diameter,
)
from psdesign.geometry.throat import percolation_radius
from psdesign.schema.flow import (
    BC_MODELS,
    DEFAULT_FLOW,
    NATIVE_BC,
    SOLVERS,
    TREATMENT_ALLOWED,
    TREATMENT_NAMES,
    check_solver_bc,
    resolution_key,
    treatment_refusal,
    unread_mesher_key,
    validated_flow,
)

__all__ = [
    "BC_MODELS",
    "SOLVERS",
    "check_route_keys",
    "checked_flow",
    "BoundaryConditionUnavailable",
    "NATIVE_BC",
    "face_mismatch",
    "mesher_options",
    "permeability",
    "permeability_fem",
    "permeability_voxel",
    "plane_average_pressure",
    "route_result",
]


class BoundaryConditionUnavailable(ValueError, NotImplementedError):
    """The chosen solver cannot apply the requested ``flow.bc`` (yet)."""


def checked_flow(flow: object, solver: str | None = None) -> dict:
    """``flow`` (the spec's ``[flow]`` table) checked by the schema as a spec file's table,
    with the defaults of the keys it lacks, else one :class:`SpecError` line naming ``flow``
    (:func:`~psdesign.geometry.rve.checked_rve`'s twin) or ``flow.<key>`` and its range:
    ``permeability(rve, fields, "z", flow=3)`` raised ``AttributeError: 'int' object has no
    attribute 'get'`` until session 48 (review), ``flow={"solver": "voxel"}`` ``KeyError:
    'viscosity'`` until session 49.

    ``solver`` (given: the route that will run) replaces ``flow["solver"]`` in the table
    checked and returned, so the cross-key rules see the route's solver: a validated spec's
    ``periodic_treatment = "mirror"`` with no ``flow.solver`` (the table's default "fem") and
    ``solver="voxel"`` was refused naming solver 'fem' (session 49's review: every such study
    case failed).

    >>> checked_flow({"periodic_treatment": "mirror"}, "voxel")["solver"]
    'voxel'
    >>> checked_flow(3)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    psdesign.errors.SpecError: flow: must be a table (a dict: the spec's [flow], ...), got 3
    """
    if not isinstance(flow, dict):
        raise SpecError(
            "flow",
            "must be a table (a dict: the spec's [flow], psdesign.build(spec).spec['flow']), "
            f"got {short(flow)}",
        )
    route = flow if solver is None else {**flow, "solver": solver}
    # the routes' one wording of a solver / bc out of the lists (the schema words it otherwise)
    check_solver_bc(route.get("solver"), route.get("bc"))
    # a table of some keys ({"solver": "voxel"}) was a KeyError 'viscosity' (session 49);
    # the defaults of the keys not given, the given values as given (a validated spec's
    # table comes back equal); FlowTable forbids extra keys, so route's keys are its given ones
    validated_flow(route)
    return {**DEFAULT_FLOW, **route}


def check_grid_voxels(fields: VoxelFields) -> None:
    """Refuse ``fields`` with fewer voxels along an axis than a spec allows
    (:data:`~psdesign.schema.rve.MIN_VOXELS_PER_EDGE`: ``rve.voxel`` at most a quarter of the
    smallest edge, an image 4 voxels per axis) where the geometry varies along that axis: one
    :class:`SpecError` line naming ``fields``. An axis along which every slice of the distance
    field is the same (an extruded, quasi-2-D geometry) passes at any count: the periodic flow
    does not vary along it either, so one voxel is exact there (plane Poiseuille flow on
    24 x 20 x 1 voxels within 1.3e-9 of its closed form,
    ``tests/unit/test_voxel_thin_one_cell.py``). A spec's fields pass it; fields built by hand
    (``image_fields``) 16 x 16 x 2-3 voxels varying along their thin axis were solved and
    rated until session 50.

    >>> from psdesign.image.fields import image_fields
    >>> check_grid_voxels(image_fields(np.eye(4, dtype=bool)[:, :, None], 1e-6))  # extruded
    >>> try:
    ...     check_grid_voxels(image_fields(np.eye(4, dtype=bool)[:, :, None] ^ [[[0, 1]]], 1e-6))
    ... except SpecError as exc:
    ...     print(exc.key, exc.message[:34])
    fields the voxel grid is [4, 4, 2] voxels
    """
    from psdesign.schema.rve import MIN_VOXELS_PER_EDGE, MIN_VOXELS_TEXT

    shape = [int(n) for n in fields.grid.shape]
    # only an axis of 2-3 voxels is read (one pass over the field each), none on a spec's grid
    thin = [a for a, n in enumerate(shape) if 1 < n < MIN_VOXELS_PER_EDGE]
    if any(fields.varies_along(a) for a in thin):
        raise SpecError(
            "fields",
            f"the voxel grid is {shape} voxels (allowed: {MIN_VOXELS_TEXT} the geometry "
            "varies along, as a spec's rve.voxel <= a quarter of the smallest edge)",
        )


def check_route_keys(flow: dict, solver: str, bc: str | None = None) -> None:
    """Refuse a ``[flow]`` choice the route would not apply (a :class:`SpecError`, exit 2):
    ``periodic_treatment`` mirror / frame is the voxel solver's periodic bc's only; the FEM
    and the permeameters ignored it (and the voxel permeameter's result reported it).
    ``bc`` is the model to be solved (default ``flow["bc"]``, else the solver's own).

    >>> check_route_keys({"periodic_treatment": "mirror"}, "voxel")
    >>> try:
    ...     check_route_keys({"periodic_treatment": "mirror"}, "fem")
    ... except ValueError as exc:
    ...     print(exc.key)
    flow.periodic_treatment
    """
    why = treatment_refusal(flow.get("periodic_treatment"), solver, bc or flow.get("bc"))
    if why:
        raise SpecError(
            "flow.periodic_treatment", f"{why}; allowed: {TREATMENT_ALLOWED}", TREATMENT_NAMES
        )


#: The permeameter's own ``[flow]`` keys and the values that mean "not asked for" (the
#: schema's defaults): a periodic solve has no side walls, reservoirs or stack.
PERMEAMETER_KEYS = {"sides": "slip", "aux_length": 0.2, "permeameter_copies": None}


def unused_permeameter_keys(flow: dict, bc: str) -> str | None:
    """The warning for permeameter keys set away from their defaults on a periodic solve,
    or None.

    >>> unused_permeameter_keys({"sides": "noslip", "aux_length": 0.2}, "periodic")[:33]
    "flow.sides = 'noslip' is not used"
    >>> unused_permeameter_keys({"sides": "noslip"}, "permeameter") is None
    True
    """
    if bc != "periodic":
        return None
    given = [
        f"flow.{k} = {flow[k]!r}"
        for k, default in PERMEAMETER_KEYS.items()
        if flow.get(k, default) != default
    ]
    if not given:
        return None
    verb = "is" if len(given) == 1 else "are"
    return (
        f"{', '.join(given)} {verb} not used: the periodic bc has no side walls, reservoirs or "
        "stacked copies (it applies to bc = 'permeameter')"
    )


def supported_bc(solver: str) -> tuple[str, ...]:
    """The ``flow.bc`` models a route can apply: its module's ``BC_MODELS``."""
    from psdesign.flow import fem, voxel

    module = fem if solver == "fem" else voxel
    return tuple(getattr(module, "BC_MODELS", (NATIVE_BC[solver],)))


def _refuse(solver: str, bc: str, got: str) -> BoundaryConditionUnavailable:
    return BoundaryConditionUnavailable(
        f"flow.bc: {bc!r} is not available with solver {solver!r} in this build "
        f"(it applies {got!r}); allowed here: {got!r}"
    )


def _cap(capture: Callable[..., None] | None) -> dict:
    """``{"capture": capture}`` when fields are asked for, else no keyword: a route (or a
    stand-in for one) without fields need not know the argument."""
    return {} if capture is None else {"capture": capture}


def route_result(
    rve: RVE,
    fields: VoxelFields,
    direction: str | int,
    flow: dict,
    solver: str,
    progress: Callable[[int, float], None] | None = None,
    capture: Callable[..., None] | None = None,
) -> dict:
    """One route's raw result with ``bc`` set; no error estimate. ``capture`` receives the
    solver's fields (see :func:`permeability`).

    Raises
    ------
    BoundaryConditionUnavailable
        If ``flow["bc"]`` is not the route's behaviour and the route does not report
        a ``bc`` of its own (it predates the ``bc`` key).
    """
    bc = flow.get("bc")
    check_solver_bc(solver, bc)
    if bc is not None and bc not in supported_bc(solver):
        raise _refuse(solver, bc, NATIVE_BC[solver])  # before a solve is wasted
    check_route_keys(flow, solver)
    if solver == "fem":
        res = permeability_fem(rve, fields, direction, flow, **_cap(capture))
    else:
        res = permeability_voxel(
            fields, direction, flow, progress=progress, rve=rve, **_cap(capture)
        )
    got = res.get("bc")
    if got is None:
        got = NATIVE_BC[solver]
        res["bc"] = got
    if bc is not None and got != bc:
        raise _refuse(solver, bc, got)
    if got == "periodic" and rve is not None:
        res["seam_gap_fraction"] = _periodic_seam(rve, fields, direction)
    return res


def _periodic_seam(rve: RVE, fields: VoxelFields, direction: str | int) -> float:
    """The wrap's seam along the flow (:attr:`psdesign.flow.stack.EndPlanes.gap_fraction`) when
    the end planes match within :data:`psdesign.flow.stack.SEAM_TOL_LENGTH`, for the error bar's
    seam term (:func:`psdesign.flow.error.seam_rel_error`): a periodic solve joins the RVE to
    itself there as the stack joins two copies; beyond the tolerance the result already warns
    that it is of the wrapped grid, seams included, and the term is left out."""
    ends = end_planes(rve, fields, axis_of(direction)[1])
    return ends.gap_fraction if ends.periodic else 0.0


def _tetwild_mesh(res: dict) -> bool:
    """True for a pytetwild mesh (it reports its target edge and has no lattice)."""
    q = res.get("mesh_quality") or {}
    return not q.get("lattice_step_m") and bool(q.get("edge_length_m"))


def _fem_step(res: dict, fields: VoxelFields, rve: RVE, flow: dict) -> float:
    """The tet route's ``h``: the stuffing lattice's step, or pytetwild's target edge (what
    that mesh resolves; the box-relative lattice step stood for it before session 39 and was
    13x finer than the edge on one cell of a square array)."""
    q = res.get("mesh_quality") or {}
    if q.get("lattice_step_m"):
        return float(q["lattice_step_m"])
    if _tetwild_mesh(res):
        return float(q["edge_length_m"])
    if flow.get("lattice_step") is not None:
        return float(flow["lattice_step"])
    from psdesign.meshing.options import default_lattice_step

    # a mesh without a lattice (pytetwild): the box-relative step stands for its resolution
    return default_lattice_step(float(fields.grid.spacing[0]), rve.size)


def _order(solver: str, res: dict) -> int:
    """Theoretical order: 1 for the voxel staircase, 2 for sub-voxel walls and tet meshes."""
    if solver == "voxel":
        wall = str(res.get("wall_treatment", "staircase"))
        return 1 if wall == "staircase" else 2
    return 2


def _coarse_fn(rve, fields, direction, flow, solver, res):
    """The second resolution, as a callable returning ``(k_coarse, ratio)``."""
    if solver == "voxel":
        found = err.coarse_voxel_shape(fields.grid.shape)
        if found is None:
            return None
        shape, ratio = found
        h_coarse = float(fields.grid.size[0]) / shape[0]

        def run() -> tuple[float, float]:
            from solvers.voxel_stokes import NoFluidPathError

            coarse = rve.voxelize(h_coarse)
            n_solid = int(np.count_nonzero(coarse.solid))
            if n_solid in (0, coarse.solid.size):
                raise err.CoarseLostPhase(
                    f"its {h_coarse:.3g} m grid has no {'solid' if n_solid == 0 else 'fluid'} voxel"
                )
            with warnings.catch_warnings():  # the coarse grid's own resolution is not the user's
                warnings.simplefilter("ignore", ResolutionWarning)
                try:
                    k = float(route_result(rve, coarse, direction, flow, solver)["permeability_m2"])
                except NoFluidPathError as exc:  # its line speaks of the user's grid or image
                    raise ValueError(
                        f"its {h_coarse:.3g} m grid has no fluid path along {res['direction']}"
                    ) from exc
            return k, ratio

        return run
    step = _fem_step(res, fields, rve, flow)
    # pytetwild ignores the lattice step: coarsen its edge (and with it the surface step), a
    # fraction of the meshed box's diagonal (flow.edge_length); the same edge gave a second mesh
    # only as fine, whose spread was read as a Richardson term of ratio 2
    fraction = (res.get("mesh_quality") or {}).get("edge_length_fraction")
    tetwild = _tetwild_mesh(res)

    def coarser(ratio: float) -> dict:
        if not tetwild:
            return {**flow, "lattice_step": ratio * step}
        if not fraction:  # a mesh cached before session 39 does not report it
            raise ValueError(f"x{ratio:g}: the mesh does not report its edge fraction")
        if ratio * fraction > 1.0:
            raise ValueError(f"x{ratio:g}: the edge would exceed the box diagonal")
        return {**flow, "edge_length": ratio * float(fraction)}

    def run_fem() -> tuple[float, float]:
        failures = []
        for ratio in err.COARSE_RATIOS[:2]:  # 2, then 1.5 if the lattice is too coarse to mesh
            try:
                f2 = coarser(ratio)
            except ValueError as exc:
                failures.append(str(exc))
                continue
            try:
                return float(route_result(rve, fields, direction, f2, solver)["permeability_m2"]), (
                    ratio
                )
            except ValueError as exc:
                failures.append(f"x{ratio:g}: {exc}")
        raise ValueError("; ".join(failures))

    return run_fem


def _throat_fn(fields: VoxelFields, direction: str | int, step: float) -> Callable:
    """The throat width (m) of ``fields`` along ``direction`` (:mod:`psdesign.geometry.throat`,
    :func:`psdesign.flow.error.throat_width_voxels`), as a callable for
    :func:`psdesign.flow.error.estimate_with`; None where no throat limits the flow
    (:func:`psdesign.flow.error.throat_limits`, e.g. along straight fibres)."""

    def run() -> float | None:
        wd = fields.wall_distance  # once per grid, whatever the direction
        r = percolation_radius(wd, axis_of(direction)[1])
        if not err.throat_limits(r, float(np.max(wd, initial=0.0))):
            return None
        return err.throat_width_voxels(r) * step

    return run


def floor_diameter(rve: RVE, fields: VoxelFields) -> float | None:
    """The fibre diameter ``D`` of the fibre floor (:data:`psdesign.flow.error.FIBER_FLOOR`):
    the thinnest fibre's; for a segmented image (no fibres) the solid's hydraulic diameter
    ``4 (1 - eps) / S_v`` (marching cubes, :func:`psdesign.transport.pores.specific_surface`),
    a cylinder's diameter exactly and a volume-weighted mean for several; None without solid."""
    d = thinnest_fiber_diameter(rve)
    if d is not None or not fields.solid.any():
        return d
    from psdesign.transport.pores import specific_surface

    sv = specific_surface(fields, check=False, rve=rve).specific_surface_m_1
    return 4.0 * float(fields.solid.mean()) / sv if sv > 0 else None


def with_error_estimate(
    rve: RVE,
    fields: VoxelFields,
    direction: str | int,
    flow: dict,
    solver: str,
    res: dict,
    second_resolution: bool = True,
) -> dict:
    """Add ``permeability_rel_error``, ``error_estimate``, ``cells_per_diameter``,
    ``warnings`` and ``status`` to a route result ``res`` (in place; returned)."""
    step = float(fields.grid.spacing[0]) if solver == "voxel" else _fem_step(res, fields, rve, flow)
    cpd = res.get("cells_per_diameter")
    if cpd is None:
        cpd = err.cells_per_diameter(rve, step)
    res["cells_per_diameter"] = cpd
    coarse = _coarse_fn(rve, fields, direction, flow, solver, res) if second_resolution else None
    t0 = time.perf_counter()
    scheme = str(res.get("wall_treatment", "staircase")) if solver == "voxel" else "tet"
    if solver == "fem" and _tetwild_mesh(res):
        scheme = "tetwild"  # its own floor (flow.error, FLOOR): h is its edge, not a lattice
    # the gap term bounds a wall misplaced on the grid: an image's walls are its voxel faces
    analytic = solver == "voxel" and fields.analytic_distance
    throat = _throat_fn(fields, direction, step) if analytic else None
    diameter = floor_diameter(rve, fields) if scheme in err.FIBER_FLOOR else None
    # a permeameter along a geometry that does not vary along the flow has no entrance reach
    varies = res.get("bc") != "permeameter" or fields.varies_along("xyz".index(res["direction"]))
    est = err.estimate_with(
        res, step, _order(solver, res), coarse, scheme, throat, diameter, varies
    )
    res.update(est.as_dict())
    res["error_estimate"]["wall_time_s"] = time.perf_counter() - t0
    warnings = list(res.get("warnings", []))
    # the key of the route the user chose (flow.mesher); the mesh's own report only where the
    # table names no mesher (a mesh cached before session 39 reports no edge: it named
    # flow.lattice_step on the pytetwild route)
    mesher = flow.get("mesher") or ("pytetwild" if scheme == "tetwild" else None)
    key = resolution_key("fem", mesher)
    measure = resolution_measure(rve)
    warnings += err.resolution_warnings(
        cpd, solver, res["direction"], mesh_key=key, fiber_floor=est.fiber > 0.0, measure=measure
    )
    if measure != DIAMETER_MEASURE:  # the words of the row's status reason (report.html)
        res["resolution_measure"] = measure
    if not res.get("converged", False):
        warnings.append(
            f"K_{res['direction']}: solver did not converge (residual {res.get('residual', 0):.2e})"
        )
    if est.method != "two_grid" and second_resolution:
        why = f" ({est.coarse_failure})" if est.coarse_failure else ""
        warnings.append(
            f"K_{res['direction']}: no second resolution could be solved{why}; the error bar is "
            "the resolution floor alone"
        )
    if est.coarse_lost_phase:
        warnings.append(
            f"K_{res['direction']}: a phase vanishes on the second resolution's coarser grid, so "
            "its features are only a few voxels across here and the resolution floor does not "
            "bound their error (untrustworthy): refine the grid (rve.voxel, or a finer image)"
        )
    refine = "rve.voxel, or a finer image" if solver == "voxel" else key
    warnings += err.bar_warnings(f"K_{res['direction']}", est, refine)
    spread = err.definition_spread(res)
    if spread is not None:
        res["definition_spread"] = spread
        if err.definition_spread_warns(res, spread):
            warnings.append(
                f"K_{res['direction']}: the face-plane pressure drop gives a K "
                f"{100 * spread:.0f} % different from the windowed one: this one-period sample "
                "is not homogeneous along the flow at its own length (e.g. few fibre layers, open "
                "end layers), so its permeameter K depends on the definition; compare bc = "
                "'periodic' (--bc both reports bc_sensitivity) or a longer RVE"
            )
    res["warnings"] = warnings
    # the staircase voxel route is unreliable below MIN_CELLS_PER_DIAMETER (status); the
    # body-fitted P2 tet route gets the warning, and its status follows the error bar
    res["status"] = err.status_of(
        bool(res.get("converged", False)),
        est.rel_error,
        cpd if solver == "voxel" else None,
        coarse_lost_phase=est.coarse_lost_phase,
    )
    return res


def permeability(
    rve: RVE,
    fields: VoxelFields,
    direction: str | int,
    flow: dict,
    solver: str | None = None,
    progress: Callable[[int, float], None] | None = None,
    error_estimate: bool | None = None,
    capture: Callable[..., None] | None = None,
) -> dict:
    """Permeability along one axis with an error bar.

    Parameters
    ----------
    rve : RVE
    fields : VoxelFields
        The RVE on its voxel grid (meshed by the fem route, solved by the voxel route).
    direction : 'x' | 'y' | 'z'
    flow : dict
        The spec's ``[flow]`` table; ``flow["bc"]`` ('permeameter' | 'periodic', absent: the
        solver's own behaviour, :data:`NATIVE_BC`) is passed to the route.
    solver : 'fem' | 'voxel', optional
        Default ``flow["solver"]`` or 'fem'.
    progress : callable, optional
        ``progress(iterations, residual)`` (voxel route only).
    error_estimate : bool, optional
        Solve a second, coarser resolution for the error bar (default
        ``flow["error_estimate"]`` or True). Without it the bar is the resolution floor alone.
    capture : callable, optional
        Receives the fields of the main solve (not of the coarse one), e.g. a
        :class:`psdesign.fields.FieldWriter`: ``capture(kind, solution=..., result=..., ...)``
        with kind ``"fem_flow"`` or ``"voxel_flow"``.

    Returns
    -------
    dict
        The route's result (``permeability_m2``, ``direction``, ``porosity``, ``solver``,
        ``bc``, ``converged``, ``residual``, ``iterations``, ``flux_imbalance``,
        ``wall_time_s``, ...) plus ``permeability_rel_error``, ``error_estimate``,
        ``cells_per_diameter``, ``warnings`` and ``status``.

    Raises
    ------
    SpecError
        ``rve`` not an :class:`RVE`, ``fields`` not :class:`VoxelFields` or with 2-3 voxels
        along an axis the geometry varies along (:func:`check_grid_voxels`), or ``flow`` not a
        dict: one line naming it, before any work (``permeability(3, ...)`` raised
        ``AttributeError: 'int' object has no attribute 'fibers'`` until session 48).
    """
    rve, fields, flow = checked_rve(rve), checked_fields(fields), checked_flow(flow, solver)
    check_grid_voxels(fields)  # a spec's rule, for fields built by hand (session 50)
    solver = flow["solver"]  # the route's: the argument, else flow.solver, else "fem"
    final = None if capture is None else HeldCapture(capture)
    res = route_result(rve, fields, direction, flow, solver, progress=progress, **_cap(final))
    res, flow = auto_lengthen(rve, fields, direction, flow, solver, res, progress, final)
    if error_estimate is None:
        error_estimate = bool(flow.get("error_estimate", True))
    out = with_error_estimate(rve, fields, direction, flow, solver, res, error_estimate)
    unread = unread_mesher_key({**flow, "solver": solver})
    for unused in (unused_permeameter_keys(flow, out["bc"]), unread):
        if unused is not None:
            out["warnings"].append(unused)
    if final is not None:  # once rated: the picture's title gives K's bar and status (s49)
        final.flush()
    return out


def _longer_flow(flow: dict, res: dict, copies: int) -> dict:
    """``flow`` with ``copies`` stacked; the FEM's default lattice step kept at the first solve's
    (:func:`psdesign.schema.budget.fem_lattice_step` could coarsen it for a longer stack)."""
    out = {**flow, "permeameter_copies": copies}
    step = (res.get("mesh_quality") or {}).get("lattice_step_m")
    if res.get("solver") == "fem" and flow.get("lattice_step") is None and step:
        out["lattice_step"] = float(step)
    return out


def _restack_refusal(res: dict, copies: int, fields: VoxelFields, flow: dict) -> tuple:
    """``(why, reason)`` when ``copies`` stacked do not fit (:func:`~psdesign.schema.budget.
    restack_bytes` over :func:`~psdesign.schema.budget.memory_budget`, a study worker's share,
    or not :func:`~psdesign.schema.budget.fits_cap` ``flow.max_memory_gb``, the rule of every
    up-front cap check), else ``(None, None)``."""
    from psdesign.schema import budget

    shape = [float(n) for n in fields.grid.shape]
    need = budget.restack_bytes(res, copies, shape, float(flow.get("aux_length", 0.2)))
    limit = budget.memory_budget()  # a study worker's share (the whole in each of N, s54)
    cap = flow.get("max_memory_gb")
    if need > limit:
        return "budget", (
            f"{copies} would need about {need / 2**30:.3g} GiB; the budget is "
            f"{limit / 2**30:.3g} GiB, {budget.budget_words()}"
        )
    if not budget.fits_cap(cap, need):
        # the FEM solve refused it after the first solve's work (exit 2, no K); the voxel
        # route went over the cap without a word. Until session 43 this stopped at the cap
        # itself while every other check allows budget.CAP_MARGIN over it
        return "max_memory_gb", (
            f"{copies} would need about {need / 1e9:.3g} GB, over flow.max_memory_gb "
            f"= {float(cap):.3g} GB"
        )
    return None, None


def _solve_longer(
    rve: RVE,
    fields: VoxelFields,
    direction: str | int,
    flow: dict,
    solver: str,
    progress: Callable[[int, float], None] | None,
    capture: Callable[..., None] | None,
) -> dict | str:
    """The longer stack's result, or the FEM solve's own ``flow.max_memory_gb`` refusal of
    its built mesh as the reason to stop (an estimate within ``CAP_MARGIN`` of the cap let it
    be meshed): the shorter stack's result and its held fields are kept."""
    held = capture.call if isinstance(capture, HeldCapture) else None
    if isinstance(capture, HeldCapture):
        capture.drop()
    try:
        return route_result(rve, fields, direction, flow, solver, progress, capture)
    except SpecError as exc:
        if exc.key != "flow.max_memory_gb":
            raise
        if isinstance(capture, HeldCapture):
            capture.call = held
        return f"{flow['permeameter_copies']} were refused by the solve: {exc.message}"


def auto_lengthen(
    rve: RVE,
    fields: VoxelFields,
    direction: str | int,
    flow: dict,
    solver: str,
    res: dict,
    progress: Callable[[int, float], None] | None = None,
    capture: Callable[..., None] | None = None,
) -> tuple[dict, dict]:
    """A ``permeameter_copies = "auto"`` permeameter solved again with one copy more while its
    window term is above the threshold (:func:`psdesign.flow.stack.next_auto_copies`) and the
    longer stack fits the memory budget and ``flow.max_memory_gb`` (:func:`_restack_refusal`).

    Returns the final result and the ``[flow]`` table it was solved with, its copies pinned to
    the final solve's for the error bar's second resolution, also when ``"auto"`` did not
    lengthen: re-planned on the coarser grid, ``"auto"`` could stack a different sample (until
    session 19 the end-plane test was in voxels of the grid: rev_toray's RVE at 0.833 um was one
    copy, at the 1.67 um of its coarse grid two, and the bar compared the two samples; the
    tolerance is now a length of the geometry, :data:`psdesign.flow.stack.SEAM_TOL_LENGTH`,
    and the pin keeps the bar's two solves one sample whatever the test). An ``"auto"`` result
    gets ``permeameter_auto``: the
    copies, K and window term of each solve and why it stopped; a stop with the window term
    still above the threshold adds a warning naming ``flow.permeameter_copies``. ``capture``
    (a :class:`HeldCapture` from :func:`permeability`) has each superseded solve's fields
    dropped before the next solve, so only the final solve's are written."""
    from psdesign.flow.stack import AUTO_MAX_COPIES, AUTO_WINDOW, MAX_COPIES, next_auto_copies

    requested, tries = flow.get("permeameter_copies"), []
    varies = fields.varies_along("xyz".index(res["direction"]))
    while True:
        window = err.window_of(res, varies)
        done = int(res.get("permeameter_copies") or 1)
        tries.append(
            {"copies": done, "permeability_m2": float(res["permeability_m2"]), "window": window}
        )
        copies, why = next_auto_copies(requested, res, window)
        reason = f"the most it stacks, {AUTO_MAX_COPIES}" if why == "max" else None
        if copies is not None:
            stop, reason = _restack_refusal(res, copies, fields, flow)
            why, copies = (stop, None) if stop else (why, copies)
        if copies is None:
            break
        longer = _longer_flow(flow, res, copies)
        got = _solve_longer(rve, fields, direction, longer, solver, progress, capture)
        if isinstance(got, str):
            why, reason = "max_memory_gb", got
            break
        res, flow = got, longer
    if why == "fixed":
        return res, flow
    flow = {**flow, "permeameter_copies": done}
    res["permeameter_auto"] = {"tries": tries, "stopped": why}
    if reason is not None:
        res.setdefault("warnings", []).append(
            f"K_{res['direction']}: flow.permeameter_copies = 'auto' stopped at {done} copies "
            f"({reason}) with the window term {100 * window:.1f} % above {100 * AUTO_WINDOW:g} "
            f"%; set flow.permeameter_copies (up to {MAX_COPIES}), or use bc = 'periodic'"
        )
    return res, flow
