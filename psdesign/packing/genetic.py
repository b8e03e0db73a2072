"""``ga`` intersection removal: the paper's genetic algorithm over the Sec. 7.1 adjustment ranges.

theta and omega +-1 deg, translations +-0.1 of the RVE edge, u in [0.1, 0.3] and f in [1, 10] for
bent fibers. The objective is Omega (Eq. 8-9): either an analytic estimate from the centre lines
(pairwise crossing volume ``int w_i(z) w_j(z) dz / sin(alpha)`` of two cylinders at axis distance
d and angle alpha), or the voxel count of Eq. (8) on a coarse grid (``objective="voxel"``, as the
paper).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from psdesign.packing.fiberset import FiberState, find_contacts
from psdesign.packing.ga_settings import GASettings

# ------------------------------------------------------------------- objectives
#: Gauss-Legendre nodes of :func:`crossing_volume`.
GL_NODES = 8
_GL_X, _GL_W = np.polynomial.legendre.leggauss(GL_NODES)


def crossing_volume(
    dist, ri, rj, sin_alpha, max_len: float = 1.0, n_gl: int = GL_NODES
) -> np.ndarray:
    """Intersection volume of two cylinders crossing at angle alpha, axes ``dist`` apart.

    ``V = int w_i(z) w_j(z) dz / sin(alpha)`` with chord widths ``w = 2 sqrt(r^2 - z^2)``
    (exact for infinite cylinders; 16 r^3 / 3 for the Steinmetz solid), by ``n_gl``-point
    Gauss-Legendre quadrature (the force field's relax route evaluates it again at
    ``n_gl // 2`` for its error bar). Near-parallel pairs are capped by an overlap length
    ``max_len``.
    """
    gl_x, gl_w = _GL_X, _GL_W
    if n_gl != GL_NODES:
        gl_x, gl_w = np.polynomial.legendre.leggauss(n_gl)
    dist, ri, rj = (np.asarray(v, float) for v in (dist, ri, rj))
    za = np.maximum(-ri, dist - rj)
    zb = np.minimum(ri, dist + rj)
    ok = zb > za
    half = 0.5 * (zb - za)
    mid = 0.5 * (zb + za)
    z = mid[:, None] + half[:, None] * gl_x[None, :]
    wi = 2 * np.sqrt(np.clip(ri[:, None] ** 2 - z**2, 0, None))
    wj = 2 * np.sqrt(np.clip(rj[:, None] ** 2 - (z - dist[:, None]) ** 2, 0, None))
    integral = half * np.sum(gl_w * wi * wj, axis=1)
    width = np.minimum(2 * ri, 2 * rj)
    s = np.maximum(np.abs(sin_alpha), width / max_len)
    return np.where(ok, integral / s, 0.0)


def analytic_omega(st: FiberState, lo: np.ndarray, hi: np.ndarray, n_gl: int = GL_NODES) -> float:
    """Estimated intersection volume fraction of the box from the centre lines
    (:func:`crossing_volume` with ``n_gl`` nodes per crossing), the GA's and the relax route's
    objective; its bar and status: :func:`psdesign.packing.overlap_status.rated_analytic_omega`."""
    c = find_contacts(st, lo, hi, 0.0)
    if len(c) == 0:
        return 0.0
    return float(contact_volumes(st, c, n_gl).sum() / np.prod(hi - lo))


def contact_volumes(st: FiberState, c, n_gl: int = GL_NODES) -> np.ndarray:
    """The crossing volume of each contact ``c`` of :func:`find_contacts` (normalized units:
    :func:`crossing_volume` of the two nominal circles at the centre lines' distance)."""
    sin_a = np.linalg.norm(np.cross(c.di, c.dj), axis=1)
    return crossing_volume(c.dist, 0.5 * st.diameter[c.i], 0.5 * st.diameter[c.j], sin_a, n_gl=n_gl)


# --------------------------------------------------------------------- the GA
@dataclass
class GAResult:
    """Outcome of :func:`genetic`."""

    state: FiberState
    objective_initial: float
    objective_final: float
    generations: int
    evaluations: int
    wall_time_s: float
    history: list = field(default_factory=list)


def ga_progress(
    generations: int, objective: str, rounds: list[int] | None = None
) -> Callable[[int, float], None] | None:
    """Throttled ``report(generation, best)`` of a GA on the command's printer (None without
    one): ``psdesign: fiber placement (GA): generation g of G, overlap O (objective), T s``.
    One callback for several GA runs (the porosity rounds; ``rounds[0]`` is the current one,
    named in the line) keeps the throttle across them: a new one per round printed nothing
    in a GA of rounds shorter than the throttle's 5 s."""
    from psdesign import progress

    def label() -> str:
        return "GA" if rounds is None else f"GA round {rounds[0]}"

    return progress.throttled(
        lambda s, g, best: (
            f"psdesign: fiber placement ({label()}): generation {g} of {generations}, "
            f"overlap {best:.2e} ({objective}), {s:.0f} s"
        )
    )


def genetic(
    st: FiberState,
    lo: np.ndarray,
    hi: np.ndarray,
    size_norm: np.ndarray,
    settings: GASettings | None = None,
    *,
    seed: int = 0,
    report: Callable[[int, float], None] | None = None,
) -> GAResult:
    """Real-coded genetic algorithm over the Sec. 7.1 adjustments (paper Eq. 9).

    Genes per movable fiber: theta and omega adjustments in ``+-angle_range_deg``,
    translation adjustments in ``+-shift_range`` of the RVE edge, and for bent fibers the
    absolute ``u`` and ``f`` in their ranges. Tournament selection, uniform crossover
    per fiber, Gaussian mutation, elitism; the unchanged state is in the first generation.

    Parameters
    ----------
    st : FiberState
        The fibers; the fixed ones are not moved.
    lo, hi : np.ndarray
        The box (normalized).
    size_norm : np.ndarray
        The RVE edges in the normalized unit (the translation scale).
    settings : GASettings, optional
        Adjustment ranges, population, generations, mutation, objective, time limit
        (default: ``GASettings()``).
    seed : int
        Seed of the GA's random generator (same seed, same result).
    report : callable, optional
        ``report(generation, best)`` after each generation (default: :func:`ga_progress`).
    """
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    settings = GASettings() if settings is None else settings
    genome = _Genome(st, size_norm, settings)
    cost = _objective(genome, settings, lo, hi)
    population = settings.population
    g0 = genome.start()
    pop = np.clip(g0 + rng.normal(0, 0.5, (population, g0.size)), -1, 1)
    pop[0] = g0
    fit = np.array([cost(g) for g in pop])
    evals = population
    f_init = float(fit[0])
    history = [float(fit.min())]
    gen = 0
    if report is None:
        report = ga_progress(settings.generations, settings.objective)
    for _ in range(settings.generations):
        if fit.min() <= 0.0 or _out_of_time(t0, settings.time_limit_s):
            break
        pop, fit = _next_generation(pop, fit, rng, genome.n_movable, settings, cost)
        evals += population - 2
        gen += 1
        history.append(float(fit.min()))
        if report is not None:
            report(gen, history[-1])
    best = int(np.argmin(fit))
    return GAResult(
        state=genome.decode(pop[best]),
        objective_initial=f_init,
        objective_final=float(fit[best]),
        generations=gen,
        evaluations=evals,
        wall_time_s=time.perf_counter() - t0,
        history=history,
    )


#: Genes per movable fiber: theta, omega, tx, ty, tz, u, f (u, f unused for straight fibers).
N_GENES = 7


class _Genome:
    """The genes of a fiber set's movable fibers (each in [-1, 1]) and the set they stand for."""

    def __init__(self, st: FiberState, size_norm: np.ndarray, settings: GASettings):
        self.st, self.size_norm, self.settings = st, size_norm, settings
        self.mov = np.flatnonzero(~st.fixed)
        self.bent = st.u[self.mov] != 0.0
        self.n_movable = len(self.mov)

    def decode(self, g: np.ndarray) -> FiberState:
        """The fiber set of the genes ``g`` (flat, ``N_GENES`` per movable fiber)."""
        st, mov, bent, opt = self.st, self.mov, self.bent, self.settings
        s = st.copy()
        g = g.reshape(self.n_movable, N_GENES)
        s.theta[mov] = st.theta[mov] + opt.angle_range_deg * g[:, 0]
        s.omega[mov] = st.omega[mov] + opt.angle_range_deg * g[:, 1]
        s.center[mov] = st.center[mov] + opt.shift_range * g[:, 2:5] * self.size_norm
        if np.any(bent):
            b = mov[bent]
            u_range, f_range = opt.u_range, opt.f_range
            s.u[b] = u_range[0] + (u_range[1] - u_range[0]) * 0.5 * (g[bent, 5] + 1)
            s.f[b] = f_range[0] + (f_range[1] - f_range[0]) * 0.5 * (g[bent, 6] + 1)
        s.refresh_frames()
        return s

    def start(self) -> np.ndarray:
        """The genes of the unchanged set (flat): zero adjustments, the drawn ``u``, ``f``."""
        st, mov, bent = self.st, self.mov, self.bent
        u_range, f_range = self.settings.u_range, self.settings.f_range
        g0 = np.zeros((self.n_movable, N_GENES))
        if np.any(bent):
            b = mov[bent]
            g0[bent, 5] = np.clip(2 * (st.u[b] - u_range[0]) / (u_range[1] - u_range[0]) - 1, -1, 1)
            g0[bent, 6] = np.clip(2 * (st.f[b] - f_range[0]) / (f_range[1] - f_range[0]) - 1, -1, 1)
        return g0.ravel()


def _objective(
    genome: _Genome, settings: GASettings, lo: np.ndarray, hi: np.ndarray
) -> Callable[[np.ndarray], float]:
    """Omega of the set a genome stands for: analytic, or counted on a voxel grid."""
    if settings.objective == "voxel":
        from psdesign.geometry.rve import RVE

        voxel = settings.voxel
        if voxel is None:
            raise ValueError("voxel objective needs a voxel step")

        def cost(g: np.ndarray) -> float:
            s = genome.decode(g)
            rve = RVE(hi - lo, s.to_fibers(), period=1.0)
            return rve.voxelize(voxel).intersection_volume_fraction

        return cost
    if settings.objective == "analytic":

        def cost(g: np.ndarray) -> float:
            return analytic_omega(genome.decode(g), lo, hi)

        return cost
    raise ValueError(f"objective must be 'analytic' or 'voxel', got {settings.objective!r}")


def _out_of_time(t0: float, time_limit_s: float | None) -> bool:
    """True when a time limit is set and the run has used it up."""
    return time_limit_s is not None and time.perf_counter() - t0 > time_limit_s


def _next_generation(
    pop: np.ndarray,
    fit: np.ndarray,
    rng: np.random.Generator,
    nm: int,
    settings: GASettings,
    cost: Callable[[np.ndarray], float],
) -> tuple[np.ndarray, np.ndarray]:
    """One generation: the two best kept (elitism), the rest by tournament selection, uniform
    crossover per fiber and Gaussian mutation; the new population and its objective values."""
    population = settings.population
    elite = np.argsort(fit)[:2]
    children = [pop[e].copy() for e in elite]
    while len(children) < population:
        a, b = (min(rng.integers(0, population, 2), key=lambda k: fit[k]) for _ in range(2))
        mask = np.repeat(rng.random(nm) < 0.5, N_GENES)
        child = np.where(mask, pop[a], pop[b])
        mut = rng.random(child.size) < max(1.0 / nm, 0.02)
        child = np.clip(child + mut * rng.normal(0, settings.mutation_sigma, child.size), -1, 1)
        children.append(child)
    pop = np.array(children)
    return pop, np.r_[fit[elite], [cost(g) for g in pop[2:]]]
