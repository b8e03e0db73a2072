"""Settings of the ``fast`` intersection removal: gap, search grid, move bounds, stop rules."""

from __future__ import annotations

from dataclasses import dataclass

from psdesign.packing.ga_settings import PAPER_MAX_ROTATION_DEG

#: What ``fast`` uses for each ``[intersections]`` key a spec leaves out (the class defaults
#: below are a library caller's): one definition, for
#: :func:`psdesign.packing.generators._fast_options` and docs/spec-keys.md
#: (:func:`psdesign.schema.keys.code_defaults`). ``max_shift``'s is
#: :data:`~psdesign.packing.ga_settings.PAPER_MAX_SHIFT` of the period.
FAST_SPEC_DEFAULTS = {
    "max_rotation_deg": PAPER_MAX_ROTATION_DEG,
    "orientation_tries": 4,
    "max_ejections": 6,
    "exceed_bounds": True,
    "exceed_rotation_deg": 5.0,
}
#: The shift search's grid step without ``intersections.step``: this fraction of the thinnest
#: drawn diameter (:class:`psdesign.packing.sequential` placement).
DEFAULT_STEP_DIAMETERS = 0.25


@dataclass(frozen=True)
class PlacementSettings:
    """How :func:`psdesign.packing.sequential.place_sequential` places each fiber (lengths
    normalized by the lattice period, angles in degrees).

    Attributes
    ----------
    gap : float
        Minimum surface gap; negative allows a contact overlap of ``-gap``.
    step : float, optional
        Grid step of the shift search (default: min diameter / 4).
    max_rotation_deg : float
        Re-orientation range of a fiber no shift can place (within the move bounds).
    orientation_tries : int
        Random re-orientations tried within ``+-max_rotation_deg``.
    on_reject : {"skip", "raise"}
        What to do with a fiber that fits nowhere: leave it out, or stop and return the
        fibers placed so far (``rejected`` then lists the first failure).
    max_consecutive_rejects : int, optional
        Stop after this many fibers in a row found no place (the packing is jammed).
    max_shift_z : float, optional
        Largest allowed z component of a shift, to keep a drawn through-plane position
        distribution (e.g. beta z translations, Fig. 17); in-plane moves stay free. Default:
        the whole lattice torus.
    max_ejections : int
        A fiber that fits nowhere may eject the placed fibers blocking its least blocked
        position; they go back to the front of the queue. Each fiber can be ejected at most
        this often (0 disables ejection).
    max_shift : float, optional
        Move bound: largest shift length a fiber may move from where it was drawn (the
        paper's GA range is 0.1 of the RVE edge per component). Every fiber is first placed
        within ``max_shift`` (re-orientations within ``max_rotation_deg``, ejections
        included); only if that fails is it moved to the nearest free shift beyond the bound
        (``exceed=True``, recorded in ``PlacementResult.exceeded``) or rejected
        (``exceed=False``). Default: no bound.
    exceed : bool
    exceed_rotation_deg : float
        Re-orientation range of that second, out-of-bounds pass (``max_rotation_deg`` is the
        bound of the first); a fiber placed in the second pass counts as exceeded.

    Examples
    --------
    >>> s = PlacementSettings(gap=0.005, max_shift=0.1)
    >>> (s.gap, s.max_shift, s.max_ejections, s.on_reject)
    (0.005, 0.1, 6, 'skip')
    """

    gap: float = 0.0
    step: float | None = None
    max_rotation_deg: float = 0.0
    orientation_tries: int = 0
    on_reject: str = "skip"
    max_consecutive_rejects: int | None = None
    max_shift_z: float | None = None
    max_ejections: int = 6
    max_shift: float | None = None
    exceed: bool = True
    exceed_rotation_deg: float = 0.0
