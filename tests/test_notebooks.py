"""Execute every notebooks/NN_*.ipynb end to end in quick mode.

Each notebook runs with ``quick=True`` (its reduced-size mode) and a temporary
``figures_dir`` (papermill injects them), in a kernel of the interpreter running pytest,
with notebooks/ as its working directory (``tests/chapter_run.py``: the one run of the
chapter that its nbval check and its student-edition check read too). A cell error fails
the test. A notebook that declares a ``figures_dir`` parameter must write at least one file
there.

One test per notebook, found when the module is collected; no notebooks, no tests.
"""

import re
from pathlib import Path

import pytest
from helpers import NOTEBOOK_TEST_TIMEOUT_S, output_text

from lab.course import NOT_IMPLEMENTED

NOTEBOOKS_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOKS_DIR.glob("[0-9][0-9]_*.ipynb"))


if NOTEBOOKS:

    @pytest.mark.slow
    @pytest.mark.timeout(NOTEBOOK_TEST_TIMEOUT_S)
    @pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[nb.name for nb in NOTEBOOKS])
    def test_notebook_runs(notebook, chapter_runs, request):
        import papermill

        run = chapter_runs.get(notebook, request)
        assert not run.error, f"{notebook.name} fails in quick mode: {run.error}"

        # Every exercise's reference solution passes its grader (lab.course.grade).
        for cell in run.executed.cells:
            if "grader" in cell.get("metadata", {}).get("tags", []):
                text = output_text(cell)
                assert "passed" in text, f"{notebook.name}: a reference solution fails its grader: {text}"

        # Every computed statement (lab.course.say) rendered a sentence from the run's values.
        from lab.course.statements import STATEMENT_KEY

        for cell in run.executed.cells:
            for o in cell.get("outputs", []):
                if o.get("metadata", {}).get(STATEMENT_KEY):
                    text = "".join(o["data"]["text/plain"])
                    assert text.strip() and not re.search(r"[{}]|\bnan\b", text), f"{notebook.name}: statement {text!r}"

        if "figures_dir" in papermill.inspect_notebook(str(notebook)):
            assert run.figures, f"{notebook.name} declares figures_dir but wrote no file into it"


def test_a_chapters_checks_go_to_one_worker(request):
    """Under ``-n`` the three checks of a chapter, which share its one run, are one unit of
    work for xdist (tests/conftest.py); other tests keep their file (or their own) unit."""
    if not request.config.pluginmanager.hasplugin("xdist"):
        pytest.skip("pytest-xdist is not loaded (-p no:xdist)")
    nodeids = [
        "tests/test_notebooks.py::test_notebook_runs[05_sim_to_real.ipynb]",
        "tests/test_nbval.py::test_headline_numbers[05_sim_to_real.ipynb]",
        "tests/test_exercises.py::test_student_edition_runs_and_says_not_implemented[05_sim_to_real.ipynb]",
    ]
    other = "tests/test_reproduce.py::test_x[05_sim_to_real.ipynb]"
    for dist, other_scope in (("loadfile", "tests/test_reproduce.py"), ("load", other)):
        config = type("Config", (), {"getvalue": staticmethod({"dist": dist, "tx": ["popen", "popen"]}.get)})
        sched = request.config.hook.pytest_xdist_make_scheduler(config=config, log=None)
        assert {sched._split_scope(n) for n in nodeids} == {"chapter 05_sim_to_real.ipynb"}
        assert (
            sched._split_scope(nodeids[0].replace("05_sim_to_real", "08_data_efficiency"))
            != "chapter 05_sim_to_real.ipynb"
        )
        assert sched._split_scope(other) == other_scope


def test_the_longest_units_of_work_go_out_first(request):
    """The chapters' shared runs and the site's build are handed to the workers before the
    many short files (xdist's own order, most tests first, left a chapter running alone at
    the end of the suite)."""
    if not request.config.pluginmanager.hasplugin("xdist"):
        pytest.skip("pytest-xdist is not loaded (-p no:xdist)")
    config = type("Config", (), {"getvalue": staticmethod({"dist": "loadfile", "tx": ["popen", "popen"]}.get)})
    sched = request.config.hook.pytest_xdist_make_scheduler(config=config, log=None)
    units = {  # a file of many short tests, two chapters' shared runs, the site's build, one test
        "tests/test_many.py": {f"tests/test_many.py::t[{i}]": False for i in range(50)},
        "chapter 11_any_soft_body.ipynb": {"tests/test_nbval.py::test_headline_numbers[11_any_soft_body.ipynb]": False},
        "tests/test_docs_site.py": {"tests/test_docs_site.py::test_build_gives_no_warning": False},
        "chapter 12_fluidic_arm.ipynb": {"tests/test_nbval.py::test_headline_numbers[12_fluidic_arm.ipynb]": False},
        "tests/test_tiny.py": {"tests/test_tiny.py::t": False},
    }
    sched.workqueue.update(units)
    node = type("Node", (), {"send_runtest_some": lambda self, indexes: None})()
    sched.registered_collections = {node: [n for unit in units.values() for n in unit]}
    while sched.workqueue:
        sched._assign_work_unit(node)
    handed = list(sched.assigned_work[node])  # the units in the order they went out
    # (the chapters' weights come from figures/chapter_times.csv, so only clear orders are asserted)
    assert set(handed[:2]) == {"chapter 12_fluidic_arm.ipynb", "tests/test_docs_site.py"}, handed
    assert handed.index("chapter 11_any_soft_body.ipynb") < handed.index("tests/test_many.py"), handed
    assert handed[-1] == "tests/test_tiny.py"


@pytest.mark.slow
def test_a_chapter_run_keeps_what_each_check_reads(tmp_path):
    """The shared run (tests/chapter_run.py) of a small chapter: the cells' outputs, the
    messages of a checked cell, the figures written, a path opened relative to the working
    folder, the student edition's stub and grader replayed after it; and a failing or
    hanging cell recorded by its id and source, the cells after it not run."""
    import nbformat
    from chapter_run import run_chapter

    def chapter(name, *cells):
        nb = nbformat.v4.new_notebook(
            cells=[nbformat.v4.new_code_cell(src, metadata={"tags": tags}) for src, tags in cells]
        )
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        nbformat.write(nb, tmp_path / name)
        return tmp_path / name

    params = ("quick = False\nfigures_dir = 'figures'", ["parameters"])
    solution = ("def double(x):\n    return 2 * x", ["solution"])
    grader = ("from lab.course import grade\ngrade('double', double, lambda x: 2 * x, [(1.0,)])", ["grader"])
    body = "import os\nos.makedirs(figures_dir, exist_ok=True)\nopen(os.path.join(figures_dir, 'f.txt'), 'w').close()\n"
    body += "open('nbval-sanitize.cfg').close()\nprint('quick', quick)"
    run = run_chapter(chapter("01_ok.ipynb", params, solution, grader, (body, ["nbval-check-output"])), tmp_path / "ok")
    assert not run.error and run.ran == len(run.executed.cells) == 5, run.error  # with papermill's injected cell
    assert "passed" in output_text(run.executed.cells[3]) and run.figures == ["f.txt"]
    assert run.checked == {4: [{"output_type": "stream", "name": "stdout", "text": "quick True\n"}]}
    assert [(e, p) for _, e, p in run.relative] == [("open", "nbval-sanitize.cfg")]
    assert [(r["kind"], NOT_IMPLEMENTED in r["text"], r["error"]) for r in run.replay] == [
        ("stub", False, ""),
        ("grader", True, ""),
    ]

    run = run_chapter(
        chapter("02_bad.ipynb", params, ("raise ValueError('broken')", []), ("x = 1", [])), tmp_path / "bad"
    )
    assert "ValueError: broken" in run.error and run.ran == 2 and run.error.startswith("cell ")
    hang = chapter("03_hang.ipynb", params, ("import time\ntime.sleep(600)", []))
    run = run_chapter(hang, tmp_path / "hang", cell_timeout_s=3)
    assert "time.sleep(600)" in run.error and "timed out" in run.error, run.error
