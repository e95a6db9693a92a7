"""The student's way in: the student edition by default, never over a student's work;
chapter 00 readable before it runs; the README's chapter times from the measured run.

The rebuild cases run ``lab.course.edition.build_student_edition`` on small made-up
chapters (version 1, then version 2 of the same chapters): an edited notebook survives,
its chapter's new edition goes beside it, an unedited one is refreshed, a corrupt one is
kept and named, a second build is refused while one runs, and a build stopped by Ctrl-C or
kill -9 leaves every notebook whole and the next build finishes the job. These are the
fault-sweep rows of the student command; they live here because the sweep runs only
``python -m lab`` commands.
"""

import csv
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from filelock import FileLock
from helpers import default_sigint, subprocess_env

from lab.course.commands import main
from lab.course.edition import LOCK, MANIFEST, build_student_edition, edition_text
from lab.course.load_times import LOAD_TIMES
from lab.course.syllabus import SYLLABUS_CELL, exercises_of, syllabus_markdown
from lab.course.times import record_times, times_block, times_markdown
from lab.errors import InputError

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.timeout(120)
NAMES = ("01_a.ipynb", "02_b.ipynb", "03_c.ipynb")


def _chapter(version: int) -> str:
    cells = [
        {"cell_type": "code", "metadata": {"tags": ["parameters"]}, "outputs": [], "execution_count": None,
         "source": ['data_path = "../data/x.csv"\n']},
        {"cell_type": "markdown", "metadata": {}, "source": [f"**Exercise 1.1 — doubling, v{version}.** Write `f`."]},
        {"cell_type": "code", "metadata": {"tags": ["solution"]}, "outputs": [], "execution_count": 3,
         "source": ['def f(x):\n', '    """Twice x."""\n', f"    return x * 2 + {version} - {version}\n"]},
        {"cell_type": "code", "metadata": {"tags": ["grader"]}, "outputs": [], "execution_count": 4,
         "source": ["check(f)\n"]},
    ]  # fmt: skip
    return json.dumps({"cells": cells, "metadata": {}, "nbformat": 4, "nbformat_minor": 5})


def _sources(d: Path, version: int) -> Path:
    d.mkdir(exist_ok=True)
    for name in NAMES:
        (d / name).write_text(_chapter(version))
    return d


def _edition(src: Path, name: str) -> str:
    return edition_text(src / name, "../")[0]


def _no_temporaries(out: Path):
    assert not list(out.glob(".*.tmp*")), list(out.glob(".*.tmp*"))


def test_rebuild_refreshes_unedited_notebooks_and_keeps_edited_ones(tmp_path):
    src, out = _sources(tmp_path / "notebooks", 1), tmp_path / "build" / "student"
    assert build_student_edition(src, out)[-1] == f"student edition in {out}/: 3 notebooks (3 new)"
    assert (out / "01_a.ipynb").read_text() == _edition(src, "01_a.ipynb")
    assert "NotImplementedError" in (out / "01_a.ipynb").read_text() and "x * 2" not in (out / "01_a.ipynb").read_text()
    assert '"../../data/x.csv' in (out / "01_a.ipynb").read_text()  # still finds data/ from build/student/
    mine = (out / "01_a.ipynb").read_text().replace("raise NotImplementedError", "return 2 * x  # mine")
    (out / "01_a.ipynb").write_text(mine)
    # the chapters unchanged: the edited notebook is kept and nothing is written beside it
    said = build_student_edition(src, out)
    assert (out / "01_a.ipynb").read_text() == mine and not (out / "01_a.updated.ipynb").exists()
    assert said[0].startswith(f"{out / '01_a.ipynb'}: kept as it is") and "2 unchanged, 1 kept" in said[-1]
    # the chapters changed: unedited ones refreshed, the edited one kept, its new edition beside it
    _sources(src, 2)
    said = build_student_edition(src, out)
    assert (out / "01_a.ipynb").read_text() == mine
    assert (out / "01_a.updated.ipynb").read_text() == _edition(src, "01_a.ipynb")
    assert (out / "02_b.ipynb").read_text() == _edition(src, "02_b.ipynb")
    assert f"its new edition is {out / '01_a.updated.ipynb'}" in said[0] and "2 refreshed, 1 kept" in said[-1]
    # again, changed: the unedited .updated is refreshed; once edited, the next goes to -2
    _sources(src, 3)
    build_student_edition(src, out)
    assert (out / "01_a.updated.ipynb").read_text() == _edition(src, "01_a.ipynb")
    (out / "01_a.updated.ipynb").write_text(mine + " ")
    _sources(src, 4)
    said = build_student_edition(src, out)
    assert (out / "01_a.updated.ipynb").read_text() == mine + " " and (out / "01_a.ipynb").read_text() == mine
    assert (out / "01_a.updated-2.ipynb").read_text() == _edition(src, "01_a.ipynb")
    _no_temporaries(out)
    # a deleted notebook comes back fresh; a manifest that is unreadable keeps everything
    (out / "02_b.ipynb").unlink()
    (out / MANIFEST).write_text("{")
    (out / "03_c.ipynb").write_text(_edition(src, "03_c.ipynb").replace("Twice", "Thrice"))
    said = build_student_edition(src, out)
    assert (out / "02_b.ipynb").read_text() == _edition(src, "02_b.ipynb")
    assert "Thrice" in (out / "03_c.ipynb").read_text() and any(MANIFEST in line for line in said)


def test_a_corrupt_student_notebook_is_kept_and_named(tmp_path, capsys):
    src, out = _sources(tmp_path / "notebooks", 1), tmp_path / "student"
    build_student_edition(src, out)
    (out / "02_b.ipynb").write_text('{"cells": [')  # a half-saved file
    _sources(src, 2)
    assert main(["student-edition", "--notebooks", str(src), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if "02_b.ipynb:" in x)
    assert "kept as it is" in line and "not valid JSON" in line and "02_b.updated.ipynb" in line, err
    assert (out / "02_b.ipynb").read_text() == '{"cells": ['
    assert "Traceback" not in err


def test_a_second_build_is_refused_while_one_runs(tmp_path, capsys):
    src, out = _sources(tmp_path / "notebooks", 1), tmp_path / "student"
    out.mkdir()
    held = FileLock(out / LOCK, timeout=0)
    held.acquire()
    try:
        assert main(["student-edition", "--notebooks", str(src), "--out", str(out)]) == 2
    finally:
        held.release()
    err = capsys.readouterr().err
    assert "error:" in err and "being built by another run" in err and "Traceback" not in err
    assert not (out / "01_a.ipynb").exists()
    assert main(["student-edition", "--notebooks", str(src), "--out", str(out)]) == 0  # and afterwards it works
    with pytest.raises(InputError, match="overwrite the source chapters"):
        build_student_edition(src, src)


def test_bad_sources_and_folders_are_refused_before_anything_is_written(tmp_path, capsys):
    src, out = _sources(tmp_path / "notebooks", 1), tmp_path / "student"
    (src / "02_b.ipynb").write_text("not a notebook")
    (tmp_path / "file").write_text("x")
    (tmp_path / "empty").mkdir()
    cases = [
        (["--notebooks", str(src), "--out", str(out)], "02_b.ipynb: not a notebook"),
        (["--notebooks", str(tmp_path / "empty"), "--out", str(out)], "no chapter notebooks"),
        (["--notebooks", str(src), "--out", str(tmp_path / "file")], "cannot hold the student edition"),
    ]
    for argv, words in cases:
        assert main(["student-edition", *argv]) == 2, argv
        err = capsys.readouterr().err
        assert words in err and "Traceback" not in err, err
    assert not any(out.glob("*.ipynb")) and (tmp_path / "file").read_text() == "x"


def test_student_with_a_root_folder_is_refused():
    for opt in ("--notebook-dir=/tmp", "--ServerApp.root_dir=/tmp"):
        r = subprocess.run(["bash", str(ROOT / "scripts" / "jupyter"), "--student", opt], capture_output=True,
                           text=True, timeout=30)  # fmt: skip
        assert r.returncode == 2, r.stderr
        assert "--student" in r.stderr and opt.split("=")[0] in r.stderr and "Traceback" not in r.stderr


#: A build that is stopped half-way through writing its second notebook: half of it is in
#: the temporary file when the signal comes.
STOPPED_BUILD = """
import os, signal, sys
import lab.course.edition as ed
from lab.files import atomic_open

how, src, out = sys.argv[1:]
written = []


def write(path, text, seen):
    written.append(path)
    if len(written) == 2:
        with atomic_open(path) as fh:
            fh.write(text[: len(text) // 2])
            fh.flush()
            os.kill(os.getpid(), signal.SIGKILL if how == "kill" else signal.SIGINT)
            fh.write(text[len(text) // 2 :])
    return real(path, text, seen)


real, ed.replace_unless_changed = ed.replace_unless_changed, write
from lab.course.commands import main

sys.exit(main(["student-edition", "--notebooks", src, "--out", out]))
"""


@pytest.mark.parametrize("how", ["kill", "ctrl-c"])
def test_a_stopped_build_leaves_whole_notebooks_and_the_next_one_finishes(tmp_path, how):
    src, out = _sources(tmp_path / "notebooks", 1), tmp_path / "student"
    build_student_edition(src, out)
    old = {n: (out / n).read_text() for n in NAMES}
    _sources(src, 2)
    new = {n: _edition(src, n) for n in NAMES}
    r = subprocess.run([sys.executable, "-c", STOPPED_BUILD, how, str(src), str(out)], capture_output=True, text=True,
                       timeout=60, env=subprocess_env(), preexec_fn=default_sigint)  # fmt: skip
    if how == "kill":
        assert r.returncode == -signal.SIGKILL, r.stderr
    else:
        assert r.returncode == 130 and "interrupted" in r.stderr and "Traceback" not in r.stderr, r.stderr
        _no_temporaries(out)
    for n in NAMES:  # every notebook whole: the old edition or the new one
        assert (out / n).read_text() in (old[n], new[n]), n
    assert sum((out / n).read_text() == new[n] for n in NAMES) == 1  # the first was written, the second stopped
    # the next build, after the chapters changed once more: every notebook is ours (as it was or
    # as the stopped build wrote it), so each is refreshed, none kept as if the student had edited it
    _sources(src, 3)
    said = build_student_edition(src, out)
    assert all((out / n).read_text() == _edition(src, n) for n in NAMES), said
    assert not list(out.glob("*.updated*")) and "kept" not in said[-1], said
    _no_temporaries(out)


def test_the_course_edition_holds_chapter_00_and_finds_data_and_figures(tmp_path):
    """build/student/ is one level deeper than notebooks/: every relative path of a parameters
    cell must point at the same file from there."""
    import ast

    build_student_edition(ROOT / "notebooks", tmp_path / "student")
    assert (tmp_path / "student" / "00_course.ipynb").exists()
    for nb in sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb")):
        pairs = []
        for cells, base in ((json.loads(nb.read_text())["cells"], ROOT / "notebooks"),
                            (json.loads(edition_text(nb, "../")[0])["cells"], ROOT / "build" / "student")):  # fmt: skip
            params = next(c for c in cells if "parameters" in c.get("metadata", {}).get("tags", []))
            tree = ast.parse("".join(params["source"]))
            strings = [n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)]
            pairs.append([os.path.normpath(base / s) for s in strings if s.startswith("../")])
        assert pairs[0] == pairs[1] and pairs[0], nb.name


def test_readme_and_course_page_show_the_measured_times():
    """The table from figures/chapter_times.csv, and the line under it from
    benchmarks/chapter_load.csv (how much a busy machine stretched the quick runs)."""
    expected = times_markdown(ROOT / "notebooks", ROOT / "figures" / "chapter_times.csv", ROOT / LOAD_TIMES)
    for page in ("README.md", "docs/course.md"):
        assert times_block(ROOT / page) == expected, (
            f"{page}: the time-per-chapter table is not figures/chapter_times.csv's and {LOAD_TIMES}'s; "
            "run scripts/chapter-times --write"
        )
    if (ROOT / LOAD_TIMES).exists():
        assert f"`{LOAD_TIMES}`" in expected  # the line names its file


def test_chapter_00_shows_the_current_syllabus_before_it_runs():
    nb = json.loads((ROOT / "notebooks" / "00_course.ipynb").read_text())
    cells = [c for c in nb["cells"] if c.get("metadata", {}).get("lab", {}).get("generated") == SYLLABUS_CELL]
    assert len(cells) == 1 and cells[0]["cell_type"] == "markdown"
    assert "".join(cells[0]["source"]) == syllabus_markdown(ROOT / "notebooks"), (
        "chapter 00's stored syllabus is stale (a chapter's title, exercises or solution functions changed): "
        "run scripts/chapter-times --write"
    )
    # every chapter's every exercise is listed with the function the student writes
    text = "".join(cells[0]["source"])
    for ch in sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))[1:]:
        for number, title, functions in exercises_of(json.loads(ch.read_text())["cells"]):
            assert f"{number} {title}" in text and functions and all(f"`{f}`" in text for f in functions), number


def test_students_are_told_the_student_command_and_the_paper():
    readme = (ROOT / "README.md").read_text()
    quick = readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    assert "```\nscripts/jupyter --student\n```" in quick and "```\nscripts/jupyter\n```" in quick
    intro = "".join(json.loads((ROOT / "notebooks" / "00_course.ipynb").read_text())["cells"][0]["source"])
    assert "scripts/jupyter --student" in intro and "shared/paper" not in intro
    doi = "https://doi.org/10.1109/RoboSoft48309.2020.9116011"
    assert doi in intro and doi in readme


def test_record_times_keeps_the_wall_time_and_the_conditions(tmp_path):
    csv_path = tmp_path / "chapter_times.csv"
    csv_path.write_text("chapter,quick_s,full_s,quick_date,full_date\n01_a.ipynb,,30.0,,2026-01-01\n")
    executed = tmp_path / "01_a.ipynb"
    meta = {"papermill": {"duration": 6.0, "parameters": {"quick": True}}}
    executed.write_text(json.dumps({"cells": [], "metadata": meta}))
    Path(f"{executed}.time").write_text("1000,25 1024,50 1.87\n")  # a comma locale's decimal mark
    record_times(csv_path, [executed], jobs=2)
    with csv_path.open(newline="") as fh:
        r = next(csv.DictReader(fh))
    assert r["quick_s"] == "24.2" and r["full_s"] == "30.0" and r["quick_load"] == "1.87" and r["quick_jobs"] == "2"
    assert "CPUs" in r["quick_machine"] and r["full_machine"] == ""
    (tmp_path / "nb").mkdir()
    (tmp_path / "nb" / "01_a.ipynb").write_text("{}")
    table = times_markdown(tmp_path / "nb", csv_path)
    assert "| `01_a.ipynb` | 24 s | 30 s |" in table
    assert "Quick mode: 1 chapter," in table and "load average 1.9" in table and "machine not recorded" in table
    with pytest.raises(InputError, match="01_b.ipynb"):
        record_times(csv_path, [tmp_path / "01_b.ipynb"], jobs=1)
