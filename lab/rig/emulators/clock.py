"""A clock for the hardware emulators that moves only when a motion-capture frame is wanted.

On the wall clock, where an emulated spool is, how far the foam has crept and whether a Bus
Watchdog fires all depend on how the operating system schedules the test's threads.
``VirtualClock`` takes the wall clock's place: the NatNet server emulator advances it by one
frame period for each frame a reader asks for (``want_frame``, which ``HardwareRig`` calls
before it waits for a frame), and the servo bus, the body, the rig and the servo driver all
read it. A run is then the same sequence of states on an idle or a loaded machine, as on the
``twin`` rig; only the timeouts that detect a dead peer stay on the wall clock. How the
tests use it: ``docs/design/hardware-tests.md``.
"""

from __future__ import annotations

import threading

__all__ = ["VirtualClock"]


class VirtualClock:
    """Seconds since construction, moved by ``advance`` only; callable like ``time.monotonic``.

    A reader that is about to wait for a frame calls ``want_frame``; the frame source takes
    the wish with ``take_wish`` and then advances the clock by one frame period.
    """

    def __init__(self):
        self._t_s = 0.0
        self._wished = False
        self._cond = threading.Condition()

    def now(self) -> float:
        """The current time.

        Returns
        -------
        float
            Seconds since construction (virtual).
        """
        with self._cond:
            return self._t_s

    __call__ = now

    def advance(self, dt_s: float) -> float:
        """Move the clock on (by a frame period, or a quiet spell a test makes).

        Parameters
        ----------
        dt_s : float
            The step (s), >= 0.

        Returns
        -------
        float
            The new time (s).
        """
        if not dt_s >= 0:
            raise ValueError(f"a clock only moves forward, got dt_s = {dt_s}")
        with self._cond:
            self._t_s += float(dt_s)
            return self._t_s

    def want_frame(self) -> None:
        """A reader waits for the next frame (wishes made before it is sent count once)."""
        with self._cond:
            self._wished = True
            self._cond.notify_all()

    def take_wish(self, timeout_s: float) -> bool:
        """Wait for a wished frame.

        Parameters
        ----------
        timeout_s : float
            How long to wait (s, wall clock).

        Returns
        -------
        bool
            True (and the wish is taken) if a frame was wished, False on timeout.
        """
        with self._cond:
            if not self._cond.wait_for(lambda: self._wished, timeout_s):
                return False
            self._wished = False
            return True
