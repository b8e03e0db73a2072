"""``python -m psdesign.cli``."""

import sys

from psdesign.cli.main import main

sys.exit(main())
