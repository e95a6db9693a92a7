"""Someone else's CSV file, read strictly: header, rows with their line numbers, a checksum.

Imported measurements (:mod:`lab.data.importing`) come from files this project did not
write, so reading them checks what our own dataset reader can take for granted, and every
complaint names the file, the line and the column: a binary or empty file, a file too large
to hold in memory, rows whose number of fields differs from the header's, a column that is
missing (the message lists the file's columns) or named twice in the header. Blank lines
are skipped, a UTF-8 byte-order mark and a missing final newline are fine.

One rule handles a quirk of real exports (the ASL Trunk's ``observations_steady_state_
uniform_src_demo_pt*.csv``): when the header has exactly one name more than every row and
that first name is the ID column (``--id``, or ``ID``/``id``/``index`` without it), the rows
are read as lacking that column -- the "phantom ID" rule; :attr:`CsvTable.phantom` says so.
Values are parsed by :meth:`CsvTable.numbers`, which classifies bad cells instead of failing,
so that the caller decides: an error naming the cell, or the row dropped and counted.
"""

from __future__ import annotations

import csv
import hashlib
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lab.errors import InputError

__all__ = ["CsvTable", "read_table", "MAX_IMPORT_BYTES", "PHANTOM_ID_NAMES", "OK", "NAN", "NON_NUMERIC"]

#: Largest CSV file an import reads (it is held in memory as text and parsed rows).
MAX_IMPORT_BYTES = 256 * 1024**2
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
        hits = [i for i, h in enumerate(self.header) if h == name]
        if not hits:
            extra = f" (the header's {self.phantom!r} has no values in the rows)" if name == self.phantom else ""
            raise InputError(
                f"{self.path}: no column {name!r} ({flag}){extra}; its columns are: {', '.join(self.header)}"
            )
        if len(hits) > 1:
            raise InputError(f"{self.path}: the header names the column {name!r} ({flag}) {len(hits)} times")
        return hits[0]

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
        for r, row in enumerate(self.rows):
            for c, i in enumerate(idx):
                text = row[i]
                try:
                    v = float(text)
                except ValueError:
                    kind[r, c] = NAN if not text.strip() else NON_NUMERIC
                    continue
                if v - v != 0.0:  # NaN or infinite
                    kind[r, c] = NAN
                else:
                    values[r, c] = v
        return values, kind


def read_table(path, *, id_column: str | None = None, what: str = "FILE") -> CsvTable:
    """Read the CSV file at ``path`` (``what`` names it in errors: "FILE", "--observations").

    ``id_column``: the ID column of a pairing (``--id``), for the phantom-ID rule. Raises
    InputError for a missing, binary, empty or oversized file, no data rows, or a row whose
    number of fields differs from the header's (naming its line)."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"{what} {path} not found")
    if p.is_dir():
        raise InputError(f"{what} {path} is a directory, not a CSV file")
    size = p.stat().st_size
    if size > MAX_IMPORT_BYTES:
        raise InputError(
            f"{path}: {size / 1024**2:.0f} MiB is larger than an import reads "
            f"({MAX_IMPORT_BYTES / 1024**2:.0f} MiB, lab.data.csv_table.MAX_IMPORT_BYTES); split the file"
        )
    raw = p.read_bytes()
    if b"\0" in raw:
        raise InputError(f"{path}: a binary file (it holds NUL bytes), not a CSV text file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not a UTF-8 text CSV file (byte {err.start} is not UTF-8)") from None
    if not text.strip():
        raise InputError(f"{path}: empty file")
    reader = csv.reader(io.StringIO(text, newline=""))
    rows, lines = [], []
    try:
        for row in reader:
            if row and any(f.strip() for f in row):
                rows.append(row)
                lines.append(reader.line_num)
    except csv.Error as err:
        raise InputError(f"{path}: line {reader.line_num}: not a readable CSV row ({err})") from None
    header = tuple(name.strip() for name in rows[0])
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
    return CsvTable(str(path), header, rows, lines, hashlib.sha256(raw).hexdigest(), phantom)
