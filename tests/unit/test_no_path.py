"""Who closed the fluid path of a refused voxel solve (:mod:`psdesign.flow.no_path`).

Geometry (closed form): a square array of cylinders across, spacing ``L``, solid fraction
``phi``, has the gap ``L (1 - 2 sqrt(phi / pi))`` between neighbours, open for ``phi < pi / 4``.
Session 39 (``benchmarks/RESULTS.md``): the diffuse wall closed such gaps up to 1.96 voxels
(0.7 at 24 voxels per spacing, gap 1.34 voxels) where the grid and the sub-voxel wall have them
open, and the refusal said "a gap under about a voxel closes on the grid"; two overlapping
cylinders that close every path were told to refine ``rve.voxel``.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from arrays import L, array_distance, array_spec

from psdesign.flow.no_path import OPEN_MOVE, closed_pore_space, no_path_message
from psdesign.flow.voxel import permeability_voxel
from psdesign.geometry.fibers import make_fiber
from psdesign.geometry.rve import RVE
from psdesign.geometry.throat import percolates
from psdesign.packing.build import build_rve
from psdesign.schema.spec import validate_spec
from solvers.voxel_stokes import NoFluidPathError


def _array(phi: float, n: int, wall: str, shift: float = 0.0):
    spec = array_spec("square", phi, n)
    for fb in spec["fibers"]:  # the cylinders moved by ``shift`` voxel along x and y
        c = fb["center"]
        fb["center"] = [c[0] + shift * L / n, c[1] + shift * L / n, c[2]]
    spec["flow"] = {**spec["flow"], "wall_treatment": wall}
    spec = validate_spec(spec)
    built = build_rve(spec)
    return built.rve, built.voxelize(spec["rve"]["voxel"]), spec["flow"]


def _diffuse_open(rve, fields) -> bool:
    """Whether the diffuse wall's cells with fluid fraction >= 1/2 percolate along x (the
    diffuse solver's own test, :func:`solvers.voxel.diffuse.solve_diffuse_stokes`)."""
    from psdesign.geometry.walls import NearestWalls
    from solvers.voxel.diffuse import DiffuseGrid
    from solvers.voxel.diffuse_wall import REACH_VOXELS

    h = float(fields.grid.spacing[0])
    grid = DiffuseGrid.sample(fields.grid.shape, NearestWalls(rve, h, reach=REACH_VOXELS + 1.0))
    return percolates(grid.cell >= 0.5, 0)


def test_a_gap_the_diffuse_wall_closes_is_said_so_with_the_voxel_that_opens_it():
    """Square array across at 0.6, 12 voxels per spacing: gap L (1 - 2 sqrt(0.6 / pi)) = 1.51
    voxels, open on the grid; the diffuse wall's layers close it. The line says the grid has it
    open, reads the gap's width to 0.1 voxel, and its voxel opens it for the diffuse wall
    (checked by sampling the wall at that voxel); the old line said 'a gap under about a voxel
    closes on the grid'."""
    phi, n = 0.6, 12
    rve, fields, flow = _array(phi, n, "diffuse")
    assert percolates(fields.distance > 0, 0)  # the grid has the gap open
    with pytest.raises(NoFluidPathError) as info:
        permeability_voxel(fields, "x", flow, rve=rve)
    line = str(info.value)
    assert line.startswith("rve.voxel: the diffuse wall closes the pore path along x")
    assert "flow.wall_treatment = 'subvoxel'" in line and "\n" not in line
    read = float(re.search(r"gap is ([\d.]+) voxels", line).group(1))
    gap = (1.0 - 2.0 * math.sqrt(phi / math.pi)) * n  # 1.51 voxels
    assert abs(read - gap) < 0.1  # 1.54: the bisection's 0.1 and the centres' sampling
    voxel = float(re.search(r"rve\.voxel <= ([\d.e+-]+) m", line).group(1))
    n_open = math.ceil(L / voxel)  # a whole number of voxels per spacing, no coarser
    assert n_open > n
    rve2, fields2, _ = _array(phi, n_open, "diffuse")
    assert _diffuse_open(rve2, fields2)


def test_a_gap_of_a_few_hundredths_of_a_voxel_is_read_to_its_width():
    """Square array at 0.78, 12 voxels per spacing, the cylinders moved by half a voxel: gap
    L (1 - 2 sqrt(0.78 / pi)) = 0.041 voxel, open on the grid (voxel centres on its midline).
    The percolation radius's bisection to 0.05 voxel read it as 0.1 and asked for 300 voxels
    per spacing, where the gap is 1.03 voxels and the layer still closes it (session 39); it
    is read to 0.005 voxel now and the voxel asked for puts 2.5 voxels across the true gap."""
    phi, n = 0.78, 12
    rve, fields, flow = _array(phi, n, "diffuse", shift=0.5)
    with pytest.raises(NoFluidPathError) as info:
        permeability_voxel(fields, "x", flow, rve=rve)
    line = str(info.value)
    assert line.startswith("rve.voxel: the diffuse wall closes")
    gap = (1.0 - 2.0 * math.sqrt(phi / math.pi)) * n  # 0.041 voxels
    read = float(re.search(r"gap is ([\d.e+-]+) voxels", line).group(1))
    assert abs(read - gap) < 0.005
    voxel = float(re.search(r"rve\.voxel <= ([\d.e+-]+) m", line).group(1))
    assert gap * (L / n) / voxel > 2.4


def test_the_sub_voxel_wall_solves_the_gap_the_diffuse_wall_closes():
    """The same array and grid with the default wall: a path, K > 0 (no refusal)."""
    rve, fields, flow = _array(0.6, 12, "subvoxel")
    res = permeability_voxel(fields, "x", flow, rve=rve)
    assert res["permeability_m2"] > 0 and res["converged"]


def _overlapping_rods():
    """Two cylinders along z, 24 um across, centres 20 um apart along y in a 40 um cell: they
    overlap by 4 um, so every path along x is closed by the fibres (closed form); the RVE and
    its 2 um voxels."""
    fibers = [
        make_fiber("cylinder", 0.6, center=[0.5, y, 0.325], direction=[0, 0, 1])
        for y in (0.25, 0.75)
    ]
    rve = RVE([L, L, 26e-6], fibers)
    return rve, rve.voxelize(2e-6)


def _overlapping_rods_spec(tmp_path):
    """The spec file of :func:`_overlapping_rods`."""
    spec = tmp_path / "rods.toml"
    rods = "".join(
        f'[[fibers]]\nshape = "cylinder"\ndiameter = 24e-6\ncenter = [20e-6, {y}e-6, 13e-6]\n'
        "direction = [0, 0, 1]\n"
        for y in (10, 30)
    )
    spec.write_text(f"[rve]\nsize = [40e-6, 40e-6, 26e-6]\nvoxel = 2e-6\n{rods}")
    return spec


@pytest.mark.parametrize("wall", ["subvoxel", "staircase"])
def test_a_geometry_without_a_path_is_not_sent_to_refine_the_voxel(wall):
    """Two cylinders along z, 24 um across, centres 20 um apart along y in a 40 um cell, overlap
    by 4 um: every path along x is closed by the fibres themselves (no voxel opens it). The old
    line named rve.voxel ('a voxel small enough to open the pore path')."""
    rve, fields = _overlapping_rods()
    with pytest.raises(NoFluidPathError) as info:
        permeability_voxel(fields, "x", {"viscosity": 1.8e-5, "wall_treatment": wall}, rve=rve)
    assert str(info.value).startswith("fibers: the pore space has no path along x")
    assert "rve.voxel" not in str(info.value)


def test_the_voxel_permeameter_of_fibers_without_a_path_names_the_fibers(tmp_path, capsys):
    """The two overlapping cylinders above close every path along x at any voxel (closed form:
    24 um fibres, centres 20 um apart, overlap 4 um). The periodic route and the FEM named
    ``fibers`` (session 44); the voxel permeameter kept ``rve.voxel: ... a voxel small enough
    to open the pore path``, a remedy that does not exist. Now its refusal tests the pore
    space with its reservoirs and side walls (:func:`closed_pore_space`, ``periodic=False``)
    and names the fibres, in Python and on the command line (exit 2, one line, before any
    work). Fails on main's no_path.py (the rve.voxel line)."""
    rve, fields = _overlapping_rods()
    flow = {"viscosity": 1.8e-5, "bc": "permeameter"}
    with pytest.raises(NoFluidPathError) as info:
        permeability_voxel(fields, "x", flow, rve=rve)
    assert str(info.value).startswith("fibers: the pore space has no path along x")
    assert "rve.voxel" not in str(info.value)
    spec = _overlapping_rods_spec(tmp_path)
    for bc in ("permeameter", "both"):  # both solves the permeameter first
        args = ["--solver", "voxel", "--bc", bc, "--direction", "x", "--quiet"]
        line = _refusal(capsys, "permeability", str(spec), *args)
        assert line.startswith("fibers: the pore space has no path along x"), line


@pytest.mark.parametrize("phi", [0.76, 0.785])
@pytest.mark.parametrize("n", [8, 16])
def test_the_permeameter_of_an_open_array_closed_by_the_grid_still_names_the_voxel(phi, n):
    """The other side of the rule above: square arrays below pi / 4 are open (closed form),
    so where the permeameter's grid closes their gap the line names rve.voxel, never the
    fibres (walls moved back by sqrt(3) / 2 voxel reopen them, with reservoirs and side walls
    too)."""
    h = L / n
    d = array_distance((n, n, 2), "square", phi) * h
    line = no_path_message("x", h, d, 0, "subvoxel", grid="permeameter")
    assert line.startswith("rve.voxel: "), line


@pytest.mark.parametrize("phi", [0.76, 0.775, 0.785])
@pytest.mark.parametrize("n", [8, 12, 16, 20, 24])
def test_an_open_array_closed_by_the_grid_is_never_called_closed(phi, n):
    """Square arrays below pi / 4 = 0.7854 are open (gap 0.02-0.16 L): where the grid closes
    the gap, the line names rve.voxel, never 'no path at any voxel size' (the walls moved back
    by sqrt(3) / 2 voxel open every such grid, the bound of the module docstring)."""
    assert phi < math.pi / 4
    h = L / n
    d = array_distance((n, n, 2), "square", phi) * h
    for wall in ("subvoxel", "diffuse"):
        line = no_path_message("x", h, d, 0, wall)
        assert line.startswith("rve.voxel: "), line
    if not percolates(d > 0, 0):
        assert no_path_message("x", h, d, 0, "subvoxel").startswith(
            "rve.voxel: no fluid path along x"
        )
    assert percolates(d > -OPEN_MOVE * h, 0)


def test_an_image_without_a_path_names_the_image():
    line = no_path_message("y", 1e-6, None, 1, "staircase")
    assert line.startswith("image: the pore space has no path along y")
    assert np.isfinite(OPEN_MOVE)


@pytest.mark.parametrize("bc", ["periodic", "permeameter"])
def test_the_image_line_says_how_the_path_was_looked_for_on_each_route(tmp_path, capsys, bc):
    """Session 44 (s44-review2, left): the image's line said "(face-connected, periodic pore
    voxels)" also for a permeameter, whose side walls close the periodic wrap (a channel that
    winds across x has a periodic path and none in the permeameter,
    :func:`test_a_permeameter_whose_only_path_winds_around_its_side_walls_names_the_image`).
    The bc is passed through :func:`no_path_message` / :func:`closed_pore_space` on the
    voxel and FEM routes, one message function, so each says the test it made."""
    words = {
        "periodic": "(face-connected, periodic pore voxels)",
        "permeameter": "(face-connected pore voxels between the reservoirs, inside the side walls)",
    }[bc]
    expected = (
        f"image: the pore space has no path along z {words}, so there is no permeability "
        "along z (allowed: an image whose pore space joins the faces normal to the flow)"
    )
    _write_plates_across_z(tmp_path)
    spec = str(tmp_path / "spec.toml")
    for solver in ("voxel", "fem"):
        args = ("--solver", solver, "--bc", bc, "--quiet")
        assert _refusal(capsys, "permeability", spec, *args) == expected
    assert no_path_message("z", 1e-6, None, 2, "staircase", grid=bc) == expected
    solid = np.zeros((6, 6, 6), bool)
    solid[:, :, 3] = True
    assert closed_pore_space("z", 1e-6, None, solid, 2, bc == "periodic") == expected


def _write_plates_across_z(folder) -> None:
    """A segmented image (ImageJ TIFF, 1 um voxels, stored zyx) whose solid plate across z
    (slices 10-13 of 24) closes every path along z; x and y stay open."""
    import tifffile

    stack = np.zeros((24, 12, 12), np.uint8)
    stack[10:14] = 255
    meta = {"unit": "um", "axes": "ZYX"}
    tifffile.imwrite(folder / "plate.tif", stack, imagej=True, resolution=(1.0, 1.0), metadata=meta)
    (folder / "spec.toml").write_text(
        '[image]\npath = "plate.tif"\nsolid_label = 255\n[flow]\ndirection = "z"\n'
    )


def _refusal(capsys, *args) -> str:
    from psdesign.cli.main import main

    assert main(list(args)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("psdesign: error: "), err
    return err[0].removeprefix("psdesign: error: ")


def test_mesh_and_the_fem_route_name_the_image_without_a_path_as_the_voxel_route_does(
    tmp_path, capsys
):
    """An image closed across z (a solid plate): ``permeability --solver voxel`` names
    ``image`` (no path in its voxels at all); ``mesh`` and ``permeability --solver fem`` said
    ``rve.voxel: disconnected pore space ... a voxel fine enough to open the path`` (a key an
    image spec does not have, a remedy that does not exist; session 44). Now all three print
    the same one line, exit 2, and ``mesh`` leaves no output folder."""
    _write_plates_across_z(tmp_path)
    spec = str(tmp_path / "spec.toml")
    args = ("--solver", "voxel", "--bc", "permeameter", "--quiet")  # the mesh's and FEM's bc
    voxel = _refusal(capsys, "permeability", spec, *args)
    assert voxel.startswith("image: the pore space has no path along z")
    out = tmp_path / "mesh_out"
    assert _refusal(capsys, "mesh", spec, "-o", str(out), "--quiet") == voxel
    assert not out.exists()
    assert _refusal(capsys, "permeability", spec, "--solver", "fem", "--quiet") == voxel
    # without --quiet too: the image is tested before the mesher prints its progress line
    # ("psdesign: meshing the pore space (stuffing, z)" came first until session 44)
    assert _refusal(capsys, "permeability", spec, "--solver", "fem") == voxel
    assert _refusal(capsys, "mesh", spec, "-o", str(out)) == voxel


def test_mesh_of_fibers_without_a_path_names_the_fibers(tmp_path, capsys):
    """The two overlapping cylinders of the test above (closed along x by the fibres, at any
    voxel): ``mesh`` (the permeameter's reservoirs included) names ``fibers``, not
    ``rve.voxel``, with the voxel route's line."""
    spec = _overlapping_rods_spec(tmp_path)
    line = _refusal(
        capsys, "mesh", str(spec), "-o", str(tmp_path / "m"), "--direction", "x", "--quiet"
    )
    assert line.startswith("fibers: the pore space has no path along x")
    assert "rve.voxel" not in line
    assert not (tmp_path / "m").exists()


def _channel_around_x() -> np.ndarray:
    """Solid mask (z, y, x; 16^3) of one pore channel, three voxels wide, that climbs along z
    while it moves along x: at slice z its pores are x = z + 8 ... z + 10 (mod 16), y 5-10.
    Below z = 7 and above it the channel's pores meet only across the box's x faces: the
    periodic box has a path along z, a permeameter (side walls) has none."""
    solid = np.ones((16, 16, 16), bool)
    for z in range(16):
        solid[z, 5:11, [(z + dx) % 16 for dx in (8, 9, 10)]] = False
    return solid


def test_a_permeameter_whose_only_path_winds_around_its_side_walls_names_the_image(
    tmp_path, capsys
):
    """The permeameter's side walls close the box across the flow: a path through the
    periodic wrap across x is none for it. ``permeability --solver voxel --bc permeameter``
    names ``image`` (its grid is walled, solvers.voxel_stokes._setup_grid); ``mesh`` and the
    FEM permeameter named ``rve.voxel`` (a key an image spec has not) because
    :func:`closed_pore_space` let the path wind around the walls (session 44 review)."""
    import tifffile

    solid = _channel_around_x()
    xyz = np.transpose(solid, (2, 1, 0))
    assert closed_pore_space("z", 1e-6, None, xyz, 2, True) is None  # the wrap is a path
    line = closed_pore_space("z", 1e-6, None, xyz, 2, False)
    assert line is not None and line.startswith("image: the pore space has no path along z")
    meta = {"unit": "um", "axes": "ZYX"}
    stack = np.where(solid, 255, 0).astype(np.uint8)
    tifffile.imwrite(tmp_path / "w.tif", stack, imagej=True, resolution=(1.0, 1.0), metadata=meta)
    spec = tmp_path / "spec.toml"
    spec.write_text('[image]\npath = "w.tif"\nsolid_label = 255\n[flow]\ndirection = "z"\n')
    args = ("--solver", "voxel", "--bc", "permeameter", "--quiet")
    voxel = _refusal(capsys, "permeability", str(spec), *args)
    assert voxel == line
    out = tmp_path / "mesh_out"
    assert _refusal(capsys, "mesh", str(spec), "-o", str(out), "--quiet") == voxel
    assert not out.exists()
    assert _refusal(capsys, "permeability", str(spec), "--solver", "fem", "--quiet") == voxel


def test_the_periodic_fem_names_the_image_whose_only_path_winds_through_the_side_faces(
    tmp_path, capsys
):
    """The channel of :func:`_channel_around_x` has a periodic path along z and none inside
    the side walls. The periodic mesher keeps only pieces joining the z faces inside the box,
    so ``permeability --solver fem --bc periodic`` refused it as ``rve.voxel: disconnected
    pore space`` (a key an image has not; session 44 review3); meshing it anyway gave a FEM K
    3-5x the voxel route's, marked ok (reverted, ee22dc1). Now the line names the image and
    the route that solves it, and the voxel route does (periodic, exit 0)."""
    import json

    import tifffile

    from psdesign.cli.main import main

    stack = np.where(_channel_around_x(), 255, 0).astype(np.uint8)
    meta = {"unit": "um", "axes": "ZYX"}
    tifffile.imwrite(tmp_path / "w.tif", stack, imagej=True, resolution=(1.0, 1.0), metadata=meta)
    spec = tmp_path / "spec.toml"
    spec.write_text('[image]\npath = "w.tif"\nsolid_label = 255\n[flow]\ndirection = "z"\n')
    fem = ("--solver", "fem", "--bc", "periodic", "--quiet")
    line = _refusal(capsys, "permeability", str(spec), *fem)
    assert line.startswith("image: the pore space's only path along z winds through the box's")
    assert "--solver voxel" in line and "rve.voxel" not in line
    args = ["permeability", str(spec), "--solver", "voxel", "--bc", "periodic", "--json"]
    assert main([*args, "--quiet"]) in (0, 3)  # finished (3: a status not ok, exit_status)
    assert json.loads(capsys.readouterr().out)["permeability_m2"] > 0


@pytest.mark.parametrize("treatment", ["mirror", "frame"])
def test_mirror_and_frame_of_fibers_without_a_path_name_the_fibers(treatment):
    """The two overlapping cylinders above (closed form: 24 um fibres, centres 20 um apart,
    overlap 4 um) close every path along x at any voxel; with ``flow.periodic_treatment`` mirror
    or frame the refusal still named ``rve.voxel: ... a voxel small enough to open the pore
    path`` (session 45, helper exits), a remedy that does not exist. Now it tests the walls
    moved back on the treatment's own grid and names the fibres. Fails on main's no_path.py."""
    rve, fields = _overlapping_rods()
    flow = {"viscosity": 1.8e-5, "periodic_treatment": treatment}
    with pytest.raises(NoFluidPathError) as info:
        permeability_voxel(fields, "x", flow, rve=rve)
    assert str(info.value).startswith("fibers: the pore space has no path along x")
    assert "rve.voxel" not in str(info.value)


@pytest.mark.parametrize("treatment", ["mirror", "frame"])
@pytest.mark.parametrize("phi", [0.76, 0.785])
@pytest.mark.parametrize("n", [8, 16])
def test_mirror_and_frame_of_an_open_array_still_name_the_voxel(treatment, phi, n):
    """The other side: square arrays below pi / 4 are open (closed form), so on the mirror and
    frame grids too the line names rve.voxel, never the fibres."""
    h = L / n
    d = array_distance((n, n, 2), "square", phi) * h
    line = no_path_message("x", h, d, 0, "subvoxel", grid=treatment)
    assert line.startswith("rve.voxel: "), line
