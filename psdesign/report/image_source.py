"""The image an image-based study solved, as rows of the report's Study table: its path and
format, voxel size (given or from the file), crop and voxel counts.

``study.json`` keeps the base spec's ``[image]`` table as given; the voxel size a file carries
and the shape after the crop are read again from the image's header by the spec's own check
(:func:`psdesign.schema.spec.validate_document` of the table: headers, not voxels; a folder's
slices one header each). Where the image can no longer be read (moved, deleted) the rows say so and
keep what ``study.json`` holds.
"""

from __future__ import annotations

import warnings
from pathlib import Path

#: Why z is taken equal to x and y for slices (:func:`psdesign.schema.image` warns the same).
NO_Z = "a slice stores no z spacing"


def image_rows(study: dict, base: Path) -> list[tuple[str, str]]:
    """``(label, value)`` rows naming the image of ``study`` (``study.json``'s ``study``
    table); ``[]`` when its base spec has no ``[image]`` table.

    Parameters
    ----------
    study : dict
        The ``study`` table of ``study.json`` (its ``base`` spec and ``parameters``).
    base : Path
        Folder a relative ``image.path`` is read from (the study folder's; ``study.json``
        holds the absolute path).

    Returns
    -------
    list of (str, str)

    Examples
    --------
    >>> image_rows({"base": {"rve": {"size": [1e-5] * 3}}}, Path("."))
    []
    >>> rows = image_rows({"base": {"image": {"path": "/nonexistent/scan.tif"}}}, Path("."))
    >>> rows[0], rows[-1][0]
    (('image', '/nonexistent/scan.tif'), 'image voxel size, shape')
    """
    table = (study.get("base") or {}).get("image")
    if not isinstance(table, dict):
        return []
    crop = table.get("crop")
    rows = [
        ("image", str(table.get("path"))),
        ("image crop (x, y, z voxel ranges)", str(crop) if crop else "none (the whole image)"),
    ]
    varied = [k for k in (study.get("parameters") or {}) if k.startswith("image.")]
    if varied:
        rows.append(("image keys varied by the study", ", ".join(varied) + " (base values here)"))
    from psdesign.schema.spec import validate_document

    try:
        with warnings.catch_warnings():  # said when the study ran
            warnings.simplefilter("ignore")
            image = validate_document({"image": table}, base).image
    except Exception as exc:  # noqa: BLE001 - a report is never lost to a moved image
        return [*rows, ("image voxel size, shape", f"not read now: {exc}")]
    source = "given (image.voxel_size)" if table.get("voxel_size") else _file_source(image)
    nx, ny, nz = image.shape_xyz
    sx, sy, sz = image.size
    rows.insert(1, ("image format", str(image.to_spec()["format"])))
    rows += [
        ("image voxel size (m)", f"{image.voxel:.6g} ({source})"),
        (
            "image shape (voxels x, y, z)",
            f"{nx} x {ny} x {nz} (box {sx:.4g} x {sy:.4g} x {sz:.4g} m)",
        ),
    ]
    return rows


def _file_source(image) -> str:
    """Where a voxel size read from the image came from: the file, or, for TIFF slices
    without a z spacing, the first slice's x/y calibration with z taken equal (the spec
    check's warning; "from the file" would claim a z spacing no slice stores)."""
    from psdesign.image.slices import is_slice_path, slice_set

    path = Path(image.to_spec()["path"])
    if is_slice_path(path) and not slice_set(path).z_spacing:
        first = slice_set(path).first.name
        return f"x and y from the calibration of {first}; z taken equal: {NO_Z}"
    return "from the file"
