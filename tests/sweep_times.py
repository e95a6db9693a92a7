"""Fault-sweep rows (tests/sweep.py format) for the chapter times of ``python -m lab.course``
(``record-times``, which scripts/reproduce runs, and ``chapter-times``, scripts/chapter-times).

Every case's folder holds a course of one chapter (``nb/01_a.ipynb``), its measured times
(``times.csv``), a README whose time table was made from them (``README.md``), and one run
of the chapter as scripts/reproduce leaves it (``01_a.ipynb`` with ``01_a.ipynb.time``).
A file that is not a chapter-times CSV is never overwritten, a measured time in the README
is never replaced by a dash, and a bad number names its file, line and column; no traceback.
The line under the table on a busy machine comes from ``--load-times`` (default
``benchmarks/chapter_load.csv``, relative to the case's folder: left out when missing); a
bad file there is refused the same way, before the README is touched.
"""

from pathlib import Path

from sweep import Case

TIMES = "chapter,quick_s,full_s,full_date,full_machine,full_load,full_jobs\n01_a.ipynb,,30.0,2026-01-01,2 CPUs,1.0,2\n"
#: Two chapters' quick runs alone and beside two CPU-bound processes (benchmarks/bench_chapter_load.py).
LOAD = (
    "chapter,quick_idle_s,quick_loaded_s,ratio,load,date,machine\n"
    '03_c.ipynb,10.0,20.0,2.00,2,2026-01-02,"2 CPUs, Test CPU"\n'
    '04_d.ipynb,10.0,30.0,3.00,2,2026-01-02,"2 CPUs, Test CPU"\n'
)
RECORD = ["record-times", "--jobs", "1", "{dir}/01_a.ipynb"]
WRITE = ["chapter-times", "--notebooks", "{dir}/nb", "--write", "{dir}/README.md"]
KEPT = ("{dir}/README.md", "{dir}/times.csv", "{dir}/01_a.ipynb", "{dir}/01_a.ipynb.time")


def _course(d: Path) -> None:
    from lab.course.times import BEGIN, END, times_markdown

    (d / "nb").mkdir()
    (d / "nb" / "01_a.ipynb").write_text('{"cells": []}')
    (d / "times.csv").write_text(TIMES)
    block = times_markdown(d / "nb", d / "times.csv")
    (d / "README.md").write_text(f"# Course\n\n{BEGIN}\n{block}{END}\n")
    (d / "01_a.ipynb").write_text('{"cells": [], "metadata": {"papermill": {"parameters": {}}}}')
    (d / "01_a.ipynb.time").write_text("1000.0 1012.5 0.7\n")


def _with(name: str, content: str | bytes):
    def setup(d: Path):
        _course(d)
        path = d / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content) if isinstance(content, bytes) else path.write_text(content)

    return setup


def _says(*words: str):
    """The README's table keeps its time and has the load line with these words (none: no line)."""

    def after(d: Path) -> None:
        text = (d / "README.md").read_text()
        assert "| `01_a.ipynb` | – | 30 s |" in text, text
        assert ("Under load:" in text) == bool(words) and all(w in text for w in words), text

    return after


def _recorded(d: Path) -> None:
    text = (d / "new.csv").read_text()
    assert text.startswith("chapter,") and "01_a.ipynb,,12.5," in text, text


BINARY = bytes(range(128, 256)) * 4
CASES = [
    # --- record-times never overwrites a file that is not a chapter-times CSV ---------------
    Case(
        "times-record-ok",
        [*RECORD, "--times", "{dir}/new.csv"],
        0,
        ("01_a.ipynb: full mode, 12.5 s",),
        KEPT,
        setup=_course,
        after=_recorded,
    ),  # fmt: skip
    Case(
        "times-record-over-a-note",
        [*RECORD, "--times", "{dir}/note.txt"],
        2,
        ("note.txt: not a chapter-times CSV", "'a note to self'"),
        ("{dir}/note.txt", *KEPT),
        setup=_with("note.txt", "a note to self\n"),
    ),  # fmt: skip
    Case(
        "times-record-over-a-notebook",
        [*RECORD, "--times", "{dir}/nb.ipynb"],
        2,
        ("nb.ipynb: not a chapter-times CSV",),
        ("{dir}/nb.ipynb", *KEPT),
        setup=_with("nb.ipynb", '{"cells": [], "metadata": {}, "nbformat": 4, "nbformat_minor": 5}\n'),
    ),  # fmt: skip
    Case(
        "times-record-over-an-unknown-column",
        [*RECORD, "--times", "{dir}/t.csv"],
        2,
        ("t.csv: not a chapter-times CSV", "unknown: my_notes"),
        ("{dir}/t.csv", *KEPT),
        setup=_with("t.csv", "chapter,full_s,my_notes\n01_a.ipynb,30.0,keep me\n"),
    ),  # fmt: skip
    Case(
        "times-record-over-a-binary-file",
        [*RECORD, "--times", "{dir}/b.csv"],
        2,
        ("b.csv: not a chapter-times CSV (not UTF-8 text",),
        ("{dir}/b.csv", *KEPT),
        setup=_with("b.csv", BINARY),
    ),  # fmt: skip
    Case(
        "times-record-into-a-folder",
        [*RECORD, "--times", "{dir}/nb"],
        2,
        ("nb: a folder, not a chapter-times CSV",),
        KEPT,
        setup=_course,
    ),  # fmt: skip
    Case(
        "times-record-jobs-zero",
        ["record-times", "--jobs", "0", "--times", "{dir}/new.csv", "{dir}/01_a.ipynb"],
        2,
        ("jobs must be >= 1",),
        KEPT,
        setup=_course,
        absent=("{dir}/new.csv",),
    ),  # fmt: skip
    # --- a garbage .time file beside the executed chapter -----------------------------------
    Case(
        "times-record-garbage-time",
        [*RECORD, "--times", "{dir}/times.csv"],
        2,
        ("01_a.ipynb.time, line 1: not a time record", "'garbage, not times'"),
        KEPT,
        setup=_with("01_a.ipynb.time", "garbage, not times\n"),
    ),  # fmt: skip
    Case(
        "times-record-binary-time",
        [*RECORD, "--times", "{dir}/times.csv"],
        2,
        ("01_a.ipynb.time: not a time record", "not UTF-8 text"),
        KEPT,
        setup=_with("01_a.ipynb.time", BINARY),
    ),  # fmt: skip
    Case(
        "times-record-backwards-time",
        [*RECORD, "--times", "{dir}/times.csv"],
        2,
        ("01_a.ipynb.time, line 1: not a time record", "'1012.5 1000.0'"),
        KEPT,
        setup=_with("01_a.ipynb.time", "1012.5 1000.0\n"),
    ),  # fmt: skip
    Case(
        "times-record-no-time",
        [*RECORD, "--times", "{dir}/times.csv"],
        2,
        ("01_a.ipynb.time is missing",),
        KEPT[:3],
        setup=lambda d: (_course(d), (d / "01_a.ipynb.time").unlink()),
    ),  # fmt: skip
    Case(
        "times-record-beside-missing",
        [*RECORD, "--times", "{dir}/new.csv", "--beside", "{dir}/full.csv"],
        2,
        ("full.csv: no such file",),
        KEPT,
        setup=_course,
        absent=("{dir}/new.csv",),
    ),  # fmt: skip
    # --- chapter-times never replaces measured times with dashes ----------------------------
    Case(
        "times-write-missing-times",
        [*WRITE, "--times", "{dir}/missing.csv"],
        2,
        ("missing.csv: no such file (a chapter-times CSV)",),
        KEPT,
        setup=_course,
    ),  # fmt: skip
    Case(
        "times-write-a-chapter-lost",
        [*WRITE, "--times", "{dir}/other.csv"],
        2,
        ("other.csv has no time for 01_a.ipynb (full mode, 30 s)", "keeps its measured times"),
        ("{dir}/other.csv", *KEPT),
        setup=_with("other.csv", "chapter,quick_s,full_s\n"),
    ),  # fmt: skip
    Case(
        "times-write-binary-target",
        ["chapter-times", "--notebooks", "{dir}/nb", "--times", "{dir}/times.csv", "--write", "{dir}/b.md"],
        2,
        ("b.md: not a Markdown file (not UTF-8 text",),
        ("{dir}/b.md", *KEPT),
        setup=_with("b.md", BINARY),
    ),  # fmt: skip
    Case(
        "times-write-binary-times",
        [*WRITE, "--times", "{dir}/b.csv"],
        2,
        ("b.csv: not a chapter-times CSV",),
        ("{dir}/b.csv", *KEPT),
        setup=_with("b.csv", BINARY),
    ),  # fmt: skip
    # --- a non-number in chapter_times.csv: its file, line and column -----------------------
    Case(
        "times-print-not-a-number",
        ["chapter-times", "--notebooks", "{dir}/nb", "--times", "{dir}/times.csv"],
        2,
        ("times.csv, line 2, column full_s: 'half a minute' is not a finite number >= 0",),
        KEPT,
        setup=_with("times.csv", TIMES.replace("30.0", "half a minute")),
    ),  # fmt: skip
    Case(
        "times-write-not-a-number",
        [*WRITE, "--times", "{dir}/times.csv"],
        2,
        ("times.csv, line 2, column full_load: 'high' is not a finite number >= 0",),
        KEPT,
        setup=_with("times.csv", TIMES.replace("1.0,2", "high,2")),
    ),  # fmt: skip
    Case(
        "times-print-bad-jobs",
        ["chapter-times", "--notebooks", "{dir}/nb", "--times", "{dir}/times.csv"],
        2,
        ("times.csv, line 2, column full_jobs: '1.5' is not a count of chapters >= 1",),
        KEPT,
        setup=_with("times.csv", TIMES.replace("1.0,2", "1.0,1.5")),
    ),  # fmt: skip
    Case(
        "times-print-ragged-row",
        ["chapter-times", "--notebooks", "{dir}/nb", "--times", "{dir}/times.csv"],
        2,
        ("times.csv, line 3: 2 fields where its header has 7",),
        KEPT,
        setup=_with("times.csv", TIMES + "02_b.ipynb,1\n"),
    ),  # fmt: skip
    # --- the line under the table: how much a busy machine stretched the quick runs ---------
    Case(
        "times-write-load-times",
        [*WRITE, "--times", "{dir}/times.csv", "--load-times", "{dir}/load.csv"],
        0,
        ("README.md: rewritten",),
        ("{dir}/times.csv", "{dir}/load.csv"),
        setup=_with("load.csv", LOAD),
        after=_says("with 2 other CPU-bound processes running beside it, a quick run took 2.5× as long", "load.csv`"),
    ),  # fmt: skip
    Case(
        "times-write-default-load-times",
        [*WRITE, "--times", "{dir}/times.csv"],
        0,
        ("README.md: rewritten",),
        ("{dir}/times.csv", "{dir}/benchmarks/chapter_load.csv"),
        setup=_with("benchmarks/chapter_load.csv", LOAD),
        after=_says("(median of chapters 03 and 04; range 2.0–3.0×; 2026-01-02", "`benchmarks/chapter_load.csv`"),
    ),  # fmt: skip
    Case(
        "times-write-no-load-times",
        [*WRITE, "--times", "{dir}/times.csv"],
        0,
        ("README.md: up to date",),
        KEPT,
        setup=_course,
        after=_says(),
    ),  # fmt: skip
    Case(
        "times-write-load-times-missing",
        [*WRITE, "--times", "{dir}/times.csv", "--load-times", "{dir}/load.csv"],
        2,
        ("load.csv: no such file (a chapter-load CSV",),
        KEPT,
        setup=_course,
    ),  # fmt: skip
    Case(
        "times-write-load-times-a-folder",
        [*WRITE, "--times", "{dir}/times.csv", "--load-times", "{dir}/nb"],
        2,
        ("nb: a folder, not a chapter-load CSV",),
        KEPT,
        setup=_course,
    ),  # fmt: skip
    Case(
        "times-write-load-times-binary",
        [*WRITE, "--times", "{dir}/times.csv", "--load-times", "{dir}/b.csv"],
        2,
        ("b.csv: not a chapter-load CSV", "not UTF-8 text"),
        ("{dir}/b.csv", *KEPT),
        setup=_with("b.csv", BINARY),
    ),  # fmt: skip
    Case(
        "times-write-load-times-is-chapter-times",
        [*WRITE, "--times", "{dir}/times.csv", "--load-times", "{dir}/times.csv"],
        2,
        ("times.csv, line 1: not a chapter-load CSV", "its header must be chapter,quick_idle_s,"),
        KEPT,
        setup=_course,
    ),  # fmt: skip
    Case(
        "times-write-load-times-bad-ratio",
        [*WRITE, "--times", "{dir}/times.csv", "--load-times", "{dir}/load.csv"],
        2,
        ("load.csv, line 3, column ratio: '2.50' is not quick_loaded_s / quick_idle_s (3.00)",),
        ("{dir}/load.csv", *KEPT),
        setup=_with("load.csv", LOAD.replace("3.00", "2.50")),
    ),  # fmt: skip
    Case(
        "times-print-load-times-not-a-number",
        ["chapter-times", "--notebooks", "{dir}/nb", "--times", "{dir}/times.csv", "--load-times", "{dir}/load.csv"],
        2,
        ("load.csv, line 2, column quick_loaded_s: 'slow' is not a finite number > 0",),
        ("{dir}/load.csv", *KEPT),
        setup=_with("load.csv", LOAD.replace("20.0", "slow")),
    ),  # fmt: skip
    Case(
        "times-write-load-times-mixed-loads",
        [*WRITE, "--times", "{dir}/times.csv", "--load-times", "{dir}/load.csv"],
        2,
        ("load.csv, line 3, column load: 4 where line 2 has 2", "one load per file"),
        ("{dir}/load.csv", *KEPT),
        setup=_with("load.csv", LOAD.replace("3.00,2,", "3.00,4,")),
    ),  # fmt: skip
    Case(
        "times-write-default-load-times-bad",
        [*WRITE, "--times", "{dir}/times.csv"],
        2,
        ("benchmarks/chapter_load.csv, line 2, column date: '02/01/2026' is not a date (YYYY-MM-DD)",),
        ("{dir}/benchmarks/chapter_load.csv", *KEPT),
        setup=_with("benchmarks/chapter_load.csv", LOAD.replace("2026-01-02", "02/01/2026", 1)),
    ),  # fmt: skip
    Case(
        "times-write-load-times-header-only",
        [*WRITE, "--times", "{dir}/times.csv", "--load-times", "{dir}/load.csv"],
        2,
        ("load.csv: no chapter measured",),
        ("{dir}/load.csv", *KEPT),
        setup=_with("load.csv", LOAD.splitlines()[0] + "\n"),
    ),  # fmt: skip
]
TIMES_CASES = [Case(**{**c.__dict__, "module": "lab.course"}) for c in CASES]
