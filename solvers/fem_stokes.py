"""Stokes flow on tetrahedral meshes with Taylor-Hood (P2-P1) finite elements.

Geometry-agnostic: a tetrahedral mesh and named sets of boundary triangles go in; velocity and
pressure fields and the volumetric flow rate through each named boundary come out
(:func:`solve_stokes`, pressure-driven). :func:`solve_stokes_periodic` solves the same equations
periodic across opposite box faces, driven by a mean pressure gradient, and returns the
superficial mean velocity. ``StokesResult.dissipation`` integrates ``w mu |grad u|^2``.

Equations (steady incompressible Stokes, constant viscosity ``mu``)::

    -mu Laplace(u) + grad p = 0,   div u = 0            in the mesh
    mu du/dn - p n = -p_inlet n     on the inlet facets  (prescribed pressure, natural BC)
    mu du/dn - p n = -p_outlet n    on the outlet facets
    u = 0                           on no-slip facets (named in ``noslip`` and all untagged ones)
    u . n = 0, mu du_t/dn = 0       on slip facets (flat, axis-aligned symmetry planes)

Discretization: Taylor-Hood P2 velocity / P1 pressure (inf-sup stable), assembled with
scikit-fem (vectorized, chunked). Solver: sparse LU for small systems, otherwise GMRES with a
block upper-triangular preconditioner (pyamg smoothed aggregation per velocity component,
lumped pressure mass / viscosity for the Schur complement; ``krylov="minres"``: the
block-diagonal one with MINRES). See :mod:`solvers.fem` for the pieces.

The problem is solved in scaled variables (lengths by the mean edge length, pressure by
max(|p_inlet|, |p_outlet|), viscosity 1) so that tolerances do not depend on the SI
magnitudes (micrometre meshes, mu ~ 1e-5 Pa s); results are returned in SI units.
"""

from __future__ import annotations

import resource
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np
from skfem import ElementTetP2

from solvers.blas_threads import single_thread_blas
from solvers.fem import assembly
from solvers.fem.boundary import BoundaryTagError, match_rows, slip_axis, vertex_components
from solvers.fem.linsolve import SaddleSystem, solve_direct, solve_iterative
from solvers.fem.memory import (
    ELEMENTS,
    MemoryLimitError,
    default_limit_gb,
    estimate_memory_gb,
)
from solvers.fem.options import StokesOptions
from solvers.fem.periodic import (
    PeriodicMeshError,
    face_partners,
    identification,
    p2_representatives,
)
from solvers.fem.probe import PointLocator, p2_weights

__all__ = [
    "solve_stokes",
    "solve_stokes_periodic",
    "StokesOptions",
    "PeriodicMeshError",
    "StokesResult",
    "estimate_memory_gb",
    "MemoryLimitError",
    "BoundaryTagError",
    "DisconnectedDomainError",
]


class DisconnectedDomainError(ValueError):
    """No connected part of the mesh touches both the inlet and the outlet."""


@dataclass
class StokesResult:
    """Result of :func:`solve_stokes` (SI units).

    Attributes
    ----------
    flux : dict[str, float]
        Volumetric flow rate ``int u.n ds`` (m^3/s, outward normal positive) through the
        facets of each tag in ``facet_tags``.
    flux_imbalance : float
        ``|Q_inlet + Q_outlet| / |Q_inlet|`` (mass conservation check).
    converged : bool
        True if the true relative residual ``||b - K x|| / ||b||`` of the scaled linear system
        is <= ``tol``.
    iterations : int
        Krylov iterations (1 for the direct solve).
    residual : float
        That true relative residual.
    n_dofs : int
        Unknowns of the solved system (free velocity dofs + pressure dofs).
    n_tets, n_points : int
        Tetrahedra and vertices in the solve (after removing isolated parts).
    n_tets_removed : int
        Tetrahedra of connected parts touching neither inlet nor outlet (no flow; removed).
    wall_time_s : float
        Total time of :func:`solve_stokes`.
    peak_memory_gb : float
        Peak resident set size of the process so far (``getrusage`` high-water mark, GB).
    memory_estimate_gb : float
        The up-front estimate.
    velocity : ndarray (n, 3)
        Velocity at the input vertices (m/s); 0 at removed/unused vertices.
    pressure : ndarray (n,)
        Pressure at the input vertices (Pa); NaN at removed/unused vertices.
    method : str
        ``"direct"``, ``"gmres+amg-sa"`` (default iterative) or ``"minres+amg-sa"``.
    slip_axes : dict[str, int]
        Normal axis (0=x, 1=y, 2=z) found for each slip tag.
    timings : dict[str, float]
        Seconds spent in ``assembly``, ``solve`` and ``post`` (wall clock) and CPU seconds of
        the solve, ``solve_cpu`` (all threads of the process; independent of other jobs'
        load, unlike the wall clock).
    mean_velocity : ndarray (3,) or None
        :func:`solve_stokes_periodic` only: superficial mean velocity ``int u dV / V_box``
        (m/s), the Darcy velocity of the homogenized medium.
    """

    flux: dict[str, float]
    flux_imbalance: float
    converged: bool
    iterations: int
    residual: float
    n_dofs: int
    n_tets: int
    n_points: int
    n_tets_removed: int
    wall_time_s: float
    peak_memory_gb: float
    memory_estimate_gb: float
    velocity: np.ndarray
    pressure: np.ndarray
    method: str
    element: str = "taylor-hood"
    slip_axes: dict[str, int] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    mean_velocity: np.ndarray | None = None
    _state: dict = field(default_factory=dict, repr=False)

    def sample(self, xyz: np.ndarray, outside: str = "raise") -> tuple[np.ndarray, np.ndarray]:
        """Velocity (k, 3) and pressure (k,) of the finite element fields at points (k, 3).

        Parameters
        ----------
        xyz : (k, 3) array of points (m).
        outside : {"raise", "nan"}
            What to do with points outside the mesh (e.g. inside a fiber): raise
            ``ValueError`` or return NaN for them.
        """
        if outside not in ("raise", "nan"):
            raise ValueError(f"outside must be 'raise' or 'nan', got {outside!r}")
        x = np.atleast_2d(np.asarray(xyz, dtype=float))
        if x.ndim != 2 or x.shape[1] != 3:
            raise ValueError(f"xyz must have shape (k, 3), got {np.shape(xyz)}")
        st = self._state
        mesh = st["mesh"]
        if "locator" not in st:
            st["locator"] = PointLocator(mesh.p.T, mesh.t.T)
        cells, lam = st["locator"].locate((x - st["origin"]) / st["length"])
        inside = cells >= 0
        if not inside.all() and outside == "raise":
            raise ValueError(f"xyz: {int((~inside).sum())} point(s) lie outside the mesh")
        c, lam = cells[inside], lam[inside]
        w = p2_weights(mesh.t, mesh.edges, mesh.t2e, c, lam)
        nv = mesh.p.shape[1]
        dof = np.concatenate([mesh.t[:, c], nv + mesh.t2e[:, c]])  # (10, k)
        u = np.full((len(x), 3), np.nan)
        p = np.full(len(x), np.nan)
        u[inside] = np.einsum("jk,cjk->kc", w, st["u"][:, dof]) * st["u_scale"]
        p[inside] = np.einsum("kj,jk->k", lam, st["p"][mesh.t[:, c]]) * st["p_scale"]
        return u, p

    def dissipation(self, weight=None) -> float:
        """Weighted viscous dissipation ``int w mu |grad u|^2 dV`` of the fluid (W).

        Without a weight this is the power put in by the driving pressures or body force
        (``Q dp`` for a permeameter; the discrete Galerkin solution satisfies the identity to the
        solver tolerance). A weight selects part of the domain, e.g. a window over the RVE
        (:mod:`psdesign.flow.fem`). Integrated with a degree-4 rule (exact for a polynomial
        weight of degree <= 2 on each tetrahedron).

        Parameters
        ----------
        weight : callable, optional
            ``weight(xyz)`` for an (k, 3) array of points (m) returns (k,) weights.
        """
        st = self._state
        mesh = st["mesh"]

        def w_scaled(x: np.ndarray) -> np.ndarray:
            if weight is None:
                return np.ones(len(x))
            w = np.asarray(weight(st["origin"] + st["length"] * x), dtype=float)
            if w.shape != (len(x),) or not np.all(np.isfinite(w)):
                raise ValueError("weight must return one finite value per point")
            return w

        phi = assembly.weighted_dissipation(mesh, st["u"], w_scaled)
        return phi * st["p_scale"] ** 2 * st["length"] ** 3 / st["viscosity"]

    def plane_mean(self, axis: int, coord: float, n: int = 64) -> tuple[float, float]:
        """Mean pressure and mean normal velocity over the fluid part of a plane.

        The plane ``x[axis] = coord`` is sampled on an ``n x n`` grid of cell centres spanning
        the mesh's bounding box; points outside the mesh (solid) are skipped. This is a
        sampling approximation (error ~ 1/n of the plane-average variation).

        Returns
        -------
        (mean pressure (Pa), mean velocity component along ``axis`` over fluid points (m/s))
        """
        if axis not in (0, 1, 2):
            raise ValueError(f"axis must be 0, 1 or 2, got {axis}")
        if int(n) < 1:
            raise ValueError(f"n must be >= 1, got {n}")
        st = self._state
        lo = st["origin"]
        hi = lo + st["length"] * st["mesh"].p.max(axis=1)
        others = [a for a in (0, 1, 2) if a != axis]
        g = [lo[a] + (np.arange(n) + 0.5) / n * (hi[a] - lo[a]) for a in others]
        A, B = np.meshgrid(*g, indexing="ij")
        xyz = np.empty((A.size, 3))
        xyz[:, axis] = coord
        xyz[:, others[0]] = A.ravel()
        xyz[:, others[1]] = B.ravel()
        u, p = self.sample(xyz, outside="nan")
        if np.all(np.isnan(p)):
            raise ValueError(f"coord: the plane x[{axis}] = {coord} misses the mesh")
        return float(np.nanmean(p)), float(np.nanmean(u[:, axis]))


def _as_names(value, arg: str) -> tuple[str, ...]:
    if isinstance(value, str):
        return (value,)
    if isinstance(value, Iterable):
        names = tuple(value)
        if all(isinstance(n, str) for n in names):
            return names
    raise ValueError(f"{arg} must be a tag name or a sequence of tag names, got {value!r}")


def _check_mesh(points, tets, facet_tags, viscosity):
    """Checks shared by both solvers (one-line ``ValueError`` messages naming the argument)."""
    points = np.asarray(points, dtype=np.float64)
    tets = np.asarray(tets)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 4:
        raise ValueError(f"points must be an (n, 3) array with n >= 4, got shape {points.shape}")
    if not np.all(np.isfinite(points)):
        raise ValueError("points must be finite")
    if tets.ndim != 2 or tets.shape[1] != 4 or len(tets) < 1:
        raise ValueError(f"tets must be an (m, 4) integer array with m >= 1, got {tets.shape}")
    if not np.issubdtype(tets.dtype, np.integer):
        raise ValueError(f"tets must be integer, got dtype {tets.dtype}")
    if tets.min() < 0 or tets.max() >= len(points):
        raise ValueError(f"tets: vertex indices must lie in [0, {len(points) - 1}]")
    if not isinstance(facet_tags, Mapping):
        raise ValueError("facet_tags must be a dict {tag name: (k, 3) int array}")
    if not (np.isfinite(viscosity) and viscosity > 0):
        raise ValueError(f"viscosity must be > 0 (Pa s), got {viscosity}")
    return points, tets.astype(np.int64)


def _check_tags(facet_tags, n_points, inlet, outlet, noslip, slip):
    """Tag arrays as int64 (k, 3) and the boundary roles; each tag has at most one role."""
    tags = {}
    for name, tri in facet_tags.items():
        tri = np.asarray(tri)
        if tri.size == 0:
            tri = np.zeros((0, 3), dtype=np.int64)
        if tri.ndim != 2 or tri.shape[1] != 3 or not np.issubdtype(tri.dtype, np.integer):
            raise ValueError(f"facet_tags[{name!r}] must be a (k, 3) integer array")
        if len(tri) and (tri.min() < 0 or tri.max() >= n_points):
            raise ValueError(
                f"facet_tags[{name!r}]: vertex indices must lie in [0, {n_points - 1}]"
            )
        tags[name] = tri.astype(np.int64)
    noslip = _as_names(noslip, "noslip")
    slip = _as_names(slip, "slip")
    roles = {}
    for role, names in (
        ("inlet", (inlet,)),
        ("outlet", (outlet,)),
        ("noslip", noslip),
        ("slip", slip),
    ):
        for n in names:
            if n not in tags:
                raise ValueError(f"{role}: tag {n!r} is not in facet_tags (have {sorted(tags)})")
    if inlet == outlet:
        raise ValueError(f"inlet and outlet must be different tags, both are {inlet!r}")
    for n in (inlet, outlet):
        if len(tags[n]) == 0:
            raise ValueError(f"facet_tags[{n!r}] is empty: the {n} needs at least one facet")
    for role, names in (
        ("inlet", (inlet,)),
        ("outlet", (outlet,)),
        ("noslip", noslip),
        ("slip", slip),
    ):
        for n in names:
            if n in roles and roles[n] != role:
                raise ValueError(f"tag {n!r} is given two roles: {roles[n]} and {role}")
            roles[n] = role
    return tags, noslip, slip


def _check_drive(p_inlet, p_outlet, element):
    for name, val in (("p_inlet", p_inlet), ("p_outlet", p_outlet)):
        if not np.isfinite(val):
            raise ValueError(f"{name} must be finite, got {val}")
    if p_inlet == p_outlet:
        raise ValueError(f"p_inlet must differ from p_outlet (both {p_inlet}); no flow to solve")
    if element not in ELEMENTS:
        raise ValueError(f"element must be one of {ELEMENTS}, got {element!r}")


def _check_memory(n_points, n_tets, element, opts: StokesOptions) -> float:
    """The up-front memory estimate (GB); :class:`MemoryLimitError` above the limit."""
    est = estimate_memory_gb(n_points, n_tets, element)
    limit = default_limit_gb() if opts.max_memory_gb is None else float(opts.max_memory_gb)
    if est > limit and not opts.force:
        exc = MemoryLimitError(
            f"estimated memory {est:.3g} GB exceeds max_memory_gb={limit:.3g} GB "
            f"({n_tets} tets, {n_points} points); coarsen the mesh or pass force=True"
        )
        exc.estimate_gb, exc.limit_gb = est, limit
        raise exc
    return est


def _connected_part(n_points, tets, tags, inlet, outlet):
    """Tets of the parts touching inlet or outlet (others carry no flow, floating pressure).

    Returns ``(keep, used, old2new)``: the kept tets, the vertices they use and the map from
    input to kept vertex numbers (-1 for dropped ones).
    """
    _, labels = vertex_components(n_points, tets)
    c_in = np.unique(labels[tags[inlet][:, 0]])
    c_out = np.unique(labels[tags[outlet][:, 0]])
    if len(np.intersect1d(c_in, c_out)) == 0:
        raise DisconnectedDomainError(
            "disconnected pore space: no connected part of the mesh touches both the inlet "
            f"({inlet!r}) and the outlet ({outlet!r})"
        )
    keep = np.isin(labels[tets[:, 0]], np.union1d(c_in, c_out))
    used = np.unique(tets[keep])
    old2new = np.full(n_points, -1, dtype=np.int64)
    old2new[used] = np.arange(len(used))
    return keep, used, old2new


def _scaled_points(points, tets):
    """Coordinates in units of the mean edge length, from the lowest corner.

    Scaled lengths keep the tolerances independent of the SI magnitudes. Returns
    ``(x, origin, length)``.
    """
    origin = points.min(axis=0)
    e = points[tets[:, 1]] - points[tets[:, 0]]
    length = float(np.sqrt((e * e).sum(axis=1)).mean())
    if not length > 0:
        raise ValueError("points: the mesh has zero extent (degenerate tetrahedra)")
    return (points - origin) / length, origin, length


def _refuse_flat(x, tets):
    a, b, c, d = (x[tets[:, i]] for i in range(4))
    vol6 = np.abs(np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a))
    n_flat = int((vol6 <= 1e-12 * vol6.mean()).sum())
    if n_flat:
        raise ValueError(f"tets: {n_flat} degenerate (zero-volume) tetrahedra; fix the mesh")


def _tag_facets(mesh, tags, old2new) -> dict[str, np.ndarray]:
    """Facet indices of each tag's triangles (on the kept vertices); all must be boundary."""
    boundary = mesh.f2t[1] == -1
    tag_facets: dict[str, np.ndarray] = {}
    for name, tri in tags.items():
        tri_new = old2new[tri]
        tri_new = tri_new[(tri_new >= 0).all(axis=1)]
        idx = match_rows(mesh.facets.T, tri_new)
        bad = (idx < 0) | ~boundary[np.maximum(idx, 0)]
        if np.any(bad):
            raise BoundaryTagError(
                f"facet_tags[{name!r}]: {int(bad.sum())} of {len(idx)} triangles are not "
                "boundary facets of tets"
            )
        tag_facets[name] = np.unique(idx)
    return tag_facets


def _free_velocity_dofs(mesh, x, dofs2, n2, tag_facets, noslip, slip):
    """Free P2 dofs per velocity component and the normal axis of each slip tag.

    No-slip: the ``noslip`` tags and every untagged boundary facet (all three components);
    slip: the normal component on the tag's flat face.
    """
    probe = assembly.CellBasis(mesh, ElementTetP2(), intorder=2, elements=np.array([0]), dofs=dofs2)
    all_bnd = np.nonzero(mesh.f2t[1] == -1)[0]
    tagged = np.unique(np.concatenate([f for f in tag_facets.values()] + [np.zeros(0, int)]))
    untagged = np.setdiff1d(all_bnd, tagged)
    ns_facets = np.unique(np.concatenate([tag_facets[n] for n in noslip] + [untagged]))
    fixed_all = probe.get_dofs(facets=ns_facets).all() if len(ns_facets) else np.zeros(0, int)
    fixed = [fixed_all, fixed_all, fixed_all]
    slip_axes = {}
    for name in slip:
        f = tag_facets[name]
        if len(f) == 0:
            continue
        ax = slip_axis(x, mesh.facets[:, f].T, name)
        slip_axes[name] = ax
        fixed[ax] = np.union1d(fixed[ax], probe.get_dofs(facets=f).all())
    free = []
    for c in range(3):
        mask = np.ones(n2, dtype=bool)
        mask[fixed[c]] = False
        free.append(np.nonzero(mask)[0])
    return free, slip_axes


def _reduced_blocks(L, free):
    """Velocity blocks on each component's free dofs (shared when the free sets are equal)."""
    A_red = []
    for c in range(3):
        same = next((j for j in range(c) if np.array_equal(free[j], free[c])), None)
        A_red.append(A_red[same] if same is not None else L[free[c]][:, free[c]].tocsr())
    return A_red


def _assemble_pressure_driven(mesh, inlet_facets, outlet_facets, pin, pout, free, counted):
    """Reduced saddle system and right-hand side for the scaled inlet/outlet pressures
    (``counted``: the assembly's ``progress(elements_done, n_elements)``)."""
    L, D, m_lumped = assembly.assemble_volume(mesh, progress=counted)
    g_in = assembly.assemble_normal_load(mesh, inlet_facets)
    g_out = assembly.assemble_normal_load(mesh, outlet_facets)
    rhs_full = -(pin * g_in + pout * g_out)
    del g_in, g_out
    A_red = _reduced_blocks(L, free)
    del L
    D_red = [D[c][:, free[c]].tocsr() for c in range(3)]
    del D
    p_keep = _coupled_pressure(D_red)
    if not p_keep.all():
        D_red = [d[p_keep] for d in D_red]
        m_lumped = m_lumped[p_keep]
    b = np.concatenate([rhs_full[c][free[c]] for c in range(3)] + [np.zeros(len(m_lumped))])
    return SaddleSystem(A=A_red, D=D_red, m_lumped=m_lumped, viscosity=1.0), b, p_keep


def _coupled_pressure(D_red: list) -> np.ndarray:
    """Mask of the pressure vertices that meet a free velocity dof (a nonzero row of the
    divergence blocks ``D_red``).

    A vertex whose every tet has all its P2 velocity nodes fixed (e.g. a cap tet on a fibre
    wall: three no-slip faces, the fourth vertex in no other tet, as pytetwild leaves on
    square arrays at solid fraction 0.5) has a zero row: its pressure does not enter the
    equations, and keeping it made the saddle matrix exactly singular ("Factor is exactly
    singular" from SuperLU). Such vertices are left out of the solve (:func:`_unpack` gives
    them their tets' mean pressure)."""
    rows = sum(np.asarray(abs(d).sum(axis=1)).ravel() for d in D_red)
    top = float(rows.max(initial=0.0))
    return rows > 1e-12 * top if top > 0 else np.ones(len(rows), dtype=bool)


def _options(options: StokesOptions | None) -> StokesOptions:
    """``options`` or the defaults; anything else is refused in one line."""
    if options is None:
        return StokesOptions()
    if not isinstance(options, StokesOptions):
        raise ValueError(f"options must be a StokesOptions, got {type(options).__name__}")
    return options


def _say(stage: Callable[[str], None] | None, message: str) -> None:
    if stage is not None:
        stage(message)


def _p2_mesh(x, tets, opts: StokesOptions):
    """The scikit-fem mesh of the scaled tets and its P2 numbering ``(mesh, dofs2, n2)``: the
    first step of the assembly (announced to ``opts.stage``)."""
    _say(opts.stage, "assembling the system")
    mesh = assembly.make_mesh(x, tets)
    dofs2, n2 = assembly.p2_dofs(mesh)
    return mesh, dofs2, n2


def _solve_stage(system, opts: StokesOptions) -> str:
    """What :func:`_solve_system` does first, for the ``stage`` callback."""
    if system.n <= opts.direct_max_dofs:
        return f"sparse LU of {system.n} unknowns"
    return f"preconditioner set-up ({opts.amg.upper()} AMG), then {opts.krylov.upper()}"


def _solve_system(system, b, opts: StokesOptions):
    """Sparse LU for small systems, else the preconditioned Krylov solver (announced to
    ``opts.stage`` first).

    Returns ``(info, wall seconds, CPU seconds)``.
    """
    _say(opts.stage, _solve_stage(system, opts))
    t0 = time.perf_counter()
    c0 = time.process_time()
    if system.n <= opts.direct_max_dofs:
        info = solve_direct(system, b, opts.tol)
    else:
        with single_thread_blas():  # short vectors: BLAS threads cost
            info = solve_iterative(
                system,
                b,
                tol=opts.tol,
                max_iter=opts.max_iter,
                amg=opts.amg,
                krylov=opts.krylov,
                callback=opts.progress,
            )
    return info, time.perf_counter() - t0, time.process_time() - c0


@dataclass(frozen=True)
class _Scales:
    """Scaled-to-SI factors of one solve: x_SI = origin + length x, u_SI = u_scale u, ..."""

    origin: np.ndarray
    length: float
    u_scale: float
    p_scale: float
    viscosity: float


def _result(
    info, *, mesh, dofs2, u, p, scales, t_start, est, balance, timings, **fields
) -> StokesResult:
    """The :class:`StokesResult` of a finished solve; ``fields`` are the solver's own.

    ``balance``: the two ``flux`` names whose relative sum is ``flux_imbalance``; ``timings``:
    the assembly, solve (wall, CPU) and post-processing seconds.
    """
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e9
    state = {"mesh": mesh, "dofs2": dofs2, "u": u, "p": p, **vars(scales)}
    q_a, q_b = (fields["flux"][name] for name in balance)
    return StokesResult(
        converged=info.converged,
        iterations=info.iterations,
        residual=info.residual,
        n_dofs=int(len(info.x)),
        wall_time_s=time.perf_counter() - t_start,
        peak_memory_gb=peak,
        memory_estimate_gb=est,
        method=info.method,
        flux_imbalance=float(abs(q_a + q_b) / abs(q_a) if q_a != 0 else float("inf")),
        timings=dict(zip(("assembly", "solve", "solve_cpu", "post"), timings, strict=True)),
        _state=state,
        **fields,
    )


def solve_stokes(
    points: np.ndarray,
    tets: np.ndarray,
    facet_tags: Mapping[str, np.ndarray],
    *,
    inlet: str = "inlet",
    outlet: str = "outlet",
    p_inlet: float = 1.0,
    p_outlet: float = 0.0,
    viscosity: float = 1.0,
    noslip: Iterable[str] = ("wall",),
    slip: Iterable[str] = (),
    element: str = "taylor-hood",
    options: StokesOptions | None = None,
) -> StokesResult:
    """Solve steady Stokes flow driven by prescribed inlet/outlet pressures.

    (Twelve parameters: the mesh, then independent boundary knobs, keyword-only, like scipy's.)

    Parameters
    ----------
    points : (n, 3) float array
        Vertex coordinates (m).
    tets : (m, 4) int array
        Tetrahedra (any orientation).
    facet_tags : dict[str, (k, 3) int array]
        Boundary triangles by tag name (vertex order free). Every triangle must be a boundary
        facet of ``tets``. Boundary facets in no tag are no-slip walls.
    inlet, outlet : str
        Tags with prescribed pressure ``p_inlet`` / ``p_outlet`` (Pa), traction ``-p n``.
    p_inlet, p_outlet : float
        Pressures (Pa); must differ.
    viscosity : float
        Dynamic viscosity (Pa s), > 0.
    noslip : sequence of str
        Tags with u = 0 (e.g. fiber walls).
    slip : sequence of str
        Tags that are flat axis-aligned symmetry planes: u.n = 0, tangential traction free.
    element : {"taylor-hood"}
        P2 velocity / P1 pressure.
    options : StokesOptions, optional
        How it is solved: tolerance, linear solver, memory guard, progress callbacks.

    Returns
    -------
    StokesResult

    Raises
    ------
    ValueError
        Bad arguments; :class:`MemoryLimitError` when the estimate exceeds the limit;
        :class:`BoundaryTagError` when a tagged triangle is not a boundary facet or a slip face
        is not axis-aligned; :class:`DisconnectedDomainError` when no fluid path joins inlet
        and outlet.
    """
    t_start = time.perf_counter()
    opts = _options(options)
    points, tets = _check_mesh(points, tets, facet_tags, viscosity)
    tags, noslip, slip = _check_tags(facet_tags, len(points), inlet, outlet, noslip, slip)
    _check_drive(p_inlet, p_outlet, element)
    est = _check_memory(len(points), len(tets), element, opts)
    keep, used, old2new = _connected_part(len(points), tets, tags, inlet, outlet)
    tets_k = old2new[tets[keep]]
    x, scales = _scaled_pressure_driven(points[used], tets_k, p_inlet, p_outlet, viscosity)
    mesh, dofs2, n2 = _p2_mesh(x, tets_k, opts)
    tag_facets = _tag_facets(mesh, tags, old2new)
    free, slip_axes = _free_velocity_dofs(mesh, x, dofs2, n2, tag_facets, noslip, slip)

    t0 = time.perf_counter()
    drive = (p_inlet / scales.p_scale, p_outlet / scales.p_scale)
    system, b, p_keep = _assemble_pressure_driven(
        mesh, tag_facets[inlet], tag_facets[outlet], *drive, free, opts.assembly_progress
    )
    t_asm = time.perf_counter() - t0
    info, t_solve, c_solve = _solve_system(system, b, opts)
    del system
    t0 = time.perf_counter()
    u, p = _unpack(info.x, free, n2, p_keep, tets_k)
    flux, velocity, pressure = _on_vertices(mesh, u, p, tag_facets, scales, used, len(points))
    t_post = time.perf_counter() - t0
    return _result(
        info,
        mesh=mesh,
        dofs2=dofs2,
        u=u,
        p=p,
        scales=scales,
        t_start=t_start,
        est=est,
        balance=(inlet, outlet),
        timings=(t_asm, t_solve, c_solve, t_post),
        flux=flux,
        n_tets=int(len(tets_k)),
        n_points=int(len(used)),
        n_tets_removed=int((~keep).sum()),
        velocity=velocity,
        pressure=pressure,
        element=element,
        slip_axes=slip_axes,
    )


def _scaled_pressure_driven(points, tets, p_inlet, p_outlet, viscosity):
    """Scaled coordinates of the kept mesh (degenerate tets refused) and its
    :class:`_Scales` (pressure by max(|p_inlet|, |p_outlet|))."""
    x, origin, length = _scaled_points(points, tets)
    _refuse_flat(x, tets)
    p_scale = max(abs(p_inlet), abs(p_outlet))
    return x, _Scales(origin, length, p_scale * length / viscosity, p_scale, float(viscosity))


def _unpack(x, free, n2, p_keep=None, tets=None) -> tuple[np.ndarray, np.ndarray]:
    """Scaled ``(u (3, n2), p)`` from the solution vector (zero on the fixed velocity dofs);
    the pressure vertices left out of the solve (not in ``p_keep``, :func:`_coupled_pressure`)
    get the mean pressure of the solved vertices of their ``tets``."""
    parts = np.split(x, np.cumsum([len(f) for f in free]))
    u = np.zeros((3, n2))
    for c in range(3):
        u[c, free[c]] = parts[c]
    if p_keep is None or p_keep.all():
        return u, parts[3]
    p = np.zeros(len(p_keep))
    p[p_keep] = parts[3]
    solved = p_keep[tets]
    total = np.bincount(tets.ravel(), (p[tets] * solved).sum(axis=1).repeat(4), len(p_keep))
    count = np.bincount(tets.ravel(), solved.sum(axis=1).repeat(4), len(p_keep))
    lone = ~p_keep
    n_lone = int(lone.sum())
    p[lone] = np.divide(total[lone], count[lone], out=np.zeros(n_lone), where=count[lone] > 0)
    return u, p


def _on_vertices(mesh, u, p, tag_facets, scales, used, n_points):
    """SI ``(flux per tag, velocity (n_points, 3), pressure)`` of the scaled solution; the
    vertices of removed parts (not in ``used``) get zero velocity and NaN pressure."""
    q_scale = scales.u_scale * scales.length**2
    flux = {name: assembly.facet_flux(mesh, f, u) * q_scale for name, f in tag_facets.items()}
    velocity = np.zeros((n_points, 3))
    velocity[used] = u[:, : len(used)].T * scales.u_scale
    pressure = np.full(n_points, np.nan)
    pressure[used] = p * scales.p_scale
    return flux, velocity, pressure


def solve_stokes_periodic(
    points: np.ndarray,
    tets: np.ndarray,
    facet_tags: Mapping[str, np.ndarray] | None = None,
    *,
    axis: int,
    pressure_gradient: float = 1.0,
    viscosity: float = 1.0,
    periodic_axes: Iterable[int] = (0, 1, 2),
    slip: Iterable[str] = (),
    options: StokesOptions | None = None,
) -> StokesResult:
    """Stokes flow periodic across opposite box faces, driven by a mean pressure gradient.

    (Nine parameters: the mesh, then independent knobs of the solve, keyword-only, like scipy's.)

    Solves ``-mu Laplace(u) + grad p' = G e_axis``, ``div u = 0`` for the periodic velocity and
    the periodic pressure fluctuation ``p'`` (total pressure ``p' - G x_axis``), with u = 0 on
    every boundary facet that is not on a periodic box face (fiber walls) and not tagged in
    ``slip``. The box is the mesh's bounding box; the boundary triangles on the two faces
    normal to each periodic axis must be translates of each other.

    Parameters
    ----------
    points, tets
        The mesh (m); see :func:`solve_stokes`.
    facet_tags : dict, optional
        Boundary triangles by name; only the ``slip`` tags are used (periodic faces are found
        geometrically, all other boundary facets are no-slip).
    axis : int
        Direction of the driving mean pressure gradient (0, 1, 2).
    pressure_gradient : float
        ``G`` (Pa/m) > 0: the mean pressure decreases by ``G`` per metre along ``axis``.
    viscosity : float
        Pa s, > 0.
    periodic_axes : sequence of int
        Axes whose face pairs are identified (default all three).
    slip : sequence of str
        Tags of flat faces normal to a non-periodic axis with a symmetry condition.
    options : StokesOptions, optional
        How it is solved, as in :func:`solve_stokes`.

    Returns
    -------
    StokesResult
        ``mean_velocity``: the superficial mean velocity (m/s), ``int u dV / V_box``;
        ``flux``: flow rates (m^3/s, outward normal) through the two box faces normal to
        ``axis`` (``"x0"``, ``"x1"`` for axis 0); ``flux_imbalance`` their relative sum.

    Raises
    ------
    PeriodicMeshError
        Opposite faces do not match (the message names the face).
    ValueError
        Bad arguments, no no-slip facets (the periodic velocity would be undetermined).
    """
    t_start = time.perf_counter()
    opts = _options(options)
    points, tets = _check_mesh(points, tets, facet_tags or {}, viscosity)
    periodic_axes, slip, tags = _check_periodic(
        axis, pressure_gradient, periodic_axes, slip, facet_tags or {}
    )
    est = _check_memory(len(points), len(tets), ELEMENTS[0], opts)
    x, scales = _scaled_periodic(points, tets, pressure_gradient, viscosity)
    lo, length = scales.origin, scales.length
    mesh, dofs2, n2 = _p2_mesh(x, tets, opts)
    boundary = mesh.f2t[1] == -1
    P2, P1k, free, slip_axes = _periodic_constraints(mesh, x, tags, slip, periodic_axes, boundary)
    t0 = time.perf_counter()
    system, b, Pf, load = _assemble_periodic(mesh, P2, P1k, free, axis, opts.assembly_progress)
    t_asm = time.perf_counter() - t0
    info, t_solve, c_solve = _solve_system(system, b, opts)
    del system

    t0 = time.perf_counter()
    u, p = _unpack_periodic(info.x, free, Pf, P1k, n2)
    box = np.prod(points.max(axis=0) - lo)
    mean_u = np.array([load @ u[c] for c in range(3)]) * scales.u_scale * length**3 / box
    flux = _face_fluxes(mesh, x, boundary, u, axis, scales.u_scale * length**2)
    t_post = time.perf_counter() - t0
    return _result(
        info,
        mesh=mesh,
        dofs2=dofs2,
        u=u,
        p=p,
        scales=scales,
        t_start=t_start,
        est=est,
        balance=(f"{'xyz'[axis]}0", f"{'xyz'[axis]}1"),
        timings=(t_asm, t_solve, c_solve, t_post),
        flux=flux,
        n_tets=int(len(tets)),
        n_points=int(len(points)),
        n_tets_removed=0,
        velocity=(u[:, : len(points)].T * scales.u_scale).copy(),
        pressure=p * scales.p_scale,
        slip_axes=slip_axes,
        mean_velocity=mean_u,
    )


def _scaled_periodic(points, tets, pressure_gradient, viscosity):
    """Scaled coordinates (every vertex in a tet) and :class:`_Scales` with G = 1, mu = 1."""
    used = np.unique(tets)
    if len(used) != len(points):
        raise ValueError(f"points: {len(points) - len(used)} vertices belong to no tetrahedron")
    x, lo, length = _scaled_points(points, tets)
    u_scale = pressure_gradient * length**2 / viscosity  # scaled G = 1, mu = 1
    return x, _Scales(lo, length, u_scale, pressure_gradient * length, float(viscosity))


def _unpack_periodic(x, free, Pf, P1k, n2) -> tuple[np.ndarray, np.ndarray]:
    """Scaled ``(u (3, n2), p)`` on all P2 / P1 nodes from the free master unknowns."""
    parts = np.split(x, np.cumsum([len(f) for f in free]))
    u = np.zeros((3, n2))
    for c in range(3):
        u[c] = Pf[c] @ parts[c]
    return u, P1k @ parts[3]


def _check_periodic(axis, pressure_gradient, periodic_axes, slip, facet_tags):
    """The periodic solve's own arguments checked (one-line ``ValueError`` naming each).

    Returns ``(periodic_axes, slip, tags)``: the sorted axes, the slip tag names and the tag
    arrays as int64 (k, 3).
    """
    if axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0, 1 or 2, got {axis}")
    if not (np.isfinite(pressure_gradient) and pressure_gradient > 0):
        raise ValueError(f"pressure_gradient must be > 0 (Pa/m), got {pressure_gradient}")
    periodic_axes = tuple(sorted(set(int(a) for a in periodic_axes)))
    if not periodic_axes or any(a not in (0, 1, 2) for a in periodic_axes):
        raise ValueError(
            f"periodic_axes must be a non-empty subset of (0, 1, 2), got {periodic_axes}"
        )
    if axis not in periodic_axes:
        raise ValueError(f"axis {axis} must be one of the periodic_axes {periodic_axes}")
    slip = _as_names(slip, "slip")
    tags = {k: np.asarray(v, dtype=np.int64).reshape(-1, 3) for k, v in facet_tags.items()}
    for n in slip:
        if n not in tags:
            raise ValueError(f"slip: tag {n!r} is not in facet_tags (have {sorted(tags)})")
    return periodic_axes, slip, tags


def _face_fluxes(mesh, x, boundary, u, axis, q_scale) -> dict[str, float]:
    """Flow rates (outward normal) through the two box faces normal to ``axis``."""
    bfac = np.nonzero(boundary)[0]
    tri = mesh.facets[:, bfac].T
    flux = {}
    for side, val in (("0", x[:, axis].min()), ("1", x[:, axis].max())):
        on = np.all(np.abs(x[tri][:, :, axis] - val) <= 1e-7 * float(x.max()), axis=1)
        flux[f"{'xyz'[axis]}{side}"] = assembly.facet_flux(mesh, bfac[on], u) * q_scale
    return flux


def _periodic_constraints(mesh, x, tags, slip, periodic_axes, boundary):
    """Identification matrices and free dofs of the periodic solve.

    Returns ``(P2, P1k, free, slip_axes)``: the P2 prolongation (nodes x masters), the P1 one
    with the first master (pressure constant) removed, the free master indices per velocity
    component and the slip tag axes. Boundary facets off the periodic faces are no-slip
    unless tagged slip.
    """
    dofs2, _ = assembly.p2_dofs(mesh)
    bfac = np.nonzero(boundary)[0]
    tri = mesh.facets[:, bfac].T
    partners = face_partners(x, tri, periodic_axes, x.min(0), x.max(0))
    vrep, rep2 = p2_representatives(partners, mesh.edges)
    tol_x = 1e-7 * float(x.max())
    on_periodic = np.zeros(len(bfac), dtype=bool)
    for ax in periodic_axes:
        for val in (x[:, ax].min(), x[:, ax].max()):
            on_periodic |= np.all(np.abs(x[tri][:, :, ax] - val) <= tol_x, axis=1)
    probe = assembly.CellBasis(mesh, ElementTetP2(), intorder=2, elements=np.array([0]), dofs=dofs2)
    slip_facets = {}
    for name in slip:
        idx = match_rows(mesh.facets.T, tags[name])
        if np.any(idx < 0) or not boundary[np.maximum(idx, 0)].all():
            raise BoundaryTagError(f"facet_tags[{name!r}]: triangles are not boundary facets")
        slip_facets[name] = np.unique(idx)
    slip_all = np.concatenate([f for f in slip_facets.values()] + [np.zeros(0, int)])
    wall = np.setdiff1d(bfac[~on_periodic], slip_all)
    if len(wall) == 0:
        raise ValueError(
            "periodic: the mesh has no no-slip facets (no fibers); the periodic velocity is "
            "undetermined"
        )
    fixed_all = probe.get_dofs(facets=wall).all()
    fixed = [fixed_all, fixed_all, fixed_all]
    slip_axes = {}
    for name, f in slip_facets.items():
        ax = slip_axis(x, mesh.facets[:, f].T, name)
        if ax in periodic_axes:
            raise ValueError(f"slip: tag {name!r} lies on a periodic face (axis {'xyz'[ax]})")
        slip_axes[name] = ax
        fixed[ax] = np.union1d(fixed[ax], probe.get_dofs(facets=f).all())
    P2, masters2 = identification(rep2)
    P1, masters1 = identification(vrep)
    free = []
    for c in range(3):
        mask = np.ones(len(masters2), dtype=bool)
        mask[np.searchsorted(masters2, rep2[fixed[c]])] = False
        free.append(np.nonzero(mask)[0])
    return P2, P1[:, 1:], free, slip_axes


def _assemble_periodic(mesh, P2, P1k, free, axis, counted):
    """Reduced saddle system for a unit body force along ``axis`` (scaled units); ``counted``
    as in :func:`_assemble_pressure_driven`.

    Returns ``(system, b, Pf, load)``: the system, its right-hand side, the per-component
    prolongations from free masters to P2 nodes and the P2 volume load ``int phi dV``.
    """
    L, D, m_lumped = assembly.assemble_volume(mesh, progress=counted)
    load = assembly.assemble_volume_load(mesh)
    Lp = (P2.T @ L @ P2).tocsr()
    del L
    Pf = [P2[:, free[c]].tocsr() for c in range(3)]
    A_red = _reduced_blocks(Lp, free)
    del Lp
    D_red = [(P1k.T @ D[c] @ Pf[c]).tocsr() for c in range(3)]
    m_red = np.asarray(P1k.T @ m_lumped).ravel()
    rhs = [np.zeros(len(free[c])) for c in range(3)]
    rhs[axis] = np.asarray(Pf[axis].T @ load).ravel()
    b = np.concatenate(rhs + [np.zeros(P1k.shape[1])])
    return SaddleSystem(A=A_red, D=D_red, m_lumped=m_red, viscosity=1.0), b, Pf, load
