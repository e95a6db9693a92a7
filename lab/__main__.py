"""``python -m lab <command>``: see ``python -m lab --help``."""

import sys

from lab.cli import main

sys.exit(main())
