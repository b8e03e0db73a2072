"""Up-front memory estimate for the Taylor-Hood Stokes solve.

Model: the number of Taylor-Hood unknowns is about ``7 n_points + 3 n_tets`` (P2 nodes =
vertices + edges, edges ~ vertices + tets by Euler's formula; 3 velocity components + 1
pressure per vertex, :func:`unknowns`), and the peak resident memory is at most

    bytes = BASE_BYTES + (BYTES_PER_DOF + KRYLOV_BYTES_PER_DOF) * unknowns

``BASE_BYTES``: the interpreter, numpy / scipy / numba / pyamg / scikit-fem and the RVE's fields
before the solve (0.24-0.43 GB measured as the solves of up to 2.2 M unknowns start);
``BYTES_PER_DOF``: what the solve holds per unknown besides the Krylov basis (the assembled and
reduced matrices, three smoothed-aggregation hierarchies, work vectors: 580-920 B measured as
GMRES starts) and what grows with the RVE before it (the stack's fields and the mesh: 1.19 GB as
a 3.4 M-unknown solve starts; 0.73-0.77 GB in an ``auto`` stack's later solve, which reuses what
the earlier one freed); ``KRYLOV_BYTES_PER_DOF``: the GMRES basis at its largest,
``DEFAULT_RESTART + 1`` float64 vectors (:mod:`solvers.fem.linsolve`). A solve of ``k``
iterations touches ``k + 1`` of them, so the peak is that much under the figure; the iterations
are not known before the solve and the restart is what bounds them, so the figure counts the
full basis (an upper bound, not the need: :data:`ESTIMATE_VERB`). The assembly (its transient
COO chunk of at most 100 k elements) and the post-solve flux and dissipation integrals come
before and after the basis and peak below it (the assembly was the peak of two of the measured
solves, by less than the basis they did not use), so they add nothing (until session 54 a chunk
term of 3 kB per tet, up to 0.3 GB, was added on top).

Calibrated in session 54 (benchmarks/RESULTS.md "Session 54: femmem", ``/usr/bin/time -v`` of
``psdesign permeability``): with the ``k + 1`` basis vectors a solve of ``k`` iterations used in
place of the full basis, the model is 1.05-1.24 x the whole-process peak RSS, never under it, on
one cylinder in a 40 um cell (periodic and permeameter, lattice 2 and 1.3 um) and a random 40 um
RVE (3 copies stacked: ``auto``, 2 then 3, at lattice 2 and 1.3 um; given, at 1.1 um): 0.18-3.4
M unknowns, 41-99 iterations, peak 0.50-5.3 GB. The estimate itself (the full basis) is
1.50-2.07 x those peaks; it was 1.62-2.58 x with 3.1 kB per unknown and 0.45 GB (session 52
mendmesh), whose 0.15 GB base was under the imports alone (a 7340-tet solve: estimate 0.278 GB,
peak 0.33 GB, session 42). The default lattice step, which is sized by this estimate, keeps its
meshes on machines of 23.6 GB or more (:data:`psdesign.schema.budget.DEFAULT_STEP_UNKNOWNS`);
on smaller ones, where half the machine bounds the step, the step is now finer than before.
``BASE_BYTES`` covers fields of the measured size (0.24-1.19 GB); a much finer voxel grid than the
lattice (e.g. 0.25 um voxels under a 6 um lattice: 1.26 GB peak against a 0.42 GB estimate) is
not counted.
"""

from __future__ import annotations

import psutil

from solvers.fem.linsolve import DEFAULT_RESTART

ELEMENTS = ("taylor-hood",)

#: Matrices, AMG hierarchies and work vectors per unknown (session 54, see the module).
BYTES_PER_DOF = 900.0
#: Imports and the RVE's fields before the solve (session 54, see the module).
BASE_BYTES = 0.35e9
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
    return estimate_bytes(unknowns(int(n_points), int(n_tets))) / 1e9


def unknowns(n_points: int, n_tets: int) -> int:
    """Taylor-Hood unknowns of a mesh, ``7 n_points + 3 n_tets`` (see the module).

    >>> unknowns(9242, 44248)
    197438
    """
    return 7 * int(n_points) + 3 * int(n_tets)


def estimate_bytes(n_unknowns: float) -> float:
    """Estimated peak bytes of a solve of ``n_unknowns`` Taylor-Hood unknowns (see the module):
    the one formula of :func:`estimate_memory_gb` and of the default lattice step's budget
    (:data:`psdesign.schema.budget.DEFAULT_STEP_BUDGET`)."""
    return BASE_BYTES + (BYTES_PER_DOF + KRYLOV_BYTES_PER_DOF) * float(n_unknowns)


def default_limit_gb() -> float:
    """80 % of the currently available RAM, in GB."""
    return 0.8 * psutil.virtual_memory().available / 1e9
