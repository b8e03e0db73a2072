"""Schema of the ``[flow]`` table."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, ValidationError, model_validator

from psdesign.errors import SpecError
from psdesign.schema.errors import spec_error
from psdesign.schema.types import Table, fail, flag, number, short

#: Largest ``flow.permeameter_copies`` (psdesign.flow.stack.MAX_COPIES).
MAX_PERMEAMETER_COPIES = 8
#: Copies ``"auto"`` stacks first for a periodic one-period RVE (psdesign.flow.stack.AUTO_COPIES);
#: where the spec cannot tell the copies (a generated RVE) the up-front memory
#: budget (half the machine) counts these, the ``flow.max_memory_gb`` cap one copy, and the
#: planned stack is checked once the RVE is built; explicit fibers or an image along a
#: direction count their planned copies in both (psdesign.schema.plan; a longer stack "auto"
#: takes after the first solve is checked before it is solved).
AUTO_PERMEAMETER_COPIES = 2
#: The Stokes solvers (``flow.solver``): the one list, which a study's ``solver``, the route
#: (:mod:`psdesign.flow.permeability`) and ``rev --solver`` take too.
SOLVERS = ("fem", "voxel")
#: The boundary-condition models of ``flow.bc``: the one list, which each route's
#: ``BC_MODELS`` (:func:`psdesign.flow.permeability.supported_bc`) names its share of.
BC_MODELS = ("permeameter", "periodic")
#: The voxel route's wall treatments (``flow.wall_treatment``): the one list.
WALL_TREATMENTS = ("subvoxel", "staircase", "diffuse")


def check_solver_bc(solver: object = None, bc: object = None) -> None:
    """``solver`` (when given) one of :data:`SOLVERS` and ``bc`` (when given) one of
    :data:`BC_MODELS`, else one :class:`~psdesign.errors.SpecError` line naming
    ``flow.solver`` / ``flow.bc`` and listing the allowed from those lists: the one wording of
    the routes' refusals (:mod:`psdesign.flow.permeability`, ``compare``, ``fem``, ``voxel``),
    which spelled the lists by hand until session 48 (review).

    >>> check_solver_bc("voxel", "periodic")
    >>> check_solver_bc(bc="open")
    Traceback (most recent call last):
    ...
    psdesign.errors.SpecError: flow.bc: must be one of permeameter, periodic, got 'open'
    """
    for key, value, allowed in (("flow.solver", solver, SOLVERS), ("flow.bc", bc, BC_MODELS)):
        if value is not None and not (isinstance(value, str) and value in allowed):
            raise SpecError(key, f"must be one of {', '.join(allowed)}, got {short(value)}")


def _copies(value: Any) -> Any:
    """``"auto"`` or an integer in ``[1, MAX_PERMEAMETER_COPIES]`` (bools and floats refused)."""
    if value == "auto" and isinstance(value, str):
        return value
    if isinstance(value, int) and not isinstance(value, bool):
        if 1 <= value <= MAX_PERMEAMETER_COPIES:
            return value
    raise fail(
        "",
        f"must be 'auto' or an integer in [1, {MAX_PERMEAMETER_COPIES}], got {short(value)}",
        f"auto | 1 ... {MAX_PERMEAMETER_COPIES}",
    )


#: The boundary-condition model each solver applies when ``flow.bc`` is not given.
NATIVE_BC = {"fem": "permeameter", "voxel": "periodic"}


def treatment_refusal(treatment: str | None, solver: str, bc: str | None) -> str | None:
    """Why ``flow.periodic_treatment`` cannot apply to ``solver`` with ``bc``, or None.

    Mirror / frame are the voxel solver's periodic bc's: the FEM and both permeameters ignored
    them (and the voxel permeameter's result reported the treatment). ``bc`` None is the
    solver's own (:data:`NATIVE_BC`). The one rule behind the schema's refusal and the
    route's (:func:`psdesign.flow.permeability.check_route_keys`).

    >>> treatment_refusal("mirror", "voxel", None) is None
    True
    >>> treatment_refusal("frame", "fem", None)[:48]
    "'frame' applies to the voxel solver's periodic b"
    """
    treatment = treatment or "periodic"
    bc = bc or NATIVE_BC.get(solver, "permeameter")
    if treatment == "periodic" or (solver, bc) == ("voxel", "periodic"):
        return None
    return (
        f"{treatment!r} applies to the voxel solver's periodic bc only, not to solver "
        f"{solver!r} with bc {bc!r}"
    )


#: What :func:`treatment_refusal`'s message allows.
TREATMENT_ALLOWED = "periodic, or solver 'voxel' with flow.bc = 'periodic'"
#: The spec keys :data:`TREATMENT_ALLOWED` names (a study spells them as its file does).
TREATMENT_NAMES = ("flow.bc",)


#: ``flow.tol`` when the spec leaves it out: the relative residual the Stokes solves stop at
#: (the voxel solver's iterations, the FEM's Krylov solve), passed by :mod:`psdesign.flow`; the
#: solvers' own keyword defaults are a library caller's. One definition, for the code and
#: docs/spec-keys.md (:func:`psdesign.schema.keys.code_defaults`).
FLOW_TOL = 1e-6
#: ``flow.tol`` left out with ``flow.wall_treatment = "diffuse"``: its solve's own (tighter)
#: stop, :func:`solvers.voxel.diffuse.solve_diffuse_stokes`'s default until session 53.
DIFFUSE_FLOW_TOL = 1e-8

#: Defaults filled into every validated spec (other keys appear only when given).
DEFAULT_FLOW = {
    "solver": "fem",
    "viscosity": 1.8e-5,
    "aux_length": 0.2,
    "sides": "slip",
    "pressure_drop": 1.0,
    "mesher": "stuffing",
}


#: The allowed range of ``flow.lattice_step`` (the checks in :mod:`psdesign.schema.document`,
#: :data:`psdesign.schema.budget.MAX_LATTICE_CELLS`), as the key's refusals print it.
LATTICE_STEP_RANGE = "> 0 m, <= half the smallest edge, at most 5e7 lattice cells"
#: The allowed range of ``flow.edge_length`` with ``mesher = "pytetwild"``, as refusals print it.
PYTETWILD_EDGE_RANGE = "in [0.005, 1] of the box diagonal"
#: The key that sets each route's resolution, as refusals and warnings name it: the FEM's
#: mesher's (``flow.mesher``) or the voxel grid's.
RESOLUTION_KEY = {
    "stuffing": "flow.lattice_step",
    "pytetwild": "flow.edge_length",
    "voxel": "rve.voxel",
}


def resolution_key(solver: str, mesher: str | None = None) -> str:
    """The key that refines the route ``solver`` (and, for the FEM, ``mesher``, default
    ``"stuffing"``) reads: what a refusal or warning on that route must name.

    >>> resolution_key("fem", "pytetwild"), resolution_key("fem"), resolution_key("voxel")
    ('flow.edge_length', 'flow.lattice_step', 'rve.voxel')
    """
    return RESOLUTION_KEY["voxel" if solver == "voxel" else mesher or "stuffing"]


def coarser_advice(key: str) -> str:
    """How a memory refusal words the cheaper resolution on ``key`` (a
    :data:`RESOLUTION_KEY` value or ``image.crop``): a longer edge, a smaller crop, a coarser
    step or voxel.

    >>> coarser_advice("flow.edge_length"), coarser_advice("rve.voxel")
    ('a longer flow.edge_length', 'a coarser rve.voxel')
    """
    return {"flow.edge_length": "a longer", "image.crop": "a smaller"}.get(key, "a coarser") + (
        f" {key}"
    )


def unread_mesher_key(flow: dict) -> str | None:
    """The warning for the other FEM mesher's resolution key set on an FEM solve, or None:
    ``flow.edge_length`` with the stuffing mesher, ``flow.lattice_step`` with pytetwild (each
    mesher reads only its own, :data:`RESOLUTION_KEY`; the value was ignored without a word).

    >>> unread_mesher_key({"solver": "fem", "mesher": "stuffing", "edge_length": 0.005})[:48]
    'flow.edge_length = 0.005 is not used: mesher stu'
    >>> unread_mesher_key({"solver": "fem", "mesher": "pytetwild", "edge_length": 0.1}) is None
    True
    """
    if flow.get("solver", "fem") != "fem":
        return None
    mesher = flow.get("mesher") or "stuffing"
    other = "pytetwild" if mesher == "stuffing" else "stuffing"
    name = RESOLUTION_KEY[other].removeprefix("flow.")
    if flow.get(name) is None:
        return None
    return (
        f"flow.{name} = {flow[name]!r} is not used: mesher {mesher} reads "
        f"{RESOLUTION_KEY[mesher]} ({RESOLUTION_KEY[other]} is mesher {other}'s)"
    )


class FlowTable(Table):
    """Stokes solve and boundary conditions."""

    solver: Literal[SOLVERS] = Field(  # type: ignore[valid-type]
        "fem", description="fem | voxel (default fem)"
    )
    bc: Literal[BC_MODELS] | None = Field(  # type: ignore[valid-type]
        None,
        description="permeameter | periodic (default: the solver's own, fem -> "
        "permeameter, voxel -> periodic)",
    )
    permeameter_copies: Annotated[int | str, BeforeValidator(_copies)] | None = Field(
        None,
        description="auto | integer in [1, 8]: copies of the RVE stacked along the flow in the "
        "permeameter (default auto: 2 when the geometry is periodic along the flow and one copy "
        "holds fewer than two periods, else 1; a stack then takes one more, up to 4, while the "
        "window term is above 1 %)",
    )
    error_estimate: flag | None = Field(
        None,
        description="true | false: second solve at a coarser resolution for the error bar "
        "(default true)",
    )
    wall_treatment: Literal[WALL_TREATMENTS] | None = Field(  # type: ignore[valid-type]
        None,
        description="subvoxel | staircase | diffuse (voxel solver walls, default subvoxel where "
        "the geometry has an analytic distance; diffuse: converges monotonically, periodic bc, "
        "straight cylinder/rod fibers, small grids)",
    )
    viscosity: number(gt=0, le=1e6) = Field(1.8e-5, description="Pa s in (0, 1e6] (default 1.8e-5)")
    density: number(gt=0, le=1e5) | None = Field(
        None,
        description="fluid density, kg/m^3 in (0, 1e5] (default 1.2, air; only the OpenFOAM "
        "export uses it: nu = viscosity / density)",
    )
    aux_length: number(ge=0, le=2) = Field(
        0.2, description="inlet/outlet zone length, fraction of the RVE length in [0, 2]"
    )
    direction: Literal["x", "y", "z"] | None = Field(
        None,
        description="x | y | z: the flow direction of `permeability` and `mesh` without "
        "--direction, and of a study without study.outputs (default z)",
    )
    sides: Literal["slip", "noslip"] = Field("slip", description="slip | noslip (default slip)")
    pressure_drop: number(gt=0, le=1e9) = Field(
        1.0,
        description="Pa in (0, 1e9] (default 1): between the permeameter's reservoir ends; "
        "periodic bc: over the RVE's length (G = drop / L)",
    )
    tol: number(gt=0, lt=1) | None = Field(None, description="relative tolerance in (0, 1)")
    edge_length: number(ge=0.005, le=10) | None = Field(
        None,
        description="pytetwild edge length, fraction of the box diagonal in [0.005, 10] "
        "(default 0.85 thinnest fiber widths: a rod's diameter, a woven or compressed fiber's "
        "thin width); at most 1 with pytetwild, its mesh within the "
        "memory budget",
    )
    max_memory_gb: number(gt=0, le=1e5) | None = Field(
        None,
        description="memory cap of the solve, GB in (0, 1e5]; either solver's estimated "
        'memory within it, checked before any work (the copies an "auto" stack plans: of '
        "explicit fibers or an image before it, of a generated RVE once built; the FEM's "
        "again on the built mesh)",
    )
    periodic_treatment: Literal["periodic", "mirror", "frame"] | None = Field(
        None,
        description="periodic | mirror | frame (voxel solver with bc periodic only, default "
        "periodic)",
    )
    mesher: Literal["stuffing", "pytetwild"] = Field(
        "stuffing", description="stuffing | pytetwild (default stuffing)"
    )
    lattice_step: number(gt=0) | None = Field(
        None,
        description=f"stuffing lattice step {LATTICE_STEP_RANGE} (default: max(2 voxels, "
        "min(thinnest fiber width / 3, smallest edge "
        "/ 30)), coarsened up to max(2 voxels, smallest edge / 30) to fit the memory budget)",
    )

    @model_validator(mode="after")
    def _mesher_fits_bc(self) -> FlowTable:
        """A periodic mesh (``bc = "periodic"``) is the stuffing mesher's only: pytetwild cannot
        give matching opposite faces (:func:`psdesign.meshing.options._check` refuses it too,
        but only after the RVE is built). The voxel solver meshes nothing: its table may keep
        a mesher for the FEM."""
        if self.solver == "fem" and self.bc == "periodic" and self.mesher == "pytetwild":
            raise fail(
                "mesher",
                "pytetwild cannot mesh with flow.bc = 'periodic' (no matching opposite faces)",
                "stuffing with flow.bc = 'periodic', or flow.bc = 'permeameter'",
                names=("flow.bc",),
            )
        return self

    @model_validator(mode="after")
    def _treatment_fits_bc(self) -> FlowTable:
        """``periodic_treatment`` mirror / frame with a route the spec itself names (``solver``
        or ``bc`` given) that would not apply it. Without either, the command line's
        ``--solver`` / ``--bc`` decide, checked by the route before the RVE is built."""
        if not {"solver", "bc"} & self.model_fields_set:
            return self
        why = treatment_refusal(self.periodic_treatment, self.solver, self.bc)
        if why:
            raise fail("periodic_treatment", why, TREATMENT_ALLOWED, TREATMENT_NAMES)
        return self

    def to_spec(self) -> dict:
        """Defaults plus the keys given."""
        out = dict(DEFAULT_FLOW)
        out.update({k: getattr(self, k) for k in self.model_fields_set})
        return out


def validated_flow(flow: dict) -> FlowTable:
    """``flow`` (a ``[flow]`` table, or some of its keys) validated as a spec file's table, else
    one :class:`~psdesign.errors.SpecError` line naming ``flow.<key>`` and its range: the one
    check of :func:`psdesign.flow.permeability.checked_flow` and of the keywords given to
    ``Model.permeability`` (each spelled it until session 49's review).

    >>> validated_flow({"solver": "voxel"}).solver
    'voxel'
    >>> validated_flow({"viscosty": 1e-5})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    psdesign.errors.SpecError: flow.viscosty: unknown key; did you mean 'viscosity'? ...
    """
    try:
        return FlowTable.model_validate(flow)
    except ValidationError as exc:  # a spec file's line: flow.<key>, its range
        raise spec_error(exc, FlowTable, prefix="flow") from None
