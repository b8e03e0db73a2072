"""Audit of Omega's status against an independent truth, set by set (session 50).

Usage::

    python benchmarks/omega_audit.py [--full] [--sets a,b] [--out rows.jsonl]

Rebuilds seeded, representative versions of session 49's probe sets (their scripts lived in
/tmp and are gone; benchmarks/RESULTS.md "Session 49: Omega's status", three sections), voxelizes
each case, and compares the count ``Omega`` (:attr:`~psdesign.geometry.rve.VoxelFields.
intersection_volume_fraction`), its bar and its status
(:func:`psdesign.packing.overlap_status.intersection_status`) with a truth computed without the
package's overlap code:

- ``pairs``: closed forms. Two cylinders crossing at right angles, axes ``s`` apart (Cavalieri;
  ``s = 0``, equal radii: the Steinmetz solid ``16 r^3 / 3``); crossing at an angle ``a`` the
  same over ``sin a`` (each section parallel to both axes is a parallelogram of the strips'
  widths, area ``w_i w_j / sin a``); parallel along z, the circle-lens area (MathWorld,
  "Circle-Circle Intersection", eq. 14) times the box's length.
- ``ud``, ``ud4``, ``arrays``, ``tiltfam``, ``d18``, ``nearaxis``: fibers sharing one direction
  ``d``. A point lies in a fiber iff its lattice coordinates ``(a, b)`` (``x . e1``, ``x . e2``,
  :attr:`~psdesign.geometry.fibers.Fiber.lattice`) are within ``r`` of the fiber's modulo 1, so
  the volume in >= 2 fibers is ``int [count(a, b) >= 2] L(a, b) da db`` over the unit cell,
  ``L`` the summed length inside the box of the lattice lines through ``(a, b)`` (session 49's
  truthtilt.py method): a midpoint count at ``M^2`` points, its error ``|T(M) - T(M / 2)|``.
- ``mix3``: cylinders along x, y and z: the voxel count at 4x finer, its error ``|4x - 2x|``.

A case is *inside* when ``|Omega - truth| + truth error <= bar``, *outside* when
``|Omega - truth| - truth error > bar``, else *borderline*. The table: per set, cases, ``ok``
inside, ``ok`` OUTSIDE (must be 0), flagged needlessly (``untrustworthy`` but inside), flagged
rightly (``untrustworthy`` and outside), borderline, and the largest ``|Omega - truth| / bar``
rated ``ok``. Rows go to a jsonl (``--out``; ``--table FILE`` prints the table of one again).
"""

from __future__ import annotations

import argparse
import itertools
import json
import time

import numpy as np
from porosity_error_coverage import circle_lens_area as lens_area
from porosity_error_coverage import crossing_lens  # the same closed forms, one definition

from psdesign.geometry.fibers import make_fiber
from psdesign.geometry.rve import RVE

L = 1e-4  # the box edge, metres (one period)


def _clipped_length(p: np.ndarray, d: np.ndarray, box: np.ndarray) -> np.ndarray:
    """Length of the lines ``p + s d`` (rows of ``p``) inside ``[0, box)``."""
    t0, t1 = np.full(len(p), -np.inf), np.full(len(p), np.inf)
    for a in range(3):
        if abs(d[a]) < 1e-300:
            out = (p[:, a] < 0.0) | (p[:, a] >= box[a])
            t1[out] = -np.inf
            continue
        u, v = (0.0 - p[:, a]) / d[a], (box[a] - p[:, a]) / d[a]
        t0, t1 = np.maximum(t0, np.minimum(u, v)), np.minimum(t1, np.maximum(u, v))
    return np.maximum(t1 - t0, 0.0)


def _family_count(fibers: list, box: np.ndarray, m: int) -> float:
    """``int [count >= 2] L da db / |box|`` at ``m^2`` midpoints (module doc)."""
    e1, e2 = fibers[0].lattice
    d = np.cross(e1, e2)
    g = (np.arange(m) + 0.5) / m
    a, b = (x.ravel() for x in np.meshgrid(g, g, indexing="ij"))
    count = np.zeros(len(a), np.int16)
    for fb in fibers:
        da, db = a - fb.center @ e1, b - fb.center @ e2
        da -= np.round(da)
        db -= np.round(db)
        count += da * da + db * db <= (0.5 * fb.diameter) ** 2
    keep = count >= 2
    base = np.outer(a[keep], e1) + np.outer(b[keep], e2)
    corners = np.array(list(itertools.product(*[(0.0, x) for x in box])))
    length = np.zeros(len(base))
    spans = [corners @ e for e in (e1, e2)]
    for j in range(int(np.floor(spans[0].min())) - 1, int(np.ceil(spans[0].max())) + 1):
        for k in range(int(np.floor(spans[1].min())) - 1, int(np.ceil(spans[1].max())) + 1):
            p = base + j * e1 + k * e2
            p -= (p @ d)[:, None] * d  # the line's point nearest the origin
            length += _clipped_length(p, d, box)
    return float(length.sum() / m**2 / np.prod(box))


def family_truth(fibers: list, box: np.ndarray, m: int = 2048) -> tuple[float, float]:
    """Volume fraction of the box in >= 2 of ``fibers`` (one shared direction) and its error."""
    fine = _family_count(fibers, box, m)
    # 3x the difference from half the points per axis: the difference alone fell under the
    # true error on a tilted pair (2.2e-6 for 0.7e-6 against lens area x length)
    return fine, 3.0 * abs(fine - _family_count(fibers, box, m // 2))


def _cyl(diameter: float, center, direction) -> object:
    return make_fiber("cylinder", diameter, center=np.asarray(center, float), direction=direction)


def set_pairs(rng: np.random.Generator, k: int) -> list[dict]:
    """Closed-form pairs: right-angle crossings, Steinmetz, angled crossings, parallel lenses."""
    cases = []
    for _ in range(k):
        n = int(rng.choice([16, 24, 32, 48, 64]))
        ri, rj = rng.uniform(0.05, 0.2, 2)
        s = ri + rj - min(rng.uniform(0.5, 12.0) / n, 1.6 * min(ri, rj))
        c = rng.uniform(0, 1, 3)
        pair = [_cyl(2 * ri, c, [1, 0, 0]), _cyl(2 * rj, c + [0, s, 0], [0, 0, 1])]
        cases.append(dict(name=f"perp n{n}", fibers=pair, n=n, truth=crossing_lens(ri, rj, s)))
        off = s * np.array([np.cos(a := rng.uniform(0, 2 * np.pi)), np.sin(a), 0.0])
        pair = [_cyl(2 * ri, c, [0, 0, 1]), _cyl(2 * rj, c + off, [0, 0, 1])]
        cases.append(dict(name=f"par n{n}", fibers=pair, n=n, truth=lens_area(ri, rj, s)))
        # an angled crossing in the box's middle: the off-axis fiber's other copies cross the
        # first fiber 1 / sin(angle) > 1.15 periods away, outside the box
        ang, r = np.radians(rng.uniform(60.0, 90.0)), rng.uniform(0.04, 0.09)
        s = 2 * r - min(rng.uniform(0.5, 8.0) / n, 1.6 * r)
        u = [np.cos(ang), np.sin(ang), 0.0]
        pair = [_cyl(2 * r, [0.5, 0.5, 0.5], [1, 0, 0]), _cyl(2 * r, [0.5, 0.5, 0.5 + s], u)]
        exact = crossing_lens(r, r, s) / np.sin(ang)
        cases.append(dict(name=f"angle{np.degrees(ang):.0f} n{n}", fibers=pair, n=n, truth=exact))
    for n in (24, 48):
        r = 0.15
        pair = [_cyl(2 * r, [0.5] * 3, [1, 0, 0]), _cyl(2 * r, [0.5] * 3, [0, 0, 1])]
        cases.append(dict(name=f"steinmetz n{n}", fibers=pair, n=n, truth=16 * r**3 / 3))
    return cases


def _random_z(rng: np.random.Generator, n: int, snapped: bool) -> list:
    count, fibers = int(rng.integers(20, 41)), []
    for _ in range(count):
        d, c = rng.uniform(0.08, 0.16), rng.uniform(0, 1, 3)
        if snapped:  # centres on voxel faces, whole-voxel diameters: errors add
            d, c = max(round(d * n), 2) / n, np.round(c * n) / n
        fibers.append(_cyl(d, c, [0, 0, 1]))
    return fibers


def set_ud(rng: np.random.Generator, k: int, snapped: bool = False) -> list[dict]:
    """Random z-cylinders (s49 ud3.py; ``snapped``: ud4.py), 48^3 and 96^3."""
    tag = "ud4" if snapped else "ud"
    return [
        dict(name=f"{tag} seed{s} n{n}", fibers=_random_z(rng, n, snapped), n=n)
        for s in range(k)
        for n in (48, 96)
    ]


def _array(k: int, n: int, thick: int, off: float, direction) -> list:
    """A ``k x k`` array of cylinders ``thick`` voxels wide at ``n`` voxels a period, centres
    ``off`` voxel off the voxel faces, along ``direction``."""
    g = (np.arange(k) + 0.5) / k + off / n
    return [_cyl(thick / n, [x, y, 0.5], direction) for x in g for y in g]


def set_arrays(rng: np.random.Generator, k: int) -> list[dict]:
    """Square z-arrays (s48/s49 scan3c.py), some with voxels in 3-4 fibers."""
    out = []
    for _ in range(k):
        side, n = int(rng.choice([3, 4])), int(rng.choice([48, 64, 80]))
        pitch = n / side
        thick = int(rng.integers(int(0.9 * pitch), int(1.6 * pitch) + 1))
        off = float(rng.choice([0.0, 0.25, 0.5]))
        fibers = _array(side, n, thick, off, [0, 0, 1])
        out.append(dict(name=f"arr {side}x{side} n{n} dv{thick} off{off}", fibers=fibers, n=n))
    return out


def _tilted(tx: float, ty: float, n: int) -> list[float]:
    """The direction drifting ``tx, ty`` voxels over a box of ``n`` voxels."""
    return [tx / n, ty / n, 1.0]


def set_tiltfam(rng: np.random.Generator, k: int) -> list[dict]:
    """4 x 4 arrays tilted 0.1-2 voxels along x or (1, 1) (s49 tiltfam.py)."""
    out = []
    cases = list(itertools.product([0.1, 0.5, 1.0, 2.0], ["x", "xy"], [0.0, 0.25, 0.5]))
    for pick in np.sort(rng.permutation(len(cases))[:k]):
        t, way, off = cases[pick]
        thick = int(rng.choice([20, 21]))
        d = _tilted(t, t if way == "xy" else 0.0, 64)
        fibers = _array(4, 64, thick, off, d)
        out.append(dict(name=f"tilt {t} {way} dv{thick} off{off}", fibers=fibers, n=64))
    return out


def set_d18(rng: np.random.Generator, k: int) -> list[dict]:
    """4 x 4 arrays 18 voxels thick at 48^3 tilted on both axes (s49 d.py 48 4 18): diagonal
    neighbours overlap, voxels in 3+ fibers."""
    out = []
    for _ in range(k):
        tx, ty = (int(v) for v in rng.integers(0, 13, 2))
        fibers = _array(4, 48, 18, 0.0, _tilted(tx, ty, 48))
        out.append(dict(name=f"d18 tilt ({tx},{ty})", fibers=fibers, n=48))
    return out


def set_nearaxis(rng: np.random.Generator, k: int) -> list[dict]:
    """Pairs and 4 x 4 arrays tilted 1e-12 to 1e-4 of a period over the box: the edge of
    "parallel and off the axes" (the threshold :data:`~psdesign.packing.overlap_status.
    LENS_MIDPOINT_GRID` is 1e-9)."""
    out = []
    # tilts of 1e-5 and under are along the axis (1 - cos < 1e-9), 1e-4 is off it
    for t in (1e-12, 1e-9, 1e-7, 1e-6, 1e-5, 1e-4)[: max(2, k)]:
        n = int(rng.choice([32, 48]))
        fibers = _array(4, n, int(0.3 * n), 0.0, [t, 0.0, 1.0])
        out.append(dict(name=f"near-axis 4x4 t{t:g} n{n}", fibers=fibers, n=n))
        r = 0.12
        fibers = [_cyl(2 * r, [0.4, 0.5, 0.5], [t, 0, 1]), _cyl(2 * r, [0.6, 0.53, 0.5], [t, 0, 1])]
        out.append(dict(name=f"near-axis pair t{t:g} n{n}", fibers=fibers, n=n))
    return out


def set_mix3(rng: np.random.Generator, k: int) -> list[dict]:
    """Random cylinders along x, y and z at 32^3 (s49 mix3.py); truth: the count 4x finer."""
    out = []
    for s in range(k):
        axes = np.eye(3)[rng.integers(0, 3, int(rng.integers(10, 21)))]
        fibers = [_cyl(rng.uniform(0.10, 0.22), rng.uniform(0, 1, 3), a) for a in axes]
        out.append(dict(name=f"mix3 seed{s}", fibers=fibers, n=32, fine=True))
    return out


SETS = {
    "pairs": lambda rng, k: set_pairs(rng, k),
    "ud": lambda rng, k: set_ud(rng, k),
    "ud4": lambda rng, k: set_ud(rng, k, snapped=True),
    "arrays": set_arrays,
    "tiltfam": set_tiltfam,
    "d18": set_d18,
    "nearaxis": set_nearaxis,
    "mix3": set_mix3,
}
#: Cases drawn per set: default (a few minutes on one core) and ``--full``.
SIZES = {
    "pairs": (6, 30),
    "ud": (5, 20),
    "ud4": (5, 20),
    "arrays": (12, 40),
    "tiltfam": (8, 24),
    "d18": (10, 60),
    "nearaxis": (6, 6),
    "mix3": (6, 40),
}


def measure(case: dict) -> dict:
    """Omega, its bar and status, and the truth with its error, of one case."""
    from psdesign.packing.overlap_status import intersection_status

    rve = RVE(size=np.full(3, L), fibers=case["fibers"])
    t0 = time.perf_counter()  # the voxelization and the status
    f = rve.voxelize(L / case["n"])
    status = intersection_status(rve, f)
    seconds = time.perf_counter() - t0
    if "truth" in case:
        truth, terr = float(case["truth"]), 1e-9 * float(case["truth"])
    elif case.get("fine"):
        c4, c2 = (rve.voxelize(L / (k * case["n"])).intersection_volume_fraction for k in (4, 2))
        truth, terr = c4, abs(c4 - c2)
    else:
        truth, terr = family_truth(case["fibers"], np.ones(3))
    omega, bar = f.intersection_volume_fraction, f.intersection_error
    dev = abs(omega - truth)
    side = "inside" if dev + terr <= bar else "outside" if dev - terr > bar else "borderline"
    return dict(
        name=case["name"], n=case["n"], omega=omega, bar=bar, status=status, truth=truth,
        truth_error=terr, dev_over_bar=dev / bar if bar > 0 else (np.inf if dev > 0 else 0.0),
        side=side,
        seconds=seconds,
    )  # fmt: skip


def table(rows: list[dict]) -> str:
    """The per-set table (module doc)."""
    head = "| set | cases | `ok` inside | `ok` OUTSIDE | flagged needlessly | flagged rightly |"
    lines = [head + " borderline | largest `ok` dev/bar |", "|---" * 8 + "|"]
    for name in dict.fromkeys(r["set"] for r in rows):
        rs = [r for r in rows if r["set"] == name]
        ok = [r["status"] == "ok" for r in rs]
        side = [r["side"] for r in rs]
        cells = [
            sum(o and s == "inside" for o, s in zip(ok, side, strict=True)),
            sum(o and s == "outside" for o, s in zip(ok, side, strict=True)),
            sum(not o and s == "inside" for o, s in zip(ok, side, strict=True)),
            sum(not o and s == "outside" for o, s in zip(ok, side, strict=True)),
            side.count("borderline"),
        ]
        worst = max((r["dev_over_bar"] for r in rs if r["status"] == "ok"), default=0.0)
        cells.append(f"{worst:.2f}")
        lines.append(f"| {name} | {len(rs)} | " + " | ".join(map(str, cells)) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="the larger sets (slower)")
    parser.add_argument("--sets", default=",".join(SETS), help="comma-separated set names")
    parser.add_argument("--out", default="omega_audit.jsonl", help="rows (jsonl)")
    parser.add_argument("--table", help="print the table of this jsonl and stop")
    args = parser.parse_args()
    if args.table:
        with open(args.table) as rows:
            print(table([json.loads(line) for line in rows]))
        return
    names = args.sets.split(",")
    unknown = [n for n in names if n not in SETS]
    if unknown:  # before --out is opened (and truncated)
        parser.error(f"--sets: unknown {', '.join(unknown)} (allowed: {', '.join(SETS)})")
    rows = []
    with open(args.out, "w") as out:
        for name in names:
            rng = np.random.default_rng(50)  # each set its own seeded stream
            for case in SETS[name](rng, SIZES[name][int(args.full)]):
                row = {"set": name, **measure(case)}
                rows.append(row)
                out.write(json.dumps(row) + "\n")
                out.flush()
                print(
                    f"{name:9s} {row['name']:36s} omega {row['omega']:.6f} bar {row['bar']:.2e}"
                    f" truth {row['truth']:.6f} +- {row['truth_error']:.1e}"
                    f" dev/bar {row['dev_over_bar']:.2f} {row['status']} ({row['side']})",
                    flush=True,
                )
    print(table(rows))


if __name__ == "__main__":
    main()
