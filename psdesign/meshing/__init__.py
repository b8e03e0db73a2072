"""Pore-space mesher (public API: :func:`psdesign.meshing.pore_mesh.mesh_pore_space`).

Modules
-------
pore_mesh
    ``mesh_pore_space(distance, voxel, size, direction, options)``: checks, dispatch.
options
    :class:`MeshOptions` (frozen; ``MeshOptions.from_flow(spec["flow"])``).
tags
    Boundary and region tag names and their integer ids.
inputs
    Input validation; scaled, gap-closed field with its pore-volume estimates.
pore_volume
    Sub-voxel ("analytic") pore volume of a signed-distance field.
stuffing_mesher, stuffing
    The default lattice mesher (deterministic; periodic option) and its lattice kernel.
tetwild_mesher, surface, tetra
    The pytetwild mesher: marching cubes + manifold3d booleans, fTetWild, snapping, tags.
periodic
    Vertex pairing of opposite box faces.
result, checks, quality, cache, topology, errors
    :class:`PoreMesh`; shared checks; tet quality; on-disk cache; face topology; exceptions.
exports
    Writer registry (vtu, msh, fluent, stl, openfoam) and ``mesh.json``.
"""

__all__ = ["MeshOptions"]


def __getattr__(name: str):
    # lazy: ``import psdesign.meshing.exports`` (the CLI's format list) must not import numpy
    if name == "MeshOptions":
        from psdesign.meshing.options import MeshOptions

        return MeshOptions
    raise AttributeError(f"module 'psdesign.meshing' has no attribute {name!r}")
