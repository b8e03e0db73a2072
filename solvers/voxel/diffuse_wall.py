"""The calibrated diffuse-domain wall: fluid fraction ``eps`` and drag ``D`` from the signed
distance (issue 12 item 3; the one definition, :mod:`solvers.voxel.diffuse` and the benchmarks
``penalty_scatter.py`` / ``diffuse3d.py`` use it).

The wall replaces the sharp no-slip surface by a smooth layer sampled on the grid, so that K no
longer depends on where the grid nodes sit next to the wall (the cut-face wall's sub-voxel
scatter, which makes its convergence non-monotone).  All lengths are in voxels.

Model (``benchmarks/RESULTS.md``, sections "wall22" and "port22")
-----------------------------------------------------------------
For a wall with signed distance ``s`` (> 0 in the fluid), ``kappa`` the Laplacian of the
distance (the sum of the principal curvatures of the surface, > 0 for a convex solid) and the
grid anisotropy ``a = n_x^4 + n_y^4 + n_z^4`` of the unit normal (1 on a grid axis, 1/2 on a face
diagonal, 1/3 on a body diagonal):

* fluid fraction ``eps = step(s - SE(a) - C LAM^2 kappa)``, ``step(t) = 1 / (1 + exp(-t / LAM))``
  (``logistic``; ``erf``: ``erfc(-t / (LAM sqrt 2)) / 2``, a Gaussian tail, kept for the
  benchmarks);
* drag ``D = exp(LOGC(a)) (1 - step(s)) / step(s)``, i.e. ``exp(LOGC(a) - s / LAM)`` for the
  logistic profile, capped at 1e12 (1 / voxel^2);
* ``LOGC(a)``, ``SE(a)`` linear in ``a`` through the axis values (``LOGC``, ``SE``) and the
  diagonal ones (``LOGC_D``, ``SE_D``): ``t = 2 (1 - a)``, ``LOGC(a) = LOGC + t (LOGC_D - LOGC)``.

Where every constant of :data:`DEFAULT_WALL` comes from (wall22 unless said):

* ``LAM`` = 0.75 voxel: the width; 0.6 and 0.9 scatter more over sub-voxel shifts
  (wall22, "Tried and not kept": 1-D sd at W = 40 voxels 0.066 / 0.012 % against 0.0069 %).
* ``LOGC`` = -0.08385500, ``SE`` = -0.00674740: plane Poiseuille flow between two walls on a
  grid axis, W = 160 and 640 voxels apart, mean over 16 shifts, zeroed (a closed form:
  flux ``W^3 / 12``; ``penalty_scatter.py wall-calibrate logistic 0.75``).
* ``LOGC_D`` = -0.09675771, ``SE_D`` = -0.01476628: the same on a diagonal (normal (1, 1)); the
  discrete layer moves the wall by an angle-dependent, first-order amount.  Calibrated per
  normal, LOGC and SE are linear in ``a`` to 4e-5 for 2-D normals (4,1), (3,1), (2,1), (3,2)
  and to 5e-5 for the 3-D normals (1,1,1), (2,1,0), (2,1,1), (3,2,1), (2,2,1), (3,1,1)
  (``wall-normals``); the interpolated wall's channel error is within 1.5e-4 % at W = 160.
* ``C`` = 2.55: the curvature coefficient, from closed forms: Poiseuille flow in a pipe and in
  an annulus ``b = 3 a`` (``wall-curvature``; C + k1/R + k2/R^2 fit 2.56, annulus 2.47-2.54) and
  their continuum limit by 1-D radial finite volumes (``wall-radial``: C = 2.53 +- 0.03 in 2-D
  and 3-D, ball and spherical shell with ``kappa`` the Laplacian of the distance).  C from 2.3
  to 2.55 keeps every square-array case monotone (wall22, "How much margin").
* The pair rule (:func:`combine`): in a gap the two nearest bodies each carry a wall, fluid
  fractions multiplied and drags added (plane channel W = 8: +2.16 % with the nearest wall's
  layer only, +1.00 % with both; phi 0.5 arrays need both parts).

With it the 2-D square arrays converge strictly monotonically at phi 0.1-0.5, along and
across, at 16 of 16 sub-voxel shifts over 24-96 voxels per spacing, within 0.46 % from 40
(wall22); in 3-D the same on spheres and on a cylinder array tilted along (3, 4, 0) (port22).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "DEFAULT_WALL",
    "KAPPA_MAX",
    "REACH_TOL",
    "REACH_VOXELS",
    "WallProfile",
    "combine",
    "parse_wall",
]

DRAG_CAP = 1e12
"""Largest drag (1 / voxel^2): deep in the solid ``exp(-s / LAM)`` would overflow."""

_KINDS = ("logistic", "erf")


@dataclass(frozen=True)
class WallProfile:
    """A diffuse-domain wall profile (module docstring); lengths in voxels.

    Parameters
    ----------
    kind : {'logistic', 'erf'}
        The step's shape.
    lam : float
        Width ``LAM`` of the layer (voxels, > 0).
    logc, se : float
        Drag level and offset for a wall along a grid axis.
    c : float
        Curvature coefficient: the fluid fraction is shifted by ``c lam^2 kappa``.
    logc_d, se_d : float or None
        Drag level and offset for a diagonal wall (default: the axis values).
    """

    kind: str
    lam: float
    logc: float
    se: float
    c: float = 0.0
    logc_d: float | None = None
    se_d: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in _KINDS:
            raise ValueError(f"profile must be logistic or erf, got {self.kind}")
        if not (math.isfinite(self.lam) and self.lam > 0):
            raise ValueError(f"lam must be a width > 0 voxels, got {self.lam!r}")
        if self.logc_d is None:
            object.__setattr__(self, "logc_d", self.logc)
        if self.se_d is None:
            object.__setattr__(self, "se_d", self.se)

    def at(self, aniso) -> tuple[np.ndarray, np.ndarray]:
        """``(LOGC(a), SE(a))``: linear in the anisotropy ``a`` of the wall normal."""
        t = 2.0 * (1.0 - np.asarray(aniso, dtype=float))  # 0 on an axis, 1 on a diagonal
        return self.logc + t * (self.logc_d - self.logc), self.se + t * (self.se_d - self.se)

    _at = at  # the benchmarks' name

    def step(self, s) -> np.ndarray:
        """The unshifted fluid fraction, 0 in the solid, 1 in the fluid."""
        s = np.asarray(s, dtype=float)
        if self.kind == "erf":  # a Gaussian tail: exp(-s^2 / 2 lam^2)
            from scipy.special import erfc

            return 0.5 * erfc(-s / (self.lam * np.sqrt(2.0)))
        return 1.0 / (1.0 + np.exp(np.minimum(-s / self.lam, 60.0)))

    def eps(self, s, kappa=0.0, aniso=1.0) -> np.ndarray:
        """Fluid fraction at signed distance ``s`` (voxels, > 0 in the fluid), curvature
        ``kappa`` (the Laplacian of the distance, 1 / voxel) and normal anisotropy ``aniso``."""
        # (s - SE) - C LAM^2 kappa: the order of the benchmarks' figures, bit for bit
        kappa = np.asarray(kappa, dtype=float)
        return self.step(
            np.asarray(s, dtype=float) - self.at(aniso)[1] - self.c * self.lam**2 * kappa
        )

    def drag(self, s, aniso=1.0) -> np.ndarray:
        """Drag (1 / voxel^2): ``exp(LOGC(a)) (1 - step) / step``, ``exp(LOGC(a) - s / lam)``
        for the logistic profile, capped at :data:`DRAG_CAP`."""
        s = np.asarray(s, dtype=float)
        logc = self.at(aniso)[0]
        if self.kind == "logistic":
            return np.minimum(np.exp(np.minimum(-s / self.lam + logc, 60.0)), DRAG_CAP)
        from scipy.special import erfc

        f = self.step(s)
        tail = 0.5 * erfc(s / (self.lam * np.sqrt(2.0)))
        return np.minimum(np.exp(logc) * tail / np.maximum(f, 1e-300), DRAG_CAP)

    def reach(self, tol: float = 1e-7, kappa_max: float = 0.5) -> float:
        """Distance into the fluid (voxels) beyond which ``1 - eps`` and the drag are both below
        ``tol`` for every normal (``a`` in [1/3, 1]) and every curvature up to ``kappa_max``.

        Logistic: ``1 - eps = 1 / (1 + exp((s - shift) / LAM)) < tol`` for ``s > shift + LAM
        ln(1 / tol - 1)`` with the largest ``shift = SE(a) + C LAM^2 kappa_max``; the drag
        ``exp(LOGC(a) - s / LAM) < tol`` for ``s > LAM (LOGC(a) + ln(1 / tol))``.  Erf: the
        same bounds with the Gaussian tail, found by bisection.
        """
        ends = np.array([1.0 / 3.0, 1.0])
        logc, se = self.at(ends)
        shift = float(se.max()) + self.c * self.lam**2 * max(kappa_max, 0.0)
        if self.kind == "logistic":
            tail = self.lam * math.log(1.0 / tol - 1.0)
            return max(shift + tail, self.lam * (float(logc.max()) + math.log(1.0 / tol)))
        lo, hi = 0.0, 100.0 * self.lam
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            worst = max(1.0 - float(self.step(mid - shift)), float(self.drag(mid, ends).max()))
            lo, hi = (mid, hi) if worst > tol else (lo, mid)
        return hi


def parse_wall(text: str) -> WallProfile:
    """``PROFILE,LAM,LOGC,SE[,LOGC_D,SE_D[,C]]`` (the benchmarks' wall strings) as a profile.

    Raises
    ------
    ValueError
        A profile other than ``logistic`` / ``erf`` or numbers that do not parse.
    """
    kind, *vals = text.split(",")
    v = [float(x) for x in vals]
    if len(v) == 3:
        return WallProfile(kind, *v)
    if len(v) not in (5, 6):
        raise ValueError(f"wall must be PROFILE,LAM,LOGC,SE[,LOGC_D,SE_D[,C]], got {text!r}")
    return WallProfile(kind, v[0], v[1], v[2], v[5] if len(v) > 5 else 0.0, v[3], v[4])


DEFAULT_WALL = parse_wall("logistic,0.75,-0.08385500,-0.00674740,-0.09675771,-0.01476628,2.55")
"""The wall that converges monotonically on the square arrays (``benchmarks/RESULTS.md``,
wall22; in 3-D port22), always used with :func:`combine`'s pair rule."""

REACH_TOL = 1e-7
"""How close to the bulk (``eps`` = 1, drag 0) a point beyond :data:`REACH_VOXELS` is."""

KAPPA_MAX = 0.5
"""Largest curvature (1 / voxel) :data:`REACH_VOXELS` allows for: a convex fibre of radius 2
voxels (fewer than 4 voxels across is below the solver's resolution warning)."""

REACH_VOXELS = DEFAULT_WALL.reach(REACH_TOL, KAPPA_MAX)
"""How far into the fluid (voxels) :data:`DEFAULT_WALL` differs from the bulk by more than
:data:`REACH_TOL` (``WallProfile.reach``): 12.8 voxels, of which ``LAM ln(1e7)`` = 12.09 is the
logistic tail, ``C LAM^2 KAPPA_MAX`` = 0.72 the curvature shift and ``SE`` = -0.007 the axis
offset (the drag falls below 1e-7 at 12.03).  A sampler of the distance must give the true
distance of every point within this band of a wall; beyond it the two nearest walls may be any
points at least this far (``eps`` = 1 and drag 0 to 1e-7).  wall22 measured that cutting the
layer at 8 voxels moves K by up to 0.019 %, at 6 by up to 0.18 %."""


def combine(
    walls: Sequence[tuple], profile: WallProfile = DEFAULT_WALL, drag: bool = True
) -> tuple[np.ndarray, np.ndarray | None]:
    """The pair rule: ``eps`` and drag of one or two walls at the same points.

    Parameters
    ----------
    walls : sequence of (s, kappa, aniso)
        One or two walls (the nearest and the second-nearest body), arrays of equal shape.
    profile : WallProfile
        The wall profile.
    drag : bool
        Also return the drag (else ``None``).

    Returns
    -------
    eps, drag : np.ndarray
        ``prod eps_i`` (fluid fractions multiplied) and ``sum D_i`` (drags added).
    """
    if not 1 <= len(walls) <= 2:
        raise ValueError(f"walls must hold one or two (s, kappa, aniso) tuples, got {len(walls)}")
    eps = profile.eps(*walls[0])
    for w in walls[1:]:
        eps = eps * profile.eps(*w)
    if not drag:
        return eps, None
    total = profile.drag(walls[0][0], walls[0][2])
    for w in walls[1:]:
        total = total + profile.drag(w[0], w[2])
    return eps, total
