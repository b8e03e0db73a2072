"""Pore-space tetrahedral mesh of an RVE with auxiliary inlet/outlet zones and boundary tags.

Pipeline (each step in :mod:`psdesign.meshing`):

1. optional closing of pore gaps narrower than ``min_gap_voxels`` (fibers that nearly touch);
2. marching-cubes surface of the fiber solid (``distance <= 0``), extended beyond the box by
   replicating the boundary layers and capped, orientation enforced outward;
3. exact box (RVE + auxiliary slabs of ``aux_length * L`` along the flow axis, manifold3d
   ``Manifold.cube``) minus the fiber solid clipped to the RVE (manifold3d booleans) -- no
   marching-cubes box, so no 45-degree strips along box edges;
4. pytetwild (fTetWild) tetrahedralization;
5. vertices of boundary faces parallel to and within two envelopes of a box plane are snapped
   exactly onto it (tets this flattens are repaired, zero-volume surface slivers dropped); faces
   whose three vertices lie on a plane are inlet / outlet / side_*; all others are ``wall``;
6. checks: tet connectivity (components touching neither inlet nor outlet are dropped, no
   inlet-outlet path -> :class:`PoreTopologyError`), tet volume against the pore volume of the
   surface, fraction of tet centroids in the pore (interpolated ``distance``), inverted tets
   (:class:`MeshFailedError`).

``mesher='stuffing'`` replaces steps 2-5 by a deterministic lattice mesher
(:mod:`psdesign.meshing.stuffing`: Kuhn-split lattice clipped to the interpolated field, box
faces exact by construction) and keeps the tags and checks (volume against the voxel pore
volume).

pytetwild is *not* deterministic (same input, different meshes, even with one thread and
``srand``); pass ``cache_dir`` to make repeated calls with the same input return the same mesh.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from psdesign.meshing.errors import MeshFailedError, MeshInputError, PoreTopologyError
from psdesign.meshing.export import export_mesh
from psdesign.meshing.quality import quality_report
from psdesign.meshing.stuffing import stuff_pore_space
from psdesign.meshing.surface import (
    AXES,
    check_voxel_connectivity,
    close_narrow_gaps,
    pore_surface,
)
from psdesign.meshing.tetra import (
    face_structure,
    keep_through_components,
    snap_to_planes,
    tag_faces,
    tet_volumes,
    tetrahedralize,
    untangle_near_planes,
)

__all__ = [
    "MeshFailedError",
    "MeshInputError",
    "PoreMesh",
    "PoreTopologyError",
    "export_mesh",
    "mesh_pore_space",
]

_CACHE_VERSION = 1


@dataclass
class PoreMesh:
    """Tetrahedral mesh of the pore space with tagged boundary facets.

    Attributes
    ----------
    points
        (n, 3) vertex coordinates in metres.
    tets
        (m, 4) vertex indices, positively oriented.
    facet_tags
        Boundary triangles (k, 3), outward-oriented, by name: ``inlet``, ``outlet``, ``wall``
        (fiber surfaces, including fiber end caps facing the auxiliary zones) and the four
        lateral faces ``side_<axis><0|1>`` (those not normal to the flow).
    direction
        Flow direction ``'x' | 'y' | 'z'``.
    porous_region
        (start, end) coordinates along the flow axis of the RVE proper (metres); the pressure drop
        across the RVE is measured between these planes.
    bounds
        (2, 3) corners of the meshed box (RVE plus auxiliary zones), metres.
    quality
        Counts, element quality, volume and pore-fraction checks, timings.
    """

    points: np.ndarray
    tets: np.ndarray
    facet_tags: dict[str, np.ndarray]
    direction: str
    porous_region: tuple[float, float]
    bounds: np.ndarray
    quality: dict = field(default_factory=dict)

    @property
    def axis(self) -> int:
        """Index (0, 1, 2) of the flow axis."""
        return AXES[self.direction]

    def tag_area(self, name: str) -> float:
        """Total area of the facets tagged ``name`` (m^2)."""
        f = self.facet_tags[name]
        p = self.points
        return float(
            0.5
            * np.linalg.norm(
                np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]]), axis=1
            ).sum()
        )

    def volume(self) -> float:
        """Total tet volume (m^3)."""
        return float(tet_volumes(self.points, self.tets).sum())


def _validate(
    distance,
    voxel,
    size,
    direction,
    aux_length,
    edge_length,
    edge_length_fac,
    epsilon,
    min_gap_voxels,
    surface_step,
):
    distance = np.asarray(distance)
    if distance.ndim != 3 or min(distance.shape) < 2:
        raise MeshInputError(
            f"distance must be a 3-D array with at least 2 samples per axis, got shape "
            f"{distance.shape}"
        )
    if not np.issubdtype(distance.dtype, np.floating) or not np.isfinite(distance).all():
        raise MeshInputError("distance must be a finite floating-point array")
    if not (np.isfinite(voxel) and voxel > 0):
        raise MeshInputError(f"voxel must be a positive length in metres, got {voxel}")
    size = np.asarray(size, dtype=float)
    if size.shape != (3,) or not (np.isfinite(size).all() and (size > 0).all()):
        raise MeshInputError(f"size must be three positive lengths in metres, got {size}")
    expected = np.asarray(distance.shape) * voxel
    if not np.allclose(expected, size, rtol=1e-6):
        raise MeshInputError(
            f"size {size.tolist()} does not match distance.shape * voxel = {expected.tolist()}"
        )
    if direction not in AXES:
        raise MeshInputError(f"direction must be 'x', 'y' or 'z', got {direction!r}")
    if not (0.0 <= aux_length <= 2.0):
        raise MeshInputError(f"aux_length must be in [0, 2] (fraction of L), got {aux_length}")
    if edge_length is not None and not (edge_length > 0):
        raise MeshInputError(f"edge_length must be a positive length in metres, got {edge_length}")
    if not (0 < edge_length_fac <= 1):
        raise MeshInputError(f"edge_length_fac must be in (0, 1], got {edge_length_fac}")
    if epsilon is not None and not (0 < epsilon < 0.1):
        raise MeshInputError(f"epsilon must be in (0, 0.1) (fraction of diagonal), got {epsilon}")
    if not (0 <= min_gap_voxels <= 10):
        raise MeshInputError(f"min_gap_voxels must be in [0, 10], got {min_gap_voxels}")
    if surface_step is not None and (
        int(surface_step) != surface_step or not (1 <= surface_step <= min(distance.shape) // 2)
    ):
        raise MeshInputError(
            f"surface_step must be an integer in [1, {min(distance.shape) // 2}], "
            f"got {surface_step}"
        )
    return distance.astype(np.float64, copy=False), float(voxel), size


def _cache_key(distance: np.ndarray, params: dict) -> str:
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(distance).tobytes())
    h.update(str(distance.shape).encode())
    h.update(json.dumps(params, sort_keys=True).encode())
    return h.hexdigest()[:32]


def mesh_pore_space(
    distance: np.ndarray,
    voxel: float,
    size,
    direction: str,
    *,
    aux_length: float = 0.2,
    edge_length: float | None = None,
    edge_length_fac: float = 0.05,
    epsilon: float | None = None,
    min_gap_voxels: float = 1.0,
    surface_step: int | None = None,
    simplify_tol: float = 0.0,
    seed: int = 0,
    num_threads: int = 1,
    tetwild_options: dict | None = None,
    volume_tol: float = 0.02,
    min_pore_fraction: float = 0.97,
    cache_dir: str | Path | None = None,
    mesher: str = "pytetwild",
    lattice_step: float | None = None,
    stuffing_alpha: float = 0.3,
    match_volume: bool = True,
    stuffing_slab_factor: float = 3.0,
) -> PoreMesh:
    """Tetrahedralize the pore space of a voxel-sampled RVE with auxiliary inlet/outlet zones.

    Parameters
    ----------
    distance
        (nx, ny, nz) approximate signed distance to the fiber surface in metres at voxel centres
        ``(i + 0.5) * voxel``; <= 0 inside fibers, > 0 in the pore.
    voxel
        Voxel size in metres; ``distance.shape * voxel`` must equal ``size``.
    size
        RVE side lengths (3,) in metres; the box is ``[0, size_x] x [0, size_y] x [0, size_z]``.
    direction
        Flow direction ``'x' | 'y' | 'z'``.
    aux_length
        Empty auxiliary zone at inlet and outlet, fraction of the RVE length along the flow
        (paper Fig. 19), in [0, 2].
    edge_length
        Target tet edge length in metres (coarseness control); if None,
        ``edge_length_fac`` times the diagonal of the meshed box.
    edge_length_fac
        Target edge length as a fraction of the meshed box diagonal (used if ``edge_length`` is
        None), in (0, 1].
    epsilon
        pytetwild envelope (max surface deviation) as a fraction of the box diagonal; default a
        quarter of the (sub-sampled) voxel.
    min_gap_voxels
        Closing diameter in voxels: pore gaps between nearly touching fibers (or between a fiber
        and a box face, which counts as a mirror plane) narrower than about this width are turned
        solid before meshing, so that they neither become sliver channels nor break the mesh;
        0 disables. A one-voxel margin protects convex surfaces from voxel quantization, so gaps
        are closed reliably up to about ``min_gap_voxels - 1`` voxels. The closed voxel count is
        reported (``n_closed_gap_voxels``).
    surface_step
        Sub-sampling step of the field for marching cubes (surface coarsening), integer >= 1.
        Default: about a fifth of the target edge length in voxels (the pytetwild time grows
        with the surface size; 1 um surfaces of a Toray-like RVE did not finish in 15 min).
    simplify_tol
        Surface decimation tolerance in metres (manifold3d ``simplify``); 0 disables. It makes
        sliver triangles and slowed pytetwild down in the benchmark; prefer ``surface_step``.
    seed
        Recorded and part of the cache key; pytetwild has no seed (see module notes).
    num_threads
        Threads for pytetwild (0 = all cores).
    tetwild_options
        Extra pytetwild arguments: ``stop_energy`` (default 10; larger stops the quality
        optimization earlier, much faster), ``num_opt_iter`` (default 80), ``coarsen``,
        ``simplify``.
    volume_tol
        Allowed relative difference between the tet volume and the pore-surface volume.
    min_pore_fraction
        Minimum fraction of RVE tet centroids that must lie in the pore (``distance > 0``).
    cache_dir
        If given, meshes are stored there keyed by a hash of the input and options and reused,
        which makes repeated calls reproducible.
    mesher
        ``'pytetwild'`` (default: unstructured fTetWild mesh of the exact box-minus-fibers
        surface) or ``'stuffing'`` (deterministic lattice mesher,
        :mod:`psdesign.meshing.stuffing`: Kuhn-split cubic lattice clipped to the interpolated
        ``distance`` field; seconds instead of minutes; ``edge_length``, ``epsilon``,
        ``surface_step``, ``simplify_tol``, ``tetwild_options`` and ``num_threads`` are
        ignored by it).
    lattice_step
        Lattice step of the ``stuffing`` mesher in metres; default
        ``max(2 * voxel, min(size) / 30)`` (3.3 um for a 100 um RVE: K within ~2 % of the
        refined value in the benchmark). Keep it near or below the fiber radius: thinner
        features can be lost.
    stuffing_alpha
        Warping threshold of the ``stuffing`` mesher in (0, 0.5) (fraction of a lattice edge).
    match_volume
        ``stuffing`` only (default True): shift the meshed level set of ``distance`` uniformly
        so that the mesh pore volume equals the voxel pore volume (removes the chord bias of
        the linear boundary, which inflates the pore by ~h^2 / (12 R) per unit fiber area; K
        of the Toray-like RVE was 55 % too high without it at a 5 um step); the shift is
        reported as ``level_offset_m``.
    stuffing_slab_factor
        ``stuffing`` only: axial lattice step in the (fiber-free) auxiliary zones as a multiple
        of ``lattice_step``, in [1, 10] (3 saved 18 % of the tets and changed K by -0.15 % on
        the Toray-like RVE).

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
    distance, voxel, size = _validate(
        distance,
        voxel,
        size,
        direction,
        aux_length,
        edge_length,
        edge_length_fac,
        epsilon,
        min_gap_voxels,
        surface_step,
    )
    if not (0 <= min_pore_fraction <= 1) or not (0 < volume_tol < 1):
        raise MeshInputError("min_pore_fraction must be in [0, 1] and volume_tol in (0, 1)")
    axis = AXES[direction]
    if mesher not in ("pytetwild", "stuffing"):
        raise MeshInputError(f"mesher must be 'pytetwild' or 'stuffing', got {mesher!r}")
    if mesher == "stuffing":
        if lattice_step is not None and not (np.isfinite(lattice_step) and lattice_step > 0):
            raise MeshInputError(
                f"lattice_step must be a positive length in metres, got {lattice_step}"
            )
        if not (0 < stuffing_alpha < 0.5):
            raise MeshInputError(f"stuffing_alpha must be in (0, 0.5), got {stuffing_alpha}")
        if not (1.0 <= stuffing_slab_factor <= 10.0):
            raise MeshInputError(
                f"stuffing_slab_factor must be in [1, 10], got {stuffing_slab_factor}"
            )
        return _mesh_by_stuffing(
            distance,
            voxel,
            size,
            direction,
            aux_length,
            max(2.0 * voxel, float(size.min()) / 30.0)
            if lattice_step is None
            else float(lattice_step),
            stuffing_alpha,
            bool(match_volume),
            stuffing_slab_factor,
            min_gap_voxels,
            volume_tol,
            min_pore_fraction,
            seed,
            cache_dir,
            t0,
        )
    if surface_step is None:  # marching-cubes grid ~ 1/5 of the target edge length
        ext = size.copy()
        ext[axis] *= 1.0 + 2.0 * aux_length
        h_target = (
            edge_length if edge_length is not None else edge_length_fac * float(np.linalg.norm(ext))
        )
        surface_step = int(np.clip(h_target // (5.0 * voxel), 1, min(distance.shape) // 4))
    surface_step = int(surface_step)
    params = dict(
        voxel=voxel,
        size=size.tolist(),
        direction=direction,
        aux_length=aux_length,
        edge_length=edge_length,
        edge_length_fac=edge_length_fac,
        epsilon=epsilon,
        min_gap_voxels=min_gap_voxels,
        surface_step=surface_step,
        simplify_tol=simplify_tol,
        seed=seed,
        tetwild_options=tetwild_options,
        volume_tol=volume_tol,
        min_pore_fraction=min_pore_fraction,
        v=_CACHE_VERSION,
    )
    cache_file, cached = _lookup_cache(cache_dir, distance, params)
    if cached is not None:
        return cached

    # work in units of the largest side so that coordinates are O(1)
    scale = float(size.max())
    d_s, v_s, size_s = distance / scale, voxel / scale, size / scale
    timings: dict[str, float] = {}

    t = time.perf_counter()
    d_closed, n_closed = close_narrow_gaps(d_s, v_s, min_gap_voxels)
    check_voxel_connectivity(d_closed, axis, aux_length > 0)
    surf = pore_surface(d_closed, v_s, size_s, axis, aux_length, surface_step, simplify_tol / scale)
    del d_closed
    timings["surface_s"] = time.perf_counter() - t

    diag = float(np.linalg.norm(surf.hi - surf.lo))
    eps_rel = epsilon if epsilon is not None else 0.25 * v_s * surface_step / diag
    eps_rel = min(eps_rel, 0.01)
    h = edge_length / scale if edge_length is not None else edge_length_fac * diag

    t = time.perf_counter()
    pts, tets = tetrahedralize(
        surf.verts, surf.faces, h, eps_rel, num_threads=num_threads, options=tetwild_options
    )
    timings["tetwild_s"] = time.perf_counter() - t

    t = time.perf_counter()
    eps_abs = eps_rel * diag
    snap_tol = 2.0 * eps_abs
    pts, tets, comp = keep_through_components(pts, tets, surf.lo, surf.hi, axis, snap_tol)
    bfaces, _, _ = face_structure(tets)
    pts, max_move = snap_to_planes(pts, bfaces, surf.lo, surf.hi, snap_tol)
    pts, n_untangled = untangle_near_planes(pts, tets, surf.lo, surf.hi, 2.0 * snap_tol)
    # tets with all four vertices snapped onto one plane (surface slivers) have zero volume:
    # dropping them leaves the boundary on the same plane
    flat = np.zeros(len(tets), dtype=bool)
    for ax in range(3):
        for plane in (surf.lo[ax], surf.hi[ax]):
            flat |= (pts[tets, ax] == plane).all(axis=1)
    if flat.any():
        tets = tets[~flat]
        used = np.unique(tets)
        if len(used) < len(pts):  # drop orphaned vertices (they would make a solver singular)
            remap = np.full(len(pts), -1, dtype=np.int64)
            remap[used] = np.arange(len(used))
            pts, tets = pts[used], remap[tets]
        bfaces, _, _ = face_structure(tets)
    tags = tag_faces(pts, bfaces, surf.lo, surf.hi, axis)
    timings["tagging_s"] = time.perf_counter() - t

    t = time.perf_counter()
    vol = tet_volumes(pts, tets)
    qual = quality_report(pts, tets)
    if qual["n_inverted"]:
        raise MeshFailedError(
            f"{qual['n_inverted']} tets are inverted or flat after snapping the box faces "
            f"(snap tolerance {snap_tol * scale:.3g} m); try a smaller epsilon"
        )
    mesh_vol = float(vol.sum())
    vol_err = mesh_vol / surf.volume - 1.0
    pore_frac, pore_frac_vol = _centroid_pore_fraction(
        d_s, v_s, pts, tets, vol, axis, surf.rve_lo, surf.rve_hi
    )
    rve_volume = float(np.prod(size_s))
    aux_volume = float(np.prod(surf.hi - surf.lo)) - rve_volume
    porosity_voxel = float((distance > 0).mean())
    expected_voxel = porosity_voxel * rve_volume + aux_volume
    timings["checks_s"] = time.perf_counter() - t

    areas = {k: _area(pts, f) * scale**2 for k, f in tags.items()}
    quality = {
        "n_tets": int(len(tets)),
        "n_points": int(len(pts)),
        "n_boundary_facets": int(len(bfaces)),
        "n_facets": {k: int(len(f)) for k, f in tags.items()},
        "tag_area_m2": areas,
        **qual,
        "mesh_volume_m3": mesh_vol * scale**3,
        "surface_pore_volume_m3": surf.volume * scale**3,
        "expected_pore_volume_voxel_m3": expected_voxel * scale**3,
        "volume_rel_error": vol_err,
        "volume_rel_error_vs_voxel": mesh_vol / expected_voxel - 1.0,
        "porosity_voxel": porosity_voxel,
        "porosity_surface": 1.0 - surf.solid_volume / rve_volume,
        "porosity_mesh": (mesh_vol - aux_volume) / rve_volume,
        "pore_centroid_fraction": pore_frac,
        "pore_centroid_volume_fraction": pore_frac_vol,
        "n_closed_gap_voxels": n_closed,
        **comp,
        "removed_volume": comp["removed_volume"] * scale**3,
        "snap_max_move_m": max_move * scale,
        "n_untangled_vertices": n_untangled,
        "n_dropped_flat_tets": int(flat.sum()),
        "edge_length_m": h * scale,
        "epsilon_rel": eps_rel,
        "n_surface_triangles": int(len(surf.faces)),
        "pytetwild_deterministic": False,
        "seed": seed,
        **{k: round(v, 4) for k, v in timings.items()},
    }
    if abs(vol_err) > volume_tol:
        raise MeshFailedError(
            f"tet mesh volume {mesh_vol * scale**3:.4g} m^3 differs from the pore volume "
            f"{surf.volume * scale**3:.4g} m^3 by {100 * vol_err:.2f} % (> volume_tol = "
            f"{100 * volume_tol:.2f} %): the mesher lost or added pore (thin gaps? try a smaller "
            "epsilon/edge_length or a larger min_gap_voxels)"
        )
    if pore_frac < min_pore_fraction:
        raise MeshFailedError(
            f"only {100 * pore_frac:.2f} % of the RVE tet centroids lie in the pore "
            f"(min_pore_fraction = {100 * min_pore_fraction:.1f} %): part of the fiber solid was "
            "meshed as fluid"
        )
    lo = surf.lo * scale
    hi = surf.hi * scale
    pm = PoreMesh(
        points=pts * scale,
        tets=tets,
        facet_tags=tags,
        direction=direction,
        porous_region=(0.0, float(size[axis])),
        bounds=np.stack([lo, hi]),
        quality=quality,
    )
    # exact plane coordinates in metres (the scaling must not perturb the flat faces)
    _restore_planes(pm, tags, lo, hi, axis)
    pm.quality["wall_time_s"] = time.perf_counter() - t0
    if cache_file is not None:
        _save_cached(cache_file, pm)
    return pm


def _mesh_by_stuffing(
    distance,
    voxel,
    size,
    direction,
    aux_length,
    lattice_step,
    alpha,
    match_volume,
    slab_factor,
    min_gap_voxels,
    volume_tol,
    min_pore_fraction,
    seed,
    cache_dir,
    t0,
) -> PoreMesh:
    """The ``mesher='stuffing'`` branch of :func:`mesh_pore_space` (same checks and tags)."""
    axis = AXES[direction]
    params = dict(
        mesher="stuffing",
        voxel=voxel,
        size=size.tolist(),
        direction=direction,
        aux_length=aux_length,
        lattice_step=lattice_step,
        alpha=alpha,
        match_volume=match_volume,
        slab_factor=slab_factor,
        min_gap_voxels=min_gap_voxels,
        volume_tol=volume_tol,
        min_pore_fraction=min_pore_fraction,
        v=_CACHE_VERSION,
    )
    cache_file, cached = _lookup_cache(cache_dir, distance, params)
    if cached is not None:
        return cached
    scale = float(size.max())
    d_s, v_s, size_s = distance / scale, voxel / scale, size / scale
    timings: dict[str, float] = {}
    t = time.perf_counter()
    d_closed, n_closed = close_narrow_gaps(d_s, v_s, min_gap_voxels)
    check_voxel_connectivity(d_closed, axis, aux_length > 0)
    timings["gap_closing_s"] = time.perf_counter() - t
    t = time.perf_counter()
    rve_volume = float(np.prod(size_s))
    box = size_s.copy()
    box[axis] *= 1.0 + 2.0 * aux_length
    expected_voxel = float((d_closed > 0).mean()) * rve_volume + float(np.prod(box)) - rve_volume
    h_s = lattice_step / scale
    sm = stuff_pore_space(
        d_closed, v_s, size_s, axis, aux_length, h_s, alpha, slab_factor=slab_factor
    )
    offset, n_match = 0.0, 0
    if match_volume:
        offset, sm, n_match = _match_volume(
            d_closed, v_s, size_s, axis, aux_length, h_s, alpha, sm, expected_voxel, slab_factor
        )
    timings["stuffing_s"] = time.perf_counter() - t
    t = time.perf_counter()
    pts, tets, comp = keep_through_components(sm.points, sm.tets, sm.lo, sm.hi, axis, 0.0)
    bfaces, _, _ = face_structure(tets)
    tags = tag_faces(pts, bfaces, sm.lo, sm.hi, axis)
    timings["tagging_s"] = time.perf_counter() - t
    t = time.perf_counter()
    vol = tet_volumes(pts, tets)
    qual = quality_report(pts, tets)
    if qual["n_inverted"]:
        raise MeshFailedError(f"{qual['n_inverted']} tets are inverted or flat after stuffing")
    mesh_vol = float(vol.sum())
    pore_frac, pore_frac_vol = _centroid_pore_fraction(
        d_s, v_s, pts, tets, vol, axis, sm.rve_lo, sm.rve_hi
    )
    aux_volume = float(np.prod(sm.hi - sm.lo)) - rve_volume
    porosity_voxel = float((distance > 0).mean())
    # isolated pockets removed by keep_through_components are part of the voxel pore volume
    vol_err = (mesh_vol + comp["removed_volume"]) / expected_voxel - 1.0
    timings["checks_s"] = time.perf_counter() - t
    quality = {
        "mesher": "stuffing",
        "n_tets": int(len(tets)),
        "n_points": int(len(pts)),
        "n_boundary_facets": int(len(bfaces)),
        "n_facets": {k: int(len(f)) for k, f in tags.items()},
        "tag_area_m2": {k: _area(pts, f) * scale**2 for k, f in tags.items()},
        **qual,
        "mesh_volume_m3": mesh_vol * scale**3,
        "expected_pore_volume_voxel_m3": expected_voxel * scale**3,
        "volume_rel_error": vol_err,
        "volume_rel_error_vs_voxel": mesh_vol / (porosity_voxel * rve_volume + aux_volume) - 1,
        "porosity_voxel": porosity_voxel,
        "porosity_mesh": (mesh_vol - aux_volume) / rve_volume,
        "pore_centroid_fraction": pore_frac,
        "pore_centroid_volume_fraction": pore_frac_vol,
        "n_closed_gap_voxels": n_closed,
        **comp,
        "removed_volume": comp["removed_volume"] * scale**3,
        "lattice_step_m": lattice_step,
        "level_offset_m": offset * scale,
        "n_volume_match_iterations": n_match,
        **{k: v for k, v in sm.report.items() if k != "lattice_step"},
        "lattice_step_axes_m": [v * scale for v in sm.report["lattice_step"]],
        "deterministic": True,
        "seed": seed,
        **{k: round(v, 4) for k, v in timings.items()},
    }
    if abs(vol_err) > volume_tol:
        raise MeshFailedError(
            f"tet mesh volume {mesh_vol * scale**3:.4g} m^3 differs from the voxel pore volume "
            f"{expected_voxel * scale**3:.4g} m^3 by {100 * vol_err:.2f} % (> volume_tol = "
            f"{100 * volume_tol:.2f} %): lattice_step too coarse for the geometry?"
        )
    if pore_frac < min_pore_fraction:
        raise MeshFailedError(
            f"only {100 * pore_frac:.2f} % of the RVE tet centroids lie in the pore "
            f"(min_pore_fraction = {100 * min_pore_fraction:.1f} %): lattice_step too coarse?"
        )
    lo, hi = sm.lo * scale, sm.hi * scale
    pm = PoreMesh(
        points=pts * scale,
        tets=tets,
        facet_tags=tags,
        direction=direction,
        porous_region=(0.0, float(size[axis])),
        bounds=np.stack([lo, hi]),
        quality=quality,
    )
    _restore_planes(pm, tags, lo, hi, axis)
    pm.quality["wall_time_s"] = time.perf_counter() - t0
    if cache_file is not None:
        _save_cached(cache_file, pm)
    return pm


def _match_volume(
    d, v, size, axis, aux_length, h, alpha, sm, target, slab_factor=1.0, rtol=2e-4, max_iter=6
):
    """Shift the meshed level set so that the mesh volume equals ``target`` (secant method).

    The piecewise-linear boundary through points on a convex fiber surface cuts its chords into
    the fiber, which inflates the pore by about (chord^2 / 12 R) x fiber area; a uniform level
    shift removes this bias. Returns (offset, mesh, iterations).
    """

    def volume(m):
        return float(tet_volumes(m.points, m.tets).sum())

    x0, v0 = 0.0, volume(sm)
    if abs(v0 / target - 1) <= rtol:
        return 0.0, sm, 0
    bf, _, _ = face_structure(sm.tets)
    wall = tag_faces(sm.points, bf, sm.lo, sm.hi, axis)["wall"]
    x1 = (v0 - target) / max(_area(sm.points, wall), 1e-300)
    best = (abs(v0 / target - 1), x0, sm)
    n_iter = 0
    for n_iter in range(1, max_iter + 1):  # noqa: B007 (reported after the loop)
        m1 = stuff_pore_space(
            d, v, size, axis, aux_length, h, alpha, offset=x1, slab_factor=slab_factor
        )
        v1 = volume(m1)
        best = min(best, (abs(v1 / target - 1), x1, m1), key=lambda b: b[0])
        if abs(v1 / target - 1) <= rtol or v1 == v0:
            break
        x0, v0, x1 = x1, v1, x1 - (v1 - target) * (x1 - x0) / (v1 - v0)
    return best[1], best[2], n_iter


def _area(pts: np.ndarray, f: np.ndarray) -> float:
    return float(
        0.5
        * np.linalg.norm(
            np.cross(pts[f[:, 1]] - pts[f[:, 0]], pts[f[:, 2]] - pts[f[:, 0]]), axis=1
        ).sum()
    )


def _restore_planes(pm: PoreMesh, tags: dict, lo: np.ndarray, hi: np.ndarray, axis: int) -> None:
    names = {("inlet", axis): lo[axis], ("outlet", axis): hi[axis]}
    for ax, c in zip("xyz", range(3), strict=True):
        if c != axis:
            names[(f"side_{ax}0", c)] = lo[c]
            names[(f"side_{ax}1", c)] = hi[c]
    for (name, c), value in names.items():
        f = tags.get(name)
        if f is not None and len(f):
            pm.points[np.unique(f), c] = value


def _centroid_pore_fraction(d_s, v_s, pts, tets, vol, axis, rve_lo, rve_hi):
    """Fraction (by count and by volume) of RVE tet centroids where interpolated distance > 0."""
    cen = pts[tets].mean(axis=1)
    inside = (cen[:, axis] > rve_lo[axis]) & (cen[:, axis] < rve_hi[axis])
    if not inside.any():
        return 1.0, 1.0
    grids = [(np.arange(n) + 0.5) * v_s for n in d_s.shape]
    interp = RegularGridInterpolator(grids, d_s, bounds_error=False, fill_value=None)
    c = cen[inside]
    for ax in range(3):
        c[:, ax] = np.clip(c[:, ax], grids[ax][0], grids[ax][-1])
    pore = interp(c) > 0
    w = vol[inside]
    return float(pore.mean()), float(w[pore].sum() / w.sum())


def _lookup_cache(cache_dir, distance: np.ndarray, params: dict):
    """(cache file or None, cached PoreMesh or None) for these inputs."""
    if cache_dir is None:
        return None, None
    cache_file = Path(cache_dir) / f"poremesh_{_cache_key(distance, params)}.npz"
    return cache_file, (_load_cached(cache_file) if cache_file.exists() else None)


def _save_cached(path: Path, pm: PoreMesh) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {f"tag_{k}": v for k, v in pm.facet_tags.items()}
    meta = json.dumps(
        {"direction": pm.direction, "porous_region": list(pm.porous_region), "quality": pm.quality}
    )
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(
        tmp, points=pm.points, tets=pm.tets, bounds=pm.bounds, meta=np.array(meta), **arrays
    )
    tmp.replace(path)


def _load_cached(path: Path) -> PoreMesh:
    with np.load(path) as z:
        meta = json.loads(str(z["meta"]))
        tags = {k[4:]: z[k] for k in z.files if k.startswith("tag_")}
        pm = PoreMesh(
            points=z["points"],
            tets=z["tets"],
            facet_tags=tags,
            direction=meta["direction"],
            porous_region=tuple(meta["porous_region"]),
            bounds=z["bounds"],
            quality=meta["quality"],
        )
    pm.quality["from_cache"] = True
    return pm
