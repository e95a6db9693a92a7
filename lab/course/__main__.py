"""``python -m lab.course``: the course's housekeeping for the scripts (see :mod:`lab.course.commands`).

Importing the commands takes a moment (NumPy); a Ctrl-C, SIGTERM or SIGHUP in that time
stops the program like one during a command -- one line, exit code 128 + the signal
number, no traceback -- since nothing has been done yet. (``lab.course`` itself imports
nothing heavy before this runs: its names are loaded on first use.)
"""

import sys

from lab.startup import run_guarded


def _load():
    from lab.course.commands import main

    return main


def run() -> int:
    """Import the commands and run one; returns the exit code."""
    return run_guarded(_load)


if __name__ == "__main__":
    sys.exit(run())
