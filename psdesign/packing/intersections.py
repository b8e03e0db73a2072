"""Intersection removal for random fiber sets (paper Sec. 7.1, Eq. 8-9).

Both methods work on a :class:`FiberState` (arrays of the Sec. 7.1 placement parameters,
normalized lengths, one PS period = 1). A PS fiber is the periodic family of its lattice
copies (one line per period^2 perpendicular to its axis); its centre-line copies are
clipped to the box, grown by the contact distance, so every overlap inside the box is seen.

``fast`` (:func:`place_sequential`)
    Fibers are placed one after the other. A fiber stays where it was drawn if its centre
    lines clear every placed fiber by ``(D_i + D_j) / 2 + gap``; otherwise it moves by the
    smallest shift in its lattice plane that clears them. Those shifts form a torus (a
    shift by a lattice vector maps the fiber onto itself), and projected along the fiber
    axis every placed centre-line piece forbids an exact capsule of shifts; the capsules
    are rasterized on a grid of the torus (numba), so one fiber costs O(pieces), not a
    search. Bent fibers use capsules dilated by the sway of their axis, and may also move
    their bend phase. A fiber that fits nowhere tries a few re-orientations and then
    ejects the fewest placed fibers blocking a position (they are re-queued). Because the
    rod cross-section of Eq. (4) lies inside the circle of the nominal diameter (and a
    bent rod's slices are shifted rod sections), this separation guarantees that no
    voxel centre is inside two fibers: Omega on the voxel grid is exactly 0.

``ga`` (:func:`genetic`)
    The paper's genetic algorithm over the adjustment ranges of Sec. 7.1 (theta and omega
    +-1 deg, translations +-0.1 of the RVE edge, u in [0.1, 0.3] and f in [1, 10] for bent
    fibers). The objective is Omega: either an analytic estimate from the centre lines
    (pairwise crossing volume ``int w_i(z) w_j(z) dz / sin(alpha)`` of two cylinders at
    axis distance d and angle alpha), or the voxel count of Eq. (8) on a coarse grid
    (``objective="voxel"``, as the paper).
"""

from __future__ import annotations

from psdesign.packing.fiberset import (
    BENT_SAMPLES_PER_WAVE,
    Contacts,
    FiberState,
    Pieces,
    build_pieces,
    carrier_lengths,
    clearance,
    copies_in_box,
    find_contacts,
    orientation_tensor,
    segment_distance,
)
from psdesign.packing.ga_settings import GASettings
from psdesign.packing.genetic import GAResult, analytic_omega, crossing_volume, genetic
from psdesign.packing.placement_settings import PlacementSettings
from psdesign.packing.sequential import PlacementResult, place_sequential, torus_offsets

__all__ = [
    "BENT_SAMPLES_PER_WAVE",
    "Contacts",
    "FiberState",
    "GAResult",
    "GASettings",
    "Pieces",
    "PlacementResult",
    "PlacementSettings",
    "analytic_omega",
    "build_pieces",
    "carrier_lengths",
    "clearance",
    "copies_in_box",
    "crossing_volume",
    "find_contacts",
    "genetic",
    "orientation_tensor",
    "place_sequential",
    "segment_distance",
    "torus_offsets",
]
