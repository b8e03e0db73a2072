"""``psdesign generate``: build an RVE and write rve.json, summary.json, field.vti, fibers.stl,
medial axes and preview.png."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from psdesign.cli.exit_status import status_code
from psdesign.cli.lines import print_json, with_porosity_status
from psdesign.cli.options import add_force_argument
from psdesign.io.vtkfile import save_vtk

#: What ``field.vti``'s point arrays hold (docs/fields.md "generate's field.vti"), written
#: beside them as string field data: until session 43 no file or page said which sign is solid.
FIELD_VTI_MEANINGS = {
    "distance_m": "signed distance to the solid surface in metres at the voxel centres: <= 0 "
    "in the solid (the voxels the porosity counts as solid), > 0 in the pore, clipped in the "
    "pore a few voxels from the surface; its contour at 0 is the surface (fibers.stl)",
    "fiber_count": "fibres whose solid contains the voxel centre: 0 pore, 1 one fibre, 2 or "
    "more an overlap (intersection_volume_fraction); an image's solid is 1",
}


def _cmd_generate(args: argparse.Namespace) -> int:
    from psdesign.schema.budget import unplanned_route
    from psdesign.schema.spec import load_spec

    # no flow solve: the spec is held to its voxel grid's memory, not to the [flow] solve a
    # permeability run would plan (session 52 walk: refused for a 16.7 GiB FEM permeameter)
    with unplanned_route():
        spec = load_spec(args.spec)
        summary = write_generate_outputs(
            spec,
            args.output,
            preview=not args.no_preview,
            force=args.force,
            formats=tuple(args.format or ()),
        )
    keys = (
        "porosity",
        "porosity_error",
        "n_fibers",
        "intersection_volume_fraction",
        "intersection_volume_fraction_error",
        "intersection_volume_fraction_status",
        "intersection_volume_fraction_note",  # an image's: why Omega does not apply
    )
    out = with_porosity_status({k: summary[k] for k in keys if k in summary})
    print_json(out)  # strict JSON, as every --json
    # the one exit rule (cli.exit_status): both numbers printed are results with a status
    return status_code(out["porosity_status"], out["intersection_volume_fraction_status"])


GENERATE_FILES = (
    "rve.json",
    "summary.json",
    "summary_timings.json",
    "field.vti",
    "fibers.stl",
    "medial_axes.csv",
    "medial_axes.json",
    "preview.png",
)
"""Files ``generate`` writes (checked against user files before the work starts)."""
#: Extra formats of ``generate --format``: name -> file written.
GENERATE_FORMATS = {"tiff": "rve.tif"}


def tiff_description(voxel: float) -> dict:
    """What ``rve.tif`` holds (written into summary.json)."""
    from psdesign.image.writer import SOLID_VALUE

    return {
        "file": GENERATE_FORMATS["tiff"],
        "dtype": "uint8",
        "solid_value": SOLID_VALUE,
        "pore_value": 0,
        "axes": "ZYX: pages z, rows y, columns x",
        "voxel_size_m": voxel,
        "voxel_size_stored": "X/Y resolution in pixels per um, ImageJ spacing (z) and unit = um",
    }


def refuse_input_overwrite(spec: dict, folder: Path, files: tuple[str, ...]) -> None:
    """Refuse to write ``files`` into ``folder`` when one of them is the spec's own image
    (or, for a folder or pattern of slices, would be read as one of its slices).

    A ``rve.tif`` that psdesign wrote becomes the user's input once an ``[image]`` spec
    reads it; ``--force`` replaces psdesign's files, and would replace that input (with
    its crop, say), so it is refused before any work.

    Parameters
    ----------
    spec : dict
        The validated spec (its ``image.path`` is absolute).
    folder : Path
        The checked output folder (resolved).
    files : tuple of str
        The names the command writes into it.

    Raises
    ------
    OutputError
        One line naming ``-o`` and the file.
    """
    from psdesign.image.slices import is_slice_member
    from psdesign.io.outputs import OutputError

    image = (spec.get("image") or {}).get("path")
    if image is None:
        return
    source = Path(image).resolve()
    for name in files:
        target = (folder / name).resolve()
        # into a folder of slices, a TIFF file would be read as one more slice next time
        member = is_slice_member(source, target)
        if target == source or member:
            what = "would be one more slice of" if member else "is"
            raise OutputError(
                "-o",
                f"{folder / name} {what} this spec's image (image.path); psdesign never "
                "replaces or changes its input, even with --force; choose another folder",
            )


def write_generate_outputs(
    spec: dict,
    out_dir: str | Path,
    preview: bool = True,
    force: bool = False,
    formats: tuple[str, ...] = (),
) -> dict:
    """Build, voxelize and write rve.json, summary.json, field.vti, fibers.stl, preview.png
    (and ``rve.tif`` with ``formats = ("tiff",)``: the solid mask as a uint8 TIFF stack,
    :func:`psdesign.image.writer.write_tiff`).

    All files appear together in ``out_dir`` or, on failure, none do.  ``out_dir`` is checked
    first (:func:`psdesign.io.outputs.check_output_dir`; ``force`` is ``--force``), so a refused
    folder costs no work and nothing psdesign did not write is ever replaced.

    Returns
    -------
    dict
        The summary.
    """
    from psdesign.errors import SpecError
    from psdesign.io.atomic import staged_directory, write_json
    from psdesign.io.outputs import check_output_dir
    from psdesign.io.timings import write_record
    from psdesign.packing.build import build_rve, rve_document, summarize
    from psdesign.packing.generators import write_medial_axes
    from psdesign.report.preview import (
        distance_image,
        fiber_surface,
        preview_title,
        render_preview,
        write_stl,
    )

    for fmt in formats:
        if fmt not in GENERATE_FORMATS:
            raise SpecError("--format", f"unknown format {fmt!r}; allowed: tiff")
    extra = tuple(GENERATE_FORMATS[f] for f in formats)
    target = check_output_dir(
        out_dir, force=force, command="generate", expected=GENERATE_FILES + extra
    )
    refuse_input_overwrite(spec, target.path, GENERATE_FILES + extra)
    t0 = time.perf_counter()
    built = build_rve(spec)
    rve = built.rve
    fields = built.voxelize(spec["rve"]["voxel"])
    summary = summarize(built, fields)
    summary["wall_time_s"] = {"build_and_voxelize": round(time.perf_counter() - t0, 3)}
    from psdesign import progress

    progress.stage(f"writing {target.path.name}: rve.json, field.vti, fibers.stl")
    # an earlier run's rve.tif / preview.png this run does not write are removed (finding 3)
    with staged_directory(
        target, replaces=GENERATE_FILES + tuple(GENERATE_FORMATS.values())
    ) as tmp:
        write_json(tmp / "rve.json", rve_document(rve))
        img = distance_image(fields.distance, fields.grid.spacing)
        img.point_data["fiber_count"] = fields.count.ravel(order="F")
        for name, meaning in FIELD_VTI_MEANINGS.items():  # ParaView's Information panel
            img.field_data[f"{name}_meaning"] = [meaning]
        save_vtk(img, tmp / "field.vti")
        del img  # its copies of the fields: not held through the surface and the preview
        surf = fiber_surface(fields.distance, fields.grid.spacing)
        if surf.n_points:
            write_stl(surf, tmp / "fibers.stl")  # in blocks: a Ctrl-C waits for one
        write_medial_axes(rve, tmp)
        if preview:
            progress.stage("rendering preview.png")
            render_preview(
                fields.distance,
                fields.grid.spacing,
                tmp / "preview.png",
                title=preview_title(summary),
                surface=surf,
            )
        if "tiff" in formats:
            from psdesign.image.writer import write_tiff

            voxel = float(fields.grid.spacing[0])
            write_tiff(fields.solid, tmp / GENERATE_FORMATS["tiff"], voxel)
            summary["tiff"] = tiff_description(voxel)
        summary["wall_time_s"]["total"] = round(time.perf_counter() - t0, 3)
        write_record(tmp, "summary.json", summary)  # the wall times beside it
    return summary


def register(sub: argparse._SubParsersAction) -> None:
    """Register ``generate``."""
    gen = sub.add_parser(
        "generate",
        help="build an RVE and write rve.json, summary.json, field.vti, fibers.stl, preview.png",
    )
    gen.add_argument("spec", help="RVE spec (TOML)")
    gen.add_argument("-o", "--output", required=True, help="output folder")
    gen.add_argument("--no-preview", action="store_true", help="skip preview.png")
    gen.add_argument(
        "--format",
        nargs="*",
        choices=tuple(GENERATE_FORMATS),
        default=[],
        help="extra outputs: tiff = rve.tif, the solid mask as a uint8 TIFF stack (1 = solid, "
        "pages z, voxel size in the resolution tags; docs/images.md)",
    )
    add_force_argument(gen)
    gen.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    gen.set_defaults(func=_cmd_generate)
