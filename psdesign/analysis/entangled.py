"""Which design parameters moved together over a study's cases: the one rule the sensitivity
indices, the regression coefficients, the response surface and the interaction plot follow.

Two parameters whose values over the cases correlate (Pearson) beyond
:data:`MAX_INPUT_CORRELATION` are linked; a group is a connected set of linked parameters
(:func:`entangled_groups`: with c = 3 a and b free, {a, c} is one group even when only a and b
are drawn). The cases cannot tell the effects of a group's members apart, and a figure that
moves one member while holding another fixed shows designs the study never had (a csv study
with c = 3 a: the surface over a and b with c held at mid-range was up to 78 % off the cases'
truth, 1.0 % with c tied to a as in the cases).
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

#: Correlation (Pearson, of the parameters' values over the cases) of two parameters above
#: which the cases cannot tell their effects apart.
MAX_INPUT_CORRELATION = 0.99


def _links(x: np.ndarray, n: int) -> dict[tuple[int, int], float]:
    """The correlation of every pair of columns of ``x`` above the threshold."""
    out = {}
    for i, j in combinations(range(n), 2):
        r = float(np.corrcoef(x[:, i], x[:, j])[0, 1])
        if abs(r) > MAX_INPUT_CORRELATION:
            out[(i, j)] = r
    return out


def _components(links: dict[tuple[int, int], float], n: int) -> list[list[int]]:
    """Connected components (two or more members, each sorted) of the graph of ``links``."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rows, cols = zip(*links, strict=True) if links else ((), ())
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    groups = [np.flatnonzero(label == c).tolist() for c in np.unique(label)]
    return sorted((g for g in groups if len(g) > 1), key=lambda g: g[0])


def entangled_groups(x: np.ndarray, names: list[str]) -> list[list[str]]:
    """The groups of parameters (columns of ``x``, cases x parameters, named ``names``) that
    moved together: connected by correlations above :data:`MAX_INPUT_CORRELATION`, two or
    more members each, in the order of ``names``.

    >>> x = np.array([[1.0, 5.0, 3.0], [2.0, 4.0, 6.0], [3.0, 6.0, 9.0], [4.0, 5.0, 12.0]])
    >>> entangled_groups(x, ["a", "b", "c"])
    [['a', 'c']]
    """
    x = np.asarray(x, dtype=float)
    return [[names[i] for i in g] for g in _components(_links(x, len(names)), len(names))]


def _say(names: list[str], rs: list[float]) -> str:
    who = " and ".join(names) if len(names) == 2 else ", ".join(names[:-1]) + f" and {names[-1]}"
    if len(rs) == 1:
        corr = f"correlation {rs[0]:.3f}"
    else:
        a = sorted(abs(r) for r in rs)
        corr = f"correlations {a[0]:.3f} to {a[-1]:.3f}"
    return (
        f"{who} moved together over the cases ({corr}): the cases cannot tell their effects "
        "apart; vary them independently (e.g. a latin-hypercube design)"
    )


def entangled(x: np.ndarray, names: list[str], axes: list[str] | None = None) -> str:
    """``"a and b moved together ..."`` for the first group (:func:`entangled_groups`) that
    holds two or more of ``axes`` (any group when ``axes`` is None), or ``""``: a figure over
    ``axes`` would spread out cases that lie on one line (and no index or regression
    coefficient can split their effects).

    >>> entangled(np.array([[1.0, 2.0], [2.0, 4.0], [3.0, 6.1]]), ["a", "b"])[:43]
    'a and b moved together over the cases (corr'
    >>> x = np.array([[1.0, 5.0, 3.0], [2.0, 4.0, 6.0], [3.0, 6.0, 9.0], [4.0, 5.0, 12.0]])
    >>> entangled(x, ["a", "b", "c"], axes=["a", "b"])
    ''
    """
    x = np.asarray(x, dtype=float)
    links = _links(x, len(names))
    for g in _components(links, len(names)):
        if axes is None or sum(names[i] in axes for i in g) >= 2:
            rs = [r for (i, j), r in links.items() if i in g and j in g]
            return _say([names[i] for i in g], rs)
    return ""


def tied_to_axes(x: np.ndarray, names: list[str], axes: list[str]) -> dict[str, tuple]:
    """How to hold the parameters not on a figure's ``axes`` as the cases had them: for each
    member of a group (:func:`entangled_groups`) with one member on ``axes``, or of a group
    with none (then tied to its first member, held where the figure holds it),
    ``{name: (anchor, slope, intercept)}`` of the least-squares line ``x[name] = intercept +
    slope * x[anchor]`` over the cases. A parameter in no group is free: not in the dict. A
    group with two members on ``axes`` is :func:`entangled`'s to refuse.

    >>> x = np.array([[1.0, 5.0, 4.0], [2.0, 4.0, 7.0], [3.0, 6.0, 10.0], [4.0, 5.0, 13.0]])
    >>> {k: (a, round(m, 6), round(c, 6)) for k, (a, m, c) in tied_to_axes(x, ["a", "b", "c"],
    ...     ["a", "b"]).items()}
    {'c': ('a', 3.0, 1.0)}
    """
    x = np.asarray(x, dtype=float)
    out: dict[str, tuple] = {}
    for g in entangled_groups(x, names):
        on = [p for p in g if p in axes]
        if len(on) > 1:
            continue
        anchor = on[0] if on else g[0]
        xa = x[:, names.index(anchor)]
        for p in g:
            if p != anchor:
                slope, icpt = np.polyfit(xa, x[:, names.index(p)], 1)
                out[p] = (anchor, float(slope), float(icpt))
    return out


def tied_note(ties: dict[str, tuple], held: str = "at mid-range") -> str:
    """One sentence for a figure's reader: which parameters follow which (``""`` if none).

    >>> tied_note({"c": ("a", 3.0, 0.0)})[:66]
    'c follows a as in the cases (they moved together), not held at mid'
    """
    if not ties:
        return ""
    pairs = [f"{p} follows {a}" for p, (a, _, _) in ties.items()]
    apart = ", ".join(f"{p} apart from {a}" for p, (a, _, _) in ties.items())
    return (
        f"{'; '.join(pairs)} as in the cases (they moved together), not held {held}: "
        f"the cases never had {apart}."
    )
