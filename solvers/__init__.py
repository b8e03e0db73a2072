"""Numerical solvers (FEM and voxel Stokes, Laplace transport)."""

from solvers.blas_threads import default_blas_threads
from solvers.voxel.threads import passive_wait, prefer_openmp

passive_wait()
prefer_openmp()
default_blas_threads()
