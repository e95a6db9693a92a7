"""``python -m lab <command>``: see ``python -m lab --help``."""
import sys

from .cli import main

sys.exit(main())
