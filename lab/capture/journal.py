"""An append-only, resumable CSV journal: one fsynced line per record.

A journal is plain CSV with ``#`` lines: a header line (``# lab.journal 1 {JSON}``: what it
is a record of), the column names, then records, with ``# session`` and ``# session-end``
lines around each appending run. Each record is written, flushed and fsynced before the
next starts, so killing the writer loses at most that line; such a torn last line is cut
off on reopening, any other malformed line is an error. Reopening refuses a journal made
with different settings, naming the fields that differ, and an exclusive lock
(``JOURNAL.lock``, removed on closing) stops two processes appending at once. Layout:
``docs/design/rig.md``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
from filelock import FileLock, Timeout

from lab.errors import InputError
from lab.files import atomic_write_text, remove_and_release

MAGIC = "# lab.journal 1 "


def lock_path(journal_path: str | Path) -> Path:
    """The lock file of a journal: ``JOURNAL.lock`` beside it, while the journal is open."""
    return Path(f"{journal_path}.lock")


class JournalError(InputError):
    """A journal is corrupt, locked, or was started with different settings."""


def _diff(old, new, prefix="") -> list[str]:
    """Dotted names of the fields that differ between two JSON-like dicts."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in sorted(set(old) | set(new), key=str):
            out += _diff(old.get(k), new.get(k), f"{prefix}{k}.")
        return out
    return [] if old == new else [f"{prefix[:-1]}: journal {old!r}, now {new!r}"]


def _format(value) -> str:
    """Integers (and bools) as integers, everything else as the shortest exact float."""
    if isinstance(value, (bool, np.bool_, int, np.integer)):
        return str(int(value))
    return repr(float(value))


class Journal:
    """Append-only record file; use :meth:`open`. ``rows`` holds the records (dicts of
    floats), ``notes`` the ``# tag {json}`` lines as (tag, dict), old and new.

    Parameters
    ----------
    path : Path
        The journal file.
    fh : file
        The file, open for reading and appending, positioned at its end.
    columns : list of str
        The record columns.
    rows : list of dict
        The records read so far, column -> float.
    notes : list of tuple
        The notes read so far, (tag, dict).
    """

    def __init__(self, path: Path, fh, columns: list[str], rows: list[dict], notes: list[tuple[str, dict]]):
        self.path, self._fh, self.columns, self.rows, self.notes = path, fh, columns, rows, notes

    def notes_tagged(self, tag: str) -> list[dict]:
        """The notes with one tag.

        Parameters
        ----------
        tag : str
            The note's tag, e.g. ``session``.

        Returns
        -------
        list of dict
            Their JSON payloads, oldest first.
        """
        return [info for t, info in self.notes if t == tag]

    @classmethod
    def open(cls, path: str | Path, header: dict, columns: list[str]) -> Journal:
        """Open (or create) the journal at ``path`` for appending records with ``columns``.

        Raises :class:`JournalError` if another process holds it, if its header differs
        from ``header`` (JSON-able) or its columns from ``columns``, or if a line is corrupt.

        Parameters
        ----------
        path : str or Path
            The journal file (CSV); its lock is ``path.lock`` while it is open.
        header : dict
            JSON-able settings the journal is a record of; a reopened journal must match.
        columns : list of str
            The record columns; a reopened journal must have the same.

        Returns
        -------
        Journal
            The open journal, with the records and notes already in it (a torn last line
            cut off), locked until :meth:`close`.
        """
        path = Path(path)
        header = json.loads(json.dumps(header))  # normalise (tuples -> lists)
        if not path.exists():
            atomic_write_text(path, MAGIC + json.dumps(header, sort_keys=True) + "\n" + ",".join(columns) + "\n")
        # a portable lock file beside the journal (filelock; fcntl does not exist on Windows)
        lock = FileLock(lock_path(path), timeout=0)
        try:
            lock.acquire()
        except Timeout:
            raise JournalError(f"{path} is being written by another process") from None
        try:
            fh = open(path, "r+", newline="")
        except BaseException:
            remove_and_release(lock)
            raise
        try:
            rows, notes = cls._read(path, fh, header, columns)
        except BaseException:
            fh.close()
            remove_and_release(lock)
            raise
        fh.seek(0, os.SEEK_END)
        journal = cls(path, fh, list(columns), rows, notes)
        journal._lock = lock
        return journal

    @staticmethod
    def _read(path: Path, fh, header: dict, columns: list[str]) -> tuple[list[dict], list]:
        text = fh.read()
        if not text.endswith("\n"):  # torn last line: cut it off
            cut = text.rfind("\n") + 1
            fh.truncate(cut)
            fh.flush()
            os.fsync(fh.fileno())
            text = text[:cut]
        lines = text.split("\n")[:-1]
        if len(lines) < 2 or not lines[0].startswith(MAGIC):
            raise JournalError(f"{path}: not a lab journal (first line must start with {MAGIC.strip()!r})")
        try:
            old = json.loads(lines[0][len(MAGIC) :])
        except json.JSONDecodeError as err:
            raise JournalError(f"{path}: corrupt header: {err}") from None
        if old != header:
            raise JournalError(
                f"{path} was started with different settings: "
                + "; ".join(_diff(old, header))
                + ". Continue it with the same settings, or write to another file."
            )
        if lines[1].split(",") != list(columns):
            raise JournalError(f"{path}: columns are {lines[1]!r}, expected {','.join(columns)!r}")
        rows, notes = [], []
        for n, line in enumerate(lines[2:], start=3):
            if line.startswith("#"):
                tag, _, info = line[1:].strip().partition(" ")
                try:
                    notes.append((tag, json.loads(info)))
                except json.JSONDecodeError:
                    raise JournalError(f"{path}: line {n} is a corrupt note: {line[:80]!r}") from None
                continue
            if not line:
                continue
            fields = line.split(",")
            try:
                if len(fields) != len(columns):
                    raise ValueError
                rows.append({c: float(v) for c, v in zip(columns, fields)})
            except ValueError:
                raise JournalError(f"{path}: line {n} is corrupt: {line[:80]!r}") from None
        return rows, notes

    def _write(self, line: str) -> None:
        self._fh.write(line + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def note(self, tag: str, info: dict) -> None:
        """Append a ``# tag {json}`` comment line (e.g. ``session``, ``session-end``).

        Parameters
        ----------
        tag : str
            One word.
        info : dict
            The payload, written as JSON (``str`` of what JSON cannot hold).
        """
        if not tag or " " in tag:
            raise InputError(f"a note tag is one word, got {tag!r}")
        text = json.dumps(info, sort_keys=True, default=str)
        self._write(f"# {tag} " + text)
        self.notes.append((tag, json.loads(text)))

    def append(self, row: dict) -> None:
        """Append one record and make it durable (written, flushed and fsynced).

        Parameters
        ----------
        row : dict
            Column -> number, a value for every column (extra keys are ignored).
        """
        missing = [c for c in self.columns if c not in row]
        if missing:
            raise InputError(f"journal record lacks columns {missing}")
        self._write(",".join(_format(row[c]) for c in self.columns))
        self.rows.append({c: float(row[c]) for c in self.columns})

    def close(self) -> None:
        """Close the file and release the lock (removing the lock file). Idempotent."""
        if not self._fh.closed:
            self._fh.close()
        lock = getattr(self, "_lock", None)
        if lock is not None and lock.is_locked:
            remove_and_release(lock)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def journal_columns(n_motors: int, predictive: bool = False, markers=("tip",)) -> list[str]:
    """The journal's columns; the predictive protocol adds ``pred_std_m`` (3-D std of the
    predicted tip, m; NaN when waited for) and ``predicted`` (1: recorded from the prediction).

    Parameters
    ----------
    n_motors : int
        Number of motors m: columns ``u0..u{m-1}`` and ``present_u0..``.
    predictive : bool
        Whether the journal is of the predictive protocol.
    markers : sequence of str
        The robot's observed points, the tip first: ``NAME_x, NAME_y, NAME_z`` follow the
        tip's columns for every further one (none for a robot observed at its tip alone).

    Returns
    -------
    list of str
        ``index``, the inputs (rad or N), the tip ``x``, ``y``, ``z`` (m, frame W), the other
        markers' columns (m), the settle statistics and times (s), the present inputs,
        ``session`` and, for the predictive protocol, its two columns.
    """
    u = [f"u{i}" for i in range(n_motors)]
    return (
        [
            "index",
            *u,
            "x",
            "y",
            "z",
            *marker_columns(markers),
            "settled",
            "t_start_s",
            "t_command_s",
            "t_arrived_s",
            "t_done_s",
            "n_readings",
            "deviation_m",
            "n_frames",
            "n_invalid_frames",
        ]
        + [f"present_{c}" for c in u]
        + ["session"]
        + (["pred_std_m", "predicted"] if predictive else [])
    )


def marker_columns(markers) -> list[str]:
    """The columns of every marker but the tip: ``NAME_x, NAME_y, NAME_z`` in order.

    Parameters
    ----------
    markers : sequence of str
        The observed points, the tip first.

    Returns
    -------
    list of str
        3(K-1) column names.
    """
    return [f"{name}_{a}" for name in list(markers)[1:] for a in "xyz"]
