"""Exceptions raised by the mesher (all subclass :class:`ValueError`)."""

from __future__ import annotations


class MeshInputError(ValueError):
    """An argument of the mesher is out of its allowed range."""


class PoreTopologyError(ValueError):
    """The pore space cannot carry a through-flow (blocked face, no inlet-outlet path)."""


class MeshFailedError(ValueError):
    """The tetrahedral mesh fails a consistency check (volume, pore fraction, inverted tets)."""
