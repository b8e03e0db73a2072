"""On-disk cache of pore meshes keyed by a hash of the field and the options (npz + JSON)."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from psdesign.io.atomic import json_default
from psdesign.meshing.result import PoreMesh

CACHE_VERSION = 3  # 3: pytetwild's fiber-diameter envelope (session 9)


def cache_key(distance: np.ndarray, params: dict) -> str:
    """Hex digest of the field bytes, its shape and the (JSON-serializable) parameters."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(distance).tobytes())
    h.update(str(distance.shape).encode())
    h.update(json.dumps(params, sort_keys=True, default=str).encode())
    return h.hexdigest()[:32]


def lookup(cache_dir, distance: np.ndarray, params: dict):
    """(cache file or None, cached PoreMesh or None) for these inputs."""
    if cache_dir is None:
        return None, None
    params = {**params, "v": CACHE_VERSION}
    path = Path(cache_dir) / f"poremesh_{cache_key(distance, params)}.npz"
    return path, (load(path) if path.exists() else None)


def save(path: Path | None, pm: PoreMesh) -> None:
    """Store ``pm`` at ``path`` atomically (no-op for None)."""
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {f"tag_{k}": v for k, v in pm.facet_tags.items()}
    arrays.update({f"pair_{k}": v for k, v in pm.periodic_pairs.items()})
    meta = json.dumps(
        {"direction": pm.direction, "porous_region": list(pm.porous_region), "quality": pm.quality},
        default=json_default,
    )
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(
        tmp, points=pm.points, tets=pm.tets, bounds=pm.bounds, meta=np.array(meta), **arrays
    )
    tmp.replace(path)


def load(path: Path) -> PoreMesh:
    """Read a cached mesh (npz without pickles)."""
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(str(z["meta"]))
        pm = PoreMesh(
            points=z["points"],
            tets=z["tets"],
            facet_tags={k[4:]: z[k] for k in z.files if k.startswith("tag_")},
            direction=meta["direction"],
            porous_region=tuple(meta["porous_region"]),
            bounds=z["bounds"],
            quality=meta["quality"],
            periodic_pairs={k[5:]: z[k] for k in z.files if k.startswith("pair_")},
        )
    pm.quality["from_cache"] = True
    return pm
