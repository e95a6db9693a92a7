"""The course's exercises: graders, and the student edition of the notebooks.

A chapter's exercise is a function the student writes in a code cell tagged ``solution``
(the source notebooks hold the reference solution); the next cell, tagged ``grader``,
calls :func:`grade` to check it against ``lab``'s own implementation on random inputs and
prints one line: ``passed``, ``FAILED`` with what was wrong, or ``not implemented yet``.
A grader never raises, so the rest of the chapter runs either way.

:func:`student_edition` turns a notebook into its student edition: every ``solution``
cell keeps only the signatures and docstrings of its functions, each body replaced by
``raise NotImplementedError``. ``scripts/student-edition`` writes them to ``build/student/``.
"""

from __future__ import annotations

import ast
import json
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

__all__ = ["grade", "student_edition", "stub_source", "SOLUTION_TAG", "GRADER_TAG", "NOT_IMPLEMENTED"]

SOLUTION_TAG, GRADER_TAG = "solution", "grader"
NOT_IMPLEMENTED = "not implemented yet"


def _compare(got, want, rtol: float, atol: float) -> str | None:
    """None if ``got`` matches ``want`` (arrays, numbers or tuples of them), else what differs."""
    if isinstance(want, tuple):
        if not isinstance(got, tuple) or len(got) != len(want):
            return f"expected a tuple of {len(want)} values, got {type(got).__name__}"
        for k, (g, w) in enumerate(zip(got, want)):
            if (why := _compare(g, w, rtol, atol)) is not None:
                return f"item {k}: {why}"
        return None
    g, w = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    if g.shape != w.shape:
        return f"shape {g.shape}, expected {w.shape}"
    err = np.abs(g - w)
    tol = atol + rtol * np.abs(w)
    if not np.all(np.isfinite(g)) or np.any(err > tol):
        i = np.unravel_index(int(np.argmax(err - tol)), err.shape) if err.ndim else ()
        return f"at index {tuple(int(k) for k in i)}: {g[i]:.6g} instead of {w[i]:.6g}"
    return None


def grade(
    name: str,
    student: Callable,
    reference: Callable,
    cases: Iterable[tuple],
    *,
    rtol: float = 1e-7,
    atol: float = 1e-10,
    hint: str = "",
) -> str:
    """Check ``student(*args)`` against ``reference(*args)`` for every ``args`` in ``cases``;
    print and return one line: "passed", "FAILED ..." (which case, what differs, ``hint``)
    or "not implemented yet". Never raises."""
    cases = list(cases)
    for k, args in enumerate(cases):
        try:
            got = student(*args)
        except NotImplementedError:
            line = f"exercise '{name}': {NOT_IMPLEMENTED} - write the function above, then run this cell again"
            print(line)
            return line
        except Exception as err:  # noqa: BLE001 - a student's bug is reported, not raised
            line = f"exercise '{name}': FAILED on case {k + 1}: {type(err).__name__}: {err}"
            print(line)
            return line
        why = _compare(got, reference(*args), rtol, atol)
        if why is not None:
            line = f"exercise '{name}': FAILED on case {k + 1}: {why}" + (f". Hint: {hint}" if hint else "")
            print(line)
            return line
    line = f"exercise '{name}': passed ({len(cases)} random cases)"
    print(line)
    return line


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
    stubbed, outputs cleared); returns the number of stubbed cells. ``up`` ("../" per extra
    directory level of ``target`` below the repository compared with ``source``) is put in
    front of the parameters cell's relative paths, so ``"../data/..."`` still finds the data."""
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
