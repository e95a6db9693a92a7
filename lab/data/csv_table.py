"""Someone else's CSV file, read strictly: header, rows with their line numbers, a checksum.

Imported measurements (:mod:`lab.data.importing`) come from files this project did not
write, so reading them checks what our own dataset reader can take for granted, and every
complaint names the file, the line and the column: a binary or empty file, a file too large
to hold in memory, rows whose number of fields differs from the header's, a column that is
missing (the message lists the file's columns), a header naming a column twice, and anything
that is not a regular file (a pipe or a device has no size to check before it is read).
Blank lines are skipped, a UTF-8 byte-order mark and a missing final newline are fine. The
file is streamed (hashed and decoded as it is read, with a progress bar on a terminal for a
large file), so only its parsed rows are held in memory.

One rule handles a quirk of real exports (the ASL Trunk's ``observations_steady_state_
uniform_src_demo_pt*.csv``): when the header has exactly one name more than every row and
that first name is the ID column (``--id``, or ``ID``/``id``/``index`` without it), the rows
are read as lacking that column -- the "phantom ID" rule; :attr:`CsvTable.phantom` says so.
Values are parsed by :meth:`CsvTable.numbers`, which classifies bad cells instead of failing,
so that the caller decides: an error naming the cell, or the row dropped and counted. A
number is what Python's ``float`` reads from ASCII text without ``_`` separators: ``1_000``
and digits of other scripts (Arabic-Indic, full-width), which ``float`` would also take, are
not numbers in a CSV file.
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
import stat
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lab.errors import InputError

__all__ = ["CsvTable", "read_table", "MAX_IMPORT_BYTES", "PHANTOM_ID_NAMES", "OK", "NAN", "NON_NUMERIC"]

#: Largest CSV file an import reads (it is held in memory as text and parsed rows).
MAX_IMPORT_BYTES = 256 * 1024**2
#: Files larger than this get a progress bar while they are read (on a terminal only).
PROGRESS_BYTES = 16 * 1024**2
#: Header names taken for an ID column by the phantom-ID rule when no ``--id`` is given.
PHANTOM_ID_NAMES = ("ID", "id", "index")
#: Cell classes of :meth:`CsvTable.numbers`: a number; NaN, infinite or empty; not a number.
OK, NAN, NON_NUMERIC = 0, 1, 2


@dataclass(frozen=True)
class CsvTable:
    """One CSV file: ``header`` (names, stripped), ``rows`` (lists of fields, as read),
    ``lines`` (the 1-based line of each row), the file's ``sha256``, and ``phantom``: the
    header name the rows lack (phantom-ID rule) or None."""

    path: str
    header: tuple[str, ...]
    rows: list[list[str]]
    lines: list[int]
    sha256: str
    phantom: str | None = None

    def has(self, name: str) -> bool:
        return name in self.header

    def index(self, name: str, flag: str) -> int:
        """The column position of ``name``; InputError naming ``flag`` if it is missing or
        named twice in the header."""
        if name not in self.header:
            extra = f" (the header's {self.phantom!r} has no values in the rows)" if name == self.phantom else ""
            raise InputError(
                f"{self.path}: no column {name!r} ({flag}){extra}; its columns are: {', '.join(self.header)}"
            )
        return self.header.index(name)  # read_table refuses a name given twice

    def strings(self, name: str, flag: str) -> list[str]:
        """The column ``name`` as stripped strings, one per row."""
        i = self.index(name, flag)
        return [row[i].strip() for row in self.rows]

    def numbers(self, names, flag: str) -> tuple[np.ndarray, np.ndarray]:
        """The columns ``names`` as floats (rows, len(names)) (NaN where a cell is bad) and
        each cell's class (:data:`OK`, :data:`NAN`: NaN, infinite or empty, :data:`NON_NUMERIC`)."""
        idx = [self.index(n, flag) for n in names]
        values = np.full((len(self.rows), len(idx)), np.nan)
        kind = np.zeros(values.shape, dtype=np.int8)
        for c, i in enumerate(idx):
            column = [row[i] for row in self.rows]
            joined = "".join(column)
            try:  # the whole column at once (numpy reads ASCII text as float does); cell by cell if one is bad
                if not joined.isascii() or "_" in joined:
                    raise ValueError
                values[:, c] = np.array(column, dtype=float)
            except ValueError:
                for r, text in enumerate(column):
                    values[r, c], kind[r, c] = _cell(text)
        bad = ~np.isfinite(values)
        kind[bad & (kind == OK)] = NAN
        values[bad] = np.nan
        return values, kind


def _cell(text: str) -> tuple[float, int]:
    """One cell's value and class: a number only in ASCII without ``_`` (see the module docstring)."""
    if not text.strip():
        return np.nan, NAN
    if not text.isascii() or "_" in text:
        return np.nan, NON_NUMERIC
    try:
        return float(text), OK
    except ValueError:
        return np.nan, NON_NUMERIC


class _Bytes(io.RawIOBase):
    """A file's bytes as they are read: hashed, counted against :data:`MAX_IMPORT_BYTES` (a
    file may grow while it is read), refused at a NUL byte (a binary file), shown on ``bar``."""

    def __init__(self, fh, path, bar):
        self.fh, self.path, self.bar = fh, path, bar
        self.sha256, self.n = hashlib.sha256(), 0

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        n = self.fh.readinto(buffer)
        if n:
            chunk = bytes(buffer[:n])
            if b"\0" in chunk:
                raise InputError(f"{self.path}: a binary file (it holds NUL bytes), not a CSV text file")
            self.n += n
            if self.n > MAX_IMPORT_BYTES:
                raise InputError(f"{self.path}: {_too_large(self.n)}")
            self.sha256.update(chunk)
            self.bar.update(n)
        return n


def _too_large(size: int) -> str:
    return (
        f"{size / 1024**2:.0f} MiB or more is larger than an import reads "
        f"({MAX_IMPORT_BYTES / 1024**2:.0f} MiB, lab.data.csv_table.MAX_IMPORT_BYTES); split the file"
    )


def _open(path, what: str) -> int:
    """The size of the regular file ``path``; InputError if it is missing, not a regular file or too large."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"{what} {path} not found") from None
    except OSError as err:
        raise InputError(f"{what} {path}: cannot be read ({err.strerror or err})") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{what} {path} is a directory, not a CSV file")
    if not stat.S_ISREG(st.st_mode):
        raise InputError(
            f"{what} {path} is not a regular file (a pipe, a device or a socket): an import reads files, whose "
            "size it checks first; save the data to a file"
        )
    if st.st_size > MAX_IMPORT_BYTES:
        raise InputError(f"{path}: {_too_large(st.st_size)}")
    return st.st_size


def _rows(path, size: int) -> tuple[list, list, str]:
    """The non-blank rows of the CSV file ``path``, their 1-based lines and the file's SHA-256."""
    from tqdm.auto import tqdm

    rows, lines = [], []
    name = Path(path).name
    with (
        open(path, "rb") as fh,
        tqdm(
            total=size,
            unit="B",
            unit_scale=True,
            desc=f"reading {name}",
            disable=None if size > PROGRESS_BYTES else True,
        ) as bar,
    ):
        raw = _Bytes(fh, path, bar)
        reader = csv.reader(io.TextIOWrapper(io.BufferedReader(raw, 1 << 20), encoding="utf-8-sig", newline=""))
        try:
            for row in reader:
                if row and (row[0].strip() or any(f.strip() for f in row)):
                    rows.append(row)
                    lines.append(reader.line_num)
        except csv.Error as err:
            raise InputError(f"{path}: line {reader.line_num}: not a readable CSV row ({err})") from None
        except UnicodeDecodeError:
            raise InputError(f"{path}: not a UTF-8 text CSV file (near line {reader.line_num + 1})") from None
    return rows, lines, raw.sha256.hexdigest()


def read_table(path, *, id_column: str | None = None, what: str = "FILE") -> CsvTable:
    """Read the CSV file at ``path`` (``what`` names it in errors: "FILE", "--observations").

    ``id_column``: the ID column of a pairing (``--id``), for the phantom-ID rule. Raises
    InputError for a missing, binary, empty, oversized or not regular file, no data rows, a
    header naming a column twice, or a row whose number of fields differs from the header's
    (naming its line)."""
    rows, lines, sha256 = _rows(path, _open(path, what))
    if not rows:
        raise InputError(f"{path}: empty file")
    header = tuple(name.strip() for name in rows[0])
    twice = sorted({h for h in header if h and header.count(h) > 1})
    if twice:
        raise InputError(
            f"{path}: line {lines[0]}: the header names the column(s) {', '.join(map(repr, twice))} more than once; "
            "give each column a name of its own"
        )
    rows, lines = rows[1:], lines[1:]
    if not rows:
        raise InputError(f"{path}: no data rows, only the header {','.join(header)}")
    counts = {len(r) for r in rows}
    phantom = None
    is_id = header[0] == id_column if id_column is not None else header[0] in PHANTOM_ID_NAMES
    if counts == {len(header) - 1} and is_id:
        phantom, header = header[0], header[1:]
    for row, line in zip(rows, lines):
        if len(row) != len(header):
            hint = ""
            if counts == {len(header) - 1}:
                hint = (
                    " (every row has one field fewer than the header; the phantom-ID rule reads such rows as "
                    f"lacking the header's first column, {header[0]!r}, only when it is the --id column, or one of "
                    f"{', '.join(PHANTOM_ID_NAMES)} without --id)"
                )
            raise InputError(f"{path}: line {line} has {len(row)} fields, the header has {len(header)}{hint}")
    return CsvTable(str(path), header, rows, lines, sha256, phantom)
