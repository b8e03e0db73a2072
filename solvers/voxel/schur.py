"""Coarse Darcy correction of the pressure block of the voxel Stokes preconditioner.

Why
---
The pressure block of the block-diagonal MINRES preconditioner (:mod:`solvers.voxel_stokes`) is
a pore-scale approximation of the Schur complement ``S = G^T A^-1 G``: the identity (staircase)
or the inverse of its diagonal (sub-voxel walls).  That is right for pressure modes shorter than
the pores, where ``S`` acts like the identity (exactly so in a wall-free box).  For modes of
wave number ``k`` much longer than the pores, ``S`` is the Darcy operator ``-div(K grad)`` (voxel
units, ``K`` the permeability over ``h^2``) with eigenvalues ``K k^2``: the preconditioned
spectrum spans ``[K (2 pi / L)^2, 1]``, so its condition number grows as ``(L / sqrt K)^2`` and
MINRES needs about ``L / sqrt K`` iterations once the box side ``L`` is a few times
``2 pi sqrt K`` (measured, Toray-like material at 1 um, ``benchmarks/RESULTS.md``: 107-114
iterations for 32-64 um boxes, 171 at 96, 222 at 128, 253 at 200, 456 at 400).

What
----
A two-level additive pressure block (as two-level additive Schwarz / a coarse-grid correction
of an elliptic preconditioner; cf. the Darcy-type coarse pressure corrections of SIMPLE-like
pore-scale solvers)::

    M_p^-1 = D^-1 + R^T S_c^+ R

* ``R`` sums the pressure residual over box blocks of :data:`BLOCK` cells per axis (the fluid
  cells only) and ``R^T`` injects a block value into the block's fluid cells, so the term is
  symmetric positive semi-definite and ``M_p`` stays SPD (MINRES).
* ``S_c`` is a 7-point finite-volume Darcy operator on the blocks: transmissibility
  ``K_f A / l`` between two face-neighbouring blocks (``A`` the block face area, ``l`` the block
  length along the axis, ``K_f`` the harmonic mean of the two blocks' permeabilities along the
  axis), 0 when no velocity unknown crosses the interface (box walls of the permeameter, solid
  planes).  The coefficient is the *Poisson* permeability, not Darcy's: the long-wave limit of
  ``G^T A^-1 G`` is ``-div(K_P grad)`` with ``K_P`` the superficial mean of the unconstrained
  velocity ``A^-1 w`` under a unit force (no incompressibility; Toray-like 48 um: ``K_P`` = 14
  voxel^2 against the Stokes 10).  ``A^-1 w`` is approximated by :data:`CYCLES` iterations of
  the velocity V-cycles already built, its block sums averaged over ``SMOOTH^3`` blocks and
  capped at ``(box side)^2`` (an empty reservoir is then nearly isobaric, as it is: ``S`` is
  the identity there and the correction must vanish).  Measured on the same 48 um box,
  plane pressure waves of 1, 2, 4, 8 periods per box: Rayleigh quotients of ``S`` 0.22, 0.49,
  0.74, 0.87 (``K_P k^2`` 0.24, 0.96, ...); with the coarse term ``(1 + C) S`` 0.98, 0.94,
  0.92, 0.92.
* ``S_c^+`` (pseudo-inverse: the constant pressure of each connected coarse component is in the
  null space of ``S``) is applied as one symmetric V-cycle of the same aggregation multigrid as
  the velocities (:class:`solvers.voxel.multigrid.ScalarMG`) with the right-hand side and the
  result projected to zero mean on each component; a tiny diagonal shift
  (:data:`SHIFT`) keeps the coarsest direct solve regular.

Each transmissibility is at least :data:`FACE_FLOOR` times the interface's sum of ``w_f^2 /
A_ff`` (the pore-scale face graph; the Galerkin coarse Schur complement is at least half of it):
where the smoothed Poisson permeability is far too low for a small open pore the term would
over-correct (since session 14).  The coarse term enters with the weight :data:`WEIGHT` (0.6).
A third, local term for the blocks a fibre cuts into several fluid parts was measured and not
kept (it over-corrects from 300 um on; ``benchmarks/RESULTS.md``, "Issue 16 item 4, iteration
growth (iter11)"; its code is in the history, commit aa21e6c).

With the Brinkman-like interpolation ``S(k) ~ K k^2 / (1 + K k^2)`` the preconditioned symbol
is ``(1 + 1 / (K_c k^2)) S(k) = 1`` for ``K_c = K``: the iteration count no longer depends on
the box.  ``D`` is the Schur diagonal ``sum over the cell's faces of w_f^2 / A_ff`` (a one-byte
logarithmic code for both wall treatments, :func:`schur_code`).  Either half alone does not
cut the iterations (Toray-like
96 um: 171 before, 192 with ``D`` alone, 182 with the coarse term alone, 121 with both; 200 um:
253 -> 176).  Cost per MINRES iteration: the restriction pass and one fused pass writing the
pressure block (read ``r``, the code and the fluid mask, write ``z``) instead of the former
copy, and a V-cycle on ``N / BLOCK^3`` blocks: within the noise of the one-level block
(``bench_voxel_scale.py schur-cost``, 8^3 blocks).  Memory: 1 B per voxel for the staircase code
plus about 1 B per voxel (4^3 blocks; 0.12 B with 8^3) for the coarse operator, hierarchy and
work arrays.  Similar in spirit to the
pore-level multiscale / pore-network preconditioners of Mehmani and co-workers (a coarse
pore-scale flow model as the coarse space of a Stokes preconditioner).
"""

from __future__ import annotations

from collections.abc import Callable

import numba as nb
import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from solvers.jit import parallel_kernel
from solvers.reduction import ordered_sum
from solvers.voxel import kernels as kr
from solvers.voxel import multigrid as mg
from solvers.voxel import simd

__all__ = [
    "BLOCK",
    "CYCLES",
    "SHIFT",
    "SMOOTH",
    "WEIGHT",
    "CoarsePressure",
    "block_sum",
    "CODE_SHIFT",
    "CODE_TABLE",
    "poisson_velocity",
    "schur_code",
    "pressure_block_code",
    "unit_inverse",
]

BLOCK = 4
"""Cells per axis of a coarse pressure block (the Darcy correction acts on modes longer than
about two blocks; the uncorrected Darcy modes then have eigenvalues above ``K (pi / BLOCK)^2``).
4 since session 10 (8 before): the SYMMLQ count to 1e-6 on the Toray-like material at 1 um,
100 / 200 um boxes, fell from 153 / 187 to 140 / 164 (2 cells: 170 at 200 um; ``SMOOTH`` 1
instead of 3 at 8 cells: 264), and the smallest preconditioned eigenvalues, which set the
count's growth with the box, are those of the pressure block (``benchmarks/RESULTS.md``, "Issue
16 item 4, iteration growth").  Memory: about 1 B per voxel for the coarse operator, its
hierarchy and work arrays (0.12 B at 8 cells)."""

CYCLES = 4
"""Multigrid-preconditioned iterations for the Poisson velocity ``A^-1 w`` of each component."""

SMOOTH = 3
"""Blocks per axis of the window over which ``phi`` and ``s`` are averaged."""

WEIGHT = 0.6
"""Weight of the coarse term in the pressure block.  0.6 since session 11 (1.0 before): the
coarse term over-corrects where the Poisson permeability exceeds the Darcy one (the largest
negative Ritz value of the preconditioned system, -1.25 / -1.47 / -1.75 at 100 / 200 / 300 um
with 1.0, -1.05 / -1.17 / -1.37 with 0.6).  Toray-like at 1 um, SYMMLQ to 1e-6, first-cycle
floor 1e-5, 100 um: weight 0.5 131, 0.6 131, 0.7 133 iterations (``benchmarks/RESULTS.md``,
"Issue 16 item 4, iteration growth (iter11)")."""

FACE_FLOOR = 2.0
"""Floor of a coarse transmissibility: this multiple of the interface's sum of ``w_f^2 / A_ff``
over the velocity unknowns crossing it (staircase ``1 / A_ff``), the edge weight of the block
graph Laplacian ``R L R^T`` of ``L = G^T diag(A)^-1 G`` (0: no floor, session 13 and before).
Why: ``A`` is diagonally dominant, so ``A^-1 >= diag(A)^-1 / 2`` and the Galerkin coarse Schur
complement ``R S R^T`` is at least ``R L R^T / 2``; where the Darcy transmissibility falls well
below the face sums (blocks of a small open pore in a region of low smoothed Poisson
permeability, 0.2-0.4 voxel^2 against a median of 16), the term over-corrects: those were the
far end of the preconditioned spectrum, the second refinement cycle's most negative Ritz values
-1.17 / -1.37 / -1.66 at 200 / 300 / 400 um on the Toray-like material (vectors on 30-60 cells
of one or two blocks).  Binds on 0.06-0.09 % of the interfaces there.  With 2: far end -1.03 /
-1.09 / -1.14; SYMMLQ iterations to 1e-6 at 100 / 200 / 300 / 400 um 104 / 139 / 164 / 182 ->
104 / 133 / 151 / 155; random sphere packs at porosity 0.25-0.5 (48^3-64^3) 261 / 193 / 161 ->
155 / 147 / 135 (floor 1: 155 / 156 / 144, 3: 166 / 152 / 131, 4: 181 / 160 / 128); the arrays
of ``docs/validation.md`` unchanged but one row (+2 of 80).  ``benchmarks/RESULTS.md``, "Issue
16 item 4, the far end of the spectrum (grow14)"."""

SHIFT = 1e-4
"""Diagonal shift of the coarse operator relative to its mean diagonal (regularises the constant
mode, which the projection removes)."""


_OPTS = {"cache": True, "fastmath": True, "nogil": True}


@nb.njit(inline="always")
def _bounds(c, f, nc, n):
    lo = c * f
    return lo, (n if c == nc - 1 else lo + f)


@parallel_kernel(**_OPTS)
def block_sum(r, fx, fy, fz, rc):
    """``rc = R r``: the sum of ``r`` over each block (the last block of an axis takes the
    remainder).  The ``fx fy`` rows of a block row are first added into one float64 row
    (plain vectorised loops), which is then summed block by block."""
    nx, ny, nz = r.shape
    ncx, ncy, ncz = rc.shape
    for ic in nb.prange(ncx):
        i0, i1 = _bounds(ic, fx, ncx, nx)
        buf = np.empty(nz)
        for jc in range(ncy):
            j0, j1 = _bounds(jc, fy, ncy, ny)
            buf[:] = 0.0
            for i in range(i0, i1):
                for j in range(j0, j1):
                    row = r[i, j]
                    for k in range(nz):
                        buf[k] += row[k]
            out = rc[ic, jc]
            for kc in range(ncz):
                k0, k1 = _bounds(kc, fz, ncz, nz)
                acc = 0.0
                for k in range(k0, k1):
                    acc += buf[k]
                out[kc] = acc


@nb.njit(inline="always")
def _expand_row(xr, fz, nz, weight, ex):
    """``ex[k] = float32(weight xr[k // fz])`` (the last block takes the remainder): the coarse
    row injected into a fine row buffer, so the fine loops are plain vectorised loops."""
    ncz = xr.shape[0]
    for kc in range(ncz):
        k0, k1 = _bounds(kc, fz, ncz, nz)
        cv = np.float32(weight * xr[kc])
        for k in range(k0, k1):
            ex[k] = cv


@nb.njit(inline="always")
def _coarse_row(xc, ic, j, fy, fz, nz, weight, ex, last):
    """Expand the coarse row ``(ic, j // fy)`` into ``ex`` (:func:`_expand_row`) unless ``last``
    says it is there already; returns its index.  Once per block row, not per fine row: formed
    for every fine row it took half of :func:`pressure_block_code`'s time (band11)."""
    jc = min(j // fy, xc.shape[1] - 1)
    if jc != last:
        _expand_row(xc[ic, jc], fz, nz, weight, ex)
    return jc


@nb.njit(inline="always")
def _block_row(rr, sr, fr, ex, zr):
    """``zr = sr rr + ex (fr != 0)`` on one row (``fr`` the pressure-cell mask, or the
    staircase's scale code standing in for it); returns the float64 ``rr . zr``."""
    acc = 0.0
    for k in range(rr.shape[0]):
        v = rr[k] * sr[k] + ex[k] * np.float32(fr[k] != 0)
        zr[k] = v
        acc += np.float64(rr[k]) * np.float64(v)
    return acc


@parallel_kernel(**_OPTS)
def pressure_block_code(code, table, fluid, r, xc, fx, fy, fz, weight, z):
    """Staircase two-level pressure block in one pass: ``z = table[code] r + weight R^T xc``
    (the Schur diagonal stored as a one-byte logarithmic code, :func:`schur_code`); returns
    ``r . z`` (float64).  ``table`` has the structure of :data:`CODE_TABLE` (``table[c] =
    table[32 + c % 16] 2^(c // 16 + CODE_SHIFT)``): the look-up runs 16 codes at a time by
    :func:`solvers.voxel.simd.code_scale16` (a register permute and an exponent add, the same
    float32 values; a gather from the table cost a third of the kernel) into a row buffer.  The
    injected coarse row is formed once per block row (:func:`_coarse_row`)."""
    nx, ny, nz = r.shape
    ncx, ncy, ncz = xc.shape
    mant = table[32:48]
    part = np.zeros(nx)
    for i in nb.prange(nx):
        ic = min(i // fx, ncx - 1)
        ex = np.empty(nz, np.float32)
        sr = np.empty(nz, np.float32)
        acc = 0.0
        last = -1
        for j in range(ny):
            last = _coarse_row(xc, ic, j, fy, fz, nz, weight, ex, last)
            cr = code[i, j]
            k = 0
            while k + simd.WIDTH <= nz:  # 16 scales from the mantissas in one register
                simd.code_scale16(cr, k, mant, CODE_SHIFT, sr)
                k += simd.WIDTH
            for t in range(k, nz):
                sr[t] = table[cr[t]]
            acc += _block_row(r[i, j], sr, fluid[i, j], ex, z[i, j])
        part[i] = acc
    return ordered_sum(part)


CODE_STEPS = 16
"""Codes per octave of the one-byte Schur-diagonal scale (a relative step of 2^(1/16) - 1 =
4.4 %, at most 2.2 % off: any fixed SPD diagonal is a valid preconditioner)."""

CODE_TABLE = (2.0 ** ((np.arange(256) - 32) / CODE_STEPS)).astype(np.float32)
"""Scale of each code: ``2^((c - 32) / 16)``, 0.25 to 1.6e4 (the floor 1e-4 of the Schur
diagonal gives at most 1e4)."""

CODE_SHIFT = -2
"""``CODE_TABLE[c] = CODE_TABLE[32 + c % 16] * 2^(c // 16 + CODE_SHIFT)`` exactly (a power of two
only moves the float32 exponent): :func:`pressure_block_code` forms the scales from the 16
mantissas ``CODE_TABLE[32:48]`` (:func:`solvers.voxel.simd.code_scale16`)."""

_c = np.arange(256)
if not np.array_equal(CODE_TABLE, np.ldexp(CODE_TABLE[32 + _c % 16], _c // 16 + CODE_SHIFT)):
    raise AssertionError("CODE_TABLE is not 16 mantissas times powers of two")
del _c


_UNIT_INVERSE = np.divide(
    1.0, np.arange(256, dtype=np.uint8), out=np.zeros(256, np.float32), where=np.arange(256) > 0
)
"""``1 / k`` of every one-byte diagonal ``k`` (0 at 0), by the very expression
:func:`unit_inverse` stands for, so the look-up gives its bits."""


def unit_inverse(da: np.ndarray) -> np.ndarray:
    """``1 / A_ff`` of the faces of one velocity component (float32, 0 off the active faces,
    where the diagonal ``da`` is 0): the staircase faces' part of the Schur diagonal.

    A one-byte diagonal (the staircase's) takes it from a 256-entry table: one gather
    instead of a masked float64 division and its cast (200^3, one thread, load 5: 17 ms
    instead of 33 ms per component on warm memory; ``benchmarks/RESULTS.md``, session 48);
    the same float32 values (the table is that division of every byte)."""
    if da.dtype == np.uint8:
        return _UNIT_INVERSE[da]
    return np.divide(1.0, da, out=np.zeros(da.shape, np.float32), where=da > 0)


def _add_upper(s2: np.ndarray, q: np.ndarray, a: int) -> None:
    """``s2 += np.roll(q, -1, axis=a)`` (the face at the upper neighbour along ``a``, periodic)
    as two slice additions (:func:`solvers.voxel.multigrid.roll_halves`): the same sums
    without the rolled copy (4 B per cell)."""
    for dst, src in mg.roll_halves(a, -1):
        s2[dst] += q[src]


def schur_code(
    diags: list[np.ndarray], floor: float, faces: list[np.ndarray] | None = None
) -> np.ndarray:
    """One-byte code of the staircase pressure scale ``1 / max(floor, sum over the cell's faces
    of 1 / A_ff)`` (the diagonal of ``G^T diag(A)^-1 G``; 1 in a wall-free box), nearest
    entry of :data:`CODE_TABLE`.  ``faces``: each component's ``w_f^2 / A_ff`` instead of
    ``1 / A_ff`` (sub-voxel weights, :meth:`solvers.voxel.cutfaces.CutFaces.scale_inverse`)."""
    s2 = np.zeros(diags[0].shape, np.float32)
    for a, da in enumerate(diags):
        if faces is not None:
            q = faces[a]
            faces[a] = None  # freed as it is summed
        else:
            q = unit_inverse(da)
        s2 += q
        _add_upper(s2, q, a)
        del q
    np.maximum(s2, floor, out=s2)
    np.log2(s2, out=s2)
    s2 *= -CODE_STEPS
    s2 += 32.0
    np.rint(s2, out=s2)
    np.clip(s2, 0, 255, out=s2)
    return s2.astype(np.uint8)


@nb.njit(cache=True, nogil=True)
def _block_count(fluid, fx, fy, fz, nf):
    """Number of fluid cells of every block (``nf`` zeroed by the caller)."""
    nx, ny, nz = fluid.shape
    ncx, ncy, ncz = nf.shape
    for i in range(nx):
        ic = min(i // fx, ncx - 1)
        for j in range(ny):
            jc = min(j // fy, ncy - 1)
            for k in range(nz):
                nf[ic, jc, min(k // fz, ncz - 1)] += fluid[i, j, k]


def poisson_velocity(
    smg: mg.ScalarMG,
    d: np.ndarray,
    c: np.ndarray,
    weight: np.ndarray | None,
    cycles: int,
) -> np.ndarray:
    """``w * A^-1 w`` approximated by ``cycles`` multigrid-preconditioned iterations (float32):
    the unconstrained velocity under a unit force, whose block mean is the Poisson permeability
    (``w`` the sub-voxel face weight, 1 on the staircase's active faces)."""
    if weight is None:
        b = np.empty(d.shape, np.float32)
        np.greater(d, 0, out=b)  # the 0/1 mask straight into float32 (no bool temporary)
    else:
        b = np.asarray(weight, np.float32)
    # the first cycle starts from u = 0: its residual is b itself and u its V-cycle (no copy
    # of b, no zero field to add to; 0 + e is e up to the sign of a zero, which no later step
    # reads: the results are bitwise those of the former copy and sum)
    u = np.empty(d.shape, np.float32)
    smg.apply(b, u)
    if cycles > 1:
        r = np.empty(d.shape, np.float32)
        e = np.empty(d.shape, np.float32)
        for _ in range(1, cycles):
            kr.lap_residual(d, c[0], c[1], c[2], u, b, r)
            smg.apply(r, e)
            u += e
        del r, e
    u *= b
    return u


def _starts(n: int, f: int, nc: int) -> np.ndarray:
    return np.arange(nc) * f if nc > 0 else np.zeros(1, int)


class CoarsePressure:
    """The coarse Darcy term ``R^T S_c^+ R`` of the pressure preconditioner (module docstring).

    Parameters
    ----------
    fluid : np.ndarray of uint8, shape (nx, ny, nz)
        Pressure unknowns (1 = fluid cell).
    diags : list of 3 np.ndarray
        Diagonals of the three velocity operators (``> 0`` on the velocity unknowns): an
        interface between two blocks is open when a velocity unknown crosses it.
    block : int
        Cells per axis of a block (:data:`BLOCK`).
    faces : callable, optional
        ``faces(a)``: ``w_f^2 / A_ff`` of component ``a``'s faces (sub-voxel walls,
        :meth:`solvers.voxel.cutfaces.CutFaces.scale_inverse`); None: ``1 / A_ff`` from the
        diagonals (staircase).  Sets the floor of the transmissibilities (:data:`FACE_FLOOR`).
    """

    def __init__(
        self,
        fluid: np.ndarray,
        ops: list[tuple[np.ndarray, np.ndarray]],
        mgs: list[mg.ScalarMG],
        weights: list[np.ndarray] | None = None,
        block: int | None = None,
        faces: Callable[[int], np.ndarray] | None = None,
    ) -> None:
        self._faces = faces
        shp = fluid.shape
        blk = BLOCK if block is None else int(block)
        self.f = tuple(max(1, min(blk, n)) for n in shp)
        nc = tuple(n // f for n, f in zip(shp, self.f, strict=True))
        self.nc = nc
        self.fluid = fluid
        nf = np.zeros(nc, np.int64)
        _block_count(fluid, *self.f, nf)
        vol = np.ones(nc)
        for a in range(3):
            sizes = np.full(nc[a], self.f[a], float)
            sizes[-1] = shp[a] - self.f[a] * (nc[a] - 1)
            vol = vol * sizes.reshape([-1 if b == a else 1 for b in range(3)])
        win = [min(SMOOTH, n) for n in nc]
        m_vol = ndimage.uniform_filter(vol, win, mode="wrap")
        kmax = float(max(shp)) ** 2
        self.permeability = []
        trans = []
        for a in range(3):
            w = None if weights is None else weights[a]
            # a wall-free periodic component has a singular A (its coarsest solve overflows):
            # its velocity is unbounded, i.e. the cap
            with np.errstate(over="ignore", invalid="ignore"):
                u = poisson_velocity(mgs[a], ops[a][0], ops[a][1], w, CYCLES)
                ku = np.zeros(nc, np.float32)
                block_sum(u, *self.f, ku)
            del u
            ku = np.nan_to_num(ku.astype(float), nan=kmax * m_vol.max(), posinf=kmax * m_vol.max())
            perm = ndimage.uniform_filter(ku, win, mode="wrap") / m_vol
            perm = np.clip(perm, 0.0, kmax)
            perm[nf == 0] = 0.0
            self.permeability.append(perm)
            trans.append(self._transmissibility(perm, ops[a][0], a))
        dc = np.zeros(nc)
        for a, t in enumerate(trans):
            dc += t + np.roll(t, -1, axis=a)
        live = dc > 0
        shift = SHIFT * float(dc[live].mean()) if live.any() else 0.0
        dc = np.where(live, dc + shift, 0.0)
        cc = np.stack([np.where(live, t, 0.0) for t in trans]).astype(np.float32)
        self.labels, self.n_comp = self._components(cc, live)
        self.live = live
        self.n_live = int(live.sum())
        self.dead = ~live
        self.mg = mg.ScalarMG(dc.astype(np.float32), cc, pre=2)
        self.rc = np.zeros(nc, np.float32)
        self.xc = np.zeros(nc, np.float32)
        self._code: np.ndarray | None = None

    def _planes(self, q: np.ndarray, a: int) -> np.ndarray:
        """The first plane of every block along ``a`` of a field on the faces of component
        ``a`` (the faces between block ``I - e_a`` and ``I``)."""
        return np.take(q, _starts(q.shape[a], self.f[a], self.nc[a]), axis=a)

    def _interface_sum(self, planes: np.ndarray, a: int) -> np.ndarray:
        """Sum of :meth:`_planes` over each block interface, per block ``I``."""
        for b in range(3):
            if b != a:
                planes = np.add.reduceat(
                    planes, _starts(planes.shape[b], self.f[b], self.nc[b]), axis=b
                )
        return planes

    def _opened(self, da: np.ndarray, a: int) -> np.ndarray:
        """Number of active velocity unknowns of component ``a`` on the interface between
        block ``I - e_a`` and ``I``, per block ``I``."""
        return self._interface_sum((self._planes(da, a) > 0).astype(np.int64), a)

    def _face_conductance(self, da: np.ndarray, a: int) -> np.ndarray:
        """``sum w_f^2 / A_ff`` over the velocity unknowns of component ``a`` on the interface
        between block ``I - e_a`` and ``I``, per block ``I``: the edge weight of the block graph
        Laplacian ``R L R^T`` of ``L = G^T diag(A)^-1 G`` (:data:`FACE_FLOOR`).  One plane at a
        time (a float64 copy of all the planes cost 2 B per cell at the set-up's peak)."""
        q = self._faces(a) if self._faces is not None else da  # sub-voxel: the caller's w^2 / A
        out = np.empty(self.nc)
        for ic, s in enumerate(_starts(da.shape[a], self.f[a], self.nc[a])):
            plane = np.take(q, [s], axis=a).astype(np.float64)
            if self._faces is None:
                np.divide(1.0, plane, out=plane, where=plane > 0)
            idx = [slice(None)] * 3
            idx[a] = slice(ic, ic + 1)
            out[tuple(idx)] = self._interface_sum(plane, a)
        return out

    def _transmissibility(self, perm: np.ndarray, da: np.ndarray, a: int) -> np.ndarray:
        """``T[I]`` between block ``I - e_a`` and ``I``: harmonic-mean permeability times face
        area over length, 0 where no velocity unknown of component ``a`` crosses."""
        nc = self.nc
        opened = self._opened(da, a)
        lower = np.roll(perm, 1, axis=a)
        with np.errstate(invalid="ignore", divide="ignore"):
            hm = np.where((perm > 0) & (lower > 0), 2.0 * perm * lower / (perm + lower), 0.0)
        area = float(np.prod([self.f[b] for b in range(3) if b != a]))
        t = hm * area / self.f[a]
        if FACE_FLOOR > 0:  # no softer than the pore-scale face graph (FACE_FLOOR)
            t = np.maximum(t, FACE_FLOOR * self._face_conductance(da, a))
        t[opened == 0] = 0.0
        if nc[a] == 1:
            t[...] = 0.0  # one block along a: no interface of its own
        return t

    @staticmethod
    def _components(cc: np.ndarray, live: np.ndarray) -> tuple[np.ndarray, int]:
        """Connected components of the coarse graph (labels -1 on dead blocks)."""
        nc = live.shape
        n = live.size
        idx = np.arange(n).reshape(nc)
        rows, cols = [], []
        for a in range(3):
            keep = (cc[a] > 0).ravel()
            rows.append(idx.ravel()[keep])
            cols.append(np.roll(idx, 1, axis=a).ravel()[keep])
        r = np.concatenate(rows)
        c = np.concatenate(cols)
        graph = coo_matrix((np.ones(r.size), (r, c)), shape=(n, n))
        _, lab = connected_components(graph, directed=False)
        lab = lab.reshape(nc)
        lab = np.where(live, lab, -1)
        uniq, inv = np.unique(lab[live], return_inverse=True)
        out = np.full(nc, -1, np.int64)
        out[live] = inv
        return out, int(uniq.size)

    def _project(self, v: np.ndarray) -> None:
        """Zero mean of ``v`` on every connected component; 0 on dead blocks (in place)."""
        live = self.live
        if self.n_comp == 1:  # the usual case: two plain passes instead of gathers
            np.copyto(v, 0.0, where=self.dead)
            mean = float(v.sum(dtype=np.float64)) / float(self.n_live)
            np.subtract(v, v.dtype.type(mean), out=v, where=live)
            return
        lab = self.labels[live]
        vals = v[live].astype(np.float64)
        mean = np.bincount(lab, vals, self.n_comp) / np.bincount(lab, None, self.n_comp)
        v[live] = (vals - mean[lab]).astype(v.dtype)
        v[~live] = 0.0

    def apply(
        self,
        r: np.ndarray,
        z: np.ndarray,
        diags: list[np.ndarray],
        floor: float = 1e-4,
    ) -> float:
        """The whole pressure block ``z = D^-1 r + R^T S_c^+ R r``; returns ``r . z``
        (float64).  ``D^-1`` is the Schur diagonal as a one-byte code: the one given by
        :meth:`use_code` (sub-voxel walls), else that of the velocity ``diags`` (staircase,
        clamped at ``floor``; :func:`schur_code`).
        Two passes over the pressure field: the restriction and one fused write."""
        self.solve(r)
        code = self.code(diags, floor)
        rz = pressure_block_code(code, CODE_TABLE, self.fluid, r, self.xc, *self.f, WEIGHT, z)
        return float(rz)

    def solve(self, r: np.ndarray) -> np.ndarray:
        """``xc = S_c^+ R r`` into :attr:`xc` (restriction, projection, one V-cycle,
        projection); :meth:`apply` injects ``WEIGHT xc`` into the fine cells."""
        block_sum(r, *self.f, self.rc)
        self._project(self.rc)
        self.mg.apply(self.rc, self.xc)
        self._project(self.xc)
        return self.xc

    def use_code(self, code: np.ndarray) -> None:
        """Take a scale code formed by the caller (:func:`schur_code`: the sub-voxel weights's, or
        the staircase's from the faces it shares with the thin blocks)."""
        self._code = code

    @property
    def stored_code(self) -> np.ndarray | None:
        """The scale code in use (None before the first :meth:`code` or :meth:`use_code`)."""
        return self._code

    def code(self, diags: list[np.ndarray], floor: float) -> np.ndarray:
        """The staircase scale code (:func:`schur_code`), formed on first use and kept
        (1 B per voxel)."""
        if self._code is None:
            self._code = schur_code(diags, floor)
        return self._code

    @property
    def nbytes(self) -> int:
        """Bytes held by the coarse operator, its multigrid hierarchy and work arrays."""
        total = self.rc.nbytes + self.xc.nbytes + self.labels.nbytes + 2 * self.live.nbytes
        total += sum(p.nbytes for p in self.permeability)
        total += 0 if self._code is None else self._code.nbytes
        for lev in self.mg.levels:
            total += lev.d.nbytes + lev.c.nbytes + lev.x.nbytes + lev.t.nbytes + lev.b.nbytes
        return int(total)
