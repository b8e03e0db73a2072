"""Pictures of RVEs: fiber isosurfaces rendered off-screen with pyvista."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np


def _quiet_vtk() -> None:
    """Hide VTK's warnings about a missing X display (rendering falls back off-screen)."""
    from vtkmodules.vtkCommonCore import vtkLogger

    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)


def distance_image(distance: np.ndarray, spacing: np.ndarray):
    """A pyvista ImageData with the distance field (metres) at voxel centres as point data."""
    import pyvista as pv

    img = pv.ImageData(
        dimensions=distance.shape, spacing=tuple(spacing), origin=tuple(np.asarray(spacing) / 2)
    )
    img.point_data["distance_m"] = np.asarray(distance, np.float32).ravel(order="F")
    return img


#: Smallest |distance| contoured, in voxels: moves the surface by at most this (1e-3 voxel).
EDGE_MARGIN = 1e-3


def fiber_surface(distance: np.ndarray, spacing: np.ndarray):
    """Closed triangle surface of the fiber solid (level 0 of the padded distance field).

    The field is padded by one pore voxel on every side so fibers are capped where
    they cross the box faces. Coordinates in metres. The triangles are wound with their
    normals out of the solid (into the pore), as STL asks: VTK's contour winds them along
    the field's gradient reversed, i.e. into the fibers (signed volume -0.198 of the box for
    a solid fraction 0.199 before 2026-12-04).

    The surface is a closed 2-manifold (every edge in exactly two triangles, one closed fan
    of triangles around every vertex) also where fibers touch: values within
    ``EDGE_MARGIN`` voxels of 0 are moved to +-EDGE_MARGIN voxels first (tested in
    ``tests/validation/test_geometry_truth.py``).
    """
    pad = np.pad(np.asarray(distance, np.float32), 1, constant_values=float(np.max(spacing)))
    # a value at (or within float32 noise of) 0 puts contour vertices on the grid point, where
    # the edges meeting there share one vertex after merging: 4-10 triangles on one edge
    # (RESULTS "geom21"); kept EDGE_MARGIN of a voxel off 0, each vertex stays on its own edge
    eps = np.float32(EDGE_MARGIN * float(np.min(spacing)))
    pad = np.where(np.abs(pad) < eps, np.where(pad < 0, -eps, eps), pad)
    img = distance_image(pad, spacing)
    img.origin = tuple(-np.asarray(spacing) / 2)
    surf = img.contour([0.0], scalars="distance_m")
    return surf.triangulate().clean().flip_faces()


STL_CHUNK = 250_000
"""Triangles per block of :func:`write_stl` (a Ctrl-C waits for one block at most)."""

_STL_RECORD = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])


def write_stl(surf, path: str | Path) -> None:
    """Write a triangle surface (:func:`fiber_surface`) as binary STL, block by block.

    The same file as VTK's binary STL writer (unit facet normals from the vertex order,
    float32 coordinates), written in blocks of :data:`STL_CHUNK` triangles: VTK wrote the
    136 MB ``fibers.stl`` of a 200^3 field in one 3 s C call, which a Ctrl-C had to wait for.
    """
    faces = np.asarray(surf.faces).reshape(-1, 4)
    if len(faces) and not np.all(faces[:, 0] == 3):
        raise ValueError("write_stl: the surface must be triangles")
    tri = faces[:, 1:]
    pts = np.asarray(surf.points, dtype=np.float64)
    header = b"psdesign binary STL (fibers, metres)".ljust(80, b" ")
    with open(path, "wb") as f:
        f.write(header)
        f.write(np.uint32(len(tri)).tobytes())
        for i in range(0, len(tri), STL_CHUNK):
            v = pts[tri[i : i + STL_CHUNK]]
            n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
            norm = np.linalg.norm(n, axis=1, keepdims=True)
            n = np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)
            block = np.zeros(len(v), _STL_RECORD)
            block["normal"] = n
            block["vertices"] = v
            f.write(block.tobytes())


PREVIEW_POINTS = 128
"""Grid points along the longest edge of the field a preview is rendered from (a finer field
is sampled every k-th point): a 900 x 700 picture shows no finer detail, and the render of the
full 200^3 field at 1 um (2.7 M triangles, smooth shading) took 6-12 s, which an interrupt
waits for."""


PREVIEW_ZOOM = 0.9
"""Camera zoom after the isometric reset: a margin of about a tenth around the RVE box."""


def box_label(shape: tuple[int, ...], spacing: np.ndarray) -> str:
    """The preview's scale: the RVE box's edge lengths in micrometres (a perspective view has
    no one scale; the box outline beside these lengths gives the fibers' size).

    >>> box_label((100, 100, 50), np.array([0.5e-6, 0.5e-6, 0.5e-6]))
    'box 50 x 50 x 25 µm'
    >>> box_label((120, 120, 120), np.full(3, 0.8333333333333333e-6))
    'box 100 x 100 x 100 µm'
    >>> box_label((1500, 1500, 200), np.full(3, 1e-6))  # never '1.5e+03' (review s45)
    'box 1500 x 1500 x 200 µm'
    """
    # 3 significant digits, written out: rve.size allows up to 1 m (1e6 µm)
    edges = [float(f"{n * float(h) * 1e6:.3g}") for n, h in zip(shape, spacing, strict=True)]
    return "box " + " x ".join(f"{e:.10g}" for e in edges) + " µm"


def preview_title(values: dict, image: bool | None = None) -> str:
    """The title of an RVE's preview picture, ``generate``'s preview.png and a study case's
    (one helper for both since session 48: a study's previews had none): the values
    ``generate`` prints of the RVE the picture shows, each with its bar and its status in the
    words of its status column (the report's values table's): the porosity
    (``porosity_status``) and the fibres' overlap Omega (``intersection_volume_fraction_status``),
    then the fibre count (session 42: the porosity without its bar; session 45: without its
    status; session 47: Omega, which the JSON line rated, was not in it). An image's RVE
    (``image``, by default ``generation.source == "image"``) has no fibre list: its 0/1 count
    cannot see where fibres overlap, so Omega is left out of its title (session 47 review:
    ``Omega 0 +- 0 [ok]`` under an image of two cylinders overlapping 0.00548 of the box;
    docs/geometry.md).

    Parameters
    ----------
    values : dict
        ``generate``'s summary or a study case's row (``results.csv``: a missing value is
        None or NaN, left out with its status).
    image : bool, optional
        Whether the RVE is an image's; None: read ``values["generation"]["source"]``.

    Returns
    -------
    str
        The title, "" without a porosity.

    Examples
    --------
    >>> preview_title({"porosity": 0.81234, "porosity_error": 0.00042, "n_fibers": 12,
    ...                "intersection_volume_fraction": 0.00213,
    ...                "intersection_volume_fraction_error": 0.0003,
    ...                "intersection_volume_fraction_status": "ok"})
    'porosity 0.8123 +- 4.2e-04 [ok], Omega 0.00213 +- 3.0e-04 [ok], 12 fibers'
    >>> preview_title({"porosity": 0.088, "porosity_error": 0.024, "n_fibers": 3,
    ...                "intersection_volume_fraction": 0.0,
    ...                "intersection_volume_fraction_error": 0.0,
    ...                "intersection_volume_fraction_status": "untrustworthy"})
    'porosity 0.0880 +- 2.4e-02 [untrustworthy], Omega 0 +- 0 [untrustworthy], 3 fibers'
    >>> preview_title({"porosity": 0.861, "porosity_error": 0.01, "n_fibers": 0,
    ...                "intersection_volume_fraction": 0.0, "generation": {"source": "image"}})
    'porosity 0.8610 +- 1.0e-02 [ok], 0 fibers'
    >>> preview_title({"porosity": 0.9, "porosity_error": float("nan"), "n_fibers": 4.0,
    ...                "intersection_volume_fraction": float("nan")})  # a table's row
    'porosity 0.9000 [unrated], 4 fibers'
    """
    from psdesign.analysis.columns import cell_number, porosity_status
    from psdesign.geometry.porosity import porosity_text

    eps, err = cell_number(values.get("porosity")), cell_number(values.get("porosity_error"))
    if eps is None:
        return ""
    parts = [f"porosity {porosity_text(eps, err)} [{porosity_status(eps, err)}]"]
    omega = cell_number(values.get("intersection_volume_fraction"))
    if image is None:
        image = (values.get("generation") or {}).get("source") == "image"
    if omega is not None and not image:  # as the values table prints it: an exact 0, 3 digits
        bar = cell_number(values.get("intersection_volume_fraction_error"))
        text = "0" if omega == 0 else f"{omega:.3g}"
        text += "" if bar is None else " +- " + ("0" if bar == 0 else f"{bar:.1e}")
        status = values.get("intersection_volume_fraction_status")
        status = status if isinstance(status, str) and status else "unrated"
        parts.append(f"Omega {text} [{status}]")
    n = cell_number(values.get("n_fibers"))
    return ", ".join(parts + ([] if n is None else [f"{n:.0f} fibers"]))


def render_preview(
    distance: np.ndarray,
    spacing: np.ndarray,
    path: str | Path,
    title: str = "",
    window_size: tuple[int, int] = (900, 700),
    surface=None,
) -> Path:
    """Render the fibers (and the RVE box outline) to a PNG off-screen.

    Parameters
    ----------
    distance : ndarray (nx, ny, nz)
        Union field in metres, <= 0 in the solid.
    spacing : ndarray (3,)
        Voxel edges in metres.
    path : path
        PNG to write.
    surface : pyvista.PolyData, optional
        :func:`fiber_surface` of ``distance``, when the caller already made it (``generate``
        writes it as ``fibers.stl``), used when the grid needs no coarsening: contouring it
        twice doubled the time and the peak memory of the two.
    """
    from psdesign.study.interrupt import held_signals

    os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
    import pyvista as pv

    pv.OFF_SCREEN = True
    _quiet_vtk()
    shape = distance.shape
    stride = max(1, -(-max(shape) // PREVIEW_POINTS))  # a coarser grid of the same box
    if surface is None or stride > 1:
        surface = fiber_surface(
            distance[::stride, ::stride, ::stride], np.asarray(spacing) * stride
        )
    surf = surface
    # VTK swallows an exception raised in pyvista's Python algorithms (smooth shading) while
    # it builds and renders the scene: a Ctrl-C there was lost; it is held and raised when the
    # render returns
    with held_signals():
        scale = 1e6  # show micrometres
        plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
        plotter.set_background("white")
        if surf.n_points:
            surf = surf.scale(scale, inplace=False)
            plotter.add_mesh(surf, color="#4a7ab5", smooth_shading=True, specular=0.3)
        box = pv.Box(
            bounds=(
                0,
                shape[0] * spacing[0] * scale,
                0,
                shape[1] * spacing[1] * scale,
                0,
                shape[2] * spacing[2] * scale,
            )
        )
        plotter.add_mesh(box, style="wireframe", color="black", line_width=1)
        plotter.show_axes()
        # the scale (session 45: no picture said how big its box was)
        plotter.add_text(
            box_label(shape, spacing), position="lower_right", font_size=12, color="black"
        )
        if title:
            plotter.add_text(title, font_size=10, color="black")
        plotter.camera_position = "iso"  # the box's bounding sphere touches the view cone
        # a corner on that sphere nearer the camera than the focal point reached the picture's
        # edge, and the zoom of 1.1 before session 42 cut it and the fibers there off
        plotter.camera.zoom(PREVIEW_ZOOM)
        path = Path(path)
        plotter.screenshot(str(path))
        plotter.close()
    return path
