"""Numba kernels of the MAC (staggered) voxel Stokes solver (see :mod:`solvers.voxel_stokes`).

Layout (all arrays C-ordered, indexed ``[i, j, k]`` = ``[x, y, z]``, periodic, voxel units h = 1,
unit viscosity):

* ``solid[i, j, k]``: uint8, 1 = solid cell.
* velocity component ``a`` lives on the faces normal to ``a``; ``q_a[i, j, k]`` is the face
  between cells ``(i, j, k) - e_a`` and ``(i, j, k)``.  A face is *active* (an unknown) when both
  of its cells are fluid; inactive entries are kept at 0.
* ``p[i, j, k]``: pressure at fluid cell centres (0 in solid cells).

Scalar operators (one per velocity component, and the Galerkin coarse operators of the
multigrid) are 7-point stencils stored as ``diag[i, j, k]`` and the couplings ``cx, cy, cz``
between unknown ``(i, j, k)`` and its *lower* neighbour along x, y, z (periodic):
``(A x)_I = diag_I x_I - sum_b (c_b[I] x[I - e_b] + c_b[I + e_b] x[I + e_b])``.
An unknown with ``diag == 0`` is inactive.  Finest-level coefficients are small integers
(uint8); coarse ones float32.  The symmetric saddle-point system is::

    [ A  G ] [q]   [f]        A = -Laplacian (per component, no-slip on solid faces)
    [ G' 0 ] [p] = [0]        (G p)_face = p[i] - p[i - e_a],  G' = -div
"""

from __future__ import annotations

import numba as nb
import numpy as np

from solvers.jit import SerialHelpers, parallel_kernel
from solvers.reduction import ordered_sum
from solvers.voxel import simd

_OPTS = {"cache": True, "fastmath": True, "nogil": True, "error_model": "numpy"}
"""Options of every kernel.  The big Stokes kernels (``stokes_residual``,
``stokes_lanczos`` in :mod:`solvers.voxel.lanczos`) and ``galerkin`` are split in two: a
serial ``@njit(**_OPTS)`` *slab* function (one iteration of the outer loop, an x-plane or a
coarse x-plane, with every row helper inlined into it) and the
:func:`~solvers.jit.parallel_kernel` that loops over the slabs (``prange``).  numba's parfor
passes then see a loop of a few statements instead of the whole inlined body (they cost 2-3
times the serial compile of what they see), and the parallel kernel and its serial twin call
the same compiled slab.  The loop index is passed as ``np.int64`` (a ``prange`` index is
unsigned, a ``range`` index signed, which would be two signatures).  The multigrid smoothing
kernels (``jacobi``, ``jacobi2_zero``, ``prolong_jacobi``, ``residual_restrict``,
``lap_residual``) keep their body inside the ``prange`` loop: split the same way they ran
1.13-1.5x slower on two threads (the code numba compiles into the parfor gufunc is faster than
the same code as a plain function; ``benchmarks/RESULTS.md``), except ``jacobi2_zero`` and
``prolong_jacobi``, whose parallel twins call one chunk body compiled over the serial helpers
(:meth:`solvers.jit.SerialHelpers.shared`: their parallel compile 26-31 -> 2-5 s per
signature, their two-thread speed within the noise, session 50).  ``error_model="numpy"``: no
zero-divisor check (and exception path) in the vectorised loops; no kernel divides by zero.
``jacobi``, ``jacobi2_zero`` and ``prolong_jacobi`` are compiled with ``noalias=True``
(:class:`solvers.jit.NoAliasCompiler`, serial twins only; their callers never pass an output
that overlaps an input) and take flat views with :func:`solvers.voxel.simd.flat`: LLVM then
drops the run-time overlap checks it put in front of every 64-cell block of the flat sweeps
(0.91-0.93x their one-thread CPU at 200^3, ``benchmarks/RESULTS.md``, band20).  The three
must stay bitwise one operator (the V-cycle's symmetry; ``tests/unit/test_voxel_kernels.py``),
which is why ``jacobi``'s row loops hide the arguments behind a reshape and
``residual_restrict`` (whose
flat loop kept its checks: its output is a local buffer) is compiled without it."""

_SERIAL = SerialHelpers(**_OPTS)
"""The helpers' variants in the serial twins (:class:`solvers.jit.SerialHelpers`): the
one-line ``leaf`` helpers are plain ``@njit`` functions there, with the kernels' options
(:data:`_OPTS` without the disk cache: the same fast-math flags and error model as when they
are inlined), so the serial twins compile in a fraction of the time; the parallel kernels
inline every helper as before.  Results are bitwise the same (``benchmarks/RESULTS.md``,
compile17 and compile18)."""


@_SERIAL.leaf
def _up(i, n):
    return i + 1 if i + 1 < n else 0


@_SERIAL.leaf
def _dn(i, n):
    return i - 1 if i > 0 else n - 1


def unit_couplings(nz: int) -> np.ndarray:
    """Stand-in for the couplings ``(cx, cy, cz)`` of a finest-level operator whose couplings are
    those of its active unknowns, ``c_b[I] = (d[I] > 0) & (d[I - e_b] > 0)`` (the staircase and
    sub-voxel component operators, :func:`solvers.voxel.multigrid.component_operator`): a row of
    ones of length ``nz + 1`` per axis, shape ``(3, 1, 1, nz + 1)``, 9 B per cell less for the
    three velocity components.  The kernels use a coupling of 1 to every neighbour then, which
    is the same product for any ``x`` that vanishes on the inactive unknowns, as every vector of
    the voxel Stokes solve does (the kernels write 0 there).  Read-only use, finest level only
    (the Galerkin product needs the real couplings)."""
    return np.ones((3, 1, 1, nz + 1), np.uint8)


@_SERIAL.leaf
def _unit(d, cx):
    """True when ``cx`` is the stand-in of :func:`unit_couplings` (its row is one longer)."""
    return cx.shape[2] != d.shape[2]


@_SERIAL.inline
def _stencil(d, cx, cy, cz, x, i, j, k, nx, ny, nz):
    """(A x) at (i, j, k) for a 7-point operator with lower-neighbour couplings (float64
    arithmetic for any dtype of ``x``)."""
    ip = _up(i, nx)
    im = _dn(i, nx)
    jp = _up(j, ny)
    jm = _dn(j, ny)
    kp = _up(k, nz)
    km = _dn(k, nz)
    if _unit(d, cx):
        s = (
            np.float64(x[im, j, k])
            + np.float64(x[ip, j, k])
            + np.float64(x[i, jm, k])
            + np.float64(x[i, jp, k])
            + np.float64(x[i, j, km])
            + np.float64(x[i, j, kp])
        )
        return d[i, j, k] * np.float64(x[i, j, k]) - s
    s = (
        cx[i, j, k] * np.float64(x[im, j, k])
        + cx[ip, j, k] * np.float64(x[ip, j, k])
        + cy[i, j, k] * np.float64(x[i, jm, k])
        + cy[i, jp, k] * np.float64(x[i, jp, k])
        + cz[i, j, k] * np.float64(x[i, j, km])
        + cz[i, j, kp] * np.float64(x[i, j, kp])
    )
    return d[i, j, k] * np.float64(x[i, j, k]) - s


AHEAD = 4
"""Rows ahead along j at which the finest-level row loops prefetch the rows they will read from
memory (:func:`_fetch`)."""


@_SERIAL.inline
def _fetch(a, i, j):
    """Prefetch row ``(i, j + AHEAD)`` of ``a`` (the next plane's row when past the last one):
    the row loops stalled on the first load of each row stream from memory (a quarter of the
    samples of ``jacobi`` on one load), which the hardware prefetcher alone did not hide
    (``benchmarks/RESULTS.md``, band11).  No effect on the values."""
    nx, ny = a.shape[0], a.shape[1]
    jj = j + AHEAD
    if jj < ny:
        simd.prefetch_row(a[i, jj])
    elif jj - ny < ny:
        simd.prefetch_row(a[_up(i, nx), jj - ny])


@_SERIAL.leaf
def _ends(nz):
    """Number of k-boundary points handled by the scalar (wrapping) stencil: k = 0 and nz - 1."""
    return 1 if nz == 1 else 2


@_SERIAL.leaf
def _on(dk):
    """1 on an active unknown (``dk != 0``), else 0, as float32: masks are applied by
    multiplying with it, after every operand is loaded.  A conditional expression
    ``val if dk != 0 else 0`` made LLVM load the operands with AVX-512 *masked* loads, which
    stall on memory here (the first Jacobi sweep from zero streamed at 1.6x the one-thread triad
    time with them, at 0.97x without; ``benchmarks/RESULTS.md``, vec10).  An inactive entry
    may then read -0.0 instead of 0.0 (equal in every comparison and sum)."""
    return np.float32(dk != 0)


@_SERIAL.inline
def _stencil_rows(dr, cxr, cxp, cyr, cyp, czr, xr, xim, xip, xjm, xjp, out):
    """out[:] = (A x) on one row along k from 1-D row views (0 where ``dr == 0``).

    ``cxr, cyr, czr`` are the couplings of the row, ``cxp, cyp`` those of the rows above along x
    and y; ``xr`` the row of ``x`` and ``xim .. xjp`` its four neighbour rows.  The interior is a
    plain loop (vectorised); the two ends wrap periodically along k.
    """
    nz = dr.shape[0]
    for k in range(1, nz - 1):
        s = (
            cxr[k] * xim[k]
            + cxp[k] * xip[k]
            + cyr[k] * xjm[k]
            + cyp[k] * xjp[k]
            + czr[k] * xr[k - 1]
            + czr[k + 1] * xr[k + 1]
        )
        out[k] = (dr[k] * xr[k] - s) * _on(dr[k])
    for e in range(_ends(nz)):
        k = 0 if e == 0 else nz - 1
        km = _dn(k, nz)
        kp = _up(k, nz)
        s = (
            cxr[k] * xim[k]
            + cxp[k] * xip[k]
            + cyr[k] * xjm[k]
            + cyp[k] * xjp[k]
            + czr[k] * xr[km]
            + czr[kp] * xr[kp]
        )
        out[k] = (dr[k] * xr[k] - s) * _on(dr[k])


@_SERIAL.inline
def _stencil_rows_unit(dr, xr, xim, xip, xjm, xjp, out):
    """:func:`_stencil_rows` with every coupling 1 (:func:`unit_couplings`): the six
    neighbours are summed without the multiplications by a row of ones (the same float32 sum,
    so the same values; 1.6x less CPU per Jacobi sweep at 200^3 on one thread: the ones were
    loaded, widened from uint8 and converted for each of the six neighbours of every cell,
    ``benchmarks/RESULTS.md``)."""
    nz = dr.shape[0]
    for k in range(1, nz - 1):
        s = xim[k] + xip[k] + xjm[k] + xjp[k] + xr[k - 1] + xr[k + 1]
        out[k] = (dr[k] * xr[k] - s) * _on(dr[k])
    for e in range(_ends(nz)):
        k = 0 if e == 0 else nz - 1
        s = xim[k] + xip[k] + xjm[k] + xjp[k] + xr[_dn(k, nz)] + xr[_up(k, nz)]
        out[k] = (dr[k] * xr[k] - s) * _on(dr[k])


@_SERIAL.leaf
def _u(q):
    """``q`` as an unsigned index: numba adds no negative-index wrap-around test, which kept LLVM
    from vectorising the flat loops (:func:`_jacobi_flat`; 8x slower, band12)."""
    return np.uint64(q)


@_SERIAL.inline
def _apply_row(d, cx, cy, cz, x, i, j, out):
    """out[:] = (A x)[i, j, :] (0 on inactive unknowns) for one row along k
    (:func:`_stencil_rows` on the row views of ``x`` around row ``(i, j)``)."""
    nx, ny, nz = d.shape
    if _unit(d, cx):  # unit_couplings: no multiplications (a separate copy: one copy shared
        # with the real couplings ran 1.09-1.7x slower, benchmarks/RESULTS.md).  Each branch
        # forms its own neighbour indices: shared by both branches, the unit branch's loops
        # ran 1.4x slower (benchmarks/RESULTS.md, band9)
        _stencil_rows_unit(
            d[i, j], x[i, j], x[_dn(i, nx), j], x[_up(i, nx), j], x[i, _dn(j, ny)],
            x[i, _up(j, ny)], out,
        )  # fmt: skip
    else:
        ip = _up(i, nx)
        im = _dn(i, nx)
        jp = _up(j, ny)
        jm = _dn(j, ny)
        _stencil_rows(
            d[i, j], cx[i, j], cx[ip, j], cy[i, j], cy[i, jp], cz[i, j],
            x[i, j], x[im, j], x[ip, j], x[i, jm], x[i, jp], out,
        )  # fmt: skip


@_SERIAL.inline
def _residual_row(d, cx, cy, cz, x, b, i, j, out):
    """out[:] = (b - A x)[i, j, :] (0 on inactive unknowns) for one row along k."""
    _apply_row(d, cx, cy, cz, x, i, j, out)
    dr = d[i, j]
    br = b[i, j]
    for k in range(out.shape[0]):
        out[k] = (br[k] - out[k]) * _on(dr[k])


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def lap_residual(d, cx, cy, cz, x, b, r):
    """r = b - A x (0 on inactive unknowns), row-vectorised."""
    nx, ny, nz = d.shape
    for i in nb.prange(nx):
        for j in range(ny):
            _residual_row(d, cx, cy, cz, x, b, i, j, r[i, j])


@_SERIAL.inline
def _sum_row(row, fz, out):
    """out[kc] += sum of ``row`` over the k-children of coarse cell kc (aggregation by ``fz``
    along k; an odd length puts the last cell in the last aggregate)."""
    nz = row.shape[0]
    ncz = out.shape[0]
    if fz == 2:
        for kc in range(ncz):
            out[kc] += row[2 * kc] + row[2 * kc + 1]
        if nz > 2 * ncz:
            out[ncz - 1] += row[nz - 1]
    else:
        for k in range(nz):
            out[min(k // fz, ncz - 1)] += row[k]


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def residual_restrict(d, cx, cy, cz, x, b, fx, fy, fz, rc):
    """rc = P^T (b - A x): the fine residual summed over each aggregate, without storing it.

    Same result as :func:`lap_residual` followed by :func:`restrict_sum` (one pass fewer over
    the fine grid).  With unit couplings (the finest level) the residual planes of each coarse
    plane are formed by the flat prefetching loop (:func:`_residual_flat`) into plane buffers
    (in cache) and summed from there, in the same order as the row loop of the stored
    couplings.
    """
    nx, ny, nz = d.shape
    ncx, ncy, ncz = rc.shape
    unit = _unit(d, cx)
    for ic in nb.prange(ncx):
        i0, i1 = _children(ic, fx, ncx, nx)
        row = np.empty(nz, dtype=rc.dtype)
        acc = np.empty(nz)
        # the residual planes of the coarse plane (unit couplings; the last aggregate of an odd
        # axis has 3)
        planes = np.empty((i1 - i0 if unit else 0, ny, nz), dtype=rc.dtype)
        if unit:
            for i in range(i0, i1):
                _residual_flat(d, x, b, i, simd.flat(planes[i - i0]))
        for jc in range(ncy):
            j0, j1 = _children(jc, fy, ncy, ny)
            # the residual rows of the aggregate row are added into one float64 row as they are
            # formed, then summed along k once per coarse row (a residual row stored, re-read
            # and summed along k per fine row took 1.6x the time, benchmarks/RESULTS.md band9)
            acc[:] = 0.0
            for i in range(i0, i1):
                for j in range(j0, j1):
                    if unit:
                        pr = planes[i - i0, j]
                        for k in range(nz):
                            acc[k] += pr[k]
                        continue
                    _apply_row(d, cx, cy, cz, x, i, j, row)
                    dr = d[i, j]
                    br = b[i, j]
                    for k in range(nz):
                        acc[k] += (br[k] - row[k]) * _on(dr[k])
            out = rc[ic, jc]
            out[:] = 0.0
            _sum_row(acc, fz, out)


@_SERIAL.leaf
def _damping(dk, om):
    """``om / dk`` in float32 (``om``: the float32 damping factor; 1 stands in for an inactive
    ``dk == 0``, whose result the caller discards).  A float32 division: the float64 one cost
    2.6 ms per 8e6 cells on one thread (the first sweep from zero: 5.2 ms, 3.3 ms in float32,
    2.6 ms with no division; ``benchmarks/RESULTS.md``, band9).  It rounds ``omega / d`` to
    float32, a fixed diagonal, so the V-cycle stays a fixed symmetric operator."""
    return om / np.float32(dk if dk != 0 else 1)


@_SERIAL.inline
def _jacobi_row(dr, xr, br, ax, omega, out):
    """out = xr + (br - ax) omega / dr on one row (float32; 0 where ``dr == 0``; ``ax`` = (A x)
    row); returns the float64 sum of ``br * out`` (the preconditioned dot product of the row)."""
    s = 0.0
    om = np.float32(omega)
    for k in range(out.shape[0]):
        val = (xr[k] + (br[k] - ax[k]) * _damping(dr[k], om)) * _on(dr[k])
        out[k] = val
        s += np.float64(br[k]) * np.float64(val)
    return s


PREFETCH = 1024
"""Cells ahead of its loads at which a flat sweep (:func:`_jacobi_flat`, :func:`_residual_flat`)
prefetches each stream it reads from memory (4 KiB of float32; 1024-4096 measured alike)."""

BLOCK = 64
"""Cells per prefetch step of the flat sweeps (one 64-byte line of uint8 ``d``)."""


@_SERIAL.leaf
def _jacobi_cell(fd, fx, fb, q, c, sm, om):
    """One cell of the Jacobi update from its neighbours' sum ``sm`` (flat views: ``d, b`` at
    ``q``, the iterate at ``c``): the expression of :func:`_stencil_rows_unit` and
    :func:`_jacobi_row` in one."""
    ax = (fd[q] * fx[c] - sm) * _on(fd[q])
    return (fx[c] + (fb[q] - ax) * _damping(fd[q], om)) * _on(fd[q])


@_SERIAL.leaf
def _residual_cell(fd, fx, fb, q, sm):
    """One cell of ``b - A x`` from its neighbours' sum ``sm`` (0 on an inactive unknown): the
    expression of :func:`_stencil_rows_unit` and :func:`residual_restrict`'s row in one."""
    ax = (fd[q] * fx[q] - sm) * _on(fd[q])
    return (fb[q] - ax) * _on(fd[q])


@_SERIAL.leaf
def _fetch_lines(a, q, step):
    """Prefetch the lines of :data:`BLOCK` entries of the 1-D array ``a`` from index ``q``: one
    prefetch per ``step`` entries (a literal at the call: 16 for float32, 64 for uint8, one
    64-byte line).  None: nothing.  (Neither a reshape nor the array's itemsize here: both are
    run-time calls or loads in numba, and per block they made the sweeps 1.1-1.9x slower.)"""
    if a is None:
        return
    for r in range(0, BLOCK, step):
        simd.prefetch_at(a, q + _u(r))


@_SERIAL.leaf
def _wrap_rows(ny):
    """Rows of a plane whose y-neighbours wrap, which a flat sweep does apart: 0 and ``ny - 1``
    (one row when ``ny == 1``)."""
    return 1 if ny == 1 else 2


@_SERIAL.leaf
def _wrap_row(r, ny):
    """``j`` of the ``r``-th row of :func:`_wrap_rows`."""
    return 0 if r == 0 else ny - 1


@_SERIAL.leaf
def _wrap_sum(x0, b0, xm, bm, xp, bp, j, k, ny, nz):
    """The six neighbours' sum of cell ``(j, k)`` of the plane at ``x0[b0:]`` (its neighbour
    planes at ``xm[bm:], xp[bp:]``), periodic along y and k; the order of the flat loops."""
    t = _u(j * nz + k)
    jm = b0 + _u(_dn(j, ny) * nz + k)
    jp = b0 + _u(_up(j, ny) * nz + k)
    km = b0 + _u(j * nz + _dn(k, nz))
    kp = b0 + _u(j * nz + _up(k, nz))
    return xm[bm + t] + xp[bp + t] + x0[jm] + x0[jp] + x0[km] + x0[kp]


@_SERIAL.inline
def _plane_dot(fx, fy, c0, pl):
    """Float64 ``x . y`` over the ``pl`` entries from flat offset ``c0`` (a plane just written:
    from cache)."""
    acc = 0.0
    for q in range(c0, c0 + pl):
        acc += np.float64(fx[q]) * np.float64(fy[q])
    return acc


@_SERIAL.inline
def _jacobi_flat(fd, fb, fo, base, x0, b0, xm, bm, xp, bp, ny, nz, om, dot, ea, eq, eb):
    """Jacobi sweep (unit couplings) of the plane of ``ny nz`` cells at flat offset ``base`` of
    ``fd, fb`` into ``fo``, from the iterate's plane at ``x0[b0:]`` and its neighbour planes
    along x at ``xm[bm:], xp[bp:]`` (the grid itself, or plane buffers); returns the plane's
    ``b . xnew`` if ``dot``, else 0.0.

    The interior rows (``1 <= j <= ny - 2``) are one flat loop over the plane (the stencil and
    the update in one expression, no row buffer), in blocks of :data:`BLOCK` cells, each block
    prefetching the lines :data:`PREFETCH` cells ahead in ``d, b`` and the output, and the
    block at ``ea[eq + t], eb[eq + t]`` (the caller's next streams from memory: the iterate's
    plane ``i + 1`` with ``eq`` that many cells ahead, or the plane two ahead; None: none).
    The row loops of the old sweeps issued their loads too slowly for the memory system (a
    sweep of the grid ran 1.9x the one-thread triad time of its bytes; an ideal flat loop with
    this prefetch 1.05x, without it 1.85x; the sweeps 0.66-0.83x main's one-thread CPU at
    200^3, ``benchmarks/RESULTS.md``, band14).  The k-neighbours at the two ends of each row (read
    from the neighbouring rows by the flat loop) are then redone with the periodic neighbours,
    the rows 0 and ``ny - 1`` (the y-wrap) by their own vector loops (:func:`_wrap_rows`; as
    scalar cells they cost ~20 % of the sweep at 200^3), and ``b . xnew`` is summed over the
    plane from cache.  Unsigned indices (:func:`_u`): vectorised."""
    pl = _u(ny * nz)
    unz = _u(nz)
    one = _u(1)
    if ny >= 3:
        t0 = unz
        while t0 < pl - unz:
            qa = base + t0 + _u(PREFETCH)
            _fetch_lines(fo, qa, 16)
            _fetch_lines(fb, qa, 16)
            _fetch_lines(fd, qa, 64)
            _fetch_lines(ea, eq + t0, 16)  # float32 (b, or x)
            _fetch_lines(eb, eq + t0, 64)  # uint8 (d) or None
            t1 = min(t0 + _u(BLOCK), pl - unz)
            for t in range(t0, t1):
                c = b0 + t
                sm = xm[bm + t] + xp[bp + t] + x0[c - unz] + x0[c + unz] + x0[c - one] + x0[c + one]
                fo[base + t] = _jacobi_cell(fd, x0, fb, base + t, c, sm, om)
            t0 = t1
    for r in range(_wrap_rows(ny)):  # the y-wrap rows, vectorised along k
        j = _wrap_row(r, ny)
        rj = _u(j * nz)
        rm = b0 + _u(_dn(j, ny) * nz)
        rp = b0 + _u(_up(j, ny) * nz)
        for k in range(one, unz - one):
            t = rj + k
            c = b0 + t
            sm = xm[bm + t] + xp[bp + t] + x0[rm + k] + x0[rp + k] + x0[c - one] + x0[c + one]
            fo[base + t] = _jacobi_cell(fd, x0, fb, base + t, c, sm, om)
    for j in range(ny):  # the two ends of every row: the periodic k-neighbours
        for e in range(_ends(nz)):
            k = 0 if e == 0 else nz - 1
            t = _u(j * nz + k)
            sm = _wrap_sum(x0, b0, xm, bm, xp, bp, j, k, ny, nz)
            fo[base + t] = _jacobi_cell(fd, x0, fb, base + t, b0 + t, sm, om)
    return _plane_dot(fb, fo, base, pl) if dot else 0.0


@_SERIAL.inline
def _residual_flat(d, x, b, i, rp):
    """``rp`` (flat, ``ny nz`` entries) = plane ``i`` of ``b - A x`` (unit couplings): the flat
    prefetching loop of :func:`_jacobi_flat` with :func:`_residual_cell`."""
    nx, ny, nz = d.shape
    fd = simd.flat(d)
    fx = simd.flat(x)
    fb = simd.flat(b)
    pl = _u(ny * nz)
    base = _u(i) * pl
    bm = _u(_dn(i, nx)) * pl
    bp = _u(_up(i, nx)) * pl
    unz = _u(nz)
    one = _u(1)
    if ny >= 3:
        hi = base + pl - unz
        q0 = base + unz
        while q0 < hi:
            qa = q0 + _u(PREFETCH)
            _fetch_lines(fx, bp + (qa - base), 16)
            _fetch_lines(fb, qa, 16)
            _fetch_lines(fd, qa, 64)
            q1 = min(q0 + _u(BLOCK), hi)
            for q in range(q0, q1):
                t = q - base
                sm = fx[bm + t] + fx[bp + t] + fx[q - unz] + fx[q + unz] + fx[q - one] + fx[q + one]
                rp[t] = _residual_cell(fd, fx, fb, q, sm)
            q0 = q1
    for r in range(_wrap_rows(ny)):  # the y-wrap rows, vectorised along k
        j = _wrap_row(r, ny)
        rj = _u(j * nz)
        rm = base + _u(_dn(j, ny) * nz)
        rq = base + _u(_up(j, ny) * nz)
        for k in range(one, unz - one):
            t = rj + k
            q = base + t
            sm = fx[bm + t] + fx[bp + t] + fx[rm + k] + fx[rq + k] + fx[q - one] + fx[q + one]
            rp[t] = _residual_cell(fd, fx, fb, q, sm)
    for j in range(ny):  # the two ends of every row: the periodic k-neighbours
        for e in range(_ends(nz)):
            k = 0 if e == 0 else nz - 1
            q = base + _u(j * nz + k)
            rp[q - base] = _residual_cell(
                fd, fx, fb, q, _wrap_sum(fx, base, fx, bm, fx, bp, j, k, ny, nz)
            )


@parallel_kernel(helpers=_SERIAL, noalias=True, **_OPTS)
def jacobi(d, cx, cy, cz, x, b, xnew, omega):
    """One damped Jacobi sweep ``xnew = x + omega D^-1 (b - A x)`` (row-vectorised; with unit
    couplings one flat prefetching loop per plane, :func:`_jacobi_flat`).

    Returns ``b . xnew`` (float64) from the same pass: after the last smoothing sweep of a
    V-cycle on the finest level that is the preconditioned dot product MINRES needs.
    """
    nx, ny, nz = d.shape
    acc = np.zeros(nx)
    if _unit(d, cx):
        om = np.float32(omega)
        pl = _u(ny * nz)
        fx = simd.flat(x)
        for i in nb.prange(nx):
            base = _u(i) * pl
            bp = _u(_up(i, nx)) * pl
            acc[i] = _jacobi_flat(
                simd.flat(d), simd.flat(b), simd.flat(xnew), base,
                fx, base, fx, _u(_dn(i, nx)) * pl, fx, bp, ny, nz, om, True,
                fx, bp + _u(PREFETCH), None,
            )  # fmt: skip
        return ordered_sum(acc)
    # stored couplings (coarse levels): the arrays through numba's reshape, whose run-time call
    # hides from LLVM that they are the noalias arguments, so that these row loops compile as
    # without noalias, to bitwise the values of jacobi2_zero's and prolong_jacobi's sweeps (the
    # V-cycle's symmetry; with noalias their vectorisation changed by an ulp, band20)
    dd, xx, bb, xo = (
        d.reshape(d.shape),
        x.reshape(x.shape),
        b.reshape(b.shape),
        xnew.reshape(nx, ny, nz),
    )
    for i in nb.prange(nx):
        row = np.empty(nz, dtype=xnew.dtype)
        s = 0.0
        for j in range(ny):
            # no prefetch (kernels._fetch) here: -8 % CPU in the parallel twin, but its serial
            # twin (one-thread solves, coarse levels) ran 1.7x slower with it (band11)
            _apply_row(dd, cx, cy, cz, xx, i, j, row)
            s += _jacobi_row(dd[i, j], xx[i, j], bb[i, j], row, omega, xo[i, j])
        acc[i] = s
    return ordered_sum(acc)


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def jacobi_zero(d, b, x, omega):
    """First Jacobi sweep from a zero guess: ``x = omega D^-1 b``."""
    nx, ny, nz = d.shape
    for i in nb.prange(nx):
        for j in range(ny):
            _zero_row(d[i, j], b[i, j], omega, x[i, j])


@_SERIAL.inline
def _zero_row(dr, br, omega, out):
    """out = br omega / dr (float32, :func:`_damping`; 0 where ``dr == 0``): one row of the first
    Jacobi sweep from 0."""
    om = np.float32(omega)
    for k in range(out.shape[0]):
        out[k] = br[k] * _damping(dr[k], om) * _on(dr[k])


@_SERIAL.leaf
def _chunk(t, nt, n):
    """Range ``[lo, hi)`` of the ``t``-th of ``nt`` equal chunks of ``range(n)``."""
    return t * n // nt, (t + 1) * n // nt


@_SERIAL.inline
def _zero_plane(d, b, i, omega, out):
    """out[j, :] = omega b[i, j, :] / d[i, j, :]: plane ``i`` of the first sweep from zero."""
    for j in range(d.shape[1]):
        _zero_row(d[i, j], b[i, j], omega, out[j])


@_SERIAL.leaf
def _fetch_ahead(fa, fb, i, j):
    """Prefetch row ``j`` of plane ``i + 2`` of ``fa`` and ``fb`` (periodic), the plane the
    next step of :func:`jacobi2_zero` (``d, b``) reads from memory, while this plane's sweep
    computes from cache: the memory stream then overlaps the arithmetic instead of following it
    (0.95x one-thread CPU).  ``None``: nothing (:func:`prolong_jacobi`, whose prolongation plane
    prefetches its rows itself).  No effect on the values."""
    if fa is None:  # compiled out (prolong_jacobi: 1.07x slower with it, band12)
        return
    nx = fa.shape[0]
    i2 = _up(_up(i, nx), nx)
    simd.prefetch_row(fa[i2, j])
    simd.prefetch_row(fb[i2, j])


@_SERIAL.leaf
def _ring(s):
    """Rows of the three-plane buffer of :func:`jacobi2_zero` and :func:`prolong_jacobi` that
    hold the planes ``i - 1, i, i + 1`` at step ``s = i - lo`` of a chunk (rows 0 and 1 hold
    planes ``lo - 1, lo`` before the first step; each step fills the third).  One buffer
    indexed by row, not three arrays swapped per step: the swapped arrays reached the sweep's
    loop through LLVM phi nodes, through which it could not tell them from the output, so
    every block of the flat loop kept its run-time overlap checks (band20)."""
    return s % 3, (s + 1) % 3, (s + 2) % 3


@_SERIAL.inline
def _jacobi_plane(d, cx, cy, cz, buf, rm, r0, rp, b, i, omega, blk, xnew, fa, fb, dot):
    """Jacobi sweep of plane ``i`` from the planes ``i - 1, i, i + 1`` of the iterate (rows
    ``rm, r0, rp`` of ``buf``, ``3 x ny nz``: :func:`_ring`) into ``xnew[i]``; returns the
    plane's ``b . xnew`` (0.0 from the flat sweep if not ``dot``; the row loops always sum it:
    without the sum LLVM vectorises them otherwise, and their values would move off
    :func:`jacobi`'s).  ``blk``: work row of ``nz`` entries; ``fa, fb``: the arrays whose plane
    ``i + 2`` the caller's next plane step streams from memory, or None (:func:`_fetch_ahead`).

    With unit couplings (the finest level) the sweep is the flat prefetching loop of
    :func:`jacobi` over the buffered planes (:func:`_jacobi_flat`), which also prefetches the
    plane ``i + 2`` of ``fa, fb`` block by block; the coarse levels (stored couplings) keep the
    row loops (``benchmarks/RESULTS.md``, band14)."""
    nx, ny, nz = d.shape
    if _unit(d, cx):  # unit_couplings: one flat loop over the plane (_jacobi_flat)
        pl = _u(ny * nz)
        ahead = _u(_up(_up(i, nx), nx)) * pl  # the next plane step's d, b (plane i + 2)
        fd, fbb, fo, om = simd.flat(d), simd.flat(b), simd.flat(xnew), np.float32(omega)
        # the three planes as one array at three offsets, as jacobi passes the grid: the row
        # ends then compile to the same sums as jacobi's (as three arrays they did not, and
        # the V-cycle's sweeps differed by an ulp at k = nz - 1, band20)
        fp = simd.flat(buf)
        o0, om_, op = _u(r0) * pl, _u(rm) * pl, _u(rp) * pl
        if fa is None:  # compiled out where the caller passes arrays
            return _jacobi_flat(
                fd, fbb, fo, _u(i) * pl, fp, o0, fp, om_, fp, op, ny, nz, om, dot,
                None, ahead, None,
            )  # fmt: skip
        return _jacobi_flat(
            fd, fbb, fo, _u(i) * pl, fp, o0, fp, om_, fp, op, ny, nz, om, dot,
            simd.flat(fb), ahead, simd.flat(fa),
        )  # fmt: skip
    pm2 = buf[rm].reshape((ny, nz))
    p02 = buf[r0].reshape((ny, nz))
    pp2 = buf[rp].reshape((ny, nz))
    ip = _up(i, nx)
    row = blk
    s = 0.0
    for j in range(ny):
        _fetch(b, i, j)
        _fetch_ahead(fa, fb, i, j)
        jp = _up(j, ny)
        jm = _dn(j, ny)
        _stencil_rows(
            d[i, j], cx[i, j], cx[ip, j], cy[i, j], cy[i, jp], cz[i, j],
            p02[j], pm2[j], pp2[j], p02[jm], p02[jp], row,
        )  # fmt: skip
        s += _jacobi_row(d[i, j], p02[j], b[i, j], row, omega, xnew[i, j])
    return s


@parallel_kernel(helpers=_SERIAL, noalias=True, **_OPTS)
def jacobi2_zero(d, cx, cy, cz, b, xnew, omega, nchunks):
    """Two damped Jacobi sweeps from a zero guess in one pass over the grid.

    ``x1 = omega D^-1 b`` (:func:`jacobi_zero`) is never stored in the grid: each thread walks
    its chunk of x-planes keeping the planes ``i - 1, i, i + 1`` of ``x1`` in three plane
    buffers (in cache), so the second sweep ``xnew = x1 + omega D^-1 (b - A x1)`` streams
    ``d, c, b`` once and writes ``xnew`` (same values as :func:`jacobi_zero` +
    :func:`jacobi`).  ``nchunks``: number of x-chunks, i.e. of threads that can work at once
    (each chunk computes two planes more).
    """
    nx = d.shape[0]
    nt = max(1, min(nchunks, nx))
    for t in nb.prange(nt):
        _jacobi2_zero_chunk(d, cx, cy, cz, b, xnew, omega, np.int64(t), nt)


# the chunk functions of jacobi2_zero and prolong_jacobi, which only their parallel twins call
# (SerialHelpers.shared; the serial twins inline the body under their own noalias), take _OPTS
# without noalias, as the parallel twins were compiled before. Session 50's review: with
# NoAliasCompiler here the compiling process stayed bitwise, but one that loaded the chunks
# from numba's cache gave other last bits at the row ends k = nz - 1 and in the stored-coupling
# rows (36 / 614 cells of a 40 x 36 x 44 sweep): the V-cycle was no longer one symmetric
# operator (test_fused_sweeps_are_bitwise_jacobis' slow parallel cases failed).
@_SERIAL.shared(**_OPTS)
def _jacobi2_zero_chunk(d, cx, cy, cz, b, xnew, omega, t, nt):
    """Chunk ``t`` of ``nt`` of :func:`jacobi2_zero` (nine parameters: the kernel's, ``t`` and
    ``nt``).  Compiled once over the serial helpers, with :data:`_OPTS` (no ``noalias``: above),
    for the parallel twin; inlined in the serial twin under its ``noalias``
    (:meth:`solvers.jit.SerialHelpers.shared`): the
    parallel twin's own copy of this body, its helpers inlined by numba, cost 25-33 s of CPU to
    compile per signature (``benchmarks/RESULTS.md``, session 50).  A chunk is a thread's
    share of the grid: one call per thread."""
    nx, ny, nz = d.shape
    lo, hi = _chunk(t, nt, nx)
    buf = np.empty((3, ny * nz), dtype=xnew.dtype)  # _ring: planes i - 1, i, i + 1
    blk = np.empty(nz, dtype=xnew.dtype)
    _zero_plane(d, b, _dn(lo, nx), omega, buf[0].reshape((ny, nz)))
    _zero_plane(d, b, lo, omega, buf[1].reshape((ny, nz)))
    for i in range(lo, hi):
        rm, r0, rp = _ring(i - lo)
        _zero_plane(d, b, _up(i, nx), omega, buf[rp].reshape((ny, nz)))
        _jacobi_plane(d, cx, cy, cz, buf, rm, r0, rp, b, i, omega, blk, xnew, d, b, False)


@_SERIAL.inline
def _expand_row(cr, fz, nz, alpha, ex):
    """``ex[k] = alpha cr[k // fz]`` (float64; the last coarse cell takes the remainder): a
    coarse row expanded to the fine row length (pairwise stores for ``fz = 2``), so that the
    fine loop of :func:`_prolong_plane` is a plain vectorised add instead of a gather (8x
    faster; the same float64 sum, so bit-identical results)."""
    ncz = cr.shape[0]
    if fz == 2:
        for kc in range(ncz):
            v = alpha * cr[kc]
            ex[2 * kc] = v
            ex[2 * kc + 1] = v
        for k in range(2 * ncz, nz):
            ex[k] = alpha * cr[ncz - 1]
    else:
        for k in range(nz):
            ex[k] = alpha * cr[min(k // fz, ncz - 1)]


@_SERIAL.inline
def _prolong_plane(d, x, xc, i, fx, fy, fz, alpha, out, ex):
    """out[j, :] = plane ``i`` of ``x + alpha P xc`` (on active unknowns; ``x`` elsewhere);
    ``ex``: float64 work row, the expanded coarse row (:func:`_expand_row`), formed once per
    coarse row."""
    ncx, ncy, _ = xc.shape
    ic = min(i // fx, ncx - 1)
    nz = d.shape[2]
    last = -1
    for j in range(d.shape[1]):
        _fetch(x, i, j)
        _fetch(d, i, j)
        jc = min(j // fy, ncy - 1)
        if jc != last:
            _expand_row(xc[ic, jc], fz, nz, alpha, ex)
            last = jc
        dr = d[i, j]
        xr = x[i, j]
        orow = out[j]
        for k in range(nz):
            orow[k] = xr[k] + ex[k] * _on(dr[k])


@parallel_kernel(helpers=_SERIAL, noalias=True, **_OPTS)
def prolong_jacobi(d, cx, cy, cz, x, xc, fx, fy, fz, alpha, b, xnew, omega, nchunks):
    """Coarse correction and the first post-smoothing sweep in one pass over the grid.

    ``x' = x + alpha P xc`` (:func:`prolong_add`) is never stored in the grid: each thread keeps
    the planes ``i - 1, i, i + 1`` of it in plane buffers while it walks its chunk of x-planes,
    and ``xnew = x' + omega D^-1 (b - A x')`` is formed from them (same values as
    :func:`prolong_add` + :func:`jacobi`; ``x`` is not modified).  Returns ``b . xnew``
    (float64) with stored couplings, 0.0 with unit couplings: the flat sweep of the finest level
    does not sum it (the V-cycle uses no dot of this sweep with two or more post-smoothing
    sweeps, its default; summing it made the sweep 1.14x slower at 200^3 on one thread,
    1.10-1.17x on two, ``benchmarks/RESULTS.md``, session 30).  ``nchunks`` as for
    :func:`jacobi2_zero`.  (14 parameters: the fine operator, both grids' vectors, the two
    methods' scalars and the chunk count.)
    """
    nx = d.shape[0]
    nt = max(1, min(nchunks, nx))
    acc = np.zeros(nt)
    for t in nb.prange(nt):
        acc[t] = _prolong_jacobi_chunk(
            d, cx, cy, cz, x, xc, fx, fy, fz, alpha, b, xnew, omega, np.int64(t), nt
        )
    return ordered_sum(acc)


@_SERIAL.shared(**_OPTS)
def _prolong_jacobi_chunk(d, cx, cy, cz, x, xc, fx, fy, fz, alpha, b, xnew, omega, t, nt):
    """Chunk ``t`` of ``nt`` of :func:`prolong_jacobi`; returns its ``b . xnew`` (15
    parameters: the kernel's, ``t`` and ``nt``); compiled as :func:`_jacobi2_zero_chunk`."""
    nx, ny, nz = d.shape
    lo, hi = _chunk(t, nt, nx)
    buf = np.empty((3, ny * nz), dtype=xnew.dtype)  # _ring: planes i - 1, i, i + 1
    blk = np.empty(nz, dtype=xnew.dtype)
    ex = np.empty(nz, dtype=np.float64)
    _prolong_plane(d, x, xc, _dn(lo, nx), fx, fy, fz, alpha, buf[0].reshape((ny, nz)), ex)
    _prolong_plane(d, x, xc, lo, fx, fy, fz, alpha, buf[1].reshape((ny, nz)), ex)
    s = 0.0
    for i in range(lo, hi):
        rm, r0, rp = _ring(i - lo)
        _prolong_plane(d, x, xc, _up(i, nx), fx, fy, fz, alpha, buf[rp].reshape((ny, nz)), ex)
        s += _jacobi_plane(
            d, cx, cy, cz, buf, rm, r0, rp, b, i, omega, blk, xnew, None, None, False
        )
    return s


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def copy_dot(r, z):
    """z = r (identity pressure block); returns ``r . z`` (float64) from the same pass."""
    fr = r.reshape(-1, r.shape[-1])
    fz = z.reshape(-1, z.shape[-1])
    m, n = fr.shape
    part = np.zeros(m)
    for row in nb.prange(m):
        a = fr[row]
        o = fz[row]
        s = 0.0
        for t in range(n):
            o[t] = a[t]
            s += np.float64(a[t]) * np.float64(o[t])
        part[row] = s
    return ordered_sum(part)


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def scale_dot(r, c, z):
    """z = r * c (diagonal pressure block); returns ``r . z`` (float64) from the same pass."""
    fr = r.reshape(-1, r.shape[-1])
    fc = c.reshape(-1, c.shape[-1])
    fz = z.reshape(-1, z.shape[-1])
    m, n = fr.shape
    part = np.zeros(m)
    for row in nb.prange(m):
        a = fr[row]
        sc = fc[row]
        o = fz[row]
        s = 0.0
        for t in range(n):
            o[t] = a[t] * sc[t]
            s += np.float64(a[t]) * np.float64(o[t])
        part[row] = s
    return ordered_sum(part)


@_SERIAL.leaf
def _children(ic, f, nc, n):
    lo = ic * f
    hi = n if ic == nc - 1 else lo + f
    return lo, hi


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def restrict_sum(r, fx, fy, fz, rc):
    """Coarse right-hand side = sum of the fine residual over each aggregate (R = P^T)."""
    nx, ny, nz = r.shape
    ncx, ncy, ncz = rc.shape
    for ic in nb.prange(ncx):
        i0, i1 = _children(ic, fx, ncx, nx)
        for jc in range(ncy):
            j0, j1 = _children(jc, fy, ncy, ny)
            out = rc[ic, jc]
            out[:] = 0.0
            for i in range(i0, i1):
                for j in range(j0, j1):
                    _sum_row(r[i, j], fz, out)


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def prolong_add(d, xc, fx, fy, fz, alpha, x):
    """x += alpha * (piecewise-constant interpolation of xc) on active fine unknowns."""
    nx, ny, nz = d.shape
    ncx, ncy, ncz = xc.shape
    for i in nb.prange(nx):
        ic = min(i // fx, ncx - 1)
        for j in range(ny):
            jc = min(j // fy, ncy - 1)
            dr = d[i, j]
            xr = x[i, j]
            cr = xc[ic, jc]
            if fz == 2:
                for k in range(2 * ncz):
                    xr[k] += alpha * cr[k >> 1] if dr[k] != 0 else 0.0
                for k in range(2 * ncz, nz):
                    xr[k] += alpha * cr[ncz - 1] if dr[k] != 0 else 0.0
            else:
                for k in range(nz):
                    if dr[k] != 0:
                        xr[k] += alpha * cr[min(k // fz, ncz - 1)]


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def galerkin(d, cx, cy, cz, fx, fy, fz, dc, cxc, cyc, czc):
    """Galerkin coarse operator P^T A P for piecewise-constant aggregation (box aggregates).

    Couplings of children on the lower boundary of an aggregate become the coarse coupling to
    the lower coarse neighbour; couplings inside an aggregate cancel against the diagonal.
    """
    for ic in nb.prange(dc.shape[0]):
        _galerkin_slab(d, cx, cy, cz, fx, fy, fz, dc, cxc, cyc, czc, np.int64(ic))


@_SERIAL.slab(**_OPTS)
def _galerkin_slab(d, cx, cy, cz, fx, fy, fz, dc, cxc, cyc, czc, ic):
    """Coarse plane ``ic`` of :func:`galerkin` (12 parameters: the kernel's and ``ic``)."""
    nx, ny, nz = d.shape
    ncx, ncy, ncz = dc.shape
    i0, i1 = _children(ic, fx, ncx, nx)
    for jc in range(ncy):
        j0, j1 = _children(jc, fy, ncy, ny)
        for kc in range(ncz):
            k0, k1 = _children(kc, fz, ncz, nz)
            dd = 0.0
            ex = 0.0
            ey = 0.0
            ez = 0.0
            for i in range(i0, i1):
                for j in range(j0, j1):
                    for k in range(k0, k1):
                        dd += d[i, j, k]
                        if i == i0:
                            ex += cx[i, j, k]
                        else:
                            dd -= 2.0 * cx[i, j, k]
                        if j == j0:
                            ey += cy[i, j, k]
                        else:
                            dd -= 2.0 * cy[i, j, k]
                        if k == k0:
                            ez += cz[i, j, k]
                        else:
                            dd -= 2.0 * cz[i, j, k]
            dc[ic, jc, kc] = dd
            cxc[ic, jc, kc] = ex
            cyc[ic, jc, kc] = ey
            czc[ic, jc, kc] = ez


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def stokes_residual(du, dv, dw, cu, cv, cw, fluid, x, gdir, r):
    """r = f - K x in float64 arithmetic (r may be float32) for the symmetric MAC Stokes
    matrix ``K`` of the module docstring (staircase walls: every face weight 1; the sub-voxel
    matrix has its own kernel, :func:`solvers.voxel.cutfaces.stokes_residual_cut`); ``x, r``
    have shape (4, nx, ny, nz) = (u, v, w, p).  f = 1 on the active faces of component
    ``gdir`` (the unit body force).  Returns ``(||r||^2, ||f||^2)``."""
    nx = fluid.shape[0]
    acc = np.zeros(nx)
    accf = np.zeros(nx)
    for i in nb.prange(nx):
        acc[i], accf[i] = _stokes_residual_slab(
            du, dv, dw, cu, cv, cw, fluid, x, gdir, r, np.int64(i)
        )
    return ordered_sum(acc), ordered_sum(accf)


@_SERIAL.slab(**_OPTS)
def _stokes_residual_slab(du, dv, dw, cu, cv, cw, fluid, x, gdir, r, i):
    """Plane ``i`` of :func:`stokes_residual`; returns its ``(||r||^2, ||f||^2)`` (11
    parameters: the kernel's and ``i``)."""
    nx, ny, nz = fluid.shape
    u = x[0]
    v = x[1]
    w = x[2]
    p = x[3]
    im = _dn(i, nx)
    ip = _up(i, nx)
    s2 = 0.0
    f2 = 0.0
    for j in range(ny):
        jm = _dn(j, ny)
        jp = _up(j, ny)
        for k in range(nz):
            km = _dn(k, nz)
            kp = _up(k, nz)
            pc = np.float64(p[i, j, k])  # float64 arithmetic for a float32 x too
            for a in range(3):
                if a == 0:
                    act = du[i, j, k] != 0
                elif a == 1:
                    act = dv[i, j, k] != 0
                else:
                    act = dw[i, j, k] != 0
                if not act:
                    r[a, i, j, k] = 0.0
                    continue
                if a == 0:
                    val = _stencil(du, cu[0], cu[1], cu[2], u, i, j, k, nx, ny, nz)
                    val += pc - np.float64(p[im, j, k])
                elif a == 1:
                    val = _stencil(dv, cv[0], cv[1], cv[2], v, i, j, k, nx, ny, nz)
                    val += pc - np.float64(p[i, jm, k])
                else:
                    val = _stencil(dw, cw[0], cw[1], cw[2], w, i, j, k, nx, ny, nz)
                    val += pc - np.float64(p[i, j, km])
                f = 1.0 if a == gdir else 0.0
                res = f - val
                r[a, i, j, k] = res
                s2 += res * res
                f2 += f * f
            if fluid[i, j, k] != 0:
                res = -(
                    np.float64(u[i, j, k])
                    - np.float64(u[ip, j, k])
                    + np.float64(v[i, j, k])
                    - np.float64(v[i, jp, k])
                    + np.float64(w[i, j, k])
                    - np.float64(w[i, j, kp])
                )
                r[3, i, j, k] = res
                s2 += res * res
            else:
                r[3, i, j, k] = 0.0
    return s2, f2


@parallel_kernel(helpers=_SERIAL, **_OPTS)
def dot(a, b):
    """Float64 dot product of two equally shaped C-contiguous arrays (any float dtype).

    Parallel over rows of the last axis, each row accumulated in float64 (vectorised).
    """
    fa = a.reshape(-1, a.shape[-1])
    fb = b.reshape(-1, b.shape[-1])
    m, n = fa.shape
    part = np.zeros(m)
    for row in nb.prange(m):
        ra = fa[row]
        rb = fb[row]
        s = 0.0
        for t in range(n):
            s += np.float64(ra[t]) * np.float64(rb[t])
        part[row] = s
    return ordered_sum(part)


_SERIAL.seal(globals())
