"""Options of the pore-space mesher: one frozen :class:`MeshOptions`, built from ``[flow]``.

:func:`psdesign.meshing.pore_mesh.mesh_pore_space` takes a :class:`MeshOptions`; the old
keyword arguments are still accepted and mapped here (:meth:`MeshOptions.from_kwargs`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from psdesign.geometry.rve import thinnest_fiber_diameter  # noqa: F401 (re-exported)
from psdesign.meshing.errors import MeshInputError

MESHERS = ("stuffing", "pytetwild")
VOLUME_TARGETS = ("analytic", "voxel")
TETWILD_OPTIONS = ("stop_energy", "num_opt_iter", "coarsen", "simplify")
# old keyword names of mesh_pore_space -> MeshOptions field
_LEGACY_NAMES = {"stuffing_alpha": "alpha", "stuffing_slab_factor": "slab_factor"}


#: Default stuffing lattice step: at most the smallest box edge over this many cells (the
#: box-relative rule, alone before session 7: 3.33 um in a 100 um box) ...
LATTICE_CELLS_PER_BOX = 30.0
#: ... and at most the thinnest fiber diameter over this many cells (2.33 um for D = 7 um, in
#: any box). Table III Toray-like RVE, 100 um cube, D = 7 um, seed 1, FEM permeameter: K_z at
#: 3.33 / 2.86 / 2.5 / 2.0 um is 6.4695 / 6.4039 / 6.3901 / 6.3606e-12, +2.7 / +1.7 / +1.4 /
#: +1.0 % over a second-order fit's limit (6.30e-12); measurements at D / 3 in
#: ``docs/meshers.md`` (session 7).
LATTICE_CELLS_PER_DIAMETER = 3.0
#: Stuffing axial step in the auxiliary zones, in lattice steps (``MeshOptions.slab_factor``).
DEFAULT_SLAB_FACTOR = 3.0


def default_lattice_step(voxel: float, size, fiber_diameter: float | None = None) -> float:
    """The stuffing mesher's lattice step when ``flow.lattice_step`` is not given.

    ``max(2 voxel, min(min(size) / LATTICE_CELLS_PER_BOX, D / LATTICE_CELLS_PER_DIAMETER))``
    with ``D = fiber_diameter``, the thinnest fiber width (a yarn's thin width): 2.33 um for 7 um
    fibers whatever the box, 3.33 um (the box term) for a 100 um image or plain field
    (``fiber_diameter`` None). The FEM route may coarsen it to fit the memory budget
    (:func:`psdesign.schema.budget.fem_lattice_step`).

    >>> round(default_lattice_step(0.5e-6, [100e-6] * 3) * 1e6, 4)
    3.3333
    >>> round(default_lattice_step(0.5e-6, [100e-6] * 3, 7e-6) * 1e6, 4)
    2.3333
    >>> round(default_lattice_step(0.5e-6, [50e-6] * 3, 7e-6) * 1e6, 4)
    1.6667
    """
    step = float(np.min(size)) / LATTICE_CELLS_PER_BOX
    if fiber_diameter is not None and fiber_diameter > 0:
        step = min(step, float(fiber_diameter) / LATTICE_CELLS_PER_DIAMETER)
    return max(2.0 * float(voxel), step)


@dataclass(frozen=True)
class MeshOptions:
    """Every choice of the pore mesher (lengths in metres).

    Attributes
    ----------
    mesher
        ``'stuffing'`` (default: deterministic lattice mesher, seconds) or ``'pytetwild'``
        (fTetWild on the exact box-minus-fibers surface; minutes, not deterministic).
    aux_length
        Empty auxiliary zone at inlet and outlet, fraction of the RVE length, in [0, 2]
        (paper Fig. 19); forced to 0 when ``periodic``.
    periodic
        Mesh for periodic boundary conditions (``flow.bc = "periodic"``): no auxiliary zones,
        the field interpolated periodically, opposite box faces with matching vertices
        (``PoreMesh.periodic_pairs``). Stuffing only.
    match_volume
        Shift the meshed level set so that the mesh pore volume equals ``volume_target``
        (removes the chord bias of a piecewise-linear boundary).
    volume_target
        ``'analytic'`` (default: sub-voxel estimate from the signed distance,
        :mod:`psdesign.meshing.pore_volume`) or ``'voxel'`` (voxel count, the old target).
    offset
        Explicit level offset in metres (the surface meshed is ``distance = offset``); if set,
        no volume matching is done.
    min_gap_voxels
        Closing diameter in voxels for pore gaps between nearly touching fibers, in [0, 10].
    volume_tol
        Allowed relative difference between the mesh volume and its target, in (0, 1).
    min_pore_fraction
        Minimum fraction of RVE tet centroids in the pore, in [0, 1].
    cache_dir
        Folder of cached meshes (keyed by a hash of field + options), or None.
    seed
        Recorded and part of the cache key (pytetwild itself has no seed).
    lattice_step
        Stuffing lattice step; default :func:`default_lattice_step` (fiber-relative when
        ``fiber_diameter`` is known: D / 3, at most min(size) / 30, at least 2 voxels).
    alpha
        Stuffing warping threshold in (0, 0.5) (fraction of a lattice edge).
    slab_factor
        Stuffing axial step in the auxiliary zones as a multiple of ``lattice_step``, [1, 10].
    edge_length
        pytetwild target edge length in metres (overrides the other two edge options).
    edge_length_fac
        pytetwild target edge length as a fraction of the box diagonal (auxiliary zones
        included), in (0, 1] (``flow.edge_length``). Default (None): ``edge_per_diameter``
        times ``fiber_diameter`` when that is known, else 0.05 of the diagonal
        (:func:`target_edge_length`).
    fiber_diameter
        Thinnest fiber diameter of the RVE in metres, or None (a plain field); sets pytetwild's
        default edge length and the stuffing mesher's default lattice step. The spec routes
        pass it (:func:`thinnest_fiber_diameter`).
    edge_per_diameter
        pytetwild default edge length in fiber diameters, in (0, 10]; default
        ``EDGE_PER_DIAMETER`` (0.85; its measurements in ``docs/meshers.md``).
    epsilon
        pytetwild envelope as a fraction of the box diagonal, in (0, 0.1); default
        :data:`ENVELOPE_PER_DIAMETER` times ``fiber_diameter`` where the edge comes from the
        fiber diameter, else half the marching-cubes step (``tetwild_mesher.ENVELOPE_PER_STEP``;
        :func:`envelope_from_diameter`).
    surface_step
        Sub-sampling step of the field for the marching-cubes surface (pytetwild input).
    simplify_tol
        Surface decimation tolerance in metres (manifold3d ``simplify``); 0 disables.
    aux_edge_factor
        pytetwild target edge length at the inlet and outlet faces as a multiple of the RVE's,
        in [1, 10]: a sizing field grows it linearly through the empty auxiliary zones
        (1 = uniform, no sizing field).
    num_threads
        pytetwild threads (0 = all cores).
    project_walls
        pytetwild: move the curved-wall vertices onto the zero set of the interpolated field
        (the stuffing mesher's :class:`~psdesign.meshing.stuffing.PoreField`) before the
        volume correction, removing the fTetWild envelope's scatter. Off by default: on the
        Table III RVE it moved K away from the stuffing mesher's (``docs/meshers.md``,
        session 6).
    tetwild_options
        Extra pytetwild arguments (``stop_energy``, ``num_opt_iter``, ``coarsen``, ``simplify``).
    """

    mesher: str = "stuffing"
    aux_length: float = 0.2
    periodic: bool = False
    match_volume: bool = True
    volume_target: str = "analytic"
    offset: float | None = None
    min_gap_voxels: float = 1.0
    volume_tol: float = 0.02
    min_pore_fraction: float = 0.97
    cache_dir: str | Path | None = None
    seed: int = 0
    lattice_step: float | None = None
    alpha: float = 0.3
    slab_factor: float = DEFAULT_SLAB_FACTOR
    edge_length: float | None = None
    edge_length_fac: float | None = None
    fiber_diameter: float | None = None
    edge_per_diameter: float | None = None
    epsilon: float | None = None
    surface_step: int | None = None
    simplify_tol: float = 0.0
    aux_edge_factor: float = 1.0
    num_threads: int = 1
    project_walls: bool = False
    tetwild_options: dict | None = field(default=None, hash=False)

    def __post_init__(self) -> None:
        _check(self)
        if self.periodic and self.aux_length != 0.0:
            object.__setattr__(self, "aux_length", 0.0)

    @classmethod
    def from_flow(cls, flow: dict, **overrides) -> MeshOptions:
        """Options from a spec's ``[flow]`` table (keys ``mesher``, ``aux_length``,
        ``lattice_step``, ``edge_length`` (fraction of the box diagonal), ``bc``).

        ``bc = "periodic"`` selects :attr:`periodic`; ``overrides`` replace single fields.
        """
        kw: dict = {"mesher": flow.get("mesher") or "stuffing"}
        if flow.get("aux_length") is not None:
            kw["aux_length"] = float(flow["aux_length"])
        if flow.get("edge_length") is not None:
            kw["edge_length_fac"] = float(flow["edge_length"])
        if flow.get("lattice_step") is not None:
            kw["lattice_step"] = float(flow["lattice_step"])
        if flow.get("bc") == "periodic":
            kw["periodic"] = True
        kw.update(overrides)
        return cls.from_kwargs(**kw)

    @classmethod
    def from_kwargs(cls, **kwargs) -> MeshOptions:
        """Options from the old keyword arguments of ``mesh_pore_space`` (and field names)."""
        names = {f.name for f in dataclasses.fields(cls)}
        kw = {}
        for key, value in kwargs.items():
            key = _LEGACY_NAMES.get(key, key)
            if key not in names:
                raise MeshInputError(
                    f"unknown mesh option {key!r}; allowed: {', '.join(sorted(names))}",
                    key="options",
                )
            kw[key] = value
        return cls(**kw)

    def replace(self, **changes) -> MeshOptions:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def cache_params(self) -> dict:
        """The options that change the mesh (part of the cache key).

        ``fiber_diameter`` and ``edge_per_diameter`` only count where they set the edge length
        and the envelope (pytetwild without an explicit edge): a stuffing mesh keeps its key.
        """
        d = dataclasses.asdict(self)
        d.pop("cache_dir")
        if self.mesher != "pytetwild":
            d.pop("project_walls")
        if self.mesher != "pytetwild" or not edge_from_diameter(self):
            d.pop("fiber_diameter")
            d.pop("edge_per_diameter")
        return d


# edge length without a fiber list (a plain field): this fraction of the box diagonal
DEFAULT_EDGE_FAC = 0.05
# default edge length in thinnest-fiber diameters (spec routes): the old rule's edge on the 60 um
# Toray-like cube; at 100 um it reads K 0.50 % above 1.42 D (docs/meshers.md, session 5)
EDGE_PER_DIAMETER = 0.85


# default fTetWild envelope where the edge comes from the fiber diameter: D / 28 (0.25 um at
# D = 7 um, a quarter of the marching-cubes step on Table III). Half the old step rule: it
# puts pytetwild's K within 2 % of the default stuffing mesh's on the five Table III seeds
# (the old envelope missed seed 1 by -2.12 %) at 1.1-4.1x the mesh CPU (2.0x summed)
# (docs/meshers.md, session 9). fTetWild facets the walls as coarsely as its envelope allows, so
# an envelope in fiber diameters keeps the facets per fiber circumference the same in any box
ENVELOPE_PER_DIAMETER = 1.0 / 28.0


def edge_from_diameter(opts: MeshOptions) -> bool:
    """True when pytetwild's edge length comes from ``opts.fiber_diameter`` (no explicit
    ``edge_length`` or ``edge_length_fac``)."""
    return opts.fiber_diameter is not None and opts.edge_length is None and not opts.edge_length_fac


def envelope_from_diameter(opts: MeshOptions) -> float | None:
    """pytetwild's default envelope in metres, :data:`ENVELOPE_PER_DIAMETER` times the fiber
    diameter, where it applies: no explicit ``epsilon`` and the edge from the fiber diameter
    (:func:`edge_from_diameter`; an explicit coarse edge keeps the cheaper step rule); else
    None (the mesher's marching-cubes step rule)."""
    if opts.epsilon is not None or not edge_from_diameter(opts):
        return None
    return ENVELOPE_PER_DIAMETER * float(opts.fiber_diameter)


def target_edge_length(size: np.ndarray, axis: int, opts: MeshOptions) -> float:
    """pytetwild's target edge length in metres.

    In this order: ``opts.edge_length`` (metres); ``opts.edge_length_fac`` times the diagonal of
    the meshed box (auxiliary zones included; ``flow.edge_length``); ``edge_per_diameter``
    (default :data:`EDGE_PER_DIAMETER`) times ``opts.fiber_diameter``, the thinnest fiber
    (the default on the spec routes); else :data:`DEFAULT_EDGE_FAC` of the diagonal (a plain
    field with no fiber list).

    Parameters
    ----------
    size
        RVE edge lengths (m).
    axis
        Flow axis (0, 1, 2): the auxiliary zones extend the box along it.
    opts
        Mesher options.

    Returns
    -------
    float
        Target edge length (m).
    """
    if opts.edge_length is not None:
        return float(opts.edge_length)
    ext = np.asarray(size, dtype=float).copy()
    ext[axis] *= 1.0 + 2.0 * opts.aux_length
    diag = float(np.linalg.norm(ext))
    if opts.edge_length_fac is not None:
        return opts.edge_length_fac * diag
    if edge_from_diameter(opts):
        per_d = opts.edge_per_diameter if opts.edge_per_diameter is not None else EDGE_PER_DIAMETER
        return per_d * opts.fiber_diameter
    return DEFAULT_EDGE_FAC * diag


#: pytetwild tets per target-edge cube of meshed box (RVE copies plus auxiliary zones), at the
#: default edge: the five Table III straight seeds at 0.85 D (188-194 k tets in a 100 x 100 x
#: 140 um box, 5.95 um edge) give 28.2-29.1; rounded up. The count grows more slowly than
#: edge^-3 (the envelope refines the walls): at 1.42 D one seed gave 58, so coarser edges scale
#: with :data:`TETWILD_COARSE_EXPONENT` (docs/meshers.md, session 6).
TETWILD_TETS_PER_EDGE_CUBE = 30.0
#: n_tets ~ edge^-(3 - TETWILD_COARSE_EXPONENT) above the default edge (82 k at 9.95 um, 193 k
#: at 5.95 um: exponent 1.66, so 1.34 here, rounded up to 1.4).
TETWILD_COARSE_EXPONENT = 1.4
#: Vertices per tet of a pytetwild mesh (0.227-0.233 on the five seeds).
TETWILD_POINTS_PER_TET = 0.24
#: Tets per edge cube with the fiber-diameter envelope (:data:`ENVELOPE_PER_DIAMETER`, the
#: default where the edge comes from the fiber diameter): the Table III straight seeds at
#: 0.85 D with an envelope of D / 28 (docs/meshers.md, session 9); rounded up.
TETWILD_TETS_PER_EDGE_CUBE_FINE = 55.0


def tetwild_mesh_size(
    box_volume: float, edge: float, fiber_diameter: float | None, fine_envelope: bool = False
):
    """Estimated ``(n_points, n_tets)`` of a pytetwild mesh before meshing.

    ``TETWILD_TETS_PER_EDGE_CUBE * box_volume / edge^3`` (``TETWILD_TETS_PER_EDGE_CUBE_FINE``
    with ``fine_envelope``, the fiber-diameter envelope of :func:`envelope_from_diameter`),
    times ``(edge / (EDGE_PER_DIAMETER * D))^TETWILD_COARSE_EXPONENT`` for an edge coarser than
    the default one (``fiber_diameter`` D known).

    Parameters
    ----------
    box_volume
        Meshed volume in m^3 (every RVE copy plus the auxiliary zones).
    edge
        Target edge length in metres (:func:`target_edge_length`).
    fiber_diameter
        Thinnest fiber diameter in metres, or None.
    fine_envelope
        The envelope is the fiber-diameter one (more tets at the walls).

    Returns
    -------
    tuple of float
        Vertices and tets.
    """
    per_cube = TETWILD_TETS_PER_EDGE_CUBE_FINE if fine_envelope else TETWILD_TETS_PER_EDGE_CUBE
    tets = per_cube * box_volume / edge**3
    if fiber_diameter:
        tets *= max(1.0, edge / (EDGE_PER_DIAMETER * fiber_diameter)) ** TETWILD_COARSE_EXPONENT
    return TETWILD_POINTS_PER_TET * tets, tets


def mesher_options(flow: dict) -> dict:
    """Old keyword arguments of ``mesh_pore_space`` from ``[flow]`` (without ``aux_length``).

    Kept for callers that pass ``aux_length`` separately (it ignores ``bc``); new code uses
    :meth:`MeshOptions.from_flow`, which also maps ``bc = "periodic"``.
    """
    kw: dict = {"mesher": flow.get("mesher", "stuffing")}
    if flow.get("edge_length") is not None:
        kw["edge_length_fac"] = float(flow["edge_length"])
    if flow.get("lattice_step") is not None:
        kw["lattice_step"] = float(flow["lattice_step"])
    return kw


def _in(name: str, value, lo: float, hi: float, lo_open=False, hi_open=False) -> None:
    ok = value is not None and np.isfinite(value)
    ok = (
        ok and (value > lo if lo_open else value >= lo) and (value < hi if hi_open else value <= hi)
    )
    if not ok:
        lb, rb = "(" if lo_open else "[", ")" if hi_open else "]"
        raise MeshInputError(f"{name} must be in {lb}{lo:g}, {hi:g}{rb}, got {value!r}")


def _check(o: MeshOptions) -> None:
    """Range checks of every field (one-line :class:`MeshInputError` naming the field)."""
    if o.mesher not in MESHERS:
        raise MeshInputError(f"mesher must be 'pytetwild' or 'stuffing', got {o.mesher!r}")
    if o.volume_target not in VOLUME_TARGETS:
        raise MeshInputError(
            f"volume_target must be 'analytic' or 'voxel', got {o.volume_target!r}"
        )
    if o.periodic and o.mesher != "stuffing":
        raise MeshInputError(
            "periodic meshes need mesher = 'stuffing' (pytetwild cannot give matching "
            f"opposite faces), got mesher = {o.mesher!r}",
            key="mesher",
        )
    bad = sorted(set(o.tetwild_options or {}) - set(TETWILD_OPTIONS))
    if bad:
        raise MeshInputError(
            f"tetwild_options {bad} not supported; allowed: {', '.join(TETWILD_OPTIONS)}"
        )
    _in("aux_length", o.aux_length, 0.0, 2.0)
    _in("min_gap_voxels", o.min_gap_voxels, 0.0, 10.0)
    _in("volume_tol", o.volume_tol, 0.0, 1.0, lo_open=True, hi_open=True)
    _in("min_pore_fraction", o.min_pore_fraction, 0.0, 1.0)
    _in("stuffing_alpha", o.alpha, 0.0, 0.5, lo_open=True, hi_open=True)
    _in("stuffing_slab_factor", o.slab_factor, 1.0, 10.0)
    _in("aux_edge_factor", o.aux_edge_factor, 1.0, 10.0)
    if o.edge_length_fac is not None:
        _in("edge_length_fac", o.edge_length_fac, 0.0, 1.0, lo_open=True)
    if o.fiber_diameter is not None:
        _in("fiber_diameter", o.fiber_diameter, 0.0, np.inf, lo_open=True, hi_open=True)
    if o.edge_per_diameter is not None:
        _in("edge_per_diameter", o.edge_per_diameter, 0.0, 10.0, lo_open=True)
    _in("simplify_tol", o.simplify_tol, 0.0, np.inf)
    _in("num_threads", o.num_threads, 0, 1024)
    if o.lattice_step is not None:
        _in("lattice_step", o.lattice_step, 0.0, np.inf, lo_open=True, hi_open=True)
    if o.edge_length is not None:
        _in("edge_length", o.edge_length, 0.0, np.inf, lo_open=True, hi_open=True)
    if o.epsilon is not None:
        _in("epsilon", o.epsilon, 0.0, 0.1, lo_open=True, hi_open=True)
    if o.offset is not None:
        _in("offset", o.offset, -np.inf, np.inf, lo_open=True, hi_open=True)
