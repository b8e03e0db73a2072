"""The representative volume element: a box in metres and a set of fibers.

Fields are evaluated in normalized coordinates ``xi = r / period`` (one PS period
equals ``period`` metres, by default the largest edge of the box, so a cube is the
paper's unit cube) and reported in metres.

Union (Eq. 7) is ``min`` over the fibers' *normalized* fields (each fiber's PS
function minus its isovalue, divided by its surface gradient norm), so that
magnitudes approximate signed distances and are comparable across diameters and
moments. Pairwise intersection (Eq. 8), ``min_{i<j} max(phi_i, phi_j)``, is the
second smallest fiber field at a point.

Voxelization is narrow-band: a fiber with a known band radius is evaluated only in
voxels within that radius (plus a margin) of its carrier axis copies, so the cost
grows with the fibers' volume, not with ``n_fibers x n_voxels``. Outside every band
the distance field holds the clip value (``margin`` metres, positive = pore).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import ClassVar

import numpy as np

from psdesign.geometry.fibers import Fiber

#: Default narrow-band margin beyond a fiber's band radius, in voxels.
BAND_MARGIN_VOXELS = 3


def _fiber_widths(rve) -> list[tuple[float, bool]]:
    """(width, non-round) of each fiber of ``rve`` with a positive finite width, normalized:
    its thin width (:attr:`psdesign.geometry.fibers.Fiber.thin_width`) where it has one, else
    its diameter (a round section)."""
    out = []
    for fb in getattr(rve, "fibers", None) or ():
        thin = getattr(fb, "thin_width", None)
        w = float((getattr(fb, "diameter", 0) or 0) if thin is None else thin)
        if np.isfinite(w) and w > 0:
            out.append((w, thin is not None))
    return out


def thinnest_fiber_diameter(rve) -> float | None:
    """Thinnest fiber width of ``rve`` in metres, or None without fibers (an image, or None):
    the one measure of a fiber RVE's resolution (cells per diameter, the FEM's default lattice
    step, the force field's grid). A round fiber's width is its diameter; a non-round one's
    (a fixed shape: woven, compressed) its thin width, not its nominal (mean) diameter: the
    Eq. (19) woven yarn is 14.0 um thick, 16.0 um in diameter at a 100 um period, so a grid
    with 7 voxels through it has 7, not 8, per width (session 43).

    >>> from types import SimpleNamespace
    >>> fibers = [SimpleNamespace(diameter=0.07), SimpleNamespace(diameter=0.05)]
    >>> round(thinnest_fiber_diameter(SimpleNamespace(fibers=fibers, period=1e-4)), 12)
    5e-06
    >>> yarn = SimpleNamespace(diameter=0.16, thin_width=0.14)
    >>> round(thinnest_fiber_diameter(SimpleNamespace(fibers=[yarn], period=1e-4)), 12)
    1.4e-05
    >>> thinnest_fiber_diameter(None) is None
    True
    """
    w = _fiber_widths(rve)
    return min(w)[0] * float(rve.period) if w else None


#: The words of the resolution measure in status reasons and warnings: a round fiber's (rods,
#: an image, no fibers) and a non-round fixed shape's (:func:`resolution_measure`).
DIAMETER_MEASURE = "fiber diameter"
THIN_WIDTH_MEASURE = "fiber thin width"


def resolution_measure(rve) -> str:
    """The words for :func:`thinnest_fiber_diameter`'s measure in a status or warning line:
    ``"fiber thin width"`` when the thinnest fiber width of ``rve`` is a non-round section's
    thin width, else ``"fiber diameter"`` (round fibers, an image, None).

    >>> from types import SimpleNamespace
    >>> yarn = SimpleNamespace(diameter=0.16, thin_width=0.14)
    >>> resolution_measure(SimpleNamespace(fibers=[yarn])), resolution_measure(None)
    ('fiber thin width', 'fiber diameter')
    """
    w = _fiber_widths(rve)
    return THIN_WIDTH_MEASURE if w and min(w)[1] else DIAMETER_MEASURE


def is_cubic(spacing, rtol: float = 1e-9) -> bool:
    """Whether a grid's ``spacing`` (metres, per axis) is cubic: every axis within ``rtol`` of
    the first, with no absolute slack (numpy's default ``atol=1e-8`` is 1 % of a 1 um voxel: a
    (1, 1, 1.009) um grid passed as cubic until session 50). The one rule of the voxel and FEM
    routes, the transport solves, the image readers and :func:`~psdesign.image.fields.resample`.

    >>> is_cubic([1e-6, 1e-6, 1e-6]), is_cubic([1e-6, 1e-6, 1.009e-6])
    (True, False)
    """
    h = np.asarray(spacing, float)
    return bool(np.allclose(h, h[0], rtol=rtol, atol=0.0))


def in_metres(length: float, unit: float) -> float:
    """``length`` (in a unit of ``unit`` metres) in metres, so that a length whose decimal
    terminates within 12 significant digits reads as written, not as the float product's last
    bit (a 0.8 pixels-per-um resolution is 1.25 um, written 1.2499999999999999e-06 m in
    rve.json until session 51; a generated RVE's 1 um voxel, 20e-6 / 20,
    1.0000000000000002e-06 m until session 52: :meth:`VoxelGrid.from_voxel`): one rule for an
    image's voxels and a generated grid's. Such a value is the product rounded to 15
    significant digits (a move of at most 5e-15 of itself); any other is the product itself
    (3 pixels per um: 3.333333333333333e-07), so a grid whose edge has no short decimal
    (100 um / 90) keeps ``size / shape`` exactly and its voxel centres, hence which voxels a
    surface on a voxel boundary covers, do not move (the session 52 merge moved them,
    ``test_the_errors_of_the_lenses_add_with_their_signs``).

    >>> 1 / 0.8 * 1e-6, in_metres(1 / 0.8, 1e-6)
    (1.2499999999999999e-06, 1.25e-06)
    >>> in_metres(1 / 3, 1e-6), in_metres(100 / 90, 1e-6)
    (3.333333333333333e-07, 1.111111111111111e-06)
    """
    value = length * unit
    short = float(f"{value:.12g}")
    return short if short == float(f"{value:.15g}") else value


@dataclass(frozen=True)
class VoxelGrid:
    """Cell-centred voxel grid of a box ``[0, size]`` in metres.

    Attributes
    ----------
    shape : tuple of int
        Voxel counts (nx, ny, nz).
    spacing : ndarray (3,)
        Voxel edge lengths in metres (``size / shape``, its decimal as written where it is short,
        :func:`in_metres`; equal to the requested voxel size when the box is a whole number
        of voxels).
    """

    size: np.ndarray
    shape: tuple[int, int, int]
    spacing: np.ndarray

    @classmethod
    def from_voxel(cls, size: np.ndarray, voxel: float) -> VoxelGrid:
        size = np.asarray(size, float)
        shape = tuple(int(max(1, round(s / voxel))) for s in size)
        # the edge rounded as image voxels are (in_metres): 20e-6 / 20 wrote
        # 1.0000000000000002e-06 into summary.json, mesh.json, rve.tif and .vti
        spacing = np.array([in_metres(s / n, 1.0) for s, n in zip(size, shape, strict=True)])
        return cls(size=size, shape=shape, spacing=spacing)

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Voxel-centre coordinates along each axis (metres)."""
        return tuple(
            (np.arange(n) + 0.5) * h for n, h in zip(self.shape, self.spacing, strict=True)
        )

    def to_dict(self) -> dict:
        return {
            "shape": list(self.shape),
            "spacing_m": self.spacing.tolist(),
            "size_m": self.size.tolist(),
            "n_voxels": int(np.prod(self.shape)),
        }


@dataclass(frozen=True)
class VoxelFields:
    """Voxelized RVE.

    Attributes
    ----------
    distance : ndarray float32 (nx, ny, nz)
        Union field in metres (approximate signed distance, <= 0 in solid), clipped
        above at the band margin.
    count : ndarray uint8 (nx, ny, nz)
        Number of fibers whose solid contains the voxel centre.
    grid : VoxelGrid
    analytic_distance : bool (class attribute)
        True when ``distance`` samples an analytic surface (sub-voxel walls and volumes
        possible); False for a segmented image (:class:`psdesign.image.fields.ImageFields`).
    """

    distance: np.ndarray
    count: np.ndarray
    grid: VoxelGrid
    analytic_distance: ClassVar[bool] = True

    @property
    def solid(self) -> np.ndarray:
        """Boolean solid mask (True = fiber)."""
        return self.distance <= 0.0

    @property
    def porosity(self) -> float:
        """Pore volume fraction of the box."""
        return float(1.0 - np.count_nonzero(self.distance <= 0.0) / self.distance.size)

    def varies_along(self, axis: int) -> bool:
        """Whether the geometry varies along ``axis`` (0, 1, 2): some two slices of
        :attr:`distance` normal to it differ. Along an axis it does not (an extruded, quasi-2-D
        geometry; one voxel always) the periodic flow, the pores and the box's edge do not
        matter: the edge is an arbitrary depth, the flow is the same at any count of voxels
        (:func:`psdesign.flow.permeability.check_grid_voxels`), a pore's size is not bounded by
        it (:func:`psdesign.transport.study_outputs.varying_edge`) and a permeameter along it
        has no entrance reach beyond the measured gap term
        (:func:`psdesign.flow.error.window_rel_error`).

        Read once per axis and kept (:attr:`_varies`): an ``"auto"`` permeameter asks it for
        its window term (:func:`psdesign.flow.permeability.auto_lengthen`) and again for the
        error bar (:func:`~psdesign.flow.permeability.with_error_estimate`), one pass over the
        field each until session 53."""
        known = self._varies
        if axis not in known:
            known[axis] = bool(np.any(np.ptp(self.distance, axis=axis)))
        return known[axis]

    @cached_property
    def _varies(self) -> dict[int, bool]:
        """:meth:`varies_along`'s answers by axis (the fields are not changed once built)."""
        return {}

    @cached_property
    def wall_distance(self) -> np.ndarray:
        """Distance of each voxel centre to the wall, in voxels (float32, read-only;
        :func:`psdesign.geometry.throat.wall_distance_voxels` at the grid's step): the throat
        term of a voxel K's error bar along each axis reads it, so a ``--direction all`` solve
        transforms the grid once (0.66-0.77 s and 32 MB at 200^3; session 41,
        benchmarks/RESULTS.md). Held with the fields, 4 B per voxel: within the voxel route's
        estimate (:data:`psdesign.schema.budget.VOXEL_SOLVER_BYTES_PER_VOXEL` counts 107 + 9 B
        per cell, the traced peak is 80.7-87.9 B, solvers/voxel/memory.py)."""
        from psdesign.geometry.throat import wall_distance_voxels

        step = float(self.grid.spacing[0])
        out = wall_distance_voxels(self.distance, step, self.analytic_distance)
        out.flags.writeable = False
        return out

    @cached_property
    def porosity_error(self) -> float:
        """Estimated absolute error of :attr:`porosity` (a voxel count) against the analytic
        surface's pore fraction (:func:`psdesign.geometry.porosity.porosity_error`); 0 for a
        segmented image, which is its own geometry."""
        if not self.analytic_distance:
            return 0.0
        from psdesign.geometry.porosity import porosity_error

        h = float(np.prod(self.grid.spacing) ** (1.0 / 3.0))
        return porosity_error(self.distance, h, self.porosity)

    @property
    def intersection_volume_fraction(self) -> float:
        """Omega of Sec. 7.1 as a fraction of the box: voxels inside two or more fibers."""
        return float(np.count_nonzero(self.count >= 2) / self.count.size)

    @cached_property
    def intersection_error(self) -> float:
        """Estimated absolute error of :attr:`intersection_volume_fraction`, a voxel count
        (:func:`psdesign.geometry.porosity.count_fraction_error`)."""
        from psdesign.geometry.porosity import count_fraction_error

        return count_fraction_error(self.count >= 2)


def checked_fields(fields: object) -> VoxelFields:
    """``fields`` when it is :class:`VoxelFields` (an image's too), else one
    :class:`~psdesign.errors.SpecError` line naming ``fields``: the transport functions
    (docs/transport.md) given something else raised ``AttributeError: 'int' object has no
    attribute 'grid'`` (session 46 walk; mended in session 47).

    >>> checked_fields(3)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    psdesign.errors.SpecError: fields: must be the voxel fields of a material (...), got int
    """
    if not isinstance(fields, VoxelFields):
        from psdesign.errors import SpecError

        raise SpecError(
            "fields",
            "must be the voxel fields of a material (psdesign.build(spec).fields, a "
            f"VoxelFields), got {type(fields).__name__}",
        )
    return fields


def _period(period: object) -> float:
    """``period`` (metres per PS period) as a float when it is one positive finite real number,
    else one :class:`~psdesign.errors.SpecError` line naming ``period``, as ``size``'s names
    ``size``: ``RVE(size, period="abc")`` raised NumPy's ``TypeError`` and ``period=0`` a
    ``ValueError`` naming no key until session 48 (review).

    >>> _period(2), _period(np.int64(3))
    (2.0, 3.0)
    >>> _period("abc")
    Traceback (most recent call last):
    ...
    psdesign.errors.SpecError: period: must be a positive length in metres, got 'abc'
    """
    real = np.ndim(period) == 0 and np.asarray(period).dtype.kind in "iuf"  # no bool, text
    value = float(period) if real else np.nan  # type: ignore[arg-type]
    if not (np.isfinite(value) and value > 0):
        from psdesign.errors import SpecError, short

        raise SpecError("period", f"must be a positive length in metres, got {short(period)}")
    return value


@dataclass
class RVE:
    """A box of fibers.

    Parameters
    ----------
    size : array_like (3,)
        Edge lengths in metres.
    fibers : list of Fiber
        Fibers in normalized coordinates.
    period : float, optional
        Metres per PS period (default: the largest edge).
    """

    size: np.ndarray
    fibers: list[Fiber] = field(default_factory=list)
    period: float | None = None

    def __post_init__(self) -> None:
        from psdesign.errors import SpecError, short

        try:
            size = np.asarray(self.size, float).reshape(3)
        except (TypeError, ValueError):  # RVE(3): NumPy's "cannot reshape array of size 1
            size = None  # into shape (3,)" named no parameter until session 48
        if size is None or not np.all(np.isfinite(size)) or np.any(size <= 0):
            # a SpecError (a ValueError): ``except psdesign.SpecError`` catches bad input
            raise SpecError(
                "size", f"must be three positive lengths in metres, got {short(self.size)}"
            )
        self.size = size
        self.period = float(self.size.max()) if self.period is None else _period(self.period)

    @property
    def box_normalized(self) -> tuple[np.ndarray, np.ndarray]:
        """The box in normalized coordinates, (lo, hi)."""
        return np.zeros(3), self.size / self.period

    # ----------------------------------------------------------- point fields
    def fiber_fields(self, points_m: np.ndarray) -> np.ndarray:
        """Each fiber's field at points, shape (n_fibers, N), metres."""
        xi = np.asarray(points_m, float) / self.period
        return np.array([fb.field(xi) for fb in self.fibers]) * self.period

    def union_field(self, points_m: np.ndarray) -> np.ndarray:
        """Eq. (7) on normalized fields, metres; <= 0 in the solid."""
        return self.fiber_fields(points_m).min(axis=0)

    def intersection_field(self, points_m: np.ndarray) -> np.ndarray:
        """Eq. (8): ``min_{i<j} max(phi_i, phi_j)`` = the second smallest fiber field."""
        if len(self.fibers) < 2:
            return np.full(len(np.atleast_2d(points_m)), np.inf)
        fields = self.fiber_fields(points_m)
        return np.partition(fields, 1, axis=0)[1]

    # -------------------------------------------------------------- voxels
    def grid(self, voxel: float) -> VoxelGrid:
        """Voxel grid with (approximately) the given step in metres."""
        if not (np.isfinite(voxel) and voxel > 0):
            raise ValueError(f"voxel must be a positive length, got {voxel}")
        return VoxelGrid.from_voxel(self.size, voxel)

    def voxelize(self, voxel: float, margin_voxels: int = BAND_MARGIN_VOXELS) -> VoxelFields:
        """Sample the union field and fiber counts at voxel centres (narrow band).

        Parameters
        ----------
        voxel : float
            Voxel edge in metres.
        margin_voxels : int
            Band margin beyond each fiber's band radius; the distance field is exact
            (to the fibers' own approximation) up to this distance from the solid.
        """
        grid = self.grid(voxel)
        h = grid.spacing / self.period  # normalized spacing
        margin = margin_voxels * float(h.max())
        distance = np.full(grid.shape, margin, dtype=np.float32)
        count = np.zeros(grid.shape, dtype=np.uint8)
        mark = np.zeros(grid.shape, dtype=np.uint16)
        dist_flat, count_flat = distance.reshape(-1), count.reshape(-1)
        for i, fb in enumerate(self.fibers):
            if fb.band_radius is not None:
                _rasterize_band(fb, distance, count, mark, (i % 65535) + 1, h, margin)
                continue
            for flat, vals in _fiber_full_values(fb, grid, self.period):
                dist_flat[flat] = np.minimum(dist_flat[flat], np.minimum(vals, margin))
                hit = flat[vals <= 0.0]
                count_flat[hit] = np.minimum(count_flat[hit].astype(np.int32) + 1, 255)
        distance *= np.float32(self.period)
        return VoxelFields(distance=distance, count=count, grid=grid)

    def porosity(self, voxel: float) -> float:
        """Porosity measured on the voxel grid."""
        return self.voxelize(voxel).porosity

    def medial_axes_m(self, n: int = 64) -> list[list[np.ndarray]]:
        """Medial-axis polylines of every fiber (per fiber, per copy), metres."""
        lo, hi = self.box_normalized
        return [[line * self.period for line in fb.medial_axis(lo, hi, n)] for fb in self.fibers]


def _rasterize_band(
    fb: Fiber,
    distance: np.ndarray,
    count: np.ndarray,
    mark: np.ndarray,
    mark_id: int,
    h: np.ndarray,
    margin: float,
) -> None:
    """Rasterize every axis copy of a fiber with a known band radius (numba kernel)."""
    from psdesign.geometry.raster import rasterize_copy

    radius = fb.band_radius + margin
    shape = np.array(distance.shape)
    d = np.ascontiguousarray(fb.direction, dtype=float)
    k = int(np.argmax(np.abs(d)))
    o0, o1 = [j for j in range(3) if j != k]
    win = [int(np.ceil(radius * np.sqrt(1.0 + d[j] ** 2 / d[k] ** 2) / h[j])) + 1 for j in (o0, o1)]
    m = fb.model
    cylinder = fb.shape == "cylinder"
    for p in fb.axis_copies(np.zeros(3), shape * h, radius):
        rasterize_copy(
            distance,
            count,
            mark,
            np.uint16(mark_id),
            np.ascontiguousarray(h, dtype=float),
            np.ascontiguousarray(p, dtype=float),
            d,
            k,
            o0,
            o1,
            win[0],
            win[1],
            radius,
            margin,
            cylinder,
            np.ascontiguousarray(fb.center, dtype=float),
            np.ascontiguousarray(fb.lattice[0]),
            np.ascontiguousarray(fb.lattice[1]),
            fb.diameter / 2.0,
            fb.isovalue,
            fb.grad_scale,
            m.mu,
            m.kappa,
            np.ascontiguousarray(m.H),
            m.alpha,
            m.minor_term.astype(np.int64),
            m.u,
            m.f,
            np.ascontiguousarray(m.G).reshape(-1, 3),
            m.beta,
        )


def _fiber_full_values(fb: Fiber, grid: VoxelGrid, period: float):
    """Yield (flat voxel indices, normalized field values) over the whole grid, in slabs."""
    h = grid.spacing / period
    axes = [(np.arange(n) + 0.5) * hi for n, hi in zip(grid.shape, h, strict=True)]
    yz = np.stack(np.meshgrid(axes[1], axes[2], indexing="ij"), -1).reshape(-1, 2)
    step = max(1, 2_000_000 // len(yz))
    for i0 in range(0, grid.shape[0], step):
        xs = axes[0][i0 : i0 + step]
        pts = np.column_stack([np.repeat(xs, len(yz)), np.tile(yz, (len(xs), 1))])
        flat = np.arange(i0 * len(yz), (i0 + len(xs)) * len(yz))
        yield flat, fb.field(pts)


def checked_rve(rve: object) -> RVE:
    """``rve`` when it is an :class:`RVE`, else one :class:`~psdesign.errors.SpecError` line
    naming ``rve`` (:func:`checked_fields`' twin): ``orientation_tensor(3)`` raised
    ``AttributeError`` until session 47.

    >>> checked_rve(3)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    psdesign.errors.SpecError: rve: must be an RVE (psdesign.build(spec).rve), got int
    """
    if not isinstance(rve, RVE):
        from psdesign.errors import SpecError

        raise SpecError(
            "rve", f"must be an RVE (psdesign.build(spec).rve), got {type(rve).__name__}"
        )
    return rve
