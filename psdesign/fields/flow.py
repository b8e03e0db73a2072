"""Stokes solutions as VTK datasets (pyvista): the voxel grid as ``ImageData`` (cell data), the
tet mesh as ``UnstructuredGrid`` (point data at the vertices).

Arrays (SI units in the names): ``velocity_m_per_s`` (3-vector), ``velocity_magnitude_m_per_s``,
``pressure_Pa`` (the total pressure: the solvers' periodic fluctuation plus the mean gradient,
shifted by a constant so that its mean over the outlet end of the solved domain is 0; NaN where
no pressure is defined), ``zone`` (region ids, :func:`psdesign.fields.tables.region_table`) and,
on the voxel grid, ``solid`` (1 = fibre) and ``pressure_cell`` (1 = the solver's pressure cell).

* **Outlet reference**: voxel grid, the mean over the grid's outlet end plane (the faces between
  two pressure cells, each the mean of its two cells; the plane is the periodic seam, so the
  mean from the inlet side is the applied drop); tet mesh, the area-weighted mean over the
  outlet triangles (:func:`face_mean`). Pointwise the outlet pressure varies about 0.
* **Pressure cells**: ``pressure_Pa`` is NaN exactly where ``pressure_cell`` is 0. With
  sub-voxel walls a cut cell whose centre lies in a fibre (``solid`` 1) but which has a face
  in the fluid is a pressure cell: it carries the solved pressure of its fluid part.
* **Voxel grid**: the solved grid (with the permeameter's empty reservoirs, so the RVE starts at
  the origin's ``+ n_aux`` cells; the origin is shifted by ``-n_aux`` voxels along the flow).
  The cell velocity is the mean of the superficial velocities on the cell's two faces normal to
  each axis (the solver's face velocity times its cut-cell fluid fraction for the sub-voxel
  walls), so the mean over the grid equals the solver's superficial mean velocity.
* **Tet mesh**: 10-node quadratic tets (VTK's ``QUADRATIC_TETRA``): the Taylor-Hood P2 velocity
  at the vertices and the edge mid-points (:meth:`StokesResult.sample`), so the file holds the
  solver's velocity, not its P1 interpolant; the P1 pressure at the vertices, and at a mid-point
  the mean of its edge's ends (exact for P1). Written at the vertices only, as until session 43,
  the flux across the gap between two fibres was 4.3 % under the solver's on the default mesh
  (3.2 tets per diameter): a linear interpolant of a parabolic profile. The boundary triangles
  are 6-node quadratic triangles on the same points.
"""

from __future__ import annotations

import numpy as np

from psdesign.fields.tables import add_tables, region_ids_along
from psdesign.meshing import tags
from psdesign.meshing.result import triangle_areas


def _flat(a: np.ndarray) -> np.ndarray:
    """An ``[x, y, z]`` array in VTK cell order (x fastest)."""
    return np.asarray(a).ravel(order="F")


def _face_weights(solution, fields) -> list[np.ndarray] | None:
    """Cut-cell fluid fractions of the faces of the solved grid (sub-voxel walls), from the
    solver's own coefficient routine; None for the staircase (all 1) or a treatment whose grid
    is not rebuilt here."""
    if solution.wall_treatment != "subvoxel":
        return None
    from solvers.voxel import boundary as bd

    d, h = int(solution.direction), float(solution.voxel_size)
    phi = np.asarray(fields.distance, np.float64) / h
    walls: dict[int, str] = {}
    if solution.bc == "permeameter":
        _, phi = bd.pad_reservoirs(fields.solid, phi, d, int(solution.rve_slice[0]))
        walls = {b: str(solution.sides) for b in range(3) if b != d}
    elif solution.periodic_treatment != "periodic":
        return None
    faces = [bd.face_distance(phi, b) for b in range(3)]
    res = [bd.component_coefficients(a, phi_faces=faces, walls=walls) for a in range(3)]
    weights = [r[3] for r in res]
    bd.pressure_cells([r[2] for r in res], weights)  # the solver's release of lone cut cells
    return weights


def _solved_solid(solution, fields, shape) -> np.ndarray:
    solid = np.asarray(fields.solid, bool)
    d = int(solution.direction)
    if solution.bc == "permeameter":
        pad = [(0, 0)] * 3
        i0 = int(solution.rve_slice[0])
        pad[d] = (i0, shape[d] - solid.shape[d] - i0)
        return np.pad(solid, pad, constant_values=False)
    from solvers.voxel_stokes import apply_treatment

    grid = apply_treatment(solid, d, solution.periodic_treatment)[0]  # as the solver built it
    if grid.shape == tuple(shape):
        return grid
    raise ValueError(
        f"fields: a solved grid {tuple(shape)} of treatment {solution.periodic_treatment!r} "
        f"does not match the RVE's {solid.shape}"
    )


def voxel_total_pressure(
    p: np.ndarray, cells: np.ndarray, d: int, h: float, gradient: float
) -> np.ndarray:
    """The written ``pressure_Pa`` of a voxel solve: the total pressure at the cell centres.

    Parameters
    ----------
    p : np.ndarray
        The solver's periodic pressure fluctuation (Pa, ``[x, y, z]``).
    cells : np.ndarray
        The solver's pressure cells (bool); the result is NaN elsewhere.
    d : int
        Flow axis.
    h : float
        Voxel size (m).
    gradient : float
        Driving mean pressure gradient (Pa/m, along ``+d``).

    Returns
    -------
    np.ndarray
        float32 ``p + gradient * (L - x_d) - p_out``: ``L`` the grid length along ``d`` and
        ``p_out`` the mean of the fluctuation over the outlet end plane ``x_d = L`` (its faces
        between two pressure cells, each face the mean of its two cells: the plane is the
        periodic seam), so the total pressure's mean there is 0 and, approached from the inlet
        side, ``gradient * L``.
    """
    last, first = np.take(p, -1, axis=d), np.take(p, 0, axis=d)
    both = np.take(cells, -1, axis=d) & np.take(cells, 0, axis=d)
    p_out = 0.5 * float(
        np.mean(last[both], dtype=np.float64) + np.mean(first[both], dtype=np.float64)
    )
    x_c = (np.arange(p.shape[d]) + 0.5) * h
    drop = gradient * (p.shape[d] * h - x_c) - p_out
    total = p + drop.reshape([-1 if b == d else 1 for b in range(3)])
    return np.where(cells, total, np.nan).astype(np.float32)


def voxel_flow_grid(solution, fields, result: dict | None = None):
    """``pyvista.ImageData`` of a voxel Stokes solve (``return_velocity`` and
    ``return_pressure`` on); ``result`` (the route's dict) adds its K and drops as field data."""
    import pyvista as pv

    vel, p = solution.velocity, solution.pressure
    if vel is None or p is None or solution.pressure_cells is None:
        raise ValueError("fields: the voxel solve was run without its velocity and pressure")
    shape = p.shape
    d, h = int(solution.direction), float(solution.voxel_size)
    weights = _face_weights(solution, fields)
    cell = np.empty((3, *shape), np.float32)
    for a in range(3):
        q = vel[a] if weights is None else vel[a] * weights[a]
        cell[a] = 0.5 * (q + np.roll(q, -1, axis=a))
    solid = _solved_solid(solution, fields, shape)
    cells = np.asarray(solution.pressure_cells, bool)
    total = voxel_total_pressure(p, cells, d, h, solution.pressure_gradient)
    i0, i1 = (int(v) for v in solution.rve_slice)
    origin = [0.0, 0.0, 0.0]
    origin[d] = -i0 * h
    grid = pv.ImageData(dimensions=np.array(shape) + 1, spacing=(h, h, h), origin=origin)
    grid.cell_data["velocity_m_per_s"] = np.column_stack([_flat(c) for c in cell])
    grid.cell_data["velocity_magnitude_m_per_s"] = _flat(np.sqrt((cell**2).sum(axis=0)))
    grid.cell_data["pressure_Pa"] = _flat(total)
    grid.cell_data["solid"] = _flat(solid.astype(np.uint8))
    grid.cell_data["pressure_cell"] = _flat(cells.astype(np.uint8))
    zone = region_ids_along(shape[d], i0, i1).reshape([-1 if b == d else 1 for b in range(3)])
    grid.cell_data["zone"] = _flat(np.broadcast_to(zone, shape).astype(np.uint8))
    add_tables(grid)
    grid.field_data["cut_cell_weighted_velocity"] = np.array([int(weights is not None)])
    _add_result(grid, result, solution.viscosity)
    return grid


def _add_result(grid, result: dict | None, viscosity: float) -> None:
    grid.field_data["viscosity_Pa_s"] = np.array([float(viscosity)])
    if not result:
        return
    grid.field_data["direction_axis"] = np.array(["xyz".index(str(result["direction"]))])
    grid.field_data["permeability_m2"] = np.array([float(result["permeability_m2"])])
    add_rating(grid, result, "permeability_rel_error")
    for key, name in (
        ("mean_velocity_m_s", "superficial_velocity_m_per_s"),
        ("flow_rate_m3_s", "flow_rate_m3_per_s"),
        ("pressure_drop_rve_pa", "pressure_drop_rve_Pa"),
        ("pressure_gradient_pa_m", "pressure_gradient_Pa_per_m"),
    ):
        if result.get(key) is not None:
            grid.field_data[name] = np.atleast_1d(np.asarray(result[key], float))
    rve = rve_gradient(result)
    if rve is not None:
        grid.field_data["pressure_gradient_rve_Pa_per_m"] = np.array([rve[0]])
        grid.field_data["rve_copies"] = np.array([rve[1]], np.int32)


def rve_gradient(result: dict) -> tuple[float, int] | None:
    """``(G, copies)``: the pressure gradient (Pa/m) that defines the reported K over the
    ``rve`` zone, so ``K = mu <u> / G`` with ``<u>`` the mean velocity along the flow over
    that zone, and the copies of the RVE the zone holds along the flow; None without the
    keys. A permeameter's ``pressure_gradient_pa_m`` spans the whole stack, reservoirs
    included (``mu <u> / G`` was K +20 % for a 24 um RVE between 5-voxel reservoirs, walk-api
    session 54): its G is ``pressure_drop_rve_pa / rve_length_m`` (the zone's length, every
    copy); a periodic solve's is its ``pressure_gradient_pa_m``, over one copy.

    >>> rve_gradient({"bc": "permeameter", "pressure_drop_rve_pa": 0.5, "rve_length_m": 4.8e-5,
    ...               "permeameter_copies": 2})
    (10416.666666666666, 2)
    >>> rve_gradient({"bc": "periodic", "pressure_gradient_pa_m": 1e5})
    (100000.0, 1)
    """
    if result.get("bc") == "permeameter":
        drop, length = result.get("pressure_drop_rve_pa"), result.get("rve_length_m")
        if drop is None or not length:
            return None
        return float(drop) / float(length), int(result.get("permeameter_copies") or 1)
    grad = result.get("pressure_gradient_pa_m")
    return None if grad is None else (float(grad), 1)


def add_rating(grid, result: dict, rel_key: str) -> None:
    """A solve's relative error bar (``result[rel_key]``, under that name:
    ``permeability_rel_error``, a Laplace solve's ``rel_error``) and ``status_ok`` (1 when its
    ``status`` is ``ok``, else 0; the word is in fields.json and the picture's title: a
    string array in a .vtu stops meshio's reader) as field data of ``grid``: a ParaView user
    read the value without either until session 49."""
    if result.get(rel_key) is not None:
        grid.field_data[rel_key] = np.array([float(result[rel_key])])
    if result.get("status") is not None:
        grid.field_data["status_ok"] = np.array([int(result["status"] == "ok")], np.int32)


def face_mean(points: np.ndarray, triangles: np.ndarray, values: np.ndarray) -> float:
    """Area-weighted mean of a P1 (vertex) field over triangles.

    Parameters
    ----------
    points : np.ndarray
        ``(n, 3)`` vertex coordinates (m).
    triangles : np.ndarray
        ``(m, 3)`` vertex indices.
    values : np.ndarray
        ``(n,)`` vertex values; triangles with a NaN vertex are left out.

    Returns
    -------
    float
        ``sum_t A_t mean_t / sum_t A_t`` (the exact integral of the linear interpolant over the
        area).
    """
    tri = np.asarray(triangles)
    area = triangle_areas(np.asarray(points, float), tri)
    mean = np.asarray(values, float)[tri].mean(axis=1)
    ok = np.isfinite(mean)
    return float((area[ok] * mean[ok]).sum() / area[ok].sum())


#: VTK's node order of a quadratic tet (``QUADRATIC_TETRA``: the mid-points of these edges
#: follow the 4 vertices) and of a quadratic triangle (``QUADRATIC_TRIANGLE``).
TET_EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
TRI_EDGES = ((0, 1), (1, 2), (2, 0))


def quadratic_cells(
    tets: np.ndarray, tris: np.ndarray, n_points: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mid-edge nodes of a tet mesh in VTK's quadratic node order.

    Parameters
    ----------
    tets : np.ndarray
        ``(m, 4)`` vertex indices.
    tris : np.ndarray
        ``(k, 3)`` boundary triangles (faces of ``tets``).
    n_points : int
        Vertices of the mesh; edge ``i`` gets the node ``n_points + i``.

    Returns
    -------
    tets10, tris6, edges : np.ndarray
        ``(m, 10)`` and ``(k, 6)`` node indices, and the ``(e, 2)`` vertex pairs of the edges.

    >>> t10, t6, e = quadratic_cells(np.array([[0, 1, 2, 3]]), np.array([[0, 2, 1]]), 4)
    >>> t10.tolist(), t6.tolist(), len(e)
    ([[0, 1, 2, 3, 4, 7, 5, 6, 8, 9]], [[0, 2, 1, 5, 7, 4]], 6)
    """
    tets, tris = np.asarray(tets, np.int64), np.asarray(tris, np.int64).reshape(-1, 3)

    def keys(cells: np.ndarray, order: tuple) -> np.ndarray:
        pairs = np.sort(np.concatenate([cells[:, list(e)] for e in order]), axis=1)
        return pairs[:, 0] * n_points + pairs[:, 1]

    unique, inverse = np.unique(keys(tets, TET_EDGES), return_inverse=True)
    tets10 = np.hstack([tets, n_points + inverse.reshape(len(TET_EDGES), -1).T])
    on_tri = keys(tris, TRI_EDGES)
    where = np.minimum(np.searchsorted(unique, on_tri), max(len(unique) - 1, 0))
    if len(on_tri) and not np.array_equal(unique[where], on_tri):
        raise ValueError("fields: a boundary triangle's edge is no edge of a tet")
    tris6 = np.hstack([tris, n_points + where.reshape(len(TRI_EDGES), -1).T])
    return tets10, tris6, np.column_stack([unique // n_points, unique % n_points])


def _mid_edge_values(solution, pts, vel, p, edges):
    """``(points, velocity, pressure)`` at the vertices followed by the edge mid-points: the
    solver's P2 velocity there (0 off the solved mesh, as at a removed vertex) and the P1
    pressure's mean of the edge's ends."""
    mid = 0.5 * (pts[edges[:, 0]] + pts[edges[:, 1]])
    u_mid = np.nan_to_num(solution.sample(mid, outside="nan")[0], nan=0.0)
    p_mid = 0.5 * (p[edges[:, 0]] + p[edges[:, 1]])
    return np.vstack([pts, mid]), np.vstack([vel, u_mid]), np.concatenate([p, p_mid])


def fem_flow_grids(
    solution,
    mesh,
    result: dict | None = None,
    viscosity: float = float("nan"),
    pressure_gradient: float = 0.0,
):
    """Volume and boundary ``pyvista.UnstructuredGrid`` of a tet-mesh Stokes solve.

    The volume holds 10-node quadratic tets with the P2 velocity at every node (module
    docstring). ``viscosity`` (Pa s) is recorded as field data; ``pressure_gradient`` (Pa/m,
    periodic solves) is added back to the periodic pressure fluctuation along the flow axis,
    and the pressure is shifted by a constant so that its area-weighted mean over the outlet
    triangles is 0 (:func:`face_mean`: the outflow condition holds the traction weakly, so the
    solved P1 pressure there is 0 neither pointwise nor exactly in the mean). The boundary grid
    holds the tagged triangles (6-node) with ``tag`` cell data (ids of
    :func:`psdesign.fields.tables.boundary_table`) and the same point data.
    """
    import pyvista as pv

    from psdesign.meshing.exports._common import boundary

    pts = np.asarray(mesh.points, float)
    vel = np.asarray(solution.velocity, float)
    p = np.asarray(solution.pressure, float)
    if pressure_gradient:
        x = pts[:, mesh.axis]
        p = p + pressure_gradient * (x.max() - x)
    tris, ids, _ = boundary(mesh)
    outlet = tris[ids == tags.TAG_IDS[tags.OUTLET]]
    if len(outlet):
        p = p - face_mean(pts, outlet, p)
    tets10, tris6, edges = quadratic_cells(mesh.tets, tris, len(pts))
    nodes, vel, p = _mid_edge_values(solution, pts, vel, p, edges)
    point_data = {
        "velocity_m_per_s": vel,
        "velocity_magnitude_m_per_s": np.linalg.norm(vel, axis=1),
        "pressure_Pa": p,
    }
    vol = pv.UnstructuredGrid({pv.CellType.QUADRATIC_TETRA: tets10}, nodes)
    zone = tags.region_ids(mesh.tet_regions(), "int32")
    vol.cell_data["zone"] = zone
    vol.cell_data["region"] = np.full(len(mesh.tets), tags.FLUID_TAG, np.int32)
    bnd = pv.UnstructuredGrid({pv.CellType.QUADRATIC_TRIANGLE: tris6}, nodes)
    bnd.cell_data["tag"] = ids.astype(np.int32)
    for g in (vol, bnd):
        for k, v in point_data.items():
            g.point_data[k] = v
        add_tables(g, boundary=True)
        g.field_data["velocity_p2_quadratic_cells"] = np.array([1], np.int32)
        _add_result(g, result, viscosity)
    return vol, bnd
