"""Voxel Laplace / two-phase conduction solver (knows nothing of fibres).

See :mod:`solvers.transport.laplace`.
"""

from solvers.transport.laplace import LaplaceResult, solve_laplace

__all__ = ["LaplaceResult", "solve_laplace"]
