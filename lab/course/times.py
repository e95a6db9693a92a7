"""How long each chapter takes to run, as measured by ``scripts/reproduce``, and its table.

``figures/chapter_times.csv`` has one row per chapter and, per mode (quick, full), the
seconds, the date, the machine (CPUs usable and their model), the 1-minute load average
when the chapter ended and how many chapters ran at once. The seconds are the wall time
of the chapter's whole papermill run, kernel start-up included -- what a student waits
for *Run All* -- not papermill's own record of the cells (which leaves the start out and
read 6 s for a chapter that took 24 s on a loaded machine).

:func:`record_times` adds a run's chapters to the CSV (``scripts/reproduce``: after a run of
every chapter to ``figures/chapter_times.csv``, after a run of some to
``build/chapter_times.partial.csv``, beside it), and never overwrites a file that is not such
a CSV; :func:`read_times` checks every number and names the file, line and column of a bad one;
:func:`times_markdown` renders the table with a sentence on the machine and load (and one on
how much a busy machine stretched the quick runs, from ``benchmarks/chapter_load.csv``:
:mod:`lab.course.load_times`); :func:`write_times_block` replaces it between
``<!-- chapter-times -->`` and ``<!-- /chapter-times -->`` in the README and docs/course.md
(``scripts/chapter-times --write``; tests/test_student_path.py fails when they differ from
the CSVs), never replacing a measured time with a dash.
"""

from __future__ import annotations

import csv
import datetime
import io
import json
import math
import os
import platform
import re
from pathlib import Path

from lab.course.load_times import csv_rows, load_sentence
from lab.course.load_times import text_of as _text
from lab.errors import InputError
from lab.files import atomic_write_text

__all__ = ["COLUMNS", "record_times", "read_times", "times_markdown", "write_times_block", "machine_name"]

MODES = ("quick", "full")
COLUMNS = ["chapter", *(f"{m}_{k}" for k in ("s", "date", "machine", "load", "jobs") for m in MODES)]
BEGIN, END = "<!-- chapter-times -->", "<!-- /chapter-times -->"


def machine_name() -> str:
    """ "N CPUs, MODEL": the CPUs this process may use and their model (Linux), else the platform."""
    n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = " ".join(line.split(":", 1)[1].split())
                break
    except OSError:
        pass
    return f"{n} CPUs, {model}" if model else f"{n} CPUs"


def _number(path: Path, line: int, column: str, text: str) -> None:
    """Check one cell of the CSV: seconds and loads are finite numbers >= 0, jobs a count >= 1."""
    if not text:
        return
    try:
        value = float(text)
        ok = (
            math.isfinite(value)
            and value >= 0
            and (not column.endswith("_jobs") or (value.is_integer() and value >= 1))
        )
    except ValueError:
        ok = False
    if not ok:
        what = "a count of chapters >= 1" if column.endswith("_jobs") else "a finite number >= 0"
        raise InputError(f"{path}, line {line}, column {column}: {text!r} is not {what}")


def read_times(path: str | Path, must_exist: bool = False) -> dict[str, dict]:
    """The CSV's rows by chapter (strings; a column an older file lacks is "").

    Parameters
    ----------
    path : str or pathlib.Path
        A chapter-times CSV (its header: ``chapter`` and some of :data:`COLUMNS`).
    must_exist : bool
        Whether a missing file is an error; else it reads as no rows.

    Returns
    -------
    dict
        Chapter name -> {column: text}, every column of :data:`COLUMNS`.

    Raises
    ------
    InputError
        A file that is not a chapter-times CSV (a note, a notebook, binary), naming the file,
        and a cell that is not a number of seconds, naming its line and column.
    """
    path = Path(path)
    if not path.exists() and not must_exist:
        return {}
    what = "a chapter-times CSV"
    lines = list(csv.reader(io.StringIO(_text(path, what), newline="")))
    header = lines[0] if lines else []
    unknown = [c for c in header if c not in COLUMNS]
    if not header or header[0] != "chapter" or unknown:
        first = ",".join(header)[:60]
        raise InputError(
            f"{path}: not {what}: its first line must be 'chapter' and columns of {','.join(COLUMNS[1:])}, "
            f"got {first!r}" + (f" (unknown: {', '.join(unknown)})" if unknown and header[:1] == ["chapter"] else "")
        )
    rows = {}
    for line, row in csv_rows(path, lines, header):
        for column, text in row.items():
            if column != "chapter" and not column.endswith(("_date", "_machine")):
                _number(path, line, column, text)
        if row["chapter"] in rows:
            raise InputError(f"{path}, line {line}: chapter {row['chapter']} has a row already")
        rows[row["chapter"]] = {c: row.get(c) or "" for c in COLUMNS}
    return rows


def _run_time(nb: Path) -> tuple[float, str]:
    """The wall time (s) and load average of one chapter's run, from ``NAME.time`` beside it."""
    path = Path(f"{nb}.time")
    what = "a time record of scripts/reproduce ('START END [LOAD]': seconds since the epoch, load average)"
    if not path.exists():
        raise InputError(f"{nb}: no time of this run ({path} is missing)")
    text = _text(path, what)
    fields = text.replace(",", ".").split()  # (a comma locale's decimal mark)
    try:
        start, end, *load = (float(f) for f in fields)
        ok = (
            len(load) <= 1
            and all(map(math.isfinite, (start, end, *load)))
            and end >= start
            and min(load, default=0) >= 0
        )
    except ValueError:
        ok = False
    if not ok:
        raise InputError(f"{path}, line 1: not {what}: {' '.join(text.split())[:60]!r}")
    return end - start, fields[2] if len(fields) > 2 else ""


def record_times(path: str | Path, executed: list[str | Path], jobs: int) -> list[tuple[str, str, float]]:
    """Add the chapters of one ``scripts/reproduce`` run to the CSV at ``path``.

    ``executed``: papermill's output notebooks; beside each, ``NAME.time`` holds the run's
    start and end (seconds since the epoch) and the 1-minute load average at its end, as
    ``scripts/reproduce`` wrote them. The mode is the notebook's ``quick`` parameter. A file
    at ``path`` that is not a chapter-times CSV is refused, never overwritten; the CSV is
    replaced atomically.

    Parameters
    ----------
    path : str or pathlib.Path
        The chapter-times CSV to update (made when missing).
    executed : list of str or pathlib.Path
        The executed notebooks.
    jobs : int
        How many chapters ran at a time (>= 1).

    Returns
    -------
    list of tuple
        Per chapter recorded: its name, its mode ("quick" or "full") and its wall time (s).
    """
    if jobs < 1:
        raise InputError(f"jobs must be >= 1 (chapters run at a time), got {jobs}")
    rows = read_times(path)
    machine, today = machine_name(), datetime.date.today().isoformat()
    done = []
    for nb in map(Path, executed):
        try:
            meta = json.loads(_text(nb, "an executed notebook"))["metadata"]["papermill"]
        except (ValueError, KeyError, TypeError) as e:
            raise InputError(f"{nb}: no papermill record of this run ({type(e).__name__}: {e})") from None
        seconds, load = _run_time(nb)
        mode = "quick" if str(meta.get("parameters", {}).get("quick", False)) in ("True", "true", "1") else "full"
        row = rows.setdefault(nb.name, dict.fromkeys(COLUMNS, "") | {"chapter": nb.name})
        row |= {
            f"{mode}_s": f"{seconds:.1f}",
            f"{mode}_date": today,
            f"{mode}_machine": machine,
            f"{mode}_load": load,
            f"{mode}_jobs": str(jobs),
        }
        done.append((nb.name, mode, seconds))
    out = io.StringIO()
    w = csv.DictWriter(out, COLUMNS, lineterminator="\n")
    w.writeheader()
    w.writerows(rows[k] for k in sorted(rows))
    atomic_write_text(path, out.getvalue())
    return done


def _seconds(text: str) -> str:
    if not text:
        return "–"
    s = float(text)
    return f"{s:.0f} s" if s < 90 else f"{s / 60:.1f} min"


def _conditions(rows: list[dict], mode: str) -> str:
    """One sentence on where the ``mode`` times were measured."""
    timed = [r for r in rows if r[f"{mode}_s"]]
    if not timed:
        return f"{mode.capitalize()} mode: not measured yet."
    known = [r for r in timed if r[f"{mode}_machine"]]
    dates = sorted({r[f"{mode}_date"] for r in timed if r[f"{mode}_date"]})
    when = f"{dates[0]} to {dates[-1]}" if len(dates) > 1 else (dates[0] if dates else "at an unrecorded date")
    text = f"{mode.capitalize()} mode: {len(timed)} chapter{'s' * (len(timed) != 1)}, {when}"
    if known:
        machines = "; ".join(sorted({r[f"{mode}_machine"] for r in known}))
        jobs = sorted({r[f"{mode}_jobs"] for r in known})
        jobs = "/".join(jobs) + (" chapter" if jobs == ["1"] else " chapters")
        loads = sorted(float(r[f"{mode}_load"]) for r in known if r[f"{mode}_load"])
        load = "not recorded"
        if loads:
            load = f"{loads[0]:.1f}" if loads[0] == loads[-1] else f"{loads[0]:.1f}–{loads[-1]:.1f}"
        text += f", on {machines}, {jobs} at a time, 1-minute load average {load} at each chapter's end"
    if len(known) < len(timed):
        old = "all" if not known else f"{len(timed) - len(known)} of them"
        text += f" ({old} timed by papermill's record of the cells, kernel start-up left out; machine not recorded)"
    return text + "."


def times_markdown(notebooks: str | Path, times: str | Path, load_times: str | Path | None = None) -> str:
    """The time per chapter in quick and full mode, as Markdown.

    Parameters
    ----------
    notebooks : str or pathlib.Path
        The folder of the chapters (every ``NN_name.ipynb`` in it gets a row).
    times : str or pathlib.Path
        The CSV of measured times (s); it must exist.
    load_times : str or pathlib.Path, optional
        A chapter-load CSV (:mod:`lab.course.load_times`): a line on how much a busy machine
        stretched the quick runs; a missing file, or None, gives no line.

    Returns
    -------
    str
        A Markdown table and a sentence per mode on how it was measured.
    """
    from lab.course.edition import CHAPTER_NAME

    rows = read_times(times, must_exist=True)
    names = sorted(p.name for p in Path(notebooks).glob("[0-9][0-9]_*.ipynb") if CHAPTER_NAME.fullmatch(p.name))
    lines = ["| chapter | quick mode | full mode |", "|---|---|---|"]
    for name in names:
        r = rows.get(name, dict.fromkeys(COLUMNS, ""))
        lines.append(f"| `{name}` | {_seconds(r['quick_s'])} | {_seconds(r['full_s'])} |")
    known = [rows[n] for n in names if n in rows]
    notes = [_conditions(known, m) for m in MODES] + ([load_sentence(load_times)] if load_times else [])
    return "\n".join([*lines, "", *(f"- {n}" for n in notes if n)]) + "\n"


def _cells(block: str) -> dict[tuple[str, str], str]:
    """The cells of a stored time table: (chapter, mode) -> its text ("–" where not measured)."""
    out = {}
    for row in re.finditer(r"^\| `([^`]+)` \| ([^|]*) \| ([^|]*) \|$", block, re.M):
        out |= {(row[1], mode): cell.strip() for mode, cell in zip(MODES, (row[2], row[3]))}
    return out


def write_times_block(
    path: str | Path, notebooks: str | Path, times: str | Path, load_times: str | Path | None = None
) -> bool:
    """Replace the text between ``<!-- chapter-times -->`` and ``<!-- /chapter-times -->`` in
    the Markdown file ``path`` by :func:`times_markdown` (same arguments); True when it changed.
    A measured time in the file is never replaced by a dash: a CSV without it is refused (an
    InputError)."""
    path = Path(path)
    text = _text(path, "a Markdown file")
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise InputError(f"{path}: needs one {BEGIN} ... {END} block for the chapter times")
    head, rest = text.split(BEGIN)
    table = times_markdown(notebooks, times, load_times)
    new_cells = _cells(table)
    old_cells = _cells(rest.split(END, 1)[0])
    lost = [f"{c} ({m} mode, {t})" for (c, m), t in old_cells.items() if t != "–" and new_cells.get((c, m)) == "–"]
    if lost:
        raise InputError(
            f"{path}: {times} has no time for {', '.join(lost)}; the table keeps its measured times "
            "(record them with scripts/reproduce, or name the chapter-times file that has them)"
        )
    new = f"{head}{BEGIN}\n{table}{END}{rest.split(END, 1)[1]}"
    if new == text:
        return False
    atomic_write_text(path, new)
    return True


def times_block(path: str | Path) -> str:
    """The text between the markers in ``path`` as stored (for the tests)."""
    text = Path(path).read_text()
    return text.split(BEGIN, 1)[1].split(END, 1)[0].removeprefix("\n")
