"""``python -m psdesign``: the ``psdesign`` command."""

from psdesign.cli.main import console

console()
