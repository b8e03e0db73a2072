"""Calibration table of the porosity's error bar (psdesign.geometry.porosity.porosity_error),
session 38: the bar before (session 32's ``|count - partial(h)| + |partial(h) -
partial(2h)|``) and after (the two-grid change of the tangent-plane partial volume as well,
the larger of the two changes) on five families, each against its own truth:

* ``aligned``: straight cylinders along z (one, or two on a centred square lattice, 30 %,
  overlapping above 0.707 periods), diameter 2-32 voxels (two: 0.71-0.99 periods), 16-48
  voxels per period, 30 % centred on a voxel corner or centre (the symmetric placements of
  session 37's misses); porosity 0.04-1. Truth: the analytic area, ``pi r^2`` per cell, minus
  the four lenses ``2 r^2 acos(D / 2r) - (D / 2) sqrt(4 r^2 - D^2)`` (D = 0.7071) where two
  overlap;
* ``oblique``: one cylinder at random Sec. 7.1 angles, diameter 2-32 voxels; truth: the
  partial volume on a 4x finer grid (its error ~1/16 of the coarse one's);
* ``straight`` / ``bent``: generator RVEs (3-11 fibres of 5-12 um in a 50 um cube, 1-1.7 um
  voxels, overlaps kept; bent u = 0.2); truth: the 4x finer partial volume;
* ``woven``: the Table I woven cell (both thickness axes) at 24-48 voxels per period; truth:
  the 4x finer partial volume.

Prints one row per family: cases, covered before and after, the median bar / true error
before and after (over cases with a true error above 1e-5); then each case the bar misses.

    python benchmarks/porosity_error_calibration.py [seed]

Seeds 0 and 1 are two sets of cases; the formula was chosen on a third (session 38's
prototype run of the same families), so both are checks on cases it was not fitted to.
"""

from __future__ import annotations

import sys

import numpy as np

from psdesign.geometry.fibers import make_fiber, woven_cell
from psdesign.geometry.porosity import partial_volume_porosity, porosity_error
from psdesign.geometry.rve import RVE, VoxelFields
from psdesign.packing.generators import build_fibers

L = 1e-4  # one period, metres
FAMILIES = ("aligned", "oblique", "straight", "bent", "woven")
COUNTS = {"aligned": 300, "oblique": 60, "straight": 16, "bent": 16}


def lens(r: float, gap: float) -> float:
    """Area common to two circles of radius ``r`` whose centres are ``gap`` apart."""
    if 2 * r <= gap:
        return 0.0
    return 2 * r * r * np.arccos(gap / (2 * r)) - gap / 2 * np.sqrt(4 * r * r - gap * gap)


def bars(f: VoxelFields, h: float) -> tuple[float, float]:
    """(before, after): session 32's bar and the current one."""
    fine = partial_volume_porosity(f.distance, h)
    coarse = partial_volume_porosity(f.distance[::2, ::2, ::2], 2 * h)
    return abs(f.porosity - fine) + abs(fine - coarse), porosity_error(f.distance, h, f.porosity)


def aligned(rng: np.random.Generator) -> tuple[VoxelFields, float, float] | None:
    n = int(rng.choice([16, 20, 24, 32, 40, 48]))
    two = rng.uniform() < 0.3
    dvox = rng.uniform(0.71 * n, 0.99 * n) if two else rng.uniform(2, min(32, 0.95 * n))
    d = dvox / n
    r = d / 2
    c = np.array([*rng.uniform(0, 1, 2), 0.5])
    if rng.uniform() < 0.3:
        c = np.array([0.5, 0.5, 0.5] if rng.uniform() < 0.5 else [0.5 + 0.5 / n] * 2 + [0.5])
    if two:
        solid, centres = 2 * np.pi * r * r - 4 * lens(r, np.sqrt(0.5)), [c, c + [0.5, 0.5, 0]]
    else:
        solid, centres = np.pi * r * r, [c]
    if 1 - solid < 0.04:
        return None
    fibers = [
        make_fiber("cylinder", diameter=d, center=list(x % 1.0), direction=[0, 0, 1])
        for x in centres
    ]
    f = RVE(size=np.array([L, L, 4 * L / n]), fibers=fibers, period=L).voxelize(L / n)
    return f, L / n, 1 - solid


def _finer(rve: RVE, voxel: float) -> tuple[VoxelFields, float, float]:
    f = rve.voxelize(voxel)
    h = float(f.grid.spacing[0])
    ref = rve.voxelize(voxel / 4)
    return f, h, partial_volume_porosity(ref.distance, float(ref.grid.spacing[0]))


def oblique(rng: np.random.Generator) -> tuple[VoxelFields, float, float]:
    n = int(rng.choice([16, 20, 24, 32]))
    d = rng.uniform(2, min(32, 0.9 * n)) / n
    fb = make_fiber(
        "cylinder",
        diameter=d,
        center=rng.uniform(0, 1, 3),
        theta=rng.uniform(0, 90),
        omega=rng.uniform(0, 180),
    )
    return _finer(RVE(size=np.full(3, L), fibers=[fb]), L / n)


def generated(rng: np.random.Generator, kind: str) -> tuple[VoxelFields, float, float] | None:
    voxel = float(rng.choice([1e-6, 1.25e-6, 1.7e-6]))
    gen = {
        "kind": kind,
        "n_fibers": int(rng.integers(3, 12)),
        "diameter": float(rng.uniform(5e-6, 12e-6)),
        "seed": int(rng.integers(1_000_000)),
    }
    if kind == "bent":
        gen["u"] = 0.2
    spec = {
        "rve": {"size": [50e-6] * 3, "voxel": voxel},
        "generator": gen,
        "intersections": {"method": "none"},
    }
    return _finer(build_fibers(spec).rve, voxel)


def cases(family: str, seed: int):
    """(fields, voxel edge, truth) of every case of one family."""
    rng = np.random.default_rng([seed, FAMILIES.index(family)])
    if family == "woven":
        for n in (24, 32, 40, 48):
            for axis in ("z", "x"):
                rve = RVE(size=np.full(3, L), fibers=woven_cell(thickness_axis=axis))
                yield _finer(rve, L / n)
        return
    for _ in range(COUNTS[family]):
        case = {
            "aligned": aligned,
            "oblique": oblique,
            "straight": lambda g: generated(g, "straight"),
            "bent": lambda g: generated(g, "bent"),
        }[family](rng)
        if case is not None:
            yield case


def main(argv: list[str]) -> None:
    seed = int(argv[0]) if argv else 0
    print(f"seed {seed}")
    print("| family | cases | covered before | covered after | median bar/error before | after |")
    print("|---|---|---|---|---|---|")
    total, misses = [], []
    for family in FAMILIES:
        rows = []
        for f, h, truth in cases(family, seed):
            rows.append((abs(f.porosity - truth), *bars(f, h)))
            if rows[-1][0] > rows[-1][2]:
                misses.append(
                    f"missed: {family}, {f.grid.shape[0]} voxels per edge, porosity "
                    f"{truth:.4f}, error {rows[-1][0]:.2e}, bar {rows[-1][2]:.2e} "
                    f"({rows[-1][2] / rows[-1][0]:.2f}x)"
                )
        a = np.array(rows)
        total.append(a)
        _row(family, a)
    _row("all", np.concatenate(total))
    print("\n".join(misses))


def _row(name: str, a: np.ndarray) -> None:
    err, before, after = a.T
    res = err > 1e-5
    print(
        f"| {name} | {len(a)} | {int(np.sum(err <= before))} | {int(np.sum(err <= after))} | "
        f"{np.median(before[res] / err[res]):.1f}x | {np.median(after[res] / err[res]):.1f}x |"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
