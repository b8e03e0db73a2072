"""Write an RVE's solid mask as a TIFF stack (what CT tools and PoreSpy/TauFactor read).

The file is a uint8 ImageJ hyperstack: ``1`` = solid (fiber), ``0`` = pore; pages are z,
rows y, columns x (``axes = "ZYX"``, the stack order of CT tools); the voxel edge is stored in
micrometres as the X/Y resolution (pixels per micrometre) and as the ImageJ ``spacing`` (z)
with ``unit = um``, so :func:`psdesign.image.reader.file_voxel_size` (and ImageJ / Fiji)
read it back without a ``voxel_size`` key.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: Value of a solid voxel in the TIFF stacks psdesign writes.
SOLID_VALUE = 1


def write_tiff(
    solid: np.ndarray, path: str | Path, voxel: float, solid_value: int = SOLID_VALUE
) -> Path:
    """Write ``solid`` (bool, ``[x, y, z]``) as a uint8 TIFF stack.

    Parameters
    ----------
    solid : ndarray of bool, (nx, ny, nz)
    path : str or Path
    voxel : float
        Voxel edge in metres.
    solid_value : int
        Stored value of a solid voxel in [1, 255] (default 1); pore voxels are 0.

    Returns
    -------
    Path
    """
    import tifffile

    if not 1 <= int(solid_value) <= 255:
        raise ValueError(f"solid_value: must be in [1, 255], got {solid_value}")
    data = np.ascontiguousarray(np.asarray(solid, dtype=bool).transpose(2, 1, 0)).astype(np.uint8)
    data *= np.uint8(solid_value)
    um = voxel * 1e6
    path = Path(path)
    tifffile.imwrite(
        path,
        data,
        imagej=True,
        resolution=(1.0 / um, 1.0 / um),
        metadata={"spacing": um, "unit": "um", "axes": "ZYX", "min": 0, "max": int(solid_value)},
    )
    return path
