"""Error estimates of voxel-count volume fractions: the porosity, and the intersection
volume fraction Omega (:func:`count_fraction_error`).

A voxel is counted as pore by its centre, so the count errs by the partial volumes of the
voxels the surface crosses.  Two independent quadratures of the same pore volume give the
estimate: the count, and the partial volume ``clip(1/2 + d / h, 0, 1)`` of each voxel from the
signed distance ``d`` at its centre (exact for a plane along a voxel face; second order for a
smooth surface), itself checked on the grid of every second voxel::

    error = |count - partial(h)| + |partial(h) - partial(2 h)|

On 100 random periodic RVEs (1-4 tilted rods and cylinders of 0.1-0.3 periods, 20 and 40
voxels per period) it covered the true error of the count (against the partial volume at 128
voxels per period) in 96 of 100 and was a median 8x that error; the rigorous bound (the
fraction of voxels the surface crosses, :func:`psdesign.transport.pores.porosity_profile`) was
a median 100x.  ``tests/unit/test_porosity_error.py`` repeats the check.
"""

from __future__ import annotations

import numpy as np

#: x-planes per slab of the partial-volume sum (bounds the float32 temporary: 32 planes of a
#: 400^3 grid are 20 MB).
SLAB = 32


def partial_volume_porosity(distance: np.ndarray, h: float) -> float:
    """Mean partial pore volume ``clip(1/2 + d / h, 0, 1)`` of the voxels (``d`` in metres,
    <= 0 in the solid; ``h`` the voxel edge).

    >>> d = np.array([[[-0.5, 0.0, 0.25, 2.0]]])
    >>> partial_volume_porosity(d, 1.0)
    0.5625
    """
    scale = np.float32(1.0 / h)
    total = 0.0
    for i in range(0, distance.shape[0], SLAB):
        part = distance[i : i + SLAB] * scale
        part += np.float32(0.5)
        np.clip(part, 0.0, 1.0, out=part)
        total += float(part.sum(dtype=np.float64))
    return total / distance.size


def porosity_error(distance: np.ndarray, h: float, porosity: float) -> float:
    """Estimated absolute error of the voxel-count ``porosity`` against the pore volume
    fraction of the analytic surface sampled by ``distance`` (see the module's docstring).

    ``h`` is the voxel edge (metres; the cube root of the voxel volume where the three
    spacings differ).  A grid with fewer than two
    voxels along an axis has no coarse grid; there the coarse term is left out.
    """
    fine = partial_volume_porosity(distance, h)
    err = abs(porosity - fine)
    if min(distance.shape) >= 2:
        coarse = partial_volume_porosity(distance[::2, ::2, ::2], 2.0 * h)
        err += abs(fine - coarse)
    return float(err)


#: Rounding spreads in :func:`count_fraction_error` (calibrated: see there).
SPREADS = 2.5


def count_fraction_error(mask: np.ndarray) -> float:
    """Estimated absolute error of the volume fraction ``mask.mean()`` of a region counted by
    voxel centres, without a distance to the region's surface (the intersection volume Omega:
    inside two fibres at once)::

        error = |f(h) - f(2 h)| + 2.5 sqrt(N_b / 12) / N

    the change on the grid of every second voxel plus 2.5 times the spread of the centre
    count's rounding: each of the ``N_b`` voxels on either side of the region's boundary
    (6-neighbours, periodic) is counted whole or not at all, an error of its partial volume,
    about uniform in [-1/2, 1/2] (variance 1/12). Calibrated on two perpendicular cylinders of
    diameter 0.15-0.4 periods (their Steinmetz intersection ``16 r^3 / 3`` exactly), 16-48
    voxels per period, 120 cases: covered the true error in 116 (97 %), a median 5.3x it (with
    2 spreads 94 %; each term alone 72 % and 78 %; ``benchmarks/porosity_error_coverage.py
    omega``).
    A region that contains no voxel centre (a lens thinner than a voxel) gives 0 and is
    missed by the count too.

    >>> m = np.zeros((8, 8, 8), bool); m[2:6, 2:6, 2:6] = True
    >>> round(count_fraction_error(m), 4)
    0.0174
    """
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return 0.0
    boundary = np.zeros_like(mask)
    for ax in range(3):
        step = mask != np.roll(mask, 1, axis=ax)  # voxel i differs from i - 1
        boundary |= step
        boundary |= np.roll(step, -1, axis=ax)  # ... and i - 1 from i
    coarse = float(mask[::2, ::2, ::2].mean())
    spread = SPREADS * np.sqrt(np.count_nonzero(boundary) / 12.0) / mask.size
    return float(abs(mask.mean() - coarse) + spread)


def porosity_text(porosity: float, error: float | None) -> str:
    """``"0.8123 +- 4.2e-04"`` (the value and its absolute error estimate) for the commands'
    text lines and the notebook's tables; without the bar where none is known.

    >>> porosity_text(0.81234, 0.00042)
    '0.8123 +- 4.2e-04'
    """
    bar = "" if error is None else f" +- {error:.1e}"
    return f"{porosity:.4f}{bar}"
