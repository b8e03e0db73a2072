"""Schema of a study file: ``base``, ``[study]`` and the value forms of ``[parameters]``."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Literal

from pydantic import Field, model_validator

from psdesign.schema.budget import MAX_CASES, MAX_LEVELS, MAX_SEEDS, MAX_TIMEOUT_S
from psdesign.schema.flow import SOLVERS
from psdesign.schema.types import Table, fail, flag, integer, number
from psdesign.transport.study_outputs import TRANSPORT_OUTPUTS

DESIGNS = ("full-factorial", "latin-hypercube", "sobol", "csv")

OUTPUTS = ("porosity", "k_x", "k_y", "k_z", "k_tensor") + TRANSPORT_OUTPUTS
#: Added to a case's outputs by ``[study] fields = true``: the case writes its flow fields.
FIELDS_FLAG = "fields"
Output = Literal[OUTPUTS]  # type: ignore[valid-type]
#: The K outputs of one direction each.
K_OUTPUTS = {"k_x": "x", "k_y": "y", "k_z": "z"}


def k_directions(outputs: Iterable[str]) -> list[str]:
    """The flow directions a case with these outputs solves (``k_tensor``: all three).

    >>> k_directions(["porosity", "k_z", "k_x"]), k_directions(["k_tensor"])
    (['x', 'z'], ['x', 'y', 'z'])
    """
    if "k_tensor" in outputs:
        return ["x", "y", "z"]
    return [d for o, d in K_OUTPUTS.items() if o in outputs]


def validate_case_spec(spec: dict, outputs: Iterable[str]) -> dict:
    """Validate a study case's ``spec``, held to the memory of the work its ``outputs`` do:
    the flow solve's (the route's budget, ``flow.max_memory_gb``, the planned stack) only when
    they include a K (:func:`k_directions`), else the voxel grid's own
    (:func:`psdesign.schema.budget.unplanned_route`, as ``generate``); transport outputs add
    their solve's (:func:`psdesign.schema.budget.check_transport`, as ``pores``) where the route
    is planned (psdesign's own case function). The one rule of the study file's check, the
    runner's and the case's: until session 53 a study of porosity or transport outputs alone
    was refused for an FEM solve no case runs.

    Raises
    ------
    SpecError
        The first check that fails, naming its key.
    """
    from contextlib import nullcontext

    from psdesign.schema import budget
    from psdesign.schema.spec import validate_spec

    outputs = list(outputs)
    planned = budget.route_planned()
    transport = planned and any(o in TRANSPORT_OUTPUTS for o in outputs)
    # an image's transport solve checked from its header, before its voxels (session 54)
    with nullcontext() if k_directions(outputs) else budget.unplanned_route(transport):
        valid = validate_spec(spec)
    if transport:
        budget.check_transport(valid)
    return valid


class StudyTable(Table):
    """The ``[study]`` table."""

    name: str | None = Field(None, description="non-empty string (default: the file name)")
    description: str = Field("", description="string")
    design: Literal["full-factorial", "latin-hypercube", "sobol", "csv"] = Field(
        "full-factorial", description="full-factorial | latin-hypercube | sobol | csv"
    )
    csv: str | None = Field(None, description="path of the CSV design (design = 'csv' only)")
    n_samples: integer(ge=1, le=MAX_CASES) | None = Field(
        None, description=f"integer in [1, {MAX_CASES}] (latin-hypercube / sobol only)"
    )
    seeds: list[integer(ge=0, le=2**63 - 1)] | None = Field(
        None, description=f"distinct integers >= 0, 1 to {MAX_SEEDS} of them"
    )
    replicates: integer(ge=1, le=MAX_SEEDS) | None = Field(
        None, description=f"integer in [1, {MAX_SEEDS}] (seeds generator.seed + 0, 1, ...)"
    )
    outputs: Output | list[Output] = Field(
        ["porosity", "k_z"],
        description=" | ".join(OUTPUTS) + " (a list; default porosity and K along the base's "
        "flow.direction, else k_z)",
    )
    solver: Literal[SOLVERS] | None = Field(  # type: ignore[valid-type]
        None, description="fem | voxel (default: base flow.solver, else fem)"
    )
    timeout_s: number(gt=0, le=MAX_TIMEOUT_S) | None = Field(
        None, description="seconds in (0, 1e7]"
    )
    fields: flag = Field(
        False,
        description="true | false (default false): each case writes its velocity and pressure "
        "fields (cases/<id>/fields/: VTU or VTI, PNG slice) and the report shows a case's "
        "field picture",
    )
    design_seed: integer(ge=0, le=2**63 - 1) = Field(0, description="integer >= 0 (default 0)")

    @model_validator(mode="after")
    def _check(self) -> StudyTable:
        if self.name is not None and not self.name.strip():
            raise fail("name", "must be a non-empty string", "non-empty string")
        if self.seeds is not None:
            if self.replicates is not None:
                raise fail("seeds", "give either seeds = [...] or replicates = N, not both")
            if not self.seeds or len(self.seeds) > MAX_SEEDS:
                raise fail("seeds", f"{len(self.seeds)} seeds", f"1 to {MAX_SEEDS} integers")
            if len(set(self.seeds)) != len(self.seeds):
                raise fail("seeds", f"seeds must be distinct, got {self.seeds!r}", "distinct")
        if self.design in ("latin-hypercube", "sobol") and self.n_samples is None:
            raise fail("n_samples", f"required for design {self.design!r}", "integer >= 1")
        if self.design not in ("latin-hypercube", "sobol") and self.n_samples is not None:
            raise fail(
                "n_samples",
                f"only used by latin-hypercube / sobol designs, not {self.design!r}",
                "remove it or change study.design",
            )
        if self.design == "csv" and self.csv is None:
            raise fail("csv", "required for design 'csv' (path to a CSV file)", "a path string")
        if self.design != "csv" and self.csv is not None:
            raise fail("csv", f"only allowed with design = 'csv' (design is {self.design!r})")
        outs = [self.outputs] if isinstance(self.outputs, str) else self.outputs
        if not outs:
            raise fail("outputs", "must be a non-empty list", ", ".join(OUTPUTS))
        return self


class RangeParam(Table):
    """``{start, stop, step}``: levels start, start + step, ... up to and including stop."""

    start: number() = Field(description="finite number")
    stop: number() = Field(description="finite number")
    step: number() = Field(description="non-zero, pointing from start to stop")


class BoundsParam(Table):
    """``{low, high[, dist, levels, type]}``: a continuous interval."""

    low: number() = Field(description="finite number < high")
    high: number() = Field(description="finite number > low")
    dist: Literal["uniform", "loguniform"] = Field("uniform", description="uniform | loguniform")
    levels: integer(ge=1, le=MAX_LEVELS) | None = Field(
        None, description=f"integer in [1, {MAX_LEVELS}] (full factorial)"
    )
    type: Literal["float", "int"] = Field("float", description="float | int")

    @model_validator(mode="after")
    def _check(self) -> BoundsParam:
        if not self.low < self.high:
            raise fail(
                "", f"low must be < high, got low={self.low}, high={self.high}", "low < high"
            )
        if self.dist == "loguniform" and self.low <= 0:
            raise fail("low", f"loguniform needs low > 0, got {self.low}", "> 0")
        return self
