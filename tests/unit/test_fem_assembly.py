"""``solvers.fem.assembly.weighted_dissipation`` (the FEM error estimate's weighted
``int w |grad u|^2 dV``) against a closed form, with no third-party warning.

Truth: on the unit cube, ``u = (x, 0, 0)`` (exact in P2) has ``|grad u|^2 = 1``, so with the
weight ``w(x) = x`` the integral is ``int_0^1 x dx = 1/2`` (a degree-4 rule is exact for it).
Session 54 (walk-api 2): the quadrature points were read as ``global_coordinates().value``,
which scikit-fem deprecates; the warning reached every API user's line.
"""

from __future__ import annotations

import warnings

import numpy as np
from skfem import MeshTet

from solvers.fem.assembly import p2_dofs, weighted_dissipation


def test_weighted_dissipation_is_the_closed_form_without_a_deprecation_warning() -> None:
    mesh = MeshTet.init_tensor(*(np.linspace(0.0, 1.0, 4),) * 3)
    _, n2 = p2_dofs(mesh)
    # P2 nodes: the vertices, then the edge midpoints in mesh.edges order
    nodes_x = np.concatenate([mesh.p[0], mesh.p[0, mesh.edges].mean(axis=0)])
    assert len(nodes_x) == n2
    u = np.zeros((3, n2))
    u[0] = nodes_x
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        got = weighted_dissipation(mesh, u, lambda x: x[:, 0], chunk=50)
    assert abs(got - 0.5) < 1e-12, got
    # the unweighted integral is the cube's volume (a wrong weight or gradient fails one)
    assert abs(weighted_dissipation(mesh, u, lambda x: np.ones(len(x))) - 1.0) < 1e-12
