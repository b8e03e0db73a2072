"""Alignment scatter of the sub-voxel walls, taken apart on an assembled 2-D model.

Usage::

    python benchmarks/voxel_scatter.py PHI N[,N...] VARIANT[,VARIANT...] [--offsets SET]

Flow across a square array of cylinders (solid fraction ``PHI``) is independent of the cylinder
axis, so the voxel solver's MAC operator (:mod:`solvers.voxel.boundary`) reduces to a 2-D one:
this script assembles it as a sparse matrix for ``N`` voxels per spacing and solves it
directly (scipy), with each part of the discretisation switchable, at several sub-voxel offsets
of the cylinder (``--offsets``: ``four``, ``eight`` = :data:`alignment_floor.OFFSETS`,
``rand16``, 16 drawn with seed 11, ``scanM@DY``, ``M`` shifts ``(t, DY)`` with ``t`` from 0 to
1, or ``scanyM@DX``, shifts ``(DX, t)``: K along a path, its total variation and largest
step). Variant ``current`` is the voxel solver's discretisation
(K equal to :func:`solvers.voxel_stokes.solve_voxel_stokes`'s to 1e-6,
``tests/validation/test_alignment_scatter.py``); the others change one part:

* (a) wall closure: ``theta=exact``: face activity and wall fractions ``theta`` from the
  analytic distance (the face-centre distance and the wall crossing of each face-to-neighbour
  segment, by bisection) instead of the mean of the two cells and a linear interpolation;
  ``tmin=T``: ``THETA_MIN`` (0.05); ``sw=1``: the non-symmetric Shortley-Weller closure
  ``2 / (theta (theta + theta_other))`` per side (consistent on each axis) with weight 1;
* (b) the face weight ``w_f`` (pressure force, flux, body force): ``w=min`` (current), ``tang``
  (min over the tangential axes), ``normal`` (the per-axis factors averaged with the squared
  components of the wall normal), ``normalfd`` (the same, normal from the cell distances),
  ``vol`` (exact fluid fraction of the face's control volume, 32^2 sub-samples),
  ``aperture`` (exact open fraction of the face), ``one``;
* (c) pressure cells: ``release=0`` (lone cut cells kept), ``release=all`` (every cell whose
  centre lies in the solid dropped, its faces' weights 0), ``release=merge`` (such a cell's
  pressure tied to the fluid-centred neighbour behind its most open face);
* (d) evaluation: ``body=vol|aperture`` (body force weighted by the exact fraction instead of
  ``w_f``), ``k=aperture`` (K from the aperture-weighted mean velocity instead of
  ``mean(w_f q_f)``).

Variants combine with ``+`` (``theta=exact+w=tang``). One JSON line per (variant, N): the true
errors at the offsets (Sangani & Acrivos), their spread, mean and standard deviation.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT))

from alignment_floor import OFFSETS as EIGHT  # noqa: E402
from arrays import L, radius_of  # noqa: E402
from validation_tables import reference_k  # noqa: E402

from solvers.voxel.boundary import THETA_MIN  # noqa: E402

OFFSETS = {
    "four": EIGHT[:4],
    "eight": EIGHT,
    "rand16": [tuple(v) for v in np.random.default_rng(11).random((16, 2)).round(3)],
}
DEFAULTS = {
    "tmin": THETA_MIN,
    "theta": "mean",
    "w": "min",
    "body": "w",
    "release": "1",
    "k": "w",
    "sw": "0",
}


class Cylinder:
    """Periodic signed distance (voxels, > 0 in the fluid) of one cylinder per ``n x n`` cell."""

    def __init__(self, n: int, radius: float, shift: tuple[float, float]) -> None:
        self.n, self.a = n, radius
        self.cx, self.cy = n / 2 + shift[0], n / 2 + shift[1]

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        dx = x - self.cx
        dy = y - self.cy
        dx = dx - self.n * np.round(dx / self.n)
        dy = dy - self.n * np.round(dy / self.n)
        return np.hypot(dx, dy) - self.a


def options(variant: str) -> dict:
    """Switches of a ``+``-joined variant (module docstring) over :data:`DEFAULTS`."""
    opt = dict(DEFAULTS)
    for part in filter(None, variant.split("+")):
        if part != "current":
            key, _, val = part.partition("=")
            if key not in opt:
                raise ValueError(f"unknown switch {key!r} (one of {sorted(opt)})")
            opt[key] = float(val) if key == "tmin" else val
    return opt


def _roll(f: np.ndarray, s: int, b: int) -> np.ndarray:
    return np.roll(f, s, axis=b)


def face_points(n: int, a: int) -> tuple[np.ndarray, np.ndarray]:
    """Centres of the faces normal to ``a``: face ``(i, j)`` lies between cells ``I - e_a`` and
    ``I`` (the voxel solver's layout)."""
    i, j = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    return (i, j + 0.5) if a == 0 else (i + 0.5, j)


def crossing(geo: Cylinder, x0, y0, x1, y1) -> np.ndarray:
    """Fraction ``t`` of the segment from a fluid point to a solid one where the analytic
    distance vanishes (bisection, 50 halvings)."""
    lo = np.zeros_like(x0)
    hi = np.ones_like(x0)
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        inside = geo(x0 + mid * (x1 - x0), y0 + mid * (y1 - y0)) > 0.0
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    return 0.5 * (lo + hi)


def fractions(geo: Cylinder, n: int, a: int, m: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """Exact (sub-sampled, ``m`` points per axis) fluid fraction of each face's control volume
    (the unit square centred on the face) and open fraction of the face (its unit segment)."""
    fx, fy = face_points(n, a)
    s = (np.arange(m) + 0.5) / m - 0.5
    vol = np.zeros((n, n))
    ap = np.zeros((n, n))
    for dx in s:
        ap += (geo(fx, fy + dx) if a == 0 else geo(fx + dx, fy)) > 0
        for dy in s:
            vol += geo(fx + dx, fy + dy) > 0
    return vol / m**2, ap / m


def _thetas(geo, phf, act, fx, fy, opt) -> list[tuple[int, int, np.ndarray, np.ndarray]]:
    """``(b, s, theta, nb_act)`` of the four in-plane neighbour sides (theta 1 where active)."""
    out = []
    for b in range(2):
        for s in (-1, 1):
            nb_act = _roll(act, -s, b)
            if opt["theta"] == "exact":
                th = np.ones(act.shape)
                m = act & ~nb_act
                x1 = fx + (s if b == 0 else 0)
                y1 = fy + (s if b == 1 else 0)
                th[m] = crossing(geo, fx[m], fy[m], x1[m], y1[m])
            else:  # the solver's linear interpolation of the face distances
                nb_phi = np.minimum(_roll(phf, -s, b), 0.0)
                with np.errstate(divide="ignore", invalid="ignore"):
                    th = np.nan_to_num(phf / (phf - nb_phi), nan=1.0, posinf=1.0)
            th = np.clip(th, opt["tmin"], 1.0)
            th[nb_act] = 1.0
            out.append((b, s, th, nb_act))
    return out


def _closure(thetas, shape, sw: bool) -> tuple[np.ndarray, dict | None]:
    """Diagonal and (``sw``) the per-side couplings: symmetric ghost fluid (1 per active side,
    ``1 / theta`` per wall side) or Shortley-Weller ``2 / (t (t + t_other))`` per side."""
    diag = np.zeros(shape)
    if not sw:
        for _, _, th, nb_act in thetas:
            diag += np.where(nb_act, 1.0, 1.0 / th)
        return diag, None
    th = {(b, s): t for b, s, t, _ in thetas}
    coef = {}
    for (b, s), t in th.items():
        coef[(b, s)] = 2.0 / (t * (t + th[(b, -s)]))
        diag += coef[(b, s)]
    return diag, coef


def _weight(geo, phi_c, a, fx, fy, vol_b, exact, kind) -> np.ndarray:
    """Face weight ``w_f`` of the kind named by ``w=`` (module docstring)."""
    if kind in ("normal", "normalfd"):
        # near a wall the curvature is along the normal n: u_bb ~ n_b^2 u_nn
        if kind == "normal":
            eps = 1e-4
            g = [
                (geo(fx + eps, fy) - geo(fx - eps, fy)) / (2 * eps),
                (geo(fx, fy + eps) - geo(fx, fy - eps)) / (2 * eps),
            ]
        else:  # central differences of the cell distances, mean of the face's two cells
            g = []
            for b in range(2):
                gc = 0.5 * (_roll(phi_c, -1, b) - _roll(phi_c, 1, b))
                g.append(0.5 * (gc + _roll(gc, 1, a)))
        g2 = np.maximum(g[0] ** 2 + g[1] ** 2, 1e-30)
        return (g[0] ** 2 * vol_b[0] + g[1] ** 2 * vol_b[1]) / g2
    table = {
        "min": lambda: np.minimum(vol_b[0], vol_b[1]),
        "tang": lambda: vol_b[1 - a],
        "one": lambda: np.ones(phi_c.shape),
        "vol": lambda: exact[0],
        "aperture": lambda: exact[1],
    }
    return table[kind]()


def component(geo: Cylinder, phi_c: np.ndarray, n: int, a: int, opt: dict) -> dict:
    """Active faces, diagonal, couplings and weights of component ``a`` under the options."""
    fx, fy = face_points(n, a)
    phf = geo(fx, fy) if opt["theta"] == "exact" else 0.5 * (phi_c + _roll(phi_c, 1, a))
    act = phf > 0.0
    thetas = _thetas(geo, phf, act, fx, fy, opt)
    diag, coef = _closure(thetas, act.shape, opt["sw"] == "1")
    vol_b = [np.ones(act.shape), np.ones(act.shape)]
    for b, _, th, nb_act in thetas:  # the 1-D cut-volume factors of the voxel solver
        vol_b[b] += np.where(nb_act, 0.0, 0.5 * (th - 1.0))
    exact = fractions(geo, n, a)
    w = (
        np.ones(act.shape)
        if opt["sw"] == "1"
        else _weight(geo, phi_c, a, fx, fy, vol_b, exact, opt["w"])
    )
    return {
        "act": act,
        "diag": np.where(act, diag, 0.0),
        "nbs": [(b, s, act & nb_act) for b, s, _, nb_act in thetas],
        "coef": coef,
        "w": np.where(act, w, 0.0),
        "vol": exact[0],
        "aperture": exact[1],
    }


def pressure_cells(comps: list[dict], n: int, release: bool) -> np.ndarray:
    """Cells with an active face, less (``release``) the lone ones (the solver's loop)."""
    cells = np.zeros((n, n), bool)
    for a, c in enumerate(comps):
        cells |= c["act"] | _roll(c["act"], -1, a)
    while release:
        count = np.zeros((n, n), int)
        for a, c in enumerate(comps):
            on = c["w"] > 0
            count += on + _roll(on, -1, a)
        lone = cells & (count == 1)
        if not lone.any():
            break
        for a, c in enumerate(comps):
            c["w"][(c["w"] > 0) & (lone | _roll(lone, 1, a))] = 0.0
        cells &= ~lone
    return cells


def _merge(mat, comps: list[dict], cells: np.ndarray, phi_c: np.ndarray, n: int):
    """Tie the pressure of every pressure cell whose centre lies in the solid to the
    fluid-centred neighbour behind its most open face (largest ``w_f``): a cell merge; the
    matrix ``T^T K T`` stays symmetric (the merged face's pressure force and flux cancel, its
    body force stays)."""
    nf = n * n
    idx = np.arange(nf).reshape(n, n)
    target = idx.copy()
    best = np.zeros(nf)
    fluid = (phi_c > 0.0).ravel()
    for a, c in enumerate(comps):
        w = c["w"]
        for mine, other in ((idx, _roll(idx, 1, a)), (_roll(idx, 1, a), idx)):
            ok = (w > best[mine]) & fluid[other] & ~fluid[mine] & cells.ravel()[mine]
            best[mine[ok]] = w[ok]
            target.ravel()[mine[ok]] = other[ok]
    moved = np.flatnonzero(target.ravel() != idx.ravel())
    cols = np.arange(3 * nf)
    cols[2 * nf + moved] = 2 * nf + target.ravel()[moved]
    t = sp.csr_matrix((np.ones(3 * nf), (np.arange(3 * nf), cols)), shape=(3 * nf,) * 2)
    red = (t.T @ mat @ t).tolil()
    for m in moved:  # the merged cell's own row and column: identity (its pressure is tied)
        red[2 * nf + m, :] = 0
        red[:, 2 * nf + m] = 0
        red[2 * nf + m, 2 * nf + m] = 1.0
    return red.tocsr()


def _assemble(comps: list[dict], cells: np.ndarray, n: int, opt: dict):
    """Saddle-point matrix ``[[A, W G], [G^T W, 0]]`` (u, v, p; inactive faces and non-pressure
    cells as identity rows) and the right-hand side (body force along x)."""
    nf = n * n
    idx = np.arange(nf).reshape(n, n)
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add(r, c, v):
        parts.append((r.ravel(), c.ravel(), np.broadcast_to(v, r.shape).ravel().astype(float)))

    rhs = np.zeros(3 * nf)
    for a, c in enumerate(comps):
        off, act, w = a * nf, c["act"], c["w"]
        add(off + idx[~act], off + idx[~act], 1.0)
        add(off + idx[act], off + idx[act], c["diag"][act])
        for b, s, cm in c["nbs"]:
            coup = -1.0 if c["coef"] is None else -c["coef"][(b, s)][cm]
            add(off + idx[cm], off + _roll(idx, -s, b)[cm], coup)
        m = act & (w > 0)
        for cell, sign in ((idx, 1.0), (_roll(idx, 1, a), -1.0)):  # cells I and I - e_a
            add(off + idx[m], 2 * nf + cell[m], sign * w[m])
            add(2 * nf + cell[m], off + idx[m], sign * w[m])
        if a == 0:
            body = w if opt["body"] == "w" else np.where(w > 0, c[opt["body"]], 0.0)
            rhs[:nf] = np.where(act, body, 0.0).ravel()
    pin = np.flatnonzero(~cells.ravel())
    add(2 * nf + pin, 2 * nf + pin, 1.0)
    live = np.flatnonzero(cells.ravel())  # the pressure's constant mode: K moves by < 1e-10
    add(2 * nf + live, 2 * nf + live, -1e-11)
    r, c, v = (np.concatenate(p) for p in zip(*parts, strict=True))
    return sp.csr_matrix((v, (r, c)), shape=(3 * nf,) * 2), rhs


def solve(phi: float, n: int, shift: tuple[float, float], variant: str) -> float:
    """True error of K (against Sangani & Acrivos) for one case and variant."""
    opt = options(variant)
    geo = Cylinder(n, radius_of(phi, "square", spacing=n), shift)
    xc, yc = np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5, indexing="ij")
    phi_c = geo(xc, yc).astype(np.float32).astype(np.float64)  # the solver's float32 distance
    comps = [component(geo, phi_c, n, a, opt) for a in range(2)]
    if opt["release"] == "all":
        sol = phi_c <= 0.0
        for a, c in enumerate(comps):
            c["w"][sol | _roll(sol, 1, a)] = 0.0
        cells = ~sol
    else:
        cells = pressure_cells(comps, n, opt["release"] == "1")
    mat, rhs = _assemble(comps, cells, n, opt)
    if opt["release"] == "merge":
        mat = _merge(mat, comps, cells, phi_c, n)
    u = spla.spsolve(mat.tocsc(), rhs)[: n * n].reshape(n, n)
    c0 = comps[0]
    weight = np.where(c0["act"], c0["aperture"], 0.0) if opt["k"] == "aperture" else c0["w"]
    k = (u * weight).mean() * (L / n) ** 2
    return k / reference_k("square", "across", phi) - 1.0


def solve_along(phi: float, n: int, shift: tuple[float, float], variant: str) -> float:
    """True error of K along the cylinders (against the Sparrow & Loeffler series): the axial
    component alone, a scalar Poisson problem on the cell-centred z faces (no pressure cells,
    so only the wall closure and the weight act; ``w=tang`` is ``min`` here)."""
    opt = options(variant)
    geo = Cylinder(n, radius_of(phi, "square", spacing=n), shift)
    xc, yc = np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5, indexing="ij")
    phi_c = geo(xc, yc).astype(np.float32).astype(np.float64)
    phf = geo(xc, yc) if opt["theta"] == "exact" else phi_c
    act = phf > 0.0
    thetas = _thetas(geo, phf, act, xc, yc, opt)
    diag, coef = _closure(thetas, act.shape, opt["sw"] == "1")
    vol_b = [np.ones(act.shape), np.ones(act.shape)]
    for b, _, th, nb_act in thetas:
        vol_b[b] += np.where(nb_act, 0.0, 0.5 * (th - 1.0))
    w = np.ones(act.shape) if opt["sw"] == "1" else np.minimum(vol_b[0], vol_b[1])
    if opt["w"] == "one":
        w = np.ones(act.shape)
    nf = n * n
    idx = np.arange(nf).reshape(n, n)
    rows = [idx[~act], idx[act]]
    cols = [idx[~act], idx[act]]
    vals = [np.ones(int((~act).sum())), diag[act]]
    for b, s, _, nb_act in thetas:
        cm = act & nb_act
        rows.append(idx[cm])
        cols.append(_roll(idx, -s, b)[cm])
        vals.append(-np.ones(int(cm.sum())) if coef is None else -coef[(b, s)][cm])
    mat = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(nf, nf)
    )
    q = spla.spsolve(mat.tocsc(), np.where(act, w, 0.0).ravel()).reshape(n, n)
    k = (q * np.where(act, w, 0.0)).mean() * (L / n) ** 2
    return k / reference_k("square", "along", phi) - 1.0


def main(argv: list[str] | None = None) -> int:
    """One JSON line per (variant, N)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("phi", type=float)
    ap.add_argument("--along", action="store_true", help="flow along the cylinders")
    ap.add_argument("ns", help="voxels per spacing, comma-separated")
    ap.add_argument("variants", help="comma-separated; switches joined by +")
    ap.add_argument(
        "--offsets",
        default="four",
        help=f"{', '.join(sorted(OFFSETS))}, scanM@DY (M shifts (t, DY), t from 0 to 1) or "
        "scanyM@DX",
    )
    args = ap.parse_args(argv)
    if args.offsets.startswith("scan"):
        ydir = args.offsets.startswith("scany")
        m, _, other = args.offsets[5 if ydir else 4 :].partition("@")
        ts = np.linspace(0.0, 1.0, int(m))
        OFFSETS[args.offsets] = [(float(other), t) if ydir else (t, float(other)) for t in ts]
    elif args.offsets not in OFFSETS:
        print(f"--offsets must be one of {sorted(OFFSETS)} or scanM@DY, got {args.offsets}")
        return 2
    for variant in args.variants.split(","):
        for n in (int(v) for v in args.ns.split(",")):
            fn = solve_along if args.along else solve
            errs = np.array([fn(args.phi, n, off, variant) for off in OFFSETS[args.offsets]])
            rec = {
                "phi": args.phi,
                "n": n,
                "variant": variant,
                "flow": "along" if args.along else "across",
                "errors_pct": [round(100 * e, 4) for e in errs],
                "spread_pct": round(100 * float(errs.max() - errs.min()), 4),
                "mean_pct": round(100 * float(errs.mean()), 4),
                "sd_pct": round(100 * float(errs.std(ddof=1)), 4),
                # along a scan: total variation and the largest change between two shifts
                "variation_pct": round(100 * float(np.abs(np.diff(errs)).sum()), 4),
                "max_step_pct": round(100 * float(np.abs(np.diff(errs)).max()), 4),
            }
            print(json.dumps(rec), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
