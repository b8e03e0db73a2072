"""Vectorized Taylor-Hood (P2-P1) assembly with scikit-fem, chunked over elements.

The viscous term is written in the gradient (Laplacian) form ``mu (grad u, grad v)``. With
constant viscosity and a divergence-free velocity it is equivalent to the symmetric-gradient
form in the interior; its natural boundary condition ``mu du/dn - p n = -p0 n`` is the usual
"do-nothing" outflow condition at the inlet and outlet, and on a flat slip face (u.n = 0
imposed) it leaves ``du_t/dn = 0``, which is exactly the symmetry-plane condition. The form
is block diagonal: the three velocity components share one scalar P2 Laplacian, so only one
scalar matrix (100 entries per tetrahedron instead of 900) is assembled.

Quadrature: all volume integrands are polynomials of degree <= 2 (grad P2 . grad P2,
P1 * grad P2, P1 * P1), so the 4-point degree-2 rule (``intorder=2``) is exact; skfem's
default for P2 would use a much larger rule and memory.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from skfem import (
    BilinearForm,
    CellBasis,
    ElementTetP1,
    ElementTetP2,
    FacetBasis,
    Functional,
    LinearForm,
    MeshTet,
    asm,
)
from skfem.helpers import dot, grad

INTORDER = 2


@BilinearForm
def _laplace(u, v, w):
    return dot(grad(u), grad(v))


def _div_form(axis: int) -> BilinearForm:
    @BilinearForm
    def form(u, v, w):
        return u.grad[axis] * v

    return form


@BilinearForm
def _mass(u, v, w):
    return u * v


def make_mesh(points: np.ndarray, tets: np.ndarray) -> MeshTet:
    """scikit-fem mesh from (n,3) points and (m,4) tetrahedra (no copy of the input order)."""
    return MeshTet(
        np.ascontiguousarray(points.T, dtype=np.float64),
        np.ascontiguousarray(tets.T, dtype=np.int64),
        validate=False,
    )


def p2_dofs(mesh: MeshTet):
    """Global P2 dof numbering (vertices first, then edges) and the number of P2 nodes."""
    basis = CellBasis(mesh, ElementTetP2(), intorder=INTORDER, elements=np.array([0]))
    return basis.dofs, basis.N


def assemble_volume(
    mesh: MeshTet,
    chunk: int = 100_000,
    progress: Callable[[int, int], None] | None = None,
):
    """Scalar P2 Laplacian, the three P1 x P2 derivative blocks and the lumped P1 mass.

    Parameters
    ----------
    mesh : MeshTet
    chunk : int
        Elements per assembly batch (bounds the temporary COO memory).
    progress : callable, optional
        ``progress(elements_done, n_elements)`` after each batch (the last call with
        ``elements_done == n_elements``); the caller throttles what it prints.

    Returns
    -------
    L : csr_matrix (n2, n2)
        ``L[i, j] = int grad phi_j . grad phi_i`` (P2).
    D : list of three csr_matrix (n1, n2)
        ``D[c][i, j] = int psi_i d(phi_j)/dx_c`` (P1 test psi, P2 trial phi).
    m_lumped : ndarray (n1,)
        Row sums of the P1 mass matrix.
    """
    dofs2, _ = p2_dofs(mesh)
    n_el = mesh.t.shape[1]
    L = None
    D = [None, None, None]
    m_lumped = None
    for start in range(0, n_el, chunk):
        idx = np.arange(start, min(start + chunk, n_el))
        vb = CellBasis(mesh, ElementTetP2(), intorder=INTORDER, elements=idx, dofs=dofs2)
        pb = CellBasis(mesh, ElementTetP1(), quadrature=vb.quadrature, elements=idx)
        Lc = asm(_laplace, vb).tocsr()
        L = Lc if L is None else L + Lc
        del Lc
        for c in range(3):
            Dc = asm(_div_form(c), vb, pb).tocsr()
            D[c] = Dc if D[c] is None else D[c] + Dc
        mc = np.asarray(asm(_mass, pb).sum(axis=1)).ravel()
        m_lumped = mc if m_lumped is None else m_lumped + mc
        del vb, pb
        if progress is not None:
            progress(int(idx[-1]) + 1, n_el)
    L.sum_duplicates()
    L.eliminate_zeros()
    return L, D, m_lumped


def assemble_normal_load(mesh: MeshTet, facets: np.ndarray) -> np.ndarray:
    """``int_F n_c phi_j ds`` for the P2 functions, as a (3, n2) array (outward normal)."""
    dofs2, n2 = p2_dofs(mesh)
    out = np.zeros((3, n2))
    if len(facets) == 0:
        return out
    fb = FacetBasis(mesh, ElementTetP2(), facets=facets, intorder=INTORDER, dofs=dofs2)
    for c in range(3):

        @LinearForm
        def lf(v, w, c=c):
            return w.n[c] * v

        out[c] = asm(lf, fb)
    return out


def assemble_volume_load(mesh: MeshTet) -> np.ndarray:
    """``int phi_j dV`` of the P2 functions (n2,) (a unit body force; degree-2 rule, exact)."""
    dofs2, _ = p2_dofs(mesh)
    vb = CellBasis(mesh, ElementTetP2(), intorder=INTORDER, dofs=dofs2)

    @LinearForm
    def lf(v, w):
        return v

    return asm(lf, vb)


def volume_integral(mesh: MeshTet, u: np.ndarray) -> np.ndarray:
    """``int u dV`` (3,) of a P2 field ``u`` (3, n2)."""
    return np.array([assemble_volume_load(mesh) @ u[c] for c in range(3)])


def facet_flux(mesh: MeshTet, facets: np.ndarray, u: np.ndarray) -> float:
    """Volumetric flow rate ``int_F u . n ds`` (outward normal) of a P2 velocity.

    Parameters
    ----------
    u : (3, n2) array of P2 velocity dofs.
    """
    if len(facets) == 0:
        return 0.0
    dofs2, _ = p2_dofs(mesh)
    fb = FacetBasis(mesh, ElementTetP2(), facets=facets, intorder=INTORDER, dofs=dofs2)

    @Functional
    def flux(w):
        return w.ux * w.n[0] + w.uy * w.n[1] + w.uz * w.n[2]

    return float(
        asm(flux, fb, ux=fb.interpolate(u[0]), uy=fb.interpolate(u[1]), uz=fb.interpolate(u[2]))
    )


def weighted_dissipation(mesh: MeshTet, u: np.ndarray, weight, chunk: int = 100_000) -> float:
    """``int w |grad u|^2 dV`` of a P2 velocity ``u`` (3, n2), weight ``w = weight(x)`` at the
    quadrature points (x: (k, 3) mesh coordinates), degree-4 rule."""
    dofs2, _ = p2_dofs(mesh)
    n_el = mesh.t.shape[1]

    @Functional
    def form(w):
        return w.wt * (
            dot(w.u0.grad, w.u0.grad) + dot(w.u1.grad, w.u1.grad) + dot(w.u2.grad, w.u2.grad)
        )

    total = 0.0
    for start in range(0, n_el, chunk):
        idx = np.arange(start, min(start + chunk, n_el))
        vb = CellBasis(mesh, ElementTetP2(), intorder=4, elements=idx, dofs=dofs2)
        xq = np.asarray(vb.global_coordinates())  # (3, n_el, n_qp); .value is deprecated
        wq = weight(xq.reshape(3, -1).T).reshape(xq.shape[1:])
        total += float(
            asm(
                form,
                vb,
                wt=wq,
                u0=vb.interpolate(u[0]),
                u1=vb.interpolate(u[1]),
                u2=vb.interpolate(u[2]),
            )
        )
    return total


def facet_mean(mesh: MeshTet, facets: np.ndarray, p1: np.ndarray) -> tuple[float, float]:
    """Integral of a P1 field over boundary facets and their area: (int p ds, area)."""
    if len(facets) == 0:
        return 0.0, 0.0
    fb = FacetBasis(mesh, ElementTetP1(), facets=facets, intorder=INTORDER)

    @Functional
    def integ(w):
        return w.f

    @Functional
    def area(w):
        return 1.0 + 0.0 * w.x[0]

    return float(asm(integ, fb, f=fb.interpolate(p1))), float(asm(area, fb))


def to_csr(m) -> sp.csr_matrix:
    """Canonical CSR copy."""
    m = sp.csr_matrix(m)
    m.sum_duplicates()
    return m
