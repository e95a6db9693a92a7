"""How long a long command will take: one estimate line after its first unit of work, and a bar.

``train`` (epochs), ``splits`` (splits), ``compare`` (fits), ``calibrate`` (iterations)
and ``inspect`` (resamples) hand a :class:`Progress` the units done and the units in all as
they go (``progress.update(done, total)``). After the first unit it writes one line to
stderr -- "estimate: about 7 min in all (first epoch 0.6 s x 800 epochs)", divided by the
workers that run units side by side -- and draws a ``tqdm`` bar there unless
``--no-progress`` (:func:`add_progress_flag`) asked for none; the estimate line is written
either way, as a log reads it. The total is an upper bound where the work may stop early
(a training's validation stop, a calibration's convergence): the line says so.
The clock is injectable, so a test controls it.
"""

from __future__ import annotations

import math
import sys
import time

__all__ = ["Progress", "add_progress_flag", "duration_words"]


def add_progress_flag(parser) -> None:
    """Add ``--no-progress`` (no bar; the estimate line stays) to a command's parser.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    parser.add_argument(
        "--no-progress", action="store_true", help="no progress bar on stderr (the one-line time estimate stays)"
    )


def duration_words(seconds: float) -> str:
    """A duration as a person reads it: "40 s", "7 min", "2.5 h".

    Parameters
    ----------
    seconds : float
        The duration, s.

    Returns
    -------
    str
        The words.
    """
    if seconds < 90:
        return f"{seconds:.2g} s" if seconds < 10 else f"{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


class Progress:
    """The estimate line and the bar of one long command (see the module docstring).

    Parameters
    ----------
    unit : str
        What one unit of work is, singular ("epoch", "split", "fit", "iteration").
    enabled : bool
        Draw the bar (False: ``--no-progress``; the estimate line is written anyway).
    parallel : int
        Units run side by side (workers), >= 1.
    at_most : bool
        The total is an upper bound (the work may stop early).
    file : file object, optional
        Where the line and the bar go (default stderr).
    clock : callable, optional
        Seconds now (default ``time.perf_counter``).
    """

    def __init__(self, unit: str, *, enabled: bool = True, parallel: int = 1, at_most: bool = False, file=None,
                 clock=time.perf_counter):  # fmt: skip
        self.unit, self.enabled, self.parallel, self.at_most = unit, enabled, max(1, int(parallel)), at_most
        self.file = file if file is not None else sys.stderr
        self.clock = clock
        self.t0 = clock()
        self.bar = None
        self.estimate_s: float | None = None

    def start(self) -> None:
        """Start the clock of the first unit now (call it as the work begins)."""
        self.t0 = self.clock()

    def update(self, done: int, total: int) -> None:
        """``done`` of ``total`` units are finished; 0 restarts the clock of the first unit.

        Parameters
        ----------
        done : int
            Units finished, 0 .. ``total``.
        total : int
            Units in all (an upper bound with ``at_most``).
        """
        if done <= 0:
            self.start()
            return
        if self.estimate_s is None:
            first = max(self.clock() - self.t0, 0.0) / done
            rounds = math.ceil(total / self.parallel)
            self.estimate_s = first * rounds
            workers = f" / {self.parallel} workers" if self.parallel > 1 and total > 1 else ""
            self.write(
                f"estimate: about {duration_words(self.estimate_s)} in all"
                + (", less if it stops early" if self.at_most else "")
                + f" (first {self.unit} {duration_words(first)} x {total} {self.unit}s{workers})"
            )
            if self.enabled:
                from tqdm import tqdm

                self.bar = tqdm(total=total, unit=self.unit, file=self.file, smoothing=0.1, leave=False)
        if self.bar is not None:
            self.bar.total = total
            self.bar.update(max(0, done - self.bar.n))

    def write(self, line: str) -> None:
        """Write a line to the progress file without breaking the bar.

        Parameters
        ----------
        line : str
            The line, without its newline.
        """
        if self.bar is not None:
            self.bar.write(line, file=self.file)
        else:
            print(line, file=self.file)

    def close(self) -> None:
        """Remove the bar (the work ended, early or not)."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
