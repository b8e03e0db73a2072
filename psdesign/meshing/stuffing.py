"""Deterministic lattice tet mesher for the pore space ("isosurface stuffing"-style).

A simplified variant of F. Labelle and J. R. Shewchuk, "Isosurface stuffing: fast tetrahedral
meshes with good dihedral angles", ACM Trans. Graph. 26(3) (SIGGRAPH 2007), art. 57:

1. a rectilinear lattice of step ~``h`` covers the box (RVE plus auxiliary slabs along the flow
   axis); the RVE end planes and all box faces are lattice planes; every cell is split into the
   6 Kuhn (Freudenthal) tets around its main diagonal, which conform across cells;
2. the pore field ``phi`` (trilinear interpolation of the voxel signed distance, edge-extended
   beyond the voxel centres, minus an optional level ``offset``) is sampled at the lattice
   vertices of the RVE (its end planes included); the auxiliary slabs are all fluid;
3. cut points: on every lattice edge whose end values have opposite signs, the zero of ``phi``
   (regula falsi on the field itself, not only on the two end values);
4. warping: a vertex closer to a cut point on one of its edges than ``alpha`` times that edge's
   length is moved onto the nearest such cut point (so it lies on the surface, ``phi := 0``).
   Vertices on a box face (or on an RVE end plane next to an auxiliary slab) only move along
   edges lying in that plane; vertices on box edges/corners never move;
5. every lattice tet of the RVE is clipped to ``phi >= 0`` by the linear interpolant on the tet
   (the stencils of the sign patterns +/0/-: tet, pyramid or prism, split into tets with the
   quad diagonal through the lowest global vertex index, which makes the split conform across
   neighbouring tets -- Dompierre et al., 8th Int. Meshing Roundtable, 1999); tets with all
   four vertices on the surface are kept when their centroid is in the pore. Slab tets are not
   clipped but split at the cut points on their edges/faces in an RVE end plane, so that they
   conform with the clipped RVE side; the negative parts of those in-plane faces are the fiber
   end caps (walls), exactly planar;
6. if warping made a kept tet flat or inverted, the warped vertices of that tet are put back
   (unwarped) and steps 5-6 repeat.

Everything is vectorized numpy and deterministic (no randomness, stable sorts). The boundary is
piecewise linear through the cut points (second-order accurate in ``h`` for smooth surfaces,
but biased: chords of a convex fiber cut into it, inflating the pore by about
``chord^2 / (12 R)`` per unit fiber area; :func:`~psdesign.meshing.pore_mesh.mesh_pore_space` can
remove the
bias with a uniform level ``offset`` that matches the voxel pore volume). Features thinner than
about ``h`` can be lost where no lattice vertex or edge sees them, so ``h`` should stay below
the fiber radius.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import permutations

import numpy as np

from psdesign.meshing.errors import MeshFailedError, MeshInputError, PoreTopologyError
from psdesign.meshing.tetra import tet_volumes

# lattice edge directions (offsets in {0, 1}^3) used by the Kuhn split
EDGE_DIRS = np.array(
    [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, 0, 1], [0, 1, 1], [1, 1, 1]], dtype=np.int64
)
_REGULA_FALSI_ITERS = 6
#: Periodic meshes: cut points are kept at least this fraction of an edge away from its ends.
#: A cut next to a lattice vertex makes a flat clipped tet, which is dropped; a flat tet with a
#: face on a box face drops that face triangle on one face of a periodic pair only (measured:
#: a cut at t = 1.8e-5 on a box edge left face y1 with 668 vertices against 670 on y0).
PERIODIC_CUT_MARGIN = 1e-2
_MAX_UNWARP_ROUNDS = 8
#: Steps of one :func:`stuff_pore_space` pass counted by its ``progress`` callback: the
#: lattice and its field values; the cut points and warp candidates; the active lattice tets;
#: the clipping with its unwarping rounds; the compaction of the vertices.
STUFFING_STEPS = 5


@dataclass
class StuffedMesh:
    """Result of :func:`stuff_pore_space` (coordinates in the caller's units).

    Attributes
    ----------
    points, tets
        Vertices (n, 3) and positively oriented tets (m, 4) of the pore mesh (every vertex used).
    lo, hi
        Corners of the meshed box (RVE plus auxiliary slabs).
    rve_lo, rve_hi
        Corners of the RVE proper.
    report
        Lattice size, warping and clipping counts.
    """

    points: np.ndarray
    tets: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    rve_lo: np.ndarray
    rve_hi: np.ndarray
    report: dict = field(default_factory=dict)


class PoreField:
    """Pore indicator field ``phi`` (> 0 in the pore) of a voxel signed distance.

    Trilinear interpolation of ``distance`` sampled at voxel centres ``(i + 0.5) * voxel``,
    constant extension beyond the outer centres (as the marching-cubes path replicates the
    boundary layers), or periodic wrap-around (``periodic``: the box faces are periodic, so both
    faces of a pair see exactly the same values). With auxiliary slabs the solid is clipped to
    the RVE along ``axis``: ``phi = max(d, s)`` with ``s`` the distance outside the slab
    ``0 <= x_axis <= L``.
    """

    def __init__(
        self,
        distance: np.ndarray,
        voxel: float,
        size: np.ndarray,
        axis: int,
        clip: bool,
        offset: float = 0.0,
        periodic: bool = False,
    ):
        self.d = np.ascontiguousarray(distance, dtype=np.float64) - offset
        self.voxel = float(voxel)
        self.axis = int(axis)
        self.length = float(size[axis])
        self.clip = bool(clip) and not periodic
        self.periodic = bool(periodic)
        self.shape = np.asarray(self.d.shape)
        self.size = np.asarray(size, dtype=float)

    def _stencil(self, u: np.ndarray, a: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Lower / upper sample index and weight of the upper one along axis ``a``."""
        n = int(self.shape[a])
        if self.periodic:  # wrap: x = 0 and x = L see the same samples (n - 1, 0)
            fl = np.floor(u)
            i0 = fl.astype(np.int64) % n
            return i0, (i0 + 1) % n, u - fl
        ua = np.clip(u, 0.0, n - 1.0)
        i0 = np.minimum(np.floor(ua).astype(np.int64), n - 2)
        return i0, i0 + 1, ua - i0

    def distance(self, x: np.ndarray) -> np.ndarray:
        """Trilinear interpolation of the voxel field at points ``x`` (k, 3)."""
        if self.periodic:  # x = L -> 0 exactly: both faces of a pair see bit-identical values
            x = np.mod(x, self.size)
        u = x / self.voxel - 0.5
        st = [self._stencil(u[:, a], a) for a in range(3)]
        d = self.d
        out = np.zeros(len(x))
        for dx in (0, 1):
            wx = st[0][2] if dx else 1.0 - st[0][2]
            ix = st[0][dx]
            for dy in (0, 1):
                wy = st[1][2] if dy else 1.0 - st[1][2]
                iy = st[1][dy]
                for dz in (0, 1):
                    wz = st[2][2] if dz else 1.0 - st[2][2]
                    out += wx * wy * wz * d[ix, iy, st[2][dz]]
        return out

    def __call__(self, x: np.ndarray) -> np.ndarray:
        d = self.distance(x)
        if not self.clip:
            return d
        xa = x[:, self.axis]
        s = np.maximum(-xa, xa - self.length)
        return np.where(s > 0.0, np.maximum(d, s), d)


def lattice_axes(
    size: np.ndarray, axis: int, aux_length: float, h: float, slab_factor: float = 1.0
) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Lattice coordinates per axis: RVE planes and box faces are lattice planes.

    The auxiliary slabs get an axial step of about ``slab_factor * h`` (they hold no fibers).

    Returns the three coordinate arrays and the box corners ``lo, hi`` (computed exactly like
    :func:`psdesign.meshing.surface.pore_surface`).
    """
    lo, hi = np.zeros(3), np.asarray(size, dtype=float).copy()
    lo[axis] -= aux_length * size[axis]
    hi[axis] += aux_length * size[axis]
    coords = []
    for a in range(3):
        n = max(1, int(round(size[a] / h)))
        c = np.linspace(0.0, float(size[a]), n + 1)
        c[-1] = size[a]
        if a == axis and aux_length > 0:
            na = max(1, int(round(aux_length * size[a] / (slab_factor * h))))
            c0 = np.linspace(lo[a], 0.0, na + 1)
            c1 = np.linspace(float(size[a]), hi[a], na + 1)
            c0[0], c0[-1], c1[0], c1[-1] = lo[a], 0.0, size[a], hi[a]
            c = np.concatenate([c0[:-1], c, c1[1:]])
        coords.append(c)
    return coords, lo, hi


def kuhn_tets(shape: tuple[int, int, int]) -> np.ndarray:
    """(6 * cells, 4) Kuhn tets of a lattice of ``shape`` vertices (C-order vertex index)."""
    nx, ny, nz = shape
    stride = np.array([ny * nz, nz, 1], dtype=np.int64)
    base = (
        np.arange(nx - 1)[:, None, None] * stride[0]
        + np.arange(ny - 1)[None, :, None] * stride[1]
        + np.arange(nz - 1)[None, None, :] * stride[2]
    ).ravel()
    out = np.empty((len(base), 6, 4), dtype=np.int64)
    for k, (a, b, _) in enumerate(permutations(range(3))):
        out[:, k, 0] = base
        out[:, k, 1] = base + stride[a]
        out[:, k, 2] = base + stride[a] + stride[b]
        out[:, k, 3] = base + stride.sum()
    return out.reshape(-1, 4)


def _crossing_edges(phi: np.ndarray, shape: tuple[int, int, int]) -> tuple[np.ndarray, ...]:
    """Lattice edges (v, w) with phi of strictly opposite signs; also their direction index."""
    idx = np.arange(int(np.prod(shape)), dtype=np.int64).reshape(shape)
    p = phi.reshape(shape)
    vs, ws, ds = [], [], []
    nx, ny, nz = shape
    for k, (ox, oy, oz) in enumerate(EDGE_DIRS):
        a = p[: nx - ox, : ny - oy, : nz - oz]
        b = p[ox:, oy:, oz:]
        m = ((a > 0) & (b < 0)) | ((a < 0) & (b > 0))
        if m.any():
            vs.append(idx[: nx - ox, : ny - oy, : nz - oz][m])
            ws.append(idx[ox:, oy:, oz:][m])
            ds.append(np.full(int(m.sum()), k, dtype=np.int64))
    if not vs:
        e = np.zeros(0, dtype=np.int64)
        return e, e, e
    return np.concatenate(vs), np.concatenate(ws), np.concatenate(ds)


def _cut_parameter(
    fn: PoreField, xv: np.ndarray, xw: np.ndarray, fv: np.ndarray, fw: np.ndarray
) -> np.ndarray:
    """Zero of phi on segments xv -> xw (fv, fw of opposite signs), Illinois regula falsi."""
    ta, tb = np.zeros(len(fv)), np.ones(len(fv))
    fa, fb = fv.copy(), fw.copy()
    t = fa / (fa - fb)
    side = np.zeros(len(fv), dtype=np.int8)
    for _ in range(_REGULA_FALSI_ITERS):
        ft = fn(xv + t[:, None] * (xw - xv))
        left = np.sign(ft) == np.sign(fa)  # root lies in [t, tb]
        ta = np.where(left, t, ta)
        fa = np.where(left, ft, fa)
        tb = np.where(left, tb, t)
        fb = np.where(left, fb, ft)
        # Illinois: halve the value of the end kept twice in a row
        fb = np.where(left & (side == 1), 0.5 * fb, fb)
        fa = np.where(~left & (side == -1), 0.5 * fa, fa)
        side = np.where(left, 1, -1).astype(np.int8)
        denom = fa - fb
        t = np.where(
            denom != 0, ta + (tb - ta) * fa / np.where(denom != 0, denom, 1.0), 0.5 * (ta + tb)
        )
        t = np.clip(t, ta, tb)
    return np.clip(t, 0.0, 1.0)


def _fixed_axes(
    points: np.ndarray,
    coords: list[np.ndarray],
    lo: np.ndarray,
    hi: np.ndarray,
    axis: int,
    clip: bool,
    length: float,
) -> np.ndarray:
    """(n, 3) bool: vertex lies on a box face (or a clipped RVE end plane) normal to each axis."""
    fixed = np.zeros(points.shape, dtype=bool)
    for a in range(3):
        x = points[:, a]
        fixed[:, a] = (x == lo[a]) | (x == hi[a])
        if clip and a == axis:
            fixed[:, a] |= (x == 0.0) | (x == length)
    return fixed


def _split_prisms(p: np.ndarray) -> np.ndarray:
    """Split prisms (k, 6) = bottom (a, b, c), top (d, e, f), lateral edges a-d, b-e, c-f.

    Quad diagonals go through each quad's lowest vertex index (conforming rule); returns
    (3k, 4) tets of unspecified orientation.
    """
    if len(p) == 0:
        return np.zeros((0, 4), dtype=np.int64)
    # permutations that keep the prism structure and bring position k to position 0
    perm = np.array(
        [
            [0, 1, 2, 3, 4, 5],
            [1, 2, 0, 4, 5, 3],
            [2, 0, 1, 5, 3, 4],
            [3, 4, 5, 0, 1, 2],
            [4, 5, 3, 1, 2, 0],
            [5, 3, 4, 2, 0, 1],
        ]
    )
    k = np.argmin(p, axis=1)
    q = np.take_along_axis(p, perm[k], axis=1)
    a, b, c, d, e, f = q.T
    bf = np.minimum(b, f) < np.minimum(c, e)
    t1 = np.where(bf[:, None], np.stack([a, b, c, f], 1), np.stack([a, b, c, e], 1))
    t2 = np.where(bf[:, None], np.stack([a, b, f, e], 1), np.stack([a, e, c, f], 1))
    t3 = np.stack([a, e, f, d], 1)
    return np.concatenate([t1, t2, t3])


def _split_pyramids(quad: np.ndarray, apex: np.ndarray) -> np.ndarray:
    """Split pyramids (cyclic quad (k, 4), apex (k,)) through each quad's lowest vertex."""
    if len(quad) == 0:
        return np.zeros((0, 4), dtype=np.int64)
    k = np.argmin(quad, axis=1)
    roll = (k[:, None] + np.arange(4)[None, :]) % 4
    q = np.take_along_axis(quad, roll, axis=1)
    t1 = np.stack([apex, q[:, 0], q[:, 1], q[:, 2]], 1)
    t2 = np.stack([apex, q[:, 0], q[:, 2], q[:, 3]], 1)
    return np.concatenate([t1, t2])


def _cut_ids(a: np.ndarray, b: np.ndarray, ekeys: np.ndarray, n_nodes: int) -> np.ndarray:
    """Vertex ids (``n_nodes + j``) of the cut points on edges (a, b); ``ekeys`` sorted."""
    key = np.minimum(a, b) * n_nodes + np.maximum(a, b)
    pos = np.searchsorted(ekeys, key)
    pos = np.minimum(pos, max(len(ekeys) - 1, 0))
    if len(key) and not (ekeys[pos] == key).all():
        raise MeshFailedError("internal error in isosurface stuffing: missing cut point")
    return n_nodes + pos


def _split_quads(q: np.ndarray) -> np.ndarray:
    """Split cyclic quads (k, 4) into triangles through each quad's lowest vertex index."""
    k = np.argmin(q, axis=1)
    roll = (k[:, None] + np.arange(4)[None, :]) % 4
    r = np.take_along_axis(q, roll, axis=1)
    return np.concatenate([r[:, [0, 1, 2]], r[:, [0, 2, 3]]])


def _split_slab_tets(
    tets: np.ndarray, phi: np.ndarray, on_plane: np.ndarray, ekeys: np.ndarray, n_nodes: int
) -> tuple[np.ndarray, np.ndarray]:
    """Subdivide auxiliary-slab tets (all fluid) to conform with the clipped RVE side.

    A slab tet touching an RVE end plane with an edge or a face is split at the cut points of
    ``phi`` (the RVE distance there) on its in-plane edges: an edge tet into two, a face tet into
    the cone from its apex over the in-plane face cut into its positive and negative parts
    (quads split through the lowest index, as the RVE-side clipping does). The negative in-plane
    triangles become the fiber end caps (walls), exactly planar. Returns (tets, source index).
    """
    s = np.sign(phi[tets]).astype(np.int8)
    onp = on_plane[tets]
    k = onp.sum(axis=1)
    # opposite strict signs among the in-plane vertices
    pos_in = ((s > 0) & onp).any(axis=1)
    neg_in = ((s < 0) & onp).any(axis=1)
    split = pos_in & neg_in & (k >= 2)
    out = [tets[~split]]
    src = [np.flatnonzero(~split)]
    # edge tets: (A, B, e0, e1) -> (A, B, e0, c), (A, B, c, e1)
    m = split & (k == 2)
    if m.any():
        idx = np.flatnonzero(m)
        o = np.argsort(onp[m], axis=1, kind="stable")  # off-plane first
        tt = np.take_along_axis(tets[m], o, axis=1)
        c = _cut_ids(tt[:, 2], tt[:, 3], ekeys, n_nodes)
        out += [
            np.stack([tt[:, 0], tt[:, 1], tt[:, 2], c], 1),
            np.stack([tt[:, 0], tt[:, 1], c, tt[:, 3]], 1),
        ]
        src += [idx, idx]
    # face tets: apex + in-plane triangle cut by the zero line
    m = split & (k == 3)
    if m.any():
        idx = np.flatnonzero(m)
        o = np.argsort(onp[m], axis=1, kind="stable")
        tt = np.take_along_axis(tets[m], o, axis=1)
        apex, face = tt[:, 0], tt[:, 1:]
        fs = np.sign(phi[face]).astype(np.int8)
        fo = np.argsort(-fs, axis=1, kind="stable")  # +, 0, -
        f = np.take_along_axis(face, fo, axis=1)
        fs = np.take_along_axis(fs, fo, axis=1)
        npos = (fs > 0).sum(axis=1)
        nneg = (fs < 0).sum(axis=1)
        tris, tsrc = [], []
        a = (npos == 1) & (nneg == 2)  # p, n1, n2
        if a.any():
            g = f[a]
            c1 = _cut_ids(g[:, 0], g[:, 1], ekeys, n_nodes)
            c2 = _cut_ids(g[:, 0], g[:, 2], ekeys, n_nodes)
            tris += [
                np.stack([g[:, 0], c1, c2], 1),
                _split_quads(np.stack([c1, g[:, 1], g[:, 2], c2], 1)),
            ]
            tsrc += [idx[a], np.tile(idx[a], 2)]
            apex_a = apex[a]
            tris[-2:] = [
                np.column_stack([apex_a, tris[-2]]),
                np.column_stack([np.tile(apex_a, 2), tris[-1]]),
            ]
        b = (npos == 1) & (nneg == 1)  # p, z, n
        if b.any():
            g = f[b]
            c = _cut_ids(g[:, 0], g[:, 2], ekeys, n_nodes)
            tris += [
                np.column_stack([apex[b], g[:, 0], g[:, 1], c]),
                np.column_stack([apex[b], c, g[:, 1], g[:, 2]]),
            ]
            tsrc += [idx[b], idx[b]]
        e = (npos == 2) & (nneg == 1)  # p1, p2, n
        if e.any():
            g = f[e]
            c1 = _cut_ids(g[:, 0], g[:, 2], ekeys, n_nodes)
            c2 = _cut_ids(g[:, 1], g[:, 2], ekeys, n_nodes)
            q = _split_quads(np.stack([g[:, 0], g[:, 1], c2, c1], 1))
            tris += [
                np.column_stack([np.tile(apex[e], 2), q]),
                np.column_stack([apex[e], c1, c2, g[:, 2]]),
            ]
            tsrc += [np.tile(idx[e], 2), idx[e]]
        out += tris
        src += tsrc
    return np.concatenate(out), np.concatenate(src)


def _clip_tets(
    tets: np.ndarray,
    phi: np.ndarray,
    points: np.ndarray,
    fn: PoreField,
    ekeys: np.ndarray,
    n_nodes: int,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Clip lattice tets to phi >= 0; returns (tets over nodes + cut ids, source tet, counts).

    Cut point ``j`` (edge key ``ekeys[j]``, sorted) has vertex id ``n_nodes + j``.
    """
    s = np.sign(phi[tets]).astype(np.int8)
    n_pos = (s > 0).sum(axis=1)
    n_neg = (s < 0).sum(axis=1)
    # order each tet's vertices: positive, zero, negative (stable, deterministic)
    order = np.argsort(-s, axis=1, kind="stable")
    t = np.take_along_axis(tets, order, axis=1)

    def cut(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return _cut_ids(a, b, ekeys, n_nodes)

    out, src = [], []
    counts = {}
    # whole tets: no negative vertex and at least one positive one, or all on the surface
    whole = (n_neg == 0) & (n_pos > 0)
    allzero = (n_neg == 0) & (n_pos == 0)
    if allzero.any():
        idx = np.flatnonzero(allzero)
        cen = points[tets[idx]].mean(axis=1)
        inpore = fn(cen) > 0
        whole[idx[inpore]] = True
        counts["n_surface_tets_kept"] = int(inpore.sum())
        counts["n_surface_tets_dropped"] = int((~inpore).sum())
    out.append(tets[whole])
    src.append(np.flatnonzero(whole))
    # one positive vertex: a tet (p, x1, x2, x3), x = zero vertex or cut point
    m = (n_pos == 1) & (n_neg > 0)
    if m.any():
        tt = t[m]
        ss = np.take_along_axis(s[m], order[m], axis=1)
        cols = [tt[:, 0]]
        for j in (1, 2, 3):
            neg = ss[:, j] < 0
            cj = tt[:, j].copy()
            if neg.any():
                cj[neg] = cut(tt[neg, 0], tt[neg, j])
            cols.append(cj)
        out.append(np.stack(cols, axis=1))
        src.append(np.flatnonzero(m))
    # two positive, one zero, one negative: pyramid (p1, p2, c2, c1) with apex z
    m = (n_pos == 2) & (n_neg == 1)
    if m.any():
        tt = t[m]
        c1, c2 = cut(tt[:, 0], tt[:, 3]), cut(tt[:, 1], tt[:, 3])
        out.append(_split_pyramids(np.stack([tt[:, 0], tt[:, 1], c2, c1], 1), tt[:, 2]))
        src.append(np.tile(np.flatnonzero(m), 2))
    # two positive, two negative: prism (p1, c11, c12) - (p2, c21, c22)
    m = (n_pos == 2) & (n_neg == 2)
    if m.any():
        tt = t[m]
        pr = np.stack(
            [
                tt[:, 0],
                cut(tt[:, 0], tt[:, 2]),
                cut(tt[:, 0], tt[:, 3]),
                tt[:, 1],
                cut(tt[:, 1], tt[:, 2]),
                cut(tt[:, 1], tt[:, 3]),
            ],
            1,
        )
        out.append(_split_prisms(pr))
        src.append(np.tile(np.flatnonzero(m), 3))
    # three positive, one negative: prism (p1, p2, p3) - (c1, c2, c3)
    m = (n_pos == 3) & (n_neg == 1)
    if m.any():
        tt = t[m]
        pr = np.stack(
            [
                tt[:, 0],
                tt[:, 1],
                tt[:, 2],
                cut(tt[:, 0], tt[:, 3]),
                cut(tt[:, 1], tt[:, 3]),
                cut(tt[:, 2], tt[:, 3]),
            ],
            1,
        )
        out.append(_split_prisms(pr))
        src.append(np.tile(np.flatnonzero(m), 3))
    counts["n_lattice_tets_whole"] = int(whole.sum())
    counts["n_lattice_tets_clipped"] = int(((n_pos > 0) & (n_neg > 0)).sum())
    return np.concatenate(out), np.concatenate(src), counts


def stuff_pore_space(
    distance: np.ndarray,
    voxel: float,
    size,
    axis: int,
    aux_length: float,
    h: float,
    *,
    alpha: float = 0.3,
    offset: float = 0.0,
    slab_factor: float = 1.0,
    periodic: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> StuffedMesh:
    """Tet mesh of ``{phi >= 0}`` in the box with auxiliary slabs by lattice stuffing.

    (Eleven parameters: the field, box and lattice step, then independent knobs, keyword-only.)

    Parameters
    ----------
    distance
        Signed distance at voxel centres ``(i + 0.5) * voxel``, > 0 in the pore.
    voxel
        Voxel size (same unit as ``size`` and ``h``).
    size
        RVE side lengths (3,).
    axis
        Flow axis index (0, 1, 2); the auxiliary slabs extend the box along it.
    aux_length
        Auxiliary slab length as a fraction of ``size[axis]`` (>= 0; must be 0 if periodic).
    h
        Lattice step (> 0); each axis gets ``round(length / h)`` cells (at least one).
    alpha
        Warping threshold in (0, 0.5): a vertex within ``alpha`` times an edge length of a cut
        point on that edge is moved onto it.
    offset
        Level-set shift: the surface meshed is ``distance = offset`` (> 0 shrinks the pore).
    slab_factor
        Axial lattice step in the auxiliary slabs as a multiple of ``h`` (>= 1; the slabs are
        plain fluid, coarser cells there save tets).
    periodic
        Periodic box: the field is interpolated with wrap-around and warping is undone on
        both vertices of a periodic pair together, so opposite faces carry the same vertices
        and triangles (up to the translation by the box side).
    progress
        ``progress(steps_done, STUFFING_STEPS)`` after each step of the pass (the last call
        with ``steps_done == STUFFING_STEPS``); the caller throttles what it prints.

    Returns
    -------
    StuffedMesh

    Raises
    ------
    MeshInputError
        ``h``, ``alpha`` or ``slab_factor`` out of range; ``aux_length > 0`` with ``periodic``.
    PoreTopologyError
        No lattice vertex lies in the pore.
    MeshFailedError
        Flat or inverted tets that unwarping could not repair.
    """
    size = np.asarray(size, dtype=float)
    _check_stuffing_args(size, h, alpha, slab_factor, aux_length, periodic)
    clip = aux_length > 0
    step = _step_counter(progress)
    fn = PoreField(distance, voxel, size, axis, clip, offset, periodic=periodic)
    lat = _Lattice.build(fn, size, axis, aux_length, h, slab_factor)
    step()
    cuts = _cut_points(fn, lat)
    warp_v, warp_c = _warp_candidates(lat, cuts, alpha, clip, size[axis])
    step()
    tets_lat, slab = _active_tets(lat, warp_v)
    step()
    twin = _periodic_keys(lat.shape) if periodic else None
    out, allpts, counts = _clip_with_unwarping(fn, lat, cuts, warp_v, warp_c, tets_lat, slab, twin)
    step()
    used = np.unique(out)
    remap = np.full(len(allpts), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    step()
    report = {
        "lattice_shape": list(lat.shape),
        "lattice_step": [float(np.diff(c).mean()) for c in lat.coords],
        "n_lattice_tets_active": int(len(tets_lat)),
        "stuffing_alpha": float(alpha),
        "periodic": bool(periodic),
        **counts,
    }
    return StuffedMesh(allpts[used], remap[out], lat.lo, lat.hi, np.zeros(3), size.copy(), report)


def _step_counter(progress: Callable[[int, int], None] | None) -> Callable[[], None]:
    """``step()``: one more of the :data:`STUFFING_STEPS` done, said to ``progress``."""
    done = [0]

    def step() -> None:
        done[0] += 1
        if progress is not None:
            progress(done[0], STUFFING_STEPS)

    return step


def _check_stuffing_args(size, h, alpha, slab_factor, aux_length, periodic) -> None:
    if not (h > 0 and np.isfinite(h)):
        raise MeshInputError(f"lattice_step must be a positive length, got {h}")
    if not (0.0 < alpha < 0.5):
        raise MeshInputError(f"stuffing alpha must be in (0, 0.5), got {alpha}", key="alpha")
    if not (size / h <= 2000).all():
        raise MeshInputError(
            f"lattice_step {h} gives more than 2000 cells per axis; use a "
            f"step >= {size.max() / 2000:.3g}"
        )
    if not (1.0 <= slab_factor <= 10.0):
        raise MeshInputError(f"slab_factor must be in [1, 10], got {slab_factor}")
    if periodic and aux_length > 0:
        raise MeshInputError(f"aux_length must be 0 for a periodic mesh, got {aux_length}")


@dataclass
class _Lattice:
    """Lattice vertices, their field values and slab / end-plane masks."""

    coords: list
    lo: np.ndarray
    hi: np.ndarray
    shape: tuple
    pts0: np.ndarray
    phi0: np.ndarray
    in_slab: np.ndarray
    on_plane: np.ndarray
    fixed: np.ndarray

    @property
    def n_nodes(self) -> int:
        return int(np.prod(self.shape))

    @classmethod
    def build(cls, fn, size, axis, aux_length, h, slab_factor) -> _Lattice:
        clip = aux_length > 0
        coords, lo, hi = lattice_axes(size, axis, aux_length, h, slab_factor)
        shape = tuple(len(c) for c in coords)
        grid = np.meshgrid(*coords, indexing="ij")
        pts0 = np.stack([g.ravel() for g in grid], axis=1)
        del grid
        phi0 = fn(pts0)
        xa = pts0[:, axis]
        in_slab = (xa < 0.0) | (xa > size[axis])  # auxiliary-slab vertices (all fluid)
        on_plane = clip & ((xa == 0.0) | (xa == size[axis]))  # RVE end planes next to a slab
        phi0[in_slab] = h
        # values at round-off level (surfaces through lattice vertices) count as on the surface
        phi0[np.abs(phi0) <= 1e-9 * h] = 0.0
        if not (phi0 > 0).any():
            raise PoreTopologyError(
                "the pore space is empty at the lattice vertices: `distance` "
                "is <= 0 everywhere (or lattice_step too coarse)"
            )
        fixed = _fixed_axes(pts0, coords, lo, hi, axis, clip, float(size[axis]))
        if fn.periodic:
            _periodic_faces(pts0, phi0, lo, hi, h)
        return cls(coords, lo, hi, shape, pts0, phi0, in_slab, on_plane, fixed)


def _periodic_faces(pts0, phi0, lo, hi, h) -> None:
    """Make the faces of a periodic box a function of the face data alone (in place).

    The triangles a clipped tet leaves on a box face depend only on the face's vertices and cut
    points, except for a face triangle whose three vertices lie on the surface (``phi = 0``): it
    is kept or dropped with the tet's fourth vertex, which lies on the other side of each face
    of a pair. So a face vertex on the surface to round-off counts as pore (``phi`` a tiny
    positive value, the cut on its edges then lies :data:`PERIODIC_CUT_MARGIN` away), and a face
    triangle whose three vertices were warped onto the surface is undone in
    :func:`_clip_with_unwarping` (:func:`_zero_face_triangles`). Face vertices do warp, within
    their face (both of a pair onto the same in-plane cut point): kept fixed on all axes (before
    session 35) they left the cut points next to them as slivers on the periodic faces, down to
    1.2e-5 h^3 and 1.3 degrees on a cylinder crossing the faces."""
    on_face = ((pts0 == lo) | (pts0 == hi)).any(axis=1)
    phi0[on_face & (phi0 == 0.0)] = 2e-9 * h


@dataclass
class _Cuts:
    """Crossing lattice edges (ev -> ew, direction index) and their cut points."""

    ev: np.ndarray
    ew: np.ndarray
    edir: np.ndarray
    t: np.ndarray
    pts: np.ndarray
    elen: np.ndarray


def _cut_points(fn: PoreField, lat: _Lattice) -> _Cuts:
    """Cut points on crossing edges (before warping); in-plane coordinates kept exact."""
    pts0, phi0 = lat.pts0, lat.phi0
    ev, ew, edir = _crossing_edges(phi0, lat.shape)
    inner = ~(lat.in_slab[ev] | lat.in_slab[ew])  # slab tets are split on the planes
    ev, ew, edir = ev[inner], ew[inner], edir[inner]
    t_cut = _cut_parameter(fn, pts0[ev], pts0[ew], phi0[ev], phi0[ew])
    if fn.periodic:  # no flat tets: their drop would differ between the faces of a pair
        t_cut = np.clip(t_cut, PERIODIC_CUT_MARGIN, 1.0 - PERIODIC_CUT_MARGIN)
    cut_pts = pts0[ev] + t_cut[:, None] * (pts0[ew] - pts0[ev])
    for a in range(3):
        same = pts0[ev, a] == pts0[ew, a]
        cut_pts[same, a] = pts0[ev[same], a]
    elen = np.linalg.norm(pts0[ew] - pts0[ev], axis=1)
    return _Cuts(ev, ew, edir, t_cut, cut_pts, elen)


def _warp_candidates(lat: _Lattice, cuts: _Cuts, alpha: float, clip: bool, length: float):
    """(vertex, cut index) of the nearest cut point within ``alpha`` edge lengths per vertex."""
    n_fixed = lat.fixed.sum(axis=1)
    dirs = EDGE_DIRS[cuts.edir].astype(bool)
    cand_v, cand_d, cand_c = [], [], []
    for verts, frac in ((cuts.ev, cuts.t), (cuts.ew, 1.0 - cuts.t)):
        ok = (frac < alpha) & (n_fixed[verts] <= 1) & ~(lat.fixed[verts] & dirs).any(axis=1)
        cand_v.append(verts[ok])
        cand_d.append((frac * cuts.elen)[ok])
        cand_c.append(np.flatnonzero(ok))
    cv, cd, cc = (np.concatenate(x) for x in (cand_v, cand_d, cand_c))
    order = np.lexsort((cc, cd, cv))  # by vertex, then distance, then cut index
    cv, cc = cv[order], cc[order]
    first = np.ones(len(cv), dtype=bool)
    first[1:] = cv[1:] != cv[:-1]
    return cv[first], cc[first]


def _active_tets(lat: _Lattice, warp_v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lattice tets that may hold pore (and whether each lies in an auxiliary slab)."""
    tets_all = kuhn_tets(lat.shape)
    active = (lat.phi0[tets_all] >= 0).any(axis=1)
    near = np.zeros(lat.n_nodes, dtype=bool)
    near[warp_v] = True
    active |= near[tets_all].any(axis=1)
    slab_all = lat.in_slab[tets_all].any(axis=1)  # a lattice tet is on one side of each plane
    active |= slab_all
    return tets_all[active], slab_all[active]


def _periodic_keys(shape: tuple) -> np.ndarray:
    """Per lattice vertex: index of its periodic representative (last layer -> first)."""
    idx = [np.arange(n) for n in shape]
    for a, n in enumerate(shape):
        idx[a] = np.where(idx[a] == n - 1, 0, idx[a])
    g = np.meshgrid(*idx, indexing="ij")
    return np.ravel_multi_index([x.ravel() for x in g], shape)


def _zero_face_triangles(lat: _Lattice, tets: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Vertices of the lattice-tet faces on a box face whose three vertices have ``phi == 0``
    (their triangle would be kept or dropped with the tet's fourth vertex, which differs between
    the two faces of a periodic pair): (k, 3) vertex ids, k = 0 when there is none."""
    zero = phi[tets] == 0.0
    found = [np.zeros((0, 3), dtype=tets.dtype)]
    for a in range(3):
        x = lat.pts0[tets, a]
        for end in (lat.lo[a], lat.hi[a]):
            on = x == end
            hit = (on & zero).sum(axis=1) == 3
            if hit.any():
                found.append(tets[hit][on[hit] & zero[hit]].reshape(-1, 3))
    return np.concatenate(found)


def _clip_with_unwarping(fn, lat, cuts, warp_v, warp_c, tets_lat, slab, twin):
    """Warp, clip, and undo warping of vertices of flat/inverted tets until none is left."""
    n_nodes = lat.n_nodes
    pts0, phi0, ev, ew = lat.pts0, lat.phi0, cuts.ev, cuts.ew
    slab_idx, rve_idx = np.flatnonzero(slab), np.flatnonzero(~slab)
    ekeys_all = np.minimum(ev, ew) * n_nodes + np.maximum(ev, ew)
    scale_v = float(np.min([np.diff(c).min() for c in lat.coords])) ** 3
    warped = np.ones(len(warp_v), dtype=bool)
    n_unwarped = 0
    for _round in range(_MAX_UNWARP_ROUNDS):
        pts, phi = pts0.copy(), phi0.copy()
        wv, wc = warp_v[warped], warp_c[warped]
        pts[wv] = cuts.pts[wc]
        phi[wv] = 0.0
        # cut points still in use: edges whose (possibly warped) ends keep opposite signs
        live = ((phi[ev] > 0) & (phi[ew] < 0)) | ((phi[ev] < 0) & (phi[ew] > 0))
        keys = ekeys_all[live]
        srt = np.argsort(keys, kind="stable")
        keys = keys[srt]
        cpts = cuts.pts[live][srt]
        out, src, counts = _clip_tets(tets_lat[rve_idx], phi, pts, fn, keys, n_nodes)
        src = rve_idx[src]
        if len(slab_idx):
            out_s, src_s = _split_slab_tets(tets_lat[slab_idx], phi, lat.on_plane, keys, n_nodes)
            out, src = np.concatenate([out, out_s]), np.concatenate([src, slab_idx[src_s]])
        allpts = np.concatenate([pts, cpts])
        vol = tet_volumes(allpts, out)
        tiny = np.abs(vol) <= 1e-10 * scale_v
        # the same connectivity on the unwarped lattice is a valid decomposition (cut points
        # lie strictly inside lattice edges): a sign change against it means inversion
        neg = np.sign(vol) != np.sign(tet_volumes(np.concatenate([pts0, cpts]), out))
        bad = tiny | neg
        flat_face = (
            _zero_face_triangles(lat, tets_lat[rve_idx], phi)
            if twin is not None
            else np.zeros((0, 3), dtype=tets_lat.dtype)
        )
        if not bad.any() and not len(flat_face):
            break
        is_w = np.zeros(n_nodes, dtype=bool)
        is_w[wv] = True
        culprits = np.unique(np.concatenate([tets_lat[src[bad]].ravel(), flat_face.ravel()]))
        culprits = culprits[is_w[culprits]]
        if len(culprits) == 0:
            # flat tets without warped vertices: clipped slivers from cut points at lattice
            # vertices (t == 0 or 1); orient the rest and drop the flat ones
            if neg[~tiny].any():
                raise MeshFailedError(
                    f"{int(neg[~tiny].sum())} inverted tets without warped vertices"
                )
            break
        if twin is None:
            warped[np.searchsorted(warp_v, culprits)] = False
        else:  # unwarp both vertices of a periodic pair so that the faces stay identical
            warped[np.isin(twin[warp_v], twin[culprits])] = False
        n_unwarped += len(culprits)
    else:
        raise MeshFailedError(
            f"isosurface stuffing left {int(bad.sum())} flat or inverted tets after "
            f"{_MAX_UNWARP_ROUNDS} unwarping rounds; try another lattice_step"
        )
    out, vol = out[~tiny], vol[~tiny]
    flip = vol < 0
    out[flip] = out[flip][:, [0, 2, 1, 3]]
    counts.update(
        n_cut_points=int(len(keys)),
        n_warped_vertices=int(warped.sum()),
        n_unwarped_vertices=int(n_unwarped),
        n_flat_tets_dropped=int(tiny.sum()),
    )
    return out, allpts, counts
