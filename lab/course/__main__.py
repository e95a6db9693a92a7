"""``python -m lab.course``: the course's housekeeping for the scripts (see :mod:`lab.course.commands`).

Importing the commands takes a moment (NumPy); a Ctrl-C, SIGTERM or SIGHUP in that time
stops the program like one during a command -- one line, exit code 128 + the signal
number, no traceback -- since nothing has been done yet. (``lab.course`` itself imports
nothing heavy before this runs: its names are loaded on first use.)
"""

import signal
import sys


class _Stopped(KeyboardInterrupt):
    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _stop(signum, frame):
    raise _Stopped(signum)


def run() -> int:
    """Import the commands and run one; returns the exit code."""
    names = [s for s in ("SIGTERM", "SIGHUP") if hasattr(signal, s)]
    previous = {s: signal.signal(getattr(signal, s), _stop) for s in names}
    try:
        from lab.course.commands import main
    except KeyboardInterrupt as err:
        signum = getattr(err, "signum", signal.SIGINT)
        what = "(Ctrl-C)" if signum == signal.SIGINT else f"by {signal.Signals(signum).name}"
        print(f"interrupted {what} while starting; nothing was done", file=sys.stderr)
        return 128 + signum
    finally:
        for s, handler in previous.items():
            signal.signal(getattr(signal, s), handler)
    return main()


if __name__ == "__main__":
    sys.exit(run())
