"""The Python API for scripts and notebooks: build a material from a spec, ask for its properties.

>>> import psdesign
>>> spec = {"rve": {"size": [20e-6, 20e-6, 20e-6], "voxel": 1e-6},
...         "fibers": [{"shape": "cylinder", "diameter": 8e-6, "direction": [0, 0, 1]}]}
>>> m = psdesign.build(spec)
>>> round(m.porosity, 2)
0.87

Results are dataclasses with a readable ``repr`` (and ``_repr_html_`` for notebooks); the full
result dict of the route stays in ``details``.
"""

from __future__ import annotations

import ast
import functools
import numbers
import sys
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from psdesign.study.options import RunOptions

__all__ = ["Material", "PermeabilityResult", "build", "from_image", "load_spec", "run_study"]


def load_spec(path: str | Path) -> dict:
    """Read and validate an RVE spec file (TOML); raises ``SpecError`` naming the key.

    A spec dict is validated by :func:`build` (or ``psdesign.validate_spec``), not here."""
    from psdesign.errors import SpecError
    from psdesign.schema.spec import load_spec as _load

    if not isinstance(path, str | Path):
        raise SpecError(
            "spec",
            f"load_spec takes a file name (str or Path), got {type(path).__name__}; "
            "give a dict to psdesign.build or psdesign.validate_spec",
        )
    return _load(path)


@dataclass(frozen=True)
class PermeabilityResult:
    """Permeability along one axis, with its trust indicators.

    Attributes
    ----------
    direction : str
    permeability_m2 : float
        K in m^2 (superficial velocity, Darcy's law).
    converged : bool
    status : str
        ``"ok"``, ``"not_converged"`` or ``"untrustworthy"`` (see ``details["warnings"]``).
    rel_error : float or None
        Estimated relative error of K (``permeability_rel_error``), when the route gives one.
    solver, bc : str
    porosity : float
    porosity_error : float or None
        Estimated absolute error of the voxel-count porosity
        (:attr:`psdesign.geometry.rve.VoxelFields.porosity_error`).
    details : dict
        Everything the route returned (iterations, residual, flux imbalance, timings, ...).
    """

    direction: str
    permeability_m2: float
    converged: bool
    status: str
    rel_error: float | None
    solver: str
    bc: str
    porosity: float
    porosity_error: float | None = None
    details: dict = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_dict(cls, d: dict) -> PermeabilityResult:
        """The result of a route's record (:func:`psdesign.flow.permeability.permeability`'s
        dict, or :meth:`to_dict`'s); ``SpecError`` naming ``d`` when it is not one (a
        ``KeyError`` or ``AttributeError`` until session 47)."""
        from psdesign.errors import SpecError

        if not isinstance(d, dict) or not {"direction", "permeability_m2"} <= d.keys():
            shown = sorted(d) if isinstance(d, dict) else type(d).__name__
            raise SpecError(
                "d",
                "must be a dict with 'direction' and 'permeability_m2' (a permeability "
                f"route's record, as to_dict writes), got {shown}",
            )
        converged = bool(d.get("converged", False))
        status = d.get("status") or ("ok" if converged else "not_converged")
        rel = d.get("permeability_rel_error")
        return cls(
            direction=str(d["direction"]),
            permeability_m2=float(d["permeability_m2"]),
            converged=converged,
            status=str(status),
            rel_error=None if rel is None else float(rel),
            solver=str(d.get("solver", "")),
            bc=str(d.get("bc", "")),
            porosity=float(d.get("porosity", float("nan"))),
            porosity_error=None if d.get("porosity_error") is None else float(d["porosity_error"]),
            details=dict(d),
        )

    def to_dict(self) -> dict:
        """Plain dict (JSON-ready): the route's full record with this result's fields, the
        inverse of :meth:`from_dict` (as the transport results' ``to_dict``)."""
        return {
            **self.details,
            "direction": self.direction,
            "permeability_m2": self.permeability_m2,
            "converged": self.converged,
            "status": self.status,
            "permeability_rel_error": self.rel_error,
            "solver": self.solver,
            "bc": self.bc,
            "porosity": self.porosity,
            "porosity_error": self.porosity_error,
        }

    def _repr_html_(self) -> str:
        import html

        from psdesign.notebook import plus_minus, porosity_html, result_html

        # from_dict takes any strings: escaped (session 52 I/O review, finding 5)
        rows = [
            ("direction", html.escape(self.direction)),
            ("K (m<sup>2</sup>)", f"{self.permeability_m2:.4e}"),
            ("error estimate", plus_minus(self.rel_error)),
            ("converged", str(self.converged)),
            ("solver / bc", html.escape(f"{self.solver} / {self.bc}")),
            ("porosity (-)", porosity_html(self.porosity, self.porosity_error)),
        ]
        notes = self.details.get("warnings") or []
        return result_html("PermeabilityResult", rows, self.status, list(notes))


def _direction(direction: Any) -> str:
    """``'x' | 'y' | 'z'`` (or the axis index 0-2), else ``SpecError`` naming ``direction``."""
    from psdesign.flow.darcy import checked_axis

    return checked_axis(direction, "direction")[0]


def _progress_flag(progress: Any) -> bool:
    """``progress``: True or False, also NumPy's (``progress="no"`` printed the progress)."""
    from psdesign.errors import SpecError, short
    from psdesign.schema.types import _is_bool

    if not _is_bool(progress):
        raise SpecError("progress", f"must be True or False, got {short(progress)}")
    return bool(progress)


def _flow_table(spec_flow: dict, given: dict) -> dict:
    """The spec's ``[flow]`` table with the keywords ``given`` to a method, validated by the
    schema like a spec file's table (``SpecError`` naming ``flow.<key>`` and its range: an
    unknown or misspelled keyword is refused, not ignored)."""
    from psdesign.schema.flow import validated_flow

    checked = validated_flow(given)
    return {**spec_flow, **{key: getattr(checked, key) for key in given}}


@contextmanager
def _progress(
    on: bool, direction: str, solve: str = "voxel solve", method: str = "MINRES"
) -> Iterator[Callable[[int, float], None] | None]:
    """The iteration callback of a solve when ``on`` (the CLI's progress lines on stderr:
    stages, estimates, iterations with their residual; plain lines in a notebook), else None.
    The printer is active only for the block, so nothing stays switched on after the call."""
    if not on:
        yield None
        return
    from psdesign.progress import activate, progress_printer

    with activate():
        yield progress_printer(direction, solve=solve, method=method)


def _warns_at_caller(method: Callable) -> Callable:
    """Re-issue the warnings a call raises at the caller's line.

    Bad input found past the spec is raised as a ``SpecError`` (:func:`_spec_errors`).
    Raised deep inside psdesign, a warning (``ResolutionWarning``: too few voxels across a
    fiber) pointed at psdesign's own line, and Python's default filter shows a warning once
    per line: a second under-resolved material in a notebook printed nothing (recording
    starts with fresh registries, so each call records its own). Recorded under the filters in
    force, as a study's case is (:func:`psdesign.study.worker.run_case_inline`): with
    ``"always"`` a library's ``DeprecationWarning`` (scikit-fem's "Writing 'u.value' is
    unnecessary", every FEM call) was re-issued at ``__main__``, where the default filters show
    it (session 54).
    """

    @functools.wraps(method)
    def call(*args: Any, **kwargs: Any) -> Any:
        caught: list = []
        try:
            with warnings.catch_warnings(record=True) as caught:  # the filters in force decide
                return _spec_errors(method, args, kwargs)
        finally:  # at the caller's line, under the same filters ("error" raised in the call)
            for w in caught:
                warnings.warn(w.message, w.category, stacklevel=2)

    return call


def _spec_errors(method: Callable, args: tuple, kwargs: dict) -> Any:
    """``method(*args, **kwargs)``, bad input found past the spec raised as a
    :class:`~psdesign.errors.SpecError` (README: ``except psdesign.SpecError`` catches any bad
    input) with the original as ``__cause__`` (:func:`psdesign.errors.as_spec_error`)."""
    from psdesign.errors import SpecError, as_spec_error

    try:
        return method(*args, **kwargs)
    except SpecError:
        raise
    except ValueError as exc:
        err = as_spec_error(exc)
        if err is None:
            raise
        raise err from exc


class Material:
    """An RVE built from a spec: geometry, voxel fields on demand, properties on request.

    Parameters
    ----------
    spec : dict
        A validated spec (see :func:`build`); anything but a dict, or a dict not validated
        (missing a key validation fills in), is one :class:`~psdesign.errors.SpecError` line
        naming ``spec`` (``Material(3)`` raised ``TypeError: argument of type 'int' is not
        iterable`` until session 48, an unvalidated dict ``KeyError: 'period'`` until 54).
    """

    def __init__(self, spec: dict) -> None:
        from psdesign.errors import SpecError
        from psdesign.packing.build import build_rve

        if not isinstance(spec, dict):
            raise SpecError(
                "spec",
                "must be a validated spec (a dict: psdesign.build(spec) validates a dict or a "
                f"spec file and makes the Material), got {type(spec).__name__}",
            )
        self.spec = spec
        try:
            self._built = build_rve(spec)
        except KeyError as exc:  # a key validate_spec fills in (rve.period): not validated
            raise SpecError(
                "spec",
                "must be a validated spec (psdesign.build(spec) validates a dict or a spec "
                f"file and makes the Material), missing key {exc}",
            ) from None
        self._fields = None

    @property
    def rve(self):
        """The :class:`~psdesign.geometry.rve.RVE` (box and fibers, SI units)."""
        return self._built.rve

    @property
    def generation_report(self) -> dict:
        """What the generator did (target and reached porosity, intersection removal, ...)."""
        return dict(self._built.report)

    @property
    def fields(self):
        """Voxel fields at ``rve.voxel`` (signed distance, fiber counts), computed once."""
        if self._fields is None:
            self._fields = self._built.voxelize(self.spec["rve"]["voxel"])
        return self._fields

    @property
    def porosity(self) -> float:
        """Pore volume fraction on the voxel grid."""
        return self.fields.porosity

    @property
    def porosity_error(self) -> float:
        """Estimated absolute error of :attr:`porosity` against the analytic surface's pore
        fraction (0 for an image; :mod:`psdesign.geometry.porosity`)."""
        return self.fields.porosity_error

    @_warns_at_caller
    def permeability(
        self,
        direction: str | None = None,
        solver: str | None = None,
        bc: str | None = None,
        fields: str | Path | None = None,
        progress: bool = False,
        **flow: Any,
    ) -> PermeabilityResult:
        """Permeability along ``direction`` ('x', 'y' or 'z'; default the spec's
        ``flow.direction``, else 'z').

        ``solver`` ('fem' | 'voxel'), ``bc`` ('permeameter' | 'periodic') and any other
        ``[flow]`` key given as a keyword override the spec's ``[flow]`` table. ``fields``: a
        folder for the velocity and pressure fields (``flow_<d>.vti`` or ``.vtu``, a PNG slice
        and ``fields.json``; see :mod:`psdesign.fields`). ``progress=True``: progress lines on
        stderr (meshing stages, solver iterations and residual), as the command prints them.
        """
        from psdesign.fields import fields_folder
        from psdesign.flow.darcy import flow_direction
        from psdesign.flow.permeability import permeability
        from psdesign.schema.spec import check_directions

        progress = _progress_flag(progress)
        direction = _direction(flow_direction(direction, self.spec["flow"]))
        given = dict(flow)
        if solver is not None:
            given["solver"] = solver
        if bc is not None:
            given["bc"] = bc
        table = _flow_table(self.spec["flow"], given)
        _check_flow_budget(self.spec, table)  # the budget of this solver / bc, as the CLI
        check_directions(self.spec, table, [direction])  # the copies "auto" stacks along it
        route = table["solver"]
        folder = fields_folder(fields, "permeability", [direction], route, option="fields")
        method = "GMRES" if route == "fem" else "MINRES"
        with folder as writer, _progress(progress, direction, f"{route} solve", method) as report:
            if report is not None and route == "voxel":  # no path: refused before the estimate
                from psdesign.flow.voxel import refuse_without_path

                refuse_without_path(self.fields, direction, table, self.rve)
            result = permeability(
                self.rve, self.fields, direction, table, route, progress=report, capture=writer
            )
        return PermeabilityResult.from_dict(result)

    @_warns_at_caller
    def diffusivity(
        self,
        direction: str = "z",
        fields: str | Path | None = None,
        progress: bool = False,
        **transport: Any,
    ):
        """Relative diffusivity ``D_eff / D_bulk`` and tortuosity factor along ``direction``
        (a :class:`~psdesign.transport.diffusivity.DiffusivityResult`); keywords override the
        spec's ``[transport]`` table; ``fields``: a folder for the concentration field;
        ``progress=True``: the solve's iterations on stderr."""
        from psdesign.fields import fields_folder
        from psdesign.geometry.rve import resolution_measure
        from psdesign.schema.budget import check_transport
        from psdesign.transport.diffusivity import relative_diffusivity

        progress = _progress_flag(progress)
        direction = _direction(direction)
        check_transport(self.spec)  # its solve's memory, before the voxels (review G, s52)
        table = {**self.spec.get("transport", {}), **transport}
        folder = fields_folder(fields, "diffusivity", [direction], option="fields")
        with folder as writer, _progress(progress, direction, "Laplace solve", "CG") as report:
            return relative_diffusivity(
                self.fields,
                direction,
                table,
                progress=report,
                capture=writer,
                cells_per_diameter=self._cpd(),
                resolution_measure=resolution_measure(self.rve),
            )

    @_warns_at_caller
    def conductivity(
        self,
        direction: str = "z",
        solid: float | None = None,
        fluid: float | None = None,
        fields: str | Path | None = None,
        progress: bool = False,
        **transport: Any,
    ):
        """Effective conductivity along ``direction`` with phase conductivities ``solid`` and
        ``fluid`` (a :class:`~psdesign.transport.conductivity.ConductivityResult`); ``fields``:
        a folder for the potential field; ``progress=True``: the solve's iterations on stderr."""
        from psdesign.fields import fields_folder
        from psdesign.geometry.rve import resolution_measure
        from psdesign.schema.budget import check_transport
        from psdesign.transport.conductivity import effective_conductivity, transport_table

        progress = _progress_flag(progress)
        direction = _direction(direction)
        table = {**self.spec.get("transport", {}), **transport}
        transport_table(solid, fluid, table)  # refused before the voxels are computed
        check_transport(self.spec)
        folder = fields_folder(fields, "conductivity", [direction], option="fields")
        with folder as writer, _progress(progress, direction, "Laplace solve", "CG") as report:
            return effective_conductivity(
                self.fields,
                direction,
                solid,
                fluid,
                table,
                progress=report,
                capture=writer,
                cells_per_diameter=self._cpd(),
                resolution_measure=resolution_measure(self.rve),
            )

    def _cpd(self) -> float | None:
        """Voxels across the thinnest fiber (None for an image)."""
        from psdesign.flow.error import cells_per_diameter

        return cells_per_diameter(self.rve, float(self.fields.grid.spacing[0]))

    @_warns_at_caller
    def pores(self, **transport: Any) -> dict:
        """Pore sizes, intrusion curve, specific surface, porosity profile and (for fibers)
        orientation tensor: the dict ``psdesign pores --json`` prints (keys carry their SI
        unit: ``pore_d50_m``, ``specific_surface_m-1``, ...; ``rel_error`` and
        ``specific_surface_rel_error`` are the error estimates). Keywords (``n_radii``,
        ``thickness_axis``, ``surface_tension_n_m``, ``contact_angle_deg``) override the spec's
        ``[transport]`` table and are validated with it (``SpecError`` naming the key)."""
        from psdesign.schema.budget import check_transport
        from psdesign.schema.transport import validate_transport
        from psdesign.transport.study_outputs import pore_report

        table = validate_transport({"transport": {**self.spec.get("transport", {}), **transport}})
        check_transport(self.spec)
        return pore_report(self.rve, self.fields, table)

    def _repr_html_(self) -> str:
        """The notebook's table: box, voxel grid, fibres (or image) and, once the voxel fields
        exist (a display does not voxelize), the porosity with its error estimate and its
        rating (a count: ``ok`` up to a 20 % bar, as in study tables)."""
        import html

        from psdesign.analysis.columns import porosity_status
        from psdesign.notebook import porosity_html, result_html

        grid = self.rve.grid(self.spec["rve"]["voxel"])
        source = (  # the file name escaped: a<i>b&c.npy went in raw (session 52 I/O review)
            ("image", html.escape(Path(self.spec["image"]["path"]).name))
            if "image" in self.spec
            else ("fibers", str(len(self.rve.fibers)))
        )
        rows = [
            ("box (m)", " x ".join(f"{s:.4g}" for s in self.rve.size)),
            ("voxel grid", f"{' x '.join(map(str, grid.shape))} of {grid.spacing[0]:.4g} m"),
            source,
        ]
        if self._fields is None:
            rows.append(("porosity (-)", "not computed yet (m.porosity voxelizes)"))
            return result_html("Material", rows, "unrated", [])
        eps, err = self.porosity, self.porosity_error
        rows.append(("porosity (-)", porosity_html(eps, err)))
        return result_html("Material", rows, porosity_status(eps, err), [])

    def __repr__(self) -> str:
        size = " x ".join(f"{s:g}" for s in self.rve.size)  # metres: SI, as every output
        if "image" in self.spec:
            name = Path(self.spec["image"]["path"]).name
            return f"Material({size} m, image {name}, voxel {self.spec['rve']['voxel']:.4g} m)"
        return f"Material({size} m, {len(self.rve.fibers)} fibers)"


def _check_flow_budget(spec: dict, flow: dict) -> None:
    """The flow solve's checks (memory budget, ``flow.max_memory_gb``, the route's keys) of
    ``spec`` with the ``[flow]`` table ``flow``, before :meth:`Material.permeability` solves:
    :func:`build` held the spec to its geometry only. Warnings the build showed are not
    repeated; a table the call changed is validated as ``--solver`` / ``--bc`` are
    (:func:`psdesign.schema.spec.check_flow_override`). ``SpecError``."""
    import warnings

    from psdesign.schema.image import ImageWarning
    from psdesign.schema.spec import SpecWarning, check_flow_override, validate_spec

    if flow != spec["flow"]:
        check_flow_override(spec, flow)
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpecWarning)
        warnings.simplefilter("ignore", ImageWarning)
        validate_spec(spec)


@_warns_at_caller
def build(spec: dict | str | Path) -> Material:
    """Build a material from a spec dict or a spec file; the spec is validated first, held to
    the memory of its geometry (its voxel grid: :func:`psdesign.schema.budget.unplanned_route`),
    not to a flow solve's: :meth:`Material.permeability` checks the solve it runs, and
    ``diffusivity`` / ``conductivity`` / ``pores`` theirs (``budget.check_transport``). Until
    session 53 a spec whose FEM permeameter would not fit was refused here, geometry and all."""
    from psdesign.schema.budget import unplanned_route
    from psdesign.schema.spec import validate_spec

    with unplanned_route():
        spec = load_spec(spec) if isinstance(spec, str | Path) else validate_spec(spec)
    return Material(spec)


@_warns_at_caller
def from_image(
    path: str | Path,
    voxel_size: float | None = None,
    solid_label: int | list[int] | None = None,
    flow: dict | None = None,
    **image: Any,
) -> Material:
    """A material from a segmented voxel image (docs/images.md).

    Parameters
    ----------
    path : str or Path
        TIFF stack, raw, ``.npy`` or ``.vti`` file, or a folder or pattern (``"recon/*.tif"``)
        of 2-D TIFF slices (relative to the current folder; docs/images.md).
    voxel_size : float, optional
        Voxel edge in metres; required unless the file carries it (TIFF ImageJ metadata,
        VTI spacing).
    solid_label : int or list of int, optional
        Label(s) of the solid (default: every nonzero voxel).
    flow : dict, optional
        A ``[flow]`` table (solver, bc, viscosity, ...).
    **image
        Other ``[image]`` keys: ``threshold``, ``crop``, ``axis_order``, ``format``, ``shape``,
        ``dtype``, ``byte_order``.

    Returns
    -------
    Material
        Validated like a spec with an ``[image]`` table (``SpecError`` naming the key).
    """
    from psdesign.errors import SpecError

    if not isinstance(path, str | PathLike):  # str() of an array made a page-long message
        raise SpecError(
            "image.path",
            f"from_image takes a file name (str or Path), got {type(path).__name__}; "
            "save an array with numpy.save and give that .npy file",
        )
    table: dict[str, Any] = {"path": str(path), **image}
    if voxel_size is not None:
        table["voxel_size"] = voxel_size
    if solid_label is not None:
        table["solid_label"] = solid_label
    spec: dict[str, Any] = {"image": table}
    if flow is not None:  # not a dict: the spec's one-line "flow: must be a table"
        spec["flow"] = dict(flow) if isinstance(flow, dict) else flow
    return build(spec)


def _unguarded_call_in_main_script(name: str) -> bool:
    """True when the running script calls ``name`` at module level outside a main guard.

    Spawned worker processes re-import that script; the call would then start again in each
    worker (and hit the output lock), so the runner refuses it up front.
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if not path or not str(path).endswith(".py") or not Path(path).is_file():
        return False  # interactive, Jupyter, python -c, python -m: nothing is re-imported
    try:
        tree = ast.parse(Path(path).read_text())
    except (OSError, SyntaxError, ValueError):
        return False
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef | ast.If):
            continue  # definitions and guarded blocks (if __name__ == "__main__") do not run
        for sub in ast.walk(node):
            if isinstance(sub, ast.Call):
                fn = sub.func
                called = fn.attr if isinstance(fn, ast.Attribute) else getattr(fn, "id", None)
                if called == name:
                    return True
    return False


def run_study(
    study: str | Path | dict, out_dir: str | Path, options: RunOptions | None = None, **kwargs: Any
):
    """Run (or resume) a study; see :func:`psdesign.study.runner.run_study` for the arguments.

    ``study`` is a study file or its tables as a dict (as :func:`build` takes a spec);
    ``options`` a :class:`psdesign.study.RunOptions`, or its fields as keywords
    (``workers=2``). With ``workers >= 1`` (worker processes), a call from a script must sit
    under ``if __name__ == "__main__":``; an unguarded call is refused with a one-line error.
    A refused ``out_dir`` is an :class:`~psdesign.io.outputs.OutputError` naming ``out_dir``
    (and ``force=True`` where that would help), not the CLI's ``-o`` / ``--force``; a
    scheduler that does not answer is a ``SchedulerError`` naming ``scheduler``, not
    ``--scheduler``. A finished study with flagged cases (an ``ok`` case with a value whose own
    status is not ok, such as an untrustworthy ``k_z_status``, or a case finished with another
    status word, such as ``blocked``) issues a :class:`psdesign.FlaggedCasesWarning` at the
    call, in ``study run``'s words. Only those: cases that did not converge, failed or timed out
    (for which ``study run`` exits 3 or 1 too) are not warned of; read the table's ``status``.
    """
    from psdesign.study import RunOptions, StudyError
    from psdesign.study import run_study as _run
    from psdesign.study.runner import check_run_keywords

    # an unknown keyword (wrkers=2) is its one line, not the main guard's (review s48)
    check_run_keywords(kwargs, {}, "run_study")
    workers = kwargs.get("workers", options.workers if isinstance(options, RunOptions) else 1)
    # a bad ``workers`` (negative, not an int) or ``options`` (not a RunOptions) is the
    # runner's one-line error, not this one (options=3 in a script was told of the main guard)
    real = isinstance(workers, numbers.Integral) and not isinstance(workers, bool) and workers >= 1
    real = real and isinstance(options, RunOptions | None)
    if real and _unguarded_call_in_main_script("run_study"):
        raise StudyError(
            "run_study: called at the top level of a script with worker processes; put the "
            'call under `if __name__ == "__main__":` (workers re-import the script) or pass '
            "workers=0"
        )
    df = _run(study, out_dir, options, **kwargs)
    _warn_flagged(df)
    return df


def _warn_flagged(df) -> None:
    """Warn at the caller's line when ``df`` (a finished study's table) has flagged cases, in
    the words ``study run`` prints before it exits 3 (:func:`~psdesign.analysis.columns.
    flagged_text`): until session 54 an API user saw "done ...: ok 3" and nothing else when
    every value was untrustworthy."""
    from psdesign.analysis.columns import FLAGGED_KEPT, FlaggedCasesWarning, flagged_text
    from psdesign.errors import warn_at_caller

    if text := flagged_text(df):
        warn_at_caller(f"run_study: {text}; {FLAGGED_KEPT}", FlaggedCasesWarning)
