"""Compare result tables of a new run with the committed ones (used by scripts/reproduce).

    python scripts/compare_tables.py REFERENCE_DIR NEW_DIR table1.csv table_model_ten_splits.csv ...
    python scripts/compare_tables.py --keep-committed-timings build/reference figures TABLE ...

Rows are matched by a key: the columns declared for the table in ``KEYS``, else every
non-numeric column and every index column (``INDEX``: split, run, seed, width, ...). The key
must be unique in both tables; a key that is not is an error of the comparison (exit 2), not a
moved cell. Every numeric cell is compared except timings and bookkeeping (columns named like
wall/time/ms/date/updated/source). A cell *moved* when

    |new - ref| > RTOL * max(|new|, |ref|) + RTOL * max |ref column|

with RTOL = 1e-3: 0.1 % of the value, and 0.1 % of the column's scale for values near zero
(round-off, e.g. Soft IK's 1e-7 cm). Prints every moved cell and exits 1 if any moved, 0
otherwise; a table missing on either side is reported and counts as moved; a table that
cannot be compared (not a CSV, a key that is not unique) is an error, exit 2.

``--keep-committed-timings``: a new table whose cells are the reference's, character for
character, except in the timing and bookkeeping columns (``wall_s``, ...) is replaced by the
reference's file, so a re-run that gave the same results leaves the committed file as it was
instead of rewriting it for its new timings (scripts/reproduce passes it).
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import shutil
import sys
from pathlib import Path

RTOL = 1e-3
SKIP = re.compile(r"wall|time|_ms|date|updated|source|command", re.I)
#: Row keys of the tables scripts/reproduce compares.
KEYS = {
    "table1.csv": ("condition",),
    "table_model_ten_splits.csv": ("split",),
    "table_model_ten_splits_real.csv": ("split",),
    "table_six_cable_tracking.csv": ("path",),
    "fig6_network_size.csv": ("width",),
    "fig6_network_size_real.csv": ("width",),
}
#: Columns that index rows wherever they appear (numeric, but part of an undeclared key).
INDEX = {"split", "run", "seed", "width", "n", "n_real", "member", "robot_seed", "pass", "period_s"}


class KeyError_(Exception):
    """The table's key does not identify its rows."""


def _num(text: str) -> float | None:
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def key_columns(name: str, rows: list[dict]) -> tuple[str, ...]:
    """The columns that identify a row of table ``name`` (declared, or inferred from ``rows``)."""
    if name in KEYS:
        return KEYS[name]

    def text(c):  # a column with a non-numeric, non-empty value
        return not SKIP.search(c) and any(_num(r.get(c)) is None and r.get(c) not in ("", None) for r in rows)

    return tuple(c for c in rows[0] if c in INDEX or text(c))


def _index(rows: list[dict], key: tuple[str, ...], where: str) -> dict:
    if not key:
        raise KeyError_(f"{where}: no key column identifies its rows")
    missing = [c for c in key if c not in rows[0]]
    if missing:
        raise KeyError_(f"{where}: key column(s) {', '.join(missing)} missing")
    out = {}
    for i, r in enumerate(rows):
        k = tuple(r[c] for c in key)
        if k in out:
            raise KeyError_(f"{where}: key ({', '.join(key)}) = {k} is not unique (rows {out[k][0] + 2} and {i + 2})")
        out[k] = (i, r)
    return out


def _rows(path: Path) -> list[dict]:
    """The rows of the CSV ``path``; :class:`KeyError_` when it is not a readable CSV of text."""
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise KeyError_(f"{path}: not a readable CSV table ({type(e).__name__}: {e})") from None
    if any(None in r for r in rows):
        raise KeyError_(f"{path}: a row has more fields than the header")
    return rows


def only_timings_differ(ref_path: Path, new_path: Path) -> bool:
    """Whether the two tables hold the same text everywhere but in the columns the comparison
    skips (timings, bookkeeping): same columns, same rows in the same order."""
    if not ref_path.is_file() or not new_path.is_file():
        return False
    ref, new = _rows(ref_path), _rows(new_path)
    if len(ref) != len(new) or (ref and list(ref[0]) != list(new[0])):
        return False
    kept = [c for c in (ref[0] if ref else []) if not SKIP.search(c)]
    return all(a[c] == b[c] for a, b in zip(ref, new) for c in kept)


def moved_cells(ref_path: Path, new_path: Path) -> list[str]:
    """Descriptions of the cells of ``new_path`` that moved from ``ref_path`` (see module doc).
    Raises :class:`KeyError_` when the key does not identify the rows of either table."""
    if not ref_path.exists() or not new_path.exists():
        return [f"{new_path.name}: missing ({'reference' if not ref_path.exists() else 'new run'})"]
    ref, new = _rows(ref_path), _rows(new_path)
    if not ref:
        return []
    key = key_columns(ref_path.name, ref)
    ref_by = _index(ref, key, f"{ref_path} (reference)")
    new_by = _index(new, key, str(new_path)) if new else {}
    label = lambda k: ", ".join(f"{c}={v}" for c, v in zip(key, k))  # noqa: E731
    out = [f"{new_path.name}: row {label(k)} is gone" for k in ref_by if k not in new_by]
    for col in ref[0]:
        if col in key or SKIP.search(col):
            continue
        scale = max((abs(v) for r in ref if (v := _num(r.get(col))) is not None), default=0.0)
        for k, (_, r) in ref_by.items():
            a = _num(r.get(col))
            if a is None or k not in new_by:
                continue
            b = _num(new_by[k][1].get(col))
            if a != a and b is not None and b != b:  # NaN in both: unchanged
                continue
            if b is None or not abs(b - a) <= RTOL * max(abs(a), abs(b)) + RTOL * scale:
                out.append(f"{new_path.name}: {label(k)}, {col}: {a:.6g} -> {b if b is None else f'{b:.6g}'}")
    return out


def main(argv: list[str] | None = None) -> int:
    """Compare the tables; 0 nothing moved, 1 a cell moved or a table is missing, 2 cannot compare."""
    parser = argparse.ArgumentParser(
        prog="scripts/compare_tables.py",
        description="Compare result tables of a new run with the committed ones (scripts/reproduce runs it).",
        epilog=f"A cell moved when it differs by more than {RTOL} relative (see the module's text); timing and "
        "bookkeeping columns are not compared. Exit: 0 nothing moved, 1 a cell moved or a table is missing, "
        "2 the tables cannot be compared.",
    )
    parser.add_argument(
        "reference", type=Path, help="the folder of the committed tables (scripts/reproduce: build/reference)"
    )
    parser.add_argument("new", type=Path, help="the folder of the new run's tables (figures)")
    parser.add_argument(
        "tables", nargs="+", metavar="TABLE", help="file names of the tables to compare, in both folders"
    )
    parser.add_argument(
        "--keep-committed-timings",
        action="store_true",
        help="where only timing columns differ, copy the reference's file over the new one",
    )
    args = parser.parse_args(argv)
    for folder in (args.reference, args.new):
        if not folder.is_dir():
            print(f"error: {folder}: no such folder of tables", file=sys.stderr)
            return 2
    moved, kept = [], []
    try:
        for name in args.tables:
            ref, new = args.reference / name, args.new / name
            moved += moved_cells(ref, new)
            if args.keep_committed_timings and only_timings_differ(ref, new) and ref.read_bytes() != new.read_bytes():
                tmp = new.with_name(f".{new.name}.tmp{os.getpid()}")  # atomic: never a half-copied table
                shutil.copyfile(ref, tmp)
                os.replace(tmp, new)
                kept.append(name)
    except KeyError_ as err:
        print(f"error: cannot compare: {err}")
        return 2
    for m in moved:
        print(f"moved: {m}")
    for name in kept:
        print(f"kept: {args.new / name} as committed (the new run's differs only in timing columns)")
    n = len(args.tables)
    print(
        f"compared {n} table(s) with the committed ones (rtol {RTOL}): {len(moved)} cell(s) moved"
        if moved
        else f"compared {n} table(s): nothing moved beyond {RTOL}"
    )
    return 1 if moved else 0


if __name__ == "__main__":
    sys.exit(main())
