"""Published reference values the tests compare against, each with its source.

One module so that a value is typed once and its citation travels with it.
"""

from __future__ import annotations

#: NASA PuMA (pumapy 3.2.2) K_zz of ``data/fibres_{32,64}.npz`` in unit-cube lengths squared:
#: Q1-Q1 voxel FEM, periodic sides, unit body force (``data/README-puma.md``).
PUMA_FIBRES_KZZ = {32: 0.009785, 64: 0.010145}
#: Porosity of the same images.
PUMA_FIBRES_POROSITY = {32: 0.96139, 64: 0.96125}

#: Paper Table III permeabilities (m^2), Huang et al., Eng. Comput. 32(1), 2015.
PAPER_TABLE3 = {
    "straight": {"through_plane": 8.07e-12, "in_plane": 1.21e-11},
    "bent": {"through_plane": 7.8e-12, "in_plane": 1.11e-11},
    "woven": {"through_plane": 2.55e-12},
}
