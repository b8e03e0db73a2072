"""Settings of a compass pattern search: its mesh sizes and factors, and its limits."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SearchSettings:
    """How :func:`psdesign.forcefield.pattern.pattern_search` moves and when it stops.

    Attributes
    ----------
    step : float
        Initial mesh size as a fraction of each variable's range.
    min_step : float
        Convergence: stop when the mesh size falls below this fraction.
    max_step : float
        Cap on the mesh size after expansions.
    expand, contract : float
        Mesh factors after a successful / failed poll (>= 1 and in (0, 1)).
    max_iter : int
        Iteration (poll) limit; hitting it returns the best point with ``converged=False``.
    max_evals : int, optional
        Limit on objective evaluations, handled like ``max_iter``.

    Raises
    ------
    ValueError
        Unless ``0 < min_step < step <= max_step``, ``expand >= 1``, ``0 < contract < 1``
        and the limits are >= 1.

    Examples
    --------
    >>> s = SearchSettings(min_step=1e-6, max_iter=5000)
    >>> (s.step, s.min_step, s.max_iter, s.max_evals)
    (0.25, 1e-06, 5000, None)
    >>> SearchSettings(step=0.1, min_step=0.2)
    Traceback (most recent call last):
    ...
    ValueError: need 0 < min_step < step <= max_step, got 0.2, 0.1, 0.5
    """

    step: float = 0.25
    min_step: float = 1e-4
    max_step: float = 0.5
    expand: float = 2.0
    contract: float = 0.5
    max_iter: int = 500
    max_evals: int | None = None

    def __post_init__(self) -> None:
        step, min_step, max_step = self.step, self.min_step, self.max_step
        if not (0 < min_step < step <= max_step):
            raise ValueError(
                f"need 0 < min_step < step <= max_step, got {min_step}, {step}, {max_step}"
            )
        if not (self.expand >= 1.0 and 0.0 < self.contract < 1.0):
            raise ValueError(
                f"expand must be >= 1 and contract in (0, 1), got {self.expand}, {self.contract}"
            )
        if self.max_iter < 1 or (self.max_evals is not None and self.max_evals < 1):
            raise ValueError("max_iter and max_evals must be >= 1")


#: The relax routes' search (:func:`.relax.relax_fibers`, :func:`.contact.relax_contacts`):
#: ``[forcefield.relax]``'s defaults of ``min_step``, ``max_iter`` and ``max_evals``.
RELAX_SEARCH = SearchSettings(min_step=1e-3, max_iter=200, max_evals=4000)
