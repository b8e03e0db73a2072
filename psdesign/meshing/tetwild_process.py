"""pytetwild (fTetWild) run in a child process, so that Ctrl-C and SIGTERM reach psdesign.

fTetWild holds the GIL for the whole call and replaces the SIGINT handler (geogram's handler,
or the default one with ``GEO_NO_SIGNAL_HANDLER``): in-process, a Ctrl-C during a mesh killed
psdesign with exit 130 and no word, and a SIGTERM waited for the mesh to finish (minutes). The
child is ``python -m psdesign.meshing.tetwild_process DIR`` (a plain subprocess: no
multiprocessing start method re-imports the user's ``__main__``, and a daemonic study worker may
start it), in a session of its own so the terminal's Ctrl-C reaches only psdesign, which kills
it; it dies with psdesign (``PR_SET_PDEATHSIG``). Surface and mesh pass through ``.npz`` files
in a temporary folder; nothing is pickled.
"""

from __future__ import annotations

import contextlib
import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from psdesign.meshing.errors import MeshFailedError


def run_in_process(verts: np.ndarray, faces: np.ndarray, kwargs: dict[str, Any]):
    """``pytetwild.tetrahedralize(verts, faces, **kwargs)`` in a scratch working directory
    (pytetwild writes ``__tracked_surface.stl`` into it); ``(points float64, tets int64)``."""
    import pytetwild

    with tempfile.TemporaryDirectory() as scratch, contextlib.chdir(scratch):
        pts, tets = pytetwild.tetrahedralize(
            np.array(verts, dtype=np.float64, order="C"),  # writeable copies: nanobind rejects
            np.array(faces, dtype=np.int32, order="C"),  # read-only buffers
            **kwargs,
        )
    return np.asarray(pts, dtype=np.float64), np.asarray(tets, dtype=np.int64)


def _write_job(folder: Path, verts, faces, kwargs: dict[str, Any]) -> None:
    arrays = {k: v for k, v in kwargs.items() if isinstance(v, np.ndarray)}
    scalars = {k: v for k, v in kwargs.items() if k not in arrays}
    np.savez(folder / "surface.npz", verts=verts, faces=faces, **arrays)
    (folder / "options.json").write_text(json.dumps(scalars))


#: Seconds between the "fTetWild running" lines while the child meshes: fTetWild reports
#: nothing until it ends, 5-18 min on a 100 um RVE (docs/meshers.md), and the command printed no
#: line in between (session 52 walk-mesh finding 2).
PROGRESS_EVERY_S = 15.0


def child_command(folder: Path) -> list[str]:
    """The child's command line: this module run on the job ``folder``."""
    return [sys.executable, "-m", "psdesign.meshing.tetwild_process", str(folder)]


def _wait_reporting(proc: subprocess.Popen) -> None:
    """Wait for ``proc``, with a progress stage line every :data:`PROGRESS_EVERY_S` (none
    without an active printer or with ``--quiet``: :func:`psdesign.progress.stage`)."""
    from psdesign import progress

    t0 = time.perf_counter()
    while True:
        try:
            proc.wait(timeout=PROGRESS_EVERY_S)
            return
        except subprocess.TimeoutExpired:
            progress.stage(f"fTetWild running, {time.perf_counter() - t0:.0f} s")


def tetrahedralize_isolated(verts: np.ndarray, faces: np.ndarray, kwargs: dict[str, Any]):
    """:func:`run_in_process` in a child process; an interrupt of psdesign kills the child and
    propagates. A child that ends without a mesh raises :class:`MeshFailedError` with the last
    line it wrote."""
    from psdesign.io.child_env import child_env

    with tempfile.TemporaryDirectory(prefix="psdesign-tetwild-") as tmp:
        folder = Path(tmp)
        _write_job(folder, verts, faces, kwargs)
        with open(folder / "child.log", "wb") as log:
            proc = subprocess.Popen(
                child_command(folder), stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                env=child_env(), start_new_session=True,
            )  # fmt: skip
            try:
                _wait_reporting(proc)
            except BaseException:  # Ctrl-C, SIGTERM: the mesh is not wanted any more
                proc.kill()
                proc.wait()
                raise
        out = folder / "mesh.npz"
        if proc.returncode != 0 or not out.is_file():
            lines = (folder / "child.log").read_text(errors="replace").strip().splitlines()
            why = lines[-1] if lines else f"exit status {proc.returncode}"
            if proc.returncode is not None and proc.returncode < 0:
                why = f"killed by {signal.Signals(-proc.returncode).name} (out of memory?)"
            raise MeshFailedError(f"pytetwild stopped without a mesh: {why}")
        with np.load(out, allow_pickle=False) as mesh:
            return mesh["points"], mesh["tets"]


def _die_with_parent() -> None:
    """Ask Linux to kill this process when its parent dies (no-op elsewhere)."""
    with contextlib.suppress(Exception):
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


def main(folder: Path) -> int:
    """The child: mesh ``folder``'s surface, write ``mesh.npz`` (via a temporary name)."""
    _die_with_parent()
    with np.load(folder / "surface.npz", allow_pickle=False) as job:
        arrays = {k: job[k] for k in job.files}
    kwargs = json.loads((folder / "options.json").read_text())
    verts, faces = arrays.pop("verts"), arrays.pop("faces")
    try:
        pts, tets = run_in_process(verts, faces, {**kwargs, **arrays})
    except Exception as exc:  # noqa: BLE001 - the parent reports the last line
        print(f"{type(exc).__name__}: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    tmp = folder / "mesh.part.npz"
    np.savez(tmp, points=pts, tets=tets)
    tmp.replace(folder / "mesh.npz")
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1])))
