"""``python -m psdesign``: the ``psdesign`` command."""

import sys

from psdesign.cli.main import main

sys.exit(main())
