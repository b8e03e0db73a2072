"""OpenFOAM case of a periodic mesh (``flow.bc = "periodic"``): cyclic patches, a pressure jump.

The box faces become three pairs of ``cyclic`` patches (translational, the RVE's edge apart):
``inlet`` / ``outlet`` along the flow and ``side_<a>0`` / ``side_<a>1`` across it, the faces of
each pair listed in matching order (the periodic mesh has identical vertices on opposite faces,
:attr:`psdesign.meshing.result.PoreMesh.periodic_pairs`). The flow is driven by a ``fixedJump``
of the kinematic pressure across the ``inlet`` / ``outlet`` pair (``flow.pressure_drop /
flow.density`` over one RVE length: the mean gradient of psdesign's periodic solve); ``wall`` is
no-slip. ``./Allrun`` turns the tetrahedra into their polyhedral dual (``polyDualMesh``, as
the permeameter case's Allrun: :data:`~psdesign.meshing.exports.openfoam.CELLS_LINES`;
``./Allrun tets`` keeps them), runs ``checkMesh`` and ``simpleFoam`` and prints
``K = nu Q L / (A dp)`` with ``Q`` the flux through ``inlet``, ``L`` the box length along the
flow, ``A`` its cross-section and ``dp`` the jump: the definition of psdesign's periodic K.
On the tets OpenFOAM's K moves away from the analytic value on refinement, on the dual it
converges to it (docs/meshers.md, session 36).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdesign.meshing import tags as T
from psdesign.meshing.exports._common import periodic_faces
from psdesign.meshing.exports.openfoam import (
    _FV_SCHEMES,
    _header,
    _patch_fo,
    case_constants,
    control_dict,
    write_constants_and_fields,
    write_script,
    write_tet_copy,
    write_topology,
)
from psdesign.meshing.topology import FaceTopology, face_keys, face_topology

if TYPE_CHECKING:
    from psdesign.meshing.result import PoreMesh


def _partner(n_points: int, pairs: np.ndarray) -> np.ndarray:
    """Vertex index -> its partner on the high face (-1 off the low face)."""
    partner = np.full(n_points, -1, dtype=np.int64)
    partner[pairs[:, 0]] = pairs[:, 1]
    return partner


def matched_faces(pm: PoreMesh, low: str, high: str, partner: np.ndarray) -> np.ndarray:
    """The ``high`` patch's triangles in the order of the ``low`` patch's: triangle ``i`` of
    each is the same face, one period apart (``partner``: :func:`_partner`).

    Raises
    ------
    ValueError
        When a face has no partner (not a periodic mesh along that axis).
    """
    lo_tri, hi_tri = pm.facet_tags[low], pm.facet_tags[high]
    mapped = partner[lo_tri]
    if (mapped < 0).any() or len(lo_tri) != len(hi_tri):
        raise ValueError(f"{low} / {high}: the faces are not periodic partners")
    want, have = face_keys(mapped, len(pm.points)), face_keys(hi_tri, len(pm.points))
    order = np.argsort(have)
    pos = np.minimum(np.searchsorted(have[order], want), len(have) - 1)
    if not (have[order][pos] == want).all():
        raise ValueError(f"{low} / {high}: the faces are not periodic partners")
    return hi_tri[order[pos]]


def _couple_vertices(topo: FaceTopology, low: str, high: str, partner: np.ndarray) -> None:
    """Write each ``high`` face as its ``low`` partner's vertices, translated, in reverse order
    from the same 0th vertex: OpenFOAM's convention for coupled faces (checkMesh: "0th or
    consecutive vertex not opposite their coupled equivalent" otherwise). Reversed, the
    partner's normal points out of the high face's own cell."""
    start = dict(zip(topo.patch_names, topo.patch_start, strict=True))
    size = dict(zip(topo.patch_names, topo.patch_size, strict=True))
    a = topo.faces[start[low] : start[low] + size[low]]
    b = slice(start[high], start[high] + size[high])
    mapped = partner[a][:, [0, 2, 1]]
    if not np.array_equal(np.sort(mapped, axis=1), np.sort(topo.faces[b], axis=1)):
        raise ValueError(f"{low} / {high}: the faces are not periodic partners")
    topo.faces[b] = mapped


def write_cyclic_polymesh(pm: PoreMesh, poly: Path) -> dict[str, int]:
    """points/faces/owner/neighbour/boundary with the cyclic patches (the three pairs of
    :func:`~psdesign.meshing.exports._common.periodic_faces`); returns nFaces per patch."""
    links = periodic_faces(pm)
    if len(links) != 3:
        raise ValueError("the OpenFOAM periodic case needs a mesh periodic along x, y and z")
    partners = {low: _partner(len(pm.points), pairs) for low, _, _, pairs, _ in links}
    patches = {T.WALL: pm.facet_tags[T.WALL]}
    for low, high, _, _, _ in links:
        patches[low] = pm.facet_tags[low]
        patches[high] = matched_faces(pm, low, high, partners[low])
    topo = face_topology(pm.points, pm.tets, patches)
    for low, high, _, _, _ in links:
        _couple_vertices(topo, low, high, partners[low])
    write_topology(pm, topo, poly)
    loc = "constant/polyMesh"
    partner = {}
    for low, high, ax, _, edge in links:
        sep = np.zeros(3)
        sep[ax] = edge
        partner[low], partner[high] = (high, sep), (low, -sep)
    lines = [_header("polyBoundaryMesh", "boundary", loc), f"{len(topo.patch_names)}\n(\n"]
    for name, start, size in zip(topo.patch_names, topo.patch_start, topo.patch_size, strict=True):
        if name == T.WALL:
            body = "        type        wall;\n        inGroups    List<word> 1(wall);\n"
        else:
            nbr, sep = partner[name]
            body = (
                "        type        cyclic;\n        inGroups    List<word> 1(cyclic);\n"
                f"        neighbourPatch {nbr};\n        transform   translational;\n"
                f"        separationVector ({sep[0]:.12g} {sep[1]:.12g} {sep[2]:.12g});\n"
                "        matchTolerance 1e-4;\n"
            )
        lines.append(f"    {name}\n    {{\n{body}        nFaces      {size};\n")
        lines.append(f"        startFace   {start};\n    }}\n")
    lines.append(")\n")
    (poly / "boundary").write_text("".join(lines))
    return dict(zip(topo.patch_names, topo.patch_size, strict=True))


def _fields(drop: float) -> dict[str, str]:
    """``0/p`` and ``0/U`` boundary entries: cyclic everywhere, the jump on the flow pair.

    OpenFOAM reads the jump of the owner patch (``inlet``, listed first) as the pressure on
    its neighbour side minus its own: ``-drop`` makes the pressure fall from inlet to outlet
    and the flow run from inlet to outlet (measured: ``+drop`` gave a positive flux out
    through ``inlet``); the neighbour's entry is its negative, as OpenFOAM derives it."""
    p = (
        f"    {T.WALL} {{ type zeroGradient; }}\n"
        f'    "({T.SIDE_PREFIX}.*)" {{ type cyclic; }}\n'
        f"    {T.INLET} {{ type fixedJump; patchType cyclic; jump uniform {-drop:.10g}; "
        "value uniform 0; }\n"
        f"    {T.OUTLET} {{ type fixedJump; patchType cyclic; jump uniform {drop:.10g}; "
        "value uniform 0; }\n"
    )
    cyclic = f"({T.INLET}|{T.OUTLET}|{T.SIDE_PREFIX}.*)"
    u = f'    {T.WALL} {{ type noSlip; }}\n    "{cyclic}" {{ type cyclic; }}\n'
    return {"p": p, "U": u}


#: Plain SIMPLE with under-relaxation (U 0.7, p 0.3): the permeameter case's SIMPLEC at 0.9
#: diverged on the fully periodic cell (continuity errors 1e33 by iteration 237, a 16^3 tet
#: mesh of a cylinder array); this converged in 1486 iterations. No non-orthogonal
#: correctors: on the polyhedral dual of the one-fibre cell (4 um, 1 363 cells) two of them
#: diverged (floating point exception at iteration 272) and one later (458), blowing up where
#: the fibre crosses the cyclic inlet / outlet, at the dual's 5 faces above 70 degrees (two
#: half cells of 1.9e-19 and 2.7e-19 m^3, the median 4e-17). Lagged to the next iteration
#: instead (and damped by the relaxation), the same case converged in 694 iterations. On the
#: tets the converged K is unchanged (the correction's fixed point is the same: 1.974614e-10
#: m^2 and 2 561 iterations either way; benchmarks/RESULTS.md, session 36).
_FV_SOLUTION = _header("dictionary", "fvSolution", "system") + (
    "solvers\n{\n    p\n    {\n        solver          GAMG;\n        smoother        "
    "GaussSeidel;\n        tolerance       1e-9;\n        relTol          0.05;\n    }\n"
    "    U\n    {\n        solver          smoothSolver;\n        smoother        "
    "symGaussSeidel;\n        tolerance       1e-11;\n        relTol          0.1;\n    }\n}\n"
    "\nSIMPLE\n{\n    nNonOrthogonalCorrectors 0;\n    consistent      no;\n"
    "    pRefCell        0;\n    pRefValue       0;\n"
    "    residualControl { p 1e-6; U 1e-7; }\n}\n\nrelaxationFactors\n{\n"
    "    equations { U 0.7; }\n    fields { p 0.3; }\n}\n"
)

_ALLRUN = r"""#!/bin/sh
# psdesign OpenFOAM case of a PERIODIC mesh: checkMesh + simpleFoam, then K by Darcy's law.
#   K = nu Q L / (A dp): Q = |flux through the inlet patch| (m^3/s), L = box length along the
#   flow, A = box cross-section, dp = the kinematic pressure jump across the cyclic inlet/outlet
#   pair (the mean gradient dp / L of psdesign's periodic solve); nu = mu / rho.
# Cells: psdesign's tetrahedra are turned into polyhedra (polyDualMesh, one cell per mesh
#   vertex; the cyclic faces stay matched) before simpleFoam. On the tets OpenFOAM's K does not
#   converge: one cylinder along z (radius 5 um, 40 um cell, Drummond & Tahir 2.0819e-10 m^2)
#   gave -5.2 / -7.8 % at 5 866 / 16 506 tets (4 / 2.83 um); the dual of the same meshes gave
#   +9.0 / +3.4 / +2.3 % (1 363 / 3 574 / 9 499 cells, 2 um the third; docs/meshers.md).
# Usage: ./Allrun          (the polyMesh written by psdesign, as polyhedra)
#        ./Allrun tets     (psdesign's tetrahedra as they are)
# psdesign's tet mesh is kept in constant/polyMesh.tet: a second run starts from it again.
cd "$(dirname "$0")" || exit 1
if [ -z "$WM_PROJECT_DIR" ] && [ -d /usr/share/openfoam ]; then
    export WM_PROJECT_DIR=/usr/share/openfoam   # Debian's openfoam package
fi
set -e
cells=dual
for arg in "$@"; do
    case $arg in
        tets) cells=tets ;;
        *) echo "Allrun: unknown argument '$arg' (allowed: tets)"; exit 2 ;;
    esac
done
@CELLS@
checkMesh > log.checkMesh 2>&1 || { echo "checkMesh failed: see log.checkMesh"; exit 1; }
simpleFoam > log.simpleFoam 2>&1 || { echo "simpleFoam failed: see log.simpleFoam"; exit 1; }
@CONVERGED@
# a re-run writes surfaceFieldValue_0.dat beside the earlier run's file: the newest one
f=$(ls -t "$(ls -d postProcessing/fluxInlet/*/ | tail -n 1)"surfaceFieldValue*.dat | head -n 1)
Q=$(tail -n 1 "$f" | awk '{print $2}')
awk -v q="$Q" -v nu=@NU@ -v rho=@RHO@ -v L=@L@ -v A=@A@ -v dp=@DP@ 'BEGIN {
    if (q < 0) q = -q
    printf "Q = %.6e m^3/s  dp = %.6e Pa over L = %.6e m (periodic)\n", q, rho*dp, L
    printf "K_periodic = %.6e m^2\n", nu*q*L/(A*dp)
}'
"""


def write_periodic_case(pm: PoreMesh, case: Path, flow: dict | None = None) -> Path:
    """Write the simpleFoam case of a periodic mesh into ``case`` (see the module docstring).

    Parameters
    ----------
    pm
        A periodic mesh (:attr:`~psdesign.meshing.result.PoreMesh.periodic`).
    case
        Case folder (created).
    flow
        The spec's ``[flow]`` table (viscosity, density, pressure drop).

    Returns
    -------
    Path
        The case folder.
    """
    case = Path(case)
    c = case_constants(pm, flow)
    write_cyclic_polymesh(pm, case / "constant" / "polyMesh")
    write_tet_copy(case)
    write_constants_and_fields(case, c["nu"], _fields(c["p_inlet"]))
    system = case / "system"
    system.mkdir(parents=True, exist_ok=True)
    flux = _patch_fo("fluxInlet", T.INLET, "sum", "phi")
    # 6000 iterations: ./Allrun tets needs 4 534 on the one-fibre cell at 2.83 um (session 35)
    (system / "controlDict").write_text(control_dict(6000, 1000, flux))
    (system / "fvSchemes").write_text(_FV_SCHEMES)
    (system / "fvSolution").write_text(_FV_SOLUTION)
    values = {"NU": c["nu"], "RHO": c["rho"], "L": c["box_length"], "A": c["area"]}
    write_script(case / "Allrun", _ALLRUN, values | {"DP": c["p_inlet"]})
    (system / "changeDictionaryDict").write_text(  # the file set of every openfoam export
        _header(
            "dictionary",
            "changeDictionaryDict",
            "system",
            "not used: gmshToFoam cannot make cyclic patches; Allrun reads psdesign's polyMesh",
        )
        + "dictionaryReplacement\n{\n}\n"
    )
    (case / "README.txt").write_text(
        "psdesign pore-space case of a PERIODIC mesh for simpleFoam (laminar, creeping flow).\n"
        f"Run ./Allrun. Flow direction {pm.direction}; every box face is a cyclic patch, the\n"
        f"kinematic pressure jumps by {c['p_inlet']:.6g} m^2/s^2 across inlet/outlet (over the\n"
        f"box length {c['box_length']:.6g} m); mu = {c['mu']:.6g} Pa s, rho = {c['rho']:.6g} "
        f"kg/m^3.\nK (printed by ./Allrun) = nu Q L / (A dp), Q = flux through the inlet patch.\n"
        "Cells: ./Allrun solves on the polyhedral dual of psdesign's tetrahedra (polyDualMesh;\n"
        "the tets are kept in constant/polyMesh.tet); ./Allrun tets solves on the tets.\n"
    )
    return case
