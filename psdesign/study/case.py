"""One study case end to end: spec -> RVE -> voxels -> permeability -> flat result row."""

from __future__ import annotations

import os
import time
import warnings
from pathlib import Path

import numpy as np

from psdesign.analysis.columns import porosity_status
from psdesign.flow.permeability import permeability
from psdesign.io.diskfull import is_disk_full
from psdesign.io.outputs import TEMP_PREFIX
from psdesign.packing.build import build_rve
from psdesign.schema.image import ImageWarning
from psdesign.schema.spec import check_directions
from psdesign.schema.study import FIELDS_FLAG, OUTPUTS, k_directions, validate_case_spec
from psdesign.study.stages import mark_stage
from psdesign.transport.study_outputs import TRANSPORT_OUTPUTS, transport_outputs


def _field_writer(workdir: Path):
    from psdesign.fields import FieldWriter

    folder = Path(workdir) / "fields"
    folder.mkdir(parents=True, exist_ok=True)
    return FieldWriter(folder)


def _finish_fields(writer) -> dict:
    """``fields.json`` written; the row's ``fields_png`` (first picture) and warnings."""
    writer.finish()
    pics = [s["picture"] for s in writer.solves if s.get("picture")]
    out: dict = {}
    if pics:
        out["fields_png"] = str(writer.folder / pics[0])
    if writer.warnings:
        out["fields_warnings"] = "; ".join(writer.warnings)
    return out


#: Result keys a K solve has only sometimes, copied to ``<key>_<d>`` where it has them: the
#: stacked permeameter's copies (:mod:`psdesign.flow.stack`), the measure of a non-round
#: thinnest fiber (``"fiber thin width"``, :func:`psdesign.geometry.rve.resolution_measure`).
OPTIONAL_K_COLUMNS = ("permeameter_copies", "resolution_measure")


def solve_size_columns(direction: str, result: dict) -> dict[str, int]:
    """The size of a K solve as a count named by what it counts: ``n_dofs_<d>`` (FEM) or
    ``n_cells_<d>`` (voxel route's fluid cells). It was ``size_<d>``, which reads as the RVE's
    edge in metres beside ``rve.size``.

    >>> solve_size_columns("z", {"n_cells": 7262})
    {'n_cells_z': 7262}
    """
    return {
        f"{key}_{direction}": int(result[key]) for key in ("n_dofs", "n_cells") if key in result
    }


#: The generation report's keys a study row copies (its Omega before and after the
#: intersection removal, with their bars and statuses: psdesign.packing.overlap_status).
GENERATION_COLUMNS = (
    "target_porosity",
    "omega_before",
    "omega_before_error",
    "omega_after",
    "omega_after_error",
    "omega_before_status",
    "omega_after_status",
)


def _preview(row: dict, fields, workdir: Path, image: bool) -> dict:
    """The case's preview.png, titled as ``generate`` titles its own (porosity and Omega with
    their bars and statuses, from ``row``): the row's ``preview_png`` and ``preview_title``,
    or ``preview_error`` (a picture never fails a case; a full disk stops the run)."""
    # drawn under a temporary name and moved into place: a full disk leaves no truncated
    # preview.png (the case is then run again)
    tmp_png = workdir / f"{TEMP_PREFIX}preview.{os.getpid()}.png"
    try:
        from psdesign.report.preview import preview_title, render_preview

        title = preview_title(row, image=image)
        render_preview(
            fields.distance, fields.grid.spacing, tmp_png, title=title, window_size=(480, 400)
        )
        os.replace(tmp_png, workdir / "preview.png")
        # the title drawn on it: the report's caption leaves it out (a folder written before
        # session 49 has no such column, and its pictures no title: there the caption has it)
        return {"preview_png": str(workdir / "preview.png"), "preview_title": title}
    except Exception as exc:  # a picture must never fail a case; a full disk stops the run
        if is_disk_full(exc):
            raise
        return {"preview_error": str(exc)}
    finally:
        tmp_png.unlink(missing_ok=True)


def run_case(spec: dict, outputs: list[str], solver: str, workdir: Path) -> dict:
    """Run one case and return a flat dict of results (SI units).

    Parameters
    ----------
    spec : dict
        An RVE spec (validated here).
    outputs : list of str
        Among :data:`OUTPUTS`; with ``"fields"`` (``[study] fields = true``) the permeability
        solves write their fields into ``workdir / "fields"`` (:mod:`psdesign.fields`) and the
        row gets ``fields_png`` (the first picture).
    solver : {"fem", "voxel"}
    workdir : Path
        Folder for this case's files (a preview picture).
    """
    t0 = time.perf_counter()
    with warnings.catch_warnings():  # the run showed them once (validate_case_specs)
        warnings.simplefilter("ignore", ImageWarning)
        spec = validate_case_spec(spec, outputs)  # held to the work its outputs do
    for o in outputs:
        if o not in OUTPUTS and o != FIELDS_FLAG:
            raise ValueError(f"outputs: unknown output {o!r}; allowed: {', '.join(OUTPUTS)}")
    directions = k_directions(outputs)
    check_directions(spec, {**spec["flow"], "solver": solver}, directions)  # before any work
    mark_stage(workdir, "generating the RVE")
    built = build_rve(spec)
    rve = built.rve
    fields = built.voxelize(spec["rve"]["voxel"])
    row: dict = {
        "porosity": fields.porosity,
        "porosity_error": fields.porosity_error,
        # rated by its bar, as generate prints it: the report, exit and fits read it
        "porosity_status": porosity_status(fields.porosity, fields.porosity_error),
        "n_fibers": len(rve.fibers),
        # an image's: not_applicable, no value (the note why is the summary's alone)
        **built.omega_values(fields),
        "time_geometry_s": time.perf_counter() - t0,
    }
    gen = built.report or {}
    row |= {key: gen[key] for key in GENERATION_COLUMNS if key in gen}
    columns = {}
    writer = _field_writer(workdir) if FIELDS_FLAG in outputs else None
    for d in directions:
        mark_stage(workdir, f"solving K_{d} ({solver}, bc {spec['flow'].get('bc', 'default')})")
        res = permeability(rve, fields, d, spec["flow"], solver=solver, capture=writer)
        row[f"k_{d}_m2"] = res["permeability_m2"]
        row[f"k_{d}_rel_error"] = res.get("permeability_rel_error")
        row[f"k_{d}_status"] = res.get("status")
        row[f"bc_{d}"] = res.get("bc")
        row[f"cells_per_diameter_{d}"] = res.get("cells_per_diameter")
        row |= {f"{k}_{d}": res[k] for k in OPTIONAL_K_COLUMNS if k in res}
        if res.get("warnings"):
            row[f"warnings_{d}"] = "; ".join(res["warnings"])
        if res.get("thread_note"):  # run metadata: how it ran (is_timing_column)
            row[f"thread_note_{d}"] = res["thread_note"]
        row[f"converged_{d}"] = res["converged"]
        row[f"residual_{d}"] = res["residual"]
        row[f"iterations_{d}"] = res["iterations"]
        row[f"flux_imbalance_{d}"] = res["flux_imbalance"]
        row[f"time_solve_{d}_s"] = res["wall_time_s"]
        row.update(solve_size_columns(d, res))
        if "permeability_column_m2" in res:
            columns[d] = res["permeability_column_m2"]
    if "k_tensor" in outputs and len(columns) == 3:
        tensor = np.column_stack([columns[d] for d in "xyz"])
        for i, a in enumerate("xyz"):
            for j, b in enumerate("xyz"):
                row[f"k_{a}{b}_m2"] = float(tensor[i, j])
    if writer is not None:
        row.update(_finish_fields(writer))
    if any(o in TRANSPORT_OUTPUTS for o in outputs):
        mark_stage(workdir, "transport outputs")
    row.update(transport_outputs(rve, fields, outputs, spec))  # issue 13: transport outputs
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    mark_stage(workdir, "preview picture")
    row.update(_preview(row, fields, workdir, image="image" in spec))
    row["time_total_s"] = time.perf_counter() - t0
    return row
