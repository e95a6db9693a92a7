"""Compare result tables of a new run with the committed ones (used by scripts/reproduce).

    python scripts/compare_tables.py REFERENCE_DIR NEW_DIR table1.csv table_model_ten_splits.csv ...

Rows are matched by their first column; every numeric cell is compared except timings and
bookkeeping (columns named like wall/time/ms/date/updated/source). A cell *moved* when

    |new - ref| > RTOL * max(|new|, |ref|) + RTOL * max |ref column|

with RTOL = 1e-3: 0.1 % of the value, and 0.1 % of the column's scale for values near zero
(round-off, e.g. Soft IK's 1e-7 cm). Prints every moved cell and exits 1 if any moved, 0
otherwise; a table missing on either side is reported and counts as moved.
"""

from __future__ import annotations

import csv
import re
import sys
from pathlib import Path

RTOL = 1e-3
SKIP = re.compile(r"wall|time|_ms|date|updated|source|command", re.I)


def _num(text: str) -> float | None:
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def moved_cells(ref_path: Path, new_path: Path) -> list[str]:
    """Descriptions of the cells of ``new_path`` that moved from ``ref_path`` (see module doc)."""
    if not ref_path.exists() or not new_path.exists():
        return [f"{new_path.name}: missing ({'reference' if not ref_path.exists() else 'new run'})"]
    ref = list(csv.DictReader(ref_path.open(newline="")))
    new = list(csv.DictReader(new_path.open(newline="")))
    if not ref:
        return []
    key = list(ref[0])[0]
    by_key = {r[key]: r for r in new}
    out = []
    for col in ref[0]:
        if col == key or SKIP.search(col):
            continue
        scale = max((abs(v) for r in ref if (v := _num(r.get(col))) is not None), default=0.0)
        for r in ref:
            a, row = _num(r.get(col)), by_key.get(r[key])
            if a is None:
                continue
            if row is None:
                out.append(f"{new_path.name}: row {key}={r[key]} is gone")
                break
            b = _num(row.get(col))
            if b is None or abs(b - a) > RTOL * max(abs(a), abs(b)) + RTOL * scale:
                out.append(f"{new_path.name}: {key}={r[key]}, {col}: {a:.6g} -> {b if b is None else f'{b:.6g}'}")
    return out


def main(argv: list[str]) -> int:
    ref_dir, new_dir, *names = argv
    moved = [m for name in names for m in moved_cells(Path(ref_dir) / name, Path(new_dir) / name)]
    for m in moved:
        print(f"moved: {m}")
    print(
        f"compared {len(names)} table(s) with the committed ones (rtol {RTOL}): {len(moved)} cell(s) moved"
        if moved
        else f"compared {len(names)} table(s): nothing moved beyond {RTOL}"
    )
    return 1 if moved else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
