"""Settings of the ``ga`` intersection removal: the adjustment ranges and the GA's own knobs."""

from __future__ import annotations

from dataclasses import dataclass

#: The paper's GA adjustment ranges (Sec. 7.1): translations +-0.1 of the RVE edge and rotations
#: +-1 degree; also the default move bounds of the ``fast`` placement
#: (:func:`psdesign.packing.generators._fast_options`).
PAPER_MAX_SHIFT = 0.1
PAPER_MAX_ROTATION_DEG = 1.0
#: The GA's voxel objective grid without ``intersections.ga_voxel``: this many RVE voxels a step.
GA_VOXEL_RVE_VOXELS = 4


@dataclass(frozen=True)
class GASettings:
    """What :func:`psdesign.packing.genetic.genetic` searches and how (paper Sec. 7.1, Eq. 9).

    Attributes
    ----------
    angle_range_deg : float
        theta and omega adjustments in ``+-angle_range_deg`` (degrees).
    shift_range : float
        Translation adjustments in ``+-shift_range`` of the RVE edge.
    u_range, f_range : tuple of float
        Absolute ``u`` and ``f`` of bent fibers (amplitude, frequency).
    population, generations : int
        Individuals per generation and generations at most.
    mutation_sigma : float
        Standard deviation of the Gaussian mutation of a gene (genes in [-1, 1]).
    objective : {"analytic", "voxel"}
        Omega from :func:`.genetic.analytic_omega`, or the voxel count of Eq. (8) on a grid of
        step ``voxel`` (normalized; needed for ``"voxel"``).
    voxel : float, optional
    time_limit_s : float, optional
        Wall time after which no further generation starts (seconds).

    Examples
    --------
    >>> s = GASettings(population=10, generations=5)
    >>> (s.population, s.generations, s.angle_range_deg, s.objective)
    (10, 5, 1.0, 'analytic')
    """

    angle_range_deg: float = PAPER_MAX_ROTATION_DEG
    shift_range: float = PAPER_MAX_SHIFT
    u_range: tuple[float, float] = (0.1, 0.3)
    f_range: tuple[float, float] = (1.0, 10.0)
    population: int = 24
    generations: int = 40
    mutation_sigma: float = 0.15
    objective: str = "analytic"
    voxel: float | None = None
    time_limit_s: float | None = None
