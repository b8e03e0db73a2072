"""The whole RVE spec: tables plus the cross-field checks that need several of them."""

from __future__ import annotations

import math
import warnings
from typing import Any

from pydantic import Field, PrivateAttr, model_validator

from psdesign.geometry.fibers import ROUND_SHAPES
from psdesign.packing.ga_settings import GASettings
from psdesign.schema import budget
from psdesign.schema.distributions import support, support_text
from psdesign.schema.fibers import FiberTable
from psdesign.schema.flow import FlowTable
from psdesign.schema.forcefield import ForceFieldTable
from psdesign.schema.generator import GeneratorTable, IntersectionsTable
from psdesign.schema.image import ImageTable
from psdesign.schema.rve import MIN_VOXELS_PER_EDGE, RveTable
from psdesign.schema.transport import TransportSpec
from psdesign.schema.types import Table, fail

#: Densest packing of equal infinite cylinders (Bezdek & Kuperberg 1990): pi / sqrt(12).
MAX_CYLINDER_PACKING = math.pi / math.sqrt(12.0)
#: Zero-overlap ("fast") placement of straight fibers tilted <= 5 deg jams at porosity
#: 0.69-0.72 in a 100 um cube (studies/porosity_sweep.toml); below it expect a jam.
FAST_JAM_POROSITY = 0.72


def _stacked_porosity(flow: FlowTable, seen: dict) -> float | None:
    """The geometry's porosity (``seen``, where the plan read it) when ``flow`` has a planned
    stack of two or more copies, else None (the unplanned checks count as before)."""
    copies = flow.permeameter_copies
    return seen.get("porosity") if isinstance(copies, int) and copies >= 2 else None


def _diameter_limit(fb: FiberTable, size, period: float) -> float:
    """The bound a round fiber's diameter must stay below: the period and the box edges across
    the fiber. A straight fiber (rod, cylinder) whose axis runs along a box axis never meets
    the faces normal to it, so that edge does not count (a cylinder along z of diameter 16 um
    in a 32 x 32 x 16 um box was refused "not below the cell", session 53); any other fiber
    (tilted or bent) is held to every edge as before. The axis is the placed one
    (:func:`psdesign.geometry.fibers.placement_rotation`), so ``direction`` and theta/omega
    (both 0 by default: along x) are one rule; until the session 53 review only ``direction``
    was read, and ``theta = omega = 0`` was held to every edge.

    >>> from types import SimpleNamespace as F
    >>> _diameter_limit(F(shape="cylinder", direction=(0, 0, 2)), (4.0, 5.0, 1.0), 6.0)
    4.0
    >>> _diameter_limit(F(shape="cylinder", direction=(0, 1, 1)), (4.0, 5.0, 1.0), 6.0)
    1.0
    >>> _diameter_limit(F(shape="rod", theta=None, omega=None, direction=None), (1.0, 5, 4), 6)
    4
    """
    from psdesign.geometry.fibers import placement_rotation

    limit = min(min(size), period)
    if fb.shape not in ("rod", "cylinder"):
        return limit
    theta, omega = getattr(fb, "theta", None), getattr(fb, "omega", None)
    axis = placement_rotation(theta, omega, fb.direction) @ (0.0, 0.0, 1.0)  # the placed axis
    along = [k for k in range(3) if abs(axis[k]) > 1.0 - 1e-9]  # on a grid axis
    if not along:
        return limit
    return min(period, *(size[k] for k in range(3) if k != along[0]))


class SpecWarning(UserWarning):
    """A spec that is valid but likely to fail or to be slow (printed as one line)."""


#: Top-level tables of a study file, none of which a spec has: the one list the study reader
#: (psdesign.study.studyfile) allows and the spec readers name a mix-up by.
STUDY_TABLES = ("base", "study", "parameters")


class SpecDocument(Table):
    """An RVE spec: ``[rve]``, ``[[fibers]]``, ``[generator]``, ``[intersections]``, ``[flow]``
    (or ``[image]`` instead of the fiber tables)."""

    entry = "table"

    rve: RveTable | None = Field(None, description="table (required unless [image])")
    fibers: list[FiberTable] = Field(default_factory=list, description="array of tables")
    generator: GeneratorTable | None = Field(None, description="table")
    intersections: IntersectionsTable | None = Field(None, description="table")
    flow: FlowTable = Field(default_factory=FlowTable, description="table")
    forcefield: ForceFieldTable | None = Field(None, description="table (force-field specs)")
    transport: TransportSpec | None = Field(None, description="table (docs/transport.md)")
    image: ImageTable | None = Field(
        None, description="table (docs/images.md): a segmented voxel image as the RVE"
    )
    #: The explicit fibers as built once for this document (:meth:`_built_fibers`).
    _built: Any = PrivateAttr(default=None)

    @model_validator(mode="before")
    @classmethod
    def _one_fiber_table(cls, data: Any) -> Any:
        if isinstance(data, dict) and isinstance(data.get("fibers"), dict):
            data = {**data, "fibers": [data["fibers"]]}
        if isinstance(data, dict) and "rve" not in data and "image" not in data:
            if set(STUDY_TABLES) & set(data):  # a study file given where a spec goes
                raise fail(
                    "rve",
                    "no [rve] table: this is a study file ([study] / [parameters] / [base.*] "
                    "tables), not an RVE spec; run it with `psdesign study run FILE -o OUT`",
                    "[rve] size = [x, y, z]",
                )
            if "forcefield" in data:  # a paper case of Sec. 6 builds its own cell
                raise fail(
                    "rve",
                    "no [rve] table: this is a force-field case spec ([forcefield] case = ...), "
                    "not an RVE spec; run it with `psdesign forcefield FILE -o OUT`",
                    "[rve] size = [x, y, z]",
                )
            raise fail(
                "rve",
                "missing [rve] table with size = [x, y, z] in metres",
                "[rve] size = [x, y, z]",
            )
        ff = data.get("forcefield") if isinstance(data, dict) else None
        if isinstance(ff, dict) and "relax" in ff:
            # a relax spec given where a spec goes: "unknown key (allowed: case, ...)" until
            # session 42's review, the keys of a paper case, not the command that takes it
            raise fail(
                "forcefield.relax",
                "this RVE spec is one to relax: run `psdesign forcefield FILE -o OUT`, then give "
                "OUT/relaxed.toml here",
                "no [forcefield.relax] table in a spec given here",
            )
        return data

    # ------------------------------------------------------------------ derived values
    @property
    def voxel(self) -> float:
        if self.image is not None:
            return self.image.voxel
        return self.rve.voxel if self.rve.voxel is not None else min(self.rve.size) / 100

    @property
    def period(self) -> float:
        if self.image is not None:
            return max(self.image.size)
        return self.rve.period if self.rve.period is not None else max(self.rve.size)

    @property
    def size(self) -> tuple[float, float, float]:
        """Box edges in metres (``[rve]`` or the image's extent)."""
        return self.image.size if self.image is not None else tuple(self.rve.size)

    @model_validator(mode="after")
    def _cross(self) -> SpecDocument:
        if self.image is not None:
            self._check_image()
            return self
        size, voxel, period = self.rve.size, self.voxel, self.period
        if voxel > min(size) / MIN_VOXELS_PER_EDGE:
            raise fail(
                "rve.voxel",
                f"{voxel:g} m is over a quarter of the smallest edge",
                f"<= {budget.round_down(min(size) / MIN_VOXELS_PER_EDGE, 6):g} m",
            )
        budget.check_copies(size, period)
        flow, planned_porosity = self._planned_flow(size, voxel)
        budget.check_grid(size, voxel, flow.solver, flow=flow)
        # the stuffing lattice's own range: pytetwild does not read the key (its refusal named
        # a key the route ignores; psdesign mesh --mesher stuffing validates again)
        lattice = self.flow.lattice_step if self.flow.mesher == "stuffing" else None
        if lattice is not None and lattice > min(size) / 2:
            raise fail(
                "flow.lattice_step",
                f"{lattice:g} m is over half the smallest edge",
                f"<= {budget.round_down(min(size) / 2, 6):g} m",
            )
        if lattice is not None and budget.route_planned():
            budget.check_cells("flow.lattice_step", size, lattice, budget.MAX_LATTICE_CELLS)
        if self.flow.solver == "fem":
            self._fem_memory(size, voxel, flow, planned_porosity)
        self._check_fibers(size, voxel, period)
        if not self.fibers and self.generator is None:
            raise fail(
                "fibers",
                "no fibers: give [[fibers]] tables or a [generator] table",
                "[[fibers]] or [generator]",
            )
        if self.generator is not None:
            self._check_generator(size, voxel, period)
        elif self.intersections is not None:  # only the generator's fibers are moved
            raise fail(
                "intersections",
                "only used with a [generator]: explicit [[fibers]] are placed as given",
                "a [generator] table, or no [intersections]",
            )
        if self.flow.wall_treatment == "diffuse" and self.flow.solver == "voxel":
            self._check_diffuse()
        return self

    def _fem_memory(self, size, voxel: float, flow: FlowTable, porosity: float | None) -> None:
        """The FEM's memory check of a fiber spec at ``flow``; ``porosity`` None: the
        generator's target, else every lattice cell counted as pore."""
        if porosity is None and self.generator is not None:
            porosity = self.generator.porosity
        budget.check_fem(size, voxel, flow, porosity, self._thinnest_diameter())

    def _fiber_memory(self, size, voxel: float, flow: FlowTable, porosity=None) -> None:
        """The memory checks of a fiber spec at ``flow`` (the voxel grid's, the FEM's)."""
        budget.check_grid(size, voxel, flow.solver, flow=flow)
        if flow.solver == "fem":
            self._fem_memory(size, voxel, flow, porosity)

    def _planned_flow(self, size, voxel: float) -> tuple[FlowTable, float | None]:
        """``[flow]`` as the memory checks count it (:func:`psdesign.schema.plan.planned_flow`),
        and the porosity the FEM's check counts with it (None: as without a plan).

        Explicit fibers alone plan their copies from their analytic field
        (:func:`psdesign.flow.stack.spec_auto_copies`); a generated RVE keeps ``"auto"``. Where
        the plan stacks two copies the FEM counts them at
        :func:`psdesign.geometry.porosity.sampled_porosity_bound`, not at porosity 1: the check
        of the built RVE counts them at its porosity (``check_planned_stack``), and porosity 1
        refused up front a 0.59-porous stack it ran (2.04 GB counted against a 1.45 GB cap,
        the solve 1.3 GB; session 43, review2)."""
        from psdesign.schema.plan import planned_flow

        if self.generator is not None or not self.fibers:
            return self.flow, None
        seen: dict = {}

        def plan(axis: int) -> int:
            import numpy as np

            from psdesign.flow.stack import spec_auto_copies
            from psdesign.geometry.porosity import sampled_porosity_bound
            from psdesign.geometry.rve import RVE

            fibers = self._built_fibers()
            if isinstance(fibers, Exception):  # the build's own line names the fiber
                raise fibers
            rve = RVE(size=np.asarray(size), fibers=fibers, period=self.rve.period)
            if self.flow.solver == "fem":
                seen["porosity"] = sampled_porosity_bound(rve)
            return spec_auto_copies(rve, [axis], voxel)

        flow = planned_flow(self.flow, lambda f: self._fiber_memory(size, voxel, f), plan)
        return flow, _stacked_porosity(flow, seen)

    def _image_memory(self, img, flow: FlowTable, porosity: float | None = None) -> None:
        """The memory checks of an image spec at ``flow`` (the crop names the grid;
        ``porosity`` None: the FEM counts every lattice cell as pore). A transport command's
        image: its solve's figure (:func:`psdesign.schema.budget.check_transport_grid`)
        from the header, before the voxels are read."""
        if not budget.route_planned() and budget.transport_route():
            budget.check_transport_grid(img.size, img.voxel, "image.crop")
            return
        budget.check_grid(img.size, img.voxel, flow.solver, key="image.crop", flow=flow)
        if flow.solver == "fem":
            budget.check_fem(img.size, img.voxel, flow, porosity)

    def _planned_image_flow(self, img) -> tuple[FlowTable, float | None]:
        """``[flow]`` as an image's memory checks count it: the copies its solid mask plans
        (the voxel seam test the built image gets, :func:`psdesign.flow.stack.
        spec_auto_copies`), read only where one copy fits and two do not
        (:func:`psdesign.schema.plan.planned_flow`); and the mask's porosity, which the FEM
        counts a planned stack at (the built image's, as ``check_planned_stack`` does)."""
        from psdesign.schema.plan import planned_flow

        seen: dict = {}

        def plan(axis: int) -> int | None:
            from psdesign.flow.stack import SolidMask, spec_auto_copies
            from psdesign.image.load import load_mask, source_of

            try:
                mask = load_mask(source_of(img.to_spec()))
            except ValueError:  # refused with its own line below
                return None
            seen["porosity"] = 1.0 - float(mask.sum()) / mask.size
            return spec_auto_copies(None, [axis], SolidMask(mask))

        flow = planned_flow(self.flow, lambda f: self._image_memory(img, f), plan)
        return flow, _stacked_porosity(flow, seen)

    def _check_diffuse(self) -> None:
        """``flow.wall_treatment = "diffuse"`` (a voxel-solver wall; the FEM ignores it, as it
        does ``subvoxel``): the periodic bc, straight cylinder or rod fibers only
        (:mod:`psdesign.flow.diffuse`)."""
        from psdesign.geometry.walls import SHAPES

        allowed = "subvoxel | staircase"
        flow = self.flow
        if flow.bc not in (None, "periodic"):
            raise fail(
                "flow.wall_treatment",
                f"'diffuse' needs flow.bc = 'periodic', not {flow.bc!r}",
                allowed,
                names=("flow.bc",),
            )
        if flow.periodic_treatment not in (None, "periodic"):
            raise fail(
                "flow.wall_treatment",
                "'diffuse' needs flow.periodic_treatment = 'periodic', not "
                f"{flow.periodic_treatment!r}",
                allowed,
                names=("flow.periodic_treatment",),
            )
        if self.forcefield is not None:
            raise fail("flow.wall_treatment", "'diffuse' with [forcefield] (bent fibers)", allowed)
        if self.generator is not None:
            # generated fibres lie at any angle: their copies do not repeat with the box, which
            # the solver wraps (psdesign.geometry.walls.untiled_axis)
            raise fail(
                "flow.wall_treatment",
                "'diffuse' with a [generator] (fibers at any angle do not repeat with the box)",
                allowed,
            )
        for i, fb in enumerate(self.fibers):
            if fb.shape not in SHAPES or (fb.u or 0.0) != 0.0:
                raise fail(
                    f"fibers[{i}].shape",
                    f"{fb.shape!r}: flow.wall_treatment = 'diffuse' needs straight fibers of a "
                    "closed-form wall distance",
                    " | ".join(SHAPES),
                    names=("flow.wall_treatment",),
                )
        self._check_diffuse_tiling()

    def _check_diffuse_tiling(self) -> None:
        """The explicit fibres' walls in the box the solver wraps are known in closed form
        (:func:`psdesign.flow.diffuse.untileable`, the rule the route applies to the built
        RVE)."""
        import numpy as np

        from psdesign.flow.diffuse import UNTILEABLE, untileable
        from psdesign.geometry.fibers import make_fiber

        size = np.asarray(self.rve.size, float)
        period = self.rve.period or float(size.max())
        fibers = [
            make_fiber(fb.shape, 0.1, theta=fb.theta, omega=fb.omega, direction=fb.direction)
            for fb in self.fibers
        ]
        i = untileable(fibers, size / period)
        if i is not None:
            raise fail(
                f"fibers[{i}].direction",
                f"fiber {i} {UNTILEABLE} (flow.wall_treatment = 'diffuse')",
                "a box axis",
                names=("flow.wall_treatment",),
            )

    def _check_image(self) -> None:
        """An ``[image]`` spec: no fiber tables, ``[rve]`` consistent, memory, the voxels."""
        from psdesign.image.load import load_mask, source_of

        for name in ("generator", "intersections", "forcefield"):
            if getattr(self, name) is not None:
                raise fail(
                    name, "not allowed with [image] (the image is the geometry)", "remove it"
                )
        if self.fibers:
            raise fail(
                "fibers", "not allowed with [image] (the image is the geometry)", "remove it"
            )
        img = self.image
        if self.rve is not None:
            for k, (a, b) in enumerate(zip(self.rve.size, img.size, strict=True)):
                if abs(a - b) > 1e-6 * b:
                    raise fail(
                        f"rve.size[{k}]",
                        f"{a:g} m is not the image's extent",
                        f"{b:g} m or leave [rve] out",
                    )
            if self.rve.voxel is not None and abs(self.rve.voxel - img.voxel) > 1e-6 * img.voxel:
                raise fail(
                    "rve.voxel",
                    f"{self.rve.voxel:g} m is not the image's voxel size",
                    f"{img.voxel:g} m",
                )
        if self.flow.wall_treatment in ("subvoxel", "diffuse"):
            raise fail(
                "flow.wall_treatment",
                f"{self.flow.wall_treatment!r} needs an analytic surface; an [image] has none",
                "staircase",
            )
        self._image_memory(img, *self._planned_image_flow(img))
        try:
            solid = load_mask(source_of(img.to_spec()))
        except ValueError as exc:
            key, _, msg = str(exc).partition(": ")
            raise fail(key, msg) from None
        n_solid = int(solid.sum())
        which = "threshold" if img.threshold is not None else "solid_label"
        if n_solid == solid.size:
            raise fail(
                f"image.{which}",
                "every voxel is solid: no pore voxels",
                "a label or threshold leaving pore",
            )
        if n_solid == 0:
            raise fail(
                f"image.{which}", "no voxel is solid", "a label or threshold that marks the solid"
            )

    def _thinnest_diameter(self) -> float | None:
        """Thinnest fiber width in metres, the measure the run's default lattice step and
        pytetwild edge follow (:func:`psdesign.geometry.rve.thinnest_fiber_diameter`): explicit
        rods' diameters, fixed shapes' (woven, compressed) thin widths as the build makes them
        (a few ms each, cached), the generator's lower bound; None without any. Before session
        43 the fixed shapes were left out, so a woven cell tiled 3 x 3 (300 um box, 100 um
        period) was budgeted at the box step 10 um instead of the run's 4.66 um."""
        diam = [
            float(fb.diameter)
            for fb in self.fibers
            if fb.diameter is not None and fb.shape in ROUND_SHAPES
        ]
        fixed = self._fixed_shape_width()
        if fixed is not None:
            diam.append(fixed)
        if self.generator is not None:
            diam.append(float(support(self.generator.diameter)[0]))
        return min(diam) if diam else None

    def _built_fibers(self) -> list | Exception:
        """The explicit ``[[fibers]]`` built as the run builds them
        (:func:`psdesign.schema.spec.explicit_fibers`), or the ``SpecError`` naming the one
        that does not build: built once per document, for the ``"auto"`` copies plan and the
        FEM budget's thin width alike. Before session 43 each built them, and the budget on
        every memory check: 2-4 builds of a woven cell per validation."""
        from psdesign.errors import SpecError
        from psdesign.schema.spec import explicit_fibers

        if self._built is None:
            rve = {"size": list(self.rve.size), "period": self.rve.period}
            try:
                tables = [fb.to_spec() for fb in self.fibers]
                self._built = explicit_fibers({"rve": rve, "fibers": tables})
            except SpecError as exc:
                self._built = exc
        return self._built

    def _fixed_shape_width(self) -> float | None:
        """The thinnest thin width (metres) of the explicit fixed-shape fibers, built as the run
        builds them (:meth:`_built_fibers`); None without any, or when the fibers do not build
        (the build names the key then)."""
        from types import SimpleNamespace

        from psdesign.geometry.rve import thinnest_fiber_diameter

        if all(fb.shape in ROUND_SHAPES for fb in self.fibers):
            return None
        built = self._built_fibers()
        if isinstance(built, Exception):
            return None
        fixed = [fb for fb in built if fb.shape not in ROUND_SHAPES]
        return thinnest_fiber_diameter(SimpleNamespace(fibers=fixed, period=self.period))

    def _check_fibers(self, size, voxel: float, period: float) -> None:
        if len(self.fibers) > budget.MAX_EXPLICIT_FIBERS:
            raise fail(
                "fibers",
                f"{len(self.fibers)} explicit fibers",
                f"at most {budget.MAX_EXPLICIT_FIBERS} (use [generator])",
            )
        for i, fb in enumerate(self.fibers):
            limit = _diameter_limit(fb, size, period)
            for k, c in enumerate(fb.center or ()):
                if not -size[k] <= c <= 2 * size[k]:
                    raise fail(
                        f"fibers[{i}].center[{k}]",
                        f"{c:g} m is far outside the box",
                        f"[{-size[k]:g}, {2 * size[k]:g}] m",
                    )
            if fb.diameter is None or fb.shape not in ROUND_SHAPES:
                continue
            if fb.diameter >= limit:
                raise fail(
                    f"fibers[{i}].diameter",
                    f"{fb.diameter:g} m is not below the cell",
                    f"< {limit:g} m",
                )
            if voxel > fb.diameter / 2:
                raise fail(
                    "rve.voxel",
                    f"{voxel:g} m gives under 2 voxels across fibers[{i}] "
                    f"(diameter {fb.diameter:g} m)",
                    f"<= {budget.round_down(fb.diameter / 2, 6):g} m",
                )

    def _check_generator(self, size, voxel: float, period: float) -> None:
        g = self.generator
        inter = self.intersections or IntersectionsTable()
        # dlo > 0 holds here: GeneratorTable._check_range refuses a diameter whose support starts
        # at or below 0 (NaN is no number), the table is frozen and nothing builds one
        # unvalidated (no model_construct / model_copy of it); only the half-period bound,
        # which needs the rve, is this check's own
        dlo, dhi = support(g.diameter)
        if not dhi < 0.5 * period:
            raise fail(
                "generator.diameter",
                support_text(g.diameter, "m"),
                f"(0, {0.5 * period:g}) m (half the period)",
            )
        if voxel > dlo / 2:
            raise fail(
                "rve.voxel",
                f"{voxel:g} m gives under 2 voxels across the thinnest generated fiber ({dlo:g} m)",
                f"<= {budget.round_down(dlo / 2, 6):g} m",
            )
        if not -0.5 * dlo <= inter.min_gap < 0.5 * period:
            raise fail(
                "intersections.min_gap",
                f"got {inter.min_gap:g}",
                f"[{-0.5 * dlo:g}, {0.5 * period:g}) m",
            )
        # solid fraction of the thinnest fiber crossing the box along its shortest edge
        one = math.pi * dlo * dlo / 4 * min(size) / math.prod(size)
        packs = inter.method != "none"
        if g.porosity is not None:
            self._check_porosity(g.porosity, g.porosity_tolerance, one, inter.method)
            n_est = (1 - g.porosity) / max(one, 1e-300)
        else:
            n_est = float(g.n_fibers)
            if packs and g.n_fibers * one > MAX_CYLINDER_PACKING:
                raise fail(
                    "generator.n_fibers",
                    f"{g.n_fibers} fibers of diameter >= {dlo:g} m "
                    f"fill {g.n_fibers * one:.3g} of the box, over the densest packing "
                    "pi/sqrt(12) without overlap",
                    f"<= {math.floor(MAX_CYLINDER_PACKING / one)}",
                )
        if n_est > g.max_fibers:
            raise fail(
                "generator.porosity",
                f"needs about {n_est:.0f} fibers, over generator.max_fibers = {g.max_fibers}",
                "a porosity reachable with generator.max_fibers fibers",
                names=("generator.max_fibers",),
            )
        if inter.step is not None and inter.step < min(size) / 1e4:
            # rounded up: :g printed 3.33333e-08 for 3.3333337e-08, refused when fed back (s54)
            least = budget.round_up(min(size) / 1e4)
            raise fail("intersections.step", f"{inter.step:g} m", f">= {least:.3g} m")
        if inter.ga_voxel is not None:
            budget.check_grid(
                size,
                inter.ga_voxel,
                "geometry",  # the overlap grid's own fields: no solve runs on it
                key="intersections.ga_voxel",
                counts="for the GA's overlap grid",
            )
        if inter.method == "ga":
            ga = GASettings()  # the GA's defaults, set there only
            pop = ga.population if inter.population is None else inter.population
            gens = ga.generations if inter.generations is None else inter.generations
            budget.check_ga(pop, gens, n_est)

    @staticmethod
    def _check_porosity(porosity: float, tol: float, one: float, method: str) -> None:
        top = min(1.0 - one, 1.0 - tol)
        if porosity > top:
            raise fail(
                "generator.porosity",
                f"{porosity} is above the porosity of one fiber or "
                "within the tolerance of an empty box (the RVE would be empty)",
                f"<= {_floor4(top):.4f}",
            )
        if method != "none" and porosity <= 1.0 - MAX_CYLINDER_PACKING:
            raise fail(
                "generator.porosity",
                f"must be > {1 - MAX_CYLINDER_PACKING:.4f} for "
                f"non-overlapping fibers (densest cylinder packing pi/sqrt(12)), got "
                f"{porosity}",
                f"> {1 - MAX_CYLINDER_PACKING:.4f}",
            )
        if method == "fast" and porosity < FAST_JAM_POROSITY:
            warnings.warn(
                f"generator.porosity: {porosity} is below {FAST_JAM_POROSITY}, where zero-overlap "
                "placement of near-planar straight fibers jams (docs/spec-keys.md); expect "
                "'packing jammed' or use method = 'none'",
                SpecWarning,
                stacklevel=2,
            )


def _floor4(x: float) -> float:
    """``x`` rounded down to 4 decimals: an upper bound printed with ``:.4f`` stays one."""
    down = math.floor(x * 1e4) / 1e4
    return down - 1e-4 if down > x else down
