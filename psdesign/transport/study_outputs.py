"""Transport outputs of a study case (one call from :func:`psdesign.study.case.run_case`).

Output names (``[study] outputs``) and the row keys they add:

* ``diffusivity_x|y|z``: ``diffusivity_<d>`` (D_eff / D_bulk), ``diffusivity_<d>_rel_error``,
  ``diffusivity_<d>_converged``, ``diffusivity_<d>_status`` (``ok``, ``untrustworthy``,
  ``not_converged``, ``blocked``: :func:`psdesign.transport.effective.rating`);
* ``tortuosity_x|y|z``: ``tortuosity_<d>`` (porosity / relative diffusivity; empty if blocked);
* ``conductivity_x|y|z``: ``conductivity_<d>`` (units of ``transport.*_conductivity``),
  ``conductivity_<d>_rel_error``, ``conductivity_<d>_converged``, ``conductivity_<d>_status``;
* ``pore_d10_m``, ``pore_d50_m``, ``pore_d90_m``: local-thickness diameters (m), with
  ``pore_bin_width_m`` (the scan step), ``pore_diameter_error_m`` (their error above; below,
  ``pore_diameter_error_below_m``, only where a face of the box does not repeat) and
  ``pore_sizes_status`` (:func:`pore_sizes_status`, as ``psdesign pores`` rates them);
* ``specific_surface_m-1``: marching-cubes surface per box volume (1/m), with
  ``specific_surface_rel_error`` and ``specific_surface_status``.
"""

from __future__ import annotations

from psdesign.geometry.rve import RVE, VoxelFields, resolution_measure

#: Spec paths of the ``[transport]`` table a study parameter may vary.
TRANSPORT_KEYS = tuple(
    f"transport.{k}"
    for k in (
        "bc",
        "tol",
        "error_estimate",
        "bulk_diffusivity_m2_s",
        "mean_free_path_m",
        "solid_conductivity",
        "fluid_conductivity",
        "insulating_phase",
        "thickness_axis",
        "n_radii",
    )
)

#: The text column of ``results.csv`` / ``summary.csv`` that names the unit of the
#: ``conductivity_<d>`` columns (their names carry none: ``W/(m K)`` or ``S/m``, as
#: ``transport.conductivity_unit`` chose); :func:`psdesign.analysis.replicates.
#: replicate_summary` carries it per design point.
UNIT_COLUMN = "conductivity_unit"
TRANSPORT_OUTPUTS = (
    "diffusivity_x",
    "diffusivity_y",
    "diffusivity_z",
    "tortuosity_x",
    "tortuosity_y",
    "tortuosity_z",
    "conductivity_x",
    "conductivity_y",
    "conductivity_z",
    "pore_d10_m",
    "pore_d50_m",
    "pore_d90_m",
    "specific_surface_m-1",
)


def pore_report(rve: RVE | None, fields: VoxelFields, transport: dict) -> dict:
    """Everything ``psdesign pores`` prints: size distribution, intrusion, surface, profile,
    orientation tensor (when ``rve`` is given)."""
    from psdesign import progress
    from psdesign.transport.pores import (
        orientation_tensor,
        pore_sizes,
        porosity_profile,
        specific_surface,
    )

    progress.stage(f"pore sizes: scanning {int(transport['n_radii'])} radii")
    ps = pore_sizes(
        fields,
        n_radii=int(transport["n_radii"]),
        thickness_axis=transport["thickness_axis"],
        surface_tension=float(transport["surface_tension_n_m"]),
        contact_angle_deg=float(transport["contact_angle_deg"]),
        rve=rve,
    )
    progress.stage("specific surface (marching cubes)")
    sv = specific_surface(fields, rve=rve)
    out = ps.to_dict()
    out["specific_surface_m-1"] = sv.specific_surface_m_1
    out["specific_surface_rel_error"] = sv.rel_error
    out["surface_area_m2"] = sv.area_m2
    out["surface_periodic_axes"] = sv.extra["periodic_axes"]  # the axes wrapped (session 52)
    out["surface_short_axes"] = sv.extra["short_axes"]  # no coarse grid along them (session 53)
    out["surface_method"] = (
        "marching cubes on the analytic signed distance"
        if fields.analytic_distance
        else "marching cubes on the image's voxel-face distance (not analytic: a segmented "
        "image has no sub-voxel surface)"
    )
    out["porosity_error"] = fields.porosity_error
    out["porosity_profile"] = porosity_profile(fields, transport["thickness_axis"])
    if rve is not None:
        out["orientation_tensor"] = orientation_tensor(rve)
    h, image = float(fields.grid.spacing[0]), not fields.analytic_distance
    out.update(_pore_rating(out, rve, h, varying_edge(fields), image))
    return out


def varying_edge(fields: VoxelFields) -> float:
    """The RVE's smallest edge (m) over the axes its geometry varies along
    (:meth:`~psdesign.geometry.rve.VoxelFields.varies_along`), the bound of a representative
    pore size: along an extruded axis the edge is an arbitrary depth (a cylinder along z in a
    40 x 40 x 25 um box has pores up to the 36 um periodic sphere, marked untrustworthy against
    the 25 um depth until session 52). The smallest edge when no axis varies.

    >>> import numpy as np
    >>> from psdesign.image.fields import image_fields
    >>> solid = np.zeros((8, 6, 4), bool)
    >>> solid[3:5, 2:4, :] = True  # a square rod along z
    >>> varying_edge(image_fields(solid, 1e-6)), varying_edge(image_fields(solid[:, :, :1], 1e-6))
    (6e-06, 6e-06)
    """
    shape = fields.grid.shape
    h = float(fields.grid.spacing[0])
    varying = [int(n) for a, n in enumerate(shape) if fields.varies_along(a)]
    return h * min(varying or [int(n) for n in shape])


def pore_sizes_status(
    converged: bool, rel_error: float, d90_m: float, cpd: float | None, edge_m: float
) -> str:
    """The pore sizes' status: by convergence, error bar and resolution
    (:func:`psdesign.flow.error.status_of`), and ``untrustworthy`` when ``d90`` exceeds the
    RVE's smallest edge ``edge_m`` (a pore larger than the RVE represents no material)."""
    from psdesign.flow.error import status_of

    status = status_of(converged, rel_error, cpd)
    return "untrustworthy" if status == "ok" and d90_m > edge_m else status


def _pore_rating(out: dict, rve: RVE | None, h: float, edge: float, image: bool = False) -> dict:
    """``status`` (the worst of the three below) and ``warnings`` of a pore report, as a
    transport value is rated (:func:`psdesign.transport.effective.rating`): the pore sizes by
    their ``rel_error`` (the larger of ``diameter_error_m`` and ``diameter_error_below_m``
    over d50, :class:`~psdesign.transport.pores.PoreSizeResult`) and the specific surface by
    its own, each
    also untrustworthy with fewer than 8 voxels across the thinnest fiber (an image: the error
    bars alone), the S_v when an axis it varies along is too short for its bar's coarse grid
    (:func:`psdesign.transport.pores.surface_status`), and the pore sizes when ``d90``
    exceeds ``edge``, the smallest edge the geometry varies along (:func:`varying_edge`: a
    pore larger than the RVE); the breakthrough ``blocked`` when no intrusion path crosses
    the sample and ``untrustworthy`` when the path is narrower than the scan resolves
    (:func:`breakthrough_rating`; ``image``: a segmented image's voxels, no ``rve.voxel``)."""
    from psdesign.flow import error as err
    from psdesign.geometry.rve import resolution_measure
    from psdesign.transport.effective import rating, worst_status
    from psdesign.transport.pores import MIN_COARSE_VOXELS, surface_status

    cpd = None if rve is None else err.cells_per_diameter(rve, h)
    # the resolution line once for both values, then each one's own error-bar line; it names
    # what cpd counts across (a woven yarn's thin width, not its diameter: session 43)
    measure = resolution_measure(rve)
    warnings = err.resolution_warnings(cpd, "voxel", "", "pore sizes and S_v", measure=measure)
    converged = bool(out.get("converged", True))
    warnings += rating("pore sizes", "", False, converged, out["rel_error"], None)[1]
    warnings += rating("S_v", "", False, True, out["specific_surface_rel_error"], None)[1]
    sizes = pore_sizes_status(converged, out["rel_error"], out["pore_d90_m"], cpd, edge)
    surface = surface_status(out["specific_surface_rel_error"], out["surface_short_axes"], cpd)
    if out["surface_short_axes"]:
        warnings.append(
            f"S_v: the geometry varies along {out['surface_short_axes']} over fewer than "
            f"{MIN_COARSE_VOXELS} voxels, too few for the bar's coarse grid: the bar misses "
            "that part of the error; use a longer box or a finer rve.voxel"
        )
    if out.get("diameter_error_below_m", 0.0) > 0:
        warnings.append(
            f"pore sizes: the geometry does not repeat across {out['walled_axes']}: the values "
            "take the outside of those faces as pore (a pore a face bounds counts as going on); "
            f"with walls there they read up to {out['diameter_error_below_m']:.3e} m lower (the "
            "bar's lower side); a larger box narrows it"
        )
    if out["pore_d90_m"] > edge:
        warnings.append(
            f"pore sizes: d90 {out['pore_d90_m']:.3e} m exceeds the smallest edge the geometry "
            f"varies along {edge:.3e} m: the RVE is smaller than its pores; use a larger RVE"
        )
    crossing, said = breakthrough_rating(out, image)
    warnings += said
    return {
        "pore_sizes_status": sizes,
        "breakthrough_status": crossing,
        "specific_surface_status": surface,
        "status": worst_status([sizes, surface, crossing]),
        "warnings": warnings,
    }


def breakthrough_rating(out: dict, image: bool) -> tuple[str, list[str]]:
    """``breakthrough_status`` of a pore report and its warning: ``ok`` with a diameter;
    without one ``untrustworthy`` when the pore space crosses the sample
    (``pore_space_crosses``: a path narrower than the scan resolves, its diameter unknown) and
    ``blocked`` when it does not (no path at all, as a diffusivity with none). Until session 53
    both were ``blocked``: a 2 x 2 voxel hole through a wall (D_eff/D 0.048 through it).
    ``image``: the voxels are the image's (no ``rve.voxel`` to refine).

    >>> out = {"breakthrough_diameter_m": None, "pore_space_crosses": True,
    ...        "thickness_axis": "x", "intrusion_diameter_m": [4e-6, 2e-6],
    ...        "diameter_error_m": 3.1e-6}
    >>> status, said = breakthrough_rating(out, image=False)
    >>> status, said[0][:56]
    ('untrustworthy', 'breakthrough: unresolved: the pore space crosses the sam')
    >>> breakthrough_rating({**out, "pore_space_crosses": False}, image=False)[0]
    'blocked'
    """
    if out["breakthrough_diameter_m"] is not None:
        return "ok", []
    axis, smallest = out["thickness_axis"], out["intrusion_diameter_m"][-1]
    if not out.get("pore_space_crosses", False):
        return "blocked", [
            f"breakthrough: no intrusion path along {axis}: the pore space does not cross "
            "the sample (no path at any diameter on this voxel grid)"
        ]
    finer = "a finer image" if image else "a finer rve.voxel"
    return "untrustworthy", [
        f"breakthrough: unresolved: the pore space crosses the sample along {axis}, but "
        f"only through throats narrower than the scan resolves (no ball of the smallest "
        f"scanned diameter {smallest:.3e} m passes; the throat is under "
        f"{smallest + out['diameter_error_m']:.3e} m with the scan's one-sided bar); use "
        f"{finer}, a few voxels across the throat"
    ]


def transport_outputs(rve: RVE, fields: VoxelFields, outputs: list[str], spec: dict) -> dict:
    """Row entries for the transport outputs requested in ``outputs`` (others ignored)."""
    from psdesign.schema.transport import validate_transport

    wanted = [o for o in outputs if o in TRANSPORT_OUTPUTS]
    if not wanted:
        return {}
    from psdesign.flow.error import cells_per_diameter

    tr = validate_transport(spec)
    cpd = cells_per_diameter(rve, float(fields.grid.spacing[0]))
    measure = resolution_measure(rve)  # what cpd counts across, named in the warnings
    row: dict = {}
    diff_dirs = sorted({o[-1] for o in wanted if o[:-1] in ("diffusivity_", "tortuosity_")})
    if diff_dirs:
        from psdesign.transport.diffusivity import relative_diffusivity

        for d in diff_dirs:
            res = relative_diffusivity(
                fields, d, tr, cells_per_diameter=cpd, resolution_measure=measure
            )
            if f"diffusivity_{d}" in wanted or f"tortuosity_{d}" in wanted:
                row[f"diffusivity_{d}"] = res.relative_diffusivity
                row[f"diffusivity_{d}_rel_error"] = res.rel_error
                row[f"diffusivity_{d}_converged"] = res.converged
                row[f"diffusivity_{d}_status"] = res.status
                if res.warnings:  # why a value is not ok (a neck, too few voxels), as K's
                    row[f"diffusivity_{d}_warnings"] = "; ".join(res.warnings)
                row[f"tortuosity_{d}"] = res.tortuosity_factor
                row[f"time_diffusivity_{d}_s"] = res.wall_time_s
    for d in sorted({o[-1] for o in wanted if o.startswith("conductivity_")}):
        from psdesign.transport.conductivity import effective_conductivity

        res = effective_conductivity(
            fields, d, transport=tr, cells_per_diameter=cpd, resolution_measure=measure
        )
        row[f"conductivity_{d}"] = res.effective_conductivity
        # the SI unit of conductivity_x/y/z (transport.conductivity_unit: W/(m K) or S/m),
        # in the table itself (walk-cli finding 4, session 52: only report.html named it)
        row[UNIT_COLUMN] = res.conductivity_unit
        row[f"conductivity_{d}_rel_error"] = res.rel_error
        row[f"conductivity_{d}_converged"] = res.converged
        row[f"conductivity_{d}_status"] = res.status
        if res.warnings:
            row[f"conductivity_{d}_warnings"] = "; ".join(res.warnings)
        row[f"time_conductivity_{d}_s"] = res.wall_time_s
    if any(o.startswith("pore_d") for o in wanted):
        from psdesign.transport.pores import pore_sizes

        axis = tr["thickness_axis"]
        ps = pore_sizes(fields, n_radii=int(tr["n_radii"]), thickness_axis=axis, rve=rve)
        row.update(
            {"pore_d10_m": ps.pore_d10_m, "pore_d50_m": ps.pore_d50_m, "pore_d90_m": ps.pore_d90_m}
        )
        row["pore_bin_width_m"] = ps.bin_width_m
        row["pore_diameter_error_m"] = ps.diameter_error_m
        # a face does not repeat: the bar reaches below too (session 54); the name is
        # analysis.columns.LOWER_BAR_COLUMN (a later stage that imports pandas: not imported
        # here; tests/unit/test_pores.py holds the two equal)
        if ps.walled_axes:
            row["pore_diameter_error_below_m"] = ps.diameter_error_below_m
        edge = varying_edge(fields)
        row["pore_sizes_status"] = pore_sizes_status(
            ps.converged, ps.rel_error, ps.pore_d90_m, cpd, edge
        )
    if "specific_surface_m-1" in wanted:
        from psdesign.transport.pores import specific_surface, surface_status

        sv = specific_surface(fields, rve=rve)
        row["specific_surface_m-1"] = sv.specific_surface_m_1
        row["specific_surface_rel_error"] = sv.rel_error
        row["specific_surface_status"] = surface_status(sv.rel_error, sv.extra["short_axes"], cpd)
    return row
