"""Tetrahedralization (pytetwild), boundary faces, plane snapping, boundary tags, connectivity."""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from psdesign.meshing import tags as T
from psdesign.meshing.errors import MeshFailedError, MeshInputError, PoreTopologyError, Remedy
from psdesign.meshing.options import TETWILD_OPTIONS
from psdesign.meshing.tetwild_process import tetrahedralize_isolated
from psdesign.schema.flow import PYTETWILD_EDGE_RANGE

# outward faces of a positively oriented tet (a, b, c, d)
TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def tetrahedralize(
    verts: np.ndarray,
    faces: np.ndarray,
    edge_length_abs: float,
    epsilon: float,
    num_threads: int = 1,
    options: dict | None = None,
    sizing: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Run pytetwild (fTetWild) on a closed surface, in a child process
    (:mod:`.tetwild_process`); tets returned positively oriented.

    ``options`` may set pytetwild's ``stop_energy``, ``num_opt_iter``, ``coarsen``, ``simplify``;
    ``sizing`` is a background mesh ``(points, tets, target edge length per point)`` (pytetwild's
    ``bg_vertices``, ``bg_tets``, ``bg_values``), see :func:`aux_sizing_field`.
    """
    options = dict(options or {})
    if sizing is not None:
        options.update(
            bg_vertices=np.ascontiguousarray(sizing[0], dtype=np.float64),
            bg_tets=np.ascontiguousarray(sizing[1], dtype=np.int32),
            bg_values=np.ascontiguousarray(sizing[2], dtype=np.float64),
        )
    bad = set(options) - set(TETWILD_OPTIONS) - {"bg_vertices", "bg_tets", "bg_values"}
    if bad:
        raise MeshInputError(
            f"tetwild_options {sorted(bad)} not supported; allowed: {sorted(TETWILD_OPTIONS)}"
        )
    pts, tets = tetrahedralize_isolated(
        verts,
        faces,
        dict(
            edge_length_abs=float(edge_length_abs),
            epsilon=float(epsilon),
            optimize=True,  # optimize=False produced broken meshes in the trial of issue 5
            num_threads=int(num_threads),
            quiet=True,
            **options,
        ),
    )
    tets = np.asarray(tets, dtype=np.int64)
    if len(tets) == 0:
        raise MeshFailedError("pytetwild returned no tetrahedra (surface too small or degenerate)")
    vol = tet_volumes(pts, tets)
    neg = vol < 0
    tets[neg] = tets[neg][:, [0, 2, 1, 3]]
    return np.asarray(pts, dtype=np.float64), tets


def aux_sizing_field(
    lo: np.ndarray, hi: np.ndarray, rve_lo: float, rve_hi: float, axis: int, h: float, factor: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Background mesh for pytetwild: edge length ``h`` in the RVE, growing linearly along the
    flow axis through the empty auxiliary zones to ``factor * h`` at the inlet and outlet faces.

    The box ``[lo, hi]`` is cut at the RVE end planes into three boxes along ``axis``, each split
    into six Kuhn tets; the target length is linear in the axis coordinate, so the
    interpolation over the tets reproduces it exactly.
    """
    ticks = [np.array([lo[a], hi[a]]) for a in range(3)]
    ticks[axis] = np.array([lo[axis], rve_lo, rve_hi, hi[axis]])
    g = np.stack(np.meshgrid(*ticks, indexing="ij"), axis=-1)
    shape = g.shape[:3]
    pts = g.reshape(-1, 3)
    idx = np.arange(pts.shape[0]).reshape(shape)
    corner = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    kuhn = [(0, 1, 3, 7), (0, 1, 5, 7), (0, 2, 3, 7), (0, 2, 6, 7), (0, 4, 5, 7), (0, 4, 6, 7)]
    tets = []
    for c in np.ndindex(*(n - 1 for n in shape)):
        ids = [idx[tuple(np.add(c, corner[m]))] for m in range(8)]  # corner m = 4 i + 2 j + k
        tets += [[ids[m] for m in t] for t in kuhn]
    x = pts[:, axis]
    dist = np.maximum(rve_lo - x, x - rve_hi).clip(min=0.0)  # distance from the RVE end planes
    depth = max(rve_lo - lo[axis], hi[axis] - rve_hi, 1e-300)
    values = h * (1.0 + (factor - 1.0) * dist / depth)
    tets = np.asarray(tets, dtype=np.int64)
    neg = tet_volumes(pts, tets) < 0
    tets[neg] = tets[neg][:, [0, 2, 1, 3]]
    return pts, tets, values


def tet_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volumes of tets."""
    a = points[tets[:, 0]]
    return (
        np.einsum(
            "ij,ij->i",
            points[tets[:, 1]] - a,
            np.cross(points[tets[:, 2]] - a, points[tets[:, 3]] - a),
        )
        / 6.0
    )


def face_structure(tets: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Boundary faces and interior face adjacency of a tet mesh.

    Returns
    -------
    bfaces
        (k, 3) outward-oriented boundary triangles.
    btet
        (k,) owning tet of each boundary face.
    pairs
        (p, 2) tets sharing an interior face.
    """
    nt = len(tets)
    allf = tets[:, TET_FACES].reshape(-1, 3)
    owner = np.repeat(np.arange(nt), 4)
    s = np.sort(allf.astype(np.int64), axis=1)  # int32 tets would wrap the keys
    n = int(tets.max()) + 1
    key = (s[:, 0] * n + s[:, 1]) * n + s[:, 2] if n < 2_000_000 else None
    if key is None:
        _, inv = np.unique(s, axis=0, return_inverse=True)
        key = inv.ravel()
    order = np.argsort(key, kind="stable")
    ks = key[order]
    same_next = ks[1:] == ks[:-1]
    if len(ks) > 2 and (same_next[1:] & same_next[:-1]).any():
        raise MeshFailedError("non-manifold tet mesh: a face is shared by more than two tets")
    first = np.flatnonzero(same_next)
    pairs = np.stack([owner[order[first]], owner[order[first + 1]]], axis=1)
    is_pair = np.zeros(len(ks), dtype=bool)
    is_pair[first] = True
    is_pair[first + 1] = True
    bidx = order[~is_pair]
    return allf[bidx], owner[bidx], pairs


def components(nt: int, pairs: np.ndarray) -> np.ndarray:
    """Connected-component label of each tet (face adjacency)."""
    g = sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(nt, nt))
    _, labels = csgraph.connected_components(g, directed=False)
    return labels


def snap_to_planes(
    points: np.ndarray,
    bfaces: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    tol: float,
    cos_max: float = 0.98,
) -> tuple[np.ndarray, float]:
    """Move the vertices of boundary faces that lie on a box plane exactly onto it.

    A boundary face is taken as lying on a plane when its three vertices are within ``tol`` of
    the plane and its unit normal is within ``arccos(cos_max)`` of the plane normal; only the
    vertices of such faces move (fiber-wall vertices that merely pass near a box face are left
    alone, which would otherwise flatten tets).

    Returns the snapped copy and the largest displacement applied.
    """
    pts = points.copy()
    a, b, c = (points[bfaces[:, i]] for i in range(3))
    n = np.cross(b - a, c - a)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    max_move = 0.0
    for ax in range(3):
        for plane in (lo[ax], hi[ax]):
            near = (np.abs(points[bfaces, ax] - plane) <= tol).all(axis=1)
            on = near & (np.abs(n[:, ax]) >= cos_max)
            if on.any():
                idx = np.unique(bfaces[on])
                max_move = max(max_move, float(np.abs(pts[idx, ax] - plane).max()))
                pts[idx, ax] = plane
    return pts, max_move


def untangle_near_planes(
    points: np.ndarray,
    tets: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    push: float,
    max_iter: int = 5,
) -> tuple[np.ndarray, int]:
    """Repair tets flattened or inverted by plane snapping.

    A tet inverts when its face was snapped onto a box plane while its fourth vertex lies within
    the snapping distance of that plane. Vertices of such tets that are not on a plane are moved
    away from every plane they are closer to than ``push`` (to distance ``push``); the moved
    vertices are interior or fiber-wall vertices (also ones left slightly outside the box),
    displaced by about ``push`` at most (of the order of the envelope).
    Returns the repaired copy and the number of vertices moved.
    """
    pts = points.copy()
    moved: set[int] = set()
    for _ in range(max_iter):
        bad = tet_volumes(pts, tets) <= 0
        if not bad.any():
            break
        verts = np.unique(tets[bad])
        for ax in range(3):
            c = pts[verts, ax]
            for plane, sign in ((lo[ax], 1.0), (hi[ax], -1.0)):
                dist = sign * (c - plane)
                sel = (dist != 0) & (dist < push)  # dist == 0: snapped, stays
                if sel.any():
                    pts[verts[sel], ax] = plane + sign * push
                    moved.update(verts[sel].tolist())
                    c = pts[verts, ax]
    return pts, len(moved)


def tag_faces(
    points: np.ndarray, bfaces: np.ndarray, lo: np.ndarray, hi: np.ndarray, axis: int
) -> dict[str, np.ndarray]:
    """Split boundary faces into inlet/outlet/side_*/wall (:mod:`.tags`) by exact plane membership.

    A face belongs to a box plane when its three (snapped) vertices lie exactly on it; every
    other boundary face lies on a fiber surface (including fiber end caps facing the auxiliary
    slabs) and is tagged ``wall``.
    """
    tags: dict[str, np.ndarray] = {}
    used = np.zeros(len(bfaces), dtype=bool)
    for ax in range(3):
        for j, plane in enumerate((lo[ax], hi[ax])):
            on = (points[bfaces, ax] == plane).all(axis=1) & ~used
            used |= on
            tags[T.face_name(ax, bool(j), axis)] = bfaces[on]
    tags[T.WALL] = bfaces[~used]
    return tags


#: The tet mesh's resolution keys, for :func:`keep_through_components`' refusal when its caller
#: names no mesher.
MESH_RESOLUTION = Remedy(
    "flow.lattice_step",
    "a tet mesh closes pore gaps narrower than about its step (allowed: a "
    "smaller step, under about the narrowest gap of the path: flow.lattice_step > 0 m with "
    f"mesher = 'stuffing', flow.edge_length {PYTETWILD_EDGE_RANGE} with mesher = "
    "'pytetwild')",
)


def keep_through_components(
    points: np.ndarray,
    tets: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    axis: int,
    tol: float,
    any_face: bool = False,
    refine: Remedy = MESH_RESOLUTION,
) -> tuple[np.ndarray, np.ndarray, dict, np.ndarray]:
    """Drop tet components that touch neither inlet nor outlet; fail if none spans both.

    With ``any_face`` (periodic meshes) only components touching no box face at all are
    dropped (a pocket cut by a lateral face continues through its periodic image).
    ``refine`` is the refusal's key and advice when no component spans both: the key that
    sets the tet mesh's resolution and its allowed range (the mesher's; default
    :data:`MESH_RESOLUTION`, both meshers' keys). The voxel field the mesh is built from had
    a path (:func:`~psdesign.meshing.surface.check_voxel_connectivity` runs
    first), so the mesh closed a gap narrower than about its step.
    Returns the filtered (points, tets) (vertices renumbered), a report dict and the
    boundary faces of the filtered mesh: exactly ``face_structure(tets)[0]`` (whole
    components are dropped, so no new boundary face appears, and the renumbering keeps the
    faces' order), which callers need and which took a second face pass (4.6 s at 5.2 M tets).
    """
    bfaces, btet, pairs = face_structure(tets)
    labels = components(len(tets), pairs)
    ncomp = int(labels.max()) + 1
    fc = points[bfaces, axis]
    at_in = (np.abs(fc - lo[axis]) <= tol).all(axis=1)
    at_out = (np.abs(fc - hi[axis]) <= tol).all(axis=1)
    touches_in = np.zeros(ncomp, dtype=bool)
    touches_out = np.zeros(ncomp, dtype=bool)
    touches_in[labels[btet[at_in]]] = True
    touches_out[labels[btet[at_out]]] = True
    vol = tet_volumes(points, tets)
    comp_vol = np.bincount(labels, weights=vol, minlength=ncomp)
    key, rest = refine
    for face, touches in ((T.INLET, touches_in), (T.OUTLET, touches_out)):
        if not touches.any():
            raise PoreTopologyError(
                f"{key}: the tet mesh has no pore at the {face} face where its voxel field "
                f"has one: {rest}"
            )
    if not (touches_in & touches_out).any():
        raise PoreTopologyError(
            f"{key}: disconnected pore space: the tet mesh has no pore path from the inlet to "
            f"the outlet ({ncomp} pore components, none touches both) where its voxel field has "
            f"one: {rest}"
        )
    keep_comp = touches_in | touches_out
    if any_face:
        on_box = np.zeros(len(bfaces), dtype=bool)
        for ax in range(3):
            fa = points[bfaces, ax]
            on_box |= (np.abs(fa - lo[ax]) <= tol).all(axis=1)
            on_box |= (np.abs(fa - hi[ax]) <= tol).all(axis=1)
        keep_comp[labels[btet[on_box]]] = True
    keep = keep_comp[labels]
    report = {
        "n_components": ncomp,
        "n_removed_components": int((~keep_comp).sum()),
        "removed_volume": float(comp_vol[~keep_comp].sum()),
    }
    if keep.all():
        return points, tets, report, bfaces
    tets = tets[keep]
    used = np.unique(tets)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return points[used], remap[tets], report, remap[bfaces[keep[btet]]].astype(tets.dtype)
