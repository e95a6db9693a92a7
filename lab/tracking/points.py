"""The points a settled ``track`` run has measured, kept on disk as they come: ``OUT.points.csv``.

Each measured point is one fsynced CSV line, so a run that is interrupted or fails keeps
what it measured. The file belongs to the output ``OUT``: a rerun appends to it, so kept
points are never overwritten or lost, and it is removed only once ``OUT`` holds a complete
result. A file by that name that this program did not write (its first line is not the
header below) is refused before any work and never touched. Columns: ``i, target_x,
target_y, target_z`` (m), ``u0..u{m-1}`` (rad), ``x, y, z`` (m, achieved), ``settled``,
``wait_s``; ``i`` starts again at 0 for each run (and each closed-loop pass).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from lab.errors import InputError

__all__ = ["PointLog", "points_header"]


def points_header(n_motors: int) -> str:
    """The first line of a points file of a robot with ``n_motors`` motors."""
    cols = ["i", "target_x", "target_y", "target_z", *(f"u{j}" for j in range(n_motors)), "x", "y", "z"]
    return ",".join([*cols, "settled", "wait_s"])


class PointLog:
    """Append-only CSV of the measured points (module docstring). Made before any work: it
    reads what an earlier run kept (``n_kept``) and refuses (InputError) a file it did not
    write; the file is opened at the first :meth:`append`, so a run that fails before
    measuring anything leaves it as it was.

    Parameters
    ----------
    path : str or Path
        The points file, ``OUT.points.csv``.
    n_motors : int
        Motors m of the robot (the ``u`` columns).
    """

    def __init__(self, path: str | Path, n_motors: int):
        self.path = Path(path)
        self.header = points_header(n_motors)
        self.n_kept = self._kept()
        self.n_new = 0
        self._fh = None

    def _kept(self) -> int:
        """Points an earlier run kept here (0 without a file); InputError for a foreign file."""
        if not self.path.exists():
            return 0
        if not self.path.is_file():
            raise InputError(
                f"points file {self.path} exists and is not a file; move it away or choose another result file"
            )
        with open(self.path, "rb") as fh:
            first = fh.readline(len(self.header) + 2)
        if first.rstrip(b"\r\n") != self.header.encode():
            raise InputError(
                f"points file {self.path} exists and is not a points file this program wrote for this robot "
                f"(its first line is not {self.header!r}); nothing was changed: move it away or choose another "
                "result file"
            )
        return self.n_points

    def _open(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.path.exists():
            data = self.path.read_bytes()
            if not data.endswith(b"\n"):  # a line torn by a kill: not a point
                with open(self.path, "r+b") as fh:
                    fh.truncate(data.rfind(b"\n") + 1)
            self._fh = open(self.path, "a", newline="")
        else:
            self._fh = open(self.path, "w", newline="")
            self._write(self.header)

    def _write(self, line: str) -> None:
        self._fh.write(line + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def append(self, i: int, target_W, u_motor, sample) -> None:
        """One measured point, written and fsynced as one CSV line.

        Parameters
        ----------
        i : int
            The point's index in its run (or closed-loop pass).
        target_W : array_like
            The target, shape (3,), m, frame W.
        u_motor : array_like
            The command sent, shape (m,), rad.
        sample : Sample
            The capture protocol's reading (settled tip (3,) m, settled flag, times in s).
        """
        if self._fh is None:
            self._open()
        values = [*np.asarray(target_W, float), *np.asarray(u_motor, float), *np.asarray(sample.p_tip_W, float)]
        wait = sample.t_done_s - sample.t_command_s
        self._write(",".join([str(i), *(repr(float(v)) for v in values), str(int(sample.settled)), repr(wait)]))
        self.n_new += 1

    @property
    def n_points(self) -> int:
        """Points on disk (complete lines), whatever interrupted the writing."""
        if not self.path.is_file():
            return 0
        with open(self.path, "rb") as fh:
            return max(0, sum(1 for line in fh if line.endswith(b"\n")) - 1)

    def note(self) -> str | None:
        """What a stopped run says about the points on disk, or None when there are none.

        Returns
        -------
        str or None
            One line naming the file and how many points it holds.
        """
        if self.n_new:
            kept = f", after {self.n_kept} kept from an earlier run" if self.n_kept else ""
            return f"(the {self.n_new} points measured so far are in {self.path}{kept})"
        if self.n_kept:
            return f"(the {self.n_kept} points kept from an earlier run are still in {self.path})"
        return None

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def remove(self) -> None:
        """Close and delete the file: the result file holds a complete run now."""
        self.close()
        self.path.unlink(missing_ok=True)
