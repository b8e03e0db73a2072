"""A one-cylinder periodic RVE (20 um cube, 8 um fiber along z, 1 um voxels) for fast CLI tests
of the transport commands: every quantity of it is a closed form or a bound (the straight pore
along z, the parallel / series means)."""

CYLINDER_SPEC = """
[rve]
size = [20e-6, 20e-6, 20e-6]
voxel = 1e-6

[[fibers]]
shape = "cylinder"
diameter = 8e-6
center = [10e-6, 10e-6, 10e-6]
direction = [0, 0, 1]

[transport]
error_estimate = "residual"
"""
