"""Write an RVE's solid mask as a TIFF stack (what CT tools and PoreSpy/TauFactor read)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_tiff(solid: np.ndarray, path: str | Path, voxel: float) -> Path:
    """Write ``solid`` (``[x, y, z]``) as a uint8 TIFF stack: 255 = solid, 0 = pore; pages
    are z, rows y, columns x; the voxel size is stored as the resolution (pixels per cm) and
    in the ImageJ metadata (``spacing``, ``unit = um``)."""
    import tifffile

    data = np.ascontiguousarray(np.asarray(solid, dtype=bool).transpose(2, 1, 0)).astype(np.uint8)
    data *= 255
    um = voxel * 1e6
    path = Path(path)
    tifffile.imwrite(
        path,
        data,
        imagej=True,
        resolution=(1.0 / um, 1.0 / um),
        metadata={"spacing": um, "unit": "um", "axes": "ZYX"},
    )
    return path
