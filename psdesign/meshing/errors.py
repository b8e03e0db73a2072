"""Exceptions raised by the mesher (all subclass :class:`ValueError`)."""

from __future__ import annotations

from typing import NamedTuple


class Remedy(NamedTuple):
    """What a mesher's refusal tells the user to change: the spec ``key`` that sets the
    mesh's resolution (the refusal's first word) and the ``advice`` with its allowed range."""

    key: str
    advice: str


class MeshInputError(ValueError):
    """An argument of the mesher is out of its allowed range."""


class PoreTopologyError(ValueError):
    """The pore space cannot carry a through-flow (blocked face, no inlet-outlet path)."""


class MeshFailedError(ValueError):
    """The tetrahedral mesh fails a consistency check (volume, pore fraction, inverted tets)."""
