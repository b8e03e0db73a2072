"""Building blocks of the Taylor-Hood Stokes solver (see :mod:`solvers.fem_stokes`).

Modules
-------
boundary
    Matching tagged boundary triangles to mesh facets, slip-face axes, connectivity.
assembly
    Chunked, vectorized scikit-fem assembly of the scalar P2 Laplacian, the P1-P2 divergence
    blocks, the P1 pressure mass matrix and the boundary pressure loads.
linsolve
    Sparse direct solve for small systems; block-triangular GMRES (default) or block-diagonal
    MINRES (pyamg velocity AMG) for large ones.
memory
    Up-front memory estimate.
periodic
    Matching of opposite box faces and the periodic identification of P2 / P1 unknowns.
probe
    Point location (KD-tree + barycentrics) and P2/P1 evaluation for ``StokesResult.sample``.
meshes
    Small structured tetrahedral meshes with tagged facets for validation and benchmarks.
"""
