"""The course's exercises: graders, the student edition, and both editions of the chapters.

The source notebooks pass every grader (tests/test_notebooks.py checks each grader cell's
output); here the student edition is built and shown to run: each grader must report "not
implemented yet" and the rest of the chapter must still run. The cells of the edition that
can behave differently from the chapter (its stubs, its graders and what depends on them)
run again after the chapter's own run (tests/chapter_run.py, tests/student_replay.py); a
chapter for which that cannot be shown is executed in full from build/student/.
"""

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from helpers import NOTEBOOK_TEST_TIMEOUT_S, execute_notebook, output_text

from lab.course import NOT_IMPLEMENTED, grade, stub_source
from lab.course.edition import student_edition

ROOT = Path(__file__).resolve().parent.parent
WITH_EXERCISES = [
    nb
    for nb in sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
    if any("solution" in c.get("metadata", {}).get("tags", []) for c in json.loads(nb.read_text())["cells"])
]


def test_stub_keeps_signature_and_docstring():
    src = 'def f(a: int, b=2) -> int:\n    """Add.\n\n    Units: none."""\n    return a + b\n'
    stub = stub_source(src)
    assert stub.startswith("def f(a: int, b=2) -> int:") and "Units: none." in stub and "return a + b" not in stub
    assert '"""Add.\n\n    Units: none."""' in stub  # the docstring's blank line stays blank (no whitespace)
    scope = {}
    exec(stub, scope)
    with pytest.raises(NotImplementedError):
        scope["f"](1)


def test_grade_says_what_is_wrong(capsys):
    ref = lambda x: (float(x.sum()), 2 * x)  # noqa: E731
    cases = [(np.arange(3.0),)]
    assert grade("demo", ref, ref, cases) == "exercise 'demo': passed (1 random cases)"
    wrong = grade("demo", lambda x: (float(x.sum()), 2 * x + (x == 2)), ref, cases)
    assert wrong.startswith(
        "exercise 'demo': FAILED on case 1 of 1: entry 3 of the 2nd returned value (result[1][2]) is 5, expected 4"
    ), wrong

    def todo(x):
        raise NotImplementedError

    todo_line = f"exercise 'demo': {NOT_IMPLEMENTED} - write the function above, then run this cell again"
    assert grade("demo", todo, ref, cases) == todo_line
    assert "FAILED on case 1 of 1: ZeroDivisionError" in grade("demo", lambda x: 1 / 0, ref, cases)  # never raises
    short = grade("demo", lambda x: (0.0, x[:2]), lambda x: (0.0, x), cases)
    assert "the 2nd returned value (result[1]) is an array of shape (2,), expected an array of shape (3,)" in short


def test_every_exercise_is_followed_by_its_grader():
    assert WITH_EXERCISES, "no chapter has exercises"
    for nb in WITH_EXERCISES:
        cells = json.loads(nb.read_text())["cells"]
        for k, c in enumerate(cells):
            if "solution" in c.get("metadata", {}).get("tags", []):
                after = next(d for d in cells[k + 1 :] if d["cell_type"] == "code")
                assert "grader" in after.get("metadata", {}).get("tags", []), f"{nb.name}: solution without grader"


@pytest.mark.slow
@pytest.mark.timeout(NOTEBOOK_TEST_TIMEOUT_S)
@pytest.mark.parametrize("notebook", WITH_EXERCISES, ids=[nb.name for nb in WITH_EXERCISES])
def test_student_edition_runs_and_says_not_implemented(notebook, chapter_runs, request, tmp_path):
    student = ROOT / "build" / "student" / notebook.name
    assert student_edition(notebook, student, up="../") >= 1
    run = chapter_runs.get(notebook, request)
    why = full_run_needed(run, student)
    if why:
        print(f"{notebook.name}: the student edition is executed in full: {why}")
        graders = run_in_full(notebook, student, tmp_path)
    else:  # the cells that differ from the chapter's own run, replayed after it (tests/student_replay.py)
        failed = [r for r in run.replay if r["error"]]
        assert not failed, f"{notebook.name}: the student edition fails at its cell {failed[0]['index']}: {failed[0]}"
        graders = [r["text"] for r in run.replay if r["kind"] == "grader"]
    assert graders, f"{notebook.name}: the student edition has no grader"
    for text in graders:
        assert NOT_IMPLEMENTED in text, f"{notebook.name}: a grader of the student edition says {text!r}"


def full_run_needed(run, student: Path) -> str:
    """Why the chapter's run with its replayed cells does not stand for a run of the
    student edition in ``student`` (see tests/student_replay.py); "" when it does."""
    if run.plan.cells is None:
        return run.plan.reason
    if run.error:
        return f"the chapter's own run failed ({run.error.splitlines()[0]})"
    if hashlib.sha256(student.read_bytes()).hexdigest() != run.edition_sha256:
        return "the edition written is not the one the replay was planned for"
    here = [(cell, path) for cell, event, path in run.relative if not path.startswith("../")]
    if here:
        return f"the chapter opened {here[0][1]!r} relative to its working folder (cell {here[0][0]})"
    return ""


def run_in_full(notebook: Path, student: Path, tmp_path: Path) -> list[str]:
    """Execute the whole student edition from its folder; its graders' outputs."""
    out = tmp_path / notebook.name
    execute_notebook(
        student,
        out,
        parameters={"quick": True, "figures_dir": str(tmp_path / "f")},
        cwd=str(student.parent),
        kernel_name="python3",
    )
    return [
        output_text(c)
        for c in json.loads(out.read_text())["cells"]
        if "grader" in c.get("metadata", {}).get("tags", [])
    ]


def test_chapters_01_to_07_pose_two_to_four_exercises():
    # each chapter 01-07 poses 2-4 exercises, each a solution cell and its grader
    for nb in sorted((ROOT / "notebooks").glob("0[1-7]_*.ipynb")):
        cells = json.loads(nb.read_text())["cells"]
        n = sum("solution" in c.get("metadata", {}).get("tags", []) for c in cells)
        graders = sum("grader" in c.get("metadata", {}).get("tags", []) for c in cells)
        assert 2 <= n <= 4 and graders == n, f"{nb.name}: {n} exercises, {graders} graders"


def test_grade_shows_once_as_html_with_the_failing_inputs(tmp_path):
    """In a kernel, a grader cell whose last line is ``grade(...)`` shows one output (HTML,
    plain text as fallback), green for pass and red for fail, the failing case's inputs as
    code; a checker's failure names the call that reruns the case, as the cell wrote it."""
    import nbformat

    code = (
        "import numpy as np\nfrom lab.course import grade\n"
        "ref = lambda x: 2 * x\n"
        "grade('ok', ref, ref, [(np.arange(3.0),)])"
    )
    bad = "grade('bad', lambda x: 2 * x + (x == 2), ref, [(np.arange(5.0),)], hint='twice')"
    said = "from lab.course import say, than\nsay(f'tracks {than(0.45, 0.06)} the paper')"
    checked = (
        "from lab.course.ch12 import check_enclosed_volume\n"
        "def enclosed_volume(x_W, triangles):\n    return 1.0\n"
        "check_enclosed_volume(enclosed_volume)"
    )
    cells = [nbformat.v4.new_code_cell(c) for c in (code, bad, said, checked)]
    nb = nbformat.v4.new_notebook(cells=cells)
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    path = tmp_path / "g.ipynb"
    nbformat.write(nb, path)
    execute_notebook(path, tmp_path / "out.ipynb", kernel_name="python3", cwd=str(tmp_path))
    cells = json.loads((tmp_path / "out.ipynb").read_text())["cells"]
    for cell, colour, words in ((cells[0], "#1a7f37", "passed"), (cells[1], "#cf222e", "FAILED")):
        assert len(cell["outputs"]) == 1, cell["outputs"]  # once: no quoted Out[] copy
        data = cell["outputs"][0]["data"]
        assert words in "".join(data["text/plain"]) and colour in "".join(data["text/html"])
    failed = "".join(cells[1]["outputs"][0]["data"]["text/plain"])
    assert "x = np.array([0.0, 1.0, 2.0, 3.0, 4.0])" in failed and "Hint: twice" in failed, failed
    assert "entry 3 of the result (result[2]) is 5, expected 4" in failed, failed
    # A computed statement (lab.course.say) is shown once too, as Markdown.
    (out,) = cells[2]["outputs"]
    assert "".join(out["data"]["text/markdown"]) == "tracks above the paper", out
    # A checker's failure names the cell's own call with the case to rerun, read from the cell.
    (out,) = cells[3]["outputs"]
    rerun = "To rerun it: check_enclosed_volume(enclosed_volume, case=1)"
    assert rerun in "".join(out["data"]["text/plain"]) and rerun in "".join(out["data"]["text/html"]), out
