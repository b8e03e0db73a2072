"""Exceptions raised by the mesher (all subclass :class:`ValueError`)."""

from __future__ import annotations

import re
from typing import NamedTuple

from psdesign.errors import SpecError

_FIRST_WORD = re.compile(r"[A-Za-z_]\w*")


class Remedy(NamedTuple):
    """What a mesher's refusal tells the user to change: the spec ``key`` that sets the
    mesh's resolution (the refusal's first word) and the ``advice`` with its allowed range."""

    key: str
    advice: str


class MeshInputError(SpecError):
    """An argument of the mesher is out of its allowed range: bad input, so a
    :class:`~psdesign.errors.SpecError` (``except psdesign.SpecError`` catches what
    ``psdesign.mesh_pore_space`` refuses; a plain ``ValueError`` until session 54) whose
    :attr:`key` names the argument.

    Parameters
    ----------
    message : str
        The one line, beginning with the argument's name (``"direction must be 'x', 'y' or
        'z', got 'w'"``), which is its :attr:`key` unless ``key`` is given.
    key : str, optional
        The argument's name when the line does not begin with it.
    """

    def __init__(self, message: str, key: str | None = None) -> None:
        word = _FIRST_WORD.match(message)
        key = key or (word.group(0) if word else "mesh")
        super().__init__(key, message)
        if message.startswith(key):  # the line names its key already: not "key: key ..."
            ValueError.__init__(self, message)


class PoreTopologyError(ValueError):
    """The pore space cannot carry a through-flow (blocked face, no inlet-outlet path)."""


class MeshFailedError(ValueError):
    """The tetrahedral mesh fails a consistency check (volume, pore fraction, inverted tets)."""
