"""Writing solver fields into a ``--fields`` folder: one file per solve (held until the solve
is rated: after the coarse solve of its error bar, so its entry carries the final result), a
PNG picture of each, and ``fields.json`` (the index: files, array names and units, tag tables).

The folder follows the safe-output rules of :mod:`psdesign.io.outputs` (a user's non-psdesign
folder is refused, nothing psdesign did not write is replaced) and appears atomically: the files
are written into a temporary folder that is moved into place when the command succeeds. A reused
folder then holds only the new run's fields: the files the previous ``fields.json`` listed that
the new run did not write are removed after the new files are in place, if the marker says
psdesign wrote them; any other file is never touched.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from psdesign.fields.tables import boundary_table, region_table
from psdesign.io.vtkfile import save_vtk

#: Array names and units of every field file (also in ``fields.json``).
UNITS = {
    "velocity_m_per_s": "m/s (3-vector)",
    "velocity_magnitude_m_per_s": "m/s",
    "pressure_Pa": "Pa (total pressure; its mean over the outlet end of the solved domain is 0; "
    "NaN where no pressure is solved: pressure_cell = 0 on the voxel grid)",
    "concentration_relative": "1 (1 at the inlet face, 0 at the outlet face)",
    "potential_relative": "1 (1 at the inlet face, 0 at the outlet face)",
    "flux_per_unit_gradient": "conductivity_unit (1 in the pore for diffusion) (3-vector)",
    "solid": "1 = fibre, 0 = pore",
    "pressure_cell": "1 = a pressure cell of the voxel solver (pressure_Pa solved), 0 = none",
    "conductivity": "conductivity_unit: the phase conductivities as given",
    "conductivity_unit": "field data: the unit of the two arrays above (1 for diffusivity)",
    "zone": "region id (see regions)",
    "tag": "boundary tag id (see boundary_tags)",
    "pressure_gradient_rve_Pa_per_m": "Pa/m, field data: the gradient that defines K over the "
    "rve zone (K = mu <u> / it, <u> the mean velocity along the flow over the rve zone; a "
    "permeameter's pressure_gradient_Pa_per_m spans its reservoirs too)",
    "rve_copies": "field data: copies of the RVE the rve zone holds along the flow",
}

_KINDS = ("fem_flow", "voxel_flow", "diffusivity", "conductivity")


def field_files(kind: str, directions: Iterable[str], solver: str = "voxel") -> list[str]:
    """The files a command writes into the fields folder (``kind``: "permeability",
    "diffusivity" or "conductivity"), for the up-front output-folder check."""
    names = ["fields.json"]
    for d in directions:
        if kind == "permeability":
            stem = f"flow_{d}"
            names += [f"{stem}.vtu", f"{stem}_boundary.vtu"] if solver == "fem" else [f"{stem}.vti"]
        else:
            stem = f"{kind}_{d}"
            names.append(f"{stem}.vti")
        names.append(f"{stem}.png")
    return names


#: Keys of a solve's result copied into ``fields.json``: what a ParaView user needs to know
#: whether to trust the field (the value, its error bar, the status and why); a flow solve has
#: the ``permeability_*`` keys, a Laplace solve its value's and ``rel_error``.
RESULT_KEYS = (
    "permeability_m2",
    "permeability_rel_error",
    "relative_diffusivity",
    "tortuosity_factor",
    "effective_conductivity",
    "conductivity_unit",
    "rel_error",
    "solver",
    "bc",
    "status",
    "converged",
    "warnings",
    "flow_rate_m3_s",
)


def result_words(kind: str, direction: str, result: dict | None) -> str:
    """A solve's reported value with its error bar and status, as the command's line starts
    (``K_z = 2.1678e-11 m^2 +- 8.6 %  [untrustworthy]``, ``D_eff/D_z = 0.8349 ...``,
    ``sigma_eff_z = 0.035215 W/(m K) ...``); "" without a result or its value.

    >>> result_words("voxel_flow", "z", {"permeability_m2": 2.1678e-11,
    ...              "permeability_rel_error": 0.086, "status": "untrustworthy"})
    'K_z = 2.1678e-11 m^2 +- 8.6 %  [untrustworthy]'
    >>> result_words("conductivity", "x", {"effective_conductivity": 0.035215,
    ...              "conductivity_unit": "W/(m K)", "rel_error": None, "status": "ok"})
    'sigma_eff_x = 0.035215 W/(m K)  [ok]'
    """
    from psdesign.lines import value_text

    if not result:
        return ""
    quantity = "permeability" if kind in ("fem_flow", "voxel_flow") else kind
    text = value_text(quantity, direction, result)
    return f"{text}  [{result.get('status', 'unrated')}]" if text else ""


def _with_result(title: str, kind: str, direction: str, result: dict | None) -> str:
    """A field picture's title: the solve's value with its bar and status
    (:func:`result_words`) above ``title``, so an untrustworthy solve's picture says so (it
    named the solver and direction only until session 49)."""
    words = result_words(kind, direction, result)
    return f"{words}\n{title}" if words else title


class HeldCapture:
    """Holds a solve's ``capture`` call until its result is final: the fields are written only
    for the solve that is reported (a superseded one is :meth:`drop`-ped), and :meth:`flush`
    can add what is known only after the solve (the result with its error bar and status).
    """

    def __init__(self, capture: Callable[..., None]) -> None:
        self.capture = capture
        self.call: tuple[tuple, dict] | None = None

    def __call__(self, *args, **kwargs) -> None:
        self.call = (args, kwargs)

    def drop(self) -> None:
        """Forget the held call (its solve is superseded)."""
        self.call = None

    def flush(self, **more) -> None:
        """Pass the held call on to ``capture``, with the keywords ``more`` added."""
        if self.call is not None:
            args, kwargs = self.call
            self.call = None
            self.capture(*args, **{**kwargs, **more})


class FieldWriter:
    """A ``capture`` callable for the solvers' routes that writes each solve's fields.

    Parameters
    ----------
    folder : Path
        An existing folder (the temporary folder of :func:`fields_output`).
    picture : bool
        Also render a PNG of each solve (:func:`psdesign.fields.picture.slice_picture`).
    """

    def __init__(self, folder: str | Path, picture: bool = True) -> None:
        self.folder = Path(folder)
        self.picture = picture
        self.solves: list[dict] = []
        self.warnings: list[str] = []

    def _stem(self, base: str) -> str:
        used = {s["stem"] for s in self.solves}
        stem, i = base, 2
        while stem in used:
            stem, i = f"{base}_{i}", i + 1
        return stem

    def __call__(self, kind: str, *, solution, fields=None, result=None, **extra) -> None:
        """Write one solve (``kind`` in "fem_flow", "voxel_flow", "diffusivity",
        "conductivity"); the keywords are those the routes pass."""
        if kind not in _KINDS:
            raise ValueError(f"fields: unknown solve kind {kind!r}")
        if kind in ("fem_flow", "voxel_flow"):
            self._flow(kind, solution, fields, result, extra)
        else:
            self._laplace(kind, solution, fields, extra["conductivity"], result)

    def _flow(self, kind, solution, fields, result, extra) -> None:
        from psdesign.fields.flow import fem_flow_grids, rve_gradient, voxel_flow_grid

        d = str(result["direction"])
        stem = self._stem(f"flow_{d}")
        entry = {"kind": kind, "stem": stem, "direction": d, "result": result}
        if kind == "voxel_flow":
            grid = voxel_flow_grid(solution, fields, result)
            save_vtk(grid, self.folder / f"{stem}.vti")
            entry["files"] = [f"{stem}.vti"]
        else:
            flow = extra.get("flow") or {}
            grad = result.get("pressure_gradient_pa_m") if result.get("bc") == "periodic" else 0
            grid, bnd = fem_flow_grids(
                solution, extra["mesh"], result, float(flow.get("viscosity", "nan")), grad or 0.0
            )
            save_vtk(grid, self.folder / f"{stem}.vtu")
            save_vtk(bnd, self.folder / f"{stem}_boundary.vtu")
            entry["files"] = [f"{stem}.vtu", f"{stem}_boundary.vtu"]
        if (rve := rve_gradient(result)) is not None:  # K = mu <u> / G over the rve zone
            entry["pressure_gradient_rve_Pa_per_m"], entry["rve_copies"] = rve
        axis = "xyz".index(d)
        title = f"{result.get('solver', '')} {result.get('bc', '')}: flow along {d}"
        title = _with_result(title, kind, d, result)
        self._picture(entry, grid, axis, "velocity_m_per_s", "pressure_Pa", title)
        self.solves.append(entry)

    def _laplace(self, kind, solution, fields, conductivity, result) -> None:
        from psdesign.fields.laplace import laplace_grid

        d = "xyz"[int(solution.axis)]
        stem = self._stem(f"{kind}_{d}")
        grid = laplace_grid(solution, conductivity, fields, kind, result)
        save_vtk(grid, self.folder / f"{stem}.vti")
        entry = {"kind": kind, "stem": stem, "direction": d, "files": [f"{stem}.vti"]}
        if result is not None:
            entry["result"] = result
        entry["mean_flux_per_unit_gradient"] = [
            float(v) for v in solution.mean_flux / solution.gradient
        ]
        scalar = "concentration_relative" if kind == "diffusivity" else "potential_relative"
        title = _with_result(f"{kind}: gradient along {d}", kind, d, result)
        self._picture(entry, grid, int(solution.axis), "flux_per_unit_gradient", scalar, title)
        self.solves.append(entry)

    def _picture(self, entry, grid, axis, vector, scalar, title) -> None:
        if not self.picture:
            return
        from psdesign.fields.picture import slice_picture

        try:
            slice_picture(grid, self.folder / f"{entry['stem']}.png", axis, vector, scalar, title)
        except Exception as exc:  # a picture must not lose the solve's field files
            self.warnings.append(f"{entry['stem']}.png: picture failed ({exc})")
            return
        entry["picture"] = f"{entry['stem']}.png"

    def index(self) -> dict:
        """The content of ``fields.json``."""
        solves = []
        for s in self.solves:
            s = dict(s)
            res = s.pop("result", None)
            if res is not None:
                s["result"] = {k: res.get(k) for k in RESULT_KEYS if k in res}
            solves.append(s)
        return {
            "solves": solves,
            "units": UNITS,
            "regions": region_table(),
            "boundary_tags": boundary_table(),
            "warnings": self.warnings,
            "notes": [
                "VTU (tet mesh): quadratic tets, P2 velocity at their 10 nodes, P1 pressure",
                "VTI (voxel grid): cell data, spacing = voxel size in metres",
            ],
        }

    def finish(self) -> Path:
        """Write ``fields.json``; returns its path."""
        path = self.folder / "fields.json"
        path.write_text(json.dumps(self.index(), indent=1, default=float))
        return path


def fields_folder(
    path: str | Path | None,
    kind: str,
    directions: Iterable[str],
    solver: str = "voxel",
    option: str = "--fields",
):
    """:func:`fields_output` for the ``--fields`` option of the command ``kind``
    ("permeability", "diffusivity", "conductivity"), or a null context (yielding None) when
    ``path`` is None. ``option``: the name the messages give (``fields`` for the keyword of
    the Python API's methods)."""
    if path is None:
        return contextlib.nullcontext(None)
    expected = field_files(kind, directions, solver)
    return fields_output(path, f"{kind} {option}", expected, option=option)


@contextlib.contextmanager
def fields_output(
    path: str | Path, command: str, expected: Iterable[str] = (), option: str = "--fields"
) -> Iterator[FieldWriter]:
    """Check the fields folder now (:class:`psdesign.io.outputs.OutputError`, exit 2, before
    any solve), yield a :class:`FieldWriter` on a temporary folder, and move its files into
    place when the block succeeds (nothing is written if it fails)."""
    from psdesign.io.outputs import check_output_dir, staged_output

    out = check_output_dir(  # no --force for a fields folder
        path, option=option, command=command, expected=expected, force_option=None
    )
    before = indexed_files(out.path / "fields.json") if out.exists else set()
    # the previous set's files this run does not write again go once the new set is in place
    # (a failed run leaves the previous set whole): staged_output's replaces
    with staged_output(out, replaces=before) as tmp:
        writer = FieldWriter(tmp)
        yield writer
        writer.finish()


def indexed_files(path: Path) -> set[str]:
    """The files a ``fields.json`` at ``path`` lists (its solves' files and pictures); an
    empty set if there is none or it is not a psdesign index. Only plain names (no folders)."""
    try:
        index = json.loads(path.read_text())
        solves = index["solves"]
        names = set()
        for s in solves:
            names.update(s.get("files", []))
            if s.get("picture"):
                names.add(s["picture"])
    except (OSError, ValueError, UnicodeDecodeError, KeyError, TypeError, AttributeError):
        return set()
    return {n for n in names if isinstance(n, str) and n and Path(n).name == n and n != ".."}
