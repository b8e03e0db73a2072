"""How the Taylor-Hood Stokes solvers solve: tolerances, linear solver, memory guard, callbacks.

One :class:`StokesOptions` serves both :func:`solvers.fem_stokes.solve_stokes` and
:func:`solvers.fem_stokes.solve_stokes_periodic`; its ranges are checked once, on creation.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from solvers.fem.linsolve import KRYLOV

__all__ = ["StokesOptions"]


@dataclass(frozen=True)
class StokesOptions:
    """Solver settings of a Stokes solve (the physics is the solver's own arguments).

    Attributes
    ----------
    tol : float
        Relative residual ``||b - K x|| / ||b||`` of the (scaled) linear system to reach, in
        (0, 1); default 1e-8.
    max_iter : int
        Maximum Krylov iterations, >= 1; default 2000.
    direct_max_dofs : int
        Systems with at most this many unknowns use a sparse LU instead of the Krylov solver
        (measured on this machine: SuperLU needs 7 s for 12.6 k and 84 s for 31 k unknowns of
        an unstructured P2-P1 mesh, MINRES 3 s for the 31 k); default 8000.
    amg : {"sa", "rs"}
        pyamg smoothed aggregation (default) or Ruge-Stuben for the velocity blocks.
    krylov : {"gmres", "minres"}
        GMRES with the block-triangular preconditioner (default; stores up to
        :data:`solvers.fem.linsolve.DEFAULT_RESTART` Krylov vectors) or MINRES with the
        block-diagonal one (no stored basis, about 3x more iterations).
    max_memory_gb : float, optional
        Refuse the solve if :func:`solvers.fem.memory.estimate_memory_gb` (GB) exceeds this;
        default None: 80 % of the available RAM.
    force : bool
        Solve even if the estimate exceeds the limit; default False.
    progress : callable, optional
        ``progress(iteration, relative_residual)`` after each Krylov iteration (GMRES: its
        recurrence value of ``||b - K x|| / ||b||``, equal to the true one up to rounding;
        MINRES: NaN). Not called by the direct solver.
    stage : callable, optional
        ``stage(message)`` at the start of the long steps before the first iteration
        (assembly, then the preconditioner's set-up and the solve): 17 s at 1.4 M unknowns.
    assembly_progress : callable, optional
        ``assembly_progress(elements_done, n_elements)`` after each element batch of the
        volume assembly (14 s of those 17 s at 1.4 M unknowns), the last call with
        ``elements_done == n_elements``.

    Raises
    ------
    ValueError
        On creation, one line naming the field and its allowed values.

    Examples
    --------
    >>> StokesOptions(tol=1e-6, krylov="minres").max_iter
    2000
    >>> StokesOptions(tol=0.0)
    Traceback (most recent call last):
    ...
    ValueError: tol must lie in (0, 1), got 0.0
    """

    tol: float = 1e-8
    max_iter: int = 2000
    direct_max_dofs: int = 8_000
    amg: str = "sa"
    krylov: str = "gmres"
    max_memory_gb: float | None = None
    force: bool = False
    progress: Callable[[int, float], None] | None = None
    stage: Callable[[str], None] | None = None
    assembly_progress: Callable[[int, int], None] | None = None

    def __post_init__(self) -> None:
        if not (0 < self.tol < 1):
            raise ValueError(f"tol must lie in (0, 1), got {self.tol}")
        if int(self.max_iter) < 1:
            raise ValueError(f"max_iter must be >= 1, got {self.max_iter}")
        if self.amg not in ("sa", "rs"):
            raise ValueError(f"amg must be 'sa' or 'rs', got {self.amg!r}")
        if self.krylov not in KRYLOV:
            raise ValueError(f"krylov must be one of {KRYLOV}, got {self.krylov!r}")
