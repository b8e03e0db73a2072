"""Measured structures in: voxel images (TIFF stacks or slices, raw, NumPy, VTI) as RVEs;
RVEs out as TIFF stacks. An image enters the data flow where the geometry stage's voxel
fields do."""
