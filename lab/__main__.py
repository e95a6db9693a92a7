"""``python -m lab <command>`` and the ``lab`` console script: see ``python -m lab --help``.

Importing the commands takes a second or more (NumPy, SciPy, torch). A Ctrl-C, SIGTERM or
SIGHUP in that time stops the program like one during a command -- one line, exit code
128 + the signal number, no traceback -- since nothing has been done yet.
"""

import sys

from lab.startup import run_guarded


def _load():
    from lab.cli import main

    return main


def run() -> int:
    """Import the command line and run it; returns the exit code."""
    return run_guarded(_load)


if __name__ == "__main__":
    sys.exit(run())
