"""The student edition counts what the student wrote, not what JupyterLab touched.

tests/data/jupyterlab_saves/ holds a small chapter (``source.json``), its student edition
as written (``written.json``) and that edition saved by a real JupyterLab driven in
headless Chromium (``make_fixtures.py`` there made them): opened and autosaved
(``opened.json``: the kernel's ``language_info`` added, keys reordered), every cell run
and saved (``ran.json``: outputs, execution counts) and a solution written and saved
(``edited.json``). Only the last is the student's work. Then: a save that lands while the
edition is being rebuilt is kept; ``scripts/jupyter --student`` never serves the
solutions; ``python -m lab.course`` answers a solution cell that is not Python, and a
Ctrl-C while it starts, with one line and no traceback.
"""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import default_sigint, subprocess_env

import lab.course.edition as ed
from lab.course.commands import main
from lab.course.edition import build_student_edition, edition_text

ROOT = Path(__file__).resolve().parent.parent
SAVES = ROOT / "tests" / "data" / "jupyterlab_saves"
NAME = "01_doubling.ipynb"
pytestmark = pytest.mark.timeout(120)


def _course(tmp_path: Path, title: str = "Doubling") -> tuple[Path, Path]:
    """The fixture's chapter as the course (its title changed for a new version), and the
    folder of its student edition."""
    src = tmp_path / "notebooks"
    src.mkdir(parents=True, exist_ok=True)
    (src / NAME).write_text((SAVES / "source.json").read_text().replace("01 — Doubling", f"01 — {title}"))
    return src, tmp_path / "student"


def _save(out: Path, fixture: str) -> str:
    text = (SAVES / fixture).read_text()
    (out / NAME).write_text(text)
    return text


def test_the_fixture_is_this_edition_of_its_chapter():
    assert edition_text(SAVES / "source.json", "../")[0] == (SAVES / "written.json").read_text(), (
        "the student edition of tests/data/jupyterlab_saves/source.json changed: run its make_fixtures.py again"
    )
    opened = json.loads((SAVES / "opened.json").read_text())
    assert "version" in opened["metadata"]["language_info"]  # what JupyterLab's kernel added
    assert any(c.get("outputs") for c in json.loads((SAVES / "ran.json").read_text())["cells"])


@pytest.mark.parametrize("fixture", ["opened.json", "ran.json"])
def test_a_chapter_opened_run_and_saved_by_jupyterlab_is_not_an_edit(tmp_path, fixture):
    src, out = _course(tmp_path)
    build_student_edition(src, out)
    assert (out / NAME).read_text() == (SAVES / "written.json").read_text()
    saved = _save(out, fixture)
    # the course unchanged: nothing to do, the student's outputs stay
    said = build_student_edition(src, out)
    assert said[-1].endswith("(1 unchanged)") and (out / NAME).read_text() == saved, said
    # the course changed: refreshed, nothing forks
    _course(tmp_path, "Doubling, v2")
    said = build_student_edition(src, out)
    assert said[-1].endswith("(1 refreshed)"), said
    assert (out / NAME).read_text() == edition_text(src / NAME, "../")[0]
    assert not list(out.glob("*.updated*.ipynb"))


def _edit(cells: list) -> list:
    cells[2]["source"] = ["print('mine')\n"]
    return cells


@pytest.mark.parametrize(
    "change",
    [
        pytest.param(None, id="jupyterlab-edited-a-solution"),
        pytest.param(_edit, id="changed-a-given-cell"),
        pytest.param(lambda c: [*c, {"cell_type": "markdown", "metadata": {}, "source": "notes"}], id="added-a-cell"),
        pytest.param(lambda c: c[:-1], id="removed-a-cell"),
        pytest.param(lambda c: [*c[:3], {**c[3], "cell_type": "raw"}, *c[4:]], id="retyped-a-cell"),
    ],
)
def test_a_cell_the_student_changed_is_an_edit(tmp_path, change):
    src, out = _course(tmp_path)
    build_student_edition(src, out)
    if change is None:
        saved = _save(out, "edited.json")
    else:
        nb = json.loads((SAVES / "opened.json").read_text())
        nb["cells"] = change(nb["cells"])
        saved = json.dumps(nb, indent=1)
        (out / NAME).write_text(saved)
    said = build_student_edition(src, out)
    assert (out / NAME).read_text() == saved and said[-1].endswith("(1 kept)"), said
    _course(tmp_path, "Doubling, v2")
    said = build_student_edition(src, out)
    assert (out / NAME).read_text() == saved
    assert (out / "01_doubling.updated.ipynb").read_text() == edition_text(src / NAME, "../")[0]
    assert "kept as it is" in said[0] and "01_doubling.updated.ipynb" in said[0], said


def _saving_during_the_build(monkeypatch, out: Path, fixture: str):
    """JupyterLab's save of ``fixture`` landing after the edition decided what to write."""
    real = ed._plan

    def plan(*args, **kwargs):
        result = real(*args, **kwargs)
        _save(out, fixture)
        return result

    monkeypatch.setattr(ed, "_plan", plan)


def test_a_save_during_the_rebuild_is_kept(tmp_path, monkeypatch):
    src, out = _course(tmp_path)
    build_student_edition(src, out)
    _course(tmp_path, "Doubling, v2")
    _saving_during_the_build(monkeypatch, out, "edited.json")
    said = build_student_edition(src, out)
    assert (out / NAME).read_text() == (SAVES / "edited.json").read_text(), "the student's save was overwritten"
    assert (out / "01_doubling.updated.ipynb").read_text() == edition_text(src / NAME, "../")[0]
    assert "saved while the edition was being built" in said[0] and said[-1].endswith("(1 kept)"), said
    assert not list(out.glob(".*.tmp*"))
    # the next build knows the saved notebook as the student's, the .updated one as its own
    monkeypatch.undo()
    _course(tmp_path, "Doubling, v3")
    said = build_student_edition(src, out)
    assert (out / NAME).read_text() == (SAVES / "edited.json").read_text()
    assert (out / "01_doubling.updated.ipynb").read_text() == edition_text(src / NAME, "../")[0]
    assert not (out / "01_doubling.updated-2.ipynb").exists(), said


def test_an_autosave_during_the_rebuild_is_refreshed_all_the_same(tmp_path, monkeypatch):
    src, out = _course(tmp_path)
    build_student_edition(src, out)
    _course(tmp_path, "Doubling, v2")
    _saving_during_the_build(monkeypatch, out, "ran.json")
    said = build_student_edition(src, out)
    assert (out / NAME).read_text() == edition_text(src / NAME, "../")[0] and said[-1].endswith("(1 refreshed)")
    assert not list(out.glob("*.updated*.ipynb"))


def _chapter_with_solution(tmp_path: Path, solution: str) -> Path:
    src = tmp_path / "notebooks"
    src.mkdir()
    nb = json.loads((SAVES / "source.json").read_text())
    next(c for c in nb["cells"] if "solution" in c["metadata"].get("tags", []))["source"] = solution
    (src / NAME).write_text(json.dumps(nb))
    return src


def test_a_solution_cell_with_ipython_magics_is_stubbed(tmp_path):
    solution = "%matplotlib inline\n!true\ndef f(x):\n    '''Twice x.'''\n    return 2 * x\n"
    src = _chapter_with_solution(tmp_path, solution)
    build_student_edition(src, tmp_path / "student")
    cells = json.loads((tmp_path / "student" / NAME).read_text())["cells"]
    stub = "".join(next(c for c in cells if "solution" in c["metadata"].get("tags", []))["source"])
    assert stub.startswith("def f(x):") and "NotImplementedError" in stub and "2 * x" not in stub, stub


@pytest.mark.parametrize(
    "solution, words",
    [("def f(x):\n    return (x\n", "is not Python (line 2"), ("def f(x):\n\x00", "is not Python")],
)
def test_a_solution_cell_that_is_not_python_is_refused(tmp_path, capsys, solution, words):
    src = _chapter_with_solution(tmp_path, solution)
    assert main(["student-edition", "--notebooks", str(src), "--out", str(tmp_path / "student")]) == 2
    err = capsys.readouterr().err
    assert f"{src / NAME}: a solution cell {words}" in err and "Traceback" not in err, err
    assert not (tmp_path / "student" / NAME).exists()


#: ``python -m lab.course`` with a Ctrl-C arriving while it starts: as it imports a module
#: (its commands; NumPy, the slowest, which the edition needs), where a user's Ctrl-C lands.
CTRL_C_AT_START = """
import os, runpy, signal, sys

MODULE = sys.argv[1]

class CtrlC:
    def find_spec(self, name, path=None, target=None):
        if name == MODULE:
            os.kill(os.getpid(), signal.SIGINT)
        return None


sys.meta_path.insert(0, CtrlC())
sys.argv = ["lab.course", *sys.argv[2:]]
runpy.run_module("lab.course", run_name="__main__", alter_sys=True)
"""


@pytest.mark.parametrize("module", ["lab.course.commands", "numpy"])
def test_ctrl_c_while_lab_course_starts_says_so_without_a_traceback(tmp_path, module):
    src, out = _course(tmp_path)
    r = subprocess.run([sys.executable, "-c", CTRL_C_AT_START, module, "student-edition", "--notebooks", str(src),
                        "--out", str(out)], capture_output=True, text=True, timeout=60, env=subprocess_env(),
                       preexec_fn=default_sigint)  # fmt: skip
    assert r.returncode == 130 and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.startswith("interrupted") and len(r.stderr.splitlines()) == 1, r.stderr
    assert not list(out.glob("*.ipynb")), "a notebook was written after the Ctrl-C"


SERVES_SOLUTIONS = [
    ["notebooks", "--no-browser"],
    ["--no-browser", "--LabApp.root_dir=notebooks"],
    ["--ContentsManager.root_dir=notebooks"],
    ["."],
    ["/"],
    ["notebooks/01_fem_simulation.ipynb"],
    ["--ServerApp.file_to_run=notebooks/01_fem_simulation.ipynb"],
    ["{root}/notebooks/"],
]


@pytest.mark.parametrize("args", SERVES_SOLUTIONS, ids=lambda a: " ".join(a))
def test_the_student_command_never_serves_the_solutions(tmp_path, args):
    """Refused before anything runs (no .venv work, no build, no server), from anywhere."""
    cmd = ["bash", str(ROOT / "scripts" / "jupyter"), "--student", *(a.format(root=ROOT) for a in args)]
    for cwd in (ROOT, tmp_path):
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=30, cwd=cwd)
        assert r.returncode == 2, (cwd, r.stderr)
        assert "--student" in r.stderr and ("solutions" in r.stderr or "root_dir" in r.stderr), r.stderr
        assert not list(tmp_path.iterdir())


def test_the_student_command_accepts_other_arguments(tmp_path):
    """Values that name no file or a folder away from notebooks/ reach JupyterLab (here a
    stand-in that prints what it was given, as tests/test_env_bootstrap.py's does)."""
    shutil.copytree(ROOT / "scripts", tmp_path / "scripts")
    (tmp_path / "notebooks").mkdir()
    (tmp_path / "scripts" / "_env.sh").write_text(
        'LAB_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"\nPATH="$LAB_ROOT/bin:$PATH"\n'
    )
    (tmp_path / "bin").mkdir()
    fake = tmp_path / "bin" / "python"
    fake.write_text('#!/bin/sh\n[ "$1 $2" = "-m jupyterlab" ] && shift 2 && echo "JUPYTERLAB $*"\nexit 0\n')
    fake.chmod(0o755)
    os.makedirs(tmp_path / "build" / "student")
    r = subprocess.run(["bash", str(tmp_path / "scripts" / "jupyter"), "--student", "--port", "8899", "build/student",
                        "--ServerApp.ip=127.0.0.1"], capture_output=True, text=True, timeout=30)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert f"--notebook-dir={tmp_path}/build/student" in r.stdout and "--port 8899 build/student" in r.stdout, r.stdout


def test_an_edition_an_older_build_recorded_learns_its_cells(tmp_path):
    """A manifest from before cells were recorded (bytes only) and a notebook JupyterLab
    has saved since: while the chapter is unchanged the cells are recorded, so the next
    course update refreshes the notebook instead of forking it."""
    src, out = _course(tmp_path)
    build_student_edition(src, out)
    manifest = json.loads((out / ed.MANIFEST).read_text())
    del manifest["cells"]
    (out / ed.MANIFEST).write_text(json.dumps(manifest))
    _save(out, "opened.json")
    assert build_student_edition(src, out)[-1].endswith("(1 unchanged)")
    _course(tmp_path, "Doubling, v2")
    said = build_student_edition(src, out)
    assert said[-1].endswith("(1 refreshed)") and not list(out.glob("*.updated*.ipynb")), said


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.timeout(600)
def test_todays_jupyterlab_saves_are_judged_as_the_committed_ones(tmp_path):
    """The committed saves made again by the JupyterLab and Chromium installed now."""
    from test_viz import require_chromium

    require_chromium()
    saves = tmp_path / "saves"
    saves.mkdir()
    r = subprocess.run([sys.executable, str(SAVES / "make_fixtures.py"), str(saves)], capture_output=True, text=True,
                       timeout=540, env={**subprocess_env(), "PYTHONPATH": str(ROOT)})  # fmt: skip
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    for fixture, verdict in [("opened.json", "refreshed"), ("ran.json", "refreshed"), ("edited.json", "kept")]:
        src, out = _course(tmp_path / fixture)
        build_student_edition(src, out)
        (out / NAME).write_text((saves / fixture).read_text())
        _course(tmp_path / fixture, "Doubling, v2")
        said = build_student_edition(src, out)
        assert said[-1].endswith(f"(1 {verdict})"), (fixture, said)
