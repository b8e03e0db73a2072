"""Solver fields for ParaView: velocity and pressure of the Stokes solves, concentration and
potential of the Laplace solves, as VTU (tet mesh) and VTI (voxel grid) files with named arrays
and units, region and boundary tag tables, and a PNG picture of each solve
(``--fields OUT/`` on ``permeability``, ``diffusivity`` and ``conductivity``)."""

from psdesign.fields.writer import UNITS, FieldWriter, field_files, fields_folder, fields_output

__all__ = ["UNITS", "FieldWriter", "field_files", "fields_folder", "fields_output"]
