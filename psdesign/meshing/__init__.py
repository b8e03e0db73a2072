"""Building blocks of the pore-space mesher (public API: :mod:`psdesign.meshing.pore_mesh`).

Modules
-------
surface
    Signed-distance field -> fiber-solid surface (marching cubes) -> exact pore-space surface with
    auxiliary inlet/outlet slabs (manifold3d booleans).
tetra
    pytetwild tetrahedralization, boundary extraction, plane snapping, boundary tags, connectivity.
quality
    Tet-quality measures (dihedral angles, radius ratio, volumes).
export
    VTU, Gmsh 2.2, STL and JSON writers; :mod:`.fluent` and :mod:`.openfoam` for the CFD formats.
"""
