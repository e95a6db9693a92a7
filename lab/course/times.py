"""How long each chapter takes to run, as measured by ``scripts/reproduce``, and its table.

``figures/chapter_times.csv`` has one row per chapter and, per mode (quick, full), the
seconds, the date, the machine (CPUs usable and their model), the 1-minute load average
when the chapter ended and how many chapters ran at once. The seconds are the wall time
of the chapter's whole papermill run, kernel start-up included -- what a student waits
for *Run All* -- not papermill's own record of the cells (which leaves the start out and
read 6 s for a chapter that took 24 s on a loaded machine).

:func:`record_times` adds a run's chapters to the CSV (``scripts/reproduce``);
:func:`times_markdown` renders the table with a sentence on the machine and load;
:func:`write_times_block` replaces it between ``<!-- chapter-times -->`` and
``<!-- /chapter-times -->`` in the README and docs/course.md (``scripts/chapter-times
--write``; tests/test_student_path.py fails when they differ from the CSV).
"""

from __future__ import annotations

import csv
import datetime
import io
import json
import os
import platform
from pathlib import Path

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


def read_times(path: str | Path) -> dict[str, dict]:
    """The CSV's rows by chapter (strings; a column an older file lacks is ""); {} when absent."""
    path = Path(path)
    if not path.exists():
        return {}
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    if rows and "chapter" not in rows[0]:
        raise InputError(f"{path}: not a chapter-times file (no 'chapter' column)")
    return {r["chapter"]: {c: r.get(c) or "" for c in COLUMNS} for r in rows}


def record_times(path: str | Path, executed: list[str | Path], jobs: int) -> None:
    """Add the chapters of one ``scripts/reproduce`` run to the CSV at ``path``.

    ``executed``: papermill's output notebooks; beside each, ``NAME.time`` holds the run's
    start and end (seconds since the epoch) and the 1-minute load average at its end, as
    ``scripts/reproduce`` wrote them. The mode is the notebook's ``quick`` parameter.
    """
    rows = read_times(path)
    machine, today = machine_name(), datetime.date.today().isoformat()
    for nb in map(Path, executed):
        try:
            meta = json.loads(nb.read_text())["metadata"]["papermill"]
            start, end, *load = Path(f"{nb}.time").read_text().replace(",", ".").split()
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise InputError(f"{nb}: no papermill record or time of this run ({type(e).__name__}: {e})") from None
        mode = "quick" if str(meta.get("parameters", {}).get("quick", False)) in ("True", "true", "1") else "full"
        row = rows.setdefault(nb.name, dict.fromkeys(COLUMNS, "") | {"chapter": nb.name})
        row |= {
            f"{mode}_s": f"{float(end) - float(start):.1f}",
            f"{mode}_date": today,
            f"{mode}_machine": machine,
            f"{mode}_load": load[0] if load else "",
            f"{mode}_jobs": str(jobs),
        }
    out = io.StringIO()
    w = csv.DictWriter(out, COLUMNS, lineterminator="\n")
    w.writeheader()
    w.writerows(rows[k] for k in sorted(rows))
    atomic_write_text(path, out.getvalue())


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


def times_markdown(notebooks: str | Path, times: str | Path) -> str:
    """The time per chapter in quick and full mode, as Markdown.

    Parameters
    ----------
    notebooks : str or pathlib.Path
        The folder of the chapters (every ``NN_name.ipynb`` in it gets a row).
    times : str or pathlib.Path
        The CSV of measured times (s).

    Returns
    -------
    str
        A Markdown table and a sentence per mode on how it was measured.
    """
    from lab.course.edition import CHAPTER_NAME

    rows = read_times(times)
    names = sorted(p.name for p in Path(notebooks).glob("[0-9][0-9]_*.ipynb") if CHAPTER_NAME.fullmatch(p.name))
    lines = ["| chapter | quick mode | full mode |", "|---|---|---|"]
    for name in names:
        r = rows.get(name, dict.fromkeys(COLUMNS, ""))
        lines.append(f"| `{name}` | {_seconds(r['quick_s'])} | {_seconds(r['full_s'])} |")
    known = [rows[n] for n in names if n in rows]
    return "\n".join([*lines, "", *(f"- {_conditions(known, m)}" for m in MODES)]) + "\n"


def write_times_block(path: str | Path, notebooks: str | Path, times: str | Path) -> bool:
    """Replace the text between ``<!-- chapter-times -->`` and ``<!-- /chapter-times -->`` in
    the Markdown file ``path`` by :func:`times_markdown`; True when it changed."""
    path = Path(path)
    text = path.read_text()
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise InputError(f"{path}: needs one {BEGIN} ... {END} block for the chapter times")
    head, rest = text.split(BEGIN)
    new = f"{head}{BEGIN}\n{times_markdown(notebooks, times)}{END}{rest.split(END, 1)[1]}"
    if new == text:
        return False
    atomic_write_text(path, new)
    return True


def times_block(path: str | Path) -> str:
    """The text between the markers in ``path`` as stored (for the tests)."""
    text = Path(path).read_text()
    return text.split(BEGIN, 1)[1].split(END, 1)[0].removeprefix("\n")
