"""Transport properties of a voxelized RVE beyond permeability (issue 13).

* :mod:`~psdesign.transport.diffusivity`: relative diffusivity ``D_eff / D_bulk`` (per direction
  and the periodic tensor), tortuosity factor, Knudsen / transition regime (Bosanquet);
* :mod:`~psdesign.transport.conductivity`: two-phase effective conductivity, bounds;
* :mod:`~psdesign.transport.pores`: local thickness, intrusion curve, specific surface,
  porosity profile, fibre orientation tensor;
* :mod:`~psdesign.transport.study_outputs`: the study-row outputs.

The Laplace solves are :func:`solvers.transport.solve_laplace`; the effective properties are
formed here (:mod:`~psdesign.transport.effective`).
"""
