"""A validated ``[image]`` table -> solid mask -> :class:`ImageRVE` with its voxel fields.

The mask of the last images read is kept (keyed by file, modification time and read
options), so the spec validation (which reads the voxels to refuse an image without pore or
solid) and the build that follows read the file once.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from psdesign.geometry.rve import BAND_MARGIN_VOXELS, RVE, VoxelFields, VoxelGrid
from psdesign.image.fields import ImageFields, image_fields, resample
from psdesign.image.reader import THREE_D_ALLOWED, ImageSource, read_image
from psdesign.image.slices import is_slice_path, signature, slice_set

_CACHE: OrderedDict[tuple, np.ndarray] = OrderedDict()
_CACHE_SIZE = 2


def source_of(table: dict, voxel: float | None = None) -> ImageSource:
    """The :class:`ImageSource` of a validated ``[image]`` table (plain dict)."""
    label = table.get("solid_label")
    solid = "nonzero" if label is None else (tuple(label) if isinstance(label, list) else label)
    crop = table.get("crop")
    shape = table.get("shape")
    return ImageSource(
        path=Path(table["path"]),
        voxel=float(voxel if voxel is not None else table["voxel_size"]),
        solid=solid,
        crop=None if crop is None else tuple(tuple(int(v) for v in c) for c in crop),
        shape=None if shape is None else tuple(int(n) for n in shape),
        dtype=table.get("dtype", "uint8"),
        byte_order=table.get("byte_order", "little"),
        axis_order=table.get("axis_order"),
        threshold=table.get("threshold"),
        format=table.get("format"),
    )


def header_shape(src: ImageSource) -> tuple[int, int, int]:
    """Voxel counts (x, y, z) of the stored image before the crop, read from its header
    where the format has one (TIFF, NumPy, raw ``shape``, the VTI header); nothing is read."""
    from psdesign.image.reader import open_npy, raw_layout, tiff_shape, vti_header

    ext = src.ext
    order = src.axis_order or ("zyx" if ext in (".tif", ".tiff", ".raw") else "xyz")
    if is_slice_path(src.path):
        stored = slice_set(src.path).stored_shape
    elif ext in (".tif", ".tiff"):
        stored = tiff_shape(Path(src.path))
        stored = (1, *stored) if len(stored) == 2 else stored
    elif ext == ".npy":
        stored = tuple(open_npy(src.path).shape)
    elif ext == ".raw":
        raw_layout(src)  # shape x dtype = the file's size; the voxels are not read
        if sorted(order) != ["x", "y", "z"]:
            raise ValueError(f"image.axis_order: a permutation of 'xyz', got {order!r}")
        return tuple(int(n) for n in src.shape)
    else:  # vti: the header's extent (the data are read after the memory budget)
        return tuple(int(n) for n in vti_header(Path(src.path))[0])
    if len(stored) != 3:
        raise ValueError(
            f"image.path: expected a 3-D image, got shape {list(stored)} {THREE_D_ALLOWED}"
        )
    return tuple(int(stored[order.index(a)]) for a in "xyz")


def load_mask(src: ImageSource) -> np.ndarray:
    """The solid mask (bool, ``[x, y, z]``) of ``src`` (cached; do not modify it)."""
    path = Path(src.path)
    if is_slice_path(path):  # every slice's name, size and time: a slice replaced is seen
        stamp: tuple = signature(path)
    else:
        st = path.stat()
        stamp = (st.st_mtime_ns, st.st_size)
    key = (
        str(path.resolve()),
        stamp,
        src.solid,
        src.crop,
        src.shape,
        src.dtype,
        src.byte_order,
        src.axis_order,
        src.threshold,
        src.format,
    )
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    mask = read_image(src)
    mask.setflags(write=False)
    _CACHE[key] = mask
    while len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return mask


@dataclass
class ImageRVE(RVE):
    """An RVE whose geometry is a segmented image (no fibers).

    ``voxelize`` at the image's own voxel size returns the image's fields; any other voxel
    size resamples them (:func:`psdesign.image.fields.resample`), which is how the error bar's
    second resolution is made.
    """

    image: ImageFields | None = None
    source: dict = field(default_factory=dict)

    def voxelize(self, voxel: float, margin_voxels: int = BAND_MARGIN_VOXELS) -> VoxelFields:
        """The image's fields at ``voxel`` metres (resampled unless it is the image's own)."""
        h = float(self.image.grid.spacing[0])
        if np.isclose(voxel, h, rtol=1e-9, atol=0.0):  # metres: no absolute slack
            return self.image
        grid = VoxelGrid.from_voxel(self.size, voxel)
        return resample(self.image, grid.shape)

    def medial_axes_m(self, n: int = 64) -> list:
        """No fibers, no medial axes."""
        return []


def image_rve(table: dict) -> ImageRVE:
    """The :class:`ImageRVE` of a validated ``[image]`` table."""
    src = source_of(table)
    mask = load_mask(src)
    fields = image_fields(mask, src.voxel)
    size = fields.grid.size.copy()  # the grid's box (reader.box_size), one rounding
    return ImageRVE(size=size, fibers=[], image=fields, source=dict(table))


def image_report(rve: ImageRVE) -> dict:
    """The generation report of an image RVE (summary.json ``generation``)."""
    f = rve.image
    return {
        "source": "image",
        "path": rve.source.get("path"),
        "format": rve.source.get("format"),
        "voxel_size_m": float(f.grid.spacing[0]),
        "shape": list(f.grid.shape),
        "solid_voxels": int(np.count_nonzero(f.solid)),
        "distance": "Euclidean distance transform of the mask (no analytic surface)",
    }
