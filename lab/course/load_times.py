"""How much a busy machine stretches a chapter's quick run, and the sentence that says it.

``benchmarks/bench_chapter_load.py --load N`` runs some chapters in quick mode twice, alone
and with N CPU-bound processes beside them, and keeps per chapter both wall times (kernel
start-up included, as the time table's) and their ratio in ``benchmarks/chapter_load.csv``,
with the load, the date and the machine. :func:`read_load_times` checks every cell and names
the file, line and column of a bad one; :func:`load_sentence` renders the line that
:func:`lab.course.times.times_markdown` puts under the table -- and nothing when there is no
such file: the stretch is measured or not said.
"""

from __future__ import annotations

import csv
import datetime
import io
import math
import re
import statistics
from pathlib import Path

from lab.errors import InputError
from lab.files import atomic_write_text

__all__ = ["LOAD_COLUMNS", "LOAD_TIMES", "read_load_times", "write_load_times", "load_sentence"]

LOAD_COLUMNS = ["chapter", "quick_idle_s", "quick_loaded_s", "ratio", "load", "date", "machine"]
#: Where the benchmark keeps them, relative to the repository's root.
LOAD_TIMES = "benchmarks/chapter_load.csv"
WHAT = "a chapter-load CSV (benchmarks/bench_chapter_load.py)"
ROOT = Path(__file__).resolve().parents[2]
_CHAPTER = re.compile(r"\d\d_[\w-]+\.ipynb")


def text_of(path: Path, what: str) -> str:
    """The UTF-8 text of ``path``; an :class:`InputError` naming it when it is missing, a
    folder or binary (``what``: what it should be, for the message)."""
    if not path.is_file():
        raise InputError(f"{path}: a folder, not {what}" if path.is_dir() else f"{path}: no such file ({what})")
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: not {what} (not UTF-8 text: byte {e.start} is {e.object[e.start]:#04x})") from None


def csv_rows(path: Path, lines: list[list[str]], header: list[str]):
    """``(line number, {column: text})`` of each non-blank row of a CSV read as ``lines``
    (its header first); an :class:`InputError` naming the file and line of a row whose
    number of fields is not the header's."""
    for line, cells in enumerate(lines[1:], start=2):
        if not cells:
            continue
        if len(cells) != len(header):
            raise InputError(f"{path}, line {line}: {len(cells)} fields where its header has {len(header)}")
        yield line, dict(zip(header, cells))


def _check(row: dict[str, str]) -> tuple[str, str] | None:
    """The first bad cell of a row: (column, what it must be), or None."""

    def number(text: str, count: bool = False) -> float | None:
        try:
            v = float(text)
        except ValueError:
            return None
        return v if math.isfinite(v) and v > 0 and (v.is_integer() or not count) else None

    if not _CHAPTER.fullmatch(row["chapter"]):
        return "chapter", "a chapter's notebook name (NN_name.ipynb)"
    for column in ("quick_idle_s", "quick_loaded_s", "ratio"):
        if number(row[column]) is None:
            return column, "a finite number > 0"
    if number(row["load"], count=True) is None:
        return "load", "a count of CPU-bound processes >= 1"
    try:
        datetime.date.fromisoformat(row["date"])
    except ValueError:
        return "date", "a date (YYYY-MM-DD)"
    if not row["machine"].strip():
        return "machine", "the machine's CPUs and model"
    ratio = float(row["quick_loaded_s"]) / float(row["quick_idle_s"])
    if abs(float(row["ratio"]) - ratio) > 0.01 + 1e-9:
        return "ratio", f"quick_loaded_s / quick_idle_s ({ratio:.2f})"
    return None


def read_load_times(path: str | Path) -> list[dict[str, str]]:
    """The rows of a chapter-load CSV, every cell checked.

    Parameters
    ----------
    path : str or pathlib.Path
        The file (header: :data:`LOAD_COLUMNS`).

    Returns
    -------
    list of dict
        One ``{column: text}`` per chapter, in the file's order.

    Raises
    ------
    InputError
        A file that is not such a CSV, a bad cell (its file, line and column), a chapter
        twice, rows of different loads, or no rows.
    """
    path = Path(path)
    lines = list(csv.reader(io.StringIO(text_of(path, WHAT), newline="")))
    if not lines or lines[0] != LOAD_COLUMNS:
        got = ",".join(lines[0])[:60] if lines else ""
        raise InputError(f"{path}, line 1: not {WHAT}: its header must be {','.join(LOAD_COLUMNS)}, got {got!r}")
    rows: list[dict[str, str]] = []
    for line, row in csv_rows(path, lines, LOAD_COLUMNS):
        bad = _check(row)
        if bad:
            raise InputError(f"{path}, line {line}, column {bad[0]}: {row[bad[0]]!r} is not {bad[1]}")
        if any(r["chapter"] == row["chapter"] for r in rows):
            raise InputError(f"{path}, line {line}: chapter {row['chapter']} has a row already")
        if rows and int(float(row["load"])) != int(float(rows[0]["load"])):
            raise InputError(
                f"{path}, line {line}, column load: {row['load']} where line 2 has {rows[0]['load']} "
                "(one load per file: one run of the benchmark)"
            )
        rows.append(row)
    if not rows:
        raise InputError(f"{path}: no chapter measured (a header and no rows)")
    return rows


def write_load_times(path: str | Path, rows: list[dict]) -> None:
    """Replace the chapter-load CSV at ``path`` (atomically) by ``rows``.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write.
    rows : list of dict
        One per chapter, with every column of :data:`LOAD_COLUMNS`; checked as
        :func:`read_load_times` reads them, before the file is touched.
    """
    out = io.StringIO()
    w = csv.DictWriter(out, LOAD_COLUMNS, lineterminator="\n")
    w.writeheader()
    w.writerows({c: str(r[c]) for c in LOAD_COLUMNS} for r in rows)
    for line, row in enumerate(rows, start=2):
        bad = _check({c: str(row[c]) for c in LOAD_COLUMNS})
        if bad:
            raise InputError(f"{path}, line {line}, column {bad[0]}: {row[bad[0]]!r} is not {bad[1]} (not written)")
    atomic_write_text(path, out.getvalue())


def _label(path: Path) -> str:
    """The file as the sentence names it: relative to the repository when inside it."""
    try:
        return path.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return str(path)


def load_sentence(path: str | Path, must_exist: bool = False) -> str:
    """One line on how much a machine busy with other CPU-bound processes stretched the
    quick runs: the median ratio and its range, the chapters, when, where and the file.

    Parameters
    ----------
    path : str or pathlib.Path
        A chapter-load CSV (:func:`read_load_times`).
    must_exist : bool
        Whether a missing file is an error; else it gives no sentence.

    Returns
    -------
    str
        The sentence, or "" when the file is missing and need not exist.
    """
    path = Path(path)
    if not path.exists() and not must_exist:
        return ""
    rows = read_load_times(path)
    ratios = sorted(float(r["ratio"]) for r in rows)
    n = int(float(rows[0]["load"]))
    chapters = [r["chapter"][:2] for r in sorted(rows, key=lambda r: r["chapter"])]
    which = f"chapter {chapters[0]}"
    if len(chapters) > 1:
        which = f"median of chapters {', '.join(chapters[:-1])} and {chapters[-1]}"
    if ratios[0] != ratios[-1]:
        which += f"; range {ratios[0]:.1f}–{ratios[-1]:.1f}×"
    dates = sorted({r["date"] for r in rows})
    when = dates[0] if len(dates) == 1 else f"{dates[0]} to {dates[-1]}"
    machines = "; ".join(sorted({r["machine"] for r in rows}))
    return (
        f"Under load: with {n} other CPU-bound process{'es' * (n != 1)} running beside it, a quick run took "
        f"{statistics.median(ratios):.1f}× as long as without {'them' if n != 1 else 'it'} ({which}; {when}, "
        f"on {machines}; `{_label(path)}`, from `benchmarks/bench_chapter_load.py --load {n}`)."
    )
