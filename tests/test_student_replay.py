"""The plan that lets a chapter's one run stand for a run of its student edition
(tests/student_replay.py): which cells it replays, and when it gives up."""

import json
from pathlib import Path

import pytest
from student_replay import replay_plan

from lab.course.edition import edition_text

PARAMS = 'quick = False\nfigures_dir = "../build/figures"\ndata_path = "../data/sim.csv"\n'
SOLUTION = "def double(x):\n    return 2 * x\n"
GRADER = "from lab.course import grade\n\ngrade('double', double, lambda x: 2 * x, [(1.0,)])"


def plan_for(tmp_path: Path, *cells):
    """The plan for a chapter of ``cells`` (source, or (source, tag)) in tmp_path/notebooks."""
    nb = {"cells": [], "metadata": {}, "nbformat": 4, "nbformat_minor": 5}
    for k, c in enumerate(cells):
        src, tags = (c, []) if isinstance(c, str) else (c[0], [c[1]])
        nb["cells"].append(
            {
                "cell_type": "code",
                "id": f"c{k}",
                "metadata": {"tags": tags},
                "source": src,
                "outputs": [],
                "execution_count": None,
            }
        )
    path = tmp_path / "notebooks" / "01_x.ipynb"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(nb))
    text, _ = edition_text(path, up="../")
    return replay_plan(path, text, tmp_path / "build" / "student")


def replayed(plan):
    assert plan.cells is not None, plan.reason
    return [(c.index, c.kind) for c in plan.cells]


def test_only_stubs_and_graders_when_nothing_else_uses_the_exercise(tmp_path):
    plan = plan_for(tmp_path, (PARAMS, "parameters"), "y = 3", (SOLUTION, "solution"), (GRADER, "grader"), "print(y)")
    assert replayed(plan) == [(2, "stub"), (3, "grader")]
    assert "raise NotImplementedError" in plan.cells[0].source  # the edition's source, not the solution


def test_cells_that_use_the_exercise_are_replayed_and_what_they_change_too(tmp_path):
    cells = [(SOLUTION, "solution"), (GRADER, "grader"), "z = double(2)", "w = z + 1", "v = 5", "print(w, v)"]
    assert replayed(plan_for(tmp_path, *cells)) == [
        (0, "stub"),
        (1, "grader"),
        (2, "dependent"),
        (3, "dependent"),
        (5, "dependent"),
    ]
    # an object changed by a method, an item or an argument counts as changed
    cells = [(SOLUTION, "solution"), "table = [double(2)]", "table.append(1)", "print(table)", "n = 5", "print(n)"]
    assert replayed(plan_for(tmp_path, *cells)) == [(0, "stub"), (1, "dependent"), (2, "dependent"), (3, "dependent")]
    # a name rebound without the exercise is the same in both editions from there on
    cells = [(SOLUTION, "solution"), "z = double(2)", "z = 7", "print(z)"]
    assert replayed(plan_for(tmp_path, *cells)) == [(0, "stub"), (1, "dependent")]


def test_a_name_changed_later_is_bound_anew_by_replaying_the_cells_that_made_it(tmp_path):
    # the end of the run does not hold a as cell 2 read it: replaying cell 0 first does
    cells = ["a = 1", (SOLUTION, "solution"), "print(double(a))", "a = 2"]
    assert replayed(plan_for(tmp_path, *cells)) == [(0, "rebind"), (1, "stub"), (2, "dependent")]
    # a cell that changes what it reads (replayed alone, it would change it twice)
    cells = ["acc = []", (SOLUTION, "solution"), "acc.append(double(1))"]
    assert replayed(plan_for(tmp_path, *cells)) == [(0, "rebind"), (1, "stub"), (2, "dependent")]
    # and what the rebound cell reads, transitively (cell 4 reads rng after cell 3 drew from it)
    cells = ["n = 3", "rng = make(n)", (SOLUTION, "solution"), "print(double(rng.random()))", "rng.random()", "n = 4"]
    assert replayed(plan_for(tmp_path, *cells)) == [
        (0, "rebind"),
        (1, "rebind"),
        (2, "stub"),
        (3, "dependent"),
        (4, "dependent"),
    ]


def test_what_cannot_change_and_what_a_cell_binds_before_reading_it_need_no_rebinding(tmp_path):
    # a string passed to functions cannot be changed by them
    join = "import os\nprint(double(1), os.path.join(figures_dir, 'x'))"
    cells = [(PARAMS, "parameters"), (SOLUTION, "solution"), join, "import os\nos.makedirs(figures_dir)"]
    assert replayed(plan_for(tmp_path, *cells)) == [(1, "stub"), (2, "dependent")]
    # names a cell binds before each use: in a loop's body, as a loop's variable, in both
    # branches of a try
    loop = "for t in (1, 2):\n    n = double(t)\n    print(n)"
    tried = "try:\n    v = double(1)\nexcept NotImplementedError:\n    v = 2\nprint(v)"
    cells = [(SOLUTION, "solution"), loop, tried, "n, t = [0], [1]\nn.append(t)\nv = [3]"]
    assert replayed(plan_for(tmp_path, *cells)) == [(0, "stub"), (1, "dependent"), (2, "dependent")]
    # a handler that raises binds nothing after the try; one that may not run binds nothing
    raised = "try:\n    v = double(1)\nexcept NotImplementedError:\n    raise\nprint(v)"
    assert replayed(plan_for(tmp_path, (SOLUTION, "solution"), raised, "v = [3]")) == [(0, "stub"), (1, "dependent")]
    maybe = "if double is None:\n    v = 1\nprint(v)"
    assert plan_for(tmp_path, "v = 0", (SOLUTION, "solution"), maybe, "v = [3]").cells is not None
    assert replayed(plan_for(tmp_path, "v = 0", (SOLUTION, "solution"), maybe, "v = [3]"))[0] == (0, "rebind")


@pytest.mark.parametrize(
    ("cells", "reason"),
    [
        # a replayed cell reads a name the chapter changes after it (or that it changes itself),
        # and no cell binds the name for certain before it: a loop's variable ...
        (["for a in (1, 2):\n    pass", (SOLUTION, "solution"), "print(double(a))", "a = 2"], "reads a, which"),
        # ... or only the parameters cell, which the edition changes
        ([("quick = False\nacc = []\n", "parameters"), (SOLUTION, "solution"), "acc.append(double(1))"], "reads acc"),
        # the stub would lose what the solution cell defines besides its functions
        ([("K = 2\n" + SOLUTION, "solution")], "more than function definitions"),
        # paths relative to the working folder: the edition runs from build/student/
        ([(SOLUTION, "solution"), "open('../data/sim.csv')"], "relative to the working folder"),
        ([(SOLUTION, "solution"), "import os\nos.chdir('/tmp')"], "chdir"),
        # names the analysis cannot follow
        ([(SOLUTION, "solution"), "globals()['double'](1)"], "globals"),
        ([(SOLUTION, "solution"), "%time double(1)"], "IPython syntax"),
        ([("quick = False\nn = len('abc')\n", "parameters"), (SOLUTION, "solution")], ""),
        ([(SOLUTION, "solution"), "len = 3"], "rebinds the builtin len"),
    ],
)
def test_the_plan_gives_up_when_the_replay_could_differ_from_the_edition(tmp_path, cells, reason):
    plan = plan_for(tmp_path, *cells)
    if not reason:  # a parameters cell without paths is the same in both editions
        assert plan.cells is not None, plan.reason
        return
    assert plan.cells is None and reason in plan.reason, plan.reason


def test_parameters_must_name_the_same_files_from_build_student(tmp_path):
    assert plan_for(tmp_path, (PARAMS, "parameters"), (SOLUTION, "solution")).cells is not None
    # an absolute path and a name are the same in both editions
    same = 'p = "/data/x.csv"\nrobot = "three-cable"\n'
    assert plan_for(tmp_path, (same, "parameters"), (SOLUTION, "solution")).cells is not None
    # a file beside the chapter, which the edition does not move: build/student/ has none
    (tmp_path / "notebooks" / "x.csv").write_text("1\n")
    plan = plan_for(tmp_path, ('q = "x.csv"\n', "parameters"), (SOLUTION, "solution"))
    assert plan.cells is None and "parameter q names another file" in plan.reason, plan.reason
