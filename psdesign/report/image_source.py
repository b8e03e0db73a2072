"""The image an image-based study solved, as rows of the report's Study table: its path and
format, voxel size (given or from the file), crop and voxel counts.

``study.json`` keeps the base spec's ``[image]`` table as given and, since session 45, what
the image's header said when the study ran (:func:`image_header`, under :data:`HEADER_KEY`):
format, voxel size and its source, the shape after the crop and the box. The report shows
that; until then it read the header again when the report was written, so an image replaced
after the run (another voxel size or shape) showed the new file's header beside the old
results. A study folder written before session 45 has no record: the header is read now by the
spec's own check (:func:`psdesign.schema.spec.validate_document` of the table: headers, not
voxels; a folder's slices one header each), and where the image can no longer be read
(moved, deleted) the rows say so and keep what ``study.json`` holds.
"""

from __future__ import annotations

import warnings
from pathlib import Path

#: Why z is taken equal to x and y for slices (:func:`psdesign.schema.image` warns the same).
NO_Z = "a slice stores no z spacing"


#: ``study.json``'s key of the image's header as read when the study ran (:func:`image_header`).
HEADER_KEY = "image_header"


def image_header(study: dict, base: Path) -> dict | None:
    """What the report shows of the image of ``study`` (``study.json``'s ``study`` table), read
    from its header now: ``format``, ``voxel_m``, ``voxel_source``, ``shape_xyz`` (voxels
    after the crop) and ``size_m`` (the box), or ``{"not_read": reason}``; None when the base
    spec has no ``[image]`` table. The runner stores it in ``study.json`` when the study runs.

    >>> image_header({"base": {"rve": {"size": [1e-5] * 3}}}, Path(".")) is None
    True
    >>> gone = {"base": {"image": {"path": "/nonexistent/scan.tif"}}}
    >>> image_header(gone, Path("."))["not_read"][:39]
    'image.path: file not found: /nonexisten'
    """
    table = (study.get("base") or {}).get("image")
    if not isinstance(table, dict):
        return None
    from psdesign.schema.spec import validate_document

    try:
        with warnings.catch_warnings():  # said when the study ran
            warnings.simplefilter("ignore")
            image = validate_document({"image": table}, base).image
    except Exception as exc:  # noqa: BLE001 - a report is never lost to a moved image
        return {"not_read": str(exc)}
    source = "given (image.voxel_size)" if table.get("voxel_size") else _file_source(image)
    return {
        "format": str(image.to_spec()["format"]),
        "voxel_m": float(image.voxel),
        "voxel_source": source,
        "shape_xyz": [int(n) for n in image.shape_xyz],
        "size_m": [float(s) for s in image.size],
    }


def image_rows(study: dict, base: Path, header: dict | None = None) -> list[tuple[str, str]]:
    """``(label, value)`` rows naming the image of ``study`` (``study.json``'s ``study``
    table); ``[]`` when its base spec has no ``[image]`` table.

    Parameters
    ----------
    study : dict
        The ``study`` table of ``study.json`` (its ``base`` spec and ``parameters``).
    base : Path
        Folder a relative ``image.path`` is read from (the study folder's; ``study.json``
        holds the absolute path).
    header : dict, optional
        :func:`image_header` as read when the study ran (``study.json``'s
        :data:`HEADER_KEY`); None (a folder written before session 45): read now.

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
    when = "when the study ran" if header else "now"
    header = header or image_header(study, base) or {}
    if "not_read" in header:
        return [*rows, ("image voxel size, shape", f"not read {when}: {header['not_read']}")]
    nx, ny, nz = header["shape_xyz"]
    sx, sy, sz = header["size_m"]
    rows.insert(1, ("image format", header["format"]))
    rows += [
        ("image voxel size (m)", f"{header['voxel_m']:.6g} ({header['voxel_source']})"),
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
