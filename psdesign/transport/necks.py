"""Does a transport value's conducting path run through a neck narrower than about a voxel?

The voxel grid of an analytic RVE samples the fibres' surface at voxel centres, so a gap between
two fibres narrower than about a voxel is open or closed on the grid by where the centres fall,
not by the RVE. For the pore phase a closed gap is reported (``blocked``, with a warning); the
converse was not: conducting fibres (solid well above the fluid) whose gap the grid closes touch
on the grid and carry the current through the bridge. Session 38 (``benchmarks/RESULTS.md``,
helper s38-tgap): a square array of cylinders at solid fraction 0.76 across, 32 voxels per
spacing, cylinders 1000x the fluid, gave ``sigma_eff = 446 +- 7.2 %``, ``ok``, where the RVE's
value is 15.1 (its gap is 0.52 voxels; Keller 1963 bounds it by 17.5); the two-grid term did
not see it because the coarse grid bridges the same gap.

:func:`neck_warning` tests the phase that conducts better (the pore phase for an insulating
solid): if it winds around the periodic box along the drive on the voxel grid but not once its
walls move inward by :data:`NECK_MOVE` voxels (the distance field is sub-voxel), its path
crosses a neck (a gap the grid bridged, or a throat) narrower than about a voxel, and the value
depends on how the grid sampled it. Such a value is rated ``untrustworthy`` with this warning
(:func:`psdesign.transport.effective.rating`). A path is the one the permeability's throat and
the voxel solver's refusal use (:func:`psdesign.geometry.throat.percolates`).
"""

from __future__ import annotations

import numpy as np

#: How far (in voxels) the conducting phase's walls move inward for the test: half a voxel,
#: the largest error of a voxel-centre sample of the surface along an axis (chosen, not
#: fitted). Measured on the 720 array cases of ``benchmarks/transport_narrow_gaps.py``: it
#: fires on 162, all at gaps below 2 voxels; 152 were already ``untrustworthy`` by
#: their bar, the other 10 were the grid-bridged ``ok`` values (errors +220 % to +3100 %).
NECK_MOVE = 0.5
#: Smallest ratio of the two phases' conductivities at which a bridged neck is looked for: a
#: bridge of a phase only a few times more conducting changes the value by about as much as
#: the staircase floor already allows.
NECK_CONTRAST = 10.0


def neck_warning(
    distance: np.ndarray,
    voxel: float,
    sigma_solid: float,
    sigma_fluid: float,
    axis: int,
) -> str | None:
    """The warning (without the value's name) of a value whose conducting phase reaches
    across the box along ``axis`` only through a neck narrower than about a voxel, else None
    (module docstring).

    Parameters
    ----------
    distance : ndarray
        Signed distance to the fibres' surface at voxel centres (m; <= 0 in the solid).
    voxel : float
        Voxel edge (m).
    sigma_solid, sigma_fluid : float
        The two phases' conductivities (0 = insulating).
    axis : int
        The drive's axis.

    >>> d = np.full((8, 8, 8), 2.0); d[:, :, 3] = -2.0; d[4, :, 3] = -0.3  # a thin solid neck
    >>> neck_warning(d, 1.0, 1000.0, 1.0, 0)[:40]
    'the conducting path crosses a neck of th'
    >>> neck_warning(d, 1.0, 1000.0, 1.0, 1) is None  # along y the sheet is whole
    True
    """
    from psdesign.geometry.throat import percolates

    hi, lo = max(sigma_solid, sigma_fluid), min(sigma_solid, sigma_fluid)
    if hi <= 0 or (lo > 0 and hi < NECK_CONTRAST * lo):
        return None
    move = NECK_MOVE * float(voxel)
    d = np.asarray(distance)
    phase = "solid" if sigma_solid > sigma_fluid else "pore"
    if phase == "solid":
        on_grid = percolates(d <= 0, axis)
        moved = on_grid and percolates(d <= -move, axis)
    else:
        on_grid = percolates(d > 0, axis)
        moved = on_grid and percolates(d > move, axis)
    if not on_grid or moved:
        return None
    return (
        f"the conducting path crosses a neck of the {phase} narrower than about a "
        f"voxel (it breaks when the {phase}'s walls move by {NECK_MOVE:g} voxel): the grid may "
        "have bridged a gap the RVE has, or sampled a throat it cannot resolve; refine rve.voxel"
    )
