"""The OpenFOAM case of a periodic mesh (psdesign.meshing.exports.openfoam_periodic).

Truths: the periodic mesh has identical vertices on opposite box faces, so every cyclic face
must be its partner translated by one edge (OpenFOAM's coupled-face convention: the same 0th
vertex, the others in reverse order), with outward normals; the flow along a square array of
cylinders has Drummond & Tahir's (1984) permeability (tests/reference_values.py).
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess

import numpy as np
import pytest
from reference_values import drummond_tahir_along_square

from psdesign.meshing.exports import export_mesh
from psdesign.meshing.pore_mesh import mesh_pore_space

L = 40e-6
R = 8e-6


def _cylinder_cell(n: int = 16, step: float = 4e-6, periodic: bool = True):
    """A periodic mesh of one cylinder (radius R) along z in an L^3 cell."""
    h = L / n
    c = (np.arange(n) + 0.5) * h
    x, y = np.meshgrid(c, c, indexing="ij")
    d = np.repeat((np.hypot(x - L / 2, y - L / 2) - R)[:, :, None], n, axis=2)
    return mesh_pore_space(d, h, (L,) * 3, "z", periodic=periodic, lattice_step=step)


def _read(path, count_re=r"^(\d+)\n\(\n") -> list[str]:
    text = path.read_text()
    n = int(re.search(count_re, text, re.M).group(1))
    body = text[re.search(count_re, text, re.M).end() :]
    return body.splitlines()[:n]


def _polymesh(case):
    poly = case / "constant" / "polyMesh"
    pts = np.array([[float(v) for v in s.strip("()").split()] for s in _read(poly / "points")])
    faces = np.array([[int(v) for v in s[2:].strip("()").split()] for s in _read(poly / "faces")])
    text = (poly / "boundary").read_text()
    patches = {}
    for m in re.finditer(r"^    (\w+)\n    \{\n(.*?)\n    \}", text, re.M | re.S):
        body = m.group(2)
        get = lambda k, b=body: re.search(rf"{k}\s+([^;]+);", b).group(1)  # noqa: E731
        patches[m.group(1)] = {
            "type": get("type"),
            "n": int(get("nFaces")),
            "start": int(get("startFace")),
            "nbr": get("neighbourPatch") if "neighbourPatch" in body else None,
            "sep": (
                np.array([float(v) for v in get("separationVector").strip("()").split()])
                if "separationVector" in body
                else None
            ),
        }
    return pts, faces, patches


def test_cyclic_faces_are_their_partners_one_edge_apart(tmp_path):
    pm = _cylinder_cell()
    case = export_mesh(pm, tmp_path, formats=("openfoam",))["openfoam"]
    pts, faces, patches = _polymesh(case)
    pairs = {("inlet", "outlet", 2), ("side_x0", "side_x1", 0), ("side_y0", "side_y1", 1)}
    assert patches["wall"]["type"] == "wall"
    for low, high, ax in pairs:
        a, b = patches[low], patches[high]
        assert (a["type"], b["type"], a["nbr"], b["nbr"]) == ("cyclic", "cyclic", high, low)
        assert a["n"] == b["n"] == len(pm.facet_tags[low])
        sep = np.zeros(3)
        sep[ax] = L
        np.testing.assert_allclose(a["sep"], sep, atol=1e-18)
        np.testing.assert_allclose(b["sep"], -sep, atol=1e-18)
        fa = faces[a["start"] : a["start"] + a["n"]]
        fb = faces[b["start"] : b["start"] + b["n"]]
        # the same 0th vertex, the others reversed, one edge along ax apart
        np.testing.assert_allclose(
            pts[fb] - pts[fa[:, [0, 2, 1]]], np.broadcast_to(sep, fb.shape + (3,)), atol=1e-15
        )
        for f, sign in ((fa, -1.0), (fb, 1.0)):  # normals point out of the box
            p = pts[f]
            normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
            assert (sign * normal[:, ax] > 0).all()
    p_text = (case / "0" / "p").read_text()
    assert re.search(
        r"inlet \{ type fixedJump; patchType cyclic; jump uniform -0\.8333333333;", p_text
    )
    assert "pRefCell" in (case / "system" / "fvSolution").read_text()


@pytest.mark.slow
@pytest.mark.skipif(
    shutil.which("simpleFoam") is None, reason="OpenFOAM (simpleFoam) not installed"
)
def test_periodic_allrun_k_matches_drummond_tahir(tmp_path):
    """Flow along a square array of cylinders (radius 8 um, spacing 40 um, solid fraction
    0.126): Drummond & Tahir's K = 1.0715e-10 m^2; the Allrun's K on a 16^3-voxel, 4 um
    lattice mesh (5 260 tets) is 1.1560e-10 on their polyhedral dual (+7.9 %, 1 274 cells,
    428 iterations; session 36), 9.997e-11 on the tets (-6.7 %; 9.925e-11 with 5 400 tets
    before session 35's sliver fix): finite volumes, one unknown per coarse cell; psdesign's
    Taylor-Hood FEM on the same cell -0.5 %, benchmarks/bench_openfoam.py --periodic. Within
    10 %; the flux must enter through the inlet."""
    pm = _cylinder_cell()
    case = export_mesh(pm, tmp_path, formats=("openfoam",))["openfoam"]
    out = subprocess.run(
        [str(case / "Allrun")], capture_output=True, text=True, timeout=1800, check=True
    ).stdout
    k = float(re.search(r"K_periodic = ([-+0-9.eE]+)", out).group(1))
    phi = math.pi * R**2 / L**2
    assert k == pytest.approx(drummond_tahir_along_square(phi) * R**2, rel=0.10)
    flux = (case / "postProcessing" / "fluxInlet" / "0" / "surfaceFieldValue.dat").read_text()
    assert float(flux.splitlines()[-1].split()[1]) < 0  # into the box through the inlet


def test_gmsh_export_links_the_periodic_faces(tmp_path):
    """A periodic mesh's ``pore.msh`` carries Gmsh's ``$Periodic`` section (it had none: the
    periodicity was lost): per axis the high face (slave) linked to the low face (master) by a
    translation of one edge, and node pairs exactly one edge apart; meshio reads it back."""
    import meshio

    from psdesign.meshing.tags import TAG_IDS

    pm = _cylinder_cell()
    meshio_mesh = meshio.read(export_mesh(pm, tmp_path, formats=("msh",))["msh"])
    links = meshio_mesh.gmsh_periodic
    assert sorted(tags for _, tags, _, _ in links) == sorted(
        [
            (TAG_IDS["side_x1"], TAG_IDS["side_x0"]),
            (TAG_IDS["side_y1"], TAG_IDS["side_y0"]),
            (TAG_IDS["outlet"], TAG_IDS["inlet"]),
        ]
    )
    pts = meshio_mesh.points
    for dim, _, affine, pairs in links:
        shift = np.asarray(affine, float).reshape(4, 4)[:3, 3]
        assert dim == 2 and np.isclose(np.linalg.norm(shift), L)
        np.testing.assert_allclose(
            pts[pairs[:, 0]] - pts[pairs[:, 1]], np.broadcast_to(shift, (len(pairs), 3)), atol=1e-15
        )
    plain = _cylinder_cell(periodic=False)  # the permeameter mesh: no links
    assert (
        meshio.read(export_mesh(plain, tmp_path / "p", formats=("msh",))["msh"]).gmsh_periodic
        is None
    )
