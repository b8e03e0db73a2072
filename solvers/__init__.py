"""Numerical solvers (FEM and voxel Stokes, Laplace transport).

Importing the package (``import psdesign`` does) sets the process's thread policies once, before
any numba parallel region or BLAS call.
"""

from solvers.blas_threads import default_blas_threads
from solvers.voxel.threads import passive_wait, prefer_openmp

passive_wait()  # idle OpenMP threads sleep, never spin
prefer_openmp()  # the layer the thread policy was measured on, also where libtbb is installed
default_blas_threads()  # BLAS on one thread unless the user set a *_NUM_THREADS variable
