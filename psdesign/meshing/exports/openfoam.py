"""Ready-to-run OpenFOAM case (constant/polyMesh + minimal system/ and 0/) for simpleFoam.

Patches: ``inlet`` and ``outlet`` (fixed kinematic pressure), ``walls`` (no-slip fiber
surfaces) and ``sides`` (the four lateral faces, ``symmetry``). Run with e.g.
``simpleFoam -case OUT/openfoam`` (Debian's openfoam package: set ``WM_PROJECT_DIR`` to its
``share/openfoam`` folder); ``checkMesh`` first.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdesign.meshing import tags as T
from psdesign.meshing.topology import FaceTopology, face_topology

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh

_BANNER = """/*--------------------------------*- C++ -*----------------------------------*\\
  written by psdesign (pore-space mesher)
\\*---------------------------------------------------------------------------*/
"""


def _header(cls: str, obj: str, location: str, note: str = "") -> str:
    note_line = f'    note        "{note}";\n' if note else ""
    return (
        _BANNER
        + "FoamFile\n{\n    version     2.0;\n    format      ascii;\n"
        + f'    class       {cls};\n{note_line}    location    "{location}";\n'
        + f"    object      {obj};\n}}\n\n"
    )


def _write_array(path: Path, header: str, rows: np.ndarray, fmt: str) -> None:
    buf = io.StringIO()
    buf.write(header)
    buf.write(f"{len(rows)}\n(\n")
    np.savetxt(buf, rows, fmt=fmt)
    buf.write(")\n")
    path.write_text(buf.getvalue())


def openfoam_patches(pm: PoreMesh) -> dict[str, np.ndarray]:
    """OpenFOAM patch name -> boundary triangles (sides merged into one patch)."""
    tags = pm.facet_tags
    sides = [v for k, v in tags.items() if T.is_side(k) and len(v)]
    return {
        T.INLET: tags[T.INLET],
        T.OUTLET: tags[T.OUTLET],
        "walls": tags[T.WALL],
        "sides": np.concatenate(sides) if sides else np.zeros((0, 3), dtype=np.int64),
    }


def write_polymesh(pm: PoreMesh, poly: Path) -> FaceTopology:
    """Write points/faces/owner/neighbour/boundary into ``poly``; returns the topology."""
    poly.mkdir(parents=True, exist_ok=True)
    topo = face_topology(pm.points, pm.tets, openfoam_patches(pm))
    loc = "constant/polyMesh"
    note = (
        f"nPoints:{len(pm.points)}  nCells:{len(pm.tets)}  nFaces:{len(topo.faces)}  "
        f"nInternalFaces:{topo.n_internal}"
    )
    _write_array(
        poly / "points", _header("vectorField", "points", loc), pm.points, "(%.12g %.12g %.12g)"
    )
    _write_array(poly / "faces", _header("faceList", "faces", loc), topo.faces, "3(%d %d %d)")
    _write_array(
        poly / "owner", _header("labelList", "owner", loc, note), topo.owner[:, None], "%d"
    )
    _write_array(
        poly / "neighbour",
        _header("labelList", "neighbour", loc, note),
        topo.neighbour[:, None],
        "%d",
    )
    types = {
        T.INLET: "patch",
        T.OUTLET: "patch",
        "walls": "wall",  # format keyword
        "sides": "symmetry",
    }
    lines = [_header("polyBoundaryMesh", "boundary", loc), f"{len(topo.patch_names)}\n(\n"]
    for name, start, size in zip(topo.patch_names, topo.patch_start, topo.patch_size, strict=True):
        is_wall = types[name] == "wall"  # format keyword, not a tag
        extra = "        inGroups    List<word> 1(wall);\n" if is_wall else ""
        lines.append(
            f"    {name}\n    {{\n        type        {types[name]};\n{extra}"
            f"        nFaces      {size};\n        startFace   {start};\n    }}\n"
        )
    lines.append(")\n")
    (poly / "boundary").write_text("".join(lines))
    return topo


def write_openfoam_case(pm: PoreMesh, case: Path, p_inlet: float = 1.0, nu: float = 1.5e-5) -> Path:
    """Write a simpleFoam case (laminar Stokes-regime flow driven by a kinematic pressure drop).

    Parameters
    ----------
    pm
        The mesh.
    case
        Case folder (created).
    p_inlet
        Inlet kinematic pressure in m^2/s^2 (outlet 0). The default with ``nu`` = 1.5e-5 m^2/s
        (air) keeps Re = u d / nu ~ 1e-3 for GDL-like media (creeping flow, Darcy regime).
    nu
        Kinematic viscosity in m^2/s.

    Returns
    -------
    Path
        The case folder.
    """
    case = Path(case)
    write_polymesh(pm, case / "constant" / "polyMesh")
    (case / "system").mkdir(parents=True, exist_ok=True)
    (case / "0").mkdir(parents=True, exist_ok=True)
    c = case / "constant"
    (c / "transportProperties").write_text(
        _header("dictionary", "transportProperties", "constant")
        + f"transportModel  Newtonian;\n\nnu              {nu:.6g};\n"
    )
    for obj in ("turbulenceProperties", "momentumTransport"):
        (c / obj).write_text(_header("dictionary", obj, "constant") + "simulationType  laminar;\n")
    s = case / "system"
    (s / "controlDict").write_text(
        _header("dictionary", "controlDict", "system")
        + "application     simpleFoam;\nstartFrom       startTime;\nstartTime       0;\n"
        "stopAt          endTime;\nendTime         2000;\ndeltaT          1;\n"
        "writeControl    timeStep;\nwriteInterval   500;\npurgeWrite      1;\n"
        "writeFormat     ascii;\nwritePrecision  10;\nrunTimeModifiable true;\n\n"
        "functions\n{\n    flux\n    {\n        type            surfaceFieldValue;\n"
        '        libs            ("libfieldFunctionObjects.so");\n'
        "        writeControl    timeStep;\n        writeInterval   50;\n"
        "        regionType      patch;\n        name            outlet;\n"
        "        writeFields     false;\n"
        "        operation       sum;\n        fields          (phi);\n    }\n}\n"
    )
    (s / "fvSchemes").write_text(
        _header("dictionary", "fvSchemes", "system")
        + "ddtSchemes      { default steadyState; }\ngradSchemes     { default Gauss linear; }\n"
        "divSchemes\n{\n    default         none;\n    div(phi,U)      bounded Gauss linearUpwind"
        " grad(U);\n    div((nuEff*dev2(T(grad(U))))) Gauss linear;\n}\n"
        "laplacianSchemes { default Gauss linear corrected; }\n"
        "interpolationSchemes { default linear; }\nsnGradSchemes   { default corrected; }\n"
    )
    (s / "fvSolution").write_text(
        _header("dictionary", "fvSolution", "system")
        + "solvers\n{\n    p\n    {\n        solver          GAMG;\n        smoother        "
        "GaussSeidel;\n        tolerance       1e-8;\n        relTol          0.05;\n    }\n"
        "    U\n    {\n        solver          smoothSolver;\n        smoother        "
        "symGaussSeidel;\n        tolerance       1e-10;\n        relTol          0.1;\n    }\n}\n"
        "\nSIMPLE\n{\n    nNonOrthogonalCorrectors 2;\n    consistent      yes;\n"
        "    residualControl { p 1e-6; U 1e-7; }\n}\n\nrelaxationFactors\n{\n"
        '    equations { U 0.9; ".*" 0.9; }\n}\n'
    )
    (case / "0" / "p").write_text(
        _header("volScalarField", "p", "0")
        + "dimensions      [0 2 -2 0 0 0 0];\n\ninternalField   uniform 0;\n\nboundaryField\n{\n"
        f"    inlet  {{ type fixedValue; value uniform {p_inlet:.6g}; }}\n"
        "    outlet { type fixedValue; value uniform 0; }\n"
        "    walls  { type zeroGradient; }\n    sides  { type symmetry; }\n}\n"
    )
    (case / "0" / "U").write_text(
        _header("volVectorField", "U", "0")
        + "dimensions      [0 1 -1 0 0 0 0];\n\ninternalField   uniform (0 0 0);\n\n"
        "boundaryField\n{\n"
        "    inlet  { type pressureInletOutletVelocity; value uniform (0 0 0); }\n"
        "    outlet { type pressureInletOutletVelocity; value uniform (0 0 0); }\n"
        "    walls  { type noSlip; }\n    sides  { type symmetry; }\n}\n"
    )
    lo, hi = pm.porous_region
    (case / "README.txt").write_text(
        "psdesign pore-space case for simpleFoam (laminar, creeping flow).\n"
        f"Flow direction: {pm.direction}; RVE proper between {pm.direction} = {lo:.6g} and "
        f"{hi:.6g} m (auxiliary zones outside).\n"
        f"Inlet kinematic pressure {p_inlet:.6g} m^2/s^2, outlet 0, nu = {nu:.6g} m^2/s.\n"
        "Permeability: K = nu * Q * L / (A * dp), Q = outlet flux (sum phi), A = RVE face area,\n"
        "dp = kinematic pressure drop between the RVE planes (sample p there, e.g. with a\n"
        "surfaceFieldValue over cutting planes), L = RVE length.\n"
        "Sides are 'symmetry' (slip); change to noSlip in 0/U for walled sides.\n"
    )
    return case
