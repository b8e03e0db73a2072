"""Up-front memory estimate for the Taylor-Hood Stokes solve.

Model: the number of Taylor-Hood unknowns is about ``7 n_points + 3 n_tets`` (P2 nodes =
vertices + edges, edges ~ vertices + tets by Euler's formula; 3 velocity components + 1
pressure per vertex), and the peak resident memory is

    bytes = (BYTES_PER_DOF + KRYLOV_BYTES_PER_DOF) * (7 n_points + 3 n_tets)
            + BYTES_PER_CHUNK_TET * min(n_tets, 1e5) + BASE_BYTES

(matrices, three smoothed-aggregation hierarchies and work vectors per unknown; the GMRES
basis of up to ``DEFAULT_RESTART + 1`` vectors, :mod:`solvers.fem.linsolve`; temporary COO
arrays of one 100 k-element assembly chunk; interpreter and libraries). Calibrated on this
machine with ``benchmarks/bench_fem.py`` (structured cylinder-array meshes with 5.6 k to 1.07 M
unknowns, measured peak 0.10-1.17 GB; fTetWild fiber meshes with 0.15 M and 1.27 M unknowns,
0.47 and 1.52 GB; see benchmarks/RESULTS.md) and rounded up: the estimate exceeded every
measured peak, by 15-80 %. These were MINRES runs; the GMRES basis term was added when GMRES
became the default (Toray-like permeameter, 658 k unknowns, 128 iterations: peak 1.46 GB).
With GMRES it is an upper bound by more: on one cylinder in a 40 um cell (periodic and
permeameter, lattice 2 and 1.3 um) and a random 40 um RVE (3 copies stacked), 39-171 k tets,
41-86 iterations of the 201 vectors the basis term counts, the peak RSS was 39-61 % of this
estimate, i.e. the estimate is 63-159 % over (session 52 mendmesh, benchmarks/RESULTS.md).
It is not lowered: the default lattice step is sized by it
(:func:`psdesign.schema.budget.fem_lattice_step`), so a smaller figure would change the default
mesh, and K, of large RVEs. Refusals say "estimated (conservatively)"
(:data:`ESTIMATE_VERB`), not the need.
"""

from __future__ import annotations

import psutil

from solvers.fem.linsolve import DEFAULT_RESTART

ELEMENTS = ("taylor-hood",)

BYTES_PER_DOF = 1.5e3
BYTES_PER_CHUNK_TET = 3.0e3
CHUNK = 100_000
BASE_BYTES = 0.15e9
#: How a refusal states the estimate: an upper bound, not the measured need (session 52
#: walk-mesh finding 1: "needs about 1.17 GB" for a solve whose peak was 0.53 GB).
ESTIMATE_VERB = "is estimated (conservatively) to need"
#: The GMRES basis at its largest (``linsolve.DEFAULT_RESTART + 1`` float64 vectors).
KRYLOV_BYTES_PER_DOF = 8.0 * (DEFAULT_RESTART + 1)


class MemoryLimitError(ValueError):
    """The estimated memory of a solve exceeds the allowed limit (``estimate_gb`` and
    ``limit_gb``, GB of 1e9 bytes, when the solve's check raised it)."""

    estimate_gb: float | None = None
    limit_gb: float | None = None


def estimate_memory_gb(n_points: int, n_tets: int, element: str = "taylor-hood") -> float:
    """Estimated peak memory (GB, 1e9 bytes) of :func:`solvers.fem_stokes.solve_stokes`.

    Parameters
    ----------
    n_points : int
        Number of mesh vertices (>= 4).
    n_tets : int
        Number of tetrahedra (>= 1).
    element : str
        Only ``"taylor-hood"`` (P2-P1).

    Returns
    -------
    float
        Estimated peak resident memory in GB.
    """
    if element not in ELEMENTS:
        raise ValueError(f"element must be one of {ELEMENTS}, got {element!r}")
    if int(n_points) < 4 or int(n_tets) < 1:
        raise ValueError(
            f"n_points must be >= 4 and n_tets >= 1, got n_points={n_points}, n_tets={n_tets}"
        )
    dofs = 7.0 * n_points + 3.0 * n_tets
    per_dof = BYTES_PER_DOF + KRYLOV_BYTES_PER_DOF
    return (per_dof * dofs + BYTES_PER_CHUNK_TET * min(n_tets, CHUNK) + BASE_BYTES) / 1e9


def default_limit_gb() -> float:
    """80 % of the currently available RAM, in GB."""
    return 0.8 * psutil.virtual_memory().available / 1e9
