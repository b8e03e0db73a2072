"""Numerical solvers (FEM and voxel Stokes, Laplace transport)."""

from solvers.voxel.threads import passive_wait, prefer_openmp

passive_wait()
prefer_openmp()
