"""``python -m lab.course``: the course's housekeeping, as the scripts call it.

    python -m lab.course student-edition [--notebooks DIR] [--out DIR]
        the student edition into build/student/, keeping the student's work
        (scripts/student-edition, scripts/jupyter --student)
    python -m lab.course chapter-times [--write [FILE ...]] [--times CSV] [--load-times CSV]
        print the time-per-chapter table; --write rewrites the generated course text:
        the tables in README.md and docs/course.md, chapter 00's syllabus (scripts/chapter-times);
        under the table, how much a busy machine stretched the quick runs, from --load-times
        (default benchmarks/chapter_load.csv, left out when that file is missing)
    python -m lab.course record-times --jobs N [--times CSV] [--beside CSV] EXECUTED.ipynb ...
        add a run's chapter times to figures/chapter_times.csv (scripts/reproduce; a run of
        some chapters only writes build/chapter_times.partial.csv, beside the full run's)

These are not ``python -m lab`` commands: they serve the repository's scripts and run from
its root (the default paths are relative to it). Errors print ``error: <message>`` and exit
2 (bad input) or 1 without a traceback; Ctrl-C exits 130 and leaves no half-written file.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from lab.errors import EXIT_INTERRUPTED, EXIT_RUNTIME, InputError, LabError

__all__ = ["main"]

GENERATED = ("README.md", "docs/course.md", "notebooks/00_course.ipynb")


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m lab.course", description="the course's housekeeping (scripts/)")
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("student-edition", help="write the student edition, keeping the student's work")
    s.add_argument("--notebooks", default="notebooks", help="the source chapters (default: notebooks)")
    s.add_argument("--out", default="build/student", help="the edition's folder (default: build/student)")
    t = sub.add_parser("chapter-times", help="the time-per-chapter table (and the generated course text)")
    t.add_argument("--write", nargs="*", metavar="FILE", help=f"rewrite these (none named: {', '.join(GENERATED)})")
    t.add_argument("--times", default="figures/chapter_times.csv", help="the measured times")
    t.add_argument("--notebooks", default="notebooks", help="the chapters")
    t.add_argument(
        "--load-times",
        metavar="CSV",
        help="quick runs idle and under load, from benchmarks/bench_chapter_load.py (default: "
        "benchmarks/chapter_load.csv, no line under the table when it is missing; a file named here must exist)",
    )
    r = sub.add_parser("record-times", help="add a scripts/reproduce run's chapter times to the CSV")
    r.add_argument("executed", nargs="+", help="papermill's output notebooks (NAME.time beside each)")
    r.add_argument("--jobs", type=int, required=True, help="chapters run at a time")
    r.add_argument("--times", default="figures/chapter_times.csv", help="the chapter-times CSV to update")
    r.add_argument("--beside", metavar="CSV", help="show each time beside this chapter-times CSV's (a full run's)")
    return p


def _load_times(named: str | None) -> str:
    """The chapter-load CSV: one named must exist and read; the default may be missing."""
    from lab.course.load_times import LOAD_TIMES, load_sentence

    load_sentence(named or LOAD_TIMES, must_exist=named is not None)  # a bad file is refused here
    return named or LOAD_TIMES


def _write_generated(files: list[str], notebooks: str, times: str, load_times: str | None) -> None:
    from lab.course.syllabus import write_syllabus
    from lab.course.times import read_times, write_times_block

    for f in files or GENERATED:
        if not Path(f).is_file():
            raise InputError(f"{f}: no such file to write the course text into")
    if any(not f.endswith(".ipynb") for f in files or GENERATED):
        read_times(times, must_exist=True)  # a missing or bad CSV is refused before any file is written
        load_times = _load_times(load_times)
    for f in files or GENERATED:
        changed = write_syllabus(f) if f.endswith(".ipynb") else write_times_block(f, notebooks, times, load_times)
        print(f"{f}: {'rewritten' if changed else 'up to date'}", file=sys.stderr)


def _record(times: str, executed: list[str], jobs: int, beside: str | None) -> None:
    from lab.course.times import read_times, record_times

    full = read_times(beside, must_exist=True) if beside else {}
    for chapter, mode, seconds in record_times(times, executed, jobs):
        line = f"{chapter}: {mode} mode, {seconds:.1f} s -> {times}"
        if beside:
            was = full.get(chapter, {}).get(f"{mode}_s")
            line += f" (the last full run's, {beside}: {f'{float(was):.1f} s' if was else 'not measured'})"
        print(line, file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Run one housekeeping command; returns the exit code."""
    args = _parser().parse_args(argv)
    try:
        if args.command == "student-edition":
            from lab.course.edition import build_student_edition

            for line in build_student_edition(args.notebooks, args.out):
                print(f"lab: {line}", file=sys.stderr)
        elif args.command == "chapter-times":
            from lab.course.times import times_markdown

            if args.write is None:
                print(times_markdown(args.notebooks, args.times, _load_times(args.load_times)), end="")
            else:
                _write_generated(args.write, args.notebooks, args.times, args.load_times)
        else:
            _record(args.times, args.executed, args.jobs, args.beside)
    except LabError as e:
        print(f"error: {e}", file=sys.stderr)
        return e.exit_code
    except OSError as e:  # a full disk, a file that cannot be read or written
        print(f"error: {e}", file=sys.stderr)
        return EXIT_RUNTIME
    except KeyboardInterrupt:
        print("interrupted: no file was left half-written; run the command again", file=sys.stderr)
        return EXIT_INTERRUPTED
    return 0
