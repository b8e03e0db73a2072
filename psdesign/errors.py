"""Error types shared by all stages."""

from __future__ import annotations


class SpecError(ValueError):
    """A bad value in a spec or study file.

    Parameters
    ----------
    key : str
        Dotted path of the offending key, e.g. ``"fibers[2].diameter"``.
    message : str
        What is wrong and what is allowed.
    """

    def __init__(self, key: str, message: str) -> None:
        self.key = key
        self.message = message
        super().__init__(f"{key}: {message}")
