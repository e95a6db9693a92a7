"""Epochs trained on worker processes, told to this process as they go.

An ensemble's members train on joblib workers (:func:`lab.learn.ensemble.train_ensemble`);
a worker's trainer calls its progress once per epoch, but in another process. Each job gets
a :class:`EpochReporter` (picklable: a file name and a slot) that writes its epoch into one
slot of a small memory-mapped file; :class:`EpochCounters`, in this process, reads the
slots a few times a second and calls ``progress(done, total)`` with the epochs done by all
jobs together -- throughput, so an estimate from it needs no division by the workers. The
clock of the first unit restarts (``progress(0, total)``) when the first worker reports,
so worker start-up does not count as training time. No process and no lock are shared;
the file is deleted on exit.
"""

from __future__ import annotations

import os
import tempfile
import threading

import numpy as np

__all__ = ["EpochCounters", "EpochReporter"]


class EpochReporter:
    """In a worker: ``reporter(epoch, row)`` writes ``epoch`` into its slot (an
    :class:`lab.learn.train.EpochProgress`).

    Parameters
    ----------
    path : str
        The counters' file.
    slot : int
        This job's slot.
    """

    def __init__(self, path: str, slot: int):
        self.path, self.slot, self._counts = path, int(slot), None

    def __getstate__(self):
        return {"path": self.path, "slot": self.slot, "_counts": None}

    def __call__(self, epoch: int, row: tuple) -> None:
        """Epoch ``epoch`` of this job is done.

        Parameters
        ----------
        epoch : int
            Epochs done.
        row : tuple
            The trainer's history row (not used).
        """
        if self._counts is None:
            self._counts = np.memmap(self.path, dtype=np.int64, mode="r+")
        self._counts[self.slot] = int(epoch)


class EpochCounters:
    """In this process: one counter per job, polled into ``progress(done, total)``.

    Parameters
    ----------
    limits : sequence of int
        Each job's most epochs; ``total`` is their sum.
    progress : callable
        ``progress(done, total)``.
    interval_s : float
        How often the counters are read, s.
    """

    def __init__(self, limits, progress, interval_s: float = 0.1):
        self.limits = [int(n) for n in limits]
        self.progress, self.interval_s = progress, interval_s
        fd, self.path = tempfile.mkstemp(prefix="lab-epochs-", suffix=".bin")
        with os.fdopen(fd, "wb") as fh:
            fh.write(np.full(len(self.limits), -1, dtype=np.int64).tobytes())  # -1: not started
        self._counts = np.memmap(self.path, dtype=np.int64, mode="r+")
        self._finished = [False] * len(self.limits)
        self._lock, self._stop = threading.Lock(), threading.Event()
        self._offset = None  # epochs done when the first worker reported
        self._thread = threading.Thread(target=self._poll, name="lab-epoch-counters", daemon=True)

    def reporter(self, slot: int) -> EpochReporter:
        """The progress callable for job ``slot``.

        Parameters
        ----------
        slot : int
            The job.

        Returns
        -------
        EpochReporter
            Picklable; writes into this file.
        """
        return EpochReporter(self.path, slot)

    def finished(self, slot: int) -> None:
        """Job ``slot`` is done: it counts its whole limit.

        Parameters
        ----------
        slot : int
            The job.
        """
        with self._lock:
            self._finished[slot] = True
            self._tell()

    def _done(self) -> int:
        counts = np.asarray(self._counts).copy()
        return int(sum(n if f else min(max(int(c), 0), n) for c, n, f in zip(counts, self.limits, self._finished)))

    def _tell(self) -> None:
        total = sum(self.limits)
        if self._offset is None:
            if not (np.any(np.asarray(self._counts) >= 0) or any(self._finished)):
                return
            self._offset = self._done()
            self.progress(0, total)  # the clock starts with the first worker's training
            return
        done = total if all(self._finished) else max(self._done() - self._offset, 0)
        self.progress(done, total)

    def _poll(self) -> None:
        while not self._stop.wait(self.interval_s):
            with self._lock:
                self._tell()

    def __enter__(self) -> EpochCounters:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()
        del self._counts
        try:
            os.unlink(self.path)
        except OSError:
            pass
