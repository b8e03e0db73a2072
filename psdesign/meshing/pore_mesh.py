"""Pore-space tetrahedral mesh of an RVE: the one public entry point :func:`mesh_pore_space`.

Pipeline (modules of :mod:`psdesign.meshing`):

1. inputs checked, field scaled to O(1) units, pore gaps narrower than ``min_gap_voxels``
   closed, voxel connectivity checked, sub-voxel pore volume estimated
   (:mod:`.inputs`, :mod:`.surface`, :mod:`.pore_volume`);
2. one of two meshers (:class:`~.options.MeshOptions` ``mesher``):
   ``'stuffing'`` (:mod:`.stuffing_mesher`, default): deterministic Kuhn-lattice mesher clipped
   to the interpolated field, box faces exact by construction, optionally periodic;
   ``'pytetwild'`` (:mod:`.tetwild_mesher`): fTetWild on the exact box-minus-fibers surface,
   box faces snapped;
3. the mesh pore volume matched to the analytic pore volume (a level shift for stuffing, a
   wall-normal shift for pytetwild), boundary tags (:mod:`.tags`), checks: tet connectivity
   (components touching neither inlet nor outlet are dropped, no inlet-outlet path ->
   :class:`PoreTopologyError`), volume against the target, fraction of tet centroids in the
   pore, inverted tets (:class:`MeshFailedError`).

Exports: :func:`export_mesh` and the registry in :mod:`psdesign.meshing.exports`.
"""

from __future__ import annotations

import time

import numpy as np

from psdesign.meshing.errors import MeshFailedError, MeshInputError, PoreTopologyError
from psdesign.meshing.exports import export_mesh
from psdesign.meshing.inputs import validate_inputs
from psdesign.meshing.options import MeshOptions
from psdesign.meshing.result import PoreMesh
from psdesign.meshing.stuffing_mesher import mesh_stuffing
from psdesign.meshing.tetwild_mesher import mesh_tetwild

__all__ = [
    "MeshFailedError",
    "MeshInputError",
    "MeshOptions",
    "PoreMesh",
    "PoreTopologyError",
    "export_mesh",
    "mesh_pore_space",
]


def mesh_pore_space(
    distance: np.ndarray,
    voxel: float,
    size,
    direction: str,
    options: MeshOptions | None = None,
    **legacy,
) -> PoreMesh:
    """Tetrahedralize the pore space of a voxel-sampled RVE (with auxiliary inlet/outlet zones).

    Parameters
    ----------
    distance
        (nx, ny, nz) signed distance to the fiber surface in metres at voxel centres
        ``(i + 0.5) * voxel``; <= 0 inside fibers, > 0 in the pore.
    voxel
        Voxel size in metres; ``distance.shape * voxel`` must equal ``size``.
    size
        RVE side lengths (3,) in metres; the box is ``[0, size_x] x [0, size_y] x [0, size_z]``.
    direction
        Flow direction ``'x' | 'y' | 'z'``.
    options
        All mesher choices (:class:`~psdesign.meshing.options.MeshOptions`; default
        ``MeshOptions()``: stuffing, aux_length 0.2, volume matched to the analytic pore
        volume). Build it from a spec with ``MeshOptions.from_flow(spec["flow"])``.
    **legacy
        The old keyword arguments (``aux_length``, ``mesher``, ``lattice_step``,
        ``edge_length_fac``, ``stuffing_alpha``, ...), applied on top of ``options``.

    Returns
    -------
    PoreMesh

    Raises
    ------
    MeshInputError
        A bad argument (message names it and its allowed range).
    PoreTopologyError
        Empty pore space, blocked inlet/outlet, or no pore path from inlet to outlet.
    MeshFailedError
        The tet mesh fails the volume, pore-fraction or orientation checks.
    """
    t0 = time.perf_counter()
    opts = options if options is not None else MeshOptions()
    if not isinstance(opts, MeshOptions):
        raise MeshInputError(f"options must be a MeshOptions, got {type(opts).__name__}")
    if legacy:
        opts = MeshOptions.from_kwargs(**{**_fields(opts), **legacy})
    distance, voxel, size = validate_inputs(distance, voxel, size, direction, opts)
    from psdesign import progress

    mesher = mesh_stuffing if opts.mesher == "stuffing" else mesh_tetwild
    progress.stage(f"meshing the pore space ({opts.mesher}, {direction})")
    pm = mesher(distance, voxel, size, direction, opts, t0)
    progress.stage(f"mesh: {len(pm.points)} points, {len(pm.tets)} tets")
    return pm


def _fields(opts: MeshOptions) -> dict:
    import dataclasses

    return {f.name: getattr(opts, f.name) for f in dataclasses.fields(opts)}
