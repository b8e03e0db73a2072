"""Fiber shapes as generalized PS models plus metadata (paper Sec. 3, 5, 7.1).

Every fiber lives in normalized coordinates (one PS period = the RVE's reference
length). Its solid is ``psi <= isovalue``. A PS fiber is an infinite, periodic
family of parallel copies (one per lattice cell perpendicular to its axis); the
RVE shows the copies that cross it.

Canonical shapes follow the paper's equations with the axis along z through the
cell centre (Eq. 4, 16, 17, 18, 19). Placement (Sec. 7.1): the fiber is first
turned to run along x, moved to the origin, rotated about y by ``theta`` and about
z by ``omega``, and moved to its centre point; equivalently, a centre point and a
direction vector can be given.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from psdesign.errors import SpecError, short
from psdesign.geometry.model import GeneralizedPS, rotation_between, rotation_matrix

SHAPES = (
    "rod",
    "cylinder",
    "bent-rod",
    "compressed-rod-a",
    "compressed-rod-b",
    "compressed-straight",
    "compressed-bent",
    "woven",
)
#: The shapes of a round section given by ``diameter``; the others are fixed shapes.
ROUND_SHAPES = ("rod", "cylinder", "bent-rod")
_CELL_CENTRE = np.array([0.5, 0.5, 0.5])
_Z = np.array([0.0, 0.0, 1.0])
_X = np.array([1.0, 0.0, 0.0])


# ------------------------------------------------------------------ closed forms
def rod_diameter(psi0: float) -> float:
    """Diameter of the rod surface Eq. (4) for isovalue ``psi0`` (Eq. 5)."""
    c = (psi0 + 1.0) / 4.0
    if not -1.0 <= c <= 1.0:
        raise ValueError(f"rod isovalue must lie in [-5, 3], got {psi0}")
    return float(1.0 - np.arccos(c) / np.pi)


def rod_isovalue(diameter: float) -> float:
    """Isovalue of the rod surface Eq. (4) for a normalized ``diameter`` (Eq. 6)."""
    if not 0.0 < diameter < 1.0:
        raise ValueError(f"rod diameter must lie in (0, 1) periods, got {diameter}")
    return float(4.0 * np.cos(np.pi * (1.0 - diameter)) - 1.0)


def rod_cross_section_area(diameter: float) -> float:
    """Exact area of the rod surface's cross-section (one copy per unit cell).

    Integrates, for each ``a`` in the cell, the length of the ``b`` interval where
    ``4 cos(2 pi a) + 4 cos(2 pi b) + 3 <= psi0``.
    """
    from scipy.integrate import quad

    psi0 = rod_isovalue(diameter)

    def chord(a: float) -> float:
        c = (psi0 - 3.0 - 4.0 * np.cos(2 * np.pi * a)) / 4.0
        if c <= -1.0:
            return 0.0
        if c >= 1.0:
            return 1.0
        return 1.0 - np.arccos(c) / np.pi

    half = diameter / 2.0
    area, _ = quad(chord, 0.5 - half, 0.5 + half, epsabs=1e-13, epsrel=1e-12, limit=200)
    return float(area)


def bent_rod_narrowing(diameter: float, u: float, f: float) -> float:
    """Largest narrowing ``D (1 - cos(arctan(u f)))`` of a bent rod (Sec. 5).

    The slope amplitude of the medial axis ``x = 1/2 - u cos(2 pi f z)/(2 pi)`` is
    ``u f``; the paper's ``arctan(u)`` is the case ``f = 1``.
    """
    return float(diameter * (1.0 - np.cos(np.arctan(abs(u * f)))))


# -------------------------------------------------------------- canonical models
def rod_model() -> GeneralizedPS:
    """Eq. (4): ``4 cos(2 pi x) + 4 cos(2 pi y) + 3``, axis along z."""
    return GeneralizedPS(
        mu=[4, 4, 3], kappa=[1, 1, 1], H=[[1, 0, 0], [0, 1, 0], [0, 0, 0]], alpha=[0, 0, 0]
    )


def bent_rod_model(u: float, f: float) -> GeneralizedPS:
    """Eq. (16): ``4 cos(2 pi x + u cos(2 pi f z)) + 4 cos(2 pi y) + 3``."""
    return GeneralizedPS(
        mu=[4, 4, 3],
        kappa=[1, 1, 1],
        H=[[1, 0, 0], [0, 1, 0], [0, 0, 0]],
        alpha=[0, 0, 0],
        minor_term=[0],
        u=[u],
        f=[f],
        G=[[0, 0, 1]],
        beta=[0],
    )


def compressed_rod_a_model() -> GeneralizedPS:
    """Fig. 6(a): ``4cos(2pi x) + cos(3pi x) + 4cos(2pi y) + cos(pi y/6)
    + cos(3pi(x+z))/4 + 2.5``."""
    return GeneralizedPS(
        mu=[4, 1, 4, 1, 0.25, 2.5],
        kappa=[1, 1.5, 1, 1 / 12, 1.5, 1],
        H=[[1, 0, 0], [1, 0, 0], [0, 1, 0], [0, 1, 0], [1, 0, 1], [0, 0, 0]],
        alpha=[0] * 6,
    )


def compressed_rod_b_model() -> GeneralizedPS:
    """Fig. 6(b): ``7cos(2pi x) + 7cos(2pi y) + 2cos(4pi x) + 2cos(4pi y) + 8``."""
    return GeneralizedPS(
        mu=[7, 7, 2, 2, 8],
        kappa=[1, 1, 2, 2, 1],
        H=[[1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0]],
        alpha=[0] * 5,
    )


def _compressed_terms(k3: float) -> dict:
    # 4cos(2pi x) + 3cos(2pi y) + 0.95cos(2pi k3 z)
    #   + 0.5cos(2pi(y+k3 z)) + 0.5cos(2pi(y-k3 z)) + 6.55
    return dict(
        mu=[4, 3, 0.95, 0.5, 0.5, 6.55],
        kappa=[1, 1, 1, 1, 1, 1],
        H=[[1, 0, 0], [0, 1, 0], [0, 0, k3], [0, 1, k3], [0, 1, -k3], [0, 0, 0]],
        alpha=[0] * 6,
    )


def compressed_straight_model() -> GeneralizedPS:
    """Eq. (17): compressed straight fiber, contacts periodic along z."""
    return GeneralizedPS(**_compressed_terms(1.0))


def compressed_bent_model() -> GeneralizedPS:
    """Eq. (18): Eq. (17) with the bend ``0.3 cos(pi z - pi/2)`` in the x phase."""
    return GeneralizedPS(
        **_compressed_terms(1.0), minor_term=[0], u=[0.3], f=[0.5], G=[[0, 0, 1]], beta=[-0.5]
    )


#: Eq. (19) in the five-term form of Sec. 6.2 (moments mu, scales kappa, minor moment u and
#: scale f; the solid is ``psi <= WOVEN_EQ19_ISOVALUE``). The Sec. 6.2 force field starts near
#: it (Table II) and its optimum (Table II result) is close to it.
WOVEN_EQ19 = {
    "mu1": 4.0,
    "mu2": 3.0,
    "mu3": 0.95,
    "mu4": 0.5,
    "mu5": 0.5,
    "kappa1": 1.0,
    "kappa2": 1.0,
    "kappa3": 3.0,
    "kappa4": 1.0,
    "kappa5": 1.0,
    "f": 1.5,
}
WOVEN_EQ19_U = 0.41
WOVEN_EQ19_ISOVALUE = -6.55


def woven_fiber_model(
    params: dict | None = None, u: float | None = None, constant: float = 0.0
) -> GeneralizedPS:
    """The one woven (compressed bent) fiber model of the product (Eq. 19, Sec. 6.2).

    ``mu1 cos(2 pi kappa1 x + u cos(2 pi f (z - 1/6))) + mu2 cos(2 pi kappa2 y)
    + mu3 cos(2 pi kappa3 z) + mu4 cos(2 pi kappa4 (y + 3z)) + mu5 cos(2 pi kappa5 (y - 3z))
    + constant``: axis along z, bend along x, flattened along y. Geometry (Table I cell,
    ``woven_cell``) and the Sec. 6.2 force field (``forcefield.cases``) both build it here.

    Parameters
    ----------
    params : dict, optional
        ``mu1..mu5``, ``kappa1..kappa5``, ``f``; missing keys take the Eq. (19) values
        (:data:`WOVEN_EQ19`).
    u : float, optional
        Minor moment (default Eq. 19's 0.41).
    constant : float
        Constant term (Eq. 19 writes +6.55 on the left with isovalue 0; the force field
        uses no constant and isovalue -6.55 / -6.65).
    """
    p = {**WOVEN_EQ19, **(params or {})}
    u = WOVEN_EQ19_U if u is None else u
    mu = [p[f"mu{i}"] for i in range(1, 6)]
    kappa = [p[f"kappa{i}"] for i in range(1, 6)]
    H = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 1, 3], [0, 1, -3]]
    if constant:
        mu, kappa, H = mu + [constant], kappa + [1.0], H + [[0, 0, 0]]
    return GeneralizedPS(
        mu=mu,
        kappa=kappa,
        H=H,
        alpha=[0] * len(mu),
        minor_term=[0],
        u=[u],
        f=[p["f"]],
        G=[[0, 0, 1]],
        beta=[-1.0 / 6.0],
    )


def woven_model() -> GeneralizedPS:
    """Eq. (19): woven fiber, ``4cos(2pi x + 0.41cos(3pi z - pi/2)) + 3cos(2pi y) + 0.95cos(6pi z)
    + 0.5cos(2pi(y+3z)) + 0.5cos(2pi(y-3z)) + 6.55`` (isovalue 0); see
    :func:`woven_fiber_model`."""
    return woven_fiber_model(constant=-WOVEN_EQ19_ISOVALUE)


_FIXED_MODELS = {
    "compressed-rod-a": compressed_rod_a_model,
    "compressed-rod-b": compressed_rod_b_model,
    "compressed-straight": compressed_straight_model,
    "compressed-bent": compressed_bent_model,
    "woven": woven_model,
}


# --------------------------------------------------------------------- the fiber
@dataclass(frozen=True)
class Fiber:
    """One fiber: a generalized PS model in normalized coordinates plus metadata.

    Attributes
    ----------
    shape : str
        One of :data:`SHAPES`.
    model : GeneralizedPS
        The placed model; solid where ``model(r) <= isovalue``.
    isovalue : float
    diameter : float
        Nominal diameter, normalized.
    center : ndarray (3,)
        A point on the centre line, normalized.
    direction : ndarray (3,)
        Unit vector along the (carrier) centre line.
    lattice : ndarray (2, 3)
        Unit vectors perpendicular to the axis along which the periodic copies repeat
        (spacing one period).
    wave : ndarray (3,)
        Unit vector of the bending displacement (bent shapes).
    u, f : float
        Minor moment and minor scale of the bend (0 and 1 for straight fibers).
    grad_scale : float
        ``|grad psi|`` on the surface; ``(psi - isovalue) / grad_scale`` approximates
        the signed distance (normalized units).
    band_radius : float or None
        Every solid point lies within this distance of a carrier axis copy;
        None when unknown (the field is then evaluated everywhere).
    theta, omega : float
        Placement angles in degrees (Sec. 7.1), when placed that way.
    thin_width : float or None
        Thin width of a fixed shape's section, normalized (:func:`fixed_shape_thin_width`:
        the narrower of its two widths across the centre line, averaged like
        :attr:`diameter`; the woven yarn's thickness through the fabric). None: a round
        section (rod, cylinder, bent rod), whose thin width is its diameter.
    """

    shape: str
    model: GeneralizedPS
    isovalue: float
    diameter: float
    center: np.ndarray
    direction: np.ndarray
    lattice: np.ndarray
    wave: np.ndarray
    u: float = 0.0
    f: float = 1.0
    grad_scale: float = 1.0
    band_radius: float | None = None
    theta: float | None = None
    omega: float | None = None
    thin_width: float | None = None
    extra: dict = field(default_factory=dict)

    # ---------------------------------------------------------------- fields
    def psi(self, points: np.ndarray) -> np.ndarray:
        """The PS function minus the isovalue (<= 0 in the solid)."""
        return self.model.evaluate(points) - self.isovalue

    def field(self, points: np.ndarray) -> np.ndarray:
        """Normalized field: approximate signed distance in periods, <= 0 in the solid.

        For ``cylinder`` it is the exact signed distance to the nearest periodic copy.
        """
        if self.shape == "cylinder":
            return self._cylinder_distance(points)
        return self.psi(points) / self.grad_scale

    def _cylinder_distance(self, points: np.ndarray) -> np.ndarray:
        rel = np.asarray(points, float) - self.center
        a = rel @ self.lattice[0]
        b = rel @ self.lattice[1]
        a -= np.round(a)
        b -= np.round(b)
        return np.hypot(a, b) - self.diameter / 2.0

    # ------------------------------------------------------------ geometry
    def axis_copies(self, lo: np.ndarray, hi: np.ndarray, margin: float) -> list[np.ndarray]:
        """Points on the carrier axis copies that come within ``margin`` of the box [lo, hi].

        Returns one point per copy; all copies share :attr:`direction`.
        """
        lo = np.asarray(lo, float) - margin
        hi = np.asarray(hi, float) + margin
        corners = (
            np.array(
                [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
            )
            - self.center
        )
        ranges = []
        for e in self.lattice:
            proj = corners @ e
            ranges.append(range(int(np.floor(proj.min())), int(np.ceil(proj.max())) + 1))
        out = []
        for j in ranges[0]:
            for k in ranges[1]:
                p = self.center + j * self.lattice[0] + k * self.lattice[1]
                if _clip_line(p, self.direction, lo, hi) is not None:
                    out.append(p)
        return out

    def medial_axis(self, lo: np.ndarray, hi: np.ndarray, n: int = 64) -> list[np.ndarray]:
        """Medial axis polylines (normalized) of every copy crossing the box [lo, hi].

        Straight fibers give two-point segments; bent ones are sampled from the closed
        form ``centre + s d - u cos(2 pi f s') / (2 pi) w``, where ``s'`` is the canonical
        coordinate along the axis: Eq. (16)'s centre line, where the carrier phase is pi.
        Eq. (13)-(15) as printed (``p . r - u cos(...) = 0``) flip the bend's sign and drop
        the factor ``1 / (2 pi kappa)`` and the half period (docs/paper-reproduction.md, 0).
        """
        lines = []
        for p in self.axis_copies(lo, hi, 0.0):
            seg = _clip_line(p, self.direction, np.asarray(lo, float), np.asarray(hi, float))
            if seg is None:
                continue
            s0, s1 = seg
            if self.u == 0.0 or self.shape == "cylinder":
                s = np.array([s0, s1])
            else:
                s = np.linspace(s0, s1, max(n, int(np.ceil((s1 - s0) * self.f * 32)) + 1))
            pts = p + np.outer(s, self.direction)
            if self.u != 0.0:
                s_canon = s + self.extra.get("axis_offset", 0.0)
                disp = -self.u * np.cos(2 * np.pi * self.f * s_canon + self.extra.get("phase", 0.0))
                pts = pts + np.outer(disp / (2 * np.pi), self.wave)
            lines.append(pts)
        return lines

    def to_dict(self, period: float) -> dict:
        """JSON-ready description; lengths in metres (``period`` = metres per period); a
        non-round section adds ``thin_width_m`` (:attr:`thin_width`)."""
        thin = {} if self.thin_width is None else {"thin_width_m": self.thin_width * period}
        return {
            "shape": self.shape,
            "diameter_m": self.diameter * period,
            **thin,
            "center_m": (self.center * period).tolist(),
            "direction": self.direction.tolist(),
            "theta_deg": self.theta,
            "omega_deg": self.omega,
            "u": self.u,
            "f": self.f,
            "isovalue": self.isovalue,
            "grad_scale": self.grad_scale,
            "period_m": period,
            "ps_model": self.model.to_dict(),
        }


def _clip_line(p: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray):
    """Parameter interval [s0, s1] of the line p + s d inside the box, or None (slab method)."""
    s0, s1 = -np.inf, np.inf
    for k in range(3):
        if abs(d[k]) < 1e-14:
            if p[k] < lo[k] or p[k] > hi[k]:
                return None
            continue
        a, b = (lo[k] - p[k]) / d[k], (hi[k] - p[k]) / d[k]
        s0, s1 = max(s0, min(a, b)), min(s1, max(a, b))
    if s0 > s1:
        return None
    return s0, s1


# ------------------------------------------------------------------- placement
def placement_rotation(
    theta: float | None = None, omega: float | None = None, direction=None
) -> np.ndarray:
    """Rotation that takes a canonical fiber (axis along z) to its final orientation.

    The canonical fiber is first turned to run along x (Sec. 7.1), then rotated about
    y by ``theta`` and about z by ``omega`` (degrees); or turned onto ``direction``.
    """
    to_x = rotation_between(_Z, _X)
    if direction is not None:
        d = _three_numbers(direction)
        norm = np.linalg.norm(d) if d is not None else np.nan
        if not np.isfinite(norm) or norm < 1e-12:
            got = d.tolist() if d is not None else short(direction)
            raise SpecError("direction", f"must be a non-zero finite vector, got {got}")
        return rotation_between(_X, d / norm) @ to_x
    for key, angle in (("theta", theta), ("omega", omega)):
        if angle is not None and not (_is_real(angle) and np.isfinite(angle)):
            raise SpecError(key, f"must be a finite angle in degrees, got {short(angle)}")
    return rotation_matrix(theta or 0.0, omega or 0.0) @ to_x


def _is_real(value: object) -> bool:
    """A real number (Python's or NumPy's), not a bool, str or sequence: make_fiber's
    ``diameter="a"`` was NumPy's TypeError from ``isfinite`` (session 54 review)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def _three_numbers(value: object) -> np.ndarray | None:
    """``value`` as a float vector of three, or None when it is none (two numbers, a str): a
    centre ``[.1, .2]`` was NumPy's "cannot reshape array of size 2" (session 54 review)."""
    try:
        v = np.asarray(value, float)
    except (TypeError, ValueError):
        return None
    return v.reshape(3) if v.size == 3 else None


def _round_args(shape: str, diameter: object, u: object, f: object) -> tuple[float, float, float]:
    """A rod's, cylinder's or bent rod's ``(diameter, u, f)`` as floats (``u`` 0 but for a bent
    rod), or a SpecError keyed on the argument that is wrong (a bent rod's ``u=nan`` was keyed
    ``f`` until session 54)."""
    if not (_is_real(diameter) and 0.0 < diameter < 1.0):  # NaN fails the comparison too
        raise SpecError("diameter", f"must lie in (0, 1) periods, got {short(diameter)}")
    if shape != "bent-rod" or (_is_real(u) and u == 0.0):  # u = 0: a straight rod, f unused
        return float(diameter), 0.0, float(f) if _is_real(f) else 1.0
    for key, value in (("u", u), ("f", f)):
        if not (_is_real(value) and np.isfinite(value)):
            raise SpecError(key, f"bent-rod needs a finite {key}, got {short(value)}")
    if not f > 0:
        raise SpecError("f", f"bent-rod needs f > 0, got {short(f)}")
    return float(diameter), float(u), float(f)


def make_fiber(
    shape: str,
    diameter: float | None = None,
    *,
    center=None,
    theta: float | None = None,
    omega: float | None = None,
    direction=None,
    u: float = 0.0,
    f: float = 1.0,
    isovalue: float | None = None,
    extra_rotation: np.ndarray | None = None,
    minor_moment: float | None = None,
) -> Fiber:
    """Build and place a fiber (all lengths normalized: one period = 1).

    (Eleven parameters: independent placement and model knobs, keyword-only after two.)

    Parameters
    ----------
    shape : str
        One of :data:`SHAPES`.
    diameter : float
        Normalized diameter (rod, cylinder, bent-rod); ignored by the fixed-shape
        fibers (compressed, woven), whose size is set by their equation or ``isovalue``.
    center : array_like (3,), optional
        A point on the centre line (default: the cell centre).
    theta, omega : float, optional
        Sec. 7.1 rotation angles in degrees.
    direction : array_like (3,), optional
        Axis direction instead of theta/omega.
    u, f : float
        Bent-rod minor moment and scale (Eq. 16).
    isovalue : float, optional
        Override of the isovalue for fixed-shape fibers.
    extra_rotation : ndarray (3, 3), optional
        Applied before the placement rotation (used by the woven cell).
    minor_moment : float, optional
        Bend moment of a fixed shape with a bend term (woven, compressed-bent; default: the
        equation's), as changed by the force field.
    """
    if shape not in SHAPES:
        raise SpecError("shape", f"got {short(shape)}; allowed: {', '.join(SHAPES)}")
    given, center = center, _CELL_CENTRE.copy() if center is None else _three_numbers(center)
    if center is None or not np.all(np.isfinite(center)):
        raise SpecError("center", f"must be three finite numbers (periods), got {short(given)}")
    R = placement_rotation(theta, omega, direction)
    if extra_rotation is not None:
        R = R @ extra_rotation
    direction_vec = R @ _Z
    lattice = np.array([R @ _X, R @ np.array([0.0, 1.0, 0.0])])
    extra: dict = {}

    if shape in ROUND_SHAPES:
        diameter, u, f = _round_args(shape, diameter, u, f)
        iso = rod_isovalue(diameter)
        canon = bent_rod_model(u, f) if u != 0.0 else rod_model()
        grad = 8.0 * np.pi * np.sin(np.pi * diameter)
        band = bent_rod_band(diameter, u)
        # minor phase along the placed axis: canonical z = s + 1/2 for s measured from centre
        extra = {"axis_offset": 0.5, "phase": 0.0}
        thin = None  # a round section: its diameter
    else:
        canon = _fixed_canonical(shape, minor_moment)
        iso = 0.0 if isovalue is None else float(isovalue)
        if canon.n_minor:
            u, f = float(canon.u[0]), float(canon.f[0])
            extra = {"axis_offset": 0.5, "phase": 2 * np.pi * f * float(canon.beta[0])}
        else:
            u, f = 0.0, 1.0
        diameter, grad = fixed_shape_scales(shape, u if canon.n_minor else None, iso)
        thin = fixed_shape_thin_width(shape, u if canon.n_minor else None, iso)
        band = None

    model = canon.translated(-_CELL_CENTRE).rotated(R).translated(center)
    return Fiber(
        shape=shape,
        model=model,
        isovalue=iso,
        diameter=float(diameter),
        center=center,
        direction=direction_vec,
        lattice=lattice,
        wave=R @ _X,
        u=float(u),
        f=float(f),
        grad_scale=float(grad),
        band_radius=band,
        theta=theta if direction is None else None,
        omega=omega if direction is None else None,
        thin_width=thin,
        extra=extra,
    )


def bent_rod_band(diameter: float, u: float) -> float:
    """Band radius of a (bent) rod: every solid point lies within it of the carrier axis."""
    return float(diameter / 2.0 + abs(u) / (2 * np.pi))


def _fixed_canonical(shape: str, minor_moment: float | None) -> GeneralizedPS:
    """The canonical (z-axis) model of a fixed shape, its bend moment set to ``minor_moment``
    (default: the equation's)."""
    canon = _FIXED_MODELS[shape]()
    if minor_moment is not None:
        if not canon.n_minor or not np.isfinite(minor_moment):
            raise ValueError(f"{shape} has no bend term; u must be 0 (got {minor_moment})")
        canon = canon._replace(u=[float(minor_moment)])
    return canon


@lru_cache(maxsize=4096)
def _fixed_shape_measures(
    shape: str, minor_moment: float | None, isovalue: float
) -> tuple[float, float, float]:
    """Diameter, field scale and thin width of a fixed shape (:func:`_measure_fixed_shape`
    on the canonical model with bend moment ``minor_moment``; None: the equation's). Cached
    (about 8 ms a call for a straight shape, 33 ms for a bent one)."""
    return _measure_fixed_shape(_fixed_canonical(shape, minor_moment), float(isovalue))


def fixed_shape_scales(
    shape: str, minor_moment: float | None, isovalue: float
) -> tuple[float, float]:
    """Nominal diameter and field scale (``grad_scale``) of a fixed shape, normalized.

    The one measurement of them (:func:`_measure_fixed_shape` on the canonical model with
    bend moment ``minor_moment``; None: the equation's): :func:`make_fiber`, the woven cell
    and :func:`with_minor_moment` all take it from here, so a fiber re-bent by the force field
    and the same fiber re-read from a spec have one field. Cached.
    """
    diameter, grad, _ = _fixed_shape_measures(shape, minor_moment, float(isovalue))
    return diameter, grad


def fixed_shape_thin_width(shape: str, minor_moment: float | None, isovalue: float) -> float:
    """Thin width of a fixed shape's section, normalized: at each measured height the
    narrower of its two widths across the centre line, averaged over the heights like the
    diameter (:func:`_measure_fixed_shape`, the same measurement, cached). The resolution
    measure of a non-round fiber (:func:`psdesign.geometry.rve.thinnest_fiber_diameter`):
    Eq. (19)'s woven yarn is 0.1399 thick (14.0 um at 100 um) beside its 0.1598 diameter.

    >>> round(fixed_shape_thin_width("woven", None, 0.0), 4)
    0.1399
    """
    return _fixed_shape_measures(shape, minor_moment, float(isovalue))[2]


def with_minor_moment(fb: Fiber, u: float) -> Fiber:
    """``fb`` with its bend moment set to ``u``, as :func:`make_fiber` builds it for ``u``.

    The placed model's minor moment is replaced (an amplitude: placement does not change it);
    a fixed shape's diameter and ``grad_scale`` are re-measured (:func:`fixed_shape_scales`),
    a bent rod's band radius follows ``u``. So the field of the result is the field of the
    fiber a spec with this ``u`` builds (to round-off), not the old field scale on a new solid.
    For the fibers :func:`make_fiber` and :func:`woven_cell` build (the equations' own models,
    as every spec does), not a fixed shape with other moments (the paper cases' own models).

    Raises
    ------
    ValueError
        If the fiber's model has no bend term.
    """
    if not fb.model.n_minor:
        raise ValueError(f"a {fb.shape} fiber has no bend term")
    u = float(u)
    model = fb.model._replace(u=[u])
    if fb.shape == "bent-rod":
        return replace(fb, model=model, u=u, band_radius=bent_rod_band(fb.diameter, u))
    diameter, grad = fixed_shape_scales(fb.shape, u, fb.isovalue)
    thin = fixed_shape_thin_width(fb.shape, u, fb.isovalue)
    return replace(fb, model=model, u=u, diameter=diameter, grad_scale=grad, thin_width=thin)


#: Heights (z = k / 7) at which :func:`_measure_fixed_shape` takes a cross-section.
MEASURE_STATIONS = 7
#: In-plane grid (per axis) whose lowest point starts the search for a bent section's centre.
_CENTRE_GRID = (np.arange(24) + 0.5) / 24
#: Step of the finite differences that give the bent centre line's tangent (normalized).
_TANGENT_STEP = 1e-5


def _section_centre(model: GeneralizedPS, z: float) -> np.ndarray:
    """Centre of the cross-section of a bent canonical fixed shape at height ``z``: the
    in-plane minimum of ``psi`` (the bend is a phase of the x term, so its minimum follows the
    centre line), from the lowest point of :data:`_CENTRE_GRID` (ties: nearest the cell centre).
    """
    from scipy.optimize import minimize

    X, Y = np.meshgrid(_CENTRE_GRID, _CENTRE_GRID, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, z)])
    low = model.evaluate(pts) + 1e-9 * np.sum((pts[:, :2] - 0.5) ** 2, axis=1)

    def f(xy: np.ndarray) -> tuple[float, np.ndarray]:
        p = np.array([[xy[0], xy[1], z]])
        return float(model.evaluate(p)[0]), model.gradient(p)[0][:2]

    res = minimize(f, pts[np.argmin(low), :2], jac=True, method="BFGS", options={"gtol": 1e-10})
    return np.array([res.x[0], res.x[1], z])


def _centre_tangent(model: GeneralizedPS, c: np.ndarray) -> np.ndarray:
    """Unit tangent of the centre line of :func:`_section_centre` at ``c``: it keeps
    ``d psi / dx = d psi / dy = 0``, so ``dc / dz = -H^-1 d(grad_xy psi) / dz`` (``H`` the
    in-plane Hessian; central differences of the gradient, one call)."""
    h = _TANGENT_STEP
    steps = np.vstack([np.eye(3) * h, -np.eye(3) * h])
    g = model.gradient(c[None] + steps)
    d = (g[:3] - g[3:]) / (2 * h)  # row i: d(grad psi) / d(coordinate i)
    hess = 0.5 * (d[:2, :2] + d[:2, :2].T)
    slope = -np.linalg.solve(hess, d[2, :2])
    t = np.array([slope[0], slope[1], 1.0])
    return t / np.linalg.norm(t)


def _measure_fixed_shape(model: GeneralizedPS, iso: float) -> tuple[float, float, float]:
    """Mean cross-section width, surface gradient and thin width of a canonical (z-axis)
    fixed shape.

    At :data:`MEASURE_STATIONS` heights: the widths through the section's centre along two
    directions perpendicular to the centre line, each by bisection to the surface on both
    sides (:func:`_section_widths`); the diameter is their mean, the field scale the mean
    surface gradient at their ends, the thin width the mean over the heights of the narrower
    of the two (a section with one closed width counts that one). A shape centred on the cell's
    axis (no bend term, ``psi`` stationary in x and y there, :func:`_centred_on_axis`): the
    cell centre and the x and y directions. A bent one, or one whose section lies off the axis
    (compressed-rod-a: centre near x = 0.44, wavering with z): the centre
    :func:`_section_centre` and the directions across the local tangent
    (:func:`_centre_tangent`): the x direction tilted with the bend and y. (Before session 42
    the bent shapes were measured like the straight ones: rays from the cell centre, which the
    bent centre line leaves, gave a chord off the axis and dropped the heights where the cell
    centre lies outside the fiber: the woven diameter fell 0.1302 at u = 0.46 and jumped to
    0.1465 at 0.47; before session 43 compressed-rod-a was measured from the cell centre,
    0.5353 against 0.5475 across its own centre.)
    """
    bent = bool(model.n_minor) or not _centred_on_axis(model)
    widths, thin, grads = [], [], []
    for z in np.linspace(0.0, 1.0, MEASURE_STATIONS, endpoint=False):
        if bent:
            c = _section_centre(model, z)
            t = _centre_tangent(model, c)
        else:
            c, t = np.array([0.5, 0.5, z]), _Z
        across = _X - t[0] * t
        across /= np.linalg.norm(across)
        w, g = _section_widths(model, iso, c, (across, np.cross(t, across)))
        widths += w
        grads += g
        if w:
            thin.append(min(w))
    if not widths:
        raise ValueError("isovalue gives no closed fiber cross-section around the cell centre")
    return float(np.mean(widths)), float(np.mean(grads)), float(np.mean(thin))


def _centred_on_axis(model: GeneralizedPS) -> bool:
    """Whether ``psi`` is stationary in x and y on the cell's axis at every height of
    :data:`MEASURE_STATIONS` (to 1e-9: round-off), i.e. the axis is the sections' centre line."""
    z = np.linspace(0.0, 1.0, MEASURE_STATIONS, endpoint=False)
    axis = np.column_stack([np.full_like(z, 0.5), np.full_like(z, 0.5), z])
    return bool(np.max(np.abs(model.gradient(axis)[:, :2])) < 1e-9)


def _section_widths(
    model: GeneralizedPS, iso: float, c: np.ndarray, directions: tuple
) -> tuple[list[float], list[float]]:
    """The section's widths through ``c`` along each of ``directions`` (bisection to the
    surface on both sides; a direction whose ray starts outside or does not leave the solid
    within half a period is skipped) and the surface gradient norms at the ends found."""
    from scipy.optimize import brentq

    widths, grads = [], []
    for e in directions:
        ends = []
        for sign in (-1.0, 1.0):

            def g(s, e=e, sign=sign):
                return model.evaluate((c + sign * s * e)[None])[0] - iso

            if g(0.0) > 0 or g(0.5) < 0:
                continue
            s = brentq(g, 0.0, 0.5, xtol=1e-12)
            ends.append(s)
            grads.append(np.linalg.norm(model.gradient((c + sign * s * e)[None])[0]))
        if len(ends) == 2:
            widths.append(sum(ends))
    return widths, grads


# -------------------------------------------------------------- woven cell (Table I)
#: Table I translation vectors (normalized) of the six woven fibers, as printed.
WOVEN_TABLE_I = np.array(
    [
        [0.41, -0.318, 0.0],
        [0.72, 0.0, 0.0],
        [0.41, 0.318, 0.0],
        [0.38, 0.204, 0.0],
        [0.33, -0.433, 0.0],
        [0.28, 0.204, 0.0],
    ]
)
#: Distance between adjacent parallel woven fibers (Table I rows 1-3; Sec. 6.2's translations
#: (0.45, -0.28), (0.45, 0.038), (0.45, 0.356): "the distances between adjacent fibers in both
#: directions are the same and fixed").
WOVEN_SPACING = 0.318


def woven_table_i() -> np.ndarray:
    """Table I as read by :func:`woven_cell` (normalized, in each fiber's own frame).

    Columns: along the fiber axis, across it in the fabric plane, through the fabric. Rows
    4 and 6 print the same lateral value 0.204, which puts two weft fibers on top of each
    other in every frame; the weft must be spaced like the warp (Sec. 6.2), and 0.204 =
    -0.433 + 2 x 0.318 (mod 1) is row 6's, so row 4's lateral value is read as
    -0.433 + 0.318 = -0.115. All other entries are used as printed.
    """
    t = WOVEN_TABLE_I.copy()
    t[3, 1] = t[4, 1] + WOVEN_SPACING
    return t


#: Sign of the Eq. (19) minor moment of the weft fibers (Table I rows 4-6). Across the cell the
#: wefts lie in the order row 6, row 4, row 5 (lateral 0.204, -0.115, -0.433 in their own frame,
#: i.e. x = 0.296, 0.615, 0.933 when the fabric is in the x-y plane); Sec. 6.2 asks adjacent
#: fibers in the same direction for opposite u, and of the two alternating choices this one
#: crosses every warp on the other side of it (the plain weave of Fig. 10; the other one puts
#: every weft on the warps' side). Row 5 alone flipped (the reading before 2026-12-01) leaves
#: row 6 on the warps' side at its three crossings (Omega 1.3 % instead of 0.6 %).
WOVEN_WEFT_SIGNS = (1.0, -1.0, -1.0)


def _woven_fiber(center: np.ndarray, R: np.ndarray, u: float) -> Fiber:
    """An Eq. (19) fiber (minor moment ``u``) turned by ``R`` and centred at ``center``."""
    base = woven_fiber_model(u=u, constant=-WOVEN_EQ19_ISOVALUE)
    model = base.translated(-_CELL_CENTRE).rotated(R).translated(center)
    diameter, grad = fixed_shape_scales("woven", float(u), 0.0)  # base is make_fiber's woven
    return Fiber(
        shape="woven",
        model=model,
        isovalue=0.0,
        diameter=diameter,
        center=np.asarray(center, float),
        direction=R @ _Z,
        lattice=np.array([R @ _X, R @ np.array([0.0, 1.0, 0.0])]),
        wave=R @ _X,
        u=float(u),
        f=float(WOVEN_EQ19["f"]),
        grad_scale=grad,
        band_radius=None,
        thin_width=fixed_shape_thin_width("woven", float(u), 0.0),
        extra={"axis_offset": 0.5, "phase": -np.pi / 2},
    )


def woven_cell_centre(edges_periods: np.ndarray) -> np.ndarray:
    """The woven cell's centre (normalized) in a box of ``edges_periods`` (its edges in periods):
    along each edge the nearest whole number of cells (at least one) is centred on the box,
    ``0.5 + (t - n) / 2`` with ``n = max(rint(t), 1)`` for an edge of ``t`` periods.

    An edge of whole periods keeps the cell centre at half a period (exactly 0.5: the cells tile
    the box, as the paper's Fig. 10 cell fills its cube); a shorter one, e.g. a box half a
    period thick, gets the cell centred on it, as every other shape defaults to the box centre
    (session 54: the cell stayed at half the period, so a 50 um box of a 100 um period held the
    lower half of every yarn, their centres on its top face). Rounding, not ceil: an edge a
    little over whole periods (1.2, 2.1) keeps its yarn layers whole and away from the faces
    (with ceil, 1.2 periods put a layer on both faces: porosity 0.899 -> 0.808).

    Parameters
    ----------
    edges_periods : array of 3 floats
        The box edges divided by the period.

    Returns
    -------
    numpy.ndarray
        The cell centre, normalized (``[0.5, 0.5, 0.5]`` for edges of whole periods).

    Examples
    --------
    >>> woven_cell_centre(np.array([1.0, 2.0, 0.5])).tolist()
    [0.5, 0.5, 0.25]
    """
    t = np.asarray(edges_periods, float).reshape(3)
    # size / period is off a whole or half period by an ulp (1e-5 / 2e-6 = 5.000000000000001,
    # 35e-6 / 1e-5 = 3.4999999999999996): snapped, so the same box in other units is placed alike
    halves = np.rint(2.0 * t) / 2.0
    t = np.where(np.isclose(t, halves, rtol=1e-9, atol=0.0), halves, t)
    n = np.maximum(np.floor(t + 0.5), 1.0)  # half periods round up (rint's half-to-even did not)
    return _CELL_CENTRE + (t - n) / 2.0


def woven_cell(
    thickness_axis: str = "z",
    layers: int = 1,
    layer_shift: tuple[float, float] = (0.0, 0.0),
    centre: np.ndarray | None = None,
) -> list[Fiber]:
    """Six-fiber plain-weave cell of Eq. (19) fibers placed by Table I (Fig. 10), stacked.

    Each fiber is Eq. (19) (axis along its own z, bend along its own x) placed as in Sec. 7.1:
    turned to run along x, with the bend through the fabric. Fibers 1-3 (warp) run along x,
    fibers 4-6 (weft) are rotated 90 degrees about the thickness axis and run along y. Table I
    (:func:`woven_table_i`) is read in each fiber's own frame before the rotation: (along the
    axis, across it, through the fabric), added to the cell centre. Rows 1-3 alternate their
    bend by the along-axis shift 0.72 - 0.41 = 0.31 (about half the bend wavelength 2/3);
    rows 4-6 do not (0.38, 0.33, 0.28), so adjacent wefts take opposite minor moments, as
    Sec. 6.2 requires ("opposite value of minor moment u"), with the signs
    :data:`WOVEN_WEFT_SIGNS` that interlace them with the warps.

    Parameters
    ----------
    thickness_axis : {"x", "z"}
        Through-fabric axis. ``"z"`` (default): fabric in the x-y plane. ``"x"``: the paper's
        Eq. (19) frame (bend along x).
    layers : int
        Fabric layers per period through the thickness (1 = the PS model's own period, the
        layer repeating every period; ``n`` stacks n copies at thickness offsets k/n).
    layer_shift : (float, float)
        In-plane shift (normalized) of layer k+1 relative to layer k (nesting), along the
        warp and weft axes.
    centre : array of 3 floats, optional
        The cell centre (normalized; :func:`woven_cell_centre` of the box); default half a
        period on every axis.
    """
    if thickness_axis not in ("x", "z"):
        raise ValueError(f"thickness_axis must be 'x' or 'z', got {thickness_axis!r}")
    if isinstance(layers, bool) or not isinstance(layers, int) or not 1 <= layers <= 8:
        raise ValueError(f"layers must be an integer in [1, 8], got {layers!r}")
    G = np.eye(3) if thickness_axis == "z" else rotation_matrix(theta_deg=90.0)
    R_warp = placement_rotation(0.0, 0.0)
    R_weft = placement_rotation(0.0, 90.0)
    rot90 = rotation_matrix(0.0, 90.0)  # own frame -> world frame of the weft
    table = woven_table_i()
    u0 = WOVEN_EQ19_U
    c0 = _CELL_CENTRE if centre is None else np.asarray(centre, float).reshape(3)
    fibers = []
    for k in range(layers):
        base = np.array([layer_shift[0] * k, layer_shift[1] * k, k / layers])
        for j in range(3):
            off = base + table[j]
            fibers.append(_woven_fiber(c0 + G @ off, G @ R_warp, u0))
        for j in range(3):
            off = base + rot90 @ table[3 + j]
            u = WOVEN_WEFT_SIGNS[j] * u0
            fibers.append(_woven_fiber(c0 + G @ off, G @ R_weft, u))
    return fibers
