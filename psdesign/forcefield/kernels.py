"""Compiled (numba) kernels for PS fiber fields.

The force-field quadratures of :mod:`.tube` and :mod:`.potentials` spend their time in
small loops with many field evaluations (Newton iterations per surface ray, per section
centre and per overlap lens) and in sums over volume grids. Written with numpy these
loops are dominated by temporaries and Python overhead; here each runs in one compiled
call. A PS model is passed as the tuple :func:`model_arrays` returns; a fiber field is
``phi = scale * (psi - isovalue)``.

All kernels are serial and deterministic (same input, same bits).
"""

from __future__ import annotations

import math

import numba
import numpy as np

import solvers.jit  # noqa: F401  (numba cache stamps cover the imported modules)
from psdesign.geometry.model import GeneralizedPS
from psdesign.geometry.ps_kernel import psi_point, term_phase

#: status codes returned by :func:`section_roots`
OK, NO_SOLID, BEYOND_RADIUS, NOT_CONVERGED = 0, 1, 2, 3


def model_arrays(model: GeneralizedPS) -> tuple:
    """The arrays of a PS model in the order the kernels take them."""
    return (
        model.mu,
        model.kappa,
        np.ascontiguousarray(model.H),
        model.alpha,
        model.minor_term.astype(np.int64),
        model.u,
        model.f,
        np.ascontiguousarray(model.G),
        model.beta,
    )


# ------------------------------------------------------------------ tube sections
@numba.njit(cache=True)
def section_centres(m, base, e1, e2):  # pragma: no cover
    """Field minimum in each cross-section plane: 2-D Newton from ``base`` (n, 3).

    Gradient-descent step (1e-3) where the plane Hessian is not positive definite; at most
    12 iterations, stops when the step is below 1e-12. Scale and isovalue do not matter.
    """
    n = base.shape[0]
    out = np.empty((n, 3))
    g = np.zeros(3)
    hs = np.zeros((3, 3))
    for k in range(n):
        c0, c1, c2 = base[k, 0], base[k, 1], base[k, 2]
        for _ in range(12):
            psi_point(m, c0, c1, c2, g, hs, 2)
            ga = g[0] * e1[0] + g[1] * e1[1] + g[2] * e1[2]
            gb = g[0] * e2[0] + g[1] * e2[1] + g[2] * e2[2]
            haa = hab = hba = hbb = 0.0
            for a in range(3):
                for b in range(3):
                    haa += e1[a] * hs[a, b] * e1[b]
                    hab += e1[a] * hs[a, b] * e2[b]
                    hba += e2[a] * hs[a, b] * e1[b]
                    hbb += e2[a] * hs[a, b] * e2[b]
            det = haa * hbb - hab * hba
            if det > 0:
                sa = (hbb * ga - hab * gb) / det
                sb = (haa * gb - hba * ga) / det
            else:
                nrm = max(math.sqrt(ga * ga + gb * gb), 1e-30)
                sa = 1e-3 * ga / nrm
                sb = 1e-3 * gb / nrm
            c0 -= sa * e1[0] + sb * e2[0]
            c1 -= sa * e1[1] + sb * e2[1]
            c2 -= sa * e1[2] + sb * e2[2]
            if max(abs(sa), abs(sb)) < 1e-12:
                break
        out[k, 0], out[k, 1], out[k, 2] = c0, c1, c2
    return out


@numba.njit(cache=True)
def section_roots(m, iso, scale, c, e, radius, max_iter):  # pragma: no cover
    """Surface distance ``rho`` along every ray ``c[k] + rho e[j]`` (section-major).

    Bracket ``[0, radius]``, start from the quadratic model of the field at the centre,
    safeguarded Newton (bisection when the Newton step leaves the bracket) until the step
    is below 1e-10. Returns ``(rho, phi(c), status)`` with status :data:`OK`,
    :data:`NO_SOLID` (a centre is not inside), :data:`BEYOND_RADIUS` (a ray is still inside
    at ``radius``) or :data:`NOT_CONVERGED`.
    """
    ns, nt = c.shape[0], e.shape[0]
    rho = np.zeros(ns * nt)
    vc = np.empty(ns)
    g = np.zeros(3)
    hs = np.zeros((3, 3))
    vmax = 1.0
    for k in range(ns):
        vc[k] = scale * (psi_point(m, c[k, 0], c[k, 1], c[k, 2], g, hs, 0) - iso)
        if vc[k] >= 0:
            return rho, vc, NO_SOLID
        vmax = max(vmax, abs(vc[k]))
    for k in range(ns):
        for j in range(nt):
            vout = scale * (
                psi_point(
                    m,
                    c[k, 0] + radius * e[j, 0],
                    c[k, 1] + radius * e[j, 1],
                    c[k, 2] + radius * e[j, 2],
                    g,
                    hs,
                    0,
                )
                - iso
            )
            if vout <= 0:
                return rho, vc, BEYOND_RADIUS
    for k in range(ns):
        psi_point(m, c[k, 0], c[k, 1], c[k, 2], g, hs, 2)
        hc = hs.copy()
        for j in range(nt):
            e0, e1_, e2_ = e[j, 0], e[j, 1], e[j, 2]
            curv = 0.0
            for a in range(3):
                for b in range(3):
                    curv += e[j, a] * scale * hc[a, b] * e[j, b]
            r = math.sqrt(-2.0 * vc[k] / curv) if curv > 0 else 0.5 * radius
            if not (math.isfinite(r) and r > 0):
                r = 0.5 * radius
            r = min(max(r, 1e-6 * radius), 0.999 * radius)
            r_lo, r_hi = 0.0, radius
            done = False
            v = 0.0
            for _ in range(max_iter):
                v = scale * (
                    psi_point(m, c[k, 0] + r * e0, c[k, 1] + r * e1_, c[k, 2] + r * e2_, g, hs, 1)
                    - iso
                )
                dv = scale * (g[0] * e0 + g[1] * e1_ + g[2] * e2_)
                if v <= 0:
                    r_lo = r
                else:
                    r_hi = r
                newton = r - v / dv if dv != 0 else r
                if newton > r_lo and newton < r_hi and dv > 0:
                    r_new = newton
                else:
                    r_new = 0.5 * (r_lo + r_hi)
                step = abs(r_new - r)
                r = r_new
                if step < 1e-10:
                    done = True
                    break
            if not done and abs(v) > 1e-8 * vmax:
                return rho, vc, NOT_CONVERGED
            rho[k * nt + j] = r
    return rho, vc, OK


# ---------------------------------------------------------------- pair overlap
@numba.njit(cache=True)
def fill_tables(m, group, deps, meta, ax, ay, az, size):  # pragma: no cover
    """Values of :func:`.fields.packed_tables`: table ``t`` at node (i, j, k) of its
    broadcast shape holds ``sum_{group[i] = t} mu_i cos(Phi_i)``."""
    mu = m[0]
    flat = np.zeros(size)
    for t in range(deps.shape[0]):
        nx = ax.shape[0] if deps[t, 0] else 1
        ny = ay.shape[0] if deps[t, 1] else 1
        nz = az.shape[0] if deps[t, 2] else 1
        for i in range(nx):
            x0 = ax[i] if deps[t, 0] else 0.0
            for j in range(ny):
                x1 = ay[j] if deps[t, 1] else 0.0
                for k in range(nz):
                    x2 = az[k] if deps[t, 2] else 0.0
                    val = 0.0
                    for n in range(mu.shape[0]):
                        if group[n] == t:
                            val += mu[n] * math.cos(term_phase(m, n, x0, x1, x2))
                    flat[meta[t, 0] + i * meta[t, 1] + j * meta[t, 2] + k * meta[t, 3]] = val
    return flat


@numba.njit(cache=True)
def _split_tables(meta):  # pragma: no cover
    """Rows of ``meta`` that vary along z, and those that do not."""
    n = meta.shape[0]
    nz = 0
    for t in range(n):
        if meta[t, 3] != 0:
            nz += 1
    zdep = np.empty(nz, dtype=np.int64)
    zfree = np.empty(n - nz, dtype=np.int64)
    a = b = 0
    for t in range(n):
        if meta[t, 3] != 0:
            zdep[a] = t
            a += 1
        else:
            zfree[b] = t
            b += 1
    return zdep, zfree


@numba.njit(cache=True, inline="always")
def _field_row(flat, meta, iso, zdep, zfree, i, j, out):  # pragma: no cover
    """``out[k] = psi(i, j, k) - iso`` for one row along z from separable term tables
    (tables constant along z summed once, the others row by row)."""
    nz = out.shape[0]
    c0 = -iso
    for t in zfree:
        c0 += flat[meta[t, 0] + i * meta[t, 1] + j * meta[t, 2]]
    out[:] = c0
    for t in zdep:
        base = meta[t, 0] + i * meta[t, 1] + j * meta[t, 2]
        sz = meta[t, 3]
        for k in range(nz):
            out[k] += flat[base + k * sz]


@numba.njit(cache=True)
def pair_max_grid(
    flat_a, meta_a, iso_a, sc_a, flat_b, meta_b, iso_b, sc_b, wx, wy, wz
):  # pragma: no cover
    """``m = max(phi_a, phi_b)`` on a tensor grid from separable term tables.

    ``psi`` of a field at node (i, j, k) is ``sum_t flat[o_t + i sx_t + j sy_t + k sz_t]``
    with ``meta[t] = (o_t, sx_t, sy_t, sz_t)`` (stride 0 along axes a table does not
    depend on; tables constant along z are summed once per (i, j), the others row by
    row). Returns ``(m, int -min(m, 0) dV, slope)`` with the trapezoid weights ``w`` and
    ``slope`` the largest difference of neighbouring nodes of ``m`` along any axis (the
    bound of :func:`lens_minima`).
    """
    nx, ny, nz = wx.shape[0], wy.shape[0], wz.shape[0]
    m = np.empty((nx, ny, nz))
    za, fa = _split_tables(meta_a)
    zb, fb = _split_tables(meta_b)
    ra = np.empty(nz)
    rb = np.empty(nz)
    total = 0.0
    bound = 0.0
    for i in range(nx):
        for j in range(ny):
            wij = wx[i] * wy[j]
            _field_row(flat_a, meta_a, iso_a, za, fa, i, j, ra)
            _field_row(flat_b, meta_b, iso_b, zb, fb, i, j, rb)
            row = m[i, j]
            for k in range(nz):
                row[k] = max(sc_a * ra[k], sc_b * rb[k])
            for k in range(nz):
                v = row[k]
                if v < 0:
                    total -= v * wij * wz[k]
            for k in range(1, nz):
                bound = max(bound, abs(row[k] - row[k - 1]))
            if j > 0:
                prev = m[i, j - 1]
                for k in range(nz):
                    bound = max(bound, abs(row[k] - prev[k]))
            if i > 0:
                prev = m[i - 1, j]
                for k in range(nz):
                    bound = max(bound, abs(row[k] - prev[k]))
    return m, total, bound


@numba.njit(cache=True)
def lens_candidates(m):  # pragma: no cover
    """Interior local minima of ``m`` within one grid slope of zero.

    The slope bound is the largest difference of neighbouring nodes along any axis. A node
    qualifies if it is not above its six neighbours and below the largest of those
    differences. Returns ``(values, indices (n, 3))`` in C order.
    """
    nx, ny, nz = m.shape
    bound = 0.0
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                v = m[i, j, k]
                if i + 1 < nx:
                    bound = max(bound, abs(m[i + 1, j, k] - v))
                if j + 1 < ny:
                    bound = max(bound, abs(m[i, j + 1, k] - v))
                if k + 1 < nz:
                    bound = max(bound, abs(m[i, j, k + 1] - v))
    return lens_minima(m, bound)


@numba.njit(cache=True)
def lens_minima(m, bound):  # pragma: no cover
    """The candidates of :func:`lens_candidates` for a given slope ``bound``."""
    nx, ny, nz = m.shape
    vals = []
    idx = []
    if nx < 3 or ny < 3 or nz < 3:
        return np.array(vals, dtype=np.float64), np.zeros((0, 3), dtype=np.int64)
    for i in range(1, nx - 1):
        for j in range(1, ny - 1):
            for k in range(1, nz - 1):
                c = m[i, j, k]
                if not c < bound:
                    continue
                nb = (
                    m[i + 1, j, k],
                    m[i - 1, j, k],
                    m[i, j + 1, k],
                    m[i, j - 1, k],
                    m[i, j, k + 1],
                    m[i, j, k - 1],
                )
                ok = True
                spread = 0.0
                for q in nb:
                    if c > q:
                        ok = False
                    spread = max(spread, abs(q - c))
                if ok and c < spread:
                    vals.append(c)
                    idx.append((i, j, k))
    out = np.zeros((len(idx), 3), dtype=np.int64)
    for n in range(len(idx)):
        out[n, 0], out[n, 1], out[n, 2] = idx[n]
    return np.array(vals, dtype=np.float64), out


@numba.njit(cache=True)
def _solve4(J, F):  # pragma: no cover
    """Solve ``J x = F`` (4x4, partial pivoting); ``ok`` False on an exactly zero pivot."""
    A = J.copy()
    b = F.copy()
    n = 4
    for col in range(n):
        p = col
        for r in range(col + 1, n):
            if abs(A[r, col]) > abs(A[p, col]):
                p = r
        if A[p, col] == 0.0:
            return b, False
        if p != col:
            for q in range(n):
                A[col, q], A[p, q] = A[p, q], A[col, q]
            b[col], b[p] = b[p], b[col]
        for r in range(col + 1, n):
            fac = A[r, col] / A[col, col]
            for q in range(col, n):
                A[r, q] -= fac * A[col, q]
            b[r] -= fac * b[col]
    for r in range(n - 1, -1, -1):
        s = b[r]
        for q in range(r + 1, n):
            s -= A[r, q] * b[q]
        b[r] = s / A[r, r]
    return b, True


@numba.njit(cache=True)
def deepest_point(ma, iso_a, sc_a, mb, iso_b, sc_b, x0, reach):  # pragma: no cover
    """Minimax point of ``(phi_a, phi_b)`` near ``x0``: Newton on
    ``grad phi_a + lam grad phi_b = 0``, ``phi_a = phi_b`` (at most 30 steps).

    Returns ``(x, ok)``; ``ok`` is False if Newton fails, ``lam <= 0`` or the point lies
    farther than ``reach`` from ``x0``.
    """
    ga = np.zeros(3)
    gb = np.zeros(3)
    ha = np.zeros((3, 3))
    hb = np.zeros((3, 3))
    x = x0.copy()
    psi_point(ma, x[0], x[1], x[2], ga, ha, 1)
    psi_point(mb, x[0], x[1], x[2], gb, hb, 1)
    na = sc_a * math.sqrt(ga[0] ** 2 + ga[1] ** 2 + ga[2] ** 2)
    nb = sc_b * math.sqrt(gb[0] ** 2 + gb[1] ** 2 + gb[2] ** 2)
    lam = na / max(nb, 1e-30)
    J = np.zeros((4, 4))
    F = np.zeros(4)
    for _ in range(30):
        va = sc_a * (psi_point(ma, x[0], x[1], x[2], ga, ha, 2) - iso_a)
        vb = sc_b * (psi_point(mb, x[0], x[1], x[2], gb, hb, 2) - iso_b)
        for a in range(3):
            F[a] = sc_a * ga[a] + lam * sc_b * gb[a]
            for b in range(3):
                J[a, b] = sc_a * ha[a, b] + lam * sc_b * hb[a, b]
            J[a, 3] = sc_b * gb[a]
            J[3, a] = sc_a * ga[a] - sc_b * gb[a]
        J[3, 3] = 0.0
        F[3] = va - vb
        step, ok = _solve4(J, -F)
        if not ok:
            return x, False
        for a in range(3):
            x[a] += step[a]
        lam += step[3]
        if max(abs(step[0]), abs(step[1]), abs(step[2]), abs(step[3])) < 1e-12:
            break
    dist = math.sqrt((x[0] - x0[0]) ** 2 + (x[1] - x0[1]) ** 2 + (x[2] - x0[2]) ** 2)
    finite = math.isfinite(x[0]) and math.isfinite(x[1]) and math.isfinite(x[2])
    return x, bool(lam > 0 and finite and dist <= reach)
