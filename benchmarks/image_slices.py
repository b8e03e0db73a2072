"""A CT scan as one 2-D TIFF per slice (docs/images.md "TIFF slices"): how long the header
checks of a big folder take, and how much memory a crop's read takes against the folder's.

Writes ``N`` slices of ``S x S`` uint8 voxels (random labels 0/1, uncompressed or zlib) into a
temporary folder, then measures in this process:

* ``check``: :func:`psdesign.image.slices.slice_set` cold (every slice's header opened, no
  pixel decoded), and the whole spec validation of a cropped ``[image]`` spec (the checks,
  the budget, the crop's mask read);
* ``read``: :func:`psdesign.image.reader.read_labels` of a crop, its peak of traced NumPy
  memory (``tracemalloc``) against the crop's and the folder's bytes.

    PYTHONPATH=$PWD python benchmarks/image_slices.py [N S]      # default 2000 512

Prints one JSON line per compression (results in benchmarks/RESULTS.md).
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path


def write(folder: Path, n: int, size: int, compression: str | None) -> None:
    import numpy as np
    import tifffile

    rng = np.random.default_rng(0)
    folder.mkdir()
    meta = {"unit": "um"}
    for k in range(n):
        page = (rng.random((size, size)) < 0.3).astype(np.uint8)
        tifffile.imwrite(
            folder / f"recon_{k:04d}.tif",
            page,
            imagej=True,
            resolution=(1.0, 1.0),
            metadata=meta,
            compression=compression,
        )


def measure(folder: Path, n: int, size: int, compression: str | None) -> dict:
    from psdesign.image import slices
    from psdesign.image.reader import ImageSource, read_labels
    from psdesign.schema.spec import validate_spec

    slices._CACHE.clear()
    t0 = time.perf_counter()
    sset = slices.slice_set(folder)
    check = time.perf_counter() - t0
    half = size // 4
    crop = [[half, 3 * half], [half, 3 * half], [n // 2, n // 2 + 2 * half]]
    slices._CACHE.clear()
    t0 = time.perf_counter()
    validate_spec(
        {"image": {"path": str(folder), "voxel_size": 1e-6, "crop": crop, "solid_label": 1}}
    )
    validate = time.perf_counter() - t0
    tracemalloc.start()
    t0 = time.perf_counter()
    labels = read_labels(ImageSource(folder, 1e-6, solid=1, crop=tuple(map(tuple, crop))))
    read = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return {
        "slices": len(sset.files),
        "slice": list(sset.shape),
        "compression": compression or "none",
        "folder_MB": round(n * size * size / 1e6, 1),
        "crop": list(labels.shape),
        "crop_MB": round(labels.nbytes / 1e6, 2),
        "check_s": round(check, 3),
        "validate_s": round(validate, 3),
        "read_s": round(read, 3),
        "read_peak_MB": round(peak / 1e6, 2),
    }


def main(n: int = 2000, size: int = 512) -> None:
    for compression in (None, "zlib"):
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp) / "recon"
            write(folder, n, size, compression)
            print(json.dumps(measure(folder, n, size, compression)), flush=True)


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
