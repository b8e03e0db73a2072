"""Mesh export registry (meshio-style): one module per format, ``WRITERS`` maps name -> writer.

Every writer has the signature ``writer(pm, out_dir) -> dict[str, Path]`` (key -> written
file); :func:`export_mesh` runs the requested ones and always adds ``mesh.json``. Register a new
format with :func:`register_writer`; ``psdesign mesh --format`` lists :data:`WRITERS`.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from psdesign.meshing.errors import MeshInputError

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh

Writer = Callable[["PoreMesh", Path], dict[str, Path]]

# The writers import meshio/numpy when called, not when the registry is imported: the CLI lists
# the format names in ``psdesign --help`` without paying for those imports (cold start).


def write_vtu(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """``pore.vtu`` + ``pore_boundary.vtu`` (:func:`psdesign.meshing.exports.vtu.write_vtu`)."""
    from psdesign.meshing.exports.vtu import write_vtu as writer

    return writer(pm, out)


def write_gmsh(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """Gmsh MSH with physical names (:func:`psdesign.meshing.exports.gmsh.write_gmsh`)."""
    from psdesign.meshing.exports.gmsh import write_gmsh as writer

    return writer(pm, out)


def write_stl(pm: PoreMesh, out: Path) -> dict[str, Path]:
    """Boundary surface STL (:func:`psdesign.meshing.exports.stl.write_stl`)."""
    from psdesign.meshing.exports.stl import write_stl as writer

    return writer(pm, out)


def write_json(pm: PoreMesh, out: Path) -> Path:
    """``mesh.json`` (:func:`psdesign.meshing.exports.meshjson.write_json`)."""
    from psdesign.meshing.exports.meshjson import write_json as writer

    return writer(pm, out)


def _write_fluent(pm: PoreMesh, out: Path, flow: dict | None = None) -> dict[str, Path]:
    """``pore_fluent.msh``: ANSYS Fluent ASCII with named boundary zones (sides typed by the
    spec's ``flow.sides``)."""
    from psdesign.meshing.exports.fluent import write_fluent

    return {"fluent": write_fluent(pm, out / "pore_fluent.msh", flow=flow)}


def _write_openfoam(pm: PoreMesh, out: Path, flow: dict | None = None) -> dict[str, Path]:
    """``openfoam/``: a ready-to-run simpleFoam case (``Allrun``) with the spec's ``flow``
    viscosity, density and pressure drop; a periodic mesh's has cyclic patches and a pressure
    jump (:mod:`psdesign.meshing.exports.openfoam_periodic`)."""
    if pm.periodic:
        from psdesign.meshing.exports.openfoam_periodic import write_periodic_case

        return {"openfoam": write_periodic_case(pm, out / "openfoam", flow=flow)}
    from psdesign.meshing.exports.openfoam import write_openfoam_case

    return {"openfoam": write_openfoam_case(pm, out / "openfoam", flow=flow)}


#: format name -> writer (insertion order is the order ``--format`` lists them)
WRITERS: dict[str, Writer] = {
    "vtu": write_vtu,
    "msh": write_gmsh,
    "fluent": _write_fluent,
    "stl": write_stl,
    "openfoam": _write_openfoam,
}


#: The files of an OpenFOAM ``constant/polyMesh`` psdesign writes (also copied into
#: ``constant/polyMesh.tet``, :func:`psdesign.meshing.exports.openfoam.write_tet_copy`).
POLYMESH_FILES = ("boundary", "faces", "neighbour", "owner", "points")
_OPENFOAM_CASE = (
    "Allrun",
    "README.txt",
    "0/U",
    "0/p",
    # polyMesh.tet: the export's own copy of the tets Allrun starts from (session 52)
    *(f"constant/{d}/{n}" for d in ("polyMesh", "polyMesh.tet") for n in POLYMESH_FILES),
    "constant/momentumTransport",
    "constant/transportProperties",
    "constant/turbulenceProperties",
    *(f"system/{n}" for n in ("changeDictionaryDict", "controlDict", "fvSchemes", "fvSolution")),
)
#: format name -> the files (relative POSIX paths) its writer puts in the output folder;
#: ``psdesign mesh`` checks them before meshing and drops a previous run's that it did not rewrite
OUTPUTS: dict[str, tuple[str, ...]] = {
    "vtu": ("pore.vtu", "pore_boundary.vtu"),
    "msh": ("pore.msh",),
    "fluent": ("pore_fluent.msh",),
    "stl": ("pore.stl",),
    "openfoam": tuple(f"openfoam/{n}" for n in _OPENFOAM_CASE),
}


#: Formats that set the boundary conditions and have no periodic patches: they would write the
#: side faces of a periodic mesh as symmetry planes or walls and its ends as a pressure inlet /
#: outlet, a different problem. Refused for a periodic mesh (openfoam writes cyclic patches).
NO_PERIODIC = ("fluent",)
NO_PERIODIC_WHY = (
    "fluent sets the side faces as symmetry planes or walls and has no periodic zones here: "
    "not with a periodic mesh (flow.bc = 'periodic'); use flow.bc = 'permeameter', or "
    "openfoam (cyclic patches), vtu or msh (periodic faces with matching vertices)"
)


def output_names(names: tuple[str, ...]) -> tuple[str, ...]:
    """The files and folders the formats ``names`` write (:data:`OUTPUTS`; a format registered
    with :func:`register_writer` and not listed there adds none).

    Parameters
    ----------
    names
        Format names from :data:`WRITERS`.

    Returns
    -------
    tuple of str
        Relative POSIX paths, in format order.
    """
    return tuple(n for fmt in names for n in OUTPUTS.get(fmt, ()))


def formats() -> tuple[str, ...]:
    """Names of the registered formats."""
    return tuple(WRITERS)


def register_writer(name: str, writer: Writer) -> None:
    """Add (or replace) the writer of format ``name``."""
    if not name.isidentifier():
        raise MeshInputError(f"format name must be an identifier, got {name!r}", key="name")
    WRITERS[name] = writer


def export_mesh(
    pm: PoreMesh, out_dir, formats=("vtu",), flow: dict | None = None
) -> dict[str, Path]:
    """Write ``pm`` into ``out_dir`` in the requested formats, plus ``mesh.json``.

    Parameters
    ----------
    pm
        The mesh.
    out_dir
        Output folder (created).
    formats
        Names from :data:`WRITERS`: ``vtu`` (``pore.vtu`` + ``pore_boundary.vtu``), ``msh``
        (Gmsh 2.2 with physical names), ``fluent`` (``pore_fluent.msh``), ``stl`` (boundary
        surface), ``openfoam`` (case folder ``openfoam/`` for simpleFoam).
    flow
        The spec's ``[flow]`` table, passed to the writers that take a ``flow`` argument
        (``openfoam``: viscosity, density, pressure drop, sides; ``fluent``: sides).

    Returns
    -------
    dict
        Output key -> written path (``json`` always present).
    """
    if isinstance(formats, str):
        formats = (formats,)
    bad = [f for f in formats if f not in WRITERS]
    if bad:
        raise MeshInputError(f"formats {bad} not supported; allowed: {', '.join(WRITERS)}")
    if pm.periodic and set(formats) & set(NO_PERIODIC):
        raise MeshInputError(NO_PERIODIC_WHY, key="formats")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: dict[str, Path] = {}
    import inspect

    for fmt in formats:
        writer = WRITERS[fmt]
        takes_flow = "flow" in inspect.signature(writer).parameters
        with _naming_failed_write(out, fmt):
            written.update(writer(pm, out, flow=flow) if takes_flow else writer(pm, out))
    with _naming_failed_write(out, "mesh.json"):
        written["json"] = write_json(pm, out)
    return written


@contextlib.contextmanager
def _naming_failed_write(out: Path, what: str) -> Iterator[None]:
    """An ``OSError`` without a file name names the folder and the export: meshio's ``open``
    block failing as the file is closed on a full disk, the CLI's one line said only "No space
    left on device" (failure audit s36, ``mesh --format msh`` on a 120 kB tmpfs); numpy's short
    write (binary STL) has no ``errno`` either, it said "2550 requested and 1964 written" (1 MB
    tmpfs): now ``ENOSPC`` if the disk is full (:func:`psdesign.io.diskfull.short_write_errno`).
    """
    from psdesign.io.diskfull import named_write_error

    try:
        yield
    except OSError as exc:
        named = named_write_error(exc, out, out, f"writing the {what} export")
        if named is exc:
            raise
        raise named from exc
