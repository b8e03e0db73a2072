"""Stage "generate": spec -> RVE -> voxel fields -> output files."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .atomic import staged_directory, write_json
from .rve import RVE, VoxelFields
from .spec import explicit_fibers


@dataclass
class BuiltRVE:
    """An RVE built from a spec, with its generation report."""

    rve: RVE
    report: dict = field(default_factory=dict)
    fields: VoxelFields | None = None

    def voxelize(self, voxel: float) -> VoxelFields:
        """Voxel fields at ``voxel``, reusing the generator's final fields when they match."""
        if self.fields is not None and np.allclose(self.fields.grid.spacing, voxel, rtol=1e-9):
            return self.fields
        return self.rve.voxelize(voxel)


def build_rve(spec: dict) -> BuiltRVE:
    """Build the RVE of a validated spec: explicit fibers plus generated ones.

    A ``[generator]`` table (and ``[intersections]``) is handed to
    :func:`psdesign.generators.build_fibers`.
    """
    fibers = explicit_fibers(spec)
    rve_spec = spec["rve"]
    if "generator" in spec:
        from .generators import build_fibers

        result = build_fibers(spec, explicit=fibers)
        return BuiltRVE(rve=result.rve, report=dict(result.report), fields=result.fields)
    rve = RVE(size=np.asarray(rve_spec["size"]), fibers=fibers, period=rve_spec["period"])
    return BuiltRVE(rve=rve, report={"n_fibers": len(fibers)})


def summarize(rve: RVE, fields: VoxelFields, report: dict | None = None) -> dict:
    """The summary.json content."""
    out = {
        "porosity": fields.porosity,
        "n_fibers": len(rve.fibers),
        "intersection_volume_fraction": fields.intersection_volume_fraction,
        "voxel_grid": fields.grid.to_dict(),
        "size_m": rve.size.tolist(),
        "period_m": rve.period,
        "units": "SI (metres)",
    }
    if report:
        out["generation"] = report
    return out


def rve_document(rve: RVE) -> dict:
    """The rve.json content: every fiber's PS parameters and medial axis (metres)."""
    axes = rve.medial_axes_m()
    fibers = []
    for fb, lines in zip(rve.fibers, axes, strict=True):
        d = fb.to_dict(rve.period)
        d["medial_axis_m"] = [line.tolist() for line in lines]
        fibers.append(d)
    return {
        "size_m": rve.size.tolist(),
        "period_m": rve.period,
        "coordinates": "PS models are in normalized coordinates xi = r / period_m",
        "solid": "psi(xi) <= isovalue",
        "fibers": fibers,
    }


def write_generate_outputs(spec: dict, out_dir: str | Path, preview: bool = True) -> dict:
    """Build, voxelize and write rve.json, summary.json, field.vti, fibers.stl, preview.png.

    All files appear together in ``out_dir`` or, on failure, none do.

    Returns
    -------
    dict
        The summary.
    """
    from .generators import write_medial_axes
    from .preview import distance_image, fiber_surface, render_preview

    t0 = time.perf_counter()
    built = build_rve(spec)
    rve = built.rve
    fields = built.voxelize(spec["rve"]["voxel"])
    summary = summarize(rve, fields, built.report)
    summary["wall_time_s"] = {"build_and_voxelize": time.perf_counter() - t0}
    with staged_directory(out_dir) as tmp:
        write_json(tmp / "rve.json", rve_document(rve))
        img = distance_image(fields.distance, fields.grid.spacing)
        img.point_data["fiber_count"] = fields.count.ravel(order="F")
        img.save(str(tmp / "field.vti"))
        surf = fiber_surface(fields.distance, fields.grid.spacing)
        if surf.n_points:
            surf.save(str(tmp / "fibers.stl"))
        write_medial_axes(rve, tmp)
        if preview:
            render_preview(fields.distance, fields.grid.spacing, tmp / "preview.png",
                           title=f"porosity {fields.porosity:.4f}, {len(rve.fibers)} fibers")
        summary["wall_time_s"]["total"] = time.perf_counter() - t0
        write_json(tmp / "summary.json", summary)
    return summary
