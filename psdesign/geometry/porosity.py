"""Error estimates of voxel-count volume fractions: the porosity, and the intersection
volume fraction Omega (:func:`count_fraction_error`).

A voxel is counted as pore by its centre, so the count errs by the partial volumes of the
voxels the surface crosses.  Independent quadratures of the same pore volume give the
estimate: the count; the partial volume ``clip(1/2 + d / h, 0, 1)`` of each voxel from the
signed distance ``d`` at its centre (exact for a plane along a voxel face); and the
tangent-plane partial volume (:mod:`psdesign.geometry.plane_cut`: exact for a plane at any
angle), both checked on the grid of every second voxel::

    error = |count - partial(h)|
            + max(|partial(h) - partial(2 h)|, |plane(h) - plane(2 h)|)

Session 32's estimate had the first two terms. On 100 random periodic RVEs (1-4 tilted rods
and cylinders of 0.1-0.3 periods, 20 and 40 voxels per period) it covered the true error of
the count (against the partial volume at 128 voxels per period) in 96 of 100 and was a median
8x that error; the rigorous bound (the fraction of voxels the surface crosses,
:func:`psdesign.transport.pores.porosity_profile`) was a median 100x. It missed axis-aligned
cylinders (session 37: 0.94922 +- 6.5e-4 against pi d^2 / 4's 0.95, 0.83x): their count is a
2-D lattice-point count repeated along the axis, and the clip partial volume's own error there
has a lattice part (the circle crosses long runs of voxels at nearly one angle and offset; a
circle centred on a voxel corner repeats each run eight times) which the coarse grid, sharing
the placement's symmetry, repeats instead of revealing. The tangent-plane volume has no such
part (its error is the curvature's, ``-pi h^2 / 12`` of the porosity per straight cylinder
along an axis, four times that at 2 h), so its two-grid change bounds what the clip's misses.
Session 38 (``benchmarks/porosity_error_calibration.py``; two sets of 354 and 365 cases:
aligned cylinders of 2-47 voxels and porosity 0.04-1 against their analytic area, oblique
cylinders, straight and bent generator RVEs and the woven cell against a 4x finer grid):
covered 352 and 360 (before: 341 and 353), aligned 252 of 254 and 261 of 265 (before 241 and
255), a median 1.8-1.9x the error on aligned cylinders (before 1.6-1.8x), 5-14x on the others
(before 3-13x); session 32's 100 random RVEs: 99 of 100, a median 10.4x / 12.4x at 20 / 40
voxels per period (before 96, 8.1x / 8.5x). Misses left: where two fibres overlap (at the
union's crease both partial volumes err) and a gap between surfaces under about two voxels,
unseen on the coarse grid (solid fraction 0.7 at 16 voxels per period: 0.59x).
``tests/unit/test_porosity_error.py`` repeats the checks.
"""

from __future__ import annotations

import numpy as np

from psdesign.geometry.plane_cut import plane_partial_porosity

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
    fraction of the analytic surface sampled by ``distance`` (see the module's docstring)::

        |count - partial(h)| + max(|partial(h) - partial(2h)|, |plane(h) - plane(2h)|)

    ``plane`` is the tangent-plane partial volume
    (:func:`psdesign.geometry.plane_cut.plane_partial_porosity`). ``h`` is the voxel edge
    (metres; the cube root of the voxel volume where the three spacings differ). A grid with
    fewer than two voxels along an axis has no coarse grid; there the coarse terms are left
    out.
    """
    fine = partial_volume_porosity(distance, h)
    err = abs(porosity - fine)
    if min(distance.shape) >= 2:
        coarse_grid = np.ascontiguousarray(distance[::2, ::2, ::2])
        clip_change = abs(fine - partial_volume_porosity(coarse_grid, 2.0 * h))
        plane_change = abs(
            plane_partial_porosity(distance, h) - plane_partial_porosity(coarse_grid, 2.0 * h)
        )
        err += max(clip_change, plane_change)
    return float(err)


#: Rounding spreads in :func:`count_fraction_error` (calibrated: see there).
SPREADS = 2.25


def count_fraction_error(mask: np.ndarray) -> float:
    """Estimated absolute error of the volume fraction ``mask.mean()`` of a region counted by
    voxel centres, without a distance to the region's surface (the intersection volume Omega:
    inside two fibres at once)::

        error = |f(h) - f(2 h)| + 2.25 sqrt(sum_runs L^2 / 12) / N

    the change on the grid of every second voxel plus 2.25 spreads of the centre count's
    rounding. Each voxel face the region's boundary crosses (``mask`` differs on its two sides)
    ends a line of counted centres, whose length errs by its partial voxel, about uniform in
    [-1/2, 1/2] (variance 1/12); faces in a run of ``L`` neighbours along another axis err
    alike where the surface is a prism along that axis (a fibre along a grid axis: each of its
    sections is the same lattice count), so a run adds ``L^2 / 12``, the larger sum of the two
    run directions per face axis (:func:`_run_square_sum`). Session 46 counted every boundary
    voxel alone (``sqrt(N_b / 12)``, 2.5 spreads): it covered 82 of 106 lenses 3-12 voxels
    deep between fibres along grid axes on voxel faces and 100 of 124 between parallel fibres
    along an axis, whose rounding repeats along the axis.

    Calibration (``python benchmarks/porosity_error_coverage.py lens 400`` and ``omega``,
    benchmarks/RESULTS.md session 47; exact lens volumes): lenses 1-12 voxels deep between
    fibres along grid axes on voxel faces 174 of 181, parallel along an axis 196 of 197,
    crossing at random places 168 of 168; Steinmetz pairs 119 of 120. The bars of the lenses
    session 46's bar covered are a median 1.2-1.5x wider (parallel: 1.7x). A region that
    contains no voxel centre (a lens thinner than a voxel) gives 0 and is missed by the count
    too.

    >>> m = np.zeros((8, 8, 8), bool); m[2:6, 2:6, 2:6] = True
    >>> round(count_fraction_error(m), 4)
    0.0249
    """
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return 0.0
    squares = 0.0
    for b in range(3):
        # the faces between voxel i and i + 1 (flatnonzero: 40x faster than nonzero at 200^3)
        face = np.unravel_index(np.flatnonzero(mask != np.roll(mask, -1, axis=b)), mask.shape)
        squares += max(_run_square_sum(face, mask.shape, a) for a in range(3) if a != b)
    coarse = float(mask[::2, ::2, ::2].mean())
    spread = SPREADS * np.sqrt(squares / 12.0) / mask.size
    return float(abs(mask.mean() - coarse) + spread)


def _run_square_sum(cells: tuple[np.ndarray, ...], shape: tuple[int, ...], axis: int) -> float:
    """Sum of ``L^2`` over the maximal runs along ``axis`` of the ``cells`` (index arrays, as
    ``np.nonzero`` gives them) of a periodic grid of ``shape``: a run may wrap, a line all
    in ``cells`` is one run of its length. Sorts the cells alone (a boundary's faces are under
    1 % of a packing's grid), not the grid.

    >>> _run_square_sum(np.nonzero([[1, 1, 0, 1, 1, 1, 0, 1]]), (1, 8), 1)  # runs 3 (wrapped), 3
    18.0
    """
    if len(cells[0]) == 0:
        return 0.0
    n = shape[axis]
    pos = cells[axis]
    others = [c for k, c in enumerate(cells) if k != axis]
    line = np.ravel_multi_index(others, [s for k, s in enumerate(shape) if k != axis])
    order = np.argsort(line.astype(np.int64) * n + pos, kind="stable")
    line, pos = line[order], pos[order]
    start = np.ones(len(pos), bool)
    start[1:] = (line[1:] != line[:-1]) | (pos[1:] != pos[:-1] + 1)
    first = np.flatnonzero(start)
    length = np.diff(np.append(first, len(pos)))
    total = float(np.sum(length.astype(np.float64) ** 2))
    # a run ending at n - 1 and the one starting at 0 on its line are one (periodic):
    # (a + b)^2 = a^2 + b^2 + 2 a b; a line all in cells is already one run of n
    head = (pos[first] == 0) & (length < n)
    tail = (pos[first + length - 1] == n - 1) & (length < n)
    _, ia, ib = np.intersect1d(line[first[head]], line[first[tail]], return_indices=True)
    return total + 2.0 * float(np.sum(length[head][ia].astype(np.float64) * length[tail][ib]))


def porosity_text(porosity: float, error: float | None) -> str:
    """``"0.8123 +- 4.2e-04"`` (the value and its absolute error estimate) for the commands'
    text lines and the notebook's tables; without the bar where none is known.

    >>> porosity_text(0.81234, 0.00042)
    '0.8123 +- 4.2e-04'
    """
    bar = "" if error is None else f" +- {error:.1e}"
    return f"{porosity:.4f}{bar}"


#: Seeded uniform points at which :func:`sampled_porosity_bound` reads the union field (50 000:
#: 6 ms on a one-fibre RVE, a binomial standard error of at most 0.0022).
SAMPLED_POINTS = 50_000
SAMPLED_SEED = 2015
#: Standard errors of the sampled fraction added to it, and the voxel count's own error the
#: bound must also cover (a count at 3-10 voxels of fibre radius errs by up to 1-2 % of the
#: solid volume, module doc).
SAMPLED_SIGMAS = 4.0
COUNT_MARGIN = 0.02


def sampled_porosity_bound(rve) -> float:
    """An upper bound of the porosity an RVE of fibers will have once voxelized, from its
    analytic union field at :data:`SAMPLED_POINTS` seeded uniform points (no grid): the pore
    fraction plus :data:`SAMPLED_SIGMAS` binomial standard errors plus :data:`COUNT_MARGIN`,
    at most 1. What a memory check made before the voxel fields exist counts where one counted
    every cell as pore (porosity 1) and would refuse what the check on the built fields passes
    (:meth:`psdesign.schema.document.SpecDocument._planned_flow`).

    >>> import numpy as np
    >>> from psdesign.geometry.fibers import make_fiber
    >>> from psdesign.geometry.rve import RVE
    >>> rve = RVE(np.full(3, 20e-6), [make_fiber("cylinder", 0.5, direction=(0, 0, 1))])
    >>> bool(1 - np.pi / 16 < sampled_porosity_bound(rve) < 1 - np.pi / 16 + 0.04)
    True
    """
    size = np.asarray(rve.size, float)
    points = np.random.default_rng(SAMPLED_SEED).uniform(0.0, 1.0, (SAMPLED_POINTS, 3)) * size
    phi = float(np.count_nonzero(rve.union_field(points) > 0.0)) / SAMPLED_POINTS
    sigma = np.sqrt(max(phi * (1.0 - phi), 0.25 / SAMPLED_POINTS) / SAMPLED_POINTS)
    return float(min(1.0, phi + SAMPLED_SIGMAS * sigma + COUNT_MARGIN))
