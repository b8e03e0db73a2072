"""``mesher = "stuffing"``: the lattice mesher of :mod:`psdesign.meshing.stuffing` behind
:func:`psdesign.meshing.pore_mesh.mesh_pore_space` (volume matching, tags, checks)."""

from __future__ import annotations

import time

import numpy as np

from psdesign.meshing import cache
from psdesign.meshing import tags as T
from psdesign.meshing.checks import (
    area,
    gate,
    mesh_quality,
    restore_planes,
)
from psdesign.meshing.errors import PoreTopologyError, Remedy
from psdesign.meshing.inputs import ScaledField, scaled_field
from psdesign.meshing.options import MeshOptions, default_lattice_step
from psdesign.meshing.periodic import periodic_pairs
from psdesign.meshing.result import PoreMesh
from psdesign.meshing.stuffing import stuff_pore_space
from psdesign.meshing.tetra import face_structure, keep_through_components, tag_faces, tet_volumes
from psdesign.schema.flow import LATTICE_STEP_RANGE

_MATCH_RTOL = 2e-4
_MATCH_MAX_ITER = 6


def mesh_stuffing(distance, voxel, size, direction, opts: MeshOptions, t0: float) -> PoreMesh:
    """Lattice ("stuffing") pore mesh; arguments as :func:`~.pore_mesh.mesh_pore_space`."""
    from psdesign import progress

    step = opts.lattice_step
    if step is None:
        step = default_lattice_step(voxel, size, opts.fiber_diameter)
    opts = opts.replace(lattice_step=step)
    params = {"voxel": voxel, "size": size.tolist(), "direction": direction, **opts.cache_params()}
    cache_file, cached = cache.lookup(opts.cache_dir, distance, params)
    if cached is not None:
        return cached
    timings: dict[str, float] = {}
    t = time.perf_counter()
    f = scaled_field(distance, voxel, size, direction, opts)
    timings["gap_closing_time_s"] = time.perf_counter() - t
    t = time.perf_counter()
    box = f.size.copy()
    box[f.axis] *= 1.0 + 2.0 * opts.aux_length
    aux_volume = float(np.prod(box)) - f.rve_volume
    pore_rve = f.analytic_closed if opts.volume_target == "analytic" else f.voxel_rve
    target = pore_rve + aux_volume
    h_s = step / f.scale
    counted = _pass_progress()

    def stuff(offset: float):
        return stuff_pore_space(
            f.closed,
            f.voxel,
            f.size,
            f.axis,
            opts.aux_length,
            h_s,
            alpha=opts.alpha,
            offset=offset,
            slab_factor=opts.slab_factor,
            periodic=opts.periodic,
            progress=counted(),
        )

    n_match = 0
    if opts.offset is not None:
        offset = opts.offset / f.scale
        sm = stuff(offset)
    else:
        sm = stuff(0.0)
        offset = 0.0
        if opts.match_volume:
            offset, sm, n_match = match_volume(stuff, sm, target, f.axis, _no_wall(step, opts))
    timings["stuffing_time_s"] = time.perf_counter() - t
    t = time.perf_counter()
    progress.stage(f"mesh: {len(sm.tets)} tets stuffed; through-flow components and tags")
    pts, tets, comp, bfaces = keep_through_components(
        sm.points, sm.tets, sm.lo, sm.hi, f.axis, 0.0, any_face=opts.periodic,
        refine=Remedy("flow.lattice_step", f"the lattice step {step:.3g} m closes pore gaps "
                      "narrower than about a step (allowed: a smaller step, under about the "
                      f"narrowest gap of the path; {LATTICE_STEP_RANGE})"),
    )  # fmt: skip
    tags = tag_faces(pts, bfaces, sm.lo, sm.hi, f.axis)
    pairs = periodic_pairs(pts, tags, f.axis) if opts.periodic else {}
    timings["tagging_time_s"] = time.perf_counter() - t
    t = time.perf_counter()
    progress.stage("mesh: quality checks")
    quality = _quality(f, pts, tets, bfaces, tags, comp, sm, target, aux_volume, opts)
    quality.update(
        level_offset_m=offset * f.scale,
        n_volume_match_iterations=n_match,
        periodic_pairs={k: int(len(v)) for k, v in pairs.items()},
    )
    timings["checks_time_s"] = time.perf_counter() - t
    quality.update({k: round(v, 4) for k, v in timings.items()})
    gate(quality, opts.volume_tol, opts.min_pore_fraction, "target pore volume",
         Remedy("flow.lattice_step", f"the lattice step {step:.3g} m may be too coarse for "
                "the geometry (allowed: a smaller step, under about the fiber radius and the "
                f"narrowest pore gap; {LATTICE_STEP_RANGE})"))  # fmt: skip
    lo, hi = sm.lo * f.scale, sm.hi * f.scale
    pm = PoreMesh(
        points=pts * f.scale,
        tets=tets,
        facet_tags=tags,
        direction=direction,
        porous_region=(0.0, float(size[f.axis])),
        bounds=np.stack([lo, hi]),
        quality=quality,
        periodic_pairs=pairs,
    )
    restore_planes(pm, lo, hi)
    pm.quality["wall_time_s"] = time.perf_counter() - t0
    cache.save(cache_file, pm)
    return pm


def _pass_progress():
    """``counted()``: the ``progress`` callback of the next stuffing pass (volume matching
    makes up to ``1 + _MATCH_MAX_ITER``), one throttled line ``psdesign: stuffing pass K:
    N/5 steps, T s`` for all; None without a printer."""
    from psdesign import progress

    report = progress.throttled(
        lambda s, k, done, total: f"psdesign: stuffing pass {k}: {done}/{total} steps, {s:.0f} s"
    )
    passes = [0]

    def counted():
        passes[0] += 1
        k = passes[0]
        return None if report is None else (lambda done, total: report(k, done, total))

    return counted


def _quality(f: ScaledField, pts, tets, bfaces, tags, comp, sm, target, aux_volume, opts) -> dict:
    """``PoreMesh.quality`` of a stuffed mesh (lengths in metres)."""
    s = f.scale
    box = (sm.rve_lo, sm.rve_hi)
    common, mesh_vol, porosity_voxel = mesh_quality(
        f,
        pts,
        tets,
        tags,
        comp,
        box,
        aux_volume=aux_volume,
        inverted="after stuffing",
        periodic=opts.periodic,
    )
    # isolated pockets removed by keep_through_components are part of the target pore volume
    vol_err = (mesh_vol + comp["removed_volume"]) / target - 1.0
    return {
        "mesher": "stuffing",
        **common,
        "n_boundary_facets": int(len(bfaces)),
        "volume_target": opts.volume_target,
        "volume_target_m3": target * s**3,
        "expected_pore_volume_voxel_m3": (f.voxel_rve + aux_volume) * s**3,
        "volume_rel_error": vol_err,
        "volume_rel_error_vs_voxel": mesh_vol / (porosity_voxel * f.rve_volume + aux_volume) - 1,
        "lattice_step_m": opts.lattice_step,
        **{k: v for k, v in sm.report.items() if k != "lattice_step"},
        "lattice_step_axes_m": [v * s for v in sm.report["lattice_step"]],
        "aux_length": opts.aux_length,
        "deterministic": True,
        "seed": opts.seed,
    }


def _no_wall(step: float, opts: MeshOptions) -> Remedy:
    """The refusal of a lattice with no vertex inside any fiber (:func:`match_volume`)."""
    d = opts.fiber_diameter
    radius = f", {d / 2:.3g} m here" if d else ""
    return Remedy(
        "flow.lattice_step",
        f"the lattice step {step:.3g} m leaves no lattice vertex inside any fiber, so the mesh "
        "has no fiber wall and the pore volume cannot be matched (allowed: a step under about "
        f"the thinnest fiber's radius{radius}; {LATTICE_STEP_RANGE})",
    )


def match_volume(stuff, sm, target: float, axis: int, no_wall: Remedy):
    """Shift the meshed level set so that the mesh volume equals ``target`` (secant method).

    The piecewise-linear boundary through points on a convex fiber surface cuts its chords into
    the fiber, which inflates the pore by about (chord^2 / 12 R) x fiber area; a uniform level
    shift removes this bias. ``stuff(offset)`` builds a mesh. Returns (offset, mesh, iterations).

    A first mesh with no wall face (a lattice coarser than the fibers: no vertex inside one)
    has nothing to shift: it raises :class:`PoreTopologyError` with ``no_wall``'s line (the
    secant step divided by a zero wall area gave an offset of -2e298, every vertex solid and
    a keyless "pore space is empty" line until session 52).
    """

    def volume(m):
        return float(tet_volumes(m.points, m.tets).sum())

    x0, v0 = 0.0, volume(sm)
    if abs(v0 / target - 1) <= _MATCH_RTOL:
        return 0.0, sm, 0
    bf, _, _ = face_structure(sm.tets)
    wall = area(sm.points, tag_faces(sm.points, bf, sm.lo, sm.hi, axis)[T.WALL])
    if not wall > 0:
        raise PoreTopologyError(f"{no_wall.key}: {no_wall.advice}")
    x1 = (v0 - target) / wall
    best = (abs(v0 / target - 1), x0, sm)
    n_iter = 0
    for n_iter in range(1, _MATCH_MAX_ITER + 1):  # noqa: B007 (reported after the loop)
        m1 = stuff(x1)
        v1 = volume(m1)
        best = min(best, (abs(v1 / target - 1), x1, m1), key=lambda b: b[0])
        if abs(v1 / target - 1) <= _MATCH_RTOL or v1 == v0:
            break
        x0, v0, x1 = x1, v1, x1 - (v1 - target) * (x1 - x0) / (v1 - v0)
    return best[1], best[2], n_iter
