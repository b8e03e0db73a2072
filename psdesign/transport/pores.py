"""Pore structure of a voxelized RVE: local thickness, intrusion, surface, profiles, orientation.

* **Local thickness** (pore size distribution, Hildebrand & Ruegsegger, J. Microsc. 185, 67,
  1997): the diameter of the largest inscribed sphere containing each pore voxel.  The
  Euclidean distance map ``dt`` (:func:`psdesign.geometry.edt.periodic_edt`, minus half a
  voxel so that it measures to the voxel *faces* of the solid) is scanned over ``n_radii``
  radii ``r`` from its maximum down: the seeds ``dt >= r`` are dilated by a ball of radius
  ``r`` (one distance transform of the seed complement per radius) and voxels first
  covered get the thickness ``2 r``.  Voxels never
  covered by a scanned radius get the smallest one.  The distribution is pore-volume
  weighted; ``d10/d50/d90`` are the diameters below which 10/50/90 % of the pore volume lies.
  Their error (``diameter_error_m``) is one-sided, low: the scan step (``bin_width_m``) plus
  ``sqrt(3) h`` (:data:`CENTRE_OFFSET`), because the inscribed balls are centred on voxel
  centres, up to ``sqrt(3) h / 2`` from a pore's true centre (a slit or cylinder pore whose
  mid-plane or axis falls between voxel centres comes out one or ``sqrt(2)`` voxels narrow).
  Faces: along an axis the geometry repeats across (:func:`periodic_axes`, the rule S_v and
  the breakthrough follow) the distance and the balls reach across them into the next period
  (the scan runs on the grid padded by ``r_max + 1`` wrapped layers there, :func:`_wrapped`);
  along another the face is open, the outside pore (as PoreSpy's ``edt``): the distance sees
  only the solid inside the box (:func:`pore_distance`) and the balls are cut at the face, so
  a pore the face cuts is not closed by an imagined wall (until session 54 every face wrapped:
  a cylinder pore of diameter 16 um an image cut at its axis read 7.0 um). Such a face can
  make the value read high (a pore the face bounds counts as continuing: a 10 um slit walled
  by the y = 0 face reads 20.5 um), so there a second scan takes the outside as solid
  (:func:`walled`, a true lower bound: local thickness is monotone in the pore set) and the
  bar is two-sided, ``+diameter_error_m/-diameter_error_below_m`` (down to the walled
  d10/d50/d90), ``rel_error`` the larger side over d50 (one 20 % rule). Every face repeating:
  one scan, ``-0``, as before.
* **Intrusion / capillary drainage** (as PoreSpy's ``porosimetry``): a non-wetting fluid
  enters from the inlet face only (first layer along ``thickness_axis``; every other face is
  closed to it, crossed by no path or ball unless the geometry repeats across it, the same
  distance as above); at radius ``r`` it fills the union of balls of radius ``r`` whose centres
  ``dt >= r`` are connected to that layer through such centres.  Saturation vs accessible
  pore diameter, and the Washburn pressure ``p = -2 gamma cos(theta) / r``.  The
  **breakthrough diameter** is the largest scanned ``2 r`` whose centres ``dt >= r`` cross the
  sample (:func:`breakthrough_radius`, :func:`crosses`): along an axis the geometry repeats
  across (:func:`periodic_axes`, the rule S_v wraps by) they wind around the periodic box
  (such a cluster meets every layer, the inlet too, so it is invaded); along another one
  cluster joins the first layer to the last, faces crossed only where the geometry repeats,
  with ``dt`` open at the other faces; None when none does, with
  ``pore_space_crosses``: whether the pore space itself (``dt > 0``) crosses (a path narrower
  than the smallest scanned ball: the breakthrough unresolved, ``untrustworthy``), else no
  path at all (``blocked``).
  Where a side face (not along ``thickness_axis``) does not repeat, the same scans with it
  walled (:func:`walled`; the two ends along the axis stay open, the inlet's reservoir and the
  outlet) give ``intrusion_saturation_walled`` and ``breakthrough_diameter_walled_m``, lower
  bounds of the open-face curve and diameter (monotone in the pore set, as above).
* **Specific surface** ``S_v = A / V_box`` (m^-1) with ``A`` from marching cubes
  (:func:`skimage.measure.marching_cubes`) on the signed distance field
  ``VoxelFields.distance`` (the analytic surface sampled at voxel centres, second order, not
  voxel faces); along an axis the geometry repeats across the box (:func:`periodic_axes`) the
  grid is padded by one wrapped layer so the surface between the last and the first voxel
  layer is counted once; along any other the box face is not a surface (edge padding).  The
  error estimate compares with the same measurement (same padding) on every second voxel
  (``|S_h - S_2h| / S_h``).
* **Porosity profile** along ``thickness_axis`` (pore fraction per voxel layer), with a bound
  of each layer's error (the fraction of its voxels the surface crosses).
* **Fibre orientation tensor** ``a_ij = sum_f w_f p_i p_j / sum_f w_f`` of the fibres' carrier
  directions ``p`` (Advani & Tucker, J. Rheol. 31, 751, 1987), weight ``w_f = d_f^2`` (volume
  per unit length).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy import ndimage

from psdesign.flow.darcy import checked_axis
from psdesign.geometry.edt import edt, periodic_edt
from psdesign.geometry.rve import RVE, VoxelFields, checked_fields, checked_rve


@dataclass
class PoreSizeResult:
    """Local-thickness pore size distribution and intrusion curve (metres)."""

    diameters_m: list[float]
    volume_fraction: list[float]
    cumulative_fraction: list[float]
    pore_d10_m: float
    pore_d50_m: float
    pore_d90_m: float
    mean_diameter_m: float
    max_diameter_m: float
    intrusion_diameter_m: list[float]
    intrusion_saturation: list[float]
    intrusion_pressure_pa: list[float]
    breakthrough_diameter_m: float | None
    bin_width_m: float
    porosity: float
    #: whether the pore space itself (``dt > 0``) crosses the sample along the axis: with no
    #: breakthrough diameter, True means the path is narrower than the scan resolves (the
    #: breakthrough unresolved, not absent); False: no path at all (``blocked``)
    pore_space_crosses: bool = True
    diameter_error_m: float = 0.0
    converged: bool = True
    rel_error: float = 0.0
    wall_time_s: float = 0.0
    thickness_axis: str = "z"
    #: the axes the geometry does not repeat across (:func:`periodic_axes`), whose faces bound
    #: the values two-sidedly (:func:`walled`): "" when every face repeats
    walled_axes: str = ""
    #: how far below d10/d50/d90 the truth may lie: the largest of (open-face scan - walled
    #: scan) over the three; 0 (the bar ``+bar/-0``) when every face repeats
    diameter_error_below_m: float = 0.0
    #: the intrusion curve and breakthrough diameter with walls past the side faces
    #: (:func:`walled`), lower bounds of the open-face values above (None: every face repeats)
    intrusion_saturation_walled: list[float] | None = None
    breakthrough_diameter_walled_m: float | None = None
    #: d10, d50, d90 of the walled scan (m): each value's own lower end, the shared
    #: ``diameter_error_below_m`` their largest distance below the values
    walled_d10_d50_d90_m: list[float] | None = None

    def to_dict(self) -> dict:
        """Plain dict (JSON-ready); the walled bounds' keys only where a face does not repeat
        (a fully periodic report is key for key what it was before session 54's bounds)."""
        out = asdict(self)
        if not self.walled_axes:
            for k in _WALLED_KEYS:
                del out[k]
        return out


_WALLED_KEYS = (
    "walled_axes",
    "diameter_error_below_m",
    "intrusion_saturation_walled",
    "breakthrough_diameter_walled_m",
    "walled_d10_d50_d90_m",
)


@dataclass
class SurfaceResult:
    """Specific surface from marching cubes on the signed distance field."""

    area_m2: float
    specific_surface_m_1: float
    coarse_specific_surface_m_1: float | None
    rel_error: float
    converged: bool = True
    extra: dict = field(default_factory=dict)


def _edt_pore(distance: np.ndarray, h: float, transform=edt) -> np.ndarray:
    """Distance (voxels) from pore voxel centres to the solid surface (``transform`` of the
    pore mask: :func:`~psdesign.geometry.edt.edt` with open faces, or the periodic one).

    The signed distance field is used where it is below its clip value (the narrow band of
    the rasterizer: exact surface, sub-voxel); farther out the Euclidean distance to the
    nearest solid voxel minus half a voxel (to its face), never below the clip value.
    """
    pore = distance > 0
    clip = float(distance.max())
    if pore.all():
        return np.maximum(distance / h, 0.5 * min(pore.shape)).astype(np.float32)
    dt = transform(pore).astype(np.float32, copy=False)
    dt[pore] -= 0.5
    analytic = (distance / h).astype(np.float32)
    far = distance >= clip
    dt = np.where(far, np.maximum(dt, analytic), analytic)
    dt[~pore] = 0.0
    return dt


def _wrapped(
    dt: np.ndarray, pad: int, periodic: tuple[bool, bool, bool]
) -> tuple[np.ndarray, tuple[slice, ...]]:
    """``dt`` padded by ``pad`` wrapped layers on both sides of each ``periodic`` axis (a ball
    there crosses the face into the next period) and by none along another (nothing beyond
    the face is known: a ball is cut at it), and the slices of the original grid in it."""
    widths = [(pad, pad) if p else (0, 0) for p in periodic]
    core = tuple(slice(w[0], w[0] + n) for w, n in zip(widths, dt.shape, strict=True))
    return np.pad(dt, widths, mode="wrap"), core


def periodic_pore_distance(distance: np.ndarray, h: float) -> np.ndarray:
    """:func:`_edt_pore` of the periodic medium: the distance to the nearest solid of any
    periodic image (:func:`~psdesign.geometry.edt.periodic_edt`)."""
    return _edt_pore(distance, h, periodic_edt)


def pore_distance(fields: VoxelFields, periodic: tuple[bool, bool, bool]) -> np.ndarray:
    """Distance (voxels) from pore voxel centres to the solid's faces for the whole pore scan
    (local thickness, intrusion, breakthrough): wrapped along the ``periodic`` axes
    (:func:`periodic_axes`), open at the other faces (:func:`~psdesign.geometry.edt.
    periodic_edt`: nothing beyond them is known to be solid, as PoreSpy's ``edt``; a pore the
    box cuts is not closed by an imagined wall, nor by the solid of the opposite face).
    Periodic on all three: :func:`periodic_pore_distance`, as before session 54. An image's
    signed distance is itself periodic (:func:`psdesign.image.fields.signed_distance`), so
    with an open face its voxels' transform alone counts; an analytic distance keeps its
    surface's own value inside its band (:func:`_edt_pore`)."""
    h = float(fields.grid.spacing[0])
    pore = fields.distance > 0
    if all(periodic) or pore.all():  # no solid: the clip value, whatever the faces
        return periodic_pore_distance(fields.distance, h)
    dt = periodic_edt(pore, periodic)
    if fields.analytic_distance:  # the surface's own distance inside its band
        return _edt_pore(fields.distance, h, lambda m: dt)
    dt[pore] -= 0.5  # to the solid voxels' faces, as _edt_pore
    dt[~pore] = 0.0
    return dt


def walled(
    dt: np.ndarray, periodic: tuple[bool, bool, bool], keep_open: tuple[int, ...] = ()
) -> np.ndarray:
    """``dt`` (:func:`pore_distance`, voxels) with a wall, a solid half-space, past both faces of
    each axis not ``periodic`` (except the axes ``keep_open``): the distance to a union is the
    smaller one, and a voxel centre lies ``i + 1/2`` voxels from the face before it.

    Local thickness, intrusion and breakthrough are monotone in the pore set, and every pore
    set a continuation of the geometry past those faces gives holds the walled one, so the
    walled scan reads no more than any continuation would (a true lower bound, up to the
    resolution bar). The open scan (:func:`pore_distance`, outside = pore, ball centres inside
    the box) is the value and the upper side, a convention, not a bound over every
    continuation (outside all pore with centres there too, a face voxel's ball is unbounded):
    session 54 found a crop 1.4 um above it at d90 (``docs/transport.md``). Until session 54
    open faces alone read a 10 um slit the y = 0 face bounds as 20.5 um under ``+bar/-0``.

    >>> d = np.full((4, 1, 1), 9.0, np.float32)
    >>> walled(d, (False, True, True))[:, 0, 0].tolist(), float(walled(d, (False,) * 3, (0,)).max())
    ([0.5, 1.5, 1.5, 0.5], 0.5)
    """
    out = dt
    for a, per in enumerate(periodic):
        if per or a in keep_open:
            continue
        i = np.arange(dt.shape[a], dtype=np.float32) + 0.5
        shape = [1, 1, 1]
        shape[a] = i.size
        out = np.minimum(out, np.minimum(i, i.size - i).reshape(shape))
    return out


#: Diameter lost, in voxels, when a pore's true centre lies between voxel centres: the balls are
#: centred on voxel centres, at most ``sqrt(3) / 2`` voxel from any point, so an inscribed radius
#: is under-counted by up to that much (a slit whose mid-plane falls on a voxel face loses one
#: voxel of width, a cylinder whose axis falls on a voxel edge ``sqrt(2)``, a sphere centred on a
#: voxel corner ``sqrt(3)``; ``tests/unit/test_pores.py``).
CENTRE_OFFSET = float(np.sqrt(3.0))


def diameter_bar_text(error_m: float, below_m: float = 0.0) -> str:
    """A pore diameter's bar as every output prints it, ``+above/-below`` (metres), never
    ``± bar`` (session 48: the report printed d10-d90 ``± bar``). The scan measures low
    (:data:`CENTRE_OFFSET`, the radius step), so with every face repeating the truth lies
    between the value and the value plus ``diameter_error_m``, never below: ``-0``. Where a
    face does not repeat the value is the open-face scan's and the truth lies down to
    ``below_m`` (``diameter_error_below_m``, the walled scan: :func:`walled`) below it.

    >>> diameter_bar_text(3e-6), diameter_bar_text(0.0), diameter_bar_text(3e-6, 8.3e-6)
    ('+3.0e-06/-0', '+0/-0', '+3.0e-06/-8.3e-06')
    """

    def num(v: float) -> str:
        return "0" if v == 0 else f"{v:.1e}"

    return f"+{num(error_m)}/-{num(below_m)}"


#: A ball union is computed crop by crop (one box per seed cluster) while the boxes hold fewer
#: voxels than this fraction of the grid; otherwise by one distance transform of the whole grid.
CROP_FRACTION = 0.6


def _volume(box: tuple) -> int:
    (x0, x1), (y0, y1), (z0, z1) = box
    return (x1 - x0) * (y1 - y0) * (z1 - z0)


def _merge_boxes(boxes: list[tuple]) -> list[tuple]:
    """Replace two boxes by their bounding box wherever that holds no more voxels than the two
    (fewer, larger transforms for the same work), until no pair qualifies."""
    items = [(b, _volume(b)) for b in sorted(boxes)]
    changed = True
    while changed and len(items) > 1:
        changed = False
        merged: list[tuple] = []
        for b, vb in items:
            (bx0, bx1), (by0, by1), (bz0, bz1) = b
            for j, (o, vo) in enumerate(merged):
                (ox0, ox1), (oy0, oy1), (oz0, oz1) = o
                m = (
                    (min(ox0, bx0), max(ox1, bx1)),
                    (min(oy0, by0), max(oy1, by1)),
                    (min(oz0, bz0), max(oz1, bz1)),
                )
                vm = _volume(m)
                if vm <= vo + vb:
                    merged[j] = (m, vm)
                    changed = True
                    break
            else:
                merged.append((b, vb))
        items = merged
    return [b for b, _ in items]


def _ball_union(lab: np.ndarray, boxes: list, ids: np.ndarray, r: float) -> np.ndarray:
    """Voxels whose centre lies within ``r`` of a voxel of the clusters ``ids`` of ``lab``.

    Every ball of a cluster lies inside the cluster's bounding box grown by ``ceil(r) + 1``;
    the distance transform inside such a box (or a box holding several) to the voxels of the
    clusters in it is exact for those clusters' balls and never marks a voxel outside the
    union, so the union over the boxes equals the whole-grid transform (the same comparisons,
    bit for bit) at the cost of the boxes' volume.
    """
    lut = np.zeros(len(boxes) + 1, bool)
    lut[ids] = True
    grow = int(np.ceil(r)) + 1
    crops = [
        tuple(
            (max(s.start - grow, 0), min(s.stop + grow, n))
            for s, n in zip(boxes[k - 1], lab.shape, strict=True)
        )
        for k in ids
    ]
    crops = _merge_boxes(crops)
    if sum(map(_volume, crops)) >= CROP_FRACTION * lab.size:
        return edt(~lut[lab]) <= r
    out = np.zeros(lab.shape, bool)
    for crop in crops:
        sl = tuple(slice(lo, hi) for lo, hi in crop)
        out[sl] |= edt(~lut[lab[sl]]) <= r
    return out


def _scan_progress(n_radii: int):
    """Throttled progress of the radius scan on the command's printer (None without one):
    ``psdesign: pore scan: radius I of N (R voxels), T s``."""
    from psdesign import progress

    return progress.throttled(
        lambda s, i, r: (
            f"psdesign: pore scan: radius {i + 1} of {n_radii} ({r:.1f} voxels), {s:.0f} s"
        )
    )


def _scan(dt, pore, radii, inlet_axis, core, cover=True):
    """Local thickness (index of the radius per voxel, -1 = none) and intrusion saturation of
    the grid ``core`` (slices) inside the padded grid of ``dt, pore``.

    At each radius ``r`` the seeds ``dt >= r`` are labelled; the ball union of the clusters
    touching the inlet (the first layer of ``core`` along ``inlet_axis``, all its periodic
    images) is the invaded set, and with the ball union of the other clusters the covered set
    (two transforms, each over the clusters' boxes or the whole grid). ``cover=False``: the
    intrusion alone (no second transform); the thickness it returns is then no local
    thickness (only the inlet clusters' balls set it, every other pore voxel gets the last,
    smallest radius): read the saturation only.
    """
    lt = np.full(dt.shape, -1, np.int16)
    sat = []
    npore = max(int(np.count_nonzero(pore[core])), 1)
    invaded = np.zeros(dt.shape, bool)
    face = core[inlet_axis].start  # the inlet layer in the padded grid
    report = _scan_progress(len(radii))
    for i, r in enumerate(radii):
        if report is not None:
            report(i, r)
        seeds = dt >= r
        if not seeds.any():
            sat.append(0.0)
            continue
        lab, n = ndimage.label(seeds)
        boxes = ndimage.find_objects(lab)
        at_inlet = np.zeros(n + 1, bool)
        at_inlet[np.unique(np.take(lab, face, axis=inlet_axis))] = True
        at_inlet[0] = False
        ids = np.arange(1, n + 1)
        inlet, other = ids[at_inlet[1:]], ids[~at_inlet[1:]]
        inv = _ball_union(lab, boxes, inlet, r) if inlet.size else None
        cov = _ball_union(lab, boxes, other, r) if other.size and cover else None
        cov = inv if cov is None else (cov if inv is None else cov | inv)
        if cov is not None:
            lt[cov & pore & (lt < 0)] = i
        if inv is not None:
            invaded |= inv & pore
        sat.append(float(np.count_nonzero(invaded[core])) / npore)
    lt = lt[core]
    lt[pore[core] & (lt < 0)] = len(radii) - 1
    return lt, sat


def crosses(mask: np.ndarray, axis: int, periodic: tuple[bool, bool, bool]) -> bool:
    """Whether the True voxels of ``mask`` (face-connected) cross the box along ``axis``,
    passing a face of the box only where the geometry repeats across it (``periodic``, per
    axis: :func:`periodic_axes`, the rule S_v wraps by). Along a periodic ``axis`` a path
    winds around the box (:func:`psdesign.geometry.throat.percolates`, the voxel solver's one
    test of a path); along another one cluster joins the first layer to the last (a fluid
    layer beyond each end, joined across the wrap: the permeameter's reservoirs,
    :func:`psdesign.flow.no_path.permeameter_pore`). Across a non-periodic side axis a solid
    layer closes the wrap (the permeameter's side walls); across a periodic one it stays open.

    >>> m = np.zeros((8, 8, 1), bool); m[np.arange(8), np.arange(8) // 2 + 2, 0] = True
    >>> m[np.arange(7), np.arange(7) // 2 + 2 + 1, 0] = True  # a face-connected diagonal
    >>> crosses(m, 0, (True, True, True)), crosses(m, 0, (False, True, True))
    (False, True)
    """
    from psdesign.geometry.throat import percolates

    if not periodic[axis]:
        ends = [(1, 1) if a == axis else (0, 0) for a in range(3)]
        mask = np.pad(mask, ends, constant_values=True)
    walls = [(0, 1) if a != axis and not periodic[a] else (0, 0) for a in range(3)]
    if any(w != (0, 0) for w in walls):
        mask = np.pad(mask, walls, constant_values=False)
    return percolates(mask, axis)


def breakthrough_radius(
    dt: np.ndarray,
    radii: np.ndarray,
    axis: int,
    periodic: tuple[bool, bool, bool] = (True, True, True),
) -> float | None:
    """The largest of ``radii`` (descending, voxels) whose ball centres ``dt >= r``
    (:func:`pore_distance` of the unpadded grid, or its :func:`walled` bound) cross the box
    along ``axis`` (:func:`crosses`: wind around it along a ``periodic`` axis, join its first
    and last layers along another), None when not even the smallest does.

    Until session 53 it was the first radius with any intruded volume: a cluster touching the
    inlet layer counted though it never reached the outlet (walls across x: 23 um ``ok`` where
    no path exists, and 0 with the box cut elsewhere). Until the session 53 review the path
    had to wind around the box also along an axis the geometry does not repeat across (a
    diagonal channel from y = 6 to 22 over x: ``blocked``, D_eff/D 0.136 along it). The set
    grows as ``r`` falls, so a bisection over ``radii`` needs ``log2(n_radii)`` tests.

    >>> d = np.zeros((6, 7, 1), np.float32); d[:, 2:5, 0] = [1.0, 2.0, 1.0]  # a channel along x
    >>> breakthrough_radius(d, np.array([2.5, 2.0, 1.0]), 0)
    2.0
    >>> breakthrough_radius(d, np.array([1.0]), 1) is None  # across the channel: no path
    True
    """
    if not crosses(dt >= radii[-1], axis, periodic):
        return None
    lo, hi = 0, len(radii) - 1  # radii[hi] crosses, none before radii[lo] does
    while lo < hi:
        mid = (lo + hi) // 2
        if crosses(dt >= radii[mid], axis, periodic):
            hi = mid
        else:
            lo = mid + 1
    return float(radii[hi])


def _breakthrough(
    dt: np.ndarray, radii: np.ndarray, axis: int, periodic: tuple[bool, bool, bool]
) -> tuple[float | None, bool]:
    """:func:`breakthrough_radius` along ``axis`` and whether the pore space crosses at all
    (no scanned ball crosses: a path too narrow to resolve, or none, ``blocked``). ``dt`` is
    the scan's :func:`pore_distance` (open at the faces the geometry does not repeat across:
    a channel reaching such a face read 0.5 voxel wide in its first layer until session 53)."""
    r_break = breakthrough_radius(dt, radii, axis, periodic)
    return r_break, r_break is not None or crosses(dt > 0, axis, periodic)


def _check_pore_arguments(
    n_radii, thickness_axis, surface_tension, contact_angle_deg
) -> tuple[str, int]:
    """:func:`pore_sizes`' arguments held to the ``[transport]`` keys they are (the schema's
    ranges, one line naming the key); returns the thickness axis's name and index.

    Called from Python with other values, ``n_radii="a"`` and ``contact_angle_deg="a"`` were
    TypeErrors from numpy, ``n_radii=3`` was taken (the schema allows [4, 200]), a negative
    surface tension or a contact angle under 90 degrees (a wetting fluid: no intrusion
    pressure) made negative pressures without a word (session 46).
    """
    from psdesign.schema.transport import validate_transport

    name, ax = checked_axis(thickness_axis, "transport.thickness_axis")
    table = {
        "n_radii": n_radii,
        "thickness_axis": name,
        "surface_tension_n_m": surface_tension,
        "contact_angle_deg": contact_angle_deg,
    }
    validate_transport({"transport": table})
    return name, ax


def pore_sizes(
    fields: VoxelFields,
    n_radii: int = 16,
    thickness_axis: str | int = "z",
    surface_tension: float = 0.485,
    contact_angle_deg: float = 140.0,
    rve: RVE | None = None,
) -> PoreSizeResult:
    """Local-thickness pore size distribution and intrusion curve (see module docstring).

    Parameters
    ----------
    fields : VoxelFields
        Cubic voxels; pore where ``distance > 0``.
    n_radii : int
        Radii scanned, evenly spaced from the largest inscribed radius down to one voxel;
        in [4, 200] (``transport.n_radii``).
    thickness_axis : "x", "y", "z" or 0..2
        Intrusion inlet is the first layer along it.
    surface_tension, contact_angle_deg : float
        Intrusion fluid for the Washburn pressure (mercury by default): N/m in (0, 10) and
        degrees in (90, 180] (``transport.surface_tension_n_m``, ``contact_angle_deg``).
    rve : RVE, optional
        The fibres of ``fields``, to judge along which axes the geometry repeats across the
        box (:func:`periodic_axes`, as :func:`specific_surface`; without it the voxel layers
        judge): only there do the distance and the balls wrap (:func:`pore_distance`) and the
        intrusion's and the breakthrough's paths cross a face (:func:`crosses`).

    Raises
    ------
    SpecError
        An argument out of its ``[transport]`` key's range, naming the key.
    """
    fields = checked_fields(fields)  # a VoxelFields, else one line naming it
    t0 = time.perf_counter()
    name, ax = _check_pore_arguments(n_radii, thickness_axis, surface_tension, contact_angle_deg)
    h = float(fields.grid.spacing[0])
    pore = ~fields.solid
    eps = fields.porosity
    if not pore.any():
        raise ValueError("pores: the RVE has no pore voxel")
    # a ball crosses a face into the next period only where the geometry repeats across it
    # (with open faces a periodic RVE's pore reaching a face grew past it: d90 134 um in the
    # 100 um three-rod cube, session 31; with every face wrapped a pore an image cuts was
    # closed by the opposite face: 7 um for a 16 um cylinder, session 54)
    periodic = periodic_axes(rve, fields)
    dt = pore_distance(fields, periodic)
    rmax = float(dt.max())
    radii = np.unique(np.linspace(max(rmax, 1.0), min(1.0, rmax), n_radii))[::-1]
    r_break, through = _breakthrough(dt, radii, ax, periodic)
    # every ball reaching the grid has its centre within rmax of it: rmax + 1 wrapped layers
    # of the distance along the periodic axes hold them all
    pad = int(np.ceil(rmax)) + 1
    walls = None if all(periodic) else _walled_scan(dt, radii, ax, periodic, pad)
    dt, core = _wrapped(dt, pad, periodic)
    lt, sat = _scan(dt, dt > 0, radii, ax, core)
    del dt
    idx = lt[pore]
    diam = 2.0 * h * radii[idx]
    d_bins = 2.0 * h * radii[::-1]
    counts = np.bincount(idx, minlength=radii.size)[::-1].astype(float)
    frac = counts / counts.sum()
    q10, q50, q90 = (float(v) for v in np.percentile(diam, [10, 50, 90], method="inverted_cdf"))
    p = -2.0 * surface_tension * np.cos(np.radians(contact_angle_deg)) / (radii * h)
    sat_arr = np.asarray(sat)
    step = float(2.0 * h * (radii[0] - radii[1])) if radii.size > 1 else 2.0 * h
    bar = step + CENTRE_OFFSET * h
    bounds = _bounds(walls, (q10, q50, q90, sat, r_break), pore, radii, h, periodic)
    return PoreSizeResult(
        diameters_m=d_bins.tolist(),
        volume_fraction=frac.tolist(),
        cumulative_fraction=np.cumsum(frac).tolist(),
        pore_d10_m=q10,
        pore_d50_m=q50,
        pore_d90_m=q90,
        mean_diameter_m=float(diam.mean()),
        max_diameter_m=float(diam.max()),
        intrusion_diameter_m=(2.0 * h * radii).tolist(),
        intrusion_saturation=sat_arr.tolist(),
        intrusion_pressure_pa=p.tolist(),
        breakthrough_diameter_m=None if r_break is None else 2.0 * h * r_break,
        bin_width_m=step,
        porosity=eps,
        pore_space_crosses=bool(through),
        diameter_error_m=bar,
        # the larger side rates them, by the one 20 % rule (status_of): the truth lies within
        # rel_error * d50 of the value, above by the scan's resolution, below by the walls
        rel_error=float(max(bar, bounds.get("diameter_error_below_m", 0.0)) / q50)
        if q50 > 0
        else 0.0,
        wall_time_s=time.perf_counter() - t0,
        thickness_axis=name,
        **bounds,
    )


def _walled_scan(dt, radii, ax, periodic, pad):
    """The scans with walls past the faces not ``periodic`` (:func:`walled`) on the open scan's
    ``radii`` (the same radii, so each voxel reads no more than on the open scan): local
    thickness with every such face walled, and intrusion and breakthrough with the side faces
    walled, the two ends along ``ax`` left open (the inlet's reservoir, the outlet: the
    sample's own faces, as the open scan). Returns (thickness index, saturation, breakthrough
    radius or None; both None with no side face walled: the open scan's then); a second scan,
    intrusion alone, only where ``ax`` and a side axis are both not periodic."""
    dtw, core = _wrapped(walled(dt, periodic), pad, periodic)
    lt, sat = _scan(dtw, dtw > 0, radii, ax, core)
    if all(p for a, p in enumerate(periodic) if a != ax):  # no side wall: the open values
        return lt, None, None
    side = walled(dt, periodic, keep_open=(ax,))
    r_break = breakthrough_radius(side, radii, ax, periodic)
    if not periodic[ax]:  # the inlet face walled gives no intrusion: open it for that
        dtw, core = _wrapped(side, pad, periodic)
        sat = _scan(dtw, dtw > 0, radii, ax, core, cover=False)[1]
    return lt, sat, r_break


def _bounds(walls, opened, pore, radii, h, periodic) -> dict:
    """:class:`PoreSizeResult`'s walled fields from :func:`_walled_scan`'s ``walls`` (None:
    every face repeats, the defaults) and the open scan's d10, d50, d90 (m), saturation and
    breakthrough radius ``opened``."""
    if walls is None:
        return {}
    lt, sat, r_break = walls
    if sat is None:  # no side face walled: intrusion and breakthrough as the open scan's
        sat, r_break = opened[3:]
    low = np.percentile(2.0 * h * radii[lt[pore]], [10, 50, 90], method="inverted_cdf")
    below = max(0.0, *(v - w for v, w in zip(opened[:3], low, strict=True)))  # monotone: >= 0
    return {
        "walled_axes": "".join(a for a, p in zip("xyz", periodic, strict=True) if not p),
        "diameter_error_below_m": float(below),
        "intrusion_saturation_walled": [float(v) for v in sat],
        "breakthrough_diameter_walled_m": None if r_break is None else 2.0 * h * r_break,
        "walled_d10_d50_d90_m": [float(v) for v in low],
    }


def periodic_axes(rve: RVE | None, fields: VoxelFields) -> tuple[bool, bool, bool]:
    """Whether the geometry repeats across the box along x, y, z: the product's one test of
    the end planes (:func:`psdesign.flow.stack.end_planes`, the rule of the permeameter's
    copies: the analytic fibre surfaces when ``rve`` is given, else the voxel layers)."""
    from psdesign.flow.stack import end_planes

    p = tuple(end_planes(rve, fields, a).periodic for a in range(3))
    return p[0], p[1], p[2]


def _mc_area(
    distance: np.ndarray,
    h: float,
    periodic: tuple[bool, bool, bool],
    first: tuple[float, float, float] = (0.5, 0.5, 0.5),
    steps: tuple[int, int, int] = (1, 1, 1),
) -> float:
    """Marching-cubes area of ``distance = 0`` inside the box of the grid (voxel centres at
    ``(i + 1/2) h``). Along a periodic axis one wrapped layer closes the surface between the
    last and the first layer; along any other axis the box face is no surface (a wrapped
    layer made the seam a false wall: a cylinder on the z = 0 face of a 60x60x30 um box gave
    9731 1/m where its half surface is 6109, session 52): one edge layer on each side extends
    the field unchanged to the face, and the surface in those end cells (a prism along the
    axis) is counted by the fraction of the cell inside the box: ``first`` (the first node's
    distance from the face, in steps: 1/2 on the grid, 1/4 on every second voxel; per axis) and
    ``1 - first`` at the far face of a box ``shape`` steps long. ``steps``: the grid's step
    along each axis in voxels of edge ``h`` (2 where a coarse grid takes every second)."""
    from skimage.measure import marching_cubes

    d = distance.astype(np.float32)
    for ax, per in enumerate(periodic):
        width = [(0, 0)] * 3
        width[ax] = (0, 1) if per else (1, 1)
        d = np.pad(d, width, mode="wrap" if per else "edge")
    if d.min() > 0 or d.max() <= 0:
        return 0.0
    spacing = tuple(h * k for k in steps)
    verts, faces, _, _ = marching_cubes(d, level=0.0, spacing=spacing)
    tri = verts[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    centre = tri.mean(axis=1) / np.asarray(spacing)  # in node indices of the padded grid
    for ax, per in enumerate(periodic):
        if not per:
            c = centre[:, ax]
            area = np.where(c < 1.0, first[ax] * area, area)
            area = np.where(c > d.shape[ax] - 2.0, (1.0 - first[ax]) * area, area)
    return float(area.sum())


#: Fewest voxels along an axis for the S_v bar's coarse grid to take every second one there.
MIN_COARSE_VOXELS = 8


def specific_surface(
    fields: VoxelFields, check: bool = True, rve: RVE | None = None
) -> SurfaceResult:
    """Specific surface ``S_v`` (m^-1) by marching cubes on the signed distance field;
    ``check``: also on every second voxel, for ``rel_error`` (else 0 and no coarse value).
    ``rve``: the fibres of ``fields``, to judge along which axes the geometry repeats across
    the box (:func:`periodic_axes`; without it the voxel layers judge); only those wrap.

    The coarse grid halves only the axes with :data:`MIN_COARSE_VOXELS` or more: an axis the
    geometry does not vary along adds no error. A shorter axis it varies along is named in
    ``extra["short_axes"]`` (the bar misses its part: :func:`surface_status` rates the value
    ``untrustworthy``). Until session 53 any axis under 8 voxels dropped the coarse grid and
    printed ``+- 0.0 % [ok]`` (a rod extruded 6 voxels deep; 4.2 % at 8 deep).
    """
    fields = checked_fields(fields)  # a VoxelFields, else one line naming it
    periodic = periodic_axes(rve, fields)
    h = float(fields.grid.spacing[0])
    vol = float(np.prod(fields.grid.size))
    area = _mc_area(fields.distance, h, periodic)
    sv = area / vol
    coarse = None
    rel = 0.0
    shape = fields.distance.shape
    steps = tuple(2 if n >= MIN_COARSE_VOXELS else 1 for n in shape)
    short = "".join(
        "xyz"[a] for a in range(3) if check and steps[a] == 1 and fields.varies_along(a)
    )
    if check and max(steps) == 2:
        n = [s - s % k for s, k in zip(shape, steps, strict=True)]
        sub = fields.distance[tuple(slice(0, m, k) for m, k in zip(n, steps, strict=True))]
        # its nodes sit 1/4 of its step inside the box's first face along a halved axis
        first = tuple(0.25 if k == 2 else 0.5 for k in steps)
        coarse = _mc_area(sub, h, periodic, first, steps) / (vol * np.prod(n) / np.prod(shape))
        rel = abs(sv - coarse) / sv if sv > 0 else 0.0
    return SurfaceResult(
        area_m2=area,
        specific_surface_m_1=sv,
        coarse_specific_surface_m_1=coarse,
        rel_error=float(rel),
        extra={
            "periodic_axes": "".join(a for a, p in zip("xyz", periodic, strict=True) if p),
            "short_axes": short,
        },
    )


def surface_status(rel_error: float, short_axes: str, cpd: float | None) -> str:
    """The specific surface's status: by its bar and the resolution
    (:func:`psdesign.flow.error.status_of`), and ``untrustworthy`` when the geometry varies
    along an axis too short for the bar's coarse grid (``short_axes``, :func:`specific_surface`)."""
    from psdesign.flow.error import status_of

    status = status_of(True, rel_error, cpd)
    return "untrustworthy" if status == "ok" and short_axes else status


def porosity_profile(fields: VoxelFields, axis: str | int = "z") -> dict:
    """Pore fraction of each voxel layer along ``axis``: positions (m), porosity and its error.

    ``porosity_error`` bounds each layer's error against the layer's true (volume) pore
    fraction: a voxel is counted by its centre, and only a voxel the surface crosses
    (``|distance| < sqrt(3) h / 2`` on the analytic distance) can be counted wrongly, by at
    most its whole volume; so the bound is the fraction of such voxels in the layer.  A
    segmented image is its own geometry: 0.
    """
    fields = checked_fields(fields)  # a VoxelFields, else one line naming it
    name, ax = checked_axis(axis, "axis")
    pore = ~fields.solid
    other = tuple(b for b in range(3) if b != ax)
    prof = pore.mean(axis=other)
    h = float(fields.grid.spacing[ax])
    pos = (np.arange(prof.size) + 0.5) * h
    if fields.analytic_distance:
        cut = np.abs(fields.distance) < 0.5 * np.sqrt(3.0) * float(fields.grid.spacing.max())
        err = cut.mean(axis=other)
    else:
        err = np.zeros_like(prof)
    return {
        "axis": name,
        "position_m": pos.tolist(),
        "porosity": prof.tolist(),
        "porosity_error": err.tolist(),
    }


def orientation_tensor(rve: RVE) -> dict:
    """Second-order fibre orientation tensor of the carrier directions (weight ``d^2``);
    anything but an :class:`RVE` is refused naming ``rve`` (:func:`checked_rve`)."""
    if not checked_rve(rve).fibers:
        return {"tensor": np.zeros((3, 3)).tolist(), "eigenvalues": [0.0, 0.0, 0.0], "n_fibers": 0}
    a = np.zeros((3, 3))
    wsum = 0.0
    for fb in rve.fibers:
        p = np.asarray(fb.direction, float)
        p = p / np.linalg.norm(p)
        w = float(fb.diameter) ** 2
        a += w * np.outer(p, p)
        wsum += w
    a /= wsum
    return {
        "tensor": a.tolist(),
        "eigenvalues": np.linalg.eigvalsh(a)[::-1].tolist(),
        "n_fibers": len(rve.fibers),
    }
