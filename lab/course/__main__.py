"""``python -m lab.course``: the course's housekeeping for the scripts (see :mod:`lab.course.commands`)."""

import sys

from lab.course.commands import main

sys.exit(main())
