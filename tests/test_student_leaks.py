"""The student edition gives no answer away.

For every exercise, the reference solution's expressions (each ``return`` value and each
assigned value of the solution's functions, whitespace removed) must appear in no cell of
the student edition: not in a grader, a hint, a later cell or the stub itself. A grader
cell calls its chapter's checker in ``lab.course`` and defines nothing: a reference
written out in a visible cell (``def newton_step_lab(...)``) is the answer.
"""

import ast
import json
import re
from pathlib import Path

import pytest

from lab.course import GRADER_TAG, SOLUTION_TAG
from lab.course.edition import student_edition

ROOT = Path(__file__).resolve().parent.parent
WITH_EXERCISES = [
    nb
    for nb in sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
    if any(SOLUTION_TAG in c.get("metadata", {}).get("tags", []) for c in json.loads(nb.read_text())["cells"])
]
#: shorter expressions (``x``, ``n + 1``, ``q.copy()``) say nothing about the answer
MIN_CHARS = 12
_PLAIN = (ast.Name, ast.Attribute, ast.Load, ast.Constant, ast.keyword, ast.Call)


def _is_api_call(value: ast.AST) -> bool:
    """One call of a library function on plain names (``model.predict_and_jacobian(u)``):
    the chapter's text names the API to use, so this is not an answer."""
    nodes = list(ast.walk(value))
    return all(isinstance(n, _PLAIN) for n in nodes) and sum(isinstance(n, ast.Call) for n in nodes) <= 1


def _squash(text: str) -> str:
    return re.sub(r"\s+", "", text)


def answer_expressions(source: str) -> set[str]:
    """What a solution cell's functions compute: every returned and assigned value
    (``ast.unparse``, whitespace removed) of at least MIN_CHARS characters."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        assigns = isinstance(node, (ast.Return, ast.Assign, ast.AugAssign, ast.AnnAssign))
        value = node.value if assigns else None
        if value is not None and not isinstance(value, ast.Constant) and not _is_api_call(value):
            text = _squash(ast.unparse(value))
            if len(text) >= MIN_CHARS:
                found.add(text)
    return found


def test_answer_expressions_of_a_solution():
    src = (
        "def f(a, b):\n    '''doc'''\n    s = a @ b + 1\n    n = a.shape[0]\n"
        "    m = model.predict_and_jacobian(u)\n    return -solve(H, g) * s\n"
    )
    assert answer_expressions(src) == {"-solve(H,g)*s"}  # 'a@b+1' and 'a.shape[0]' are short


@pytest.mark.parametrize("notebook", WITH_EXERCISES, ids=[nb.name for nb in WITH_EXERCISES])
def test_student_edition_shows_no_answer(notebook, tmp_path):
    source_cells = json.loads(notebook.read_text())["cells"]
    student_edition(notebook, tmp_path / notebook.name, up="../")
    student_cells = json.loads((tmp_path / notebook.name).read_text())["cells"]
    visible = [(k, _squash("".join(c["source"]))) for k, c in enumerate(student_cells)]
    leaks = []
    for k, cell in enumerate(source_cells):
        tags = cell.get("metadata", {}).get("tags", [])
        if SOLUTION_TAG in tags:
            for expr in answer_expressions("".join(cell["source"])):
                leaks += [f"cell {j}: {expr}" for j, text in visible if expr in text]
        if GRADER_TAG in tags:
            tree = ast.parse("".join(cell["source"]))
            defined = [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.Lambda))]
            if defined:
                leaks.append(f"cell {k}: the grader defines a function: a reference in sight")
    assert not leaks, f"{notebook.name} student edition:\n" + "\n".join(leaks)
