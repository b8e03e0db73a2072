"""A CT scan exported as one 2-D TIFF per slice: a folder or a glob pattern -> the ordered,
checked slice files -> the (cropped) stack.

``[image] path`` names a folder (every ``*.tif`` / ``*.tiff`` in it; other files and hidden
``.name`` files are ignored) or a pattern in the file name (``slices/recon_*.tif``). The
slices are ordered by their number, the last run of digits in each name, or the one run
that differs between names otherwise alike (``recon_0007_8bit``: ``0007``) (``s2`` before
``s10``: ``sorted()`` puts ``s10`` first and would scramble the scan), and slice ``i`` is the
z index ``i`` (the stored order ``zyx``: slices, rows, columns). Every check reads headers
only (one ``TiffFile`` per slice, no pixel decoded: 0.6-1 ms a slice), before any work:

* no matching file; fewer than :data:`MIN_SLICES` slices;
* a name without a number, names of two patterns (two scans in one folder), a duplicate or a
  gap in the numbering (a lost slice would shift the geometry above it without a word);
* a colour / multi-channel or multi-page file; a slice of another shape or type;
* slices whose ImageJ calibration (unit, X / Y resolution) disagree.

Every problem is a :class:`ValueError` starting with the ``[image]`` key (``image.path: ...``),
as in :mod:`psdesign.image.reader`. A crop reads only its slices, and of each only its rows
and columns (memory-mapped where the slice is stored uncompressed; else one slice decoded at
a time), so the memory is the crop's.
"""

from __future__ import annotations

import hashlib
import os
import re
from collections import OrderedDict
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path

import numpy as np

from psdesign.schema.rve import MIN_VOXELS_PER_EDGE

#: Characters that make ``path`` a glob pattern.
GLOB_CHARS = "*?["
#: Extensions of slice files (any case).
SLICE_EXTS = (".tif", ".tiff")
#: Fewest slices read: an image needs as many voxels per axis as any grid
#: (:data:`psdesign.schema.rve.MIN_VOXELS_PER_EDGE`, the one rule).
MIN_SLICES = MIN_VOXELS_PER_EDGE
_NUMBER = re.compile(r"(\d+)(\D*)$")
_DIGITS = re.compile(r"(\d+)")
_CACHE: OrderedDict[tuple, SliceSet] = OrderedDict()
_CACHE_SIZE = 4


def is_slice_path(path: str | Path) -> bool:
    """True for a folder, or a name with a glob character that is no existing file."""
    path = Path(path)
    return path.is_dir() or (not path.exists() and any(c in path.name for c in GLOB_CHARS))


def is_slice_member(path: str | Path, file: str | Path) -> bool:
    """True when ``file`` would be read as a slice of the folder or pattern ``path``."""
    path, file = Path(path), Path(file)
    if not is_slice_path(path):
        return False
    folder, pattern = _folder_pattern(path)
    return (
        file.parent == folder
        and file.suffix.lower() in SLICE_EXTS
        and not file.name.startswith(".")
        and fnmatchcase(file.name, pattern)
    )


@dataclass(frozen=True)
class SliceSet:
    """The checked slices of a folder or pattern.

    Attributes
    ----------
    path : Path
        The folder or pattern as given.
    files : tuple of Path
        The slice files, slice ``i`` = z index ``i``.
    shape : tuple of int
        Rows (y) and columns (x) of every slice.
    dtype : str
        The element type of every slice.
    z_spacing : bool
        Whether the slices carry an ImageJ z ``spacing`` (2-D slices usually do not).
    """

    path: Path
    files: tuple[Path, ...]
    shape: tuple[int, int]
    dtype: str
    z_spacing: bool

    @property
    def stored_shape(self) -> tuple[int, int, int]:
        """Slices, rows, columns (the stored ``zyx`` order)."""
        return (len(self.files), *self.shape)

    @property
    def first(self) -> Path:
        """The first slice (its tags give the voxel size)."""
        return self.files[0]


def _folder_pattern(path: Path) -> tuple[Path, str]:
    """The folder the slices lie in and the pattern their names match."""
    return (path, "*") if path.is_dir() else (path.parent, path.name)


def _candidates(path: Path) -> list[os.DirEntry]:
    """The TIFF files of the folder, or of the pattern's folder matching its name."""
    folder, pattern = _folder_pattern(path)
    # a folder that exists is taken by its name, brackets and all (``run[1]/``, ``scan[2]/*.tif``)
    if not folder.is_dir() and any(c in str(folder) for c in GLOB_CHARS):
        raise ValueError(
            f"image.path: {path}: a pattern may only be in the file name (allowed: a folder, "
            "or folder/name_*.tif)"
        )
    if not folder.is_dir():
        raise ValueError(f"image.path: file not found: {path} (its folder {folder} does not exist)")
    with os.scandir(folder) as entries:
        found = [
            e
            for e in entries
            if not e.name.startswith(".")
            and os.path.splitext(e.name)[1].lower() in SLICE_EXTS
            and fnmatchcase(e.name, pattern)
            and e.is_file()
        ]
    if not found:
        what = f"in the folder {path}" if pattern == "*" else f"matches {path}"
        raise ValueError(
            f"image.path: no .tif / .tiff file {what} (allowed: an image file, or a folder or "
            "pattern of 2-D TIFF slices)"
        )
    return found


def _numbering_run(stems: list[str]) -> int | None:
    """Which run of digits numbers the slices, when it is not the last: names of one
    skeleton (digits aside) whose values differ in that run alone (``recon_0007_8bit``: the
    ``0007``; the last run, ``8``, is the same in every name). None: the last run."""
    skeletons = {_DIGITS.sub("#", stem) for stem in stems}
    if len(skeletons) != 1:
        return None
    values = np.array([[int(d) for d in _DIGITS.findall(stem)] for stem in stems])
    varying = [j for j in range(values.shape[1]) if len(set(values[:, j])) > 1]
    return varying[0] if len(varying) == 1 and varying[0] != values.shape[1] - 1 else None


def _ordered(entries: list[os.DirEntry]) -> list[Path]:
    """The slices in the order of their numbers, refused when the numbering is not one run
    ``n0, n0 + 1, ...`` of names of one pattern."""
    rows = []
    run = _numbering_run([os.path.splitext(e.name)[0] for e in entries])
    for e in entries:
        stem = os.path.splitext(e.name)[0]
        m = _NUMBER.search(stem) if run is None else list(_DIGITS.finditer(stem))[run]
        if m is None:
            raise ValueError(
                f"image.path: {e.name} has no slice number (allowed: numbered slices, e.g. "
                "recon_0000.tif, recon_0001.tif, ...; move other TIFF files out of the folder)"
            )
        rows.append((int(m.group(1)), stem[: m.start(1)] + "#" + stem[m.end(1) :], e.name))
    rows.sort()
    for _, template, name in rows:
        if template != rows[0][1]:
            raise ValueError(
                f"image.path: {rows[0][2]} and {name} are named by two patterns "
                f"({rows[0][1]!r}, {template!r}; # the number): two scans in one folder? "
                "(allowed: the slices of one scan; give a pattern such as recon_*.tif)"
            )
    for (n0, _, a), (n1, _, b) in zip(rows, rows[1:], strict=False):
        if n1 == n0:
            raise ValueError(
                f"image.path: {a} and {b} both have slice number {n0} (allowed: one file per "
                "slice number)"
            )
        if n1 != n0 + 1:
            gap = f"{n0 + 1}" if n1 == n0 + 2 else f"{n0 + 1} to {n1 - 1}"
            raise ValueError(
                f"image.path: slice number {gap} is missing (between {a} and {b}): a lost "
                "slice shifts the geometry above it (allowed: consecutive numbers; crop with "
                "image.crop instead of deleting slices)"
            )
    folder = Path(entries[0].path).parent
    return [folder / name for _, _, name in rows]


@dataclass(frozen=True)
class _Header:
    shape: tuple[int, ...]
    dtype: str
    pages: int
    pixel: tuple  # ImageJ unit, X and Y resolution (pixels per unit), z spacing


def _resolution(tags, name: str) -> float | None:
    tag = tags.get(name)
    if tag is None:
        return None
    num, den = tag.value
    return float(num) / float(den) if num and den else None


def _header(path: Path) -> _Header:
    """One slice's header (no pixel is decoded); a colour image, or one whose elements are
    not numbers (:func:`psdesign.image.reader.check_numeric`), is refused."""
    import tifffile

    from psdesign.image.reader import check_numeric, plain_tiff_shape, tifffile_quiet

    try:
        with tifffile_quiet(), tifffile.TiffFile(path) as tf:
            series = tf.series[0]
            axes, shape = str(series.axes), tuple(int(n) for n in series.shape)
            meta = tf.imagej_metadata or {}
            tags = tf.pages[0].tags
            pixel = (
                str(meta.get("unit", "")).strip(),
                _resolution(tags, "XResolution"),
                _resolution(tags, "YResolution"),
                meta.get("spacing"),
            )
            header = _Header(shape, str(series.dtype), len(tf.pages), pixel)
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        raise ValueError(f"image.path: cannot read {path.name} as TIFF: {exc}") from None
    shape = plain_tiff_shape(path.name, axes, shape, stack=False)
    check_numeric(np.dtype(header.dtype), path.name)  # complex slices were read (review s54)
    while header.pages == 1 and len(shape) > 2 and shape[0] == 1:  # a writer's (1, rows, cols)
        shape = shape[1:]
    return _Header(shape, header.dtype, header.pages, pixel)


def _same_pixel(a: tuple, b: tuple) -> bool:
    if a[0] != b[0] or (a[3] is None) != (b[3] is None):
        return False
    return all(
        (x is None and y is None)
        or (x is not None and y is not None and abs(x - y) <= 1e-6 * abs(x))
        for x, y in zip(a[1:], b[1:], strict=True)
    )


def _pixel_text(pixel: tuple) -> str:
    unit, x, y, z = pixel
    xy = " x ".join("?" if r is None else f"{1 / r:g}" for r in (x, y))
    return f"{xy} {unit or 'pixel'}" + ("" if z is None else f", z {z:g}")


def _checked(files: list[Path]) -> tuple[_Header, bool]:
    """Every slice one 2-D page of the first's shape, type and calibration."""
    first = _header(files[0])
    for f in files:
        h = first if f is files[0] else _header(f)
        if h.pages != 1 or len(h.shape) != 2:
            raise ValueError(
                f"image.path: {f.name} holds {h.pages} pages of shape {list(h.shape)}, not one "
                "2-D slice (allowed: one 2-D page per file; a multi-page stack is given as the "
                "path of that one file)"
            )
        if h.shape != first.shape or h.dtype != first.dtype:
            raise ValueError(
                f"image.path: {f.name} is {list(h.shape)} (rows, columns) {h.dtype}, "
                f"{files[0].name} is {list(first.shape)} {first.dtype} (allowed: slices of one "
                "shape and type)"
            )
        if not _same_pixel(h.pixel, first.pixel):
            raise ValueError(
                f"image.path: {f.name} has pixels of {_pixel_text(h.pixel)}, {files[0].name} of "
                f"{_pixel_text(first.pixel)} (allowed: slices of one scan, one calibration)"
            )
    return first, first.pixel[3] is not None


def _listing(entries: list[os.DirEntry]) -> tuple:
    return tuple(sorted((e.name, e.stat().st_size, e.stat().st_mtime_ns) for e in entries))


def signature(path: str | Path) -> tuple:
    """The folder or pattern's TIFF files as names, sizes and modification times (a stat per
    file, nothing opened): the key under which a slice set and its mask are cached."""
    return _listing(_candidates(Path(path)))


def slice_set(path: str | Path) -> SliceSet:
    """The checked slices of a folder or pattern (cached per file listing)."""
    path = Path(path)
    entries = _candidates(path)
    key = (str(path), _listing(entries))
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    files = _ordered(entries)
    first, z_spacing = _checked(files)  # first: one stack given as a folder is named so
    if len(files) < MIN_SLICES:
        raise ValueError(
            f"image.path: {len(files)} slices (allowed: at least {MIN_SLICES}: "
            f"{MIN_SLICES} voxels per axis)"
        )
    out = SliceSet(path, tuple(files), first.shape, first.dtype, z_spacing)
    _CACHE[key] = out
    while len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return out


def _slice_array(path: Path) -> np.ndarray:
    """One slice: memory-mapped when stored uncompressed (only the rows taken are read), else
    decoded."""
    import tifffile

    from psdesign.image.reader import tifffile_quiet

    try:
        with tifffile_quiet():
            try:
                return tifffile.memmap(path, mode="r")
            except ValueError:  # compressed or tiled: not memory-mappable
                with tifffile.TiffFile(path) as tf:
                    return tf.pages[0].asarray()
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        raise ValueError(f"image.path: cannot read {path.name} as TIFF: {exc}") from None


def read_slices(sset: SliceSet, crop: tuple | None = None) -> np.ndarray:
    """The stored values ``[slice, row, column]`` of the crop (``(lo, hi)`` per stored axis,
    checked by the caller), one slice at a time: the memory is the crop's."""
    crop = crop or tuple((0, n) for n in sset.stored_shape)
    (z0, z1), (r0, r1), (c0, c1) = crop
    out = np.empty((z1 - z0, r1 - r0, c1 - c0), dtype=np.dtype(sset.dtype))
    for k, f in enumerate(sset.files[z0:z1]):
        page = _slice_array(f).reshape(sset.shape)
        out[k] = page[r0:r1, c0:c1]
        del page  # a memory map closes its file
    return out


def slices_digest(path: str | Path) -> str:
    """``"sha256:<hex>"`` of the slices' bytes in slice order (not their names or folder)."""
    outer = hashlib.sha256()
    for f in slice_set(path).files:
        with open(f, "rb") as fh:
            outer.update(hashlib.file_digest(fh, "sha256").digest())
    return "sha256:" + outer.hexdigest()
