"""Ctrl-C during pytetwild (fTetWild) is psdesign's: fTetWild holds the GIL for the whole
call and replaces the SIGINT handler, so Ctrl-C used to kill psdesign with exit 130 and no
word (and a SIGTERM waited for the mesh). It now runs in a child process
(psdesign.meshing.tetwild_process) that psdesign kills on an interrupt: one line, exit
128 + 2, no child left, no output folder."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import psutil

SPEC = """
[rve]
size = [40e-6, 40e-6, 40e-6]
voxel = 1e-6
[generator]
n_fibers = 6
diameter = 8e-6
seed = 1
[flow]
mesher = "pytetwild"
edge_length = 0.04
"""


def _mesher_children(pid: int) -> list[psutil.Process]:
    try:
        kids = psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []
    out = []
    for k in kids:
        try:
            if "psdesign.meshing.tetwild_process" in " ".join(k.cmdline()):
                out.append(k)
        except psutil.Error:
            pass
    return out


def test_ctrl_c_during_pytetwild_stops_the_mesher_with_one_line(tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC)
    out = tmp_path / "o"
    proc = subprocess.Popen(
        [sys.executable, "-m", "psdesign", "mesh", str(spec), "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # as from a terminal
    )
    try:
        deadline = time.monotonic() + 90
        kids: list[psutil.Process] = []
        while not kids:
            assert proc.poll() is None, proc.stderr.read().decode()
            assert time.monotonic() < deadline, "pytetwild's child process did not appear"
            time.sleep(0.1)
            kids = _mesher_children(proc.pid)
        time.sleep(0.5)  # inside fTetWild
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    err = err.decode()
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "psdesign: interrupted", err
    psutil.wait_procs(kids, timeout=5)
    assert not any(k.is_running() and k.status() != psutil.STATUS_ZOMBIE for k in kids)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def _stub_child(seconds: float):
    """A child that sleeps ``seconds`` (fTetWild's silent run) and then writes a one-tet mesh."""

    def command(folder):
        code = (
            "import sys, time, numpy as np; time.sleep(float(sys.argv[2])); "
            "np.savez(sys.argv[1] + '/mesh.npz', points=np.eye(4, 3), tets=np.arange(4)[None])"
        )
        return [sys.executable, "-c", code, str(folder), str(seconds)]

    return command


def test_a_long_fTetWild_run_prints_elapsed_time(monkeypatch):
    """Session 52 walk-mesh finding 2: psdesign printed nothing between "meshing the pore space
    (pytetwild, z)" and the mesh's line while fTetWild ran (23 s on a 40 um RVE; 5-18 min on a
    100 um one, docs/meshers.md). Truth: a stub child sleeping 1.0 s with a line every 0.3 s
    gives at least three lines "fTetWild running, N s" (at 0.3, 0.6, 0.9 s: a lower bound, no
    timing asserted); with --quiet (a quiet printer) none."""
    import io

    import numpy as np

    from psdesign import progress
    from psdesign.meshing import tetwild_process as tp

    monkeypatch.setattr(tp, "child_command", _stub_child(1.0))
    monkeypatch.setattr(tp, "PROGRESS_EVERY_S", 0.3)
    verts, faces = np.eye(4, 3), np.array([[0, 1, 2]])
    for quiet, want in ((False, True), (True, False)):
        stream = io.StringIO()
        with progress.activate(quiet=quiet, stream=stream):
            pts, tets = tp.tetrahedralize_isolated(verts, faces, {})
        assert pts.shape == (4, 3) and tets.shape == (1, 4)
        lines = [x for x in stream.getvalue().splitlines() if "fTetWild running" in x]
        assert len(lines) >= 3 if want else not lines, stream.getvalue()
        assert all(x.startswith("psdesign: fTetWild running, ") for x in lines)
