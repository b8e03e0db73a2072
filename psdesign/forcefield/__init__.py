"""Empirical force field for fiber bending and contact (paper Sec. 6).

Modules: :mod:`.fields` (PS fields, analytic derivatives), :mod:`.potentials` (I^V, I^S,
S and U; marching-cubes quadrature), :mod:`.tube` (high-order tube quadrature and the
Gauss-Bonnet end formula), :mod:`.pattern` (bounded pattern search), :mod:`.params`
(equality constraints as a parametrization), :mod:`.cases` (the paper's two examples),
:mod:`.run` / :mod:`.cli` (``psdesign forcefield``), :mod:`.render` (pictures).
"""

from psdesign.forcefield.cases import ForceFieldProblem, six_fiber_problem, two_fiber_problem
from psdesign.forcefield.pattern import PatternSearchResult, pattern_search
from psdesign.forcefield.potentials import Potentials, total_potential

__all__ = [
    "ForceFieldProblem",
    "PatternSearchResult",
    "Potentials",
    "pattern_search",
    "six_fiber_problem",
    "total_potential",
    "two_fiber_problem",
]
