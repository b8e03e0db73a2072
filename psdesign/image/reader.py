"""Read a voxel image into a solid mask indexed ``[x, y, z]``.

Formats (by extension): ``.tif``/``.tiff`` stacks (tifffile; pages are z, rows y, columns x),
``.npy`` (NumPy, indexed as stored unless ``axis_order`` says otherwise), ``.raw`` (headerless;
``shape`` in x, y, z order, ``dtype``, ``byte_order``, C order with x fastest unless stated) and
``.vti`` (VTK image data, first point or cell array). Which values are solid is given by
``solid`` (a label or list of labels, or ``"nonzero"``); an optional ``crop`` keeps
``[[x0, x1], [y0, y1], [z0, z1]]`` voxels (half-open).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

FORMATS = (".tif", ".tiff", ".npy", ".raw", ".vti")


@dataclass(frozen=True)
class ImageSource:
    """Where and how to read an image.

    Attributes
    ----------
    path : Path
    voxel : float
        Voxel edge in metres (cubic voxels).
    solid : int, list of int, or "nonzero"
    crop : tuple of (lo, hi) per axis, or None
    shape, dtype, byte_order : raw images only (shape in x, y, z order; "little" | "big")
    axis_order : str
        Order of the axes as stored: ``"zyx"`` (TIFF and raw default: x varies fastest) or
        ``"xyz"`` (NumPy default).
    """

    path: Path
    voxel: float
    solid: int | tuple[int, ...] | str = "nonzero"
    crop: tuple[tuple[int, int], ...] | None = None
    shape: tuple[int, int, int] | None = None
    dtype: str = "uint8"
    byte_order: str = "little"
    axis_order: str | None = None


def _read_raw(src: ImageSource) -> np.ndarray:
    if src.shape is None:
        raise ValueError("image.shape: required for a .raw image ([nx, ny, nz])")
    dt = np.dtype(src.dtype).newbyteorder("<" if src.byte_order == "little" else ">")
    n = int(np.prod(src.shape))
    size = src.path.stat().st_size
    if size != n * dt.itemsize:
        raise ValueError(
            f"image.shape: {list(src.shape)} x {dt.itemsize} bytes = {n * dt.itemsize} bytes, "
            f"but {src.path.name} has {size} bytes"
        )
    data = np.fromfile(src.path, dtype=dt, count=n)
    order = src.axis_order or "zyx"
    nx, ny, nz = src.shape
    if order == "zyx":
        return data.reshape(nz, ny, nx).transpose(2, 1, 0)
    return data.reshape(nx, ny, nz)


def _read_vti(path: Path) -> np.ndarray:
    import pyvista as pv

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
    return data.reshape(dims, order="F")


def read_labels(src: ImageSource) -> np.ndarray:
    """The stored values as an array indexed ``[x, y, z]`` (after the crop)."""
    path = Path(src.path)
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise ValueError(f"image.path: unknown format {ext!r}; allowed: {', '.join(FORMATS)}")
    if not path.is_file():
        raise ValueError(f"image.path: file not found: {path}")
    if ext in (".tif", ".tiff"):
        import tifffile

        data = np.asarray(tifffile.imread(path))
        if data.ndim == 2:
            data = data[None]
        if data.ndim != 3:
            raise ValueError(f"image.path: expected a 3-D stack, got shape {data.shape}")
        data = data.transpose(2, 1, 0) if (src.axis_order or "zyx") == "zyx" else data
    elif ext == ".npy":
        data = np.load(path, allow_pickle=False)
        if data.ndim != 3:
            raise ValueError(f"image.path: expected a 3-D array, got shape {data.shape}")
        data = data.transpose(2, 1, 0) if src.axis_order == "zyx" else data
    elif ext == ".raw":
        data = _read_raw(src)
    else:
        data = _read_vti(path)
    if src.crop is not None:
        sl = []
        for ax, (lo, hi) in enumerate(src.crop):
            if not 0 <= lo < hi <= data.shape[ax]:
                raise ValueError(
                    f"image.crop[{ax}]: must satisfy 0 <= lo < hi <= {data.shape[ax]}, "
                    f"got [{lo}, {hi}]"
                )
            sl.append(slice(lo, hi))
        data = data[tuple(sl)]
    return data


def solid_mask(labels: np.ndarray, solid: int | tuple[int, ...] | str) -> np.ndarray:
    """Boolean mask of the solid voxels."""
    if isinstance(solid, str):
        if solid != "nonzero":
            raise ValueError(f"image.solid: a label, a list of labels or 'nonzero', got {solid!r}")
        return labels != 0
    values = (solid,) if isinstance(solid, int) else tuple(solid)
    mask = np.isin(labels, values)
    if not mask.any():
        present = np.unique(labels)[:10].tolist()
        raise ValueError(
            f"image.solid: no voxel has label {list(values)}; labels present: {present}"
        )
    return mask


def read_image(src: ImageSource) -> np.ndarray:
    """The solid mask (bool, ``[x, y, z]``) of an image."""
    return solid_mask(read_labels(src), src.solid)
