"""The FEM route's own signed-distance field, fine enough for the thinnest fiber.

Whatever ``rve.voxel`` the voxel solver was given, the FEM meshes the analytic geometry sampled
at a voxel tied to the thinnest fiber.

The stuffing mesher clips its lattice on the trilinear interpolant of a sampled signed distance
and matches the mesh volume to the sub-voxel pore volume of the same samples
(:mod:`psdesign.meshing.pore_volume`, a smoothed step two voxels wide). Both need several voxels
across a fiber: at 4.3 voxels across the yarns of the 30 um woven cell the volume target puts
the solid fraction at 0.1075 against 0.1102 at 8.6 and 17 voxels, and the periodic FEM's K moves
by 5.9 % at the same lattice (1.5674e-12 vs 1.4802e-12). The geometry is analytic, so the
FEM samples it itself: at ``rve.voxel / r`` with the smallest integer ``r`` that gives
:data:`FIELD_VOXELS_PER_DIAMETER` voxels across the thinnest fiber width (a yarn's thin
width), capped at :data:`FIELD_MAX_VOXELS` voxels. A field that is already fine enough is used
as it is (the mesh is then the one of earlier releases, bit for bit); an image has no analytic
geometry and keeps its own grid (and the voxel-count volume target, :func:`psdesign.image.fields.
mesh_overrides`).

What a resolved field still moves (``benchmarks/RESULTS.md``): the woven cell -0.52 % from 8.5
to 17 voxels per yarn (periodic, 2 um lattice, bar 15 %), the quickstart's RVE -0.26 % from 14
to 28 voxels per diameter (one-copy permeameter, 3 um lattice; bar about 5 %). A field below
8 voxels per diameter (the cap, or pytetwild) adds :func:`field_rel_error` to the error bar.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from psdesign.geometry.rve import RVE, VoxelFields, is_cubic

#: Voxels across the thinnest fiber diameter the FEM's field has at least (the resolution at
#: which the smoothed-step volume of rods of 3.5-10 voxels radius is within 5e-4 of the exact
#: one, ``tests/unit/test_pore_volume.py``; the woven cell's solid fraction is the same at 8.6
#: and 17 voxels across a yarn).
FIELD_VOXELS_PER_DIAMETER = 8.0
#: Most voxels of a refined FEM field, the permeameter's stacked copies included (about
#: :data:`FIELD_BYTES_PER_VOXEL` each while meshing): 2^24 voxels, about 1 GB.
FIELD_MAX_VOXELS = 2**24
#: Bytes per voxel of the refined field while it is meshed (counted in the up-front estimate,
#: :func:`psdesign.schema.budget.check_fem`; measured 50 B per added voxel on the quickstart's
#: stacked field, ``benchmarks/RESULTS.md``).
FIELD_BYTES_PER_VOXEL = 60


@dataclass(frozen=True)
class FemField:
    """The field the FEM meshes.

    Attributes
    ----------
    fields
        The voxel fields (the caller's own when ``refinement == 1``).
    refinement
        Integer ratio of the caller's voxel to this field's (1: not refined).
    wanted
        The ratio :data:`FIELD_VOXELS_PER_DIAMETER` asked for (> ``refinement`` when the cap
        :data:`FIELD_MAX_VOXELS` bound it; 1 for an image or a fine enough field).
    voxels_per_diameter
        Voxels of this field across the thinnest fiber diameter (None without fibers).
    rel_error
        The error bar's field term (:func:`field_rel_error`; 0 on a field with at least
        :data:`FIELD_VOXELS_PER_DIAMETER` voxels across, and for an image).
    """

    fields: VoxelFields
    refinement: int
    wanted: int
    voxels_per_diameter: float | None
    rel_error: float = 0.0

    @property
    def voxel(self) -> float:
        """Voxel edge of the meshed field in metres."""
        return float(self.fields.grid.spacing[0])

    @property
    def capped(self) -> bool:
        """True when the voxel cap kept the field coarser than asked."""
        return self.wanted > self.refinement

    def as_dict(self) -> dict:
        """JSON-ready summary (``fem_field`` in the route's result)."""
        return {
            "voxel_m": self.voxel,
            "refinement": self.refinement,
            "wanted_refinement": self.wanted,
            "voxels_per_diameter": self.voxels_per_diameter,
            "capped": self.capped,
            "rel_error": self.rel_error,
        }


def wanted_refinement(voxel: float, diameter: float | None) -> int:
    """Smallest integer ``r`` with ``diameter / (voxel / r) >= FIELD_VOXELS_PER_DIAMETER``.

    >>> wanted_refinement(1e-6, 4.26e-6), wanted_refinement(0.5e-6, 4.26e-6)
    (2, 1)
    """
    if diameter is None or not diameter > 0:
        return 1
    return max(1, math.ceil(FIELD_VOXELS_PER_DIAMETER * voxel / diameter - 1e-9))


def capped_refinement(n_voxels: int, wanted: int, max_voxels: int = FIELD_MAX_VOXELS) -> int:
    """The largest ``r <= wanted`` whose refined grid (``n_voxels r^3``) stays within
    ``max_voxels`` (at least 1: the caller's own grid is always allowed)."""
    r = int(wanted)
    while r > 1 and n_voxels * r**3 > max_voxels:
        r -= 1
    return r


def spec_grid_step(
    flow: dict,
    spec_voxel: float,
    size,
    diameter: float | None,
    copies: int = 1,
    porosity: float | None = None,
) -> tuple[dict, str | None]:
    """The default lattice step of a spec route, as a mesher override, and its budget note.

    :func:`psdesign.schema.budget.fem_lattice_step` on the spec's grid (``spec_voxel``: a field
    the FEM refined must not make the lattice finer through the ``2 voxel`` bound) for the
    RVE's own ``size`` (not the permeameter's stack), ``diameter`` the thinnest fiber (None for
    an image), ``copies`` stacked copies, ``flow.aux_length`` reservoirs (0 when periodic): the
    step the up-front budget counts (:func:`psdesign.schema.budget.check_fem`), coarsened to fit
    the memory budget if need be (the note then says so). Empty (and no note) when
    ``flow.lattice_step`` is given or the mesher is pytetwild."""
    if flow.get("lattice_step") is not None or (flow.get("mesher") or "stuffing") != "stuffing":
        return {}, None
    from psdesign.schema.budget import fem_lattice_step

    periodic = flow.get("bc") == "periodic"
    aux = 0.0 if periodic else float(flow.get("aux_length", 0.2))
    size = tuple(float(s) for s in size)
    step, note = fem_lattice_step(size, spec_voxel, diameter, copies, aux, porosity)
    return {"lattice_step": step}, note


def refinable(rve: RVE, fields: VoxelFields) -> bool:
    """True when the FEM may sample ``rve`` itself: analytic geometry with fibers, and ``fields``
    covers the RVE's own box (not an image, not a stack)."""
    return (
        bool(getattr(fields, "analytic_distance", False))
        and bool(getattr(rve, "fibers", None))
        and np.allclose(
            np.asarray(fields.grid.size, float), np.asarray(rve.size, float), rtol=1e-9, atol=0.0
        )
        and is_cubic(fields.grid.spacing)
    )


def fem_field(rve: RVE, fields: VoxelFields, mesher: str = "stuffing", copies: int = 1) -> FemField:
    """The field the FEM meshes for ``rve`` given the caller's ``fields`` (see module).

    Parameters
    ----------
    rve : RVE
    fields : VoxelFields
        The RVE on the spec's grid (``rve.voxel``).
    mesher : str
        ``flow.mesher``; pytetwild meshes the exact fiber surface and keeps ``fields``.
    copies : int
        Copies the permeameter stacks (the cap counts the stacked field the mesher holds).

    Returns
    -------
    FemField
    """
    from psdesign.flow.error import under_resolved
    from psdesign.meshing.options import thinnest_fiber_diameter

    voxel = float(fields.grid.spacing[0])
    diameter = thinnest_fiber_diameter(rve)
    r, wanted = 1, 1
    if mesher == "stuffing" and refinable(rve, fields):
        wanted = wanted_refinement(voxel, diameter)
        r = capped_refinement(int(np.prod(fields.grid.shape)) * max(1, int(copies)), wanted)
    if r > 1:
        fine = rve.voxelize(voxel / r)
        if tuple(fine.grid.shape) == tuple(int(n) * r for n in fields.grid.shape):
            fields, voxel = fine, voxel / r
        else:  # the box is no whole number of fine voxels
            r = 1
    per_d = None if diameter is None else diameter / voxel
    term = 0.0
    # up to rounding: an 8 um fiber in a 20 um box at 1 um has 7.999999999999998 voxels across
    # (the diameter is stored as a fraction of the period), which drew "8.0 voxels (< 8)"
    if under_resolved(per_d, FIELD_VOXELS_PER_DIAMETER) and fields.analytic_distance:
        term = field_rel_error(fields.distance, voxel)
    return FemField(fields, r, max(wanted, r), per_d, term)


def field_rel_error(distance: np.ndarray, voxel: float) -> float:
    """The error bar's field term of a field too coarse for its thinnest fiber.

    The mesh volume target (:func:`psdesign.meshing.pore_volume.analytic_pore_volume`, a
    smoothed step two voxels wide) under-counts fibers less than about 8 voxels across (their
    field never reaches the kernel's width); a kernel one voxel wide does not, but is 0.6-1 %
    off on resolved rods, so it is no default. Their gap in solid fraction ``s`` times the
    sensitivity of the Kozeny-Carman law, ``|d ln K / d ln s| = 2 + 3 s / (1 - s)``, bounds
    the K error of the target. Measured on the 30 um woven cell at 1 um (4.3 voxels across a
    yarn, periodic FEM, 2 um lattice): solid 0.1075 (two voxels) vs 0.1103 (one voxel; 0.1104
    by Monte Carlo), term 6.0 %, the K on that field +5.9 % over the one on a 0.5 um field.
    Only applied below :data:`FIELD_VOXELS_PER_DIAMETER` voxels per diameter, where the two
    kernels' gap is the field's error and not the narrow kernel's.
    """
    from psdesign.meshing.pore_volume import analytic_porosity

    d = np.asarray(distance)
    s2 = 1.0 - analytic_porosity(d, voxel, 2.0)
    s1 = 1.0 - analytic_porosity(d, voxel, 1.0)
    if not 0.0 < s2 < 1.0:
        return 0.0
    sensitivity = 2.0 + 3.0 * s2 / (1.0 - s2)
    return float(sensitivity * abs(s1 - s2) / s2)
