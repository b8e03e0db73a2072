"""BLAS / LAPACK thread limit shared by the solvers (FEM Krylov loop, batched voxel thin-piece
inverses)."""

from __future__ import annotations

import contextlib


def single_thread_blas() -> contextlib.AbstractContextManager:
    """Context in which BLAS / LAPACK run on one thread (``threadpoolctl``; nothing without it).
    OpenBLAS threading costs more than it gives on small problems: the FEM Krylov loop's short
    vectors ran 6x slower with it, batched 64 x 64 eigenvalue problems (:mod:`solvers.voxel.thin`)
    90x slower on a loaded 2-core machine (0.09 vs 8 ms each)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - optional dependency
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")
