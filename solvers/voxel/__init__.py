"""Kernels and multigrid for the staggered-grid (MAC) voxel Stokes solver (see
solvers.voxel_stokes)."""
