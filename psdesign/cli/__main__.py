"""``python -m psdesign.cli``: the ``psdesign`` command, as ``python -m psdesign``."""

from psdesign.cli.main import console

console()
