"""Numerical solvers (FEM and voxel Stokes, Laplace transport)."""

from solvers.voxel.threads import passive_wait

passive_wait()
