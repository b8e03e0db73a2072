"""Offscreen pictures of a field: the mid-plane slice through the flow axis, rendered with
matplotlib's Agg backend (no display, no X server, no GPU; pyvista's own renderer needs an
OpenGL context that a headless machine may not have).

Of the two mid-planes through the flow axis the one cutting more fibre outline is drawn.
Left panel: the magnitude of a vector field with its in-plane streamlines; right panel: a
scalar (pressure, concentration or potential). The slice is sampled from the dataset with
``vtkProbeFilter`` (:meth:`pyvista.DataSet.sample`) on a regular grid of points, so voxel
(``ImageData``) and tet-mesh (``UnstructuredGrid``) results are drawn the same way; points in
the solid are blank.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _valid(probe) -> np.ndarray:
    valid = np.asarray(probe.point_data["vtkValidPointMask"], bool)
    if "solid" in probe.point_data:  # voxel grids: blank the fibres as the mesh does
        valid &= np.asarray(probe.point_data["solid"]) == 0
    return valid


def _probe(dataset, flow_axis: int, n: int):
    """The mid-plane probe through the flow axis that cuts the most fibre outline (of the two
    planes containing the flow axis), and its normal axis."""
    best = None
    for normal in [b for b in range(3) if b != flow_axis]:
        plane = _plane(dataset, flow_axis, n, normal)
        probe = plane.sample(dataset)
        img = _valid(probe).reshape([d for d in probe.dimensions if d > 1], order="F")
        edges = int(np.count_nonzero(np.diff(img, axis=0)) + np.count_nonzero(np.diff(img, axis=1)))
        if best is None or edges > best[0]:
            best = (edges, probe, normal)
    return best[1], best[2]


def _plane(dataset, flow_axis: int, n: int, normal: int):
    import pyvista as pv

    lo = np.array(dataset.bounds[0::2], float)
    hi = np.array(dataset.bounds[1::2], float)
    dims = [n, n, n]
    dims[normal] = 1
    spacing = (hi - lo) / np.maximum(np.array(dims) - 1, 1)
    origin = lo.copy()
    origin[normal] = 0.5 * (lo[normal] + hi[normal])
    spacing[normal] = 1.0
    # keep the probe points off the bounding box faces (a probe on a face can miss the cell)
    inset = 1e-6 * (hi - lo)
    spacing = spacing - 2 * inset / np.maximum(np.array(dims) - 1, 1)
    origin = origin + np.where(np.arange(3) == normal, 0.0, inset)
    return pv.ImageData(dimensions=dims, spacing=spacing, origin=origin)


#: Flow extent over the extent across above which the slice is drawn with the flow axis across
#: the page and the two panels one above the other: a permeameter's stack (two or three copies
#: and two reservoirs, 4.4 times as long as the 12 um across of the fields test's RVE) was two
#: thin upright strips in a wide picture, about 15 % of it field (session 43).
LONG_SLICE = 1.5
#: Width (inches) of a panel's field when the panels are stacked, and the most a stacked
#: picture may be tall (a very long slice gets thinner panels, not a taller picture).
STACKED_FIELD_WIDTH_IN = 8.2
STACKED_MAX_HEIGHT_IN = 9.0


def slice_picture(
    dataset,
    path: str | Path,
    flow_axis: int,
    vector: str,
    scalar: str,
    title: str = "",
    n: int = 160,
) -> Path:
    """Write a PNG of the mid-plane slice (see module docstring); returns its path.

    The flow axis is vertical and the panels side by side, or, for a slice longer than
    :data:`LONG_SLICE` times its width (a permeameter's stack with its reservoirs), horizontal
    with the panels one above the other, so that the field fills the picture.

    Parameters
    ----------
    dataset : pyvista dataset
        With the point or cell arrays ``vector`` (3 components) and ``scalar``.
    path : path of the PNG.
    flow_axis : int
        The slice contains this axis and the first other axis.
    vector, scalar : str
        Array names; each panel's colour bar is labelled with the name.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    probe, normal = _probe(dataset, flow_axis, n)
    valid = _valid(probe)
    across = [b for b in range(3) if b not in (flow_axis, normal)][0]
    shape = [d for d in probe.dimensions if d > 1]
    vec = np.asarray(probe.point_data[vector], float)
    sca = np.asarray(probe.point_data[scalar], float)
    vec[~valid] = np.nan
    sca[~valid] = np.nan
    pts = np.asarray(probe.points)
    xs = np.unique(pts[:, across]) * 1e6
    ys = np.unique(pts[:, flow_axis]) * 1e6
    long = (ys[-1] - ys[0]) > LONG_SLICE * (xs[-1] - xs[0])

    def grid2(v: np.ndarray) -> np.ndarray:  # the flow axis vertical, or horizontal if long
        img = v.reshape(shape, order="F")
        img = img.T if across < flow_axis else img  # (flow, across)
        return img.T if long else img

    names = "xyz"
    h, v = (ys, xs) if long else (xs, ys)  # the picture's horizontal and vertical coordinates
    labels = [f"{names[a]} (um)" for a in ((flow_axis, across) if long else (across, flow_axis))]
    mag = np.linalg.norm(vec, axis=1)
    mag[~valid] = np.nan
    u, w = grid2(vec[:, across]), grid2(vec[:, flow_axis])
    fig, axes = _figure(plt, long, (ys[-1] - ys[0]) / max(xs[-1] - xs[0], 1e-30))
    ext = (h[0], h[-1], v[0], v[-1])
    im0 = axes[0].imshow(grid2(mag), origin="lower", extent=ext, cmap="viridis", aspect="equal")
    if np.isfinite(u).any() and np.nanmax(np.hypot(u, w)) > 0:
        along, up = (w, u) if long else (u, w)
        axes[0].streamplot(
            h, v, np.nan_to_num(along), np.nan_to_num(up), color="w", linewidth=0.6, density=1.2
        )
    fig.colorbar(im0, ax=axes[0], label=f"|{vector}|")
    im1 = axes[1].imshow(grid2(sca), origin="lower", extent=ext, cmap="coolwarm", aspect="equal")
    fig.colorbar(im1, ax=axes[1], label=scalar)
    for ax in axes:
        ax.set_xlim(h[0], h[-1])  # the streamlines' arrows widened the first panel's limits
        ax.set_ylim(v[0], v[-1])
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
    where = f"mid-plane {names[normal]} = {float(probe.origin[normal]) * 1e6:.4g} um"
    full = f"{title} ({where})" if title else f"{where} slice"
    fig.suptitle(full)
    path = Path(path)
    fig.savefig(path, dpi=110, metadata={"Title": full})  # the plane also in the PNG's text
    plt.close(fig)
    return path


def _figure(plt, long: bool, length: float):
    """The figure and its two panels: side by side (10 x 4.6 in), or for a ``long`` slice
    (``length``: its flow extent over its extent across) one above the other, each
    :data:`STACKED_FIELD_WIDTH_IN` wide and as tall as the slice's aspect makes it, the
    picture at most :data:`STACKED_MAX_HEIGHT_IN` tall."""
    if not long:
        return plt.subplots(1, 2, figsize=(10, 4.6), constrained_layout=True)
    height = min(2.0 * STACKED_FIELD_WIDTH_IN / length + 1.6, STACKED_MAX_HEIGHT_IN)
    return plt.subplots(2, 1, figsize=(10, height), constrained_layout=True)
