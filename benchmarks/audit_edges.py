"""Audit at the edges of the design space (session 37): do the numbers and their status stay
honest where users push the spec keys to the ends of their ranges?

Each case is one small spec at (or one step inside) the end of an allowed range, run through the
CLI as a user would (``python -m psdesign COMMAND SPEC ... --json``).  Checked per case:

* a refusal: exit 2, one stderr line naming the expected key, no traceback, no output folder;
* a run: exit 0 (3 when its status is not ok: psdesign/cli/exit_status.py, session 45), no
  traceback, a finite error bar > 0, and the status against independent truth:
  a closed form where the edge reduces to one (square cylinder arrays, Sangani & Acrivos 1982
  across, Drummond & Tahir 1984 along: ``tests/reference_values.py``), else the same design at
  a 2x (and 4x where cheap) finer voxel, an image upsampled 2x by voxel repetition (the same
  staircase geometry, solved finer).  ``covered`` = ``|K / K_ref - 1| <= bar``; a case
  reported ``ok`` and not covered is a defect.

    PYTHONPATH=. python benchmarks/audit_edges.py [--cases NAME ...] [--out /tmp/audit_edges]

Prints one row per case (spec summary, command, exit, status, K, bar, reference K, its true
error, covered, seconds) and writes them to ``OUT/audit_edges.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from reference_values import (  # noqa: E402
    SANGANI_ACRIVOS_SQUARE_TRANSVERSE,
    drummond_tahir_square_parallel,
)

ROOT = Path(__file__).resolve().parents[1]


def _cyl(
    d: float, box: tuple[float, float, float], voxel: float, direction: str = "0, 0, 1"
) -> str:
    bx, by, bz = box
    return (
        f"[rve]\nsize = [{bx!r}, {by!r}, {bz!r}]\nvoxel = {voxel!r}\n\n"
        f'[[fibers]]\nshape = "cylinder"\ndiameter = {d!r}\n'
        f"center = [{bx / 2!r}, {by / 2!r}, {bz / 2!r}]\ndirection = [{direction}]\n"
    )


def _gen(voxel: float, body: str, size: float = 100e-6) -> str:
    return (
        f"[rve]\nsize = [{size!r}, {size!r}, {size!r}]\nvoxel = {voxel!r}\n\n[generator]\n{body}\n"
    )


def _image(voxel: float, name: str) -> str:
    return f'[image]\npath = "{name}"\nvoxel_size = {voxel!r}\n'


def _across(l: float, d: float) -> float:
    """Sangani & Acrivos' K across a square array of spacing l at a tabulated solid fraction."""
    phi = math.pi * d * d / 4 / (l * l)
    for p, l2k in SANGANI_ACRIVOS_SQUARE_TRANSVERSE.items():
        if abs(p - phi) < 1e-9:
            return l * l / l2k
    raise ValueError(f"solid fraction {phi} not tabulated")


def _duct(a: float, cell: float) -> float:
    """K (m^2) of square ducts of side ``a``, one per ``cell`` x ``cell`` of the cross-section:
    Poiseuille flow in a square duct, Q = 0.0351443 a^4 G / mu (0.421731 a^4 G / (12 mu);
    Shah & London 1978, White, Viscous Fluid Flow, Eq. 3-48)."""
    return 0.0351443 * a**4 / cell**2


def _d_at(l: float, phi: float) -> float:
    return math.sqrt(4 * phi / math.pi) * l


@dataclass
class Case:
    """One edge design: ``spec(f)`` is the spec text at ``f`` times finer voxels."""

    name: str
    summary: str
    spec: Callable[[int], str]
    cmd: str = "permeability"
    args: tuple[str, ...] = ("--solver", "voxel", "--direction", "x")
    refine: tuple[int, ...] = (2,)
    exact: float | None = None  # closed-form K (m^2) when the edge reduces to one
    refuse: str | None = None  # the key a refusal must name
    porosity: float | None = None  # analytic porosity, where the geometry has one
    images: dict[str, Callable[[int], np.ndarray]] = field(default_factory=dict)


def _channel(n: int, w: int) -> Callable[[int], np.ndarray]:
    """Solid n^3 block with a square w x w straight channel along x (pore = 0)."""

    def make(f: int) -> np.ndarray:
        a = np.ones((n, n, n), np.uint8)
        lo = (n - w) // 2
        a[:, lo : lo + w, lo : lo + w] = 0
        return np.repeat(np.repeat(np.repeat(a, f, 0), f, 1), f, 2)

    return make


def _closed_pore(n: int) -> Callable[[int], np.ndarray]:
    def make(f: int) -> np.ndarray:
        a = np.ones((n, n, n), np.uint8)
        a[n // 2 - 1 : n // 2 + 1, n // 2 - 1 : n // 2 + 1, n // 2 - 1 : n // 2 + 1] = 0
        return a

    return make


def _dead_end(n: int) -> Callable[[int], np.ndarray]:
    """A channel along y only: pore space percolates along y, not along x."""

    def make(f: int) -> np.ndarray:
        a = np.ones((n, n, n), np.uint8)
        a[n // 2 - 1 : n // 2 + 1, :, n // 2 - 1 : n // 2 + 1] = 0
        return a

    return make


def _one_solid(n: int) -> Callable[[int], np.ndarray]:
    def make(f: int) -> np.ndarray:
        a = np.zeros((n * f,) * 3, np.uint8)
        a[:f, :f, :f] = 1
        return a

    return make


L20 = 20e-6
CASES = [
    Case(
        "cyl_d_2vox",
        "cylinder d=4um at 2um voxel (2 voxels across, the minimum), 20um box, across",
        lambda f: _cyl(4e-6, (L20,) * 3, 2e-6 / f),
        porosity=0.9685840735,
        refine=(2, 4),
    ),
    Case(
        "cyl_d_1.9vox",
        "cylinder d=3.8um at 2um voxel (below 2 voxels across)",
        lambda f: _cyl(3.8e-6, (L20,) * 3, 2e-6 / f),
        refine=(),
        refuse="rve.voxel",
    ),
    Case(
        "cyl_d_8vox_phi0.05",
        "cylinder phi=0.05 (d=5.05um) at d/8 voxel, across (S&A)",
        lambda f: _cyl(_d_at(L20, 0.05), (L20,) * 3, _d_at(L20, 0.05) / 8 / f),
        porosity=1 - 0.05,
        exact=_across(L20, _d_at(L20, 0.05)),
        refine=(2,),
    ),
    Case(
        "cyl_phi0.75_across",
        "cylinder phi=0.75 (gap 0.46um) at 0.5um voxel, across (S&A)",
        lambda f: _cyl(_d_at(L20, 0.75), (L20,) * 3, 0.5e-6 / f),
        exact=_across(L20, _d_at(L20, 0.75)),
        refine=(2,),
        refuse="rve.voxel",
    ),
    Case(
        "cyl_phi0.75_diff",
        "cylinder phi=0.75 (gap 0.46um) at 0.5um voxel: diffusivity x (the grid closes the gap)",
        lambda f: _cyl(_d_at(L20, 0.75), (L20,) * 3, 0.5e-6 / f),
        cmd="diffusivity",
        args=("--direction", "x"),
        refine=(),
    ),
    Case(
        "cyl_phi0.75_fine",
        "cylinder phi=0.75 (gap 0.46um) at 0.25um voxel (gap 1.8 voxels), across (S&A)",
        lambda f: _cyl(_d_at(L20, 0.75), (L20,) * 3, 0.25e-6 / f),
        exact=_across(L20, _d_at(L20, 0.75)),
        porosity=1 - 0.75,
        refine=(),
    ),
    Case(
        "cyl_phi0.7_across",
        "cylinder phi=0.7 (gap 1.1um) at 0.5um voxel, across (S&A)",
        lambda f: _cyl(_d_at(L20, 0.7), (L20,) * 3, 0.5e-6 / f),
        porosity=1 - 0.7,
        exact=_across(L20, _d_at(L20, 0.7)),
        refine=(2,),
    ),
    Case(
        "cyl_phi0.6_across_coarse",
        "cylinder phi=0.6 at 1um voxel (gap 2.5 voxels), across (S&A)",
        lambda f: _cyl(_d_at(L20, 0.6), (L20,) * 3, 1e-6 / f),
        porosity=1 - 0.6,
        exact=_across(L20, _d_at(L20, 0.6)),
        refine=(2,),
    ),
    Case(
        "cyl_d_edge",
        "cylinder d = the box edge (20um)",
        lambda f: _cyl(20e-6, (L20,) * 3, 1e-6),
        refine=(),
        refuse="fibers[0].diameter",
    ),
    Case(
        "cyl_along_phi0.1",
        "cylinder phi=0.1 along its axis (D&T), 1um voxel",
        lambda f: _cyl(_d_at(L20, 0.1), (L20,) * 3, 1e-6 / f),
        porosity=1 - 0.1,
        args=("--solver", "voxel", "--direction", "z"),
        exact=L20**2 * drummond_tahir_square_parallel(0.1),
        refine=(2,),
    ),
    Case(
        "box_quarter",
        "8um box at 2um voxel (a quarter of the edge), d=4um, across",
        lambda f: _cyl(4e-6, (8e-6,) * 3, 2e-6 / f),
        porosity=0.8036504592,
        refine=(2, 4),
    ),
    Case(
        "box_voxel_gt_quarter",
        "8um box at 2.1um voxel",
        lambda f: _cyl(4.2e-6, (8e-6,) * 3, 2.1e-6),
        refine=(),
        refuse="rve.voxel",
    ),
    Case(
        "box_aspect_8",
        "80x10x10um box, cylinder along x phi=0.2, 0.5um voxel, across y (S&A)",
        lambda f: _cyl(_d_at(10e-6, 0.2), (80e-6, 10e-6, 10e-6), 0.5e-6 / f, "1, 0, 0"),
        porosity=1 - 0.2,
        args=("--solver", "voxel", "--direction", "y"),
        exact=_across(10e-6, _d_at(10e-6, 0.2)),
        refine=(),
    ),
    Case(
        "gen_por_0.97_few",
        "straight generator porosity 0.97, d=10um, 100um box, 2.5um voxel",
        lambda f: _gen(
            2.5e-6 / f, 'kind = "straight"\nporosity = 0.97\ndiameter = 10e-6\nseed = 1'
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "gen_n1",
        "straight generator n_fibers=1, d=10um, 50um box, 1.25um voxel",
        lambda f: _gen(1.25e-6 / f, "n_fibers = 1\ndiameter = 10e-6\nseed = 3", size=50e-6),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "gen_por_0.35",
        "straight generator porosity 0.35 (overlaps allowed), d=10um, 50um box",
        lambda f: _gen(1.25e-6 / f, "porosity = 0.35\ndiameter = 10e-6\nseed = 2", size=50e-6),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "gen_aniso_1e6",
        "straight, anisotropy 1e6 (in-plane), porosity 0.8, 50um box, through-plane",
        lambda f: _gen(
            1.25e-6 / f,
            "porosity = 0.8\ndiameter = 8e-6\nseed = 4\norientation = { anisotropy = 1e6 }",
            size=50e-6,
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(),
        refuse="generator.porosity",
    ),
    Case(
        "gen_aniso_iso",
        "straight, anisotropy 1 (isotropic), porosity 0.8, 50um box",
        lambda f: _gen(
            1.25e-6 / f,
            "porosity = 0.8\ndiameter = 8e-6\nseed = 4\norientation = { anisotropy = 1.0 }",
            size=50e-6,
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "bent_f_max",
        "bent generator u=0.01, f=1000 (max f), porosity 0.85, 50um box",
        lambda f: _gen(
            1.25e-6 / f,
            'kind = "bent"\nporosity = 0.85\ndiameter = 8e-6\nseed = 5\nu = 0.01\nf = 1000',
            size=50e-6,
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(),
        refuse="generator.porosity",
    ),
    Case(
        "bent_uf_10",
        "bent generator u=3.1 (near pi), f=3 (|u| f ~ 9.3), porosity 0.85, 50um box",
        lambda f: _gen(
            1.25e-6 / f,
            'kind = "bent"\nporosity = 0.85\ndiameter = 8e-6\nseed = 5\nu = 3.1\nf = 3',
            size=50e-6,
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "woven_cell_8",
        "woven-cell, 8 layers, 1um voxel",
        lambda f: (
            "[rve]\nsize = [40e-6, 40e-6, 40e-6]\nvoxel = "
            + repr(1e-6 / f)
            + '\n\n[[fibers]]\nshape = "woven-cell"\nlayers = 8\n'
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "img_channel_2vox",
        "image 16^3 solid, 2x2-voxel square channel along x (1um voxels)",
        lambda f: _image(1e-6 / f, "img.npy"),
        images={"img.npy": _channel(16, 2)},
        exact=_duct(2e-6, 16e-6),
        refine=(2, 4),
    ),
    Case(
        "img_closed_pore",
        "image 16^3, one closed 2^3 pore (no path)",
        lambda f: _image(1e-6, "img.npy"),
        images={"img.npy": _closed_pore(16)},
        refine=(),
        refuse="image",
    ),
    Case(
        "img_dead_end_x",
        "image 16^3, channel along y only; flow along x (no path along x)",
        lambda f: _image(1e-6, "img.npy"),
        images={"img.npy": _dead_end(16)},
        refine=(),
        refuse="image",
    ),
    Case(
        "img_one_solid",
        "image 8^3, one solid voxel (nearly empty)",
        lambda f: _image(1e-6 / f, "img.npy"),
        images={"img.npy": _one_solid(8)},
        refine=(2, 4),
    ),
    Case(
        "img_closed_pore_diff",
        "image 16^3 closed pore: diffusivity x",
        lambda f: _image(1e-6, "img.npy"),
        cmd="diffusivity",
        args=("--direction", "x"),
        images={"img.npy": _closed_pore(16)},
        refine=(),
    ),
    Case(
        "img_one_solid_diff",
        "image 8^3, one solid voxel: diffusivity x",
        lambda f: _image(1e-6 / f, "img.npy"),
        cmd="diffusivity",
        args=("--direction", "x"),
        images={"img.npy": _one_solid(8)},
        refine=(2, 4),
    ),
    Case(
        "img_one_solid_cond",
        "image 8^3, one solid voxel: conductivity x (solid 120, fluid 0.026)",
        lambda f: _image(1e-6 / f, "img.npy"),
        cmd="conductivity",
        args=("--direction", "x", "--solid", "120", "--fluid", "0.026"),
        images={"img.npy": _one_solid(8)},
        refine=(2, 4),
    ),
    Case(
        "img_channel_diff",
        "image 16^3 solid, 2x2 channel along x: diffusivity x (truth 1/64 exactly)",
        lambda f: _image(1e-6 / f, "img.npy"),
        cmd="diffusivity",
        args=("--direction", "x"),
        images={"img.npy": _channel(16, 2)},
        exact=4 / 256,
        refine=(),
    ),
    Case(
        "img_4vox",
        "image 4^3 (the minimum), 2x2 channel along x",
        lambda f: _image(1e-6 / f, "img.npy"),
        images={"img.npy": _channel(4, 2)},
        exact=_duct(2e-6, 4e-6),
        refine=(2, 4),
    ),
    Case(
        "img_3vox",
        "image 3^3 (under 4 voxels per axis)",
        lambda f: _image(1e-6, "img.npy"),
        images={"img.npy": _channel(3, 1)},
        refine=(),
        refuse="image",
    ),
    Case(
        "img_all_solid",
        "image 8^3 all solid",
        lambda f: _image(1e-6, "img.npy"),
        images={"img.npy": lambda f: np.ones((8, 8, 8), np.uint8)},
        refine=(),
        refuse="image",
    ),
    Case(
        "img_no_solid",
        "image 8^3 all pore",
        lambda f: _image(1e-6, "img.npy"),
        images={"img.npy": lambda f: np.zeros((8, 8, 8), np.uint8)},
        refine=(),
        refuse="image",
    ),
    Case(
        "no_fibers",
        "an [rve] with no fibers and no generator (empty box)",
        lambda f: "[rve]\nsize = [2e-05, 2e-05, 2e-05]\nvoxel = 1e-06\n",
        refine=(),
        refuse="fibers",
    ),
    Case(
        "gen_por_0.999",
        "straight generator porosity 0.999 (above one fiber's porosity)",
        lambda f: _gen(2.5e-6, "porosity = 0.999\ndiameter = 10e-6"),
        refine=(),
        refuse="generator.porosity",
    ),
    Case(
        "gen_aniso_1e6_tol",
        "as gen_aniso_1e6 with porosity_tolerance 0.03",
        lambda f: _gen(
            1.25e-6 / f,
            "porosity = 0.8\ndiameter = 8e-6\nseed = 4\nporosity_tolerance = 0.03\n"
            "orientation = { anisotropy = 1e6 }",
            size=50e-6,
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "bent_f_max_tol",
        "bent u=0.01, f=1000, porosity 0.85 +-0.03, 50um box",
        lambda f: _gen(
            1.25e-6 / f,
            'kind = "bent"\nporosity = 0.85\ndiameter = 8e-6\nseed = 5\nu = 0.01\nf = 1000\n'
            "porosity_tolerance = 0.03",
            size=50e-6,
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "bent_explicit_f_max",
        "one explicit bent-rod d=8um along z, u=0.01, f=1000, 50um box, 1.25um voxel",
        lambda f: (
            "[rve]\nsize = [5e-05, 5e-05, 5e-05]\nvoxel = "
            + repr(1.25e-6 / f)
            + '\n\n[[fibers]]\nshape = "bent-rod"\ndiameter = 8e-6\ndirection = [0, 0, 1]\n'
            "u = 0.01\nf = 1000\n"
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "bent_fast_f_max",
        "bent generator f=1000, u=0.01, n_fibers=6, intersections fast, 50um box",
        lambda f: _gen(
            1.25e-6 / f,
            'kind = "bent"\nn_fibers = 6\ndiameter = 8e-6\nseed = 5\nu = 0.01\nf = 1000\n'
            '\n[intersections]\nmethod = "fast"',
            size=50e-6,
        ),
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "cyl_diagonal",
        "cylinder d=6um along [1,1,1] in a 20um cube (cut by the faces), 0.75um voxel",
        lambda f: _cyl(6e-6, (L20,) * 3, 0.75e-6 / f, "1, 1, 1"),
        # the cylinder is cut by the faces (not periodic): Monte Carlo, 4e6 points, +-1.5e-4
        porosity=0.89412,
        args=("--solver", "voxel", "--direction", "z"),
        refine=(2,),
    ),
    Case(
        "fem_cyl_phi0.05",
        "FEM: cylinder phi=0.05 across (S&A), permeameter",
        lambda f: _cyl(_d_at(L20, 0.05), (L20,) * 3, _d_at(L20, 0.05) / 8),
        porosity=1 - 0.05,
        args=("--solver", "fem", "--direction", "x"),
        exact=_across(L20, _d_at(L20, 0.05)),
        refine=(),
    ),
    Case(
        "fem_cyl_phi0.6",
        "FEM: cylinder phi=0.6 across (S&A, gap 2.5um), permeameter",
        lambda f: _cyl(_d_at(L20, 0.6), (L20,) * 3, 1e-6),
        porosity=1 - 0.6,
        args=("--solver", "fem", "--direction", "x"),
        exact=_across(L20, _d_at(L20, 0.6)),
        refine=(),
    ),
    Case(
        "fem_cyl_phi0.75",
        "FEM: cylinder phi=0.75 across (gap 0.46um) on a 1um field",
        lambda f: _cyl(_d_at(L20, 0.75), (L20,) * 3, 1e-6),
        args=("--solver", "fem", "--direction", "x"),
        refine=(),
        refuse="rve.voxel",
    ),
    Case(
        "fem_cyl_phi0.75_fine",
        "FEM: cylinder phi=0.75 across (gap 0.46um) on a 0.2um field (S&A)",
        lambda f: _cyl(_d_at(L20, 0.75), (L20,) * 3, 0.2e-6),
        args=("--solver", "fem", "--direction", "x"),
        exact=_across(L20, _d_at(L20, 0.75)),
        porosity=1 - 0.75,
        refine=(),
    ),
    Case(
        "fem_cyl_along",
        "FEM: cylinder phi=0.1 along (D&T), permeameter",
        lambda f: _cyl(_d_at(L20, 0.1), (L20,) * 3, 1e-6),
        porosity=1 - 0.1,
        args=("--solver", "fem", "--direction", "z"),
        exact=L20**2 * drummond_tahir_square_parallel(0.1),
        refine=(),
    ),
    Case(
        "fem_gen_n1",
        "FEM: straight generator n_fibers=1, 50um box, through-plane",
        lambda f: _gen(1.25e-6, "n_fibers = 1\ndiameter = 10e-6\nseed = 3", size=50e-6),
        args=("--solver", "fem", "--direction", "z"),
        refine=(),
    ),
    Case(
        "img_dead_end_pores",
        "image 16^3 channel along y: pores",
        lambda f: _image(1e-6, "img.npy"),
        cmd="pores",
        args=(),
        images={"img.npy": _dead_end(16)},
        refine=(),
    ),
]


def _write(case: Case, folder: Path, f: int) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name, make in case.images.items():
        np.save(folder / name, make(f))
    spec = folder / "spec.toml"
    spec.write_text(case.spec(f))
    return spec


#: Address-space cap of each command (bytes): a runaway case fails with a MemoryError in its
#: own process instead of filling the shared machine (bent f = 1000 took 22.7 GB before f70f707).
MEMORY_CAP = 10 * 2**30


def _cap_memory() -> None:
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))


#: The exit statuses of a run that printed its result: 3 when its status is not ok (since
#: session 45, psdesign/cli/exit_status.py; an untrustworthy or blocked result exited 0).
RUN_EXITS = (0, 3)


def _run(case: Case, spec: Path, timeout: float) -> dict:
    cmd = [sys.executable, "-m", "psdesign", case.cmd, str(spec), *case.args, "--json"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.monotonic()
    try:
        p = subprocess.run(
            cmd, capture_output=True, text=True, timeout=timeout, env=env, preexec_fn=_cap_memory
        )
    except subprocess.TimeoutExpired:
        return {"exit": "timeout", "seconds": timeout}
    row = {
        "exit": p.returncode,
        "seconds": round(time.monotonic() - t0, 1),
        "traceback": "Traceback" in p.stderr,
        "stderr_last": p.stderr.strip().splitlines()[-1] if p.stderr.strip() else "",
    }
    if p.returncode in RUN_EXITS:
        try:
            out = json.loads(p.stdout)
        except json.JSONDecodeError:
            row["json"] = "unparseable"
            return row
        res = out[0] if isinstance(out, list) else out
        row.update(
            status=res.get("status"),
            k=next(
                (
                    res[n]
                    for n in ("permeability_m2", "relative_diffusivity", "effective_conductivity")
                    if res.get(n) is not None
                ),
                None,
            ),
            bar=res.get("permeability_rel_error", res.get("rel_error")),
            porosity=res.get("porosity"),
            porosity_error=res.get("porosity_error"),
            warnings=res.get("warnings"),
        )
    else:
        row["error_lines"] = [
            ln for ln in p.stderr.splitlines() if ln.startswith("psdesign: error")
        ]
    return row


def audit(case: Case, work: Path, timeout: float) -> dict:
    folder = work / case.name
    shutil.rmtree(folder, ignore_errors=True)
    spec = _write(case, folder / "x1", 1)
    row = {
        "case": case.name,
        "summary": case.summary,
        "command": f"psdesign {case.cmd} spec.toml {' '.join(case.args)} --json",
        **_run(case, spec, timeout),
    }
    if case.refuse is not None:
        row["clean_refusal"] = (
            row["exit"] == 2
            and not row["traceback"]
            and len(row["error_lines"]) == 1
            and case.refuse in row["error_lines"][0]
        )
        return row
    if row.get("exit") not in RUN_EXITS or row.get("k") is None:
        return row
    if case.porosity is not None and row.get("porosity") is not None:
        row["porosity_exact"] = case.porosity
        row["porosity_covered"] = abs(row["porosity"] - case.porosity) <= (
            row.get("porosity_error") or 0.0
        )
    refs = {}
    for f in case.refine:
        r = _run(case, _write(case, folder / f"x{f}", f), timeout)
        refs[f] = r
        row[f"k_x{f}"], row[f"bar_x{f}"], row[f"status_x{f}"] = (
            r.get("k"),
            r.get("bar"),
            r.get("status"),
        )
    if case.exact is not None:
        row["k_ref"], row["ref"] = case.exact, "closed form"
    elif refs and refs[max(refs)].get("k") is not None:
        row["k_ref"], row["ref"] = refs[max(refs)]["k"], f"{max(refs)}x finer"
    if row.get("k_ref"):
        row["true_err"] = row["k"] / row["k_ref"] - 1
        bar = row.get("bar")
        row["covered"] = bar is not None and math.isfinite(bar) and abs(row["true_err"]) <= bar
    return row


def _g(x: object, fmt: str = ".3g") -> str:
    return "" if x is None else format(x, fmt) if isinstance(x, float) else str(x)


def table(rows: list[dict]) -> str:
    """The rows as a Markdown table (RESULTS.md)."""
    head = (
        "| case | design | command | exit | status | K | bar | reference | true error | covered "
        "| porosity +- error (analytic) | s |"
    )
    out = [head, "|" + " --- |" * 12]
    last = {r["case"]: r for r in rows}  # a case run again replaces its earlier row
    order = [c.name for c in CASES if c.name in last]
    for r in (last[n] for n in order):
        if r.get("clean_refusal") is not None or r.get("exit") not in (*RUN_EXITS, None):
            line = _g(r.get("stderr_last")).replace("psdesign: error: ", "")
            status = ("clean refusal: " if r.get("clean_refusal") else "") + line
        else:
            status = _g(r.get("status"))
            if r.get("status") == "blocked" and r.get("warnings"):
                status += " + warning: refine rve.voxel"
        ref = f"{_g(r.get('k_ref'))} ({r['ref']})" if r.get("k_ref") else ""
        err = f"{100 * r['true_err']:+.1f} %" if r.get("true_err") is not None else ""
        bar = f"{100 * r['bar']:.2f} %" if isinstance(r.get("bar"), float) else ""
        cmd = r["command"].replace("psdesign ", "").replace(" spec.toml", "").replace(" --json", "")
        por = ""
        if r.get("porosity_exact") is not None:
            por = (
                f"{r['porosity']:.4f} +- {r['porosity_error']:.1e} ({r['porosity_exact']:.4f}): "
                f"{'covered' if r['porosity_covered'] else 'MISSED'}"
            )
        design = r["summary"].replace("|", "/")
        out.append(
            f"| {r['case']} | {design} | {cmd} | {r['exit']} | {status} | {_g(r.get('k'))} "
            f"| {bar} | {ref} | {err} | {_g(r.get('covered'))} | {por} | {r['seconds']} |"
        )
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="*", default=None)
    ap.add_argument("--out", type=Path, default=Path("/tmp/audit_edges"))
    ap.add_argument("--timeout", type=float, default=300.0)
    ap.add_argument("--table", action="store_true", help="print OUT/audit_edges.jsonl as Markdown")
    a = ap.parse_args()
    if a.table:
        print(table([json.loads(ln) for ln in open(a.out / "audit_edges.jsonl")]))
        return
    a.out.mkdir(parents=True, exist_ok=True)
    cases = [c for c in CASES if a.cases is None or c.name in a.cases]
    with open(a.out / "audit_edges.jsonl", "a") as log:
        for case in cases:
            row = audit(case, a.out, a.timeout)
            row["load"] = os.getloadavg()[0]
            log.write(json.dumps(row) + "\n")
            log.flush()
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
