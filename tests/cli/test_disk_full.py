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


def test_save_vtk_raises_when_vtk_cannot_write_and_prints_nothing(tmp_path, capfd):
    # pyvista's save returned normally when the VTK writer failed (on a full disk it left the
    # truncated file) and VTK printed about twenty lines on stderr
    import pyvista as pv

    from psdesign.io.vtkfile import save_vtk

    target = tmp_path / "a.vti"
    target.mkdir()  # VTK cannot open it for writing
    with pytest.raises(OSError) as info:
        save_vtk(_image(), target)
    assert info.value.errno in (errno.EIO, errno.ENOSPC) and info.value.filename == str(target)
    assert target.is_dir()  # only a regular file of the writer's is removed
    err = capfd.readouterr().err
    assert err == "", err
    ok = save_vtk(_image(), tmp_path / "b.vti")  # a writable place: the ordinary file
    assert pv.read(ok).n_points == 27000


def test_save_vtk_names_enospc_when_the_file_system_is_full(tmp_path, monkeypatch):
    from psdesign.io import vtkfile

    full = os.statvfs_result((4096, 4096, 100, 0, 0, 10, 0, 0, 0, 255))  # no free block
    free = os.statvfs_result((4096, 4096, 100, 90, 90, 10, 0, 0, 0, 255))
    target = tmp_path / "a.vti"
    blocked = tmp_path / "blocked.vti"
    blocked.mkdir()

    class Truncating:
        """Writes a partial file, then VTK fails (as its writer does on a full disk)."""

        def save(self, path):
            Path(path).write_bytes(b"<VTKFile")
            _image().save(blocked)  # a real VTK writer failure

    # the disk is full while the partial file is there; removing it frees its blocks (the
    # first version asked after the removal and said EIO, seen on a 100 kB tmpfs)
    monkeypatch.setattr(vtkfile.os, "statvfs", lambda _p: full if target.exists() else free)
    with pytest.raises(OSError, match="No space left on device") as info:
        vtkfile.save_vtk(Truncating(), target)
    assert not target.exists()
    assert info.value.errno == errno.ENOSPC


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


@pytest.mark.skipif(
    not sys.platform.startswith("linux") or os.geteuid() != 0 or not shutil.which("mount"),
    reason="mounts a small tmpfs: Linux, root",
)
def test_generate_on_a_really_full_disk(tmp_path):
    # the old code: exit 1 but VTK's twenty lines of pipeline state before psdesign's line
    spec = tmp_path / "spec.toml"
    spec.write_text(RANDOM_SPEC)
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=20k", "tmpfs", str(disk)])
    if mounted.returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        p = subprocess.run(
            [
                sys.executable,
                "-m",
                "psdesign",
                "generate",
                str(spec),
                "-o",
                str(disk / "out"),
                "--quiet",
            ],
            capture_output=True,
            text=True,
        )
        assert p.returncode == 1
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and "No space left on device" in lines[0], p.stderr
        assert os.listdir(disk) == []
    finally:
        subprocess.run(["umount", str(disk)], check=True)
