"""SIGTERM and SIGHUP handled like Ctrl-C, so every command cleans up the same way.

A scheduler or ``systemd`` stops a process with SIGTERM; closing its terminal sends
SIGHUP. Inside :func:`interrupts_as_keyboard`, both raise :class:`Terminated` -- a
``KeyboardInterrupt`` -- in the main thread, so the code that already handles Ctrl-C
runs for them too: rigs close (torque off), journals are flushed, worker processes are
stopped. ``lab.cli.main`` then exits with ``128 + signal number`` (130 for Ctrl-C,
143 for SIGTERM, 129 for SIGHUP) and a one-line message.
"""

from __future__ import annotations

import contextlib
import signal
import threading

__all__ = ["Terminated", "interrupts_as_keyboard", "exit_code"]

SIGNALS = tuple(s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if s is not None)


class Terminated(KeyboardInterrupt):
    """The process was asked to stop by a signal (``signum``)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _raise(signum, frame):
    raise Terminated(signum)


@contextlib.contextmanager
def interrupts_as_keyboard():
    """Within the block, SIGTERM and SIGHUP raise :class:`Terminated` (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _raise) for s in SIGNALS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def exit_code(err: KeyboardInterrupt) -> int:
    """128 + the signal number: 130 for Ctrl-C (SIGINT), 143 for SIGTERM, 129 for SIGHUP."""
    return 128 + getattr(err, "signum", signal.SIGINT)
