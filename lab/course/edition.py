"""The student edition of a chapter: the same notebook with the exercises' solutions removed.

A chapter's exercise is a function the student writes in a code cell tagged ``solution``
(the source notebooks hold the reference solution). :func:`student_edition` keeps only
the signatures and docstrings of those functions, each body replaced by
``raise NotImplementedError``, and clears every output, so the graders say "not
implemented yet" until the student has written the function. ``scripts/student-edition``
and ``scripts/jupyter --student`` write the edition to ``build/student/``.
"""

from __future__ import annotations

import ast
import json
from pathlib import Path

__all__ = ["student_edition", "stub_source", "SOLUTION_TAG", "GRADER_TAG"]

SOLUTION_TAG, GRADER_TAG = "solution", "grader"


def stub_source(source: str) -> str:
    """The student's version of a solution cell: each top-level function keeps its
    signature and docstring, its body becomes ``raise NotImplementedError``."""
    tree = ast.parse(source)
    lines = source.splitlines()
    out = []
    for node in tree.body:
        if not isinstance(node, ast.FunctionDef):
            continue
        start = min([node.lineno, *(d.lineno for d in node.decorator_list)])
        head = "\n".join(lines[start - 1 : node.body[0].lineno - 1])  # decorators and signature
        doc = ast.get_docstring(node)
        doc = doc.replace("\n", "\n    ") if doc else doc
        body = ([f'    """{doc}"""'] if doc else []) + [f'    raise NotImplementedError("exercise: write {node.name}")']
        out.append(head + "\n" + "\n".join(body))
    return "\n\n\n".join(out) + "\n"


def student_edition(source: str | Path, target: str | Path, up: str = "") -> int:
    """Write the student edition of notebook ``source`` to ``target`` (solution cells
    stubbed, outputs cleared).

    Parameters
    ----------
    source, target : notebook paths (``.ipynb``).
    up : "../" per extra directory level of ``target`` below the repository compared with
        ``source``; put in front of the parameters cell's relative paths, so ``"../data/..."``
        still finds the data.

    Returns
    -------
    The number of stubbed (solution) cells.
    """
    nb = json.loads(Path(source).read_text())
    n = 0
    for cell in nb["cells"]:
        if cell["cell_type"] != "code":
            continue
        cell["outputs"], cell["execution_count"] = [], None
        if up and "parameters" in cell.get("metadata", {}).get("tags", []):
            text = "".join(cell["source"]).replace('"../', f'"{up}../')
            cell["source"] = text.splitlines(keepends=True)
        if SOLUTION_TAG in cell.get("metadata", {}).get("tags", []):
            cell["source"] = stub_source("".join(cell["source"])).splitlines(keepends=True)
            n += 1
    Path(target).parent.mkdir(parents=True, exist_ok=True)
    Path(target).write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n")
    return n
