"""Before/after pictures of force-field assemblies (like paper Figs 11 and 12)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from psdesign.forcefield.fields import ImplicitField
from psdesign.forcefield.potentials import surface_sample

_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


def render_fibers(
    fields: list[ImplicitField], path: str | Path, title: str = "", h: float = 0.008
) -> None:
    """Render every fiber's surface inside the unit cube to a PNG (off-screen pyvista).

    Parameters
    ----------
    fields : list of ImplicitField
    path : str or Path
        Output PNG.
    title : str
        Caption drawn in the picture.
    h : float
        Marching-cubes grid step.
    """
    import pyvista as pv
    from vtkmodules.vtkCommonCore import vtkLogger

    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    from psdesign.study.interrupt import held_signals

    domain = (np.zeros(3), np.ones(3))
    meshes = []
    for i, fld in enumerate(fields):
        s = surface_sample(fld, domain, h, curvature=False)
        if len(s.faces) == 0:
            continue
        faces = np.column_stack([np.full(len(s.faces), 3), s.faces]).ravel()
        meshes.append((i, pv.PolyData(s.verts, faces)))
    # VTK swallows an exception raised in pyvista's smooth-shading algorithm: a Ctrl-C during
    # the scene's set-up or render is held and raised when it returns
    with held_signals():
        plotter = pv.Plotter(off_screen=True, window_size=(900, 700))
        plotter.set_background("white")
        for i, mesh in meshes:
            plotter.add_mesh(mesh, color=_COLORS[i % len(_COLORS)], smooth_shading=True)
        plotter.add_mesh(pv.Box(bounds=(0, 1, 0, 1, 0, 1)).outline(), color="black")
        if title:
            plotter.add_text(title, font_size=10, color="black")
        plotter.camera_position = [(2.2, -1.6, 1.9), (0.5, 0.5, 0.5), (0, 0, 1)]
        plotter.screenshot(str(path))
        plotter.close()
