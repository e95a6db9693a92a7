"""Start a command line whose imports take a while, answering a signal during them.

Importing a command line can take a second or more (NumPy, SciPy, torch). A Ctrl-C,
SIGTERM or SIGHUP in that time stops the program like one during a command -- one line,
exit code 128 + the signal number, no traceback -- since nothing has been done yet.
``python -m lab`` and ``python -m lab.course`` start through :func:`run_guarded`.
"""

import signal
import sys

__all__ = ["run_guarded"]


class _Stopped(KeyboardInterrupt):
    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _stop(signum, frame):
    raise _Stopped(signum)


def run_guarded(load) -> int:
    """Import a command line with ``load()`` and run what it returns.

    Parameters
    ----------
    load : callable
        Imports the command line and returns its ``main`` (a callable returning an exit code).

    Returns
    -------
    int
        ``main()``'s exit code, or 128 + the signal number when stopped while importing.
    """
    names = [s for s in ("SIGTERM", "SIGHUP") if hasattr(signal, s)]
    previous = {s: signal.signal(getattr(signal, s), _stop) for s in names}
    try:
        main = load()
    except KeyboardInterrupt as err:
        signum = getattr(err, "signum", signal.SIGINT)
        what = "(Ctrl-C)" if signum == signal.SIGINT else f"by {signal.Signals(signum).name}"
        print(f"interrupted {what} while starting; nothing was done", file=sys.stderr)
        return 128 + signum
    finally:
        for s, handler in previous.items():
            signal.signal(getattr(signal, s), handler)
    return main()
