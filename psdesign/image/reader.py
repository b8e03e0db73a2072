"""Read a voxel image into a solid mask indexed ``[x, y, z]``.

Formats (``format``, by default from the extension): ``tif``/``tiff`` stacks (tifffile;
pages are z, rows y, columns x) and folders or patterns of 2-D TIFF slices (slice i is z
index i, :mod:`psdesign.image.slices`), ``npy`` (NumPy, indexed ``[x, y, z]`` as stored unless
``axis_order`` says otherwise), ``raw`` (headerless; ``shape`` in x, y, z order, ``dtype``,
``byte_order``, C order with x fastest unless ``axis_order`` says otherwise) and ``vti`` (VTK
image data, first point or cell array, ``[x, y, z]``). ``axis_order`` names the stored axes
from the slowest to the fastest index, e.g. ``"zyx"`` (TIFF and raw default). Which values are
solid is given by ``solid`` (a label or list of labels, or ``"nonzero"``) or by
``threshold`` (solid where the value is ``>= threshold``); an optional ``crop`` keeps
``[[x0, x1], [y0, y1], [z0, z1]]`` voxels (half-open, after the axis order is applied).

Every problem is a :class:`ValueError` whose message starts with the ``[image]`` key it is
about (``image.path: ...``), so the spec validation can report it as a one-line error.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from psdesign.geometry.rve import in_metres, is_cubic
from psdesign.image.slices import is_slice_path, read_slices, slice_set
from psdesign.schema.rve import MIN_VOXELS_TEXT

FORMATS = (".tif", ".tiff", ".npy", ".raw", ".vti")
#: Element types of a raw image.
RAW_DTYPES = ("uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64")
#: What a file's voxel size must be (its refusal's allowed range; the tests below use 1e-6).
CUBIC_ALLOWED = "(allowed: cubic voxels, x = y = z to 1 part in 1e6)"
#: What an image's array must be (the refusal of one of another rank).
THREE_D_ALLOWED = f"(allowed: a 3-D image, {MIN_VOXELS_TEXT})"
#: Length units of ImageJ metadata, in metres (looked up in lower case: ImageJ's own "micron",
#: its escaped "\\u00B5m", and the spellings other writers use; "microns" read as "no voxel
#: size" until session 43). Not "inch": ImageJ's unit of a picture calibrated by its DPI tag
#: (72 dpi: 0.35 mm "voxels"), never a scan's; it is named in the refusal instead.
_UNITS = {
    "nm": 1e-9,
    "nanometer": 1e-9,
    "nanometre": 1e-9,
    "um": 1e-6,
    "micron": 1e-6,
    "microns": 1e-6,
    "micrometer": 1e-6,
    "micrometre": 1e-6,
    "\u00b5m": 1e-6,
    "\u03bcm": 1e-6,
    "\\u00b5m": 1e-6,
    "mm": 1e-3,
    "millimeter": 1e-3,
    "millimetre": 1e-3,
    "cm": 1e-2,
    "centimeter": 1e-2,
    "centimetre": 1e-2,
    "m": 1.0,
    "meter": 1.0,
    "metre": 1.0,
}
#: ImageJ's word for "not calibrated".
_NO_UNIT = ("", "pixel", "pixels")


def unit_metres(unit: str) -> float | None:
    """Metres per ImageJ ``unit`` (any case, spaces around it, a word's plural "s": the
    spellings writers use), or None where it is not a length psdesign reads. One rule for the
    voxel size and the refusal's note (s43-iface read "microns" but not "micrometers" or
    "meters", review2).

    >>> unit_metres("Micrometers"), unit_metres(" UM "), unit_metres("meter"), unit_metres("ms")
    (1e-06, 1e-06, 1.0, None)
    """
    u = str(unit).strip().lower()
    if u not in _UNITS and len(u) > 3 and u.endswith("s"):  # not "ms": milliseconds
        u = u[:-1]
    return _UNITS.get(u)


def tiff_unit(path: str | Path) -> str:
    """The ImageJ ``unit`` of a TIFF file as written ('' without ImageJ metadata)."""
    import tifffile

    with tifffile_quiet(), tifffile.TiffFile(path) as tf:
        return str((tf.imagej_metadata or {}).get("unit", "")).strip()


def unknown_unit_note(path: str | Path, fmt: str | None = None) -> str:
    """Why a TIFF file's calibration is not read: ``" (its ImageJ unit 'furlong' is not a
    length psdesign reads: nm, um, micron, mm, cm, m)"``, or '' (none, or not a TIFF)."""
    ext = f".{fmt}" if fmt else Path(path).suffix.lower()
    if ext not in (".tif", ".tiff"):
        return ""
    unit = tiff_unit(slice_set(path).first if is_slice_path(path) else path)
    if unit.lower() in _NO_UNIT or unit_metres(unit) is not None:
        return ""
    known = "nm, um, micron, mm, cm, m"
    return f" (its ImageJ unit {unit!r} is not a length psdesign reads: {known})"


@dataclass(frozen=True)
class ImageSource:
    """Where and how to read an image.

    Attributes
    ----------
    path : Path
    voxel : float
        Voxel edge in metres (cubic voxels).
    solid : int, tuple of int, or "nonzero"
        Labels of the solid (ignored when ``threshold`` is set).
    crop : tuple of (lo, hi) per axis, or None
    shape, dtype, byte_order : raw images only (shape in x, y, z order; "little" | "big")
    axis_order : str, optional
        Stored axes from the slowest to the fastest index, a permutation of ``"xyz"``
        (default ``"zyx"`` for TIFF and raw, ``"xyz"`` for NumPy and VTI).
    threshold : float, optional
        Solid where the stored value is ``>= threshold``.
    format : str, optional
        ``"tif"``, ``"tiff"``, ``"npy"``, ``"raw"`` or ``"vti"`` (default: the extension).
    """

    path: Path
    voxel: float
    solid: int | tuple[int, ...] | str = "nonzero"
    crop: tuple[tuple[int, int], ...] | None = None
    shape: tuple[int, int, int] | None = None
    dtype: str = "uint8"
    byte_order: str = "little"
    axis_order: str | None = None
    threshold: float | None = None
    format: str | None = None

    @property
    def ext(self) -> str:
        """The format as an extension (``".tif"``, ...; a folder or pattern of slices:
        ``".tif"``)."""
        if self.format:
            return f".{self.format}"
        return ".tif" if is_slice_path(self.path) else Path(self.path).suffix.lower()


def _to_xyz(data: np.ndarray, order: str) -> np.ndarray:
    """Transpose stored axes ``order`` (slowest first) to ``[x, y, z]``."""
    if sorted(order) != ["x", "y", "z"]:
        raise ValueError(f"image.axis_order: a permutation of 'xyz', got {order!r}")
    return data.transpose([order.index(a) for a in "xyz"])


def raw_layout(src: ImageSource) -> tuple[np.dtype, int]:
    """Element type and voxel count of a raw image, checked against the file's size (nothing
    is read: the schema learns a raw image's extent before the memory budget)."""
    if src.shape is None:
        raise ValueError("image.shape: required for a raw image ([nx, ny, nz])")
    if src.dtype not in RAW_DTYPES:
        raise ValueError(f"image.dtype: unknown {src.dtype!r}; allowed: {', '.join(RAW_DTYPES)}")
    dt = np.dtype(src.dtype).newbyteorder("<" if src.byte_order == "little" else ">")
    n = int(np.prod(src.shape))
    size = Path(src.path).stat().st_size
    if size != n * dt.itemsize:
        raise ValueError(
            f"image.shape: {list(src.shape)} x {dt.itemsize} bytes = {n * dt.itemsize} bytes, "
            f"but {Path(src.path).name} has {size} bytes (allowed: [nx, ny, nz] with nx ny nz x "
            f"{dt.itemsize} bytes = the file's {size} bytes)"
        )
    return dt, n


def _read_raw(src: ImageSource) -> np.ndarray:
    """The raw file memory-mapped (indexed ``[x, y, z]``): a crop reads only its voxels."""
    dt, n = raw_layout(src)
    data = np.memmap(src.path, dtype=dt, mode="r", shape=(n,))
    order = src.axis_order or "zyx"
    stored = [src.shape["xyz".index(a)] for a in order] if sorted(order) == list("xyz") else [n]
    return _to_xyz(data.reshape(stored), order)


def vti_header(path: Path) -> tuple[tuple[int, int, int], tuple[float, float, float]]:
    """Voxel counts ``(nx, ny, nz)`` of the first array :func:`_read_vti` takes and the
    spacing, from the VTI file's header (VTK's ``UpdateInformation``: no data is read, so the
    memory budget can refuse a huge image first)."""
    from vtkmodules.vtkCommonDataModel import vtkDataObject
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    reader = vtkXMLImageDataReader()
    if not reader.CanReadFile(str(path)):
        raise ValueError(f"image.path: cannot read {Path(path).name} as VTK image data (.vti)")
    reader.SetFileName(str(path))
    reader.UpdateInformation()
    info = reader.GetOutputInformation(0)
    ext = info.Get(vtkStreamingDemandDrivenPipeline.WHOLE_EXTENT())
    spacing = info.Get(vtkDataObject.SPACING())
    if ext is None or spacing is None:
        raise ValueError(f"image.path: cannot read the header of {Path(path).name}")
    _check_vti_direction(Path(path).name, info.Get(vtkDataObject.DIRECTION()))
    if not reader.GetNumberOfPointArrays() and not reader.GetNumberOfCellArrays():
        raise ValueError(f"image.path: {Path(path).name} holds no data array")
    points = tuple(int(ext[2 * a + 1] - ext[2 * a] + 1) for a in range(3))
    cells = points if reader.GetNumberOfPointArrays() else tuple(max(1, n - 1) for n in points)
    return cells, tuple(float(h) for h in spacing)


#: What a .vti file's Direction matrix must be (the refusal of another).
IDENTITY_ALLOWED = '(allowed: the identity direction, Direction="1 0 0 0 1 0 0 0 1", or none)'


def _check_vti_direction(name: str, direction) -> None:
    """Refuse a .vti whose Direction matrix is not the identity (``image.path``): psdesign
    reads the stored i, j, k axes as x, y, z, so a rotated or flipped image was read in the
    wrong frame (a 90-degree swap of x and y gave K_x of the plates normal to x, ``ok``,
    exit 0: session 52 I/O review, finding 2). ``None`` (VTK < 9 writes none) is the identity.
    """
    if direction is None:
        return
    d = np.asarray(direction, dtype=float).reshape(3, 3)
    if not np.array_equal(d, np.eye(3)):
        rows = "; ".join(" ".join(f"{v:g}" for v in row) for row in d)
        raise ValueError(
            f"image.path: {name} has the Direction matrix [{rows}], not the identity: psdesign "
            "reads the stored i, j, k axes as x, y, z and would solve in a rotated or flipped "
            f"frame {IDENTITY_ALLOWED}; resample it onto axis-aligned x, y, z "
            "(ParaView: Resample To Image) or give it as .npy with image.axis_order"
        )


def _read_vti(path: Path) -> np.ndarray:
    import pyvista as pv

    vti_header(path)  # its Direction checked (a cheap header read) before the voxels
    img = pv.read(str(path))
    arrays = list(img.point_data.keys()) or list(img.cell_data.keys())
    if not arrays:
        raise ValueError(f"image.path: {path.name} holds no data array")
    if img.point_data.keys():
        dims = img.dimensions
        data = np.asarray(img.point_data[arrays[0]])
    else:
        dims = tuple(max(1, d - 1) for d in img.dimensions)
        data = np.asarray(img.cell_data[arrays[0]])
    if data.ndim != 1:  # e.g. a velocity field: the image must be one label per voxel
        raise ValueError(
            f"image.path: the first array of {path.name}, {arrays[0]!r}, has "
            f"{data.shape[1]} components; give a file whose first array is the label image"
        )
    return data.reshape(dims, order="F")


@contextmanager
def tifffile_quiet() -> Iterator[None]:
    """tifffile's own log lines silenced while psdesign reads a TIFF file.

    On a damaged file tifffile logs a line (``<tifffile.TiffPages @...> invalid offset to
    first page ...``) to stderr before it raises: a second line beside psdesign's one
    ``image.path: cannot read ... as TIFF`` line (session 40's input audit).
    """
    log = logging.getLogger("tifffile")
    level = log.level
    log.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        log.setLevel(level)


def tiff_shape(path: Path) -> tuple[int, ...]:
    """The stored shape of the stack a TIFF file holds, from its header (no voxel is read):
    its first series, or its pages as z when written page by page (:func:`_stack_header`);
    a colour or multi-channel image is refused (``image.path``).

    tifffile puts the colour samples of an RGB(A) image on an axis ``S`` and ImageJ's channels
    on ``C``: read as voxels, a 2-D RGBA picture (16 x 16 x 4) became a 3-D image four voxels
    thick whose colour channels were solved as slices (exit 0, a K of a structure nobody
    gave), a 2-D RGB one was refused for its three "voxels" along x.
    """
    import tifffile

    name = Path(path).name
    try:
        with tifffile_quiet(), tifffile.TiffFile(path) as tf:
            axes, shape = _stack_header(tf, name)
    except ValueError as exc:
        if str(exc).startswith("image."):  # the refusals of _stack_header
            raise
        raise ValueError(f"image.path: cannot read {name} as TIFF: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        raise ValueError(f"image.path: cannot read {name} as TIFF: {exc}") from None
    return plain_tiff_shape(name, axes, shape)


def page_series(tf) -> bool:
    """Whether a TIFF file holds its stack as one 2-D series per page, as
    ``tifffile.imwrite(path, page, append=True)`` writes it page by page: several one-page
    series of one shape and element type (:func:`tiff_shape` refuses other series sets).
    Such a file read as its first series was "a 2-D image" (session 54 walk)."""
    series = tf.series
    if len(series) < 2:
        return False
    first = series[0]
    return all(
        len(s.pages) == 1 and s.shape == first.shape and s.dtype == first.dtype for s in series
    )


def _stack_header(tf, name: str) -> tuple[str, tuple[int, ...]]:
    """The axes and shape of the stack a TIFF file holds (its first series, also beside
    smaller ones: :func:`_aux_series_only`; or its pages as z when :func:`page_series`), from
    the header; a file of other series, or one whose header describes more pages than it
    holds (truncated), is refused (``image.path``)."""
    series = tf.series
    if page_series(tf):
        first = series[0]  # its pages' axes: a writer's leading 1 (1 x rows x cols) dropped
        axes = zip(first.axes, first.shape, strict=True)
        page = [(a, int(n)) for a, n in axes if a in "YXSC" or n > 1]
        if len([a for a, _ in page if a not in "SC"]) == 2:
            _check_complete(tf, name)
            check_numeric(first.dtype, name)
            return "Q" + "".join(a for a, _ in page), (len(series), *(n for _, n in page))
    if len(series) > 1 and not _aux_series_only(series):
        kinds = sorted({f"{'x'.join(map(str, s.shape))} {s.dtype}" for s in series})
        raise ValueError(
            f"image.path: {name} holds {len(series)} image series ({', '.join(kinds[:4])}); "
            "psdesign reads one stack (allowed: a single 3-D series, or one 2-D page per "
            "series, all of one shape and element type)"
        )
    _check_complete(tf, name)
    check_numeric(series[0].dtype, name)
    return str(series[0].axes), tuple(int(n) for n in series[0].shape)


def _aux_series_only(series) -> bool:
    """Whether a TIFF file's series after the first are only smaller images beside a 3-D
    first one (a thumbnail, RGB preview, OME label image or reduced-resolution page): the
    first is then the stack, as tifffile, Fiji and PoreSpy read it (review of session 54: the
    multi-series refusal had refused such files, which main read). Series of the first one's
    page size (a file appended in 3-D chunks) are no such file: reading the first chunk alone
    lost the rest without a word."""
    first = series[0].keyframe
    area = first.imagewidth * first.imagelength
    return len([a for a in series[0].axes if a not in "SC"]) >= 3 and all(
        s.keyframe.imagewidth * s.keyframe.imagelength < area for s in series[1:]
    )


def _check_complete(tf, name: str) -> None:
    """Refuse a truncated TIFF stack (an interrupted copy or save) naming the pages its header
    describes and those the file holds: tifffile falls back to the first page when the ImageJ
    header's ``images`` are missing, and keeps a shaped series whose data end early (both were
    read as "a 2-D image" or a stack of missing pages, session 54 walk). A compressed (not
    contiguous) stack holds one page directory per page: fewer than its ImageJ or tifffile
    shaped header describes is truncated too (a zlib stack cut short read as "a 2-D image"),
    and so is a file whose last page's data end past the file's end (a page-by-page file cut
    mid-page: tifffile's read error, with its own log line, came only when the voxels were
    read)."""
    series = tf.series[0]
    page = series.keyframe
    meta = tf.imagej_metadata or {}
    size = tf.filehandle.size
    expected, found = 1, len(tf.pages)
    if meta and series.kind.lower() != "imagej":  # tifffile found the ImageJ header invalid
        expected = int(meta.get("images", 1))
    elif series.dataoffset is not None:  # contiguous: may hold one page directory alone
        if series.dataoffset + series.nbytes > size:
            expected = series.size // max(1, page.size)
            found = min(found, (size - series.dataoffset) // max(1, page.nbytes))
    elif meta:
        expected = int(meta.get("images", 1))
    elif tf.shaped_metadata:  # the first series' shape over the first page's size
        shape = tf.shaped_metadata[0].get("shape") or [1]
        expected = int(np.prod(shape)) // max(1, tf.pages[0].size)
    last = tf.pages[-1]  # its data cut short (a page-by-page file cut mid-page)
    ends = zip(last.dataoffsets, last.databytecounts, strict=True)
    if max((o + n for o, n in ends), default=0) > size:
        expected, found = max(expected, len(tf.pages)), min(found, len(tf.pages) - 1)
    if found < expected:
        raise ValueError(
            f"image.path: {name} is truncated: its header describes {expected} pages, the "
            f"file holds {found} (allowed: a complete stack; copy or save it again)"
        )


def plain_tiff_shape(
    name: str, axes: str, shape: tuple[int, ...], stack: bool = True
) -> tuple[int, ...]:
    """A TIFF series' shape without its colour (``S``) and channel (``C``) axes of length 1;
    a colour or multi-channel image is refused (``image.path``, naming ``name``). ``stack``:
    the file is the whole image (a single-file stack), not one slice of a folder, where the
    channels-as-z cure (write the planes as ZYX) would only meet the one-slice-per-file
    refusal (review B, session 52)."""
    colour = {a: n for a, n in zip(axes, shape, strict=True) if a in "SC" and n > 1}
    if stack and set(colour) == {"C"} and not set(axes) & set("ZT"):
        # session 52 I/O review, finding 3: tifffile.imwrite(path, vol, imagej=True) stores a
        # 3-D array as channels (CYX) unless told its axes; the colour advice did not help
        raise ValueError(
            f"image.path: {name} stores its {colour['C']} planes as ImageJ channels (axes "
            f"{axes}, no Z), as tifffile.imwrite(..., imagej=True) saves a 3-D array without "
            "metadata={'axes': 'ZYX'}; psdesign does not read channels as z slices "
            "(allowed: a single-channel stack, axes ZYX): if the planes are z slices, write it "
            "with metadata={'axes': 'ZYX'} (Fiji: Image > Hyperstacks > Re-order Hyperstacks, "
            "channels to slices)"
        )
    if colour:
        what = ", ".join(
            f"{n} {'colour samples' if a == 'S' else 'channels'}" for a, n in colour.items()
        )
        raise ValueError(
            f"image.path: {name} is a colour or multi-channel image (axes {axes}, "
            f"{what}); psdesign needs one label or grey value per voxel: save the "
            "segmentation as a single-channel 8- or 16-bit stack (Fiji: Image > Type > 8-bit)"
        )
    return tuple(n for a, n in zip(axes, shape, strict=True) if a not in "SC")


def _tiff_array(path: Path, pages: tuple[int, int] | None = None) -> tuple[np.ndarray, bool]:
    """The stack of a TIFF file (its first series, or its pages when :func:`page_series`),
    and whether only the pages ``[lo, hi)`` of ``pages`` were read. A file written page by
    page is decoded page by page (only the crop's pages); else the first series is
    memory-mapped when stored uncompressed and contiguous (a crop then reads only its
    voxels); else, for a stack of pages, only those pages (decoded one at a time); else read
    whole."""
    import tifffile

    with tifffile.TiffFile(path) as tf:
        if page_series(tf):  # one series per page: tifffile.memmap would map the first only
            return _read_pages(tf.pages, len(tf.series), pages)
    try:
        return tifffile.memmap(path, mode="r"), False
    except ValueError:  # compressed or tiled: not memory-mappable
        pass
    with tifffile.TiffFile(path) as tf:
        series = tf.series[0]
        stack = series.pages
        if pages is None or len(series.shape) != 3 or len(stack) != series.shape[0]:
            return np.asarray(series.asarray()), False
        return _read_pages(stack, len(stack), pages)


def _read_pages(stack, n: int, pages: tuple[int, int] | None) -> tuple[np.ndarray, bool]:
    """The first ``n`` pages of ``stack`` as a (z, y, x) array, decoded one at a time, or only
    ``pages = (lo, hi)`` of them (then True); a bad range reads all (``read_labels`` names
    the bad crop)."""
    lo, hi = (0, n) if pages is None else pages
    sliced = pages is not None and 0 <= lo < hi <= n
    if not sliced:
        lo, hi = 0, n
    first = np.asarray(stack[lo].asarray())
    out = np.empty((hi - lo, *first.shape), dtype=first.dtype)
    out[0] = first
    for k in range(lo + 1, hi):
        out[k - lo] = stack[k].asarray()
    return out, sliced


def _read_slice_crop(src: ImageSource, order: str) -> np.ndarray:
    """The crop of a folder or pattern of TIFF slices, stored axes (slices, rows, columns):
    only the crop's slices, rows and columns are read."""
    sset = slice_set(src.path)
    if src.crop is None:
        return read_slices(sset)
    xyz = _crop_slices(src.crop, [sset.stored_shape[order.index(a)] for a in "xyz"])
    return read_slices(sset, [(xyz["xyz".index(a)].start, xyz["xyz".index(a)].stop) for a in order])


def _crop_slices(crop: tuple, shape) -> tuple[slice, ...]:
    """The crop's index ranges as slices of an array of ``shape`` (x, y, z), checked."""
    out = []
    for ax, (lo, hi) in enumerate(crop):
        if not 0 <= lo < hi <= shape[ax]:
            raise ValueError(
                f"image.crop[{ax}]: must satisfy 0 <= lo < hi <= {shape[ax]}, got [{lo}, {hi}]"
            )
        out.append(slice(lo, hi))
    return tuple(out)


def _read_stored(src: ImageSource) -> tuple[np.ndarray, tuple | None]:
    """The stored values indexed ``[x, y, z]`` and the crop still to apply to them;
    memory-mapped where the format allows it (raw, NumPy, uncompressed TIFF), so that
    :func:`read_labels` copies only the crop; a compressed TIFF stack decodes only the
    crop's pages."""
    path, ext = Path(src.path), src.ext
    if ext in (".tif", ".tiff"):
        order = src.axis_order or "zyx"
        if sorted(order) != ["x", "y", "z"]:
            raise ValueError(f"image.axis_order: a permutation of 'xyz', got {order!r}")
        if is_slice_path(path):
            return _to_xyz(_read_slice_crop(src, order), order), None
        page_axis = "xyz".index(order[0])  # the stored axis of the pages, as an x/y/z axis
        pages = None if src.crop is None else tuple(src.crop[page_axis])
        tiff_shape(path)  # a colour image is refused before its pixels are read
        try:
            with tifffile_quiet():
                data, sliced = _tiff_array(path, pages)
        except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
            raise ValueError(f"image.path: cannot read {path.name} as TIFF: {exc}") from None
        if data.ndim == 2:
            data = data[None]
        if data.ndim != 3:
            raise ValueError(
                f"image.path: expected a 3-D stack, got shape {data.shape} {THREE_D_ALLOWED}"
            )
        crop = src.crop
        if sliced:  # the pages read are the crop's: the rest of it still to apply
            crop = tuple((0, data.shape[0]) if ax == page_axis else c for ax, c in enumerate(crop))
        return _to_xyz(data, order), crop
    if ext == ".npy":
        data = open_npy(path)
        if data.ndim != 3:
            raise ValueError(
                f"image.path: expected a 3-D array, got shape {data.shape} {THREE_D_ALLOWED}"
            )
        return _to_xyz(data, src.axis_order or "xyz"), src.crop
    if ext == ".raw":
        return _read_raw(src), src.crop
    data = _read_vti(path)
    check_numeric(data.dtype, path.name)
    return _to_xyz(data, src.axis_order or "xyz"), src.crop


#: The element types an image's voxels may have (NumPy kinds: bool, signed and unsigned
#: integer, float) and the refusal's allowed range.
NUMERIC_KINDS = "biuf"
NUMERIC_ALLOWED = "(allowed: bool, integer or float voxels)"


def check_numeric(dtype: np.dtype, name: str) -> None:
    """Refuse an image whose element type is not a number psdesign can label or threshold
    (``image.path``): a string array of '0' / '1' read as all solid, a structured one raised
    a TypeError at ``labels != 0``, complex, datetime and object arrays were taken as
    labels (session 54 walk)."""
    if np.dtype(dtype).kind not in NUMERIC_KINDS:
        raise ValueError(
            f"image.path: {name} holds elements of type {np.dtype(dtype)}, not numbers "
            f"{NUMERIC_ALLOWED}"
        )


def open_npy(path: str | Path) -> np.ndarray:
    """A ``.npy`` file memory-mapped (its header read, no voxel), its element type checked
    (:func:`check_numeric`); an unreadable file, an empty one (an interrupted ``np.save``:
    ``EOFError``) or a pickled array is refused naming ``image.path``."""
    name = Path(path).name
    try:
        data = np.load(path, mmap_mode="r", allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise ValueError(f"image.path: cannot read {name} as .npy: {exc}") from None
    check_numeric(data.dtype, name)
    return data


def read_labels(src: ImageSource) -> np.ndarray:
    """The stored values as an array indexed ``[x, y, z]`` (after the crop)."""
    path = Path(src.path)
    if src.ext not in FORMATS:
        raise ValueError(
            f"image.format: unknown format {src.ext!r}; allowed: "
            f"{', '.join(f.lstrip('.') for f in FORMATS)}"
        )
    if not path.is_file() and not is_slice_path(path):
        raise ValueError(f"image.path: file not found: {path}")
    data, crop = _read_stored(src)
    if crop is not None:
        data = data[_crop_slices(crop, data.shape)]
    if isinstance(data, np.memmap):
        data = np.array(data)  # the crop in memory, the file closed
    return data


def _check_segmented(labels: np.ndarray) -> None:
    """The default "every nonzero voxel is solid" on an image that does not look segmented:
    non-integer values are refused (``image.threshold``), more than two grey levels in an
    8 / 16-bit image are warned about (a labelled image of several phases or of single fibers
    is fine, a grey-value scan is not)."""
    import warnings

    if labels.dtype.kind == "f":
        finite = labels[np.isfinite(labels)]
        if finite.size != labels.size or np.any(finite != np.round(finite)):
            raise ValueError(
                "image.threshold: the image holds non-integer (or non-finite) values, not "
                "labels: a grey-value scan? (allowed: a segmented image, or threshold = V: "
                "solid where the value >= V)"
            )
        return
    if labels.dtype.kind in "ub" and labels.dtype.itemsize <= 2:
        flat = labels.reshape(-1)
        sample = flat[:: max(1, flat.size >> 24)]  # at most ~16 M voxels: no copy of a big scan
        counts = np.bincount(sample.astype(np.int64), minlength=2)
        levels = int(np.count_nonzero(counts))
        if levels > 2:
            solid = 1.0 - counts[0] / sample.size
            warnings.warn(
                f"image: {levels} distinct values and neither solid_label nor threshold: every "
                f"nonzero voxel is taken as solid (solid fraction {solid:.4f}); if this is a "
                "grey-value scan, segment it or give image.threshold",
                UserWarning,
                stacklevel=3,
            )


def solid_mask(
    labels: np.ndarray, solid: int | tuple[int, ...] | str, threshold: float | None = None
) -> np.ndarray:
    """Boolean mask of the solid voxels (``threshold`` wins over ``solid``).

    A grey image with a NaN voxel is refused with a threshold (``NaN >= V`` is False, so the
    voxel was taken as pore without a word):

    >>> try:
    ...     solid_mask(np.array([0.2, np.nan, 0.9]), "nonzero", threshold=0.5)
    ... except ValueError as exc:
    ...     print(str(exc)[:77])
    image.threshold: 1 of the image's 3 voxels hold no grey value (NaN), first at
    """
    if threshold is not None:
        if labels.dtype.kind == "f":
            bad = np.isnan(labels)
            if bad.any():
                first = tuple(int(i) for i in np.argwhere(bad)[0])
                raise ValueError(
                    f"image.threshold: {int(bad.sum())} of the image's {labels.size} voxels hold "
                    f"no grey value (NaN), first at index {first}; fill or crop them away "
                    "(image.crop)"
                )
        return labels >= threshold
    if isinstance(solid, str):
        if solid != "nonzero":
            raise ValueError(
                f"image.solid_label: a label, a list of labels or 'nonzero', got {solid!r}"
            )
        _check_segmented(labels)
        return labels != 0
    values = (solid,) if isinstance(solid, int) else tuple(solid)
    mask = np.isin(labels, values)
    if not mask.any():
        present = np.unique(labels)[:10].tolist()
        raise ValueError(
            f"image.solid_label: no voxel has label {list(values)}; labels present: {present}"
        )
    return mask


def read_image(src: ImageSource) -> np.ndarray:
    """The solid mask (bool, ``[x, y, z]``, C order) of an image.

    C order whatever the file's axis order: a transposed (Fortran-ordered) mask reached the
    transport and distance kernels as a layout ``psdesign warmup`` does not compile, so the
    first transport command on a cropped TIFF compiled four kernels again (~3 s CPU) and
    ran them along strided lines (``benchmarks/RESULTS.md``, session 40).  A copy only when the
    mask is not C-ordered already (1 byte per voxel, after the labels are freed)."""
    return np.ascontiguousarray(solid_mask(read_labels(src), src.solid, src.threshold))


def box_size(shape, voxel: float) -> tuple[float, float, float]:
    """The box edges in metres of ``shape`` voxels of ``voxel`` metres, rounded as
    :func:`psdesign.geometry.rve.in_metres` (a count in a unit of one voxel): the spec,
    rve.json and the image grid print 12 voxels of 1.25 um as 1.5e-05 m, not the float
    product 1.5000000000000002e-05 (session 51). The edge stays a whole number of cubic
    voxels: the rounding moves it by at most 5e-15 of itself
    (:func:`psdesign.geometry.rve.is_cubic` allows 1e-9).

    >>> 12 * 1.25e-6, box_size((12, 8, 1), 1.25e-6)
    (1.5000000000000002e-05, (1.5e-05, 1e-05, 1.25e-06))
    """
    return tuple(in_metres(int(n), voxel) for n in shape)


def file_voxel_size(path: str | Path, fmt: str | None = None) -> float | None:
    """The voxel edge (metres) a file carries, or None.

    TIFF: the ImageJ ``unit`` with the X/Y resolution tags (pixels per unit) and the z
    ``spacing``; x, y and z must agree to 1e-6 (cubic voxels). A folder or pattern of TIFF
    slices: its first slice's (the slices agree, :mod:`psdesign.image.slices`); a 2-D slice
    stores no z spacing, and z is taken equal to x and y (the spec check says so). VTI: the
    ``spacing`` (taken as metres, as psdesign writes it). Raw and NumPy files carry none.
    """
    path = Path(path)
    ext = f".{fmt}" if fmt else path.suffix.lower()
    if is_slice_path(path):
        path, ext = slice_set(path).first, ".tif"
    if ext in (".tif", ".tiff"):
        import tifffile

        with tifffile_quiet(), tifffile.TiffFile(path) as tf:
            meta = tf.imagej_metadata or {}
            unit = unit_metres(str(meta.get("unit", "")))
            tags = tf.pages[0].tags
            xtag, ytag = tags.get("XResolution"), tags.get("YResolution")
            if unit is None or xtag is None:
                return None
            num, den = xtag.value
            if not num or not den:
                return None
            xy = in_metres(den / num, unit)
            # y from its own tag (read as x's until review2: 0.5 x 1 um pixels gave 0.5 um cubes)
            ynum, yden = ytag.value if ytag is not None else (num, den)
            y = in_metres(yden / ynum, unit) if ynum and yden else xy
            z = in_metres(float(meta.get("spacing", den / num)), unit)
        if not is_cubic((xy, y, z), rtol=1e-6):  # the .vti branch's rule below
            raise ValueError(
                f"image.voxel_size: the file's voxels are not cubic (x {xy:g} m, y {y:g} m, "
                f"z {z:g} m); resample to cubic voxels {CUBIC_ALLOWED}"
            )
        return float(xy)
    if ext == ".vti":
        h = np.asarray(vti_header(path)[1], float)
        if not is_cubic(h, rtol=1e-6):
            raise ValueError(
                f"image.voxel_size: the file's voxels are not cubic (spacing {h.tolist()}); "
                f"resample to cubic voxels {CUBIC_ALLOWED}"
            )
        return float(h[0])
    return None
