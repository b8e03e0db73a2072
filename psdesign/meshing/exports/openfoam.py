"""Ready-to-run OpenFOAM case (constant/polyMesh, system/, 0/, ``Allrun``) for simpleFoam.

Patches: the boundary tags of :mod:`psdesign.meshing.tags`, as in every other export:
``inlet`` and ``outlet`` (fixed kinematic pressure), ``wall`` (no-slip fiber surfaces) and
``side_x0`` ... (the lateral box faces: ``symmetry`` with ``flow.sides = "slip"``, no-slip walls
with ``"noslip"``, as psdesign's own solve treats them). The case uses the spec's
viscosity and density (``nu = flow.viscosity / flow.density``, kinematic pressure drop
``flow.pressure_drop / flow.density``). Its function objects sample the area-averaged pressure
on the inlet and outlet patches, on the two RVE planes (cutting planes at the ends of
``porous_region``) and on :data:`PROFILE_LAYERS` + 1 equally spaced planes across the RVE, and
the flux through the inlet and outlet. ``./Allrun`` (with ``./Allrun gmsh``, after converting
``../pore.msh`` with ``gmshToFoam`` and typing its ``wall`` patch as a wall and the sides as
``flow.sides`` says) turns the tetrahedra into polyhedra with ``polyDualMesh`` (``./Allrun
tets`` keeps them: on tets OpenFOAM's K moves away from the analytic value on refinement, see
``docs/meshers.md``), runs ``checkMesh``, ``simpleFoam``, and prints ``K_windowed``: Darcy's K from
the sin^2-windowed drop of the plane profile, psdesign's
:func:`psdesign.flow.darcy.windowed_drop` (its ``pressure_drop_plane_window_pa``, the second
estimator of the windowed-dissipation drop that defines its K). It also prints the plain
``K_rve_planes = mu Q L / (A (p_start - p_end))`` (psdesign's ``pressure_drop_faces_pa``, see
:func:`openfoam_permeability`), which is ill-posed where fibres end on an RVE plane: the plane
average jumps there, and a cutting plane on a mesh node plane samples one side of it.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdesign.meshing import tags as T
from psdesign.meshing.exports import POLYMESH_FILES
from psdesign.meshing.exports._common import side_type
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
    """OpenFOAM patch name -> boundary triangles: one patch per boundary tag that has faces,
    named as the tag (:data:`psdesign.meshing.tags.BOUNDARY_TAGS` order; inlet, outlet and
    wall always)."""
    tags = pm.facet_tags
    empty = np.zeros((0, 3), dtype=np.int64)
    keep = (T.INLET, T.OUTLET, T.WALL)
    return {
        name: tags.get(name, empty)
        for name in T.BOUNDARY_TAGS
        if name in keep or len(tags.get(name, empty))
    }


def write_topology(pm: PoreMesh, topo: FaceTopology, poly: Path) -> None:
    """``points``, ``faces``, ``owner`` and ``neighbour`` of a polyMesh (``boundary`` is the
    caller's: patch types differ between the permeameter and the periodic case)."""
    poly.mkdir(parents=True, exist_ok=True)
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


def write_tet_copy(case: Path) -> None:
    """Copy the exported ``constant/polyMesh`` into ``constant/polyMesh.tet``, the tets every
    Allrun starts from (:data:`CELLS_LINES`). Written (and listed in the output marker) by the
    export itself, so a re-export replaces it: a copy made by an earlier ``./Allrun`` was left
    holding the old mesh, which the next Allrun copied over the new one (session 52, I/O
    review finding 1)."""
    poly, tet = case / "constant" / "polyMesh", case / "constant" / "polyMesh.tet"
    tet.mkdir(parents=True, exist_ok=True)
    for name in POLYMESH_FILES:
        (tet / name).write_bytes((poly / name).read_bytes())


def write_constants_and_fields(case: Path, nu: float, boundary: dict[str, str]) -> None:
    """``constant/`` (laminar, Newtonian ``nu``) and ``0/p``, ``0/U`` at rest with the
    ``boundaryField`` entries ``boundary[name]`` (``"p"``, ``"U"``)."""
    const = case / "constant"
    (case / "0").mkdir(parents=True, exist_ok=True)
    const.mkdir(parents=True, exist_ok=True)
    (const / "transportProperties").write_text(
        _header("dictionary", "transportProperties", "constant")
        + f"transportModel  Newtonian;\n\nnu              {nu:.10g};\n"
    )
    for obj in ("turbulenceProperties", "momentumTransport"):
        (const / obj).write_text(
            _header("dictionary", obj, "constant") + "simulationType  laminar;\n"
        )
    for name, cls, dim, init in (
        ("p", "volScalarField", "[0 2 -2 0 0 0 0]", "0"),
        ("U", "volVectorField", "[0 1 -1 0 0 0 0]", "(0 0 0)"),
    ):
        (case / "0" / name).write_text(
            _header(cls, name, "0")
            + f"dimensions      {dim};\n\ninternalField   uniform {init};\n\n"
            + "boundaryField\n{\n"
            + boundary[name]
            + "}\n"
        )


def write_polymesh(pm: PoreMesh, poly: Path, flow: dict | None = None) -> FaceTopology:
    """Write points/faces/owner/neighbour/boundary into ``poly``; returns the topology.
    ``flow.sides`` types the side patches (:func:`side_type`)."""
    topo = face_topology(pm.points, pm.tets, openfoam_patches(pm))
    write_topology(pm, topo, poly)
    loc = "constant/polyMesh"
    types = {T.INLET: "patch", T.OUTLET: "patch", T.WALL: "wall"}  # values: format keywords
    lines = [_header("polyBoundaryMesh", "boundary", loc), f"{len(topo.patch_names)}\n(\n"]
    for name, start, size in zip(topo.patch_names, topo.patch_start, topo.patch_size, strict=True):
        types.setdefault(name, side_type(flow))
        is_wall = types[name] == "wall"  # format keyword, not a tag
        extra = "        inGroups    List<word> 1(wall);\n" if is_wall else ""
        lines.append(
            f"    {name}\n    {{\n        type        {types[name]};\n{extra}"
            f"        nFaces      {size};\n        startFace   {start};\n    }}\n"
        )
    lines.append(")\n")
    (poly / "boundary").write_text("".join(lines))
    return topo


#: Density used when the spec has no ``flow.density`` (air at 20 C, kg/m^3).
DEFAULT_DENSITY = 1.2


def _patch_bc(field: str, p_inlet: float, flow: dict | None) -> str:
    """``boundaryField`` entries of ``0/p`` or ``0/U``. The keys are the tag names of
    :mod:`psdesign.meshing.tags` (the direct polyMesh and gmshToFoam name the patches alike);
    the sides follow ``flow.sides`` (symmetry planes for slip, no-slip walls)."""
    sides = f'"{T.SIDE_PREFIX}.*"'
    slip = side_type(flow) == "symmetry"
    if field == "p":
        side = "symmetry" if slip else "zeroGradient"
        return (
            f"    {T.INLET}  {{ type fixedValue; value uniform {p_inlet:.10g}; }}\n"
            f"    {T.OUTLET} {{ type fixedValue; value uniform 0; }}\n"
            f"    {T.WALL} {{ type zeroGradient; }}\n    {sides} {{ type {side}; }}\n"
        )
    inout = "type pressureInletOutletVelocity; value uniform (0 0 0);"
    side = "symmetry" if slip else "noSlip"
    return (
        f"    {T.INLET}  {{ {inout} }}\n    {T.OUTLET} {{ {inout} }}\n"
        f"    {T.WALL} {{ type noSlip; }}\n    {sides} {{ type {side}; }}\n"
    )


_FV_SCHEMES = _header("dictionary", "fvSchemes", "system") + (
    "ddtSchemes      { default steadyState; }\ngradSchemes     { default Gauss linear; }\n"
    "divSchemes\n{\n    default         none;\n    div(phi,U)      bounded Gauss linearUpwind"
    " grad(U);\n    div((nuEff*dev2(T(grad(U))))) Gauss linear;\n}\n"
    "laplacianSchemes { default Gauss linear corrected; }\n"
    "interpolationSchemes { default linear; }\nsnGradSchemes   { default corrected; }\n"
)

_FV_SOLUTION = _header("dictionary", "fvSolution", "system") + (
    "solvers\n{\n    p\n    {\n        solver          GAMG;\n        smoother        "
    "GaussSeidel;\n        tolerance       1e-8;\n        relTol          0.05;\n    }\n"
    "    U\n    {\n        solver          smoothSolver;\n        smoother        "
    "symGaussSeidel;\n        tolerance       1e-10;\n        relTol          0.1;\n    }\n}\n"
    "\nSIMPLE\n{\n    nNonOrthogonalCorrectors 2;\n    consistent      yes;\n"
    "    residualControl { p 1e-6; U 1e-7; }\n}\n\nrelaxationFactors\n{\n"
    '    equations { U 0.9; ".*" 0.9; }\n}\n'
)


def _patch_fo(name: str, patch: str, operation: str, field: str) -> str:
    return (
        f"    {name}\n    {{\n        type            surfaceFieldValue;\n"
        '        libs            ("libfieldFunctionObjects.so");\n'
        "        writeControl    timeStep;\n        writeInterval   50;\n"
        f"        regionType      patch;\n        name            {patch};\n"
        "        writeFields     false;\n        log             false;\n"
        f"        operation       {operation};\n        fields          ({field});\n    }}\n"
    )


def _plane_fo(name: str, point: np.ndarray, axis: int) -> str:
    # interpolate false: cell values (on a mesh node plane, the cells on one side of it).
    # interpolate true (point-interpolated values) is unusable with Debian's OpenFOAM 1912:
    # surfaceFieldValue then averaged garbage (p ~ 1e250 on the one-fibre case, session 34).
    normal = " ".join("1" if a == axis else "0" for a in range(3))
    pt = " ".join(f"{v:.12g}" for v in point)
    return (
        f"    {name}\n    {{\n        type            surfaceFieldValue;\n"
        '        libs            ("libfieldFunctionObjects.so");\n'
        "        writeControl    timeStep;\n        writeInterval   50;\n"
        f"        regionType      sampledSurface;\n        name            {name};\n"
        "        sampledSurfaceDict\n        {\n            type        cuttingPlane;\n"
        "            planeType   pointAndNormal;\n"
        f"            pointAndNormalDict {{ point ({pt}); normal ({normal}); }}\n"
        "            interpolate false;\n        }\n"
        "        writeFields     false;\n        log             false;\n"
        "        operation       areaAverage;\n        fields          (p);\n    }\n"
    )


def _rve_plane_points(pm: PoreMesh) -> tuple[np.ndarray, np.ndarray]:
    """A point on each RVE plane (box centre moved to ``porous_region``'s ends)."""
    ax = pm.axis
    centre = np.asarray(pm.bounds, dtype=float).mean(axis=0)
    a, b = centre.copy(), centre.copy()
    a[ax], b[ax] = pm.porous_region
    return a, b


#: Layers of the plane-pressure profile across the RVE whose windowed drop ``./Allrun`` prints
#: as ``K_windowed``: psdesign's :data:`psdesign.flow.fem.PLANE_PROFILE_LAYERS` (one period).
PROFILE_LAYERS = 60


def profile_plane_points(pm: PoreMesh, layers: int = PROFILE_LAYERS) -> np.ndarray:
    """A point on each of the ``layers + 1`` equally spaced profile planes ``pProfile0`` ...
    across the RVE (the first and last on the RVE planes)."""
    a, b = _rve_plane_points(pm)
    return a + np.linspace(0.0, 1.0, layers + 1)[:, None] * (b - a)


def _control_dict(pm: PoreMesh) -> str:
    a, b = _rve_plane_points(pm)
    fos = (
        _patch_fo("pInlet", T.INLET, "areaAverage", "p")
        + _patch_fo("pOutlet", T.OUTLET, "areaAverage", "p")
        + _patch_fo("fluxInlet", T.INLET, "sum", "phi")
        + _patch_fo("flux", T.OUTLET, "sum", "phi")
        + _plane_fo("pRveStart", a, pm.axis)
        + _plane_fo("pRveEnd", b, pm.axis)
        + "".join(
            _plane_fo(f"pProfile{k}", pt, pm.axis) for k, pt in enumerate(profile_plane_points(pm))
        )
    )
    return control_dict(2000, 500, fos)


def control_dict(end: int, every: int, functions: str) -> str:
    """``system/controlDict`` of a steady simpleFoam run of ``end`` iterations, written every
    ``every``, with the function objects ``functions``."""
    return (
        _header("dictionary", "controlDict", "system")
        + "application     simpleFoam;\nstartFrom       startTime;\nstartTime       0;\n"
        f"stopAt          endTime;\nendTime         {end};\ndeltaT          1;\n"
        f"writeControl    timeStep;\nwriteInterval   {every};\npurgeWrite      1;\n"
        "writeFormat     ascii;\nwritePrecision  10;\nrunTimeModifiable true;\n\n"
        f"functions\n{{\n{functions}}}\n"
    )


def write_script(path: Path, template: str, values: dict[str, float]) -> None:
    """An executable script from ``template`` with each ``@KEY@`` replaced by its value,
    ``@CONVERGED@`` by :data:`CONVERGED_LINE` and ``@CELLS@`` by :data:`CELLS_LINES`."""
    template = template.replace("@CONVERGED@", CONVERGED_LINE).replace("@CELLS@\n", CELLS_LINES)
    for key, val in values.items():
        template = template.replace(f"@{key}@", f"{val:.12g}")
    path.write_text(template)
    path.chmod(0o755)


def case_constants(pm: PoreMesh, flow: dict | None = None) -> dict[str, float]:
    """Viscosity, density, kinematic quantities and RVE geometry of the exported case.

    ``mu`` = ``flow.viscosity`` (default 1.8e-5 Pa s), ``rho`` = ``flow.density`` (default
    :data:`DEFAULT_DENSITY`), ``nu = mu / rho``, ``p_inlet`` = ``flow.pressure_drop / rho``
    (kinematic, m^2/s^2), ``length`` = RVE length along the flow, ``area`` = cross-section.
    """
    flow = flow or {}
    mu = float(flow.get("viscosity") or 1.8e-5)
    rho = float(flow.get("density") or DEFAULT_DENSITY)
    dp = float(flow.get("pressure_drop") or 1.0)
    lo, hi = pm.porous_region
    extent = np.ptp(np.asarray(pm.bounds, dtype=float), axis=0)
    area = float(np.prod(np.delete(extent, pm.axis)))
    return {
        "mu": mu,
        "rho": rho,
        "nu": mu / rho,
        "p_inlet": dp / rho,
        "length": float(hi - lo),
        "area": area,
        "box_length": float(extent[pm.axis]),
    }


def openfoam_permeability(c: dict[str, float], q: float, p_start: float, p_end: float) -> float:
    """K (m^2) from the sampled OpenFOAM values, the definition ``./Allrun`` prints.

    ``K = nu Q L / (A (p_start - p_end))`` with the kinematic pressures averaged over the RVE
    planes: the same as ``mu Q L / (A dp)`` with the static pressures (psdesign's
    ``pressure_drop_faces_pa``).
    """
    return c["nu"] * abs(q) * c["length"] / (c["area"] * (p_start - p_end))


CELLS_LINES = """[ -d constant/polyMesh.tet ] || cp -r constant/polyMesh constant/polyMesh.tet
rm -rf constant/polyMesh
cp -r constant/polyMesh.tet constant/polyMesh
if [ "$cells" = dual ]; then
    polyDualMesh -overwrite 70 > log.polyDualMesh 2>&1 ||
        { echo "polyDualMesh failed: see log.polyDualMesh"; exit 1; }
    rm -f ./*.obj   # polyDualMesh's feature dumps
fi
echo "cells: $cells"
"""
"""Shell lines of every Allrun before ``checkMesh``: psdesign's tets are kept in
``constant/polyMesh.tet`` (written by the export, :func:`write_tet_copy`; a second run starts
from them again) and, with ``$cells`` = ``dual``,
turned into their polyhedral dual (``polyDualMesh``, feature angle 70 degrees: one cell per
mesh vertex); ``$cells`` = ``tets`` solves on the tets themselves (docs/meshers.md)."""


CONVERGED_LINE = r"""n=$(awk '/solution converged in/ {n = $5} END {print n}' log.simpleFoam)
if [ -n "$n" ]; then
    echo "converged: yes (SIMPLE residualControl met in $n iterations)"
else
    echo "converged: NO (residualControl not met by endTime): the K below is not final;" \
        "raise endTime in system/controlDict and run again"
fi"""
"""Shell lines every Allrun runs after ``simpleFoam``: its convergence flag, from the log
(``residualControl`` stops a converged run early with "SIMPLE solution converged in N
iterations"; a run that reaches ``endTime`` has no such line and its K is not final: the
57 k-tet one-cylinder case needed 3 828 of the 2 000 iterations, K 0.2 % low, session 34)."""


_ALLRUN = r"""#!/bin/sh
# psdesign OpenFOAM case: checkMesh + simpleFoam, then K by Darcy's law.
#
# K_windowed (compare with psdesign's K of this one-copy case: flow.permeameter_copies = 1, its
#   drop pressure_drop_plane_window_pa; the K psdesign reports by default takes the
#   windowed-dissipation drop on the 'auto' stack of copies, another sample):
#   K = nu Q L / (A dp_w), dp_w = n sum_k w_k (F_k - F_k+1) / sum_k w_k, w_k = sin^2(pi (k+1/2)/n)
#   F_0 ... F_n = area-averaged kinematic pressure on n + 1 = @NP@ equally spaced planes across the
#   RVE (pProfile0 ... ; the first and last on the RVE planes), Q = |flux through the outlet|
#   (sum of phi, m^3/s), A = RVE cross-section, L = RVE length, nu = mu / rho.
#   psdesign's windowed drop of its plane-pressure profile (psdesign.flow.darcy.windowed_drop,
#   pressure_drop_plane_window_pa), the second estimator of its windowed-dissipation drop: the
#   window vanishes at the RVE planes, so the entrance and exit losses drop out and so does
#   the jump of the plane average there (a fibre crossing an RVE plane ends on it: the cut
#   loses the fibre's end face from one side to the other).
# K_rve_planes (plain): the same with dp = p_start - p_end, the averages on the RVE planes
#   themselves (psdesign's pressure_drop_faces_pa). A cutting plane on a mesh node plane samples
#   the cells on one side of it, and the average jumps across an RVE plane where fibres end:
#   moving one plane by 1e-10 m moved this K by about 6 % on a 7 050-tet one-fibre mesh.
# Cells: psdesign's tetrahedra are turned into polyhedra (polyDualMesh, one cell per mesh
#   vertex) before simpleFoam. On the tets themselves OpenFOAM's K does not converge: one
#   cylinder along z (Drummond & Tahir 2.0819e-10 m^2) gave -5.1 / -8.2 / -8.2 % at 7 050 /
#   18 914 / 56 930 tets (linear interpolation to skewed tet faces is inconsistent); the dual
#   of the same meshes gave +12.2 / +3.2 / +1.9 % (docs/meshers.md, session 35).
# Usage: ./Allrun          (the polyMesh written by psdesign, as polyhedra)
#        ./Allrun gmsh     (gmshToFoam on ../pore.msh, written by psdesign mesh --format msh;
#                           wall, side_* typed as in polyMesh; a failed conversion keeps the
#                           case's mesh)
#        ./Allrun tets     (psdesign's tetrahedra as they are; also ./Allrun gmsh tets)
# psdesign's (or gmshToFoam's) tet mesh is kept in constant/polyMesh.tet: a second run starts
# from it again.
cd "$(dirname "$0")" || exit 1
if [ -z "$WM_PROJECT_DIR" ] && [ -d /usr/share/openfoam ]; then
    export WM_PROJECT_DIR=/usr/share/openfoam   # Debian's openfoam package
fi
set -e
route=polymesh; cells=dual
for arg in "$@"; do
    case $arg in
        gmsh) route=gmsh ;;
        tets) cells=tets ;;
        *) echo "Allrun: unknown argument '$arg' (allowed: gmsh, tets)"; exit 2 ;;
    esac
done
# an interrupted ./Allrun gmsh left the case's mesh in *.keep and a half-converted one in its
# place: every route puts the case's mesh back first
for d in polyMesh polyMesh.tet; do
    if [ -d "constant/$d.keep" ]; then rm -rf "constant/$d"; mv "constant/$d.keep" "constant/$d"; fi
done
if [ "$route" = gmsh ]; then
    [ -f ../pore.msh ] || { echo "Allrun gmsh: ../pore.msh not found (export it with" \
        "psdesign mesh ... --format msh openfoam); the case's mesh is left as it was"; exit 2; }
    # the case's meshes wait in *.keep until the conversion succeeded
    for d in polyMesh polyMesh.tet; do
        if [ -d "constant/$d" ]; then mv "constant/$d" "constant/$d.keep"; fi
    done
    restore() {
        for d in polyMesh polyMesh.tet; do
            rm -rf "constant/$d"
            if [ -d "constant/$d.keep" ]; then mv "constant/$d.keep" "constant/$d"; fi
        done
    }
    gmshToFoam ../pore.msh > log.gmshToFoam 2>&1 || { restore
        echo "gmshToFoam failed: see log.gmshToFoam (the case's mesh is left as it was)"; exit 1; }
    changeDictionary > log.changeDictionary 2>&1 || { restore
        echo "changeDictionary failed: see log.changeDictionary (the case's mesh is left as" \
            "it was)"; exit 1; }
    rm -rf constant/polyMesh.keep constant/polyMesh.tet.keep
fi
@CELLS@
checkMesh > log.checkMesh 2>&1 || { echo "checkMesh failed: see log.checkMesh"; exit 1; }
simpleFoam > log.simpleFoam 2>&1 || { echo "simpleFoam failed: see log.simpleFoam"; exit 1; }
@CONVERGED@
last() {
    # a re-run writes surfaceFieldValue_0.dat beside the earlier run's file: the newest one
    f=$(ls -t "$(ls -d postProcessing/"$1"/*/ | tail -n 1)"surfaceFieldValue*.dat | head -n 1)
    tail -n 1 "$f" | awk '{print $2}'
}
Q=$(last flux); PS=$(last pRveStart); PE=$(last pRveEnd); PI=$(last pInlet); PO=$(last pOutlet)
PROF=""; k=0
while [ "$k" -lt @NP@ ]; do PROF="$PROF $(last "pProfile$k")"; k=$((k + 1)); done
awk -v q="$Q" -v ps="$PS" -v pe="$PE" -v pi="$PI" -v po="$PO" -v prof="$PROF" \
    -v nu=@NU@ -v rho=@RHO@ -v L=@L@ -v A=@A@ -v LB=@LB@ 'BEGIN {
    if (q < 0) q = -q
    n = split(prof, f, " ") - 1; sw = 0; s = 0
    for (k = 0; k < n; k++) {
        w = sin(atan2(0, -1) * (k + 0.5) / n)^2; sw += w; s += w * (f[k+1] - f[k+2])
    }
    dw = n * s / sw
    printf "Q = %.6e m^3/s  dp_rve = %.6e Pa  dp_patches = %.6e Pa\n", q, rho*(ps-pe), rho*(pi-po)
    printf "dp_windowed = %.6e Pa\n", rho*dw
    printf "K_windowed = %.6e m^2\n", nu*q*L/(A*dw)
    printf "K_rve_planes = %.6e m^2\n", nu*q*L/(A*(ps-pe))
    printf "K_patches (whole box incl. auxiliary zones) = %.6e m^2\n", nu*q*LB/(A*(pi-po))
}'
"""


def _change_dict(flow: dict | None) -> str:
    """``changeDictionaryDict`` of the gmsh route: gmshToFoam makes every physical surface a
    plain patch; type the wall and the sides (``flow.sides``) as the direct polyMesh does.

    The ``boundary`` replacement is written twice: at the top level, where OpenFOAM.com's
    ``changeDictionary`` (Debian's ``openfoam`` 1912) reads it (``etc/caseDicts/annotated/
    changeDictionaryDict``), and inside ``dictionaryReplacement``, where the older OpenFOAM.org
    releases read it. Each reads its own and passes over the other (1912 warns that no field
    ``dictionaryReplacement`` exists). Only the wrapped one was written: 1912 left every patch
    a plain ``patch`` and simpleFoam refused the ``symmetry`` sides (``./Allrun gmsh`` failed
    with the default ``flow.sides = "slip"``)."""
    side = side_type(flow)
    boundary = (
        "boundary\n{\n"
        f"    {T.WALL} {{ type wall; inGroups List<word> 1(wall); }}\n"
        f'    "{T.SIDE_PREFIX}.*" {{ type {side}; inGroups List<word> 1({side}); }}\n'
        "}\n"
    )
    wrapped = "".join(f"    {line}\n" for line in boundary.splitlines())
    return boundary + "\ndictionaryReplacement\n{\n" + wrapped + "}\n"


def _write_allrun(case: Path, c: dict[str, float], flow: dict | None = None) -> None:
    values = {"NU": c["nu"], "RHO": c["rho"], "L": c["length"], "A": c["area"]}
    extra = {"LB": c["box_length"], "NP": PROFILE_LAYERS + 1}
    write_script(case / "Allrun", _ALLRUN, values | extra)
    (case / "system" / "changeDictionaryDict").write_text(
        _header("dictionary", "changeDictionaryDict", "system") + _change_dict(flow)
    )


def write_openfoam_case(
    pm: PoreMesh,
    case: Path,
    p_inlet: float | None = None,
    nu: float | None = None,
    flow: dict | None = None,
) -> Path:
    """Write a simpleFoam case (laminar Stokes-regime flow driven by a kinematic pressure drop).

    Parameters
    ----------
    pm
        The mesh.
    case
        Case folder (created).
    p_inlet
        Inlet kinematic pressure in m^2/s^2 (outlet 0); default ``flow.pressure_drop /
        flow.density``. With the defaults (1 Pa, 1.2 kg/m^3, 1.8e-5 Pa s) Re = u d / nu ~ 1e-3
        for GDL-like media (creeping flow, Darcy regime).
    nu
        Kinematic viscosity in m^2/s; default ``flow.viscosity / flow.density``.
    flow
        The spec's ``[flow]`` table (``viscosity``, ``density``, ``pressure_drop``).

    Returns
    -------
    Path
        The case folder.
    """
    case = Path(case)
    c = case_constants(pm, flow)
    if nu is not None:
        c["nu"] = float(nu)
        c["rho"] = c["mu"] / c["nu"]
    if p_inlet is not None:
        c["p_inlet"] = float(p_inlet)
    write_polymesh(pm, case / "constant" / "polyMesh", flow)
    write_tet_copy(case)
    (case / "system").mkdir(parents=True, exist_ok=True)
    bcs = {f: _patch_bc(f, c["p_inlet"], flow) for f in ("p", "U")}
    write_constants_and_fields(case, c["nu"], bcs)
    s = case / "system"
    (s / "controlDict").write_text(_control_dict(pm))
    (s / "fvSchemes").write_text(_FV_SCHEMES)
    (s / "fvSolution").write_text(_FV_SOLUTION)
    _write_allrun(case, c, flow)
    lo, hi = pm.porous_region
    (case / "README.txt").write_text(
        "psdesign pore-space case for simpleFoam (laminar, creeping flow). Run ./Allrun.\n"
        f"Flow direction: {pm.direction}; RVE proper between {pm.direction} = {lo:.6g} and "
        f"{hi:.6g} m (auxiliary zones outside).\n"
        f"mu = {c['mu']:.6g} Pa s, rho = {c['rho']:.6g} kg/m^3, nu = {c['nu']:.6g} m^2/s; inlet "
        f"kinematic pressure {c['p_inlet']:.6g} m^2/s^2, outlet 0.\n"
        "Permeability (printed by ./Allrun): K = nu * Q * L / (A * dp), Q = outlet flux\n"
        "(sum phi), A = RVE face area, L = RVE length. K_windowed (compare with psdesign's K\n"
        "of this one-copy case: flow.permeameter_copies = 1, from its\n"
        "pressure_drop_plane_window_pa; its default K takes the windowed-dissipation drop on\n"
        "the 'auto' stack of copies):\n"
        "dp = sin^2-windowed drop of the area-averaged kinematic pressure on "
        f"{PROFILE_LAYERS + 1} planes\n"
        "across the RVE (postProcessing/pProfile*), psdesign's windowed_drop. K_rve_planes:\n"
        "dp between the RVE planes themselves (pRveStart, pRveEnd; sensitive to the side of\n"
        "a plane its cut samples where fibres end on it).\n"
        "Cells: ./Allrun solves on the polyhedral dual of psdesign's tetrahedra (polyDualMesh;\n"
        "the tets are kept in constant/polyMesh.tet); ./Allrun tets solves on the tets.\n"
        "./Allrun gmsh converts ../pore.msh with gmshToFoam instead: it needs the export's\n"
        "--format msh (psdesign mesh ... --format msh openfoam).\n"
        + (
            "Sides (side_*) are symmetry planes (flow.sides = slip).\n"
            if side_type(flow) == "symmetry"
            else "Sides (side_*) are no-slip walls (flow.sides = noslip).\n"
        )
    )
    return case
