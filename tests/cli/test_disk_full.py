"""A full disk while writing outputs (audit s35, benchmarks/audit_failures.py): the command
stops with one line and a non-zero exit, and no partial file appears under an output's name.

VTK's writers fail silently through pyvista (``DataObject.save`` returns normally, VTK prints
its pipeline state on stderr).  Without root a VTK write failure is made by a folder in the
way of the file; as root a real full disk is a small tmpfs.
"""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from psdesign.cli import main
from psdesign.io import outputs

SPEC = """
[rve]
size = [40e-6, 40e-6, 40e-6]
voxel = 2e-6

[[fibers]]
shape = "rod"
diameter = 10e-6
center = [20e-6, 20e-6, 20e-6]
"""
#: Five random fibers: field.vti (about 25 kB) does not compress to a few blocks, so a 20 kB
#: disk fills while VTK writes it (rve.json, 9 kB, is written first).
RANDOM_SPEC = """
[rve]
size = [20e-6, 20e-6, 20e-6]
voxel = 1e-6

[generator]
kind = "straight"
porosity = 0.85
diameter = 4e-6
seed = 1
porosity_tolerance = 0.05

[intersections]
method = "fast"
min_gap = 0.5e-6
"""


def _image():
    import pyvista as pv

    img = pv.ImageData(dimensions=(30, 30, 30))
    img.point_data["a"] = np.arange(27000, dtype=float)
    return img


def test_save_vtk_raises_when_the_file_cannot_be_written_and_prints_nothing(tmp_path, capfd):
    # pyvista's save returned normally when the VTK writer failed (on a full disk it left the
    # truncated file) and VTK printed about twenty lines on stderr
    import pyvista as pv

    from psdesign.io.vtkfile import save_vtk

    target = tmp_path / "a.vti"
    target.mkdir()  # cannot be opened for writing
    with pytest.raises(OSError) as info:
        save_vtk(_image(), target)
    assert info.value.filename == str(target)
    assert target.is_dir()  # only a regular file of the writer's is removed
    err = capfd.readouterr().err
    assert err == "", err
    ok = save_vtk(_image(), tmp_path / "b.vti")  # a writable place: the ordinary file
    assert pv.read(ok).n_points == 27000


def test_save_vtk_streaming_on_a_disk_that_filled_says_enospc(tmp_path, monkeypatch):
    # session 37 review: where the disk had room, VTK streams the file itself, and its failure
    # was always EIO; a disk another process filled meanwhile must read as full (ENOSPC), as
    # session 35's save_vtk said and as the study runner needs to stop rather than record a
    # failed case (diskfull.is_disk_full). Truth: the file system reports no free block.
    from psdesign.io import diskfull, vtkfile

    monkeypatch.setattr(vtkfile, "_free_bytes", lambda folder: 1 << 40)  # room: streamed
    target = tmp_path / "a.vti"
    target.mkdir()  # VTK cannot open it: its writer reports an error
    full = os.statvfs_result((4096, 4096, 100, 0, 0, 10, 0, 0, 0, 255))  # no free block
    monkeypatch.setattr(diskfull.os, "statvfs", lambda _p: full)
    with pytest.raises(OSError, match="No space left on device") as info:
        vtkfile.save_vtk(_image(), target)
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(target)
    assert diskfull.is_disk_full(info.value) and target.is_dir()


class _FullDisk:
    """A file opened on a disk with ``room`` bytes left: the rest of a write fails ENOSPC."""

    def __init__(self, path, room: int) -> None:
        self._fh = open(path, "wb")  # noqa: SIM115 - closed by __exit__
        self._room = room

    def write(self, data: bytes) -> int:
        self._fh.write(data[: self._room])
        self._fh.flush()
        if len(data) > self._room:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return len(data)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self._fh.close()


@pytest.mark.parametrize("suffix", [".vti", ".vtu"])
def test_save_vtk_writes_with_python_so_a_full_disk_raises(tmp_path, monkeypatch, suffix):
    # audit s36: VTK's XML writer on a full disk crashed the process (`psdesign mesh` on an
    # 8 kB tmpfs: segmentation fault / "free(): invalid pointer", no message, the staging
    # folder left). VTK now writes into memory and Python writes the file: ENOSPC raises.
    # The old save_vtk let VTK write the file itself: this simulated full disk went unseen.
    import pyvista as pv

    from psdesign.io import vtkfile

    data = _image() if suffix == ".vti" else _image().cast_to_unstructured_grid()
    reference = tmp_path / f"ref{suffix}"
    data.save(reference)  # pyvista's own file: save_vtk's is byte-equal, streamed or not
    assert vtkfile.save_vtk(data, tmp_path / f"same{suffix}").read_bytes() == (
        reference.read_bytes()
    )
    monkeypatch.setattr(vtkfile, "_free_bytes", lambda folder: 1000)  # a nearly full disk
    assert vtkfile.save_vtk(data, tmp_path / f"mem{suffix}").read_bytes() == (
        reference.read_bytes()
    )
    target = tmp_path / f"a{suffix}"
    monkeypatch.setattr(vtkfile, "open", lambda p, mode="r": _FullDisk(p, room=1000), raising=False)
    with pytest.raises(OSError, match="No space left on device") as info:
        vtkfile.save_vtk(data, target)
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(target)
    assert not target.exists()  # the partial file removed
    assert pv.read(reference).n_points == 27000


def test_generate_stops_with_one_line_when_field_vti_cannot_be_written(
    tmp_path, monkeypatch, capfd
):
    # the old generate went on after the VTK writer's failure and finished with exit 0,
    # moving what was at field.vti (a truncated file on a full disk) into the output
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    out = tmp_path / "out"
    real_mkdtemp = tempfile.mkdtemp

    def staging_with_field_vti_blocked(*args, **kwargs):
        folder = real_mkdtemp(*args, **kwargs)
        (Path(folder) / "field.vti").mkdir()
        return folder

    monkeypatch.setattr(outputs.tempfile, "mkdtemp", staging_with_field_vti_blocked)
    assert main(["generate", str(spec), "-o", str(out), "--no-preview", "--quiet"]) == 1
    lines = capfd.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "field.vti" in lines[0], lines
    assert not out.exists()  # nothing under the output's name
    assert [p.name for p in tmp_path.iterdir()] == ["spec.toml"]  # staging folder removed


_ROOT_MOUNT = pytest.mark.skipif(
    not sys.platform.startswith("linux") or os.geteuid() != 0 or not shutil.which("mount"),
    reason="mounts a small tmpfs: Linux, root",
)


def _on_a_full_disk(tmp_path: Path, size: str, argv: list[str]) -> None:
    """Run ``psdesign ARGV -o DISK/out --quiet`` with ``DISK`` a tmpfs of ``size``: exit 1,
    one line naming the full disk, nothing left on the disk."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(disk)])
    if mounted.returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        p = subprocess.run(
            [sys.executable, "-m", "psdesign", *argv, "-o", str(disk / "out"), "--quiet"],
            capture_output=True,
            text=True,
        )
        assert p.returncode == 1, p.stderr
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and "No space left on device" in lines[0], p.stderr
        assert os.listdir(disk) == []
    finally:
        subprocess.run(["umount", str(disk)], check=True)


@_ROOT_MOUNT
def test_generate_on_a_really_full_disk(tmp_path):
    # the old code: exit 1 but VTK's twenty lines of pipeline state before psdesign's line
    spec = tmp_path / "spec.toml"
    spec.write_text(RANDOM_SPEC)
    _on_a_full_disk(tmp_path, "20k", ["generate", str(spec)])


@_ROOT_MOUNT
def test_mesh_vtu_on_a_really_full_disk(tmp_path):
    # audit s36: the old code crashed in VTK's XML writer (exit -11 / -6, no line) and left its
    # staging folder on the disk
    spec = tmp_path / "spec.toml"
    spec.write_text(RANDOM_SPEC)
    _on_a_full_disk(tmp_path, "8k", ["mesh", str(spec), "--format", "vtu"])


def test_a_new_file_the_full_disk_stopped_is_named_and_not_left(tmp_path):
    # failure audit s36: `pores --plot FILE` on an 8 / 40 kB tmpfs said only "psdesign: error:
    # No space left on device" (matplotlib's PNG write raises with no file name)
    from psdesign.io.newfile import write_new_file

    target = tmp_path / "p.png"

    def full_disk(tmp: Path) -> None:
        tmp.write_bytes(b"\x89PNG partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(OSError, match="No space left on device") as info:
        write_new_file(target, "--plot", full_disk)
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(target)
    assert list(tmp_path.iterdir()) == []  # neither the file nor its temporary
