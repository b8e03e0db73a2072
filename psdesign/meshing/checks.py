"""Checks and bookkeeping shared by both meshers: pore fraction, exact planes, volume gate."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from psdesign.meshing import tags as T
from psdesign.meshing.errors import MeshFailedError, Remedy
from psdesign.meshing.result import PoreMesh, triangle_areas


def area(pts: np.ndarray, f: np.ndarray) -> float:
    """Total area of triangles ``f``."""
    return float(triangle_areas(pts, f).sum())


def restore_planes(pm: PoreMesh, lo: np.ndarray, hi: np.ndarray) -> None:
    """Put the vertices of box-face tags exactly on their planes (after scaling to metres)."""
    for ax in range(3):
        for high, value in ((False, lo[ax]), (True, hi[ax])):
            f = pm.facet_tags.get(T.face_name(ax, high, pm.axis))
            if f is not None and len(f):
                pm.points[np.unique(f), ax] = value


def centroid_pore_fraction(f, pts, tets, vol, rve_box, periodic=False):
    """Fraction (by count and by volume) of RVE tet centroids where interpolated distance > 0.

    ``f`` is the :class:`psdesign.meshing.inputs.ScaledField` (its distance ``d``, voxel and
    flow axis), ``rve_box`` the RVE's ``(lo, hi)`` in scaled units; ``periodic``: the field
    wraps around the box faces, as the periodic mesh was made from
    (:class:`psdesign.meshing.stuffing.PoreField`); else it is extended constant beyond the outer
    voxel centres."""
    d_s, v_s, axis = f.d, f.voxel, f.axis
    rve_lo, rve_hi = rve_box
    cen = pts[tets].mean(axis=1)
    inside = (cen[:, axis] > rve_lo[axis]) & (cen[:, axis] < rve_hi[axis])
    if not inside.any():
        return 1.0, 1.0
    w = vol[inside]
    if periodic:
        from psdesign.meshing.stuffing import PoreField

        size = np.asarray(d_s.shape) * v_s
        pore = PoreField(d_s, v_s, size, axis, clip=False, periodic=True)(cen[inside]) > 0
        return float(pore.mean()), float(w[pore].sum() / w.sum())
    grids = [(np.arange(n) + 0.5) * v_s for n in d_s.shape]
    interp = RegularGridInterpolator(grids, d_s, bounds_error=False, fill_value=None)
    c = cen[inside]
    for ax in range(3):
        c[:, ax] = np.clip(c[:, ax], grids[ax][0], grids[ax][-1])
    pore = interp(c) > 0
    return float(pore.mean()), float(w[pore].sum() / w.sum())


def volume_report(mesh_volume: float, analytic: float, voxel: float, scale3: float) -> dict:
    """The pore-volume keys of ``PoreMesh.quality`` (inputs in scaled units, output in m^3)."""
    return {
        "pore_volume_m3": mesh_volume * scale3,
        "analytic_pore_volume_m3": analytic * scale3,
        "voxel_pore_volume_m3": voxel * scale3,
        "pore_volume_rel_diff": mesh_volume / analytic - 1.0,
        "pore_volume_rel_diff_vs_voxel": mesh_volume / voxel - 1.0,
    }


def removed_components(comp: dict, scale: float) -> dict:
    """The pore components the mesher dropped (isolated pockets), as ``PoreMesh.quality``
    reports them: the counts as they are and their volume in m^3 as ``removed_volume_m3``
    (``comp``: the record of :func:`psdesign.meshing.tetra.keep_through_components`, its
    volume in scaled units of ``scale`` metres)."""
    kept = {k: v for k, v in comp.items() if k != "removed_volume"}
    return {**kept, "removed_volume_m3": float(comp["removed_volume"]) * scale**3}


def mesh_quality(
    f,
    pts,
    tets,
    tags: dict,
    comp: dict,
    rve_box,
    *,
    aux_volume: float,
    inverted: str,
    periodic=False,
):
    """The ``PoreMesh.quality`` keys both meshers report (lengths in metres).

    (Nine parameters: the field, the mesh and its box, then three independent knobs, keyword-only.)

    Counts, tag areas,
    element quality, pore volumes and porosities, pore-centroid fractions and the removed
    components. ``f`` is the :class:`psdesign.meshing.inputs.ScaledField`, ``rve_box`` the
    RVE's ``(lo, hi)`` in scaled units; a mesh with inverted or flat tets raises
    :class:`MeshFailedError` (``inverted`` completes its message); ``periodic``: the mesh was made
    from the wrapped field (the pore-centroid check wraps it too). Returns ``(quality,
    mesh_volume, porosity_voxel)``, the volume in scaled units."""
    from psdesign.meshing.quality import quality_report
    from psdesign.meshing.tetra import tet_volumes

    s = f.scale
    vol = tet_volumes(pts, tets)
    qual = quality_report(pts, tets)
    if qual["n_inverted"]:
        raise MeshFailedError(f"{qual['n_inverted']} tets are inverted or flat {inverted}")
    mesh_vol = float(vol.sum())
    pore_frac, pore_frac_vol = centroid_pore_fraction(f, pts, tets, vol, rve_box, periodic)
    porosity_voxel = float((f.d > 0).mean())
    voxel_rve = porosity_voxel * f.rve_volume
    report = {
        "n_tets": int(len(tets)),
        "n_points": int(len(pts)),
        "n_facets": {k: int(len(v)) for k, v in tags.items()},
        "tag_area_m2": {k: area(pts, v) * s**2 for k, v in tags.items()},
        **qual,
        "mesh_volume_m3": mesh_vol * s**3,
        **volume_report(mesh_vol - aux_volume, f.analytic_rve, voxel_rve, s**3),
        "porosity_voxel": porosity_voxel,
        "porosity_analytic": f.analytic_rve / f.rve_volume,
        "porosity_mesh": (mesh_vol - aux_volume) / f.rve_volume,
        "pore_centroid_fraction": pore_frac,
        "pore_centroid_volume_fraction": pore_frac_vol,
        "n_closed_gap_voxels": f.n_closed,
        **removed_components(comp, s),
    }
    return report, mesh_vol, porosity_voxel


def gate(quality: dict, volume_tol: float, min_pore_fraction: float, what: str, remedy: Remedy):
    """Raise :class:`MeshFailedError` when the volume or pore-fraction checks fail.

    The refusal begins with ``remedy.key``, the mesher's resolution key, and ends with its
    advice and allowed range (a spec's user reads which key to change and how).
    """
    key, rest = remedy
    err = quality["volume_rel_error"]
    if abs(err) > volume_tol:
        raise MeshFailedError(
            f"{key}: tet mesh volume {quality['mesh_volume_m3']:.4g} m^3 differs from the "
            f"{what} {quality['volume_target_m3']:.4g} m^3 by {100 * err:.2f} % (> volume_tol "
            f"= {100 * volume_tol:.2f} %): {rest}"
        )
    frac = quality["pore_centroid_fraction"]
    if frac < min_pore_fraction:
        raise MeshFailedError(
            f"{key}: only {100 * frac:.2f} % of the RVE tet centroids lie in the pore "
            f"(min_pore_fraction = {100 * min_pore_fraction:.1f} %): {rest}"
        )
