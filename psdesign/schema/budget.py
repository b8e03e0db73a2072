"""Up-front time and memory estimates: refuse a spec before any allocation or long run.

Every check raises a schema error naming the key and the estimate. Figures:

* geometry: 16 bytes per voxel (float32 distance, uint8 count, uint16 mark, bool solid and a
  float64 temporary; ``benchmarks/RESULTS.md``: 7 bytes per voxel of fields);
* voxel Stokes solver: :data:`solvers.voxel.memory.BYTES_PER_CELL` (sub-voxel walls, the
  larger figure, plus the box walls' couplings) per *solved* cell: a permeameter solves
  ``copies`` stacked copies of the RVE
  (``flow.permeameter_copies``; ``"auto"`` counts :data:`AUTO_PERMEAMETER_COPIES`, its first
  solve) plus two reservoirs of ``flow.aux_length`` times one copy, each rounded up to whole
  cells as the solver does (:func:`solved_cells`, through
  :func:`solvers.voxel.memory.solved_shape`; until session 44 counted continuously: 1.4
  cells for the 2 of a 7-cell sample at 0.2), or the periodic treatment's mirror or frame;
* the diffuse wall (``flow.wall_treatment = "diffuse"``, periodic only): the assembled solve's
  :func:`solvers.voxel.diffuse.diffuse_memory_bytes`;
* the stack's tiled fields, :data:`FIELD_BYTES_PER_VOXEL` per copy, held next to the RVE's;
* FEM solver: :func:`solvers.fem.memory.estimate_memory_gb` (the estimate the solve checks) of
  the stuffing mesh, whose size follows from the lattice (:func:`fem_mesh_size`; the default
  fiber-relative step is coarsened to fit, :func:`fem_lattice_step`); before it, the
  FEM's own field refined for thin fibers (:func:`fem_field_bytes`, at most about 1 GB);
* ``flow.max_memory_gb``, on every route before any work (:func:`check_cap`, over it by
  :data:`CAP_MARGIN`): the stuffing FEM's estimate (:func:`check_fem`), pytetwild's least mesh
  (:data:`TETWILD_CAP_SAFETY`, :func:`check_tetwild`), the voxel grid's (:func:`check_grid`),
  each with ``"auto"`` counted as the copies explicit fibers or an image plan along
  ``flow.direction`` (:mod:`psdesign.schema.plan`; the routes pin the direction they solve,
  :func:`psdesign.schema.spec.check_directions`), else as the one copy a non-periodic RVE
  stacks (:func:`least_stack_of`); there (a generated RVE) the stack ``"auto"``
  plans once the RVE is built is checked the same way before it is meshed or solved
  (:func:`check_planned_stack`); each refusal names the route's resolution key;
* the budget is half the machine's memory (``psutil.virtual_memory().total``), of which each
  of a run's concurrent local workers gets its share on the voxel and transport routes, up
  front and while its case runs, each process's fixed load counted once
  (:func:`memory_budget`, :func:`concurrent_workers`). A permeameter
  whose ``"auto"`` copies lengthen the sample after the first solve
  (:mod:`psdesign.flow.stack`) checks each longer stack against it before solving
  (:func:`restack_bytes`) and stops, warning with ``flow.permeameter_copies``, where it would not
  fit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar

from psdesign.schema.flow import (
    AUTO_PERMEAMETER_COPIES,
    NATIVE_BC,
    FlowTable,
    coarser_advice,
    resolution_key,
)
from psdesign.schema.types import fail
from solvers.voxel.memory import BYTES_PER_CELL, WALL_COUPLING_BYTES

GEOMETRY_BYTES_PER_VOXEL = 16
#: sub-voxel walls with the permeameter's box walls (their couplings stored), the larger figure
VOXEL_SOLVER_BYTES_PER_VOXEL = BYTES_PER_CELL["subvoxel"] + WALL_COUPLING_BYTES
MEMORY_FRACTION = 0.5
#: The most Taylor-Hood unknowns (:func:`solvers.fem.memory.unknowns`) the *default* FEM
#: lattice step may plan for (:func:`fem_lattice_step`), fixed so that the default mesh, and with
#: it K, is the same on every machine large enough: what the estimate before session 54 (3108 B
#: per unknown plus 0.45 GB) fitted in its 11 GiB, ``floor((11 GiB - 0.45 GB) / 3108 B)``, so
#: that its recalibration changed no default mesh (``tests/unit/test_lattice_step.py``).
DEFAULT_STEP_UNKNOWNS = 3_655_456
#: :data:`DEFAULT_STEP_UNKNOWNS` in bytes, ``solvers.fem.memory.estimate_bytes`` of it plus half
#: an unknown (the counts are whole, so the comparison cannot round either way), written out
#: because the estimate's module loads the solver. A machine of at least twice this (19.0 GB,
#: 17.7 GiB; 23.6 GB before session 54) gets the default mesh; a smaller one plans for half its
#: memory, and the result's note says so.
DEFAULT_STEP_BUDGET = 9517884902.0
#: The kept voxel fields (float32 distance, uint8 count): what the stacked permeameter tiles.
FIELD_BYTES_PER_VOXEL = 5
#: Peak bytes per voxel of a transport command (``pores``, ``diffusivity``,
#: ``conductivity``: the pore scan's distance transforms, the Laplace solve's fields and
#: multigrid) over the grid's own fields (:data:`GEOMETRY_BYTES_PER_VOXEL`), on top of
#: :data:`PROCESS_FIXED_BYTES`. Session 54 (mendscale, ``benchmarks/RESULTS.md``): peak RSS at
#: 64^3, 100^3 and 150^3 (Toray-like, 1 um) rises 91 (pores), 109 (diffusivity) and 118
#: (conductivity) B per voxel with ~0.31-0.33 GB at zero; the largest, 118, with a tenth to
#: spare, is 130 with the fields' 16 (estimate / peak 1.10-1.29 measured). Until session 54
#: 400 + 16 and no fixed term: 4-5x the peak, refusing grids that fit (session 52's 270-324 B
#: on 864 k voxels had the fixed process load divided into the slope).
TRANSPORT_BYTES_PER_VOXEL = 114
#: A psdesign process's memory before its grids: Python, numpy, scipy, numba's LLVM and the
#: compiled kernels (0.31-0.33 GB measured at zero voxels, session 54), rounded up.
PROCESS_FIXED_BYTES = 0.35e9
#: Stuffing mesh per lattice cell of pore (6 Kuhn tets a cell, plus the clipped pieces), rounded
#: up from 6.2 tets and 1.43 vertices per pore lattice vertex (50 um Toray-like cube, porosity
#: 0.80, 2 um step, periodic and permeameter meshes alike) and 6.40 tets, 1.36 vertices (random
#: straight 40 um RVE, porosity 0.85, 3 copies and reservoirs, 2 um; session 54 femmem). On one
#: smooth cylinder in a 40 um cell it counts 32-33 % more tets than the mesh has (5.89e4 /
#: 44 248, 2 um step; session 52 mendmesh): the fewest clipped cells, the one case over 10 %.
TETS_PER_PORE_CELL = 6.5
POINTS_PER_PORE_CELL = 1.5
#: ``flow.max_memory_gb`` is refused before the mesh when this estimate is over it by this
#: factor (the solve's own estimate from the built mesh refuses the rest): the estimate is
#: within 5 % of the solve's (20 um cube, 6 um rod, 2 um step: 0.372 GB against 0.38 GB).
CAP_MARGIN = 1.25
#: pytetwild's mesh estimate (:func:`tetwild_mesh_size`, rounded up for the budget) over the
#: mesh made, in tets: 1.03-1.06 on the Table III seeds (100 x 100 x 140 um); session 41
#: (benchmarks/RESULTS.md): 2.60 and 2.64 for one 6 um fibre in a 20 and 30 um box (2 copies,
#: default edge), 4.47 at edge_length 0.1, 1.42 and 1.16 for a 60 x 60 x 40 um generated
#: paper (default edge, 0.06); vertices 1.19-4.05. ``flow.max_memory_gb`` is refused before
#: meshing only when the estimate divided by this factor (the largest ratio, 4.47, with a third
#: to spare) is over the cap; the solve's estimate from the built mesh refuses the rest, naming
#: flow.edge_length.
TETWILD_CAP_SAFETY = 6.0
#: Periodic copies of one fiber in the box (a tiny period multiplies the work).
MAX_COPIES = 1000
MAX_EXPLICIT_FIBERS = 2000
#: Cells of the stuffing mesher's lattice (a tiny flow.lattice_step).
MAX_LATTICE_CELLS = 5e7
#: GA work: population x generations x fibers fitness terms.
MAX_GA_WORK = 5e9
#: Study size: cases, seeds, levels of one parameter.
MAX_CASES = 100_000
MAX_SEEDS = 1000
MAX_LEVELS = 10_000
#: Per-case time limit: ``study.timeout_s``, ``study run --timeout``, ``run_study(timeout_s=)``.
MAX_TIMEOUT_S = 1e7


#: False while a spec is validated for a study whose case function is not psdesign's pipeline
#: (:func:`unplanned_route`).
_ROUTE_PLANNED: ContextVar[bool] = ContextVar("psdesign_route_planned", default=True)
#: True while a transport command's spec is validated (``unplanned_route(transport=True)``).
_TRANSPORT_ROUTE: ContextVar[bool] = ContextVar("psdesign_transport_route", default=False)


def transport_route() -> bool:
    """True inside ``unplanned_route(transport=True)``: the spec is a transport command's,
    whose image the schema holds to :func:`check_transport`'s figure from its header, before
    its voxels are read (session 54 walk: a 700^3 image was read whole, 12.8 s and 0.8 GB,
    before the same refusal)."""
    return _TRANSPORT_ROUTE.get()


@contextmanager
def unplanned_route(transport: bool = False) -> Iterator[None]:
    """Validations inside plan no flow route: a study's own case function
    (``run_study(case_fn=...)``) decides what it builds and solves, so its specs are held to
    the schema's keys and to the memory of their voxel grid (:func:`check_grid` as geometry),
    not to a solve psdesign would run: the voxel or FEM solver's estimate, a permeameter's
    stacked copies, ``flow.max_memory_gb``, the stuffing lattice's cells. Before session 44 a
    study of a custom case function that builds no permeameter was refused at load for the
    2-copy FEM permeameter of its base spec ("a 1000x1000x1000 grid ... 2 copies stacked
    needs about 14.9 GiB"), or for ``flow.max_memory_gb``, and never ran. The commands that
    solve no flow (``generate``, ``pores``, ``diffusivity``, ``conductivity``, ``forcefield``)
    load their spec inside it too (session 52: they were refused for a 16.7 GiB FEM
    permeameter; ``permeability`` and ``study run`` still plan theirs up front), and since
    session 53 ``psdesign.build`` (geometry; ``Material.permeability`` checks its solve), a
    study's cases without a K output (:func:`psdesign.schema.study.validate_case_spec`) and
    ``mesh`` (then checked at the one copy it meshes). ``transport``: a transport command's
    spec (:func:`transport_route`)."""
    token = _ROUTE_PLANNED.set(False)
    kind = _TRANSPORT_ROUTE.set(transport)
    try:
        yield
    finally:
        _TRANSPORT_ROUTE.reset(kind)
        _ROUTE_PLANNED.reset(token)


def route_planned() -> bool:
    """False inside :func:`unplanned_route`."""
    return _ROUTE_PLANNED.get()


#: Processes of one run on this machine that hold their memory at once (a study's local pool,
#: ``rev --workers``): each case is held to its share of the budget (:func:`memory_budget`);
#: with the option's spelling (``--workers`` or ``workers``) for the refusal.
_CONCURRENT: ContextVar[tuple[int, str]] = ContextVar(
    "psdesign_concurrent_workers", default=(1, "workers")
)


@contextmanager
def concurrent_workers(n: int, option: str = "workers") -> Iterator[None]:
    """Validations inside are for one of ``n`` processes running at once on this machine
    (:func:`psdesign.study.runner.concurrent_cases`), named ``option`` in a refusal: each
    grid's budget is the machine's divided by ``n`` (session 54: a 2-worker study of two
    10.5 GiB cases was accepted against the 11.8 GiB budget of one process)."""
    token = _CONCURRENT.set((max(1, int(n)), option))
    try:
        yield
    finally:
        _CONCURRENT.reset(token)


def workers_at_once() -> tuple[int, str]:
    """``(n, option)`` of the innermost :func:`concurrent_workers` (``(1, "workers")``
    outside one): what a run sends each case so that it is held to its share while it runs."""
    return _CONCURRENT.get()


def memory_budget(counts_process: bool = False, n: int | None = None) -> float:
    """Bytes one case may use: :data:`MEMORY_FRACTION` of the machine shared by the ``n``
    processes that run at once (default: :func:`concurrent_workers`'; 1 outside a study run).

    One rule for every route: each process's fixed load (:data:`PROCESS_FIXED_BYTES`) is
    counted once. ``counts_process``: the route's estimate counts its own (transport,
    :func:`grid_bytes`), so the share is ``B / n``; else (the voxel route, whose one process
    was never charged it: the machine's other half holds it, small CI machines unchanged) the
    other ``n - 1`` processes' are taken off first, ``(B - (n - 1) F) / n``. Until session
    54's review the voxel share was ``B / n``: 8 workers on 4 GiB could reach B + 8 F.

    >>> with concurrent_workers(1):
    ...     memory_budget() == memory_budget(True) == MEMORY_FRACTION * machine_memory()
    True
    """
    if n is None:
        n = _CONCURRENT.get()[0]
    whole = MEMORY_FRACTION * machine_memory()
    if counts_process or n == 1:
        return whole / n
    return max(0.0, whole - (n - 1) * PROCESS_FIXED_BYTES) / n


def most_workers(need: float, counts_process: bool = False) -> int:
    """The most processes at once whose shares (:func:`memory_budget`) each hold ``need``
    bytes (0: not even one).

    >>> most_workers(0.25 * MEMORY_FRACTION * machine_memory(), True)
    4
    """
    if need <= 0:
        return MAX_CASES
    whole = MEMORY_FRACTION * machine_memory()
    if counts_process:
        return int(whole // need)
    # n need + (n - 1) F <= B, with one process allowed the whole budget
    return int((whole + PROCESS_FIXED_BYTES) // (need + PROCESS_FIXED_BYTES))


def workers_flag(n: int) -> str:
    """``--workers n`` or ``workers=n``, as the run's option is spelled."""
    option = _CONCURRENT.get()[1]
    return f"--workers {n}" if option.startswith("-") else f"{option}={n}"


def budget_words(counts_process: bool = False) -> str:
    """How a refusal names the budget (:func:`memory_budget`): ``"half the machine"``, or
    shared by the workers at once (the user's ``--workers`` value is not spelled: a 2-case
    study of ``--workers 4`` runs 2 at once, and the refusal said "--workers 2", session 54's
    review), less the other workers' fixed loads where the route does not count its own."""
    n = _CONCURRENT.get()[0]
    if n == 1:
        return "half the machine"
    less = "" if counts_process else f" less {PROCESS_FIXED_BYTES / 1e9:g} GB per other worker"
    return f"half the machine{less} shared by {n} workers at once"


def fewer_workers(need: float, counts_process: bool = False) -> str:
    """``", or --workers 1"``: the most workers whose shares each fit ``need`` bytes, when
    fewer than the run's would (``""`` outside a multi-worker run or when none would)."""
    n = _CONCURRENT.get()[0]
    most = most_workers(need, counts_process)
    if n == 1 or not 1 <= most < n:
        return ""
    return f", or {workers_flag(most)}"


def machine_memory() -> float:
    """Total memory of the machine in bytes (8 GiB when psutil cannot tell)."""
    try:
        import psutil

        return float(psutil.virtual_memory().total)
    except Exception:  # noqa: BLE001 - an estimate must never fail
        return 8.0 * 2**30


def grid_shape(size: tuple[float, ...], voxel: float) -> list[float]:
    """Voxels per axis as floats (no overflow for absurd sizes)."""
    out = []
    for s in size:
        v = s / voxel
        out.append(max(1.0, float(math.floor(v + 0.5)) if math.isfinite(v) else v))
    return out


def solved_bc(flow) -> str:
    """The bc a ``[flow]`` table solves with: ``flow.bc``, else its solver's own
    (:data:`psdesign.schema.flow.NATIVE_BC`; periodic without a solver)."""
    return flow.bc or NATIVE_BC.get(flow.solver, "periodic")


def stack_of(flow) -> tuple[int, float]:
    """``(copies, aux_length)`` of the solve a ``[flow]`` table asks for, at most: a permeameter
    (``flow.bc``, or the FEM's default) stacks ``flow.permeameter_copies`` copies (``"auto"``
    where the spec cannot tell its copies: :data:`AUTO_PERMEAMETER_COPIES`, what it takes on a
    periodic one-period RVE; a spec that can tell has the planned count here,
    :func:`psdesign.schema.plan.planned_flow`) between
    reservoirs of ``aux_length`` times one copy; a periodic solve is one copy, no reservoirs."""
    if flow is None:
        return 1, 0.0
    if solved_bc(flow) != "permeameter":
        return 1, 0.0
    copies = flow.permeameter_copies
    n = AUTO_PERMEAMETER_COPIES if copies in (None, "auto") else int(copies)
    return n, float(flow.aux_length)


def least_stack_of(flow) -> tuple[int, float]:
    """:func:`stack_of` with ``"auto"`` copies counted as one, the fewest a run stacks (it
    takes two only for a periodic one-period RVE, known once the RVE is built where the spec
    cannot tell; a spec that can has its planned count in place of ``"auto"``): what
    ``flow.max_memory_gb`` is checked against up front on every route, so that no spec a run
    would fit is refused; the stack ``"auto"`` plans is checked before it is stacked
    (:func:`check_planned_stack`)."""
    copies, aux = stack_of(flow)
    if flow is not None and flow.permeameter_copies in (None, "auto"):
        copies = 1
    return copies, aux


def fits_cap(cap_gb: float | None, need: float) -> bool:
    """Does an estimate of ``need`` bytes fit ``flow.max_memory_gb = cap_gb`` (None: no cap)?
    The one rule of every check made before the mesh or grid it estimates is built: at most
    :data:`CAP_MARGIN` times the cap (the estimates are upper bounds; the FEM solve's own check
    on the built mesh decides above the cap).

    >>> fits_cap(1.0, 1.2e9), fits_cap(1.0, 1.3e9), fits_cap(None, 1e30)
    (True, False, True)
    """
    return cap_gb is None or need <= CAP_MARGIN * float(cap_gb) * 1e9


def check_cap(
    flow, need: float, what: str, key: str, least: bool = False, verb: str = "needs"
) -> None:
    """Refuse ``need`` bytes (the route's estimate, ``what`` describes it) over
    ``flow.max_memory_gb`` times :data:`CAP_MARGIN`, naming the key, the estimate and the
    route's resolution ``key`` with its direction (:func:`~psdesign.schema.flow.coarser_advice`;
    ``key`` is in the error's ``names``, so a study spells it as its file does);
    ``least``: ``need`` is a lower bound (the built mesh's estimate decides above it);
    ``verb``: how ``what`` relates to the figure (the FEM's is a conservative estimate,
    :data:`solvers.fem.memory.ESTIMATE_VERB`)."""
    cap = getattr(flow, "max_memory_gb", None)
    if fits_cap(cap, need):
        return
    gb = f"{need / 1e9:.3g} GB"
    raise fail(
        "flow.max_memory_gb",
        f"{what} {verb} {'at least' if least else 'about'} {gb}, over the cap of {cap:.3g} GB",
        (f"over {gb} (the built mesh's estimate decides)" if least else f">= {gb}")
        + f", or {coarser_advice(key)}",
        names=(key,),
    )


def check_planned_stack(
    flow: dict,
    solver: str,
    copies: int,
    size,
    voxel: float,
    porosity: float | None,
    fiber_diameter: float | None,
    key: str = "rve.voxel",
) -> None:
    """Refuse the first stack an ``"auto"`` permeameter planned (``copies``,
    :func:`psdesign.flow.stack.plan_copies`) over ``flow.max_memory_gb``, with the up-front
    check of the route (:func:`_check_voxel_cap`, :func:`check_fem`, the same estimate and
    line) at those copies: up front ``"auto"`` counts one copy (:func:`least_stack_of`) where
    the spec cannot tell its copies (a generated RVE), so such a
    periodic one-period RVE's two copies are checked here, after the RVE is built and before
    the grid is stacked or meshed (explicit fibers and images along a direction were counted
    before any work, :mod:`psdesign.schema.plan`, and pass here again). ``flow``:
    the route's permeameter ``[flow]`` dict; ``key``: the voxel route's resolution key
    (``image.crop`` for an image).

    Raises
    ------
    SpecError
        ``flow.max_memory_gb``, as the spec's check words it.
    """
    from pydantic_core import PydanticCustomError

    from psdesign.schema.errors import fail_error

    if flow.get("max_memory_gb") is None or copies <= 1:
        return
    if flow.get("permeameter_copies") not in (None, "auto"):
        return  # counted as given up front
    fields = {k: v for k, v in flow.items() if k in FlowTable.model_fields and v is not None}
    pinned = {"solver": solver, "bc": "permeameter", "permeameter_copies": copies}
    table = FlowTable.model_construct(**{**fields, **pinned})
    size = tuple(float(s) for s in size)
    try:
        if solver == "voxel":
            _check_voxel_cap(grid_shape(size, voxel), table, key)
        else:
            check_fem(size, voxel, table, porosity, fiber_diameter)
    except PydanticCustomError as exc:
        raise fail_error(exc) from None


def solved_cells(
    shape: Sequence[float],
    copies: int = 1,
    aux: float | None = None,
    treatment: str = "periodic",
    axis: int | None = None,
) -> float:
    """Cells of the grid the voxel solver holds for an RVE grid of ``shape`` voxels:
    ``copies`` stacked along the flow, then the solver's own count of what it adds
    (:func:`solvers.voxel.memory.solved_shape`, one definition with the solve): a permeameter's
    two reservoirs of ``aux`` times one copy (``aux`` None: periodic), each rounded up to whole
    cells and at least one, or the periodic ``treatment``'s mirror or frame. Along ``axis``,
    else the fewest over the three axes (any may be solved: refuse only what none of them
    fits, as :func:`psdesign.schema.plan.planned_flow`). A shape too large to count cell by
    cell: ``copies + 2 aux`` per voxel.

    >>> solved_cells([7, 7, 7], 1, 0.2, axis=2)  # reservoirs of 2 cells each, not 1.4
    539.0
    >>> solved_cells([10, 10, 10], 2, 0.2), solved_cells([4, 4, 4], treatment="mirror")
    (2400.0, 128.0)
    """
    from solvers.voxel.memory import solved_shape

    dims = [float(n) for n in shape]
    if not all(math.isfinite(n) and n < 1e12 for n in dims):
        return math.prod(dims) * (copies + 2.0 * (aux or 0.0))
    bc = "periodic" if aux is None else "permeameter"
    counts = []
    for a in range(3) if axis is None else (axis,):
        stack = tuple(int(n) * (copies if b == a else 1) for b, n in enumerate(dims))
        # the solver's reservoir: aux of one copy = aux / copies of the stack (flow.voxel)
        solved = solved_shape(stack, a, bc, treatment, (aux or 0.0) / copies)
        counts.append(float(math.prod(solved)))
    return min(counts)


def solve_of(flow, aux: float) -> dict:
    """The :func:`solved_cells` keywords of a ``[flow]`` table (None: periodic): the
    permeameter's ``aux`` (``aux_length`` from :func:`stack_of`), the periodic treatment,
    and the axis of ``flow.direction`` where the route pinned it
    (:func:`psdesign.schema.plan.solved_axis`)."""
    from psdesign.schema.plan import solved_axis

    if flow is None:
        return {}
    return {
        "aux": aux if solved_bc(flow) == "permeameter" else None,
        "treatment": getattr(flow, "periodic_treatment", None) or "periodic",
        "axis": solved_axis(flow),
    }


def grid_bytes(
    shape: Sequence[float], solver: str, copies: int = 1, solve: dict | None = None
) -> float:
    """Estimated peak bytes of the voxel fields (and the voxel solver's grid) of an RVE grid
    of ``shape`` voxels, ``copies`` stacked; ``solve``: :func:`solved_cells`' keywords
    (:func:`solve_of`; None: periodic)."""
    n = math.prod(float(s) for s in shape)
    geometry = n * max(GEOMETRY_BYTES_PER_VOXEL, FIELD_BYTES_PER_VOXEL * (1 + copies))
    if solver == "transport":  # a command's own process: its fixed load counted
        return PROCESS_FIXED_BYTES + geometry + TRANSPORT_BYTES_PER_VOXEL * n
    if solver != "voxel":
        return geometry
    return geometry + VOXEL_SOLVER_BYTES_PER_VOXEL * solved_cells(shape, copies, **(solve or {}))


def restack_bytes(result: dict, copies: int, shape: Sequence[float], aux: float) -> float:
    """Estimated peak bytes of solving a permeameter ``result`` again with ``copies`` copies
    (``"auto"`` lengthening the sample, :func:`psdesign.flow.stack.next_auto_copies`). Voxel
    route: :func:`grid_bytes` of the RVE's grid ``shape`` with ``aux`` (``flow.aux_length``)
    reservoirs along the result's ``direction``; FEM:
    :func:`solvers.fem.memory.estimate_memory_gb` of the result's mesh scaled by
    ``copies / permeameter_copies`` (the reservoirs keep their size: an upper bound).

    >>> z = {"aux": 0.2, "axis": 2}
    >>> restack_bytes({"solver": "voxel", "direction": "z"}, 3, [10] * 3, 0.2) == grid_bytes(
    ...     [10] * 3, "voxel", 3, z)
    True
    """
    if result.get("solver") == "voxel":
        axis = "xyz".index(result["direction"]) if result.get("direction") else None
        return grid_bytes(shape, "voxel", copies, {"aux": aux, "axis": axis})
    from solvers.fem.memory import estimate_memory_gb

    scale = copies / max(1, int(result.get("permeameter_copies") or 1))
    pts = max(4, int(scale * float(result["n_points"])))
    tets = max(1, int(scale * float(result["n_tets"])))
    return estimate_memory_gb(pts, tets) * 1e9


def check_grid(
    size: tuple[float, ...],
    voxel: float,
    solver: str,
    key: str = "rve.voxel",
    flow=None,
    counts: str = "",
) -> None:
    """Refuse a voxel grid whose estimated memory (the permeameter's stack included,
    :func:`stack_of`) exceeds the budget (:func:`memory_budget`: one worker's share in a
    multi-worker run); ``flow.permeameter_copies`` is named when one copy
    would fit. Inside :func:`unplanned_route` the grid alone (``solver = "geometry"``).
    ``counts``: what the grid is, for the refusal, when it is no solve's
    (``"for the GA's overlap grid"`` with ``solver = "geometry"``); ``""``: the solve's
    words, :func:`_counted`."""
    if not route_planned() and solver != "transport":
        solver, flow = "geometry", None
    shape = grid_shape(size, voxel)
    n = math.prod(shape)
    copies, aux = stack_of(flow)

    def need_of(grid: list[float], stacked: int = copies) -> float:
        if solver == "voxel" and getattr(flow, "wall_treatment", None) == "diffuse":
            from solvers.voxel.diffuse import diffuse_memory_bytes

            return grid_bytes(grid, "geometry") + diffuse_memory_bytes(grid)
        return grid_bytes(grid, solver, stacked, solve_of(flow, aux))

    transport = solver == "transport"  # its estimate counts its process's fixed load
    need = need_of(shape)
    budget = memory_budget(transport)
    if need <= budget:
        if solver == "voxel":
            _check_voxel_cap(shape, flow, key)
        return
    dims = "x".join(f"{s:.0f}" if s < 1e9 else f"{s:.2g}" for s in shape)
    single = need_of(shape, 1)
    counted = counts or _counted(solver, flow, aux)
    words = f"the budget is {budget / 2**30:.3g} GiB ({budget_words(transport)})"
    if copies > 1 and single <= budget:
        raise fail(
            "flow.permeameter_copies",
            f"{copies} copies of the {dims} grid stacked in the permeameter ({counted}) "
            f"need about {need / 2**30:.3g} GiB, one copy {single / 2**30:.3g} GiB; {words}",
            f"1, or flow.bc = 'periodic', or {coarser_advice(key)}{fewer_workers(need, transport)}",
            names=(key, "flow.bc"),
        )
    fixed = PROCESS_FIXED_BYTES if transport else 0.0  # the process's, once
    per = (need - fixed) / n
    allowed = _grid_advice(size, voxel, need_of, key, per, transport)
    raise fail(
        key,
        f"a {dims} grid ({n:.3g} voxels, {per:.4g} B each {counted}"
        f"{f', {copies} copies stacked' if copies > 1 else ''}"
        f"{f', and {fixed / 1e9:.3g} GB for the process' if fixed else ''}) needs about "
        f"{need / 2**30:.3g} GiB; {words}",
        allowed if allowed.startswith("at most") else allowed + fewer_workers(need, transport),
    )


def _grid_advice(
    size: tuple[float, ...], voxel: float, need_of: Callable, key: str, per: float, transport: bool
) -> str:
    """:func:`check_grid`'s allowed values: the least voxel (an image's largest crop) within a
    worker's share; where not even one voxel fits it (a transport process's fixed load over
    the share), the most workers at once that leave room, with the voxel or crop at their
    share (it said "a crop of at most 0 voxels" / "no grid fits", session 54's review)."""
    budget, prefix = memory_budget(transport), ""
    one_voxel = need_of([1.0] * len(size))
    if one_voxel > budget:
        most = most_workers(one_voxel, transport)
        if most < 1:
            return "more memory: no grid fits"
        budget = memory_budget(transport, most)
        plural = "s" if most > 1 else ""
        prefix = f"at most {most} worker{plural} at once ({workers_flag(most)}), with "
    if key == "image.crop":  # an image's voxel is fixed: the crop is what the user can change
        fixed = PROCESS_FIXED_BYTES if transport else 0.0
        most_voxels = round_down(max(0.0, budget - fixed) / per)  # per: the grid's B a voxel
        cube = int(most_voxels ** (1 / 3))
        return f"{prefix}a crop of at most {most_voxels:.3g} voxels (about {cube}^3)"
    return f"{prefix}voxel >= {least_voxel(size, voxel, need_of, budget):.3g} m"


def round_up(x: float, digits: int = 3) -> float:
    """``x`` rounded up to ``digits`` significant digits: a lower bound printed with
    ``:.3g`` stays one (``1.0853e-6`` printed as 1.09e-06, not 1.08e-06, session 54).

    >>> round_up(1.0853e-6), round_up(1.5e-6), round_up(0.0)
    (1.09e-06, 1.5e-06, 0.0)
    """
    return _round_toward(x, digits, 1.0)


def round_down(x: float, digits: int = 3) -> float:
    """``x`` rounded down to ``digits`` significant digits: an upper bound printed with
    ``:.3g`` stays one (``period <= 0.0334 m`` for 100 x 3.337e-4 m was refused when fed
    back, session 54's review).

    >>> round_down(0.03337), round_down(1.5e-6), round_down(0.0)
    (0.0333, 1.5e-06, 0.0)
    """
    return _round_toward(x, digits, -1.0)


def _round_toward(x: float, digits: int, sign: float) -> float:
    """``x`` to ``digits`` significant digits, one step of the last digit further in the
    direction ``sign`` (+1 up, -1 down) where the nearest rounding went the other way."""
    if not (math.isfinite(x) and x > 0):
        return x
    near = float(f"{x:.{digits}g}")
    if (near - x) * sign < 0:
        step = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
        near = float(f"{near + sign * step:.{digits}g}")
    return near


def least_voxel(
    size: tuple[float, ...], voxel: float, need_of: Callable[[list[float]], float], budget: float
) -> float:
    """The smallest voxel (to 3 significant digits, rounded up) whose grid (:func:`grid_shape`,
    which rounds the voxel count to the nearest) ``need_of`` fits ``budget`` bytes: the
    "allowed" bound of a refusal, accepted when fed back. The cube root of need over budget
    alone fell short by the grid's rounding (session 54: "voxel >= 1.09e-06 m", then a
    459^3 grid at 1.09e-6 needed 11.9 GiB of 11.8 and was refused again). ``inf`` when not
    even one voxel fits (a transport process's fixed load over a worker's share)."""
    if need_of([1.0] * len(size)) > budget:  # the process's fixed load alone is over it
        return math.inf
    v = voxel * max(1.0, need_of(grid_shape(size, voxel)) / budget) ** (1 / 3)
    for _ in range(100_000):  # 0.1 % steps from the continuous estimate: a few dozen
        v = round_up(v)
        if need_of(grid_shape(size, v)) <= budget:
            return v
        v *= 1.001
    return v


def check_transport(spec: dict) -> None:
    """Refuse a validated ``spec`` whose transport solve (``pores``, ``diffusivity``,
    ``conductivity``: :data:`TRANSPORT_BYTES_PER_VOXEL`) exceeds the memory budget, one line
    naming ``rve.voxel`` (``image.crop`` for an image). One check for the commands
    (:func:`psdesign.transport.load.load_case`) and the Python API's methods (review G,
    session 52: the API was held to the grid's own 16 B per voxel).

    Raises
    ------
    SpecError
        The grid's transport solve does not fit.
    """
    from pydantic_core import PydanticCustomError

    from psdesign.schema.errors import fail_error

    key = "image.crop" if spec.get("image") else "rve.voxel"
    try:
        check_transport_grid(tuple(spec["rve"]["size"]), spec["rve"]["voxel"], key)
    except PydanticCustomError as exc:  # the schema's own line, raised outside it
        raise fail_error(exc) from None


def check_transport_grid(size: tuple[float, ...], voxel: float, key: str) -> None:
    """Refuse a grid of ``size`` (m) at ``voxel`` (m) whose transport solve does not fit the
    memory budget, naming ``key``: the one rule :func:`check_transport` applies to a validated
    spec and the schema to an image's header (a transport command's image, before its voxels
    are read). Raises the schema's ``PydanticCustomError`` (:func:`check_grid`)."""
    check_grid(size, voxel, "transport", key)


def _counted(solver: str, flow, aux: float) -> str:
    """What :func:`check_grid`'s estimate of a solve counted, for its refusal: the solver, and
    for the voxel solver's grid (reservoirs, mirror or frame) the direction it was counted
    along (:func:`counted_axis`); inside :func:`unplanned_route` the grid's own fields (it
    said "with solver 'geometry'", no solver a user can set, until session 44). A grid that
    is no solve's says what it is itself (:func:`check_grid`'s ``counts``: the GA's overlap
    grid, which said "with solver 'fem'" whatever the solver until session 44).

    >>> _counted("fem", None, 0.2)
    "with solver 'fem'"
    """
    if solver == "transport":
        return "for a transport command's scan or Laplace solve; no flow solve is counted"
    if solver == "geometry":  # inside unplanned_route: no solver a user could set
        return (
            "for the voxel grid's own fields; no flow solve is counted (a command that runs "
            "none, or a custom case function's)"
        )
    if solver == "voxel" and getattr(flow, "wall_treatment", None) != "diffuse":
        return f"with solver 'voxel', counted along {counted_axis(solve_of(flow, aux).get('axis'))}"
    return f"with solver {solver!r}"


def _check_voxel_cap(shape: list[float], flow, key: str) -> None:
    """``flow.max_memory_gb`` on the voxel route: the grid's estimate (:func:`grid_bytes`, the
    fewest stacked copies, :func:`least_stack_of`; the diffuse wall's assembled solve) over the
    cap refuses the spec before the grid is built (the solver itself takes no cap)."""
    if getattr(flow, "max_memory_gb", None) is None:
        return
    dims = "x".join(f"{s:.0f}" if s < 1e9 else f"{s:.2g}" for s in shape)
    stacked = ""  # the diffuse wall's count does not depend on the direction
    if getattr(flow, "wall_treatment", None) == "diffuse":
        from solvers.voxel.diffuse import diffuse_memory_bytes

        need = grid_bytes(shape, "geometry") + diffuse_memory_bytes(shape)
    else:
        copies, aux = least_stack_of(flow)
        solve = solve_of(flow, aux)
        need = grid_bytes(shape, "voxel", copies, solve)
        along = f"counted along {counted_axis(solve['axis'])}"
        stacked = f" ({copies} copies stacked, {along})" if copies > 1 else f" ({along})"
    check_cap(flow, need, f"the voxel solve of the {dims} grid{stacked}", key)


def counted_axis(axis: int | None) -> str:
    """The direction whose solved grid a voxel estimate counted (:func:`solved_cells`' axis),
    for its refusal: a permeameter's reservoirs and a treatment's mirror or frame make the
    count depend on it, so the same cap refuses z and accepts x (session 44).

    >>> counted_axis(2), counted_axis(None)
    ('z', 'the least of x, y, z')
    """
    return "the least of x, y, z" if axis is None else "xyz"[axis]


def fem_mesh_size(
    size: tuple[float, ...], step: float, copies: int, aux: float, porosity: float
) -> tuple[float, float]:
    """``(n_points, n_tets)`` of the stuffing mesh: lattice cells of pore in ``copies`` copies
    (``porosity``) plus the all-fluid reservoir slabs (axial step ``slab_factor`` times
    ``step``, :data:`psdesign.meshing.options.DEFAULT_SLAB_FACTOR`)."""
    from psdesign.meshing.options import DEFAULT_SLAB_FACTOR

    cells = math.prod(max(1.0, s / step) for s in size)
    pore = cells * (copies * porosity + 2.0 * aux / DEFAULT_SLAB_FACTOR)
    return POINTS_PER_PORE_CELL * pore, TETS_PER_PORE_CELL * pore


def fem_need_bytes(
    size: tuple[float, ...], step: float, copies: int, aux: float, porosity: float
) -> float:
    """Estimated peak bytes of the FEM solve of the stuffing mesh at lattice ``step``
    (:func:`solvers.fem.memory.estimate_memory_gb` of :func:`fem_mesh_size`)."""
    from solvers.fem.memory import estimate_memory_gb

    pts, tets = fem_mesh_size(size, step, copies, aux, porosity)
    return estimate_memory_gb(max(4, int(pts)), max(1, int(tets))) * 1e9


def fem_lattice_step(
    size: tuple[float, ...],
    voxel: float,
    fiber_diameter: float | None,
    copies: int = 1,
    aux: float = 0.0,
    porosity: float | None = None,
    budget: float | None = None,
) -> tuple[float, str | None]:
    """The FEM's default lattice step within the memory budget, and a note when it was coarsened.

    The step is :func:`psdesign.meshing.options.default_lattice_step` (fiber-relative). When the
    FEM solve of its mesh (:func:`fem_need_bytes`: ``copies`` copies of porosity ``porosity``,
    None = all pore, reservoirs of ``aux``) would exceed the budget (:data:`MEMORY_FRACTION` of
    the machine) while the box-relative step (the same rule without a fiber diameter) fits, the
    finest step between the two that fits is taken instead (never coarser than the box-relative
    one, to 1e-3; the error bar's two-grid term grows with it), and the note says so. When
    neither fits, the box-relative step is returned (:func:`check_fem` then refuses the spec, as
    before). ``budget``: the machine's budget in bytes (default half its memory); the step is
    planned for the smaller of it and :data:`DEFAULT_STEP_BUDGET`, so the default step does not
    depend on the machine above that size.

    Returns
    -------
    (float, str or None)
        Step in metres; the note (None when the fiber-relative step was kept).
    """
    from psdesign.meshing.options import default_lattice_step

    fine = default_lattice_step(voxel, size, fiber_diameter)
    coarse = default_lattice_step(voxel, size)
    if fine >= coarse:
        return fine, None
    phi = 1.0 if porosity is None else float(porosity)
    if budget is None:
        budget = MEMORY_FRACTION * machine_memory()
    budget = min(budget, DEFAULT_STEP_BUDGET)
    fine_need = fem_need_bytes(size, fine, copies, aux, phi)
    if fine_need <= budget:
        return fine, None
    if fem_need_bytes(size, coarse, copies, aux, phi) > budget:
        return coarse, None
    lo, hi = fine, coarse  # need(lo) > budget >= need(hi); need falls with the step
    while hi - lo > 1e-3 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fem_need_bytes(size, mid, copies, aux, phi) > budget else (lo, mid)
    per_d = f"{fiber_diameter / fine:.3g} -> {fiber_diameter / hi:.3g} cells per fiber diameter"
    note = (
        f"the default lattice step {fine:.3g} m would need about {fine_need / 2**30:.3g} GiB in "
        f"the FEM ({copies} cop{'y' if copies == 1 else 'ies'}); the budget is "
        f"{budget / 2**30:.3g} GiB (at most {DEFAULT_STEP_BUDGET / 2**30:.3g} GiB, at most half "
        f"the machine), so the step is {hi:.3g} m ({per_d}; the "
        "error bar grows with it); set flow.lattice_step to choose"
    )
    return hi, note


def check_fem(
    size: tuple[float, ...],
    voxel: float,
    flow,
    porosity: float | None,
    fiber_diameter: float | None = None,
) -> None:
    """Refuse an FEM solve whose estimated memory (:func:`fem_need_bytes`, the stack included)
    exceeds the budget; ``porosity`` None counts every lattice cell as pore. Without
    ``flow.lattice_step`` the step is :func:`fem_lattice_step`'s (``fiber_diameter``: the
    thinnest, in metres, or None), coarsened to fit where the box-relative step fits. With
    ``flow.mesher = "pytetwild"`` the mesh is :func:`tetwild_mesh_size` instead. Nothing
    inside :func:`unplanned_route`."""
    from solvers.fem.memory import ESTIMATE_VERB

    if not route_planned():
        return
    if getattr(flow, "mesher", "stuffing") == "pytetwild":
        check_tetwild(size, flow, fiber_diameter)
        return

    copies, aux = stack_of(flow)
    phi = 1.0 if porosity is None else float(porosity)
    budget = MEMORY_FRACTION * machine_memory()
    step = flow.lattice_step
    if step is None:
        step, _ = fem_lattice_step(size, voxel, fiber_diameter, copies, aux, phi, budget)
    check_fem_field(size, voxel, budget)

    total = fem_need_bytes(size, step, copies, aux, phi)
    if total <= budget:
        # the solve's own check came after meshing: work, then 'pass force=True'. The cap
        # counts the fewest copies a run stacks (an "auto" stack of two is checked once it is
        # planned, check_planned_stack): the step is the one of that stack
        least, _ = least_stack_of(flow)
        if least != copies and flow.lattice_step is None:
            step, _ = fem_lattice_step(size, voxel, fiber_diameter, least, aux, phi, budget)
        _, tets = fem_mesh_size(size, step, least, aux, phi)
        what = f"the FEM solve of about {tets:.3g} tets (lattice step {step:.3g} m)"
        need = fem_need_bytes(size, step, least, aux, phi)
        check_cap(flow, need, what, resolution_key("fem", "stuffing"), verb=ESTIMATE_VERB)
        return
    pts, tets = fem_mesh_size(size, step, copies, aux, phi)
    what = (
        f"the FEM solve of about {tets:.3g} tets ({copies} copies, lattice step {step:.3g} m) "
        f"{ESTIMATE_VERB} about {total / 2**30:.3g} GiB; the budget is "
        f"{budget / 2**30:.3g} GiB (half the machine)"
    )
    if copies > 1 and fem_need_bytes(size, step, 1, aux, phi) <= budget:
        raise fail("flow.permeameter_copies", what, "1, or flow.bc = 'periodic'", ("flow.bc",))
    raise fail("flow.lattice_step", what, "a coarser step, or a smaller rve.size", ("rve.size",))


def tetwild_mesh_size(
    size: tuple[float, ...], flow, fiber_diameter: float | None, least: bool = False
) -> tuple[float, float, float]:
    """``(n_points, n_tets, edge)`` of the pytetwild mesh of a spec
    (:func:`psdesign.meshing.options.tetwild_mesh_size` of the box with the stack and its
    reservoirs, :func:`~psdesign.meshing.options.target_edge_length`, the shortest edge over
    the possible flow axes when ``flow.direction`` is not given); ``least``: the fewest stacked
    copies (:func:`least_stack_of`)."""
    from psdesign.meshing.options import MeshOptions, envelope_from_diameter, target_edge_length
    from psdesign.meshing.options import tetwild_mesh_size as estimate

    copies, aux = least_stack_of(flow) if least else stack_of(flow)
    if flow.edge_length is not None and flow.edge_length > 1.0:  # the mesher refuses it too
        raise fail(
            "flow.edge_length",
            f"{flow.edge_length:g} of the box diagonal is longer than the box",
            "(0, 1] with flow.mesher = 'pytetwild'",
            names=("flow.mesher",),
        )
    opts = MeshOptions(
        mesher="pytetwild",
        aux_length=aux,
        edge_length_fac=flow.edge_length,
        fiber_diameter=fiber_diameter,
    )
    axes = ["xyz".index(flow.direction)] if flow.direction else range(3)
    edge = min(target_edge_length(size, a, opts) for a in axes)
    fine = envelope_from_diameter(opts) is not None
    pts, tets = estimate(math.prod(size) * (copies + 2.0 * aux), edge, fiber_diameter, fine)
    return pts, tets, edge


def check_tetwild(size: tuple[float, ...], flow, fiber_diameter: float | None) -> None:
    """Refuse a pytetwild FEM solve whose estimated memory (:func:`tetwild_mesh_size`,
    :func:`solvers.fem.memory.estimate_memory_gb`) exceeds the budget, before any meshing."""
    from solvers.fem.memory import estimate_memory_gb

    pts, tets, edge = tetwild_mesh_size(size, flow, fiber_diameter)
    total = estimate_memory_gb(max(4, int(pts)), max(1, int(tets))) * 1e9
    budget = MEMORY_FRACTION * machine_memory()
    if total <= budget:
        # the cap: the least mesh this spec can give (the estimate over its safety factor, one
        # copy for "auto"); the longer edge is what shrinks it on this route
        pts, tets, edge = tetwild_mesh_size(size, flow, fiber_diameter, least=True)
        pts, tets = pts / TETWILD_CAP_SAFETY, tets / TETWILD_CAP_SAFETY
        least = estimate_memory_gb(max(4, int(pts)), max(1, int(tets))) * 1e9
        what = f"the FEM solve of at least {tets:.3g} tets (pytetwild, edge {edge:.3g} m)"
        check_cap(flow, least, what, resolution_key("fem", "pytetwild"), least=True)
        return
    raise fail(
        "flow.edge_length",
        f"the pytetwild mesh of about {tets:.3g} tets (edge {edge:.3g} m) needs about "
        f"{total / 2**30:.3g} GiB in the FEM; the budget is {budget / 2**30:.3g} GiB (half the "
        "machine)",
        f"an edge about {(total / budget) ** (1 / 3):.2g} x longer, flow.mesher = 'stuffing', or "
        "a smaller rve.size",
        names=("flow.mesher", "rve.size"),
    )


def check_cells(key: str, size: tuple[float, ...], step: float, limit: float) -> None:
    """Refuse a lattice step giving more than ``limit`` cells in the box."""
    n = math.prod(grid_shape(size, step))
    if not n <= limit:
        least = step * (n / limit) ** (1 / 3) if math.isfinite(n) else math.inf
        while math.isfinite(least) and math.prod(grid_shape(size, round_up(least))) > limit:
            least *= 1.001  # grid_shape rounds the cells to the nearest (session 54)
        raise fail(
            key,
            f"{step:g} m gives {n:.3g} cells",
            f"at most {limit:.0e} cells, step >= {round_up(least):.3g} m",
        )


def check_copies(size: tuple[float, ...], period: float) -> None:
    """Refuse a period so small that every fiber has too many periodic copies."""
    copies = math.prod(s / period + 1.0 for s in size)
    if not copies <= MAX_COPIES:
        # rounded up: printed at :.3g, 1.11e-4 m for a 1 mm cube gave 1000.1 copies (session 54)
        lo = round_up(max(size) / (MAX_COPIES ** (1 / 3) - 1.0))
        while math.prod(s / lo + 1.0 for s in size) > MAX_COPIES:
            lo = round_up(lo * 1.001)
        raise fail(
            "rve.period",
            f"gives about {copies:.3g} periodic copies of every fiber in the box",
            f"period >= {lo:.3g} m (at most {MAX_COPIES} copies)",
        )
    if period > 100.0 * max(size):
        raise fail(
            "rve.period",
            f"{period:g} m is over 100 x the largest edge",
            f"period <= {round_down(100 * max(size)):.3g} m",
        )


def check_ga(population: int, generations: int, n_fibers: float) -> None:
    """Refuse a GA whose fitness work (population x generations x fibers) is unbounded."""
    work = population * generations * max(n_fibers, 1.0)
    if work > MAX_GA_WORK:
        raise fail(
            "intersections.generations",
            f"population {population} x generations {generations} x about {n_fibers:.0f} "
            f"fibers = {work:.3g} fitness terms",
            f"population x generations x fibers <= {MAX_GA_WORK:.0e}",
        )


def fem_field_bytes(size: tuple[float, ...], voxel: float) -> float:
    """Peak bytes of the FEM's own field while it is meshed (:mod:`psdesign.flow.fem_field`):
    a grid refined for thin fibers holds at most ``FIELD_MAX_VOXELS`` voxels, the stack
    included; a grid that cannot be refined within that is meshed as it is (0 here: the spec's
    grid is counted by :func:`check_grid`)."""
    from psdesign.flow.fem_field import FIELD_BYTES_PER_VOXEL, FIELD_MAX_VOXELS

    n = math.prod(grid_shape(size, voxel))
    return FIELD_MAX_VOXELS * FIELD_BYTES_PER_VOXEL if 8 * n <= FIELD_MAX_VOXELS else 0.0


def check_fem_field(size: tuple[float, ...], voxel: float, budget: float) -> None:
    """Refuse an FEM whose own refined field (:func:`fem_field_bytes`) exceeds ``budget``."""
    need = fem_field_bytes(size, voxel)
    if need > budget:
        raise fail(
            "rve.voxel",
            f"the FEM's refined field needs about {need / 2**30:.3g} GiB while meshing; the "
            f"budget is {budget / 2**30:.3g} GiB (half the machine)",
            "a voxel with 8 or more voxels across the thinnest fiber, or more memory",
        )
