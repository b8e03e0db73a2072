"""Schema of the ``[image]`` table: a segmented voxel image (micro-CT) as the RVE.

A spec with ``[image]`` holds no fiber tables (``[[fibers]]``, ``[generator]``,
``[intersections]``, ``[forcefield]`` are refused): the image is the geometry. ``[rve]`` may
be left out (the box is the image's extent, the voxel its voxel size); if given it must agree.
The table checks everything it can before any work: the file exists and has a known format,
a raw file's size matches ``shape`` x ``dtype``, the crop lies inside the image, the voxel
size is known. :mod:`psdesign.schema.document` reads the voxels (after the memory budget)
and refuses an image without pore or without solid voxels.

``path`` is relative to the spec file's folder (the validation context ``base``; the current
folder for a spec given as a dict). It may name a folder or pattern of 2-D TIFF slices, checked
from their headers (:mod:`psdesign.image.slices`).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, ValidationInfo, model_validator

from psdesign.schema.rve import MIN_VOXELS_PER_EDGE, MIN_VOXELS_TEXT
from psdesign.schema.types import Table, fail, integer, number

Label = integer(ge=-(2**63), le=2**64 - 1)
Index = integer(ge=0, le=10**6)
Count = integer(ge=1, le=10**6)
AXIS_ORDERS = ("xyz", "xzy", "yxz", "yzx", "zxy", "zyx")
DTYPES = ("uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64")
RAW_ONLY = ("shape", "dtype", "byte_order")


#: A voxel size read from a VTI file above this (m) is warned about: its spacing carries no
#: unit and is read as metres (a TIFF's ImageJ unit is explicit), and CT software writes
#: millimetres (3D Slicer) or micrometres; a fibre scan's voxels are 0.1-20 um. Spacing 1e-3
#: (mm) for 1 um voxels gave K 1e6 times too large, 1.4333e-05 m^2 [ok], without a word
#: (session 43).
COARSE_FILE_VOXEL_M = 1e-4


def coarse_file_voxel_note(name: str, voxel: float) -> str:
    """The warning for a file's voxel size above :data:`COARSE_FILE_VOXEL_M`."""
    return (
        f"image.voxel_size: {name} gives voxels of {voxel:g} m (taken as metres; a VTI's "
        f"spacing has no unit), over {COARSE_FILE_VOXEL_M:g} m: if the file's spacing is in mm "
        "or um, give image.voxel_size in metres"
    )


#: What ``image.path`` may name (docs/images.md).
IMAGE_PATHS = "an existing image file, or a folder or pattern (slices/*.tif) of 2-D TIFF slices"


class ImageWarning(UserWarning):
    """An image spec that is valid but probably not what was meant (one line)."""


class ImageTable(Table):
    """A segmented voxel image: file, voxel size, which values are solid, crop, axis order."""

    path: str = Field(
        description="image file, or a folder or pattern (slices/*.tif) of 2-D TIFF slices, "
        "relative to the spec file's folder (required)"
    )
    format: Literal["tif", "tiff", "raw", "npy", "vti"] | None = Field(
        None,
        description="tif | tiff | raw | npy | vti (default: from the file's extension; tif for "
        "a folder or pattern of slices)",
    )
    voxel_size: number(ge=1e-9, le=1e-2) | None = Field(
        None,
        description="voxel edge in [1e-9, 1e-2] m (cubic voxels); required unless the file "
        "carries it (TIFF ImageJ unit + resolution; of TIFF slices the first slice's x/y, z "
        "taken equal to them with a warning; VTI spacing in metres)",
    )
    solid_label: Label | list[Label] | None = Field(
        None,
        description="label or list of labels of the solid (default: every nonzero voxel is "
        "solid); not with threshold",
    )
    threshold: number() | None = Field(
        None,
        description="solid where the value is >= threshold (grey images); not with solid_label",
    )
    crop: (
        Annotated[
            tuple[tuple[Index, Index], tuple[Index, Index], tuple[Index, Index]],
            Field(description="[[x0, x1], [y0, y1], [z0, z1]]"),
        ]
        | None
    ) = Field(
        None,
        description="[[x0, x1], [y0, y1], [z0, z1]] voxel index ranges (half-open, "
        "0 <= lo < hi <= the image's extent, x y z after axis_order)",
    )
    axis_order: Literal["xyz", "xzy", "yxz", "yzx", "zxy", "zyx"] | None = Field(
        None,
        description="stored axes, slowest index first: a permutation of xyz (default zyx for "
        "tif and raw, xyz for npy and vti)",
    )
    shape: tuple[Count, Count, Count] | None = Field(
        None, description="raw only (required): [nx, ny, nz] voxels, each in [1, 1e6]"
    )
    dtype: Literal["uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64"] = (
        Field("uint8", description=f"raw only: {' | '.join(DTYPES)} (default uint8)")
    )
    byte_order: Literal["little", "big"] = Field(
        "little", description="raw only: little | big (default little)"
    )

    # ------------------------------------------------------------------ derived values
    @property
    def resolved_path(self) -> Path:
        """The image file (absolute)."""
        return self._resolved

    @property
    def voxel(self) -> float:
        """Voxel edge in metres (given, or read from the file)."""
        return self._voxel

    @property
    def shape_xyz(self) -> tuple[int, int, int]:
        """Voxel counts (x, y, z) after the crop."""
        return self._shape

    @property
    def size(self) -> tuple[float, float, float]:
        """Box edges in metres (:func:`psdesign.image.reader.box_size`)."""
        from psdesign.image.reader import box_size

        return box_size(self._shape, self._voxel)

    @model_validator(mode="after")
    def _check_file(self, info: ValidationInfo) -> ImageTable:
        from psdesign.image.load import header_shape, source_of
        from psdesign.image.reader import file_voxel_size
        from psdesign.image.slices import is_slice_path, slice_set

        base = Path((info.context or {}).get("base") or Path.cwd())
        path = Path(self.path).expanduser()
        path = (path if path.is_absolute() else base / path).resolve()
        # the file first: a missing file is the path's fault, not the format's
        slices = is_slice_path(path)
        if not slices and not path.is_file():
            raise fail("path", f"file not found: {path}", IMAGE_PATHS)
        fmt = self.format or ("tif" if slices else path.suffix.lower().lstrip("."))
        if fmt not in ("tif", "tiff", "raw", "npy", "vti"):
            raise fail(
                "format", f"cannot tell the format of {path.name!r}", "tif | tiff | raw | npy | vti"
            )
        if slices and fmt not in ("tif", "tiff"):
            raise fail("format", f"{fmt}: a folder or pattern is read as TIFF slices", "tif")
        if fmt != "raw":
            for key in RAW_ONLY:
                if key in self.model_fields_set:
                    raise fail(key, f"only for raw images (this is {fmt})", "leave it out")
        elif self.shape is None:
            raise fail("shape", "required for a raw image", "[nx, ny, nz]")
        if self.solid_label is not None and self.threshold is not None:
            raise fail("threshold", "give solid_label or threshold, not both", "one of them")
        self._resolved, self._format = path, fmt
        src = source_of(self.to_spec(), voxel=1.0)
        try:
            stored = header_shape(src)
            shape = _cropped(stored, self.crop)
            in_file = file_voxel_size(path, fmt)
            voxel = self.voxel_size if self.voxel_size is not None else in_file
        except ValueError as exc:
            key, _, msg = str(exc).partition(": ")
            raise fail(key.removeprefix("image."), msg) from None
        if voxel is None:
            from psdesign.image.reader import unknown_unit_note

            name = (
                f"{path.name} (first slice {slice_set(path).first.name})" if slices else path.name
            )
            raise fail(
                "voxel_size",
                f"required: {name} carries no voxel size{unknown_unit_note(path, fmt)}",
                "voxel edge in [1e-9, 1e-2] m",
            )
        if not 1e-9 <= voxel <= 1e-2:
            raise fail(
                "voxel_size",
                f"the file's voxel size {voxel:g} is not a length in metres in [1e-9, 1e-2]",
                "give voxel_size in metres",
            )
        if min(shape) < MIN_VOXELS_PER_EDGE:
            if self.crop is not None:
                raise fail("crop", f"the image is {list(shape)} voxels", MIN_VOXELS_TEXT)
            flat = " (a 2-D image: give the 3-D stack)" if min(stored) == 1 else ""
            raise fail("path", f"{path.name} is {list(stored)} voxels{flat}", MIN_VOXELS_TEXT)
        if in_file is not None and abs(voxel - in_file) > 1e-3 * in_file:
            warnings.warn(
                f"image.voxel_size: {voxel:g} m is used; {path.name} says {in_file:g} m",
                ImageWarning,
                stacklevel=2,
            )
        elif self.voxel_size is None and fmt == "vti" and voxel > COARSE_FILE_VOXEL_M:
            warnings.warn(coarse_file_voxel_note(path.name, voxel), ImageWarning, stacklevel=2)
        elif self.voxel_size is None and slices and not slice_set(path).z_spacing:
            warnings.warn(
                f"image.voxel_size: {voxel:g} m from {slice_set(path).first.name}'s x/y "
                "calibration; a slice file stores no z spacing, so z is taken equal to x and y "
                "(cubic voxels, as CT reconstructions are); give image.voxel_size to say so",
                ImageWarning,
                stacklevel=2,
            )
        self._voxel = float(voxel)
        self._shape = shape
        return self

    def to_spec(self) -> dict:
        """The table as the pipeline reads it: absolute ``path``, ``format`` and (once
        validated) ``voxel_size`` filled in."""
        out = {k: getattr(self, k) for k in self.model_fields_set}
        resolved = getattr(self, "_resolved", None)
        if resolved is not None:
            out["path"] = str(resolved)
            out["format"] = self._format
        if getattr(self, "_voxel", None) is not None:
            out["voxel_size"] = self._voxel
        if out.get("format") == "raw":
            out.setdefault("dtype", self.dtype)
            out.setdefault("byte_order", self.byte_order)
        for key in ("crop", "shape"):
            if out.get(key) is not None:
                out[key] = [list(v) if isinstance(v, tuple) else v for v in out[key]]
        return out


def _cropped(stored: tuple[int, ...], crop) -> tuple[int, int, int]:
    if crop is None:
        return tuple(int(n) for n in stored)
    out = []
    for ax, (lo, hi) in enumerate(crop):
        if not 0 <= lo < hi <= stored[ax]:
            raise ValueError(
                f"image.crop[{ax}]: must satisfy 0 <= lo < hi <= {stored[ax]} (the image is "
                f"{list(stored)} voxels), got [{lo}, {hi}]"
            )
        out.append(hi - lo)
    return tuple(out)
